//! Schlick's Fresnel approximation as the glTF specification uses it (Appendix B.3.4), the
//! dielectric's reflectance at normal incidence from its index of refraction
//! (`KHR_materials_ior`), and the directional albedo of its `fresnel_mix` diffuse base, which the
//! irradiance cache needs.

use glam::Vec3;

/// The dielectric's reflectance at normal incidence, ((1 − ior)/(1 + ior))² for the
/// specification's fixed ior = 1.5: 0.04.
pub const DIELECTRIC_F0: f32 = 0.04;

/// Schlick's weight (1 − |cos θ|)⁵, with cos θ = V·H in the specification: F = f0 + (1 − f0)·w.
#[inline]
pub fn schlick_weight(cos_theta: f32) -> f32 {
    let m = (1.0 - cos_theta.abs()).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// Schlick's Fresnel F = f0 + (1 − f0)(1 − |cos θ|)⁵ (Schlick 1994, "An Inexpensive BRDF Model for
/// Physically-based Rendering", eq. 15), per colour channel.
#[inline]
pub fn schlick(f0: Vec3, cos_theta: f32) -> Vec3 {
    f0 + (Vec3::ONE - f0) * schlick_weight(cos_theta)
}

/// The coefficients, constant term first, of the polynomial in cos θo that approximates
/// S(cos θo) = (1/π) ∫ (1 − |wo·h|)⁵ cos θi dωi over the hemisphere, h = normalize(wo + wi):
/// the cosine-weighted mean of Schlick's weight with the half vector. Fitted (Lawson's iteration
/// towards the minimax fit) to a midpoint quadrature at 401 values of cos θo; the largest error,
/// 4.25e-6 against S ∈ [8.2e-5, 2.82e-2], is checked by a test against an independent quadrature.
const HALF_VECTOR_SCHLICK_MEAN: [f32; 5] = [
    0.028_159_764,
    -0.079_744_43,
    0.085_935_13,
    -0.042_827_413,
    0.008_554_594,
];

/// The dielectric's reflectance at normal incidence for index of refraction `ior` against air
/// (`KHR_materials_ior`): ((ior − 1)/(ior + 1))², computed as (ior − 1)²/(ior + 1)². For
/// ior = 1.5 that is 0.25/6.25, a quotient of exact f32 numbers, rounded once: [`DIELECTRIC_F0`]
/// bit for bit (squaring the rounded ratio 0.5/2.5 instead gives 0.040000003). An infinite ior
/// gives 1 (the limit). `ior` is expected in [1, ∞]; the material validates it
/// ([`crate::MetallicRoughness::with_ior`]).
#[inline]
pub fn dielectric_f0(ior: f32) -> f32 {
    if ior.is_infinite() {
        return 1.0;
    }
    let (below, above) = (ior - 1.0, ior + 1.0);
    (below * below) / (above * above)
}

/// S(cos θo), the cosine-weighted mean of Schlick's weight (1 − |wo·h|)⁵ over the hemisphere
/// ([`HALF_VECTOR_SCHLICK_MEAN`]'s polynomial).
#[inline]
fn half_vector_schlick_mean(cos_theta_o: f32) -> f32 {
    let c = cos_theta_o.clamp(0.0, 1.0);
    let [c0, c1, c2, c3, c4] = HALF_VECTOR_SCHLICK_MEAN;
    c0 + c * (c1 + c * (c2 + c * (c3 + c * c4)))
}

/// [`dielectric_diffuse_albedo`] for a dielectric of reflectance `f0` at normal incidence
/// (`KHR_materials_ior`'s [`dielectric_f0`]): (1 − f0)(1 − S(cos θo)), since
/// 1 − (f0 + (1 − f0) w) = (1 − f0)(1 − w) and S is the mean of w. The fit's absolute error in S,
/// 4.25e-6, enters multiplied by 1 − f0 ≤ 1. For f0 = [`DIELECTRIC_F0`] it is
/// [`dielectric_diffuse_albedo`] bit for bit.
#[inline]
pub fn dielectric_diffuse_albedo_f0(cos_theta_o: f32, f0: f32) -> f32 {
    (1.0 - f0) * (1.0 - half_vector_schlick_mean(cos_theta_o))
}

/// The directional albedo of the specification's dielectric diffuse base for a white base
/// colour: ρ(cos θo) = ∫ (1 − F(|wo·h|)) / π · cos θi dωi with F = Schlick at f0 = 0.04, which is
/// (1 − 0.04)(1 − S(cos θo)) with S the cosine-weighted mean of (1 − |wo·h|)⁵.
///
/// The exact value lies in [0.933, 0.960] (0.960 at normal incidence, 0.933 at the horizon); this
/// polynomial fit is within 4.1e-6 of it (relative: 4.4e-6). Because the half vector couples wo
/// and wi, the specification's diffuse term is not a constant times 1/π; this albedo is the one
/// constant that reflects the same total as the exact term under uniform incident light. See
/// [`crate::MetallicRoughness::diffuse_albedo`].
#[inline]
pub fn dielectric_diffuse_albedo(cos_theta_o: f32) -> f32 {
    dielectric_diffuse_albedo_f0(cos_theta_o, DIELECTRIC_F0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::hemisphere_quadrature;
    use glam::DVec3;

    /// The exact S(cos θo) by quadrature in f64 (midpoint rule, 256² cells over a smooth
    /// integrand: error ≲ 2e-7, from the difference with 512² cells at cos θo ∈ {0, 1}).
    fn half_vector_schlick_mean(cos_o: f64, n: usize) -> f64 {
        let wo = DVec3::new((1.0 - cos_o * cos_o).max(0.0).sqrt(), 0.0, cos_o);
        hemisphere_quadrature(1.0, n, |wi| {
            let c = (wo + wi).normalize().dot(wo);
            (1.0 - c).powi(5) * wi.z
        }) / std::f64::consts::PI
    }

    /// The fit against an independent quadrature at 41 values of cos θo (0 to 1 by 0.025, which
    /// include the fit's extremes' neighbourhoods): the fit's error was 4.25e-6 at fit time; the
    /// quadrature's own error here is the difference between 256² and 128² cells (≲ 1e-6), and the
    /// polynomial's f32 evaluation adds ≤ 5 roundings of numbers ≤ 0.09 (≲ 1e-8). The absolute
    /// bound on S is 4.25e-6 + that difference + 1e-8; the albedo's relative error is then
    /// ≤ bound / (1 − S) ≤ bound / 0.97.
    #[test]
    fn diffuse_albedo_fit_matches_quadrature() {
        let mut worst = 0.0f64;
        for i in 0..=40 {
            let c = f64::from(i) / 40.0;
            let fine = half_vector_schlick_mean(c, 256);
            let coarse = half_vector_schlick_mean(c, 128);
            let exact_albedo = 0.96 * (1.0 - fine);
            let got = f64::from(dielectric_diffuse_albedo(c as f32));
            let bound = 4.25e-6 + (fine - coarse).abs() + 1e-8;
            let err = (got - exact_albedo).abs();
            worst = worst.max(err / exact_albedo);
            assert!(
                err <= 0.96 * bound,
                "cos θo {c}: {got} vs {exact_albedo} (bound {bound})"
            );
        }
        assert!(worst < 4.4e-6 + 1e-6, "worst relative error {worst}");
        assert!((f64::from(dielectric_diffuse_albedo(1.0)) - 0.96 * (1.0 - 8.19e-5)).abs() < 5e-6);
    }

    #[test]
    fn schlick_limits() {
        assert_eq!(schlick(Vec3::splat(0.04), 1.0), Vec3::splat(0.04));
        assert_eq!(schlick(Vec3::splat(0.04), 0.0), Vec3::ONE);
        assert_eq!(schlick_weight(-0.5), schlick_weight(0.5));
    }
}
