//! Tests of `KHR_materials_ior` and `KHR_materials_transmission`: the opaque material unchanged
//! bit for bit (against a frozen copy of the code before them), the ior's validation and F0,
//! the volumetric BTDF against an f64 transcription of Walter et al.'s eq. 21, its reciprocity,
//! Snell's law and total internal reflection in its samples, the samplers' densities (each
//! sample against `pdf`, and chi-square fits over the sphere), white furnaces of the thin pane and
//! the volume against quadrature, and the diffuse lobe's albedo.

use super::super::legacy::Legacy;
use super::*;
use crate::testing::{self, direction, hemisphere_quadrature3, spec_brdf};
use glam::DVec3;
use irr_sampling::SampleKey;
use proptest::prelude::*;
use std::f32::consts::TAU;
use std::f64::consts::PI;

const EPS: f64 = f32::EPSILON as f64;

/// Any direction with |cos θ| in [1e-3, 1], above or below the surface.
fn sphere() -> impl Strategy<Value = Vec3> {
    (1e-3f32..=1.0, any::<bool>(), 0.0f32..1.0).prop_map(|(c, below, v)| {
        let s = (1.0 - c * c).sqrt();
        let (sp, cp) = (TAU * v).sin_cos();
        Vec3::new(s * cp, s * sp, if below { -c } else { c })
    })
}

fn unit_square() -> impl Strategy<Value = Vec2> {
    (0.0f32..1.0, 0.0f32..1.0).prop_map(|(a, b)| Vec2::new(a, b))
}

fn bits(v: Vec3) -> [u32; 3] {
    [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]
}

fn sample_bits(s: Option<BsdfSample>) -> Option<([u32; 3], [u32; 3], u32, Lobe)> {
    s.map(|s| (bits(s.wi), bits(s.f), s.pdf.to_bits(), s.lobe))
}

/// A transmitting material: any base colour, metallic, roughness, specular weight, transmission
/// in (0, 1], ior in [1, 3], thin-walled or not.
fn transmitting() -> impl Strategy<Value = MetallicRoughness> {
    (
        (0.0f32..=1.0, 0.0f32..=1.0, 0.0f32..=1.0),
        0.0f32..=1.0,
        0.0f32..=1.0,
        0.0f32..=1.0,
        1e-3f32..=1.0,
        1.0f32..=3.0,
        any::<bool>(),
    )
        .prop_map(|((r, g, b), m, rough, s, t, ior, thin)| {
            MetallicRoughness::with_specular(Vec3::new(r, g, b), m, rough, s)
                .with_ior(ior)
                .with_transmission(t, thin)
        })
}

/// A clear glass: white, metallic 0, transmission 1, specular weight 1.
fn glass(roughness: f32, ior: f32, thin: bool) -> MetallicRoughness {
    MetallicRoughness::new(Vec3::ONE, 0.0, roughness)
        .with_ior(ior)
        .with_transmission(1.0, thin)
}

proptest! {
    /// Without transmission and at ior 1.5, every public function returns the same bits as the
    /// code before transmission and ior existed (`legacy`), for directions on both sides: the
    /// new fields enter only through `transmission > 0` branches, F0 = 0.25/6.25 is 0.04's bits,
    /// and the factors (1 − transmission) = 1 multiply exactly. Also through `with_ior(1.5)` and
    /// `with_transmission(0, false)`.
    #[test]
    fn unchanged_without_transmission(
        (r, g, b) in (0.0f32..=1.0, 0.0f32..=1.0, 0.0f32..=1.0),
        metallic in 0.0f32..=1.0,
        roughness in 0.0f32..=1.0,
        specular in prop_oneof![Just(0.0f32), Just(1.0f32), 0.0f32..=1.0],
        variant in 0u8..3,
        wo in sphere(),
        wi in sphere(),
        u_lobe in 0.0f32..1.0,
        u in unit_square(),
    ) {
        let base = Vec3::new(r, g, b);
        let old = Legacy::with_specular(base, metallic, roughness, specular);
        let plain = MetallicRoughness::with_specular(base, metallic, roughness, specular);
        let new = match variant {
            0 => plain,
            1 => plain.with_ior(1.5),
            _ => plain.with_ior(1.5).with_transmission(0.0, false),
        };
        let (lo, ln) = (old.eval_lobes(wo, wi), new.eval_lobes(wo, wi));
        prop_assert_eq!(bits(lo.diffuse), bits(ln.diffuse));
        prop_assert_eq!(bits(lo.glossy), bits(ln.glossy));
        prop_assert_eq!(bits(ln.transmission), bits(Vec3::ZERO));
        prop_assert_eq!(bits(old.eval(wo, wi)), bits(new.eval(wo, wi)));
        prop_assert_eq!(old.pdf(wo, wi).to_bits(), new.pdf(wo, wi).to_bits());
        prop_assert_eq!(old.glossy_pdf(wo, wi).to_bits(), new.glossy_pdf(wo, wi).to_bits());
        prop_assert_eq!(
            sample_bits(old.sample(wo, u_lobe, u)),
            sample_bits(new.sample(wo, u_lobe, u))
        );
        prop_assert_eq!(sample_bits(old.sample_glossy(wo, u)), sample_bits(new.sample_glossy(wo, u)));
        prop_assert_eq!(bits(old.diffuse_albedo(wo)), bits(new.diffuse_albedo(wo)));
        prop_assert_eq!(
            old.glossy_probability(wo).to_bits(),
            new.glossy_probability(wo).to_bits()
        );
        prop_assert_eq!(new.transmission_probability(wo), 0.0);
        prop_assert_eq!(bits(old.specular_f0()), bits(new.specular_f0()));
        prop_assert_eq!(bits(old.specular_f90()), bits(new.specular_f90()));
        prop_assert_eq!(old.alpha().to_bits(), new.alpha().to_bits());
        prop_assert_eq!(old.is_lambertian(), new.is_lambertian());
        prop_assert_eq!(new.straight_transmittance(wo.z), Some(Vec3::ZERO));
    }
}

/// F0 = ((ior − 1)/(ior + 1))²: 0.04's bits at 1.5; elsewhere against f64 within 3ε relative
/// (ior − 1 is exact for ior in [1, 2] and rounded once above, ior + 1 rounded once, each square
/// and the quotient once: ≤ 5 roundings of ε/2, and no cancellation after the subtraction).
/// The validation of file values follows `KHR_materials_ior`: NaN is the default 1.5, 0 and +∞
/// an infinite ior (F = 1, or the specular weight), values below 1 raised to 1, above
/// `MAX_IOR` lowered to it.
#[test]
fn ior_gives_f0_and_is_validated() {
    assert_eq!(dielectric_f0(1.5).to_bits(), 0.04f32.to_bits());
    assert_eq!(dielectric_f0(1.0), 0.0);
    assert_eq!(dielectric_f0(f32::INFINITY), 1.0);
    for ior in [1.0f32, 1.33, 1.38, 1.52, 1.76, 2.42, 4.0, MAX_IOR] {
        let exact = ((f64::from(ior) - 1.0) / (f64::from(ior) + 1.0)).powi(2);
        let got = f64::from(dielectric_f0(ior));
        assert!(
            (got - exact).abs() <= 3.0 * EPS * exact,
            "{ior}: {got} vs {exact}"
        );
    }
    let m = MetallicRoughness::new(Vec3::new(0.5, 0.4, 0.3), 0.0, 0.5);
    let cases = [
        (f32::NAN, 1.5f32),
        (0.0, f32::INFINITY),
        (-0.0, f32::INFINITY),
        (f32::INFINITY, f32::INFINITY),
        (0.5, 1.0),
        (-2.0, 1.0),
        (f32::NEG_INFINITY, 1.0),
        (1e6, MAX_IOR),
        (1.33, 1.33),
    ];
    for (given, kept) in cases {
        assert_eq!(m.with_ior(given).ior(), kept, "ior {given}");
    }
    // ior 1.33: F0 = 0.02006, and the glossy lobe's f0 follows it.
    let water = m.with_ior(1.33);
    assert_eq!(water.specular_f0(), Vec3::splat(water.dielectric_f0()));
    assert!((water.dielectric_f0() - 0.020_059).abs() < 1e-6);
    // The compatibility mode: F is 1 at every angle (the specular weight s with
    // KHR_materials_specular), the diffuse lobe vanishes, nothing transmits.
    for specular in [1.0f32, 0.6] {
        let mode = MetallicRoughness::with_specular(Vec3::ONE, 0.0, 0.4, specular).with_ior(0.0);
        for c in [1.0f32, 0.5, 0.01, -0.5] {
            assert_eq!(mode.dielectric_fresnel(c), specular, "s {specular} cos {c}");
        }
        let glass = mode.with_transmission(1.0, false);
        let (wo, wi) = (direction(0.8), -direction(0.7));
        assert_eq!(glass.eval_lobes(wo, wi).transmission, Vec3::ZERO);
        assert_eq!(glass.transmission_probability(wo), 0.0);
        // Inside an infinitely dense volume everything reflects.
        assert_eq!(glass.dielectric_fresnel(-1.0), 1.0);
    }
    let mode = MetallicRoughness::new(Vec3::ONE, 0.0, 0.4).with_ior(0.0);
    assert_eq!(mode.diffuse_albedo(direction(0.7)), Vec3::ZERO);
    assert_eq!(
        mode.with_transmission(1.0, true)
            .eval_lobes(direction(0.8), -direction(0.8))
            .transmission,
        Vec3::ZERO
    );
}

/// A transmitting material is not Lambertian, even with specular weight 0 (its transmission
/// lobe remains); and the lobe-choice probabilities are positive wherever the lobes can be.
#[test]
fn transmitting_material_is_not_lambertian() {
    let base = Vec3::new(0.7, 0.2, 0.05);
    let m = MetallicRoughness::with_specular(base, 0.0, 0.3, 0.0);
    assert!(m.is_lambertian());
    for thin in [true, false] {
        let t = m.with_transmission(0.5, thin);
        assert!(!t.is_lambertian());
        let wo = direction(0.6);
        assert!(t.transmission_probability(wo) > 0.0);
        assert!(t.transmission_probability(wo) < 1.0);
    }
}

/// The smooth thin pane's closed forms. At normal incidence with ior 1.5, F = 0.04 exactly
/// (Schlick's weight is 0), and the pane transmits (1 − F)/(1 + F) = 0.96/1.04 = 0.923077 (two
/// roundings and a quotient: ≤ 2ε relative), per channel times the tint τ = (1 − metallic) ·
/// transmission · base_color. At every angle the pane's reflectance 2F/(1 + F) (the first
/// surface's F and the back surface's F(1 − F)/(1 + F)) and its transmittance sum to 1 (a few
/// roundings of numbers ≤ 1: 4ε).
#[test]
fn thin_pane_known_answers() {
    let clear = glass(0.0, 1.5, true);
    let t = clear.straight_transmittance(1.0).map(|t| f64::from(t.x));
    let expected = 0.96 / 1.04;
    assert!(
        t.is_some_and(|t| (t - expected).abs() <= 2.0 * EPS * expected),
        "{t:?}"
    );
    assert!((expected - 0.923_077).abs() < 1e-6);
    // Tinted and partly metallic: τ scales it per channel.
    let tinted = MetallicRoughness::new(Vec3::new(0.9, 0.5, 0.1), 0.25, 0.0)
        .with_transmission(0.8, true)
        .straight_transmittance(1.0);
    let tau = Vec3::new(0.9, 0.5, 0.1) * (0.75 * 0.8);
    assert!(
        tinted.is_some_and(|t| (t - tau * (0.96 / 1.04)).abs().max_element() < 4e-7),
        "{tinted:?}"
    );
    for c in [1.0f32, 0.8, 0.5, 0.2, 0.05, 0.0] {
        let f = clear.dielectric_fresnel(c);
        let transmitted = clear.straight_transmittance(c).map_or(f32::NAN, |t| t.x);
        let reflected = f + pane_back_reflection(f);
        assert!(
            (f64::from(reflected + transmitted) - 1.0).abs() <= 4.0 * EPS,
            "cos {c}: R {reflected} + T {transmitted}"
        );
    }
    // Not a straight pass-through: rough sheets and volumes.
    assert_eq!(glass(0.2, 1.5, true).straight_transmittance(1.0), None);
    assert_eq!(glass(0.0, 1.5, false).straight_transmittance(1.0), None);
    // Smooth means α at the floor: roughness up to √1e-3.
    assert!(glass(0.03, 1.5, true).straight_transmittance(1.0).is_some());
}

/// The thin pane's directional reflectance and transmittance for white clear glass by f64
/// quadrature over the microfacet normal (as `testing::spec_albedo` does for reflection): each
/// facet wm reflects wi = reflect(wo, wm) with weight R'(F) = F + F(1 − F)/(1 + F) and transmits
/// the mirror image of wi with T'(F) = (1 − F)/(1 + F), F Schlick's at |wo·wm|, both times the
/// GGX lobe D ν cos θi with dωi = 4 |wo·wm| dωm. `spec_brdf` of a white metal gives D ν (its F is
/// 1).
fn pane_albedo(alpha: f64, f0: f64, wo: DVec3, n: usize) -> (f64, f64) {
    let both = hemisphere_quadrature3(alpha, n, |wm| {
        let d = wo.dot(wm);
        let wi = 2.0 * d * wm - wo;
        if d <= 0.0 || wi.z <= 0.0 {
            return DVec3::ZERO;
        }
        let lobe = spec_brdf(DVec3::ONE, 1.0, alpha, wo, wi).glossy.x * wi.z * 4.0 * d;
        let f = f0 + (1.0 - f0) * (1.0 - d).powi(5);
        DVec3::new(
            (f + f * (1.0 - f) / (1.0 + f)) * lobe,
            (1.0 - f) / (1.0 + f) * lobe,
            0.0,
        )
    });
    (both.x, both.y)
}

/// Monte Carlo over `sample`: the means and standard errors of the weight f |cos θi| / pdf
/// (channel x) split by the side of `wi` (reflected: `wi` on `wo`'s side; transmitted: the
/// other), and of the energy weight, the transmitted ones times η'² = (η(wi's side)/η(wo's
/// side))²: the radiance-mode BTDF's 1/η'² undone, which turns f into the BSDF of energy (its
/// adjoint), whose albedo is at most 1.
struct Estimate {
    reflected: (f64, f64),
    transmitted: (f64, f64),
    energy: (f64, f64),
}

fn estimate(m: &MetallicRoughness, wo: Vec3, n: u64, stream: u64) -> Estimate {
    let etap2 = if m.is_thin_walled() {
        1.0
    } else if wo.z > 0.0 {
        f64::from(m.ior().max(MIN_VOLUME_IOR)).powi(2)
    } else {
        f64::from(m.ior().max(MIN_VOLUME_IOR)).powi(-2)
    };
    let mut sums = [[0.0f64; 2]; 3];
    for i in 0..n {
        let key = SampleKey::new(77, stream, i);
        let Some(s) = m.sample(wo, key.uniform(0), key.uniform_2d(1)) else {
            continue;
        };
        let w = f64::from(s.f.x) * f64::from(s.wi.z.abs()) / f64::from(s.pdf);
        let transmitted = s.wi.z * wo.z < 0.0;
        let e = if transmitted { w * etap2 } else { w };
        let k = usize::from(transmitted);
        for (slot, value) in [(k, w), (2, e)] {
            sums[slot][0] += value;
            sums[slot][1] += value * value;
        }
    }
    let stat = |[sum, sum2]: [f64; 2]| {
        let mean = sum / n as f64;
        let var = (sum2 / n as f64 - mean * mean).max(0.0) * n as f64 / (n - 1) as f64;
        (mean, (var / n as f64).sqrt())
    };
    Estimate {
        reflected: stat(sums[0]),
        transmitted: stat(sums[1]),
        energy: stat(sums[2]),
    }
}

/// White furnace of the thin pane (white clear glass, ior 1.5): the sampler's reflected and
/// transmitted albedos against `pane_albedo`'s quadrature. Tolerance: 5 standard errors (from
/// the samples) + the quadrature's error (the whole 256² − 512² difference; the rule is second
/// order) + 1e-5 for the f32 weights (≤ 30 roundings of weights ≤ 2). Since R' + T' = 1 at every
/// facet, their sum is the GGX lobe's single-scattering albedo ≤ 1, and for the smooth pane (α at
/// the floor) within 1e-4 of 1 here: a closed white box of it conserves energy. At normal
/// incidence the smooth pane transmits 0.96/1.04 = 0.923077 of the light.
#[test]
fn thin_pane_white_furnace() {
    let mut stream = 0;
    for roughness in [0.0f32, 0.3, 0.6, 1.0] {
        let m = glass(roughness, 1.5, true);
        let alpha = f64::from(m.alpha());
        for cos_o in [1.0f32, 0.5, 0.1] {
            stream += 1;
            let wo = direction(cos_o);
            let e = estimate(&m, wo, 40_000, stream);
            let (r256, t256) = pane_albedo(alpha, 0.04, wo.as_dvec3(), 256);
            let (r512, t512) = pane_albedo(alpha, 0.04, wo.as_dvec3(), 512);
            eprintln!(
                "thin pane roughness {roughness} cos θo {cos_o}: R {:.6}±{:.1e} (quad {r512:.6}) \
                 T {:.6}±{:.1e} (quad {t512:.6})",
                e.reflected.0, e.reflected.1, e.transmitted.0, e.transmitted.1
            );
            for (name, (mean, se), quad, err) in [
                ("R", e.reflected, r512, (r512 - r256).abs()),
                ("T", e.transmitted, t512, (t512 - t256).abs()),
            ] {
                let tol = 5.0 * se + err + 1e-5;
                assert!(
                    (mean - quad).abs() <= tol,
                    "roughness {roughness} cos θo {cos_o} {name}: {mean} vs {quad} (tol {tol:.1e})"
                );
            }
            let quad_err = (r512 - r256).abs() + (t512 - t256).abs();
            assert!(r512 + t512 <= 1.0 + quad_err, "albedo {}", r512 + t512);
            if roughness == 0.0 && cos_o >= 0.5 {
                assert!(r512 + t512 >= 1.0 - 1e-4 - quad_err, "{}", r512 + t512);
            }
            if roughness == 0.0 && cos_o == 1.0 {
                let tol = 5.0 * e.transmitted.1 + (1.0 - r512 - t512).abs() + quad_err + 1e-5;
                assert!(
                    (e.transmitted.0 - 0.96 / 1.04).abs() <= tol,
                    "normal incidence: T {}",
                    e.transmitted.0
                );
            }
        }
    }
}

/// White furnace of the volume (white clear glass): the energy albedo (reflected + transmitted
/// weight times η'²) is at most 1 from both sides, and 1 for a smooth boundary (every facet
/// splits its light into F and 1 − F, or reflects it all beyond the critical angle). Tolerance: 5 standard errors + 1e-5 (f32 weights); the smooth case's
/// lower bound also allows 1e-3 for the lobe's light lost to masking and to facets that send it
/// below the horizon (at α = 1e-3, Λ ≤ α² tan²θ / 4 ≤ 1e-5 for these angles, and the visible
/// normals tilted past 0.05 rad, the least tilt that turns any of these directions past the
/// horizon, have probability ≈ α²/0.05² = 4e-4).
#[test]
fn volume_white_furnace() {
    let mut stream = 100;
    for ior in [1.5f32, 1.33] {
        for roughness in [0.0f32, 0.3, 0.6, 1.0] {
            let m = glass(roughness, ior, false);
            for cos_o in [1.0f32, 0.6, 0.2, -1.0, -0.9, -0.6, -0.2] {
                stream += 1;
                let wo = if cos_o > 0.0 {
                    direction(cos_o)
                } else {
                    -direction(-cos_o)
                };
                let e = estimate(&m, wo, 40_000, stream);
                let (energy, se) = e.energy;
                eprintln!(
                    "volume ior {ior} roughness {roughness} cos θo {cos_o}: energy {energy:.6} \
                     ± {se:.1e} (R {:.4}, T {:.4})",
                    e.reflected.0, e.transmitted.0
                );
                assert!(energy <= 1.0 + 5.0 * se + 1e-5, "{energy}");
                if roughness == 0.0 && cos_o.abs() >= 0.6 {
                    assert!(energy >= 1.0 - 5.0 * se - 1e-5 - 1e-3, "{energy}");
                }
            }
        }
    }
}

/// Walter et al. 2007, eq. 21, transcribed in f64 for white clear glass (τ = 1, s = 1) with the
/// names of the paper: i = wi (towards the light), o = wo (towards the viewer), η_i and η_o the
/// iors of their sides, h_t = −(η_i i + η_o o)/|…| (eq. 16) turned to the outside normal's side:
/// f = |i·h||o·h| / (|i·n||o·n|) · η_o² (1 − F) G D / (η_i (i·h) + η_o (o·h))², with D GGX,
/// G the height-correlated Smith G2 = χ⁺ χ⁺ / (1 + Λ(o) + Λ(i)) (Heitz 2014, eq. 99) and F
/// Schlick's at the outside direction's cosine to h.
fn walter_btdf(wo: DVec3, wi: DVec3, ior: f64, alpha: f64, f0: f64) -> f64 {
    let (eta_o, eta_i) = if wo.z > 0.0 { (1.0, ior) } else { (ior, 1.0) };
    let mut h = -(eta_i * wi + eta_o * wo).normalize();
    if h.z < 0.0 {
        h = -h;
    }
    if wo.dot(h) * wo.z <= 0.0 || wi.dot(h) * wi.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let d = a2 / (PI * (h.z * h.z * (a2 - 1.0) + 1.0).powi(2));
    let lambda = |w: DVec3| {
        let tan2 = (1.0 - w.z * w.z) / (w.z * w.z);
        ((1.0 + a2 * tan2).sqrt() - 1.0) / 2.0
    };
    let g = 1.0 / (1.0 + lambda(wo) + lambda(wi));
    let outside = if wo.z > 0.0 { wo } else { wi };
    let f = f0 + (1.0 - f0) * (1.0 - outside.dot(h).abs()).powi(5);
    (wi.dot(h) * wo.dot(h)).abs() / (wi.z * wo.z).abs() * eta_o * eta_o * (1.0 - f) * g * d
        / (eta_i * wi.dot(h) + eta_o * wo.dot(h)).powi(2)
}

/// The relative error bound of the f32 BTDF at a refraction pair against exact arithmetic on the
/// same f32 inputs: ≤ 40 roundings (40ε/2 = 20ε) for the products, quotients and square roots,
/// plus the facet normal's error. wm = normalize(wo + η' wi) has direction error
/// δ ≤ (1 + η')·2ε / |wo + η' wi| (each input component ≤ ε/2 off unit length and the sum's
/// rounding, divided by the sum's length); D changes by at most (2/α)·δ relatively (its
/// logarithmic slope 4 tan θ (1 − α²)/(tan²θ + α²) ≤ 2/α), each of |wi·wm| and |wo·wm| by δ/|·|,
/// the squared denominator (η' wi + wo)·wm = |wo + η' wi| only to second order, and 1 − F by
/// 5δ/(1 − F) (Schlick's slope is at most 5).
fn btdf_tolerance(wo: DVec3, wi: DVec3, ior: f64, alpha: f64, f0: f64, s: f64) -> f64 {
    let etap = if wo.z > 0.0 { ior } else { 1.0 / ior };
    let sum = wo + etap * wi;
    let wm = sum.normalize();
    let delta = (1.0 + etap) * 2.0 * EPS / sum.length();
    let outside = if wo.z > 0.0 { wo } else { wi };
    let f = s * (f0 + (1.0 - f0) * (1.0 - outside.dot(wm).abs()).powi(5));
    20.0 * EPS
        + delta
            * (2.0 / alpha
                + 1.0 / wo.dot(wm).abs()
                + 1.0 / wi.dot(wm).abs()
                + 5.0 / (1.0 - f).max(1e-12))
}

proptest! {
    /// The volumetric BTDF against `walter_btdf` (an independent transcription, in f64, from the
    /// same f32 directions), both sides of the boundary, within `btdf_tolerance`.
    #[test]
    fn btdf_matches_walter(
        roughness in 0.0f32..=1.0,
        ior in 1.01f32..=3.0,
        wo in sphere(),
        wi in sphere(),
    ) {
        let wi = if wi.z * wo.z > 0.0 { -wi } else { wi };
        let m = glass(roughness, ior, false);
        let (wo64, wi64, ior64, alpha) =
            (wo.as_dvec3(), wi.as_dvec3(), f64::from(ior), f64::from(m.alpha()));
        let f0 = f64::from(m.dielectric_f0());
        let reference = walter_btdf(wo64, wi64, ior64, alpha, f0);
        let got = m.eval_lobes(wo, wi);
        prop_assert_eq!(got.diffuse + got.glossy, Vec3::ZERO);
        let got = f64::from(got.transmission.x);
        if reference == 0.0 {
            // Back-facing facets: zero in both (or, at the boundary of that set, tiny).
            prop_assert!(got == 0.0 || got < 1e-6, "{got}");
        } else {
            let tol = btdf_tolerance(wo64, wi64, ior64, alpha, f0, 1.0);
            prop_assume!(tol < 1e-2);
            let rel = (got / reference - 1.0).abs();
            prop_assert!(rel <= tol, "{got} vs {reference}: {rel:e} > {tol:e}");
        }
    }

    /// Reciprocity of the volumetric BTDF for radiance: f(wo, wi)/η(wo's side)² = f(wi, wo)/
    /// η(wi's side)² (Veach 1997, eq. 5.14, pbrt-v4's `TransportMode` section). The two
    /// evaluations compute the same quantities from normalize(wo + η' wi) and normalize(wi + wo/η'),
    /// whose directions agree within each one's `btdf_tolerance`. The thin pane's transmission is
    /// reciprocal bit for bit, with both directions mirrored to the viewer's side (the two
    /// refractions cancel: no η factor): f(wo, wi) = f(wi mirrored, wo mirrored).
    #[test]
    fn btdf_reciprocity(
        m in transmitting(),
        wo in sphere(),
        wi in sphere(),
    ) {
        let wi = if wi.z * wo.z > 0.0 { -wi } else { wi };
        if m.is_thin_walled() {
            let wo = if wo.z > 0.0 { wo } else { -wo };
            let wi = if wi.z < 0.0 { wi } else { -wi };
            prop_assert_eq!(
                bits(m.eval(wo, wi)),
                bits(m.eval(mirror(wi), mirror(wo)))
            );
        } else {
            let eta = f64::from(m.ior().max(MIN_VOLUME_IOR));
            let side = |w: Vec3| if w.z > 0.0 { 1.0 } else { eta };
            let forward = m.eval(wo, wi).as_dvec3() / side(wo).powi(2);
            let backward = m.eval(wi, wo).as_dvec3() / side(wi).powi(2);
            let (wo64, wi64) = (wo.as_dvec3(), wi.as_dvec3());
            let (f0, sw) = (f64::from(m.dielectric_f0()), f64::from(m.specular()));
            let alpha = f64::from(m.alpha());
            let tol = btdf_tolerance(wo64, wi64, eta, alpha, f0, sw)
                + btdf_tolerance(wi64, wo64, eta, alpha, f0, sw);
            prop_assume!(tol < 1e-2);
            for c in 0..3 {
                let (a, b) = (forward[c], backward[c]);
                prop_assert!(
                    (a - b).abs() <= tol * a.abs().max(b.abs()) || a.max(b) < 1e-30,
                    "{forward} vs {backward} (tol {tol:e})"
                );
            }
        }
    }

    /// Snell's law in every refracted sample, against the visible normal the sampler drew (the
    /// same function on the same `u`): η_o wo + η_i wi has no component along the facet plane
    /// (the vector form of η_o sin θo = η_i sin θi with both in one plane), and wi leaves on the
    /// facet's other side. The tangential part of wi is −wo_t/η' up to the rounding of two
    /// products and a sum per component (the facet-normal term adds nothing tangential but its
    /// rounding): |error| ≤ 4ε (1/η' + 2) per component, times η_i and √3 for the vector.
    #[test]
    fn refracted_samples_obey_snell(
        roughness in 0.0f32..=1.0,
        ior in 1.01f32..=3.0,
        wo in sphere(),
        u in unit_square(),
    ) {
        let m = glass(roughness, ior, false);
        // Outside, the transmission lobe's share of [0, 1) ends at 1 − (the diffuse share, 0 for
        // clear glass); inside, refraction follows reflection: u_lobe just below 1 refracts
        // wherever refraction has a positive probability.
        let Some(s) = m.sample(wo, 1.0 - f32::EPSILON, u) else { return Ok(()); };
        prop_assume!(s.lobe == Lobe::Transmission);
        let wm = if wo.z > 0.0 {
            sample_visible_normal(wo, m.alpha(), u)
        } else {
            sample_visible_normal(-wo, m.alpha(), u)
        };
        let (eta_o, eta_i) = if wo.z > 0.0 { (1.0, f64::from(ior)) } else { (f64::from(ior), 1.0) };
        let (wo64, wi64, wm64) = (wo.as_dvec3(), s.wi.as_dvec3(), wm.as_dvec3());
        let v = eta_o * wo64 + eta_i * wi64;
        let tangential = (v - v.dot(wm64) * wm64).length();
        let tol = eta_i * 3f64.sqrt() * 4.0 * EPS * (eta_o / eta_i + 2.0) + 4.0 * EPS;
        prop_assert!(tangential <= tol, "tangential {tangential:e} > {tol:e}");
        prop_assert!(s.wi.z * wo.z < 0.0);
        prop_assert!(wo64.dot(wm64) * wi64.dot(wm64) < 0.0);
    }
}

/// Snell's law at the macro scale for a smooth boundary (α at the floor): η_o sin θo = η_i sin θi
/// up to the drawn facet's tilt θm from the normal, since the law holds exactly about the facet
/// and each direction's angle to the normal differs from its angle to the facet by at most θm:
/// |η_o sin θo − η_i sin θi| ≤ (η_o + η_i) θm (+ 1e-6 for rounding). The tilts are of order α.
#[test]
fn smooth_refraction_follows_snell() {
    for ior in [1.33f32, 1.5, 2.42] {
        let m = glass(0.0, ior, false);
        // Inside, within the critical angle of the densest (cos θc = 0.911 for 2.42).
        for cos_o in [1.0f32, 0.8, 0.5, 0.2, -1.0, -0.98, -0.95] {
            let wo = if cos_o > 0.0 {
                direction(cos_o)
            } else {
                -direction(-cos_o)
            };
            let (eta_o, eta_i) = if cos_o > 0.0 { (1.0, ior) } else { (ior, 1.0) };
            let mut refracted = 0;
            for i in 0..200 {
                let u = SampleKey::new(3, i, 0).uniform_2d(0);
                let Some(s) = m.sample(wo, 1.0 - f32::EPSILON, u) else {
                    continue;
                };
                if s.lobe != Lobe::Transmission {
                    continue;
                }
                refracted += 1;
                let wm = if cos_o > 0.0 {
                    sample_visible_normal(wo, m.alpha(), u)
                } else {
                    sample_visible_normal(-wo, m.alpha(), u)
                };
                // From the tangential components: acos of wm.z ≈ 1 would carry f32's spacing
                // near 1 (6e-8) into the angle as 6e-8/sin θm, ~3e-5 at θm = 1e-3.
                let tilt = f64::from(wm.x.hypot(wm.y)).min(1.0).asin();
                let sin = |w: Vec3| f64::from(w.x.hypot(w.y));
                let gap = (f64::from(eta_o) * sin(wo) - f64::from(eta_i) * sin(s.wi)).abs();
                let tol = f64::from(eta_o + eta_i) * tilt + 1e-6;
                assert!(gap <= tol, "ior {ior} cos θo {cos_o}: {gap:e} > {tol:e}");
                assert!(tilt < 100.0 * f64::from(m.alpha()), "tilt {tilt}");
            }
            // Most samples refract (u_lobe picks refraction wherever it is possible).
            assert!(
                refracted > 150,
                "ior {ior} cos θo {cos_o}: {refracted} refracted"
            );
        }
    }
}

/// Total internal reflection: from inside, beyond the critical angle (sin θ > 1/η), the boundary
/// reflects everything, F = 1 exactly, while just inside the critical angle F < 1. A smooth
/// boundary seen from inside at 53° (critical: 41.8°) reflects every sample drawn on a facet
/// beyond the critical angle (all but those tilted ≳ 11° by GGX's tail: at least 99.9% of them),
/// and its energy albedo is 1 within 5 standard errors and the 1e-3 masking allowance of
/// `volume_white_furnace`.
#[test]
fn total_internal_reflection() {
    let m = glass(0.0, 1.5, false);
    let critical = (1.0f32 - 1.0 / 2.25).sqrt(); // cos θc = 0.745
    assert_eq!(m.dielectric_fresnel(-(critical - 1e-3)), 1.0);
    assert_eq!(m.dielectric_fresnel(-0.3), 1.0);
    // Total: 1 whatever the specular weight, which scales only Schlick's F.
    let weak =
        MetallicRoughness::with_specular(Vec3::ONE, 0.0, 0.0, 0.5).with_transmission(1.0, false);
    assert_eq!(weak.dielectric_fresnel(-0.3), 1.0);
    assert!(weak.dielectric_fresnel(-1.0) < 0.05);
    assert!(m.dielectric_fresnel(-(critical + 1e-3)) < 1.0);
    assert!(m.dielectric_fresnel(-1.0) < 0.05);
    // From outside there is no total reflection.
    assert!(m.dielectric_fresnel(0.3) < 1.0);
    let wo = -direction(0.6);
    let n = 20_000u64;
    let (mut sum, mut sum2, mut beyond) = (0.0f64, 0.0f64, 0u64);
    for i in 0..n {
        let key = SampleKey::new(4, 0, i);
        let u = key.uniform_2d(1);
        let Some(s) = m.sample(wo, key.uniform(0), u) else {
            continue;
        };
        let wm = sample_visible_normal(-wo, m.alpha(), u);
        let c = f64::from(-wo.dot(wm));
        let mut w = f64::from(s.f.x * s.wi.z.abs() / s.pdf);
        if 2.25 * (1.0 - c * c) > 1.0 {
            beyond += 1;
            assert!(s.wi.z < 0.0 && s.lobe == Lobe::Glossy, "{s:?}");
        } else if s.lobe == Lobe::Transmission {
            w *= 1.0 / 2.25;
        }
        sum += w;
        sum2 += w * w;
    }
    assert!(beyond as f64 >= 0.999 * n as f64, "{beyond}");
    let mean = sum / n as f64;
    let se = ((sum2 / n as f64 - mean * mean).max(0.0) / (n - 1) as f64).sqrt();
    assert!(
        (mean - 1.0).abs() <= 5.0 * se + 1e-3 + 1e-5,
        "{mean} ± {se}"
    );
}

proptest! {
    /// The density that `sample` reports equals `pdf(wo, wi)`, and its value `eval`'s, for
    /// transmitting materials on both sides. A diffuse sample's density is the same computation
    /// (equal bits). Otherwise the sample takes D, F and the Jacobian at the drawn facet and
    /// `pdf` at the facet recomputed from wi: for reflection within the bound of the opaque
    /// material's test (16ε + 10ε/(α cos θvh)); for refraction `btdf_tolerance` (which bounds
    /// the recomputed facet's error and its effect) plus the same 16ε. From inside, the choice
    /// between reflection and refraction depends on F at the facet, through Snell's
    /// cos θt = √(1 − η² sin²θ), whose slope η² cos θ / cos θt is unbounded at the critical
    /// angle: its effect, 5 η² cos θ/cos θt · δ/min(F, 1 − F) with δ the facet's error, is
    /// added, and facets within cos θt < 0.05 of the critical angle are skipped.
    #[test]
    fn transmitting_sampled_pdf_matches_pdf(
        m in transmitting(),
        wo in sphere(),
        u_lobe in 0.0f32..1.0,
        u in unit_square(),
    ) {
        let wo = if m.is_thin_walled() && wo.z < 0.0 { -wo } else { wo };
        let Some(s) = m.sample(wo, u_lobe, u) else { return Ok(()); };
        prop_assert!((s.wi.length() - 1.0).abs() < 1e-5);
        prop_assert_eq!(s.lobe == Lobe::Transmission, s.wi.z * wo.z < 0.0);
        let (pdf, f) = (m.pdf(wo, s.wi), m.eval(wo, s.wi));
        if s.lobe == Lobe::Diffuse {
            prop_assert_eq!(s.pdf, pdf);
            prop_assert_eq!(bits(s.f), bits(f));
            return Ok(());
        }
        let (wo64, wi64) = (wo.as_dvec3(), s.wi.as_dvec3());
        let alpha = f64::from(m.alpha());
        let eta = f64::from(m.ior().max(MIN_VOLUME_IOR));
        let refracted = s.lobe == Lobe::Transmission && !m.is_thin_walled();
        let (tol, facet, delta) = if refracted {
            let (f0, sw) = (f64::from(m.dielectric_f0()), f64::from(m.specular()));
            let etap = if wo.z > 0.0 { eta } else { 1.0 / eta };
            let sum = wo64 + etap * wi64;
            (
                16.0 * EPS + btdf_tolerance(wo64, wi64, eta, alpha, f0, sw),
                sum.normalize(),
                (1.0 + etap) * 2.0 * EPS / sum.length(),
            )
        } else {
            // Reflection, or the pane's transmission, which is the reflection mirrored.
            let wr = if s.wi.z * wo.z < 0.0 { mirror(s.wi).as_dvec3() } else { wi64 };
            let h = (wo64 + wr).normalize();
            let cos_vh = wo64.dot(h).abs();
            (16.0 * EPS + 10.0 * EPS / (alpha * cos_vh), h, 4.5 * EPS / cos_vh)
        };
        let mut tol = tol;
        if wo.z < 0.0 {
            let c = wo64.dot(facet).abs();
            let sin2_t = eta * eta * (1.0 - c * c);
            prop_assume!(sin2_t > 1.0 || (1.0 - sin2_t).sqrt() >= 0.05);
            if sin2_t < 1.0 {
                let cos_t = (1.0 - sin2_t).sqrt();
                let fr = f64::from(m.dielectric_fresnel(-(c as f32)));
                prop_assume!(fr.min(1.0 - fr) > 1e-3);
                tol += 5.0 * eta * eta * c / cos_t * (delta + 2.0 * EPS) / fr.min(1.0 - fr);
            }
        }
        let rel = (f64::from(s.pdf) / f64::from(pdf) - 1.0).abs();
        prop_assert!(rel <= tol, "{:?}: pdf {} vs {pdf}: {rel:e} > {tol:e}", s.lobe, s.pdf);
        // The value's Fresnel factors move with the facet too: the opaque material's test
        // allows 300ε for them (Schlick's slope ≤ 5 over factors ≥ 1/60); refraction's are in
        // `btdf_tolerance` already.
        let tol_f = if refracted { tol } else { tol + 300.0 * EPS };
        for c in 0..3 {
            let (a, b) = (f64::from(s.f[c]), f64::from(f[c]));
            prop_assert!(
                (a - b).abs() <= tol_f * b.abs() + 1e-30,
                "{:?}: f {} vs {}", s.lobe, s.f, f
            );
        }
    }
}

/// Chi-square fits over the whole sphere of `sample` (lobe choice included) against `pdf`, for
/// thin panes, a volume seen from outside, and from inside below and beyond the critical angle
/// (see `testing::chi2_directions` for the binning, pooling and significance level).
#[test]
fn transmitting_sampler_fits_its_pdf() {
    let cases = [
        // (base, metallic, roughness, transmission, ior, thin, cos θo)
        (Vec3::ONE, 0.0f32, 0.3f32, 1.0f32, 1.5f32, true, 0.6f32),
        (Vec3::new(0.8, 0.5, 0.2), 0.2, 0.5, 0.5, 1.5, true, 0.9),
        (Vec3::ONE, 0.0, 0.3, 1.0, 1.5, false, 0.7),
        (Vec3::new(0.9, 0.7, 0.4), 0.1, 0.6, 0.7, 1.33, false, 0.3),
        (Vec3::ONE, 0.0, 0.4, 1.0, 1.5, false, -0.85),
        (Vec3::ONE, 0.0, 0.4, 1.0, 1.5, false, -0.6),
        (Vec3::new(0.5, 0.5, 0.9), 0.0, 0.8, 0.6, 2.0, false, -0.3),
    ];
    for (case, &(base, metallic, roughness, t, ior, thin, cos_o)) in cases.iter().enumerate() {
        let m = MetallicRoughness::new(base, metallic, roughness)
            .with_ior(ior)
            .with_transmission(t, thin);
        let wo = if cos_o > 0.0 {
            direction(cos_o)
        } else {
            -direction(-cos_o)
        };
        let result = testing::chi2_sphere(
            200_000,
            |i| {
                let key = SampleKey::new(8, case as u64, i);
                m.sample(wo, key.uniform(0), key.uniform_2d(1))
                    .map(|s| s.wi)
            },
            |wi| m.pdf(wo, wi),
        );
        eprintln!(
            "transmitting case {case} (thin {thin}, roughness {roughness}, cos θo {cos_o}): {result}"
        );
        assert!(result.passes(), "case {case}: {result}");
    }
}

/// The diffuse lobe's albedo with transmission and another ior, (1 − metallic)(1 − t) base
/// (1 − s (1 − (1 − F0)(1 − S))), against f64 quadrature of the lobe as the specification writes
/// it with F = s (F0 + (1 − F0)(1 − |wo·h|)⁵). Tolerance: the fit's absolute error in S, 4.25e-6,
/// times 1 − F0 ≤ 1 and the weight ≤ 1; the quadrature's (the 256² − 128² difference); 1e-6 for
/// the f32 arithmetic. It keeps the irradiance cache's stand-in exact under uniform light.
#[test]
fn diffuse_albedo_with_transmission_and_ior() {
    let base = DVec3::new(0.8, 0.4, 0.1);
    for (t, ior, specular, thin) in [
        (0.3f32, 1.33f32, 1.0f32, true),
        (1.0, 1.5, 1.0, false),
        (0.6, 2.0, 0.5, false),
    ] {
        let metallic = 0.25f32;
        let m = MetallicRoughness::with_specular(base.as_vec3(), metallic, 0.5, specular)
            .with_ior(ior)
            .with_transmission(t, thin);
        let f0 = f64::from(m.dielectric_f0());
        for cos_o in [1.0f32, 0.5, 0.05] {
            let wo = direction(cos_o).as_dvec3();
            let quad = |cells| {
                hemisphere_quadrature3(1.0, cells, |wi| {
                    let c = wo.dot((wo + wi).normalize());
                    let f = f64::from(specular) * (f0 + (1.0 - f0) * (1.0 - c).powi(5));
                    base * ((1.0 - f64::from(metallic)) * (1.0 - f64::from(t)) * (1.0 - f) / PI
                        * wi.z)
                })
            };
            let (fine, coarse) = (quad(256), quad(128));
            let got = m.diffuse_albedo(wo.as_vec3()).as_dvec3();
            for c in 0..3 {
                let tol = 4.25e-6 + (fine[c] - coarse[c]).abs() + 1e-6;
                assert!(
                    (got[c] - fine[c]).abs() <= tol,
                    "t {t} ior {ior} cos θo {cos_o} [{c}]: {} vs {} (tol {tol:.1e})",
                    got[c],
                    fine[c]
                );
            }
            // And the diffuse lobe itself integrates to it (the lobe the sampler evaluates).
            let lobe = hemisphere_quadrature3(1.0, 256, |wi| {
                m.eval_lobes(wo.as_vec3(), wi.as_vec3()).diffuse.as_dvec3() * wi.z
            });
            for c in 0..3 {
                let tol = 4.25e-6 + (fine[c] - coarse[c]).abs() + 2e-6;
                assert!((got[c] - lobe[c]).abs() <= tol, "{} vs {}", got[c], lobe[c]);
            }
        }
    }
}

/// A sheet whose transmission passes straight (`with_straight_transmission`) keeps its
/// reflection exactly and loses its transmission lobe: eval, pdf and samples below the surface
/// are zero or absent, the values above are the thin sheet's own, bit for bit; and for a smooth
/// white pane the reflection it keeps plus the straight transmittance is the white furnace's 1
/// (the same bound as `thin_pane_white_furnace`: 5 standard errors + 1e-4 for the smooth lobe's
/// masking + 1e-5 for f32 weights). `sheet_transmittance` is `straight_transmittance` where the
/// latter is defined (smooth and thin), and the straight ray's pane formula elsewhere.
#[test]
fn straight_transmission_leaves_the_reflection() {
    let mut stream = 1000;
    for roughness in [0.0f32, 0.5] {
        let thin = glass(roughness, 1.5, true);
        let straight = thin.with_straight_transmission();
        assert!(straight.is_straight() && straight.is_thin_walled());
        for cos_o in [1.0f32, 0.5, 0.2] {
            stream += 1;
            let wo = direction(cos_o);
            for k in 0..64 {
                let key = SampleKey::new(5, stream, k);
                let wi = irr_sampling::sample_uniform_sphere(key.uniform_2d(0));
                if wi.z > 0.0 {
                    assert_eq!(straight.eval(wo, wi), thin.eval(wo, wi));
                } else {
                    assert_eq!(straight.eval(wo, wi), Vec3::ZERO);
                    assert_eq!(straight.pdf(wo, wi), 0.0);
                }
                if let Some(s) = straight.sample(wo, key.uniform(1), key.uniform_2d(2)) {
                    assert!(s.wi.z > 0.0 && s.lobe != Lobe::Transmission, "{s:?}");
                }
            }
            let t = straight.sheet_transmittance(cos_o);
            if roughness == 0.0 {
                assert_eq!(Some(t), thin.straight_transmittance(cos_o));
                let e = estimate(&straight, wo, 40_000, stream);
                assert_eq!(e.transmitted.0, 0.0);
                let sum = e.reflected.0 + f64::from(t.x);
                let tol = 5.0 * e.reflected.1 + 1e-4 + 1e-5;
                assert!((sum - 1.0).abs() <= tol, "cos θo {cos_o}: R + T = {sum}");
            } else {
                assert_eq!(thin.straight_transmittance(cos_o), None);
                assert_eq!(t, glass(0.0, 1.5, true).sheet_transmittance(cos_o));
            }
        }
    }
}
