//! Irradiance gradients for the irradiance cache, from one stratified hemisphere gather given as
//! plain data: the rotation gradient ∇ᵣE (Ward & Heckbert 1992), the translation gradient ∇ₜE
//! (Ward & Heckbert 1992, Křivánek et al. 2005 in the form of Křivánek & Gautron 2009, or the
//! occlusion-aware triangle fan of Schwarzhaupt et al. 2012), the irradiance Hessian, the
//! distance statistics that size a record (harmonic mean and minimum hit distance) and the
//! gradient-based limit on the radius (R ≤ E/‖∇ₜE‖, Křivánek et al. 2006).
//!
//! # What it owns
//! - [`GatherSamples`]: per cell of an `irr_sampling::HemisphereStrata`, the radiance Lⱼₖ and the
//!   hit distance rⱼₖ (`f32::INFINITY` for a miss), checked on construction ([`GatherError`]);
//!   its irradiance estimate and distance statistics.
//! - The estimators, [`GatherSamples::rotation_gradient`] and
//!   [`GatherSamples::translation_gradient`] (variant chosen by [`TranslationGradient`]), and
//!   [`Gradients`], which holds E, ∇ᵣE and ∇ₜE, turns them to world coordinates, extrapolates to
//!   first order and gives the radius limit. The formulas and their derivation are in the
//!   `gradient` module's source, next to the code.
//! - A gather's own noise ([`GatherSamples::irradiance_variance`],
//!   [`GatherSamples::relative_error`]): the variance of E from the differences of neighbouring
//!   cells, with no ray more (the `noise` module's source derives it).
//! - Super-sampled gathers: [`CellSamples`] (a cell's samples, accumulated),
//!   [`GatherSamples::from_cells`] (their means and nearest hits, the form every estimator
//!   reads) and [`plan_extra_samples`] (which cells get more samples to meet a noise target,
//!   chosen without reading a cell's own value; the `cells` module's source derives both).
//! - The triangle fan over the gather's hit points ([`GatherSamples::fan`], the `hessian`
//!   module): the occlusion-aware translation gradient ([`TranslationGradient::OcclusionFan`])
//!   and the relative irradiance Hessian with its tangent-plane eigen-decomposition
//!   ([`Curvature`]), the inputs of anisotropic records (Schwarzhaupt, Jensen & Jarosz 2012;
//!   Radiance ≥ 4.2), summed from per-edge integrals whose closed forms the module's source
//!   derives.
//! - [`GatherValue`]: the value type (f32, RGB `Vec3`, …), this crate's own, generic.
//!
//! Gradients are computed in the **local frame** of the gather (normal = +z, the frame in which
//! `HemisphereStrata::sample` places the cells); [`Gradients::in_world`] rotates them with the
//! same `irr_sampling::Frame` that turned the sample directions to world space.
//!
//! # What it must not know
//! Rays, scenes, records and the cache: the caller traces the rays and hands over the numbers;
//! irr-cache stores the result (irr-gather-record pairs the two crates' value traits and makes
//! the record).
//! It depends on irr-sampling only for the stratification's layout.
//!
//! # Example
//! ```
//! use glam::Vec3;
//! use irr_gradients::{GatherSamples, TranslationGradient};
//! use irr_sampling::{Frame, HemisphereStrata};
//! use std::f32::consts::PI;
//!
//! let strata = HemisphereStrata::new(8, 24)?;
//! // A uniform sky of radiance 1 (every ray misses): E = π and no gradient at all.
//! let sky = GatherSamples::from_fn(strata, |_| (Vec3::ONE, f32::INFINITY))?;
//! let g = sky.gradients(TranslationGradient::WardHeckbert);
//! assert!((g.irradiance - Vec3::splat(PI)).abs().max_element() < 1e-5);
//! assert!(g.translation.iter().all(|&v| v == Vec3::ZERO));
//!
//! // A bright dome at distance 1 over the +x half of the hemisphere (the cells whose middle
//! // azimuth has cos φ > 0), darkness elsewhere: moving towards +x, the dome's edges fall
//! // behind and the bright part grows, so E increases along +x.
//! let half = GatherSamples::from_fn(strata, |cell| {
//!     let phi = (cell.k as f32 + 0.5) / 24.0 * 2.0 * PI;
//!     if phi.cos() > 0.0 { (Vec3::ONE, 1.0) } else { (Vec3::ZERO, f32::INFINITY) }
//! })?;
//! let g = half.gradients(TranslationGradient::WardHeckbert);
//! assert!(g.translation[0].x > 0.0 && g.translation[1].x.abs() < 1e-5);
//! // In world space, for a gather whose normal was +y: the dome's walls are all azimuthal, so
//! // nothing moves along the normal.
//! let world = g.in_world(&Frame::from_normal(Vec3::Y));
//! assert!(world.translation[1].x.abs() < 1e-5);
//! assert!(g.radius_limit(Vec3::Z).is_finite());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod cells;
mod gradient;
mod hessian;
mod noise;
mod samples;
mod value;

#[cfg(test)]
mod analytic;
#[cfg(test)]
mod cell_aligned;
#[cfg(test)]
mod hessian_tests;
#[cfg(test)]
mod known_answers;
#[cfg(test)]
mod scene_tests;

pub use cells::{CellSamples, plan_extra_samples};
pub use gradient::{Gradients, TranslationGradient, directional, rotate_to_world};
pub use hessian::{Curvature, Fan};
pub use samples::{GatherError, GatherSamples};
pub use value::GatherValue;
