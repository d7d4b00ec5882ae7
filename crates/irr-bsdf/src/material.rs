//! The glTF 2.0 metallic-roughness material (specification, Appendix B): its evaluation, its
//! lobes, and their importance sampling; with `KHR_materials_ior` and
//! `KHR_materials_transmission` (in [`transmission`]).

use crate::fresnel::{DIELECTRIC_F0, dielectric_diffuse_albedo_f0, schlick_weight};
use crate::microfacet::{ggx_d, sample_visible_normal, smith_g1, visibility};
use glam::{Vec2, Vec3};
use irr_sampling::{cosine_hemisphere_pdf, sample_cosine_hemisphere};
use std::f32::consts::FRAC_1_PI;

/// The smallest GGX width α = roughness² the material uses: rougher values are kept, smoother
/// ones (roughness below √1e-3 ≈ 0.032, including 0) are raised to it.
///
/// At α = 0 the distribution D is a Dirac delta (its formula gives 0/0 at the peak), which a
/// function returning finite values cannot represent; a perfectly specular (delta) lobe is out of
/// this crate's scope. pbrt-v4 treats α < 1e-3 as effectively smooth and switches to such a delta
/// lobe; here the glossy lobe is kept rough down to α = 1e-3 instead: a lobe ~0.1° wide, a mirror
/// to the eye, whose peak D = 1/(π α²) ≈ 3.2e5 is finite and whose sampled weights f·cos/pdf stay
/// ≤ 1, so every estimator of the renderer keeps working unchanged.
pub const MIN_ALPHA: f32 = 1e-3;

/// The parameters of the glTF 2.0 metallic-roughness material at one shading point, clamped into
/// their ranges: base colour (linear RGB) in [0, 1]³, metallic, roughness and the dielectric's
/// specular weight (`KHR_materials_specular`'s `specularFactor`, 1 without the extension) in
/// [0, 1].
///
/// `KHR_materials_ior`'s index of refraction (1.5 unless given by
/// [`with_ior`](Self::with_ior)) sets the dielectric's reflectance at normal incidence, F0 =
/// ((ior − 1)/(ior + 1))² (0.04 at 1.5); `KHR_materials_transmission`'s factor (0 unless given by
/// [`with_transmission`](Self::with_transmission)) turns part of the dielectric's diffuse base
/// into a transmission lobe, thin-walled or volumetric (the crate documentation describes the
/// model).
///
/// Immutable: the constructors clamp, and derive the GGX width and the glossy lobe's Fresnel
/// reflectances at normal and grazing incidence once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MetallicRoughness {
    base_color: Vec3,
    metallic: f32,
    roughness: f32,
    specular: f32,
    alpha: f32,
    f0: Vec3,
    f90: Vec3,
    /// The index of refraction in [1, [`MAX_IOR`]], or +∞ (`KHR_materials_ior`'s ior = 0).
    ior: f32,
    /// ((ior − 1)/(ior + 1))², before the specular weight.
    dielectric_f0: f32,
    /// `KHR_materials_transmission`'s factor in [0, 1].
    transmission: f32,
    /// Whether the transmission is through a thin sheet (no `KHR_materials_volume`) rather than
    /// into a volume.
    thin_walled: bool,
    /// Whether the thin sheet's transmission is left to the renderer's straight rays
    /// ([`with_straight_transmission`](Self::with_straight_transmission)): no transmission lobe.
    straight: bool,
}

/// One of the material's lobes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Lobe {
    /// The Lambertian base of the dielectric, weighted by (1 − metallic)(1 − transmission)(1 − F).
    Diffuse,
    /// The GGX microfacet reflection of both the dielectric and the metal (and, from inside a
    /// volumetric material, the reflection at its boundary).
    Glossy,
    /// The GGX microfacet transmission of a transmitting dielectric: `wi` on the other side of
    /// the surface from `wo`.
    Transmission,
}

/// The BSDF split into its lobes; their sum is the BSDF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lobes {
    /// (1 − metallic) · (1 − transmission) · (1 − F_dielectric(|wo·h|)) · base_color / π, with
    /// F_dielectric = s·(F0 + (1 − F0)(1 − |wo·h|)⁵) for specular weight s and F0 from the ior
    /// (0.04 at ior 1.5). Zero unless both directions lie above the surface.
    pub diffuse: Vec3,
    /// F(|wo·h|) · D(h) · ν(wo, wi), with F Schlick's from f0 = mix(F0 s, base_color, metallic)
    /// to f90 = mix(s, 1, metallic); plus, for a thin-walled transmitting material, the pane's
    /// back-surface reflection τ F_d (1 − F_d)/(1 + F_d) · D ν (τ = (1 − metallic) ·
    /// transmission · base_color, F_d = F_dielectric). From inside a volumetric material
    /// (both directions below the surface), its boundary's reflection F_inside · D ν.
    pub glossy: Vec3,
    /// The transmission lobe, non-zero only for `wi` on the other side of the surface from `wo`:
    /// τ (1 − F_d)/(1 + F_d) · D ν at `wi` mirrored through the surface (thin-walled), or the
    /// rough dielectric BTDF (volumetric; Walter et al. 2007, eq. 21, for radiance). Zero
    /// without transmission.
    pub transmission: Vec3,
}

impl Lobes {
    /// All lobes zero.
    pub const ZERO: Self = Self {
        diffuse: Vec3::ZERO,
        glossy: Vec3::ZERO,
        transmission: Vec3::ZERO,
    };

    /// The BSDF: diffuse + glossy + transmission.
    #[inline]
    pub fn total(self) -> Vec3 {
        self.diffuse + self.glossy + self.transmission
    }
}

/// A direction drawn by one of the samplers, with what an estimator needs: its contribution is
/// `f * |wi.z| / pdf` times the incident radiance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// The incident direction (local frame, unit): on `wo`'s side of the surface for the
    /// reflection lobes, on the other side (`wi.z` of the opposite sign) for
    /// [`Lobe::Transmission`].
    pub wi: Vec3,
    /// The BSDF value that the sampler stands for (the whole BSDF for
    /// [`MetallicRoughness::sample`], one lobe for [`MetallicRoughness::sample_glossy`]).
    pub f: Vec3,
    /// The density of `wi` per unit solid angle, positive.
    pub pdf: f32,
    /// The lobe that was sampled.
    pub lobe: Lobe,
}

/// A number clamped into [0, 1], with NaN read as 0.
#[inline]
fn unit_interval(x: f32) -> f32 {
    if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) }
}

/// Rec. 709 luminance of a linear RGB colour: the weight that lobe selection compares, and
/// that renderers built on these crates rank colours by.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

impl MetallicRoughness {
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
            ior: 1.5,
            dielectric_f0: DIELECTRIC_F0,
            transmission: 0.0,
            thin_walled: true,
            straight: false,
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

    /// The glossy lobe's reflectance at normal incidence, mix(F0 s, base_color, metallic) for
    /// specular weight s and the dielectric's F0 ([`dielectric_f0`](Self::dielectric_f0), 0.04
    /// at ior 1.5).
    pub fn specular_f0(&self) -> Vec3 {
        self.f0
    }

    /// The glossy lobe's reflectance at grazing incidence, mix(s, 1, metallic) for specular
    /// weight s: 1 without `KHR_materials_specular`.
    pub fn specular_f90(&self) -> Vec3 {
        self.f90
    }

    /// Whether the glossy lobe is zero everywhere (a dielectric of specular weight 0) and the
    /// material does not transmit: it is then exactly Lambertian, f = base_color/π, and an
    /// integrator can shade it as such (cosine sampling, no Fresnel).
    pub fn is_lambertian(&self) -> bool {
        self.f90 == Vec3::ZERO && self.transmission == 0.0
    }

    /// Both lobes for half vector `wm` and |wo·wm| = `cos_vh`.
    #[inline]
    ///
    /// Both directions lie above the surface. With transmission, the diffuse lobe is scaled by
    /// 1 − transmission and, thin-walled, the glossy lobe gains the pane's back-surface
    /// reflection; without, the arithmetic is the plain material's.
    fn lobes_at(&self, wo: Vec3, wi: Vec3, wm: Vec3, cos_vh: f32) -> Lobes {
        let w = schlick_weight(cos_vh);
        let dielectric_fresnel =
            self.specular * (self.dielectric_f0 + (1.0 - self.dielectric_f0) * w);
        let d_nu = ggx_d(wm, self.alpha) * visibility(wo, wi, self.alpha);
        let mut lobes = Lobes {
            diffuse: self.base_color
                * ((1.0 - self.metallic) * (1.0 - dielectric_fresnel) * FRAC_1_PI),
            glossy: (self.f0 + (self.f90 - self.f0) * w) * d_nu,
            transmission: Vec3::ZERO,
        };
        if self.transmission > 0.0 {
            lobes.diffuse *= 1.0 - self.transmission;
            if self.thin_walled {
                lobes.glossy +=
                    self.transmittance_tint() * (pane_back_reflection(dielectric_fresnel) * d_nu);
            }
        }
        lobes
    }

    /// The BSDF's lobes for unit directions `wo` (towards the viewer) and `wi` (towards the
    /// light), both pointing away from the surface in the local frame (normal +z). Without
    /// transmission: zero unless both lie strictly above the surface. With transmission:
    /// thin-walled, `wo` must lie above (zero otherwise) and `wi` below gives the transmission
    /// lobe; volumetric, `wo` below the surface is a viewer inside the object (the normal must
    /// then be the outward one, not flipped to the viewer), and any `wi` off the tangent plane
    /// counts.
    ///
    /// The half vector h = (wo + wi)/|wo + wi| and |V·H| = |wo·h| = |wo + wi|/2 (equal for unit
    /// vectors) are computed from the sum only, so reflection is reciprocal bit for bit:
    /// `eval_lobes(wo, wi) == eval_lobes(wi, wo)` (the volumetric transmission lobe is
    /// reciprocal in the form f(wo, wi)/η_o² = f(wi, wo)/η_i², η the ior on each one's side).
    #[inline]
    pub fn eval_lobes(&self, wo: Vec3, wi: Vec3) -> Lobes {
        if self.transmission > 0.0 {
            return self.transmitting_lobes(wo, wi);
        }
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Lobes::ZERO;
        }
        let sum = wo + wi;
        let len = sum.length();
        self.lobes_at(wo, wi, sum / len, (0.5 * len).min(1.0))
    }

    /// The BSDF f(wo, wi) (not multiplied by |cos θi|): `eval_lobes(wo, wi).total()`.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.eval_lobes(wo, wi).total()
    }

    /// The directional albedo of the diffuse lobe, ∫ f_diffuse(wo, wi) cos θi dωi =
    /// (1 − metallic) · (1 − transmission) · base_color · (1 − s (1 − ρ(cos θo))) with ρ =
    /// [`crate::dielectric_diffuse_albedo_f0`] at the ior's F0 and s the specular weight (the
    /// lobe's weight 1 − s·F is affine in s; zero for `wo` below the surface): the factor by which an irradiance cache multiplies its
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
        let weight =
            1.0 - self.specular * (1.0 - dielectric_diffuse_albedo_f0(wo.z, self.dielectric_f0));
        self.base_color * ((1.0 - self.metallic) * (1.0 - self.transmission) * weight)
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
    ///
    /// With transmission the transmission lobe's estimate joins the two
    /// ([`transmission_probability`](Self::transmission_probability)); for `wo` below the
    /// surface (inside a volumetric material), where [`sample`](Self::sample) chooses between
    /// reflection and refraction per microfacet, this is 1 (as for any `wo` below without
    /// transmission).
    #[inline]
    pub fn glossy_probability(&self, wo: Vec3) -> f32 {
        if self.transmission > 0.0 {
            return self.outside_probabilities(wo).0;
        }
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
    ///
    /// With transmission, `u_lobe` chooses among three lobes (glossy, transmission, diffuse, in
    /// that order along [0, 1)) for `wo` above the surface; for `wo` inside a volumetric material
    /// it chooses reflection or refraction at the drawn microfacet, by that facet's Fresnel
    /// weights (so total internal reflection is never lost). A transmitted `wi` lies on the other
    /// side of the surface; the weight is then `f * |wi.z| / pdf`.
    #[inline]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if self.transmission > 0.0 {
            return self.sample_transmitting(wo, u_lobe, u);
        }
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
    /// lie above the surface. With transmission, the mixture of all three lobes, over both
    /// hemispheres (as [`sample`](Self::sample) draws).
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.transmission > 0.0 {
            return self.transmitting_pdf(wo, wi);
        }
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        self.mixture_pdf(wo, wi, self.glossy_probability(wo))
    }
}

#[cfg(test)]
mod legacy;
#[cfg(test)]
mod tests;
mod transmission;

use transmission::pane_back_reflection;
pub use transmission::{MAX_IOR, MIN_VOLUME_IOR, SMOOTH_ALPHA};
