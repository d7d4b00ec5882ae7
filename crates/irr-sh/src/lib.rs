//! Real spherical harmonics (SH) and hemispherical harmonics (HSH): evaluation, projection of a
//! gather, reconstruction, and rotation, exact and fast, the basis of radiance caching
//! (Křivánek, Gautron, Pattanaik & Bouatouch 2005, "Radiance Caching for Efficient Global
//! Illumination Computation", TVCG 11(5); Křivánek et al. 2006, "Making Radiance and Irradiance
//! Caching Practical: Adaptive Caching and Neighbor Clamping", EGSR).
//!
//! # What it owns
//! - [`Basis`]: SH over the sphere or HSH over the upper hemisphere ([`Domain`]), of order n
//!   (bands 0..n, n² functions, coefficient (l, m) at [`index`]`(l, m)` = l² + l + m),
//!   orthonormal, evaluated for a direction ([`Basis::eval`], [`Basis::eval_f64`],
//!   [`Basis::eval_vec`]) and summed against coefficients ([`Basis::reconstruct`]). The
//!   conventions and formulas are in [`basis`].
//! - [`Projection`] and [`project()`]: coefficients cᵢ = Σₛ wₛ Lₛ Bᵢ(ωₛ) of weighted samples, for
//!   any [`Coefficient`] (f32, f64, `Vec3` RGB, `DVec3`).
//! - [`ShRotation`]: the exact rotation of SH coefficients by Ivanic & Ruedenberg's recurrence
//!   ([`rotation`]).
//! - [`ZyzRotation`]: the same rotation through z-y-z Euler angles and two fixed quarter turns
//!   about x, 8× cheaper per rotation at order 10 ([`zyz`]).
//! - [`FastRotation`]: Křivánek et al. 2006's approximation (Euler z-y-z, the y rotation by a
//!   first- or second-order Taylor polynomial), with its exact error norm and a measured table
//!   ([`fast`]).
//! - [`HemisphereConversion`]: HSH ↔ SH matrices, to rotate HSH through SH as Gautron et al.
//!   2004 do, with their measured error ([`hemisphere`]).
//!
//! # What it must not know
//! Rays, scenes, records, materials, BRDFs, and irr's other crates: it takes directions in
//! some local frame and plain values. Which frame, and what the values mean, is the caller's.
//!
//! # Conventions and precision
//! - Directions are `glam` vectors (`Vec3` or `DVec3`), z up: θ is measured from +z, φ from +x
//!   towards +y. They need not be unit (each is normalised in f64); a zero or non-finite one
//!   is an [`ShError::InvalidDirection`]. An HSH basis evaluates z < 0 as the horizon.
//! - Real SH **without** the Condon–Shortley phase: Y_1^{−1}, Y_1^0, Y_1^1 are √(3/(4π)) times
//!   y, z, x.
//! - Everything is computed in f64. Basis values come out in f32 or f64; coefficients keep
//!   their own type (f32 or `Vec3` for what a record stores).
//! - Orders run from 1 to [`MAX_ORDER`] = 32. The recurrences are stable far beyond; the cap
//!   bounds the work and memory (an exact rotation of order 32 holds 44 000 f64 entries) and is
//!   what the tests cover. Other orders are an [`ShError`], never a panic.
//! - A rotation R maps the coefficients of f to those of f∘Rᵀ (a lobe along d moves to R d).
//!   To carry a record's coefficients, expressed in its local frame F_r (a matrix whose
//!   columns are the frame's axes in world space), into a query's frame F_q, rotate by
//!   R = F_qᵀ F_r: a direction with local coordinates ω in F_r has F_qᵀ F_r ω in F_q.
//!
//! # Projecting a cosine-stratified hemisphere gather
//! irr's gather (irr-sampling's `HemisphereStrata`) draws one cosine-distributed direction in
//! each of M×N cells; every cell has the same projected solid angle π/(MN). Within a cell the
//! direction's density over solid angle is cos θ · MN/π, so a sample at polar angle θ stands
//! for the solid angle **wₛ = π/(MN cos θₛ)**, and
//!
//! cᵢ ≈ Σₛ π/(MN cos θₛ) · Lₛ · Bᵢ(ωₛ)
//!
//! is an unbiased estimate of the radiance's coefficients ∫ L Bᵢ dω. **Grazing caveat:** the
//! weight grows without bound towards the horizon. In the last ring of cells cos²θ is uniform
//! on (0, 1/M], so E[1/cos²θ] diverges there: every coefficient whose basis function does not
//! vanish on the horizon (all SH; HSH with m = 0, c₀₀ among them) is estimated with *infinite
//! variance*. It still converges, slowly and with outliers.
//!
//! The alternative is to project the **cosine-weighted radiance** L·cos θ with the uniform
//! weight **wₛ = π/(MN)**:
//!
//! cᵢ' ≈ Σₛ π/(MN) · Lₛ · Bᵢ(ωₛ), an unbiased estimate of ∫ L cos θ Bᵢ dω,
//!
//! with bounded weights and the variance of irr's own irradiance estimate. The irradiance is
//! then E = ∫ L cos θ dω = c₀' √(2π) with HSH (H_0^0 = 1/√(2π)), or c₀' √(4π) with SH. (Weighting
//! radiance by each cell's solid angle instead bounds the weights too, but the samples are not
//! uniform within a cell: biased.)
//!
//! Measured on a smooth radiance field in HSH of order 3, over 2000 jittered 8×25 gathers
//! (relative to each estimate's true coefficients; the [`project`](mod@project) module's tests):
//!
//! | weights | projects | bias | RMS error |
//! |---|---|---|---|
//! | π/(MN cos θ) | L | 3.4e-3 (noise) | 2.5e-1 |
//! | π/(MN) | L cos θ | 3.4e-4 (noise) | 2.8e-2 |
//! | cell's solid angle | L | 1.5e-1 | 1.6e-1 |
//!
//! **Which to store depends on the normal the cosine belongs to.** The cosine-weighted
//! coefficients carry the *record's* cosine. Rotated into the frame of a query whose normal is
//! tilted (module [`hemisphere`]), they still weight by it, where the query needs its own. On
//! the same field, the irradiance at a query tilted by 5°, 10°, 20° is off by 1.1 %, 2.2 %,
//! 4.0 % from rotated cosine-weighted coefficients (1.4 %, 3.0 %, 7.0 % without any rotation),
//! and by 0.05 %, 0.11 %, 0.22 % from rotated radiance coefficients with the
//! [`Extension::Mirror`] conversion (−0.07 %, −0.37 %, −1.7 % with [`Extension::Zero`]).
//!
//! So this crate's recommendation for radiance caching, where records are rotated to queries
//! with other normals and the query's cosine-weighted BRDF multiplies them (Křivánek et al.
//! 2005), is to **project radiance with the 1/cos θ weights and rotate with the mirror
//! extension**, and to treat the grazing ring's noise as the known cost (at the record itself
//! it cancels in E: projected onto cos θ, which HSH of order ≥ 2 hold exactly, the 1/cos θ
//! weights give back irr's π/(MN) Σ L). The cosine-weighted form is the better choice where
//! the cosine is the record's own: irradiance, or queries that share the record's normal; it
//! pairs with [`Extension::Zero`], since L cos θ vanishes on the horizon (module
//! [`hemisphere`]'s table).
//!
//! # Example
//! ```
//! use glam::{Mat3, Vec3};
//! use irr_sh::{Basis, Projection, ShRotation};
//!
//! // Project a radiance field onto HSH of order 3 from a 16×16 midpoint gather in (cos θ, φ):
//! // each sample stands for the solid angle (1/16)·(2π/16).
//! let basis = Basis::hsh(3)?;
//! let mut projection = Projection::<Vec3>::new(basis);
//! let (rows, columns) = (16, 16);
//! for j in 0..rows {
//!     for k in 0..columns {
//!         let z = (j as f32 + 0.5) / rows as f32;
//!         let phi = std::f32::consts::TAU * (k as f32 + 0.5) / columns as f32;
//!         let s = (1.0 - z * z).sqrt();
//!         let direction = Vec3::new(s * phi.cos(), s * phi.sin(), z);
//!         let radiance = Vec3::new(1.0, 0.5, 0.25) * z; // brighter overhead
//!         let weight = std::f64::consts::TAU / f64::from(rows * columns);
//!         projection.add(direction, weight, radiance)?;
//!     }
//! }
//! let coefficients = projection.coefficients();
//! let overhead = basis.reconstruct(coefficients, Vec3::Z)?;
//! assert!((overhead - Vec3::new(1.0, 0.5, 0.25)).abs().max_element() < 1e-2);
//!
//! // Rotate SH coefficients: a lobe along +z turned a quarter turn about x points along −y.
//! let sh = Basis::sh(4)?;
//! let lobe: Vec<f32> = sh.eval_vec(Vec3::Z)?;
//! let rotation = ShRotation::new(4, Mat3::from_rotation_x(std::f32::consts::FRAC_PI_2))?;
//! let turned = rotation.rotate(&lobe)?;
//! let along_minus_y: Vec<f32> = sh.eval_vec(-Vec3::Y)?;
//! assert!(turned.iter().zip(&along_minus_y).all(|(a, b)| (a - b).abs() < 1e-5));
//! # Ok::<(), irr_sh::ShError>(())
//! ```

pub mod basis;
mod error;
pub mod fast;
pub mod hemisphere;
mod legendre;
pub mod project;
pub mod rotation;
mod value;
pub mod zyz;

pub use basis::{Basis, Domain, index};
pub use error::ShError;
pub use fast::{FastRotation, Taylor, ZyzAngles};
pub use hemisphere::{Extension, HemisphereConversion};
pub use project::{Projection, project};
pub use rotation::{ROTATION_TOLERANCE, ShRotation};
pub use value::Coefficient;
pub use zyz::ZyzRotation;

/// The largest supported order n (bands 0..n): 32, 1024 coefficients.
pub const MAX_ORDER: usize = 32;

#[cfg(test)]
mod testutil;
