//! Warps from the unit square to directions and points, each in a three: `sample_*(u)`, `*_pdf`,
//! `invert_*` (as pbrt-v4's `util/sampling.h` and Mitsuba 3's `warp.h`).
//!
//! Directions are in a local frame with the normal along +z (see [`crate::Frame`]).

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, TAU};

/// Cosine-weighted direction on the +z hemisphere.
///
/// Uses the polar map sin²θ = u.x, φ = 2π·u.y (Malley's method without the disk). Unlike the
/// concentric map, it sends the rectangle [a, b) × [c, d) of the square to the spherical cell
/// θ ∈ [asin √a, asin √b), φ ∈ [2πc, 2πd): that is what lets the M×N stratification of
/// [`crate::HemisphereStrata`] state its cells' bounds in θ and φ, as the gradient estimators of
/// Ward & Heckbert (1992) and Křivánek et al. (2005) require.
#[inline]
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let sin_theta = u.x.sqrt();
    // Compute cos θ as √(1 − u.x) rather than √(1 − sin²θ) to keep the precision near the pole.
    let cos_theta = (1.0 - u.x).max(0.0).sqrt();
    let (sin_phi, cos_phi) = (TAU * u.y).sin_cos();
    Vec3::new(sin_theta * cos_phi, sin_theta * sin_phi, cos_theta)
}

/// The density of [`sample_cosine_hemisphere`] per unit solid angle: cos θ / π (zero below the
/// horizon).
#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * FRAC_1_PI
}

/// The `u` that [`sample_cosine_hemisphere`] maps to `w` (a unit vector with w.z ≥ 0).
#[inline]
pub fn invert_cosine_hemisphere(w: Vec3) -> Vec2 {
    let sin2_theta = (w.x * w.x + w.y * w.y).clamp(0.0, 1.0);
    Vec2::new(sin2_theta, phi_fraction(w))
}

/// Uniform direction on the unit sphere: z = 1 − 2u.x, φ = 2π·u.y.
#[inline]
pub fn sample_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin_phi, cos_phi) = (TAU * u.y).sin_cos();
    Vec3::new(r * cos_phi, r * sin_phi, z)
}

/// The density of [`sample_uniform_sphere`] per unit solid angle: 1 / 4π.
#[inline]
pub fn uniform_sphere_pdf() -> f32 {
    0.25 * FRAC_1_PI
}

/// The `u` that [`sample_uniform_sphere`] maps to the unit vector `w`.
#[inline]
pub fn invert_uniform_sphere(w: Vec3) -> Vec2 {
    Vec2::new(((1.0 - w.z) * 0.5).clamp(0.0, 1.0), phi_fraction(w))
}

/// Uniform point on a triangle, as barycentric coordinates (b0, b1, b2) of its vertices:
/// b0 = 1 − √u.x, b1 = u.y·√u.x (Osada et al. 2002, "Shape distributions", eq. 1).
#[inline]
pub fn sample_uniform_triangle(u: Vec2) -> [f32; 3] {
    let su = u.x.sqrt();
    let b0 = 1.0 - su;
    let b1 = u.y * su;
    [b0, b1, (1.0 - b0 - b1).max(0.0)]
}

/// The density of [`sample_uniform_triangle`] per unit area: 1 / area.
#[inline]
pub fn uniform_triangle_pdf(area: f32) -> f32 {
    1.0 / area
}

/// The `u` that [`sample_uniform_triangle`] maps to the barycentric coordinates `b`.
#[inline]
pub fn invert_uniform_triangle(b: [f32; 3]) -> Vec2 {
    let su = (1.0 - b[0]).clamp(0.0, 1.0);
    let v = if su > 0.0 {
        (b[1] / su).clamp(0.0, 1.0)
    } else {
        0.0
    };
    Vec2::new(su * su, v)
}

/// φ / 2π in [0, 1) for a direction (0 on the +x axis, increasing towards +y).
#[inline]
fn phi_fraction(w: Vec3) -> f32 {
    let phi = w.y.atan2(w.x);
    let f = if phi < 0.0 {
        (phi + TAU) / TAU
    } else {
        phi / TAU
    };
    // atan2 of −0.0 or rounding of (φ + 2π)/2π can give exactly 1.0: wrap it into [0, 1).
    if f >= 1.0 { 0.0 } else { f }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn u2() -> impl Strategy<Value = Vec2> {
        (0.0f32..1.0, 0.0f32..1.0).prop_map(|(a, b)| Vec2::new(a, b))
    }

    /// Wraparound distance in the φ coordinate (u.y = 0 and u.y = 1 are the same direction).
    fn phi_distance(a: f32, b: f32) -> f32 {
        let d = (a - b).abs();
        d.min(1.0 - d)
    }

    proptest! {
        /// Round trip through sin/cos/atan2/sqrt: each step is accurate to a few ulps of values of
        /// size ≤ 1, so the recovered u is off by at most ~1e-6; φ loses precision where sin θ is
        /// tiny (atan2 of two numbers of size ~√u.x), so we compare it only where u.x > 1e-4, and
        /// there the error is ≲ ulp(1)/√u.x ≈ 1.2e-5.
        #[test]
        fn cosine_hemisphere_round_trip(u in u2()) {
            let w = sample_cosine_hemisphere(u);
            prop_assert!((w.length() - 1.0).abs() < 1e-5);
            prop_assert!(w.z >= 0.0);
            let back = invert_cosine_hemisphere(w);
            prop_assert!((back.x - u.x).abs() < 2e-6, "{u} -> {back}");
            if u.x > 1e-4 {
                prop_assert!(phi_distance(back.y, u.y) < 5e-5, "{u} -> {back}");
            }
        }

        #[test]
        fn uniform_sphere_round_trip(u in u2()) {
            let w = sample_uniform_sphere(u);
            prop_assert!((w.length() - 1.0).abs() < 1e-5);
            let back = invert_uniform_sphere(w);
            prop_assert!((back.x - u.x).abs() < 2e-6);
            if u.x > 1e-4 && u.x < 1.0 - 1e-4 {
                prop_assert!(phi_distance(back.y, u.y) < 5e-5, "{u} -> {back}");
            }
        }

        /// b1 = u.y·√u.x is recovered as b1/√u.x: the error grows as 1/√u.x, so compare u.y only
        /// where u.x > 1e-4 (error ≲ ulp/1e-2 ≈ 1.2e-5).
        #[test]
        fn uniform_triangle_round_trip(u in u2()) {
            let b = sample_uniform_triangle(u);
            prop_assert!(b.iter().all(|&x| (0.0..=1.0).contains(&x)));
            prop_assert!((b[0] + b[1] + b[2] - 1.0).abs() < 1e-6);
            let back = invert_uniform_triangle(b);
            prop_assert!((back.x - u.x).abs() < 2e-6);
            if u.x > 1e-4 {
                prop_assert!((back.y - u.y).abs() < 5e-5, "{u} -> {back}");
            }
        }
    }

    #[test]
    fn pdfs_integrate_to_one() {
        // ∫ cos θ/π dω over the hemisphere = 1, by the midpoint rule in (cos θ, φ): the integrand
        // is linear in cos θ, so the rule is exact up to rounding.
        let n = 1000;
        let mut sum = 0.0f64;
        for i in 0..n {
            let c = (i as f64 + 0.5) / n as f64;
            sum += f64::from(cosine_hemisphere_pdf(c as f32))
                * (1.0 / n as f64)
                * std::f64::consts::TAU;
        }
        assert!((sum - 1.0).abs() < 1e-6, "{sum}");
        assert!((f64::from(uniform_sphere_pdf()) * 4.0 * std::f64::consts::PI - 1.0).abs() < 1e-6);
        assert_eq!(uniform_triangle_pdf(0.5), 2.0);
        assert_eq!(cosine_hemisphere_pdf(-0.5), 0.0);
    }

    #[test]
    fn pole_and_seam() {
        assert_eq!(sample_cosine_hemisphere(Vec2::ZERO), Vec3::Z);
        let w = Vec3::new(1.0, -0.0, 0.0);
        let u = invert_cosine_hemisphere(w);
        assert!((0.0..1.0).contains(&u.y));
    }
}
