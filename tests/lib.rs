//! irr's cross-crate integration tests live in `it/` (one test binary, `it/main.rs`, with a
//! module per subject, so linking stays fast). This library is empty on purpose: the package
//! exists to hold those tests and their dev-dependencies.
