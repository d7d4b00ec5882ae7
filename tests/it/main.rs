//! Cross-crate integration tests for irr: one binary, a module per subject.

mod bad_input;
mod fuzz;
mod geometry;
mod hostile;
mod render;
mod sampling;
mod signals;
