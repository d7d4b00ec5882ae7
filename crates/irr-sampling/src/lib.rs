//! Deterministic sampling for irr: a counter-based random source, the warps from the unit square
//! to directions and points (each in a three: sample, pdf, invert), a continuous orthonormal basis,
//! and the M×N stratified hemisphere layout that the irradiance cache's final gather and its
//! gradient estimator share.
//!
//! # What it owns
//! - [`rng`]: `uniform(key, dimension)`, a value that depends only on (seed, stream, sample index,
//!   dimension): never on the thread, the order of calls or anything that happened before.
//! - [`sobol`]: the shuffled, Owen-scrambled 2D Sobol sequence (Burley 2020) that a pixel's
//!   key ([`SampleKey::pixel`]) draws its dimensions from: still a function of (seed, pixel,
//!   sample index, dimension) alone, and stratified in every dimension pair.
//! - [`warp`]: `sample_cosine_hemisphere(u)`, `cosine_hemisphere_pdf(cos_theta)`,
//!   `invert_cosine_hemisphere(w)`, and the same for the uniform sphere and the uniform triangle.
//! - [`Frame`]: an orthonormal basis around a normal (Duff et al. 2017), continuous and robust.
//! - [`correlated_multi_jitter`]: Kensler's stratified pixel pattern for any sample count,
//!   sample by sample (the film's sample positions).
//! - [`HemisphereStrata`]: the M×N stratification in (θ, φ) with one cosine-distributed direction
//!   per cell, and the cell bounds that the gradient estimator needs.
//!
//! # What it must not know
//! Rays, scenes, records. **Sampling functions take `u` (a point of the unit square), never an RNG**:
//! the caller decides where `u` comes from.
//!
//! # Example
//! ```
//! use irr_sampling::{Frame, HemisphereStrata, SampleKey};
//! use glam::Vec3;
//!
//! let normal = Vec3::new(0.0, 1.0, 0.0);
//! let frame = Frame::from_normal(normal);
//! let strata = HemisphereStrata::new(4, 16).unwrap();
//! let key = SampleKey::new(7, 42, 0); // seed, stream (e.g. a record id), sample index
//! let mut sum = 0.0;
//! for cell in strata.cells() {
//!     // Two dimensions per cell, numbered by the cell's index so the order of the loop is irrelevant.
//!     let u = key.uniform_2d(2 * cell.index(&strata));
//!     let wi = frame.to_world(strata.sample(cell, u));
//!     assert!(wi.dot(normal) >= 0.0);
//!     sum += 1.0;
//! }
//! assert_eq!(sum, 64.0);
//! ```

pub mod cmj;
mod frame;
pub mod rng;
pub mod sobol;
mod strata;
pub mod warp;

pub use cmj::{Cmj, correlated_multi_jitter};
pub use frame::Frame;
pub use rng::{PixelKeys, SampleKey};
pub use strata::{Cell, HemisphereStrata, StrataError};
pub use warp::{
    cosine_hemisphere_pdf, invert_cosine_hemisphere, invert_uniform_sphere,
    invert_uniform_triangle, sample_cosine_hemisphere, sample_uniform_sphere,
    sample_uniform_triangle, uniform_sphere_pdf, uniform_triangle_pdf,
};
