//! A frozen copy of the material as it was before transmission and `KHR_materials_ior` were
//! added (its struct renamed `Legacy`), kept only so that a test can check that the material
//! without transmission and with ior 1.5 computes the same bits as before.

#![allow(dead_code, clippy::all)]

use super::{BsdfSample, Lobe, MIN_ALPHA, luminance};
use crate::fresnel::{DIELECTRIC_F0, schlick_weight};
use crate::microfacet::{ggx_d, sample_visible_normal, smith_g1, visibility};
use glam::{Vec2, Vec3};
use irr_sampling::{cosine_hemisphere_pdf, sample_cosine_hemisphere};
use std::f32::consts::FRAC_1_PI;

/// The two lobes as they were.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lobes {
    pub diffuse: Vec3,
    pub glossy: Vec3,
}

impl Lobes {
    pub const ZERO: Self = Self {
        diffuse: Vec3::ZERO,
        glossy: Vec3::ZERO,
    };

    #[inline]
    pub fn total(self) -> Vec3 {
        self.diffuse + self.glossy
    }
}

/// The parameters of the glTF 2.0 metallic-roughness material at one shading point, clamped into
/// their ranges: base colour (linear RGB) in [0, 1]³, metallic, roughness and the dielectric's
/// specular weight (`KHR_materials_specular`'s `specularFactor`, 1 without the extension) in
/// [0, 1].
///
/// Immutable: the constructors clamp, and derive the GGX width and the glossy lobe's Fresnel
/// reflectances at normal and grazing incidence once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Legacy {
    base_color: Vec3,
    metallic: f32,
    roughness: f32,
    specular: f32,
    alpha: f32,
    f0: Vec3,
    f90: Vec3,
}

/// The fresnel module's dielectric diffuse albedo as it was (its fit at F0 = 0.04).
const HALF_VECTOR_SCHLICK_MEAN: [f32; 5] = [
    0.028_159_764,
    -0.079_744_43,
    0.085_935_13,
    -0.042_827_413,
    0.008_554_594,
];

#[inline]
fn dielectric_diffuse_albedo(cos_theta_o: f32) -> f32 {
    let c = cos_theta_o.clamp(0.0, 1.0);
    let [c0, c1, c2, c3, c4] = HALF_VECTOR_SCHLICK_MEAN;
    let s = c0 + c * (c1 + c * (c2 + c * (c3 + c * c4)));
    (1.0 - DIELECTRIC_F0) * (1.0 - s)
}

/// A number clamped into [0, 1], with NaN read as 0.
#[inline]
fn unit_interval(x: f32) -> f32 {
    if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) }
}

impl Legacy {
    /// The material with these parameters, each clamped into [0, 1] (NaN read as 0), and the
    /// specification's full specular reflection (specular weight 1). The GGX width is
    /// α = max(roughness², [`MIN_ALPHA`]).
    pub fn new(base_color: Vec3, metallic: f32, roughness: f32) -> Self {
        Self::with_specular(base_color, metallic, roughness, 1.0)
    }

    /// [`new`](Self::new) with the dielectric's specular weight s (`KHR_materials_specular`'s
    /// `specularFactor`, clamped into [0, 1]), which scales its Fresnel term from F0 = 0.04 s to
    /// F90 = s: s = 0 leaves the dielectric a pure Lambertian reflector of `base_color`, whose
    /// glossy lobe is zero (with metallic 0, [`is_lambertian`](Self::is_lambertian)). Metals
    /// are unaffected.
    pub fn with_specular(base_color: Vec3, metallic: f32, roughness: f32, specular: f32) -> Self {
        let base_color = Vec3::new(
            unit_interval(base_color.x),
            unit_interval(base_color.y),
            unit_interval(base_color.z),
        );
        let metallic = unit_interval(metallic);
        let roughness = unit_interval(roughness);
        let specular = unit_interval(specular);
        Self {
            base_color,
            metallic,
            roughness,
            specular,
            alpha: (roughness * roughness).max(MIN_ALPHA),
            // Schlick's F is affine in (f0, f90), so mix(F_dielectric, F_metal, metallic) is F
            // with mixed f0 and f90: the dielectric's and the metal's specular terms share one
            // lobe.
            f0: Vec3::splat(DIELECTRIC_F0 * specular).lerp(base_color, metallic),
            f90: Vec3::splat(specular).lerp(Vec3::ONE, metallic),
        }
    }

    /// The base colour, linear RGB in [0, 1]³.
    pub fn base_color(&self) -> Vec3 {
        self.base_color
    }

    /// The metallic factor in [0, 1].
    pub fn metallic(&self) -> f32 {
        self.metallic
    }

    /// The (perceptual) roughness in [0, 1], as given after clamping.
    pub fn roughness(&self) -> f32 {
        self.roughness
    }

    /// The dielectric's specular weight in [0, 1] (1 unless given by
    /// [`with_specular`](Self::with_specular)).
    pub fn specular(&self) -> f32 {
        self.specular
    }

    /// The GGX width α = max(roughness², [`MIN_ALPHA`]).
    pub fn alpha(&self) -> f32 {
        self.alpha
    }

    /// The glossy lobe's reflectance at normal incidence, mix(0.04 s, base_color, metallic) for
    /// specular weight s.
    pub fn specular_f0(&self) -> Vec3 {
        self.f0
    }

    /// The glossy lobe's reflectance at grazing incidence, mix(s, 1, metallic) for specular
    /// weight s: 1 without `KHR_materials_specular`.
    pub fn specular_f90(&self) -> Vec3 {
        self.f90
    }

    /// Whether the glossy lobe is zero everywhere (a dielectric of specular weight 0): the
    /// material is then exactly Lambertian, f = base_color/π, and an integrator can shade it as
    /// such (cosine sampling, no Fresnel).
    pub fn is_lambertian(&self) -> bool {
        self.f90 == Vec3::ZERO
    }

    /// Both lobes for half vector `wm` and |wo·wm| = `cos_vh`.
    #[inline]
    fn lobes_at(&self, wo: Vec3, wi: Vec3, wm: Vec3, cos_vh: f32) -> Lobes {
        let w = schlick_weight(cos_vh);
        let dielectric_fresnel = self.specular * (DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * w);
        Lobes {
            diffuse: self.base_color
                * ((1.0 - self.metallic) * (1.0 - dielectric_fresnel) * FRAC_1_PI),
            glossy: (self.f0 + (self.f90 - self.f0) * w)
                * (ggx_d(wm, self.alpha) * visibility(wo, wi, self.alpha)),
        }
    }

    /// The BRDF's two lobes for unit directions `wo` (towards the viewer) and `wi` (towards the
    /// light), both pointing away from the surface in the local frame (normal +z). Zero unless
    /// both lie strictly above the surface.
    ///
    /// The half vector h = (wo + wi)/|wo + wi| and |V·H| = |wo·h| = |wo + wi|/2 (equal for unit
    /// vectors) are computed from the sum only, so the result is reciprocal bit for bit:
    /// `eval_lobes(wo, wi) == eval_lobes(wi, wo)`.
    #[inline]
    pub fn eval_lobes(&self, wo: Vec3, wi: Vec3) -> Lobes {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Lobes::ZERO;
        }
        let sum = wo + wi;
        let len = sum.length();
        self.lobes_at(wo, wi, sum / len, (0.5 * len).min(1.0))
    }

    /// The BRDF f(wo, wi) (not multiplied by cos θi): `eval_lobes(wo, wi).total()`.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.eval_lobes(wo, wi).total()
    }

    /// The directional albedo of the diffuse lobe, ∫ f_diffuse(wo, wi) cos θi dωi =
    /// (1 − metallic) · base_color · (1 − s (1 − ρ(cos θo))) with ρ =
    /// [`crate::dielectric_diffuse_albedo`] and s the specular weight (the lobe's weight
    /// 1 − s·F is affine in s; zero for `wo` below the surface): the factor by which an irradiance cache multiplies its
    /// cached irradiance E, as `diffuse_albedo(wo) / π · E`, to stand for the diffuse lobe's
    /// reflected indirect light.
    ///
    /// That stand-in replaces the lobe's h-dependent (1 − F(|wo·h|)) by its cosine-weighted mean
    /// over wi. It is exact when the incident light is uniform; the crate documentation gives its
    /// error otherwise.
    #[inline]
    pub fn diffuse_albedo(&self, wo: Vec3) -> Vec3 {
        if wo.z <= 0.0 {
            return Vec3::ZERO;
        }
        let weight = 1.0 - self.specular * (1.0 - dielectric_diffuse_albedo(wo.z));
        self.base_color * ((1.0 - self.metallic) * weight)
    }

    /// The probability with which [`sample`](Self::sample) chooses the glossy lobe for `wo`:
    /// the share of the glossy lobe in an estimate of the two lobes' albedos, by luminance. The
    /// glossy estimate is Schlick's F at cos θo with the material's f0 and f90 (the GGX lobe reflects
    /// about F at low roughness, less when rough); the diffuse one is the exact
    /// [`diffuse_albedo`](Self::diffuse_albedo).
    ///
    /// Positive whenever the glossy lobe can be non-zero (f90 > 0), below 1 whenever the diffuse
    /// lobe can be (metallic < 1 and a non-black base colour): each lobe is sampled wherever it
    /// contributes, so the mixture estimator is unbiased.
    #[inline]
    pub fn glossy_probability(&self, wo: Vec3) -> f32 {
        let cos_o = wo.z.clamp(0.0, 1.0);
        let glossy = luminance(self.f0 + (self.f90 - self.f0) * schlick_weight(cos_o));
        let diffuse = luminance(self.diffuse_albedo(wo));
        let total = glossy + diffuse;
        if total > 0.0 { glossy / total } else { 1.0 }
    }

    /// The density, per unit solid angle of wi, of reflecting a visible normal wm drawn for `wo`:
    /// D_wo(wm) / (4 |wo·wm|) (Walter et al. 2007, eq. 14) = G1(wo) D(wm) / (4 cos θo), since
    /// D_wo(wm) = G1(wo) (wo·wm) D(wm) / cos θo.
    #[inline]
    fn reflected_pdf(&self, wo: Vec3, wm: Vec3) -> f32 {
        smith_g1(wo, self.alpha) * ggx_d(wm, self.alpha) / (4.0 * wo.z)
    }

    /// Draws the glossy lobe's incident direction for `wo` from `u`: a visible normal wm (Heitz
    /// 2018) reflected about, wi = 2 (wo·wm) wm − wo. `None` when `wo` is below the surface or
    /// the reflection goes below it (the lobe's shadowed share: the sample's weight is then zero).
    ///
    /// The sample's `f` is the glossy lobe alone, its `pdf` [`glossy_pdf`](Self::glossy_pdf): the
    /// weight `f * wi.z / pdf` = F · G2(wo, wi) / G1(wo) ≤ F. For an integrator that takes the
    /// diffuse lobe's indirect light from an irradiance cache and traces the glossy lobe.
    #[inline]
    pub fn sample_glossy(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let (wi, wm, cos_vh) = self.reflect_visible_normal(wo, u)?;
        let pdf = self.reflected_pdf(wo, wm);
        (pdf > 0.0).then(|| BsdfSample {
            wi,
            f: self.lobes_at(wo, wi, wm, cos_vh).glossy,
            pdf,
            lobe: Lobe::Glossy,
        })
    }

    /// A visible normal wm drawn for `wo` from `u` (Heitz 2018) and `wo` reflected about it:
    /// (wi, wm, wo·wm), or `None` when the reflection goes below the surface (the lobe's
    /// shadowed share). The glossy lobe's value and density are then taken at wm rather than at
    /// the half vector recomputed from wi, so D(wm) cancels exactly in the sample's weight.
    #[inline]
    fn reflect_visible_normal(&self, wo: Vec3, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
        let wm = sample_visible_normal(wo, self.alpha, u);
        let cos_vh = wo.dot(wm);
        let wi = 2.0 * cos_vh * wm - wo;
        (wi.z > 0.0 && cos_vh > 0.0).then_some((wi, wm, cos_vh))
    }

    /// The density of [`sample_glossy`](Self::sample_glossy) at `wi`: G1(wo) D(h) / (4 cos θo)
    /// with h the half vector; zero unless both directions lie above the surface.
    #[inline]
    pub fn glossy_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        self.reflected_pdf(wo, (wo + wi).normalize())
    }

    /// The mixture density of [`sample`](Self::sample) given the glossy probability.
    #[inline]
    fn mixture_pdf(&self, wo: Vec3, wi: Vec3, glossy_probability: f32) -> f32 {
        glossy_probability * self.glossy_pdf(wo, wi)
            + (1.0 - glossy_probability) * cosine_hemisphere_pdf(wi.z)
    }

    /// Draws an incident direction for `wo` from the whole BRDF: `u_lobe` chooses the glossy
    /// lobe with probability [`glossy_probability`](Self::glossy_probability), else the diffuse
    /// one; `u` then draws wi from that lobe: a reflected visible normal (as
    /// [`sample_glossy`](Self::sample_glossy)) or a cosine-weighted direction
    /// (irr-sampling's `sample_cosine_hemisphere`).
    ///
    /// The sample's `f` is the whole BRDF and its `pdf` the mixture density of both lobes (as
    /// [`pdf`](Self::pdf) gives), so `f * wi.z / pdf` is the one-sample estimator's weight and
    /// `pdf` is what multiple importance sampling needs. `None` when `wo` is below the surface or
    /// the glossy reflection goes below it.
    #[inline]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let glossy_probability = self.glossy_probability(wo);
        if u_lobe < glossy_probability {
            let (wi, wm, cos_vh) = self.reflect_visible_normal(wo, u)?;
            let pdf = glossy_probability * self.reflected_pdf(wo, wm)
                + (1.0 - glossy_probability) * cosine_hemisphere_pdf(wi.z);
            (pdf > 0.0).then(|| BsdfSample {
                wi,
                f: self.lobes_at(wo, wi, wm, cos_vh).total(),
                pdf,
                lobe: Lobe::Glossy,
            })
        } else {
            let wi = sample_cosine_hemisphere(u);
            let pdf = self.mixture_pdf(wo, wi, glossy_probability);
            (wi.z > 0.0 && pdf > 0.0).then(|| BsdfSample {
                wi,
                f: self.eval(wo, wi),
                pdf,
                lobe: Lobe::Diffuse,
            })
        }
    }

    /// The density of [`sample`](Self::sample) at `wi` per unit solid angle: p · glossy_pdf +
    /// (1 − p) · cos θi / π with p the glossy probability for `wo`. Zero unless both directions
    /// lie above the surface.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        self.mixture_pdf(wo, wi, self.glossy_probability(wo))
    }
}
