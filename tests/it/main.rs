//! Cross-crate integration tests for irr: one binary, a module per subject.

mod bad_input;
mod cache;
mod cutouts;
mod extreme_scenes;
mod extremes;
mod fuzz;
mod geometry;
mod glass;
mod hostile;
mod ic;
mod khronos;
mod lights;
mod normal_maps;
mod render;
mod sampling;
mod signals;
mod support;
mod textures;
mod walkthrough;
