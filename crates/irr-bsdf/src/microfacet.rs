//! The Trowbridge–Reitz (GGX) microfacet distribution of the glTF specification: its normal
//! distribution D, the Smith masking G1 and the height-correlated visibility term, and the
//! sampling of its visible normals (Heitz 2018) in a three: sample, pdf, invert.
//!
//! Isotropic only (glTF 2.0's core material has one roughness). Directions are in the local
//! shading frame, normal along +z, and are unit vectors; `alpha` is the GGX width α (the glTF
//! roughness squared), positive.
//!
//! Every square root below is written as √(z² + α²(x² + y²)) rather than the textbook
//! √(α² + (1 − α²)cos²θ): the two are equal for unit vectors, and the first has no `1 − α²` (which
//! rounds to 1 once α² < 2⁻²⁴) and no cancellation near the pole.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, TAU};

/// The GGX normal distribution D(wm) (Walter et al. 2007, "Microfacet Models for Refraction
/// through Rough Surfaces", eq. 33; glTF 2.0 specification, Appendix B.3.2):
/// D = α² χ⁺(cos θm) / (π (cos²θm (α² − 1) + 1)²).
///
/// The denominator is evaluated as sin²θm + α² cos²θm, the same number for a unit `wm`, without
/// the cancellation of 1 − cos²θm near the peak. Zero for `wm` at or below the horizon (χ⁺).
#[inline]
pub fn ggx_d(wm: Vec3, alpha: f32) -> f32 {
    if wm.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let t = wm.x * wm.x + wm.y * wm.y + a2 * wm.z * wm.z;
    a2 * FRAC_1_PI / (t * t)
}

/// √(cos²θ + α² sin²θ) for direction `w`: the root that both the Smith masking and the visibility
/// term use (cos θ · √(1 + α² tan²θ) in Heitz 2014's notation).
#[inline]
fn smith_root(w: Vec3, a2: f32) -> f32 {
    (w.z * w.z + a2 * (w.x * w.x + w.y * w.y)).sqrt()
}

/// The Smith masking function of GGX, G1(w) = 1 / (1 + Λ(w)) with
/// Λ(w) = (√(1 + α² tan²θ) − 1) / 2 (Heitz 2014, "Understanding the Masking-Shadowing Function
/// in Microfacet-Based BRDFs", JCGT 3(2), eq. 86), written as 2|cos θ| / (|cos θ| + √(cos²θ +
/// α² sin²θ)): no cancellation in the small-Λ limit.
#[inline]
pub fn smith_g1(w: Vec3, alpha: f32) -> f32 {
    let c = w.z.abs();
    let root = smith_root(w, alpha * alpha);
    if root > 0.0 {
        2.0 * c / (c + root)
    } else {
        0.0
    }
}

/// The height-correlated Smith visibility term ν = G2 / (4 |cos θo| |cos θi|) of the glTF
/// specification (Appendix B.3.2, after Heitz 2014, eq. 99):
/// ν = 1 / (2 (|cos θo| √(α² + (1 − α²) cos²θi) + |cos θi| √(α² + (1 − α²) cos²θo))).
///
/// The specification's χ⁺(H·L) χ⁺(H·V) factors are the caller's: for a reflection with both
/// directions above the surface they are 1. Symmetric in `wo` and `wi` bit for bit (the two
/// products swap places in a commutative sum). Zero if both directions lie in the tangent plane.
#[inline]
pub fn visibility(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let sum = wo.z.abs() * smith_root(wi, a2) + wi.z.abs() * smith_root(wo, a2);
    if sum > 0.0 { 0.5 / sum } else { 0.0 }
}

/// The orthonormal basis (T1, T2) around the stretched view direction `vh` of Heitz 2018,
/// section 4.1: T1 horizontal, with T1 = +x when `vh` is the normal itself.
#[inline]
fn visible_basis(vh: Vec3) -> (Vec3, Vec3) {
    let len2 = vh.x * vh.x + vh.y * vh.y;
    let t1 = if len2 > 0.0 {
        Vec3::new(-vh.y, vh.x, 0.0) / len2.sqrt()
    } else {
        Vec3::X
    };
    (t1, vh.cross(t1))
}

/// `wo` stretched into the configuration where the microsurface is the unit hemisphere (Heitz
/// 2018, section 3.2).
#[inline]
fn stretched_view(wo: Vec3, alpha: f32) -> Vec3 {
    Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize()
}

/// A microfacet normal drawn from the distribution of normals visible from `wo`,
/// D_wo(wm) = G1(wo) max(0, wo·wm) D(wm) / cos θo, by Heitz's construction (Heitz 2018,
/// "Sampling the GGX Distribution of Visible Normals", JCGT 7(4), listing 1).
///
/// `wo` must lie above the surface (`wo.z > 0`). The map is a bijection from the unit square to
/// the visible normals: [`invert_visible_normal`] undoes it.
#[inline]
pub fn sample_visible_normal(wo: Vec3, alpha: f32, u: Vec2) -> Vec3 {
    // Stretch the view direction so that the microsurface becomes the unit hemisphere, where the
    // visible normals are the hemisphere's points weighted by their projected area.
    let vh = stretched_view(wo, alpha);
    let (t1, t2) = visible_basis(vh);
    // Draw a point uniformly on the unit disk perpendicular to vh (polar map, so that the
    // inverse below is exact)...
    let r = u.x.sqrt();
    let (sin_phi, cos_phi) = (TAU * u.y).sin_cos();
    let p1 = r * cos_phi;
    let disk_p2 = r * sin_phi;
    // ...and squeeze its lower half so that the disk becomes the projection of the visible part
    // of the hemisphere: an ellipse half and a disk half, whose relative sizes s and 1 − s
    // depend on vh.z (section 4.2).
    let s = 0.5 * (1.0 + vh.z);
    let half_chord = (1.0 - p1 * p1).max(0.0).sqrt();
    let p2 = (1.0 - s) * half_chord + s * disk_p2;
    // Lift the projected point back onto the hemisphere along vh (section 4.3).
    let lift = (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
    let nh = p1 * t1 + p2 * t2 + lift * vh;
    // Unstretch: normals transform with the inverse transpose of the stretch (section 3.4).
    Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(0.0)).normalize()
}

/// The density of [`sample_visible_normal`] per unit solid angle of `wm`:
/// D_wo(wm) = G1(wo) max(0, wo·wm) D(wm) / cos θo (Heitz 2014, eq. 16; Heitz 2018, eq. 3).
/// Zero when `wo` lies at or below the horizon.
#[inline]
pub fn visible_normal_pdf(wo: Vec3, wm: Vec3, alpha: f32) -> f32 {
    if wo.z <= 0.0 {
        return 0.0;
    }
    smith_g1(wo, alpha) * wo.dot(wm).max(0.0) * ggx_d(wm, alpha) / wo.z
}

/// The largest `f32` below 1: inverses return values in [0, 1), like the samples they undo.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// The `u` that [`sample_visible_normal`] maps to `wm` for view direction `wo`: each step of the
/// construction undone in reverse order. `wm` must be a visible normal (`wm.z > 0`,
/// `wo·wm ≥ 0`); `wo.z > 0`.
#[inline]
pub fn invert_visible_normal(wo: Vec3, wm: Vec3, alpha: f32) -> Vec2 {
    let vh = stretched_view(wo, alpha);
    let (t1, t2) = visible_basis(vh);
    // Stretch the normal back into the hemisphere configuration (the inverse of the unstretch).
    let nh = Vec3::new(wm.x / alpha, wm.y / alpha, wm.z).normalize();
    // Its coordinates in the disk perpendicular to vh: the projection along vh.
    let p1 = nh.dot(t1);
    let p2 = nh.dot(t2);
    // Undo the squeeze of the disk's lower half (s ≥ 1/2 for vh.z ≥ 0, so no division by zero).
    let s = 0.5 * (1.0 + vh.z);
    let half_chord = (1.0 - p1 * p1).max(0.0).sqrt();
    let disk_p2 = (p2 - (1.0 - s) * half_chord) / s;
    // Undo the polar map.
    let r2 = (p1 * p1 + disk_p2 * disk_p2).clamp(0.0, ONE_MINUS_EPSILON);
    let phi = disk_p2.atan2(p1);
    let mut v = if phi < 0.0 {
        phi / TAU + 1.0
    } else {
        phi / TAU
    };
    // (φ + 2π)/2π can round up to exactly 1: wrap it into [0, 1).
    if v >= 1.0 {
        v = 0.0;
    }
    Vec2::new(r2, v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{self, hemisphere_quadrature};
    use irr_sampling::SampleKey;
    use proptest::prelude::*;

    fn unit_upper() -> impl Strategy<Value = Vec3> {
        // cos θ in [0.01, 1]: the sampler's precondition is wo.z > 0; 0.01 is 89.4°.
        (0.01f32..=1.0, 0.0f32..1.0).prop_map(|(c, v)| {
            let s = (1.0 - c * c).sqrt();
            let (sp, cp) = (TAU * v).sin_cos();
            Vec3::new(s * cp, s * sp, c)
        })
    }

    /// ∫ D(wm) cos θm dωm = 1 (the projected microfacet area is the macro-surface's: Heitz 2014,
    /// eq. 4), and ∫ D_wo(wm) dωm = 1 for every wo (the visible normals' density is normalised:
    /// Heitz 2014, eq. 17, which holds because G1 is Smith's for this D).
    ///
    /// The quadrature is the midpoint rule in (v, φ) with θ = atan(α v/(1 − v)), a change of
    /// variables that puts the grid where D varies (its Jacobian is applied in f64). Its error is
    /// estimated by halving the step: the rule is second order, so the finer value's error is
    /// about a third of the difference; we allow the whole difference. The f32 evaluation of D
    /// (about ten roundings, each ≤ 2⁻²⁴ relative, no cancellation) adds ≤ 1e-6 relative; the
    /// tolerance adds 2e-6 for it.
    #[test]
    fn distributions_are_normalised() {
        for alpha in [1e-3f32, 0.01, 0.1, 0.3, 0.7, 1.0] {
            let projected = |n: usize| {
                hemisphere_quadrature(f64::from(alpha), n, |wm| {
                    f64::from(ggx_d(testing::to_f32(wm), alpha)) * wm.z
                })
            };
            let (coarse, fine) = (projected(256), projected(512));
            let tol = (coarse - fine).abs() + 2e-6;
            assert!(
                (fine - 1.0).abs() < tol,
                "α {alpha}: ∫D cos = {fine} (±{tol})"
            );
            for cos_o in [1.0f32, 0.7, 0.2, 0.02] {
                let wo = Vec3::new((1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o);
                let visible = |n: usize| {
                    hemisphere_quadrature(f64::from(alpha), n, |wm| {
                        f64::from(visible_normal_pdf(wo, testing::to_f32(wm), alpha))
                    })
                };
                let (coarse, fine) = (visible(256), visible(512));
                let tol = (coarse - fine).abs() + 2e-6;
                assert!(
                    (fine - 1.0).abs() < tol,
                    "α {alpha}, cos θo {cos_o}: ∫D_wo = {fine} (±{tol})"
                );
            }
        }
    }

    /// The visibility term against the specification's formula evaluated in f64 (an independent
    /// transcription: ν = 1/(2(|N·V|√(α² + (1 − α²)(N·L)²) + |N·L|√(α² + (1 − α²)(N·V)²)))), and
    /// G1 against 1/(1 + Λ). Each f32 value goes through ≤ 12 roundings of well-conditioned
    /// operations (sums of positive terms, a square root, a division): relative error
    /// ≤ 12 · 2⁻²⁴ ≈ 7e-7, plus the inputs' non-unit length (≤ 2 ulp, entering at most squared:
    /// 5e-7). We allow 2e-6.
    #[test]
    fn visibility_and_g1_match_the_formulas() {
        for alpha in [1e-3f32, 0.05, 0.3, 1.0] {
            for (co, ci) in [
                (1.0f32, 1.0f32),
                (1.0, 0.01),
                (0.5, 0.3),
                (0.02, 0.9),
                (0.001, 0.001),
            ] {
                let wo = Vec3::new((1.0 - co * co).sqrt(), 0.0, co);
                let wi = Vec3::new(0.0, -(1.0 - ci * ci).sqrt(), ci);
                let a2 = f64::from(alpha).powi(2);
                let (cof, cif) = (f64::from(wo.z), f64::from(wi.z));
                let reference = 1.0
                    / (2.0
                        * (cof * (a2 + (1.0 - a2) * cif * cif).sqrt()
                            + cif * (a2 + (1.0 - a2) * cof * cof).sqrt()));
                let got = f64::from(visibility(wo, wi, alpha));
                assert!(
                    (got / reference - 1.0).abs() < 2e-6,
                    "α {alpha}, ({co}, {ci}): {got} vs {reference}"
                );
                let tan2 = (1.0 - cof * cof) / (cof * cof);
                let lambda = ((1.0 + a2 * tan2).sqrt() - 1.0) / 2.0;
                let got = f64::from(smith_g1(wo, alpha));
                assert!((got * (1.0 + lambda) - 1.0).abs() < 2e-6, "G1 {got}");
            }
        }
    }

    proptest! {
        /// sample → invert returns u. Error budget: the forward map and the inverse each take
        /// ~30 roundings of numbers of size ≤ 1, so the disk point (p1, p2) is recovered to
        /// ~1e-6 absolute, except that the unstretch multiplies by α and the re-stretch divides
        /// by it: that is exact up to rounding (componentwise relative error is preserved), so no
        /// 1/α growth. Undoing the squeeze divides by s ≥ 1/2 (×2), and the half chord
        /// √(1 − p1²) has derivative p1/√(1 − p1²), unbounded at |p1| → 1, so we compare only
        /// where 1 − p1² > 1e-2 (growth ≤ 10). u.x = p1² + p2² then carries ≲ 2·2·10·1e-6 = 4e-5.
        /// φ = atan2 is off by (error of p)/r: compared only where r² = u.x > 1e-2, giving
        /// ≲ 4e-5/0.1/2π ≈ 6e-5 in u.y. (The round trip is checked in u, not in directions: the
        /// forward map's lift √(1 − p²) and its unstretch, whose Jacobian reaches 1/α for normals
        /// near the stretched equator, amplify a recovered u's rounding into the direction.)
        #[test]
        fn visible_normal_round_trip(
            wo in unit_upper(),
            alpha in 1e-3f32..=1.0,
            u in (0.0f32..1.0, 0.0f32..1.0).prop_map(|(a, b)| Vec2::new(a, b)),
        ) {
            let wm = sample_visible_normal(wo, alpha, u);
            prop_assert!((wm.length() - 1.0).abs() < 1e-5);
            prop_assert!(wm.z >= 0.0);
            // The sample is visible from wo (up to rounding of the unit vectors: 1e-5).
            prop_assert!(wo.dot(wm) > -1e-5, "wo·wm = {}", wo.dot(wm));
            let back = invert_visible_normal(wo, wm, alpha);
            let p1 = u.x.sqrt() * (TAU * u.y).cos();
            if 1.0 - p1 * p1 > 1e-2 {
                prop_assert!((back.x - u.x).abs() < 4e-5, "{u} -> {wm} -> {back}");
                if u.x > 1e-2 {
                    let d = (back.y - u.y).abs();
                    prop_assert!(d.min(1.0 - d) < 6e-5, "{u} -> {wm} -> {back}");
                }
            }
        }
    }

    /// Chi-square goodness of fit of the visible-normal sampler against its pdf, with
    /// independent uniform samples from irr-sampling's counter-based source (reproducible), at
    /// several widths and view angles (see `testing::chi2_directions` for the binning, pooling and
    /// significance level).
    #[test]
    fn visible_normal_sampler_fits_its_pdf() {
        let cases = [(0.05f32, 1.0f32), (0.2, 0.5), (0.5, 0.1), (1.0, 0.8)];
        for (case, &(alpha, cos_o)) in cases.iter().enumerate() {
            let wo = Vec3::new((1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o);
            let result = testing::chi2_directions(
                100_000,
                |i| {
                    let u = SampleKey::new(11, case as u64, i).uniform_2d(0);
                    Some(sample_visible_normal(wo, alpha, u))
                },
                |wm| visible_normal_pdf(wo, wm, alpha),
            );
            eprintln!("visible normals α {alpha} cos θo {cos_o}: {result}");
            assert!(result.passes(), "α {alpha}, cos θo {cos_o}: {result}");
        }
    }
}
