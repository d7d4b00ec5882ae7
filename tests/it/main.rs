//! Cross-crate integration tests for irr: one binary, a module per subject.

mod geometry;
mod sampling;
