//! Cross-crate integration tests for irr: one binary, a module per subject.

mod bad_input;
mod cache;
mod extremes;
mod geometry;
mod ic;
mod render;
mod sampling;
