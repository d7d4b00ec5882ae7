//! `KHR_materials_ior` and `KHR_materials_transmission`: the ior's validation, the transmission
//! lobe (a thin two-interface pane, or a rough dielectric boundary of a volume), its sampling and
//! density, and the straight-line transmittance of a smooth thin sheet for shadow rays.
//!
//! The model, its sources and its choices are stated in the crate documentation.

use super::{BsdfSample, Lobe, Lobes, MIN_ALPHA, MetallicRoughness, luminance, unit_interval};
use crate::fresnel::{dielectric_f0, schlick_weight};
use crate::microfacet::{ggx_d, sample_visible_normal, smith_g1, visibility};
use glam::{Vec2, Vec3};
use irr_sampling::{cosine_hemisphere_pdf, sample_cosine_hemisphere};

/// The largest finite index of refraction the material keeps; larger ones are lowered to it.
///
/// `KHR_materials_ior` sets no upper bound, but no real material comes close (diamond: 2.42,
/// germanium in the infrared: about 4). At 1000, F0 = (999/1001)² ≈ 0.996, within 0.4% of its
/// limit 1, and the squares that the refraction's Jacobian takes (η² ≤ 10⁶) stay far inside f32's
/// range, where (ior − 1)² would overflow for ior ≳ 1.8e19.
pub const MAX_IOR: f32 = 1000.0;

/// The least index of refraction a volumetric material refracts with: a smaller ior (in [1,
/// 1.01)) keeps its own F0 for the Fresnel term but refracts at this one.
///
/// As η → 1 the rough BTDF degenerates to a Dirac delta along −wo whatever the roughness (an
/// index-matched boundary does not bend light): the transmitted lobe's width is about α·|η − 1|,
/// and its generalised half vector wo + η wi is the difference of nearly opposite unit vectors,
/// whose direction loses about log10(1/|η − 1|) of f32's 7 digits (at η = 1.01 and α at the floor
/// [`MIN_ALPHA`], D's relative error from it is ≲ 1e-2). At 1.01 an object bends rays by at most
/// 8° at grazing incidence and reflects F0 = 2.5e-5 head-on: it looks index-matched.
pub const MIN_VOLUME_IOR: f32 = 1.01;

/// The GGX width up to which a thin-walled material counts as smooth for
/// [`MetallicRoughness::straight_transmittance`]: the roughness floor [`MIN_ALPHA`] itself, i.e.
/// roughness ≤ √1e-3 ≈ 0.032. Its transmission lobe is then ≈ 0.1° wide around −wo (the crate
/// documentation's "looks like a mirror"), so a straight shadow ray stands for it.
pub const SMOOTH_ALPHA: f32 = MIN_ALPHA;

/// The pane's back-surface reflection factor F (1 − F)/(1 + F): the light that enters a
/// two-interface pane of interface reflectance F, is reflected an odd number of times inside and
/// leaves through the front (Σₖ (1 − F) F^(2k+1) (1 − F) = F(1 − F)²/(1 − F²)). With the first
/// surface's F it makes the pane's reflectance R = 2F/(1 + F).
#[inline]
pub(super) fn pane_back_reflection(f: f32) -> f32 {
    f * (1.0 - f) / (1.0 + f)
}

/// The pane's transmittance (1 − F)/(1 + F): Σₖ (1 − F) F^(2k) (1 − F) = (1 − F)²/(1 − F²).
#[inline]
fn pane_transmission(f: f32) -> f32 {
    (1.0 - f) / (1.0 + f)
}

/// An index of refraction as a glTF file gives it (`KHR_materials_ior`), made usable:
/// - NaN (not a number: no value) reads as the default 1.5;
/// - 0, the extension's "specular-glossiness compatibility mode", and +∞ mean an infinite ior
///   (the extension: "the Fresnel term MUST evaluate to 1.0"), kept as +∞;
/// - values below 1, which the extension forbids ("Valid values for `ior` are numbers greater
///   than or equal to one", 0 excepted), are raised to 1, the nearest valid value;
/// - finite values above [`MAX_IOR`] are lowered to it.
#[inline]
fn validate_ior(ior: f32) -> f32 {
    if ior.is_nan() {
        1.5
    } else if ior == 0.0 || ior == f32::INFINITY {
        f32::INFINITY
    } else {
        ior.clamp(1.0, MAX_IOR)
    }
}

/// `wo` refracted through a facet of unit normal `n` on `wo`'s side (`cos_i` = wo·n > 0) into the
/// medium whose ior relative to `wo`'s is `etap`; `None` under total internal reflection. Snell's
/// law in vector form: wi = −wo/η + (cos θi/η − cos θt) n (pbrt-v4's `Refract`, written for
/// directions pointing away from the surface).
#[inline]
fn refract(wo: Vec3, n: Vec3, cos_i: f32, etap: f32) -> Option<Vec3> {
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (etap * etap);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-wo / etap + (cos_i / etap - cos_t) * n)
}

/// A direction mirrored through the surface plane.
#[inline]
fn mirror(w: Vec3) -> Vec3 {
    Vec3::new(w.x, w.y, -w.z)
}

/// The generalised half vector of a transmission pair and what the BTDF needs of it.
struct Refraction {
    /// The microfacet normal, unit, facing +z: normalize(wo + η' wi) turned up.
    wm: Vec3,
    /// wo·wm.
    dot_o: f32,
    /// wi·wm.
    dot_i: f32,
    /// η' = η(wi's side)/η(wo's side): the ior for `wo` outside, its inverse inside.
    etap: f32,
}

impl Refraction {
    /// etap² |wi·wm| / (etap wi·wm + wo·wm)², the Jacobian dωm/dωi of the refraction (Walter
    /// et al. 2007, eq. 17, with η' = η_i/η_o).
    #[inline]
    fn jacobian(&self) -> f32 {
        let denom = self.etap * self.dot_i + self.dot_o;
        self.etap * self.etap * self.dot_i.abs() / (denom * denom)
    }
}

impl MetallicRoughness {
    /// This material with `KHR_materials_ior`'s index of refraction, which sets the
    /// dielectric's reflectance at normal incidence to F0 = ((ior − 1)/(ior + 1))² (times the
    /// specular weight; its reflectance at grazing incidence stays the specular weight), and a
    /// volumetric material's refraction. 1.5 (the default, F0 = 0.04) leaves the material as
    /// it was, bit for bit.
    ///
    /// Read from a file, it is validated: NaN reads as 1.5; 0 (the extension's
    /// specular-glossiness compatibility mode) and +∞ are an infinite ior, F0 = 1, so that the
    /// dielectric's Fresnel term is 1 (the specular weight, with `KHR_materials_specular`) and
    /// nothing refracts; values below 1, which the extension forbids, are raised to 1; finite
    /// values above [`MAX_IOR`] are lowered to it.
    pub fn with_ior(self, ior: f32) -> Self {
        let ior = validate_ior(ior);
        let f0 = dielectric_f0(ior);
        Self {
            ior,
            dielectric_f0: f0,
            f0: Vec3::splat(f0 * self.specular).lerp(self.base_color, self.metallic),
            ..self
        }
    }

    /// This material with `KHR_materials_transmission`'s factor (clamped into [0, 1], NaN read as
    /// 0): the dielectric's base becomes mix(diffuse, transmission, factor). `thin_walled` is
    /// true for a material without `KHR_materials_volume` (or of thickness 0): a thin
    /// two-interface pane; false for the boundary of a volume, which refracts with the ior.
    /// A factor of 0 leaves the material as it was, bit for bit, whatever `thin_walled`.
    pub fn with_transmission(self, transmission: f32, thin_walled: bool) -> Self {
        Self {
            transmission: unit_interval(transmission),
            thin_walled,
            ..self
        }
    }

    /// This material as a thin sheet whose transmission a renderer handles itself by passing
    /// rays straight through it (stochastic transparency with probability
    /// [`sheet_transmittance`](Self::sheet_transmittance), as for a blended cut-out): the BSDF
    /// keeps its reflection lobes (the pane's reflectance 2F/(1 + F) included) and loses its
    /// transmission lobe, in [`eval`](Self::eval), [`sample`](Self::sample) and
    /// [`pdf`](Self::pdf) alike. Exact for a smooth sheet (its transmission lobe is then a
    /// delta about the straight direction); a rough sheet's transmitted light is then seen
    /// sharp instead of blurred.
    #[must_use]
    pub fn with_straight_transmission(self) -> Self {
        Self {
            thin_walled: true,
            straight: true,
            ..self
        }
    }

    /// Whether the transmission is left to straight rays
    /// ([`with_straight_transmission`](Self::with_straight_transmission)).
    pub fn is_straight(&self) -> bool {
        self.straight
    }

    /// The transmittance of the material as a smooth thin pane for a straight ray at `cos_theta`
    /// to its normal (either side): τ (1 − F)/(1 + F) per channel with τ the
    /// [`transmittance_tint`](Self::transmittance_tint), whatever its roughness and
    /// thin-walledness (what [`straight_transmittance`](Self::straight_transmittance) gives a
    /// smooth thin material). Zero without transmission.
    #[inline]
    pub fn sheet_transmittance(&self, cos_theta: f32) -> Vec3 {
        if self.transmission == 0.0 {
            return Vec3::ZERO;
        }
        let f = self.fresnel_outside(cos_theta.abs().min(1.0));
        self.transmittance_tint() * pane_transmission(f)
    }

    /// The index of refraction, in [1, [`MAX_IOR`]] or +∞ (see [`with_ior`](Self::with_ior)).
    pub fn ior(&self) -> f32 {
        self.ior
    }

    /// The dielectric's reflectance at normal incidence before the specular weight,
    /// ((ior − 1)/(ior + 1))² (0.04 at ior 1.5, 1 for an infinite ior).
    pub fn dielectric_f0(&self) -> f32 {
        self.dielectric_f0
    }

    /// The transmission factor in [0, 1] (0 unless given by
    /// [`with_transmission`](Self::with_transmission)).
    pub fn transmission(&self) -> f32 {
        self.transmission
    }

    /// Whether the transmission is through a thin sheet (true unless given otherwise by
    /// [`with_transmission`](Self::with_transmission)).
    pub fn is_thin_walled(&self) -> bool {
        self.thin_walled
    }

    /// τ = (1 − metallic) · transmission · base_color: the share of the light entering the
    /// dielectric that is transmitted, tinted by the base colour (`KHR_materials_transmission`:
    /// metals do not transmit, and the base colour tints what is transmitted).
    #[inline]
    pub fn transmittance_tint(&self) -> Vec3 {
        self.base_color * ((1.0 - self.metallic) * self.transmission)
    }

    /// The dielectric's Fresnel reflectance F_d = s (F0 + (1 − F0)(1 − c)⁵) for the cosine c
    /// measured on the outside.
    #[inline]
    fn fresnel_outside(&self, c: f32) -> f32 {
        self.specular * (self.dielectric_f0 + (1.0 - self.dielectric_f0) * schlick_weight(c))
    }

    /// The index of refraction a volumetric material refracts with: the ior, at least
    /// [`MIN_VOLUME_IOR`].
    #[inline]
    fn eta(&self) -> f32 {
        self.ior.max(MIN_VOLUME_IOR)
    }

    /// Whether the material's transmission refracts (volumetric with a finite ior).
    #[inline]
    fn refracts(&self) -> bool {
        !self.thin_walled && self.ior.is_finite()
    }

    /// The boundary's reflectance for light inside a volumetric material meeting a facet at
    /// cosine `c` > 0: 1 under total internal reflection (sin θt = η sin θ ≥ 1), else Schlick's
    /// F at the cosine of the refracted direction outside, cos θt = √(1 − η² sin²θ). Evaluating
    /// Schlick's approximation on the outside's cosine makes F the same number for both
    /// directions of a refraction pair, as the exact Fresnel reflectance is.
    #[inline]
    fn fresnel_inside(&self, c: f32) -> f32 {
        if !self.ior.is_finite() {
            return 1.0;
        }
        let eta = self.eta();
        let sin2_t = eta * eta * (1.0 - c * c).max(0.0);
        if sin2_t >= 1.0 {
            1.0
        } else {
            self.fresnel_outside((1.0 - sin2_t).sqrt())
        }
    }

    /// The dielectric's Fresnel reflectance for light meeting the surface (or a microfacet) at
    /// `cos_theta` to its normal: from outside (cos θ ≥ 0, or any cos θ for a thin-walled
    /// material, whose two sides are alike) F_d = s (F0 + (1 − F0)(1 − |cos θ|)⁵), the
    /// specification's Schlick approximation; from inside a volumetric material (cos θ < 0),
    /// 1 beyond the critical angle (total internal reflection) and otherwise Schlick's F at the
    /// refracted direction's cosine outside.
    #[inline]
    pub fn dielectric_fresnel(&self, cos_theta: f32) -> f32 {
        if cos_theta >= 0.0 || self.thin_walled {
            self.fresnel_outside(cos_theta.abs().min(1.0))
        } else {
            self.fresnel_inside((-cos_theta).min(1.0))
        }
    }

    /// The transmittance of a smooth thin-walled sheet of this material for a straight ray
    /// meeting it at `cos_theta` to its normal (either side), per colour channel:
    /// τ (1 − F)/(1 + F) with τ = [`transmittance_tint`](Self::transmittance_tint) and F =
    /// [`dielectric_fresnel`](Self::dielectric_fresnel)`(cos θ)` — the two-interface pane's
    /// (1 − F)²/(1 − F²). A white clear pane at normal incidence with ior 1.5 passes
    /// 0.96/1.04 ≈ 0.923 of the light behind it. It is the integral of the transmission lobe
    /// when that lobe is a delta; the smooth lobe integrates to it times the GGX lobe's
    /// single-scattering albedo (1 within ~1e-5 at α = [`SMOOTH_ALPHA`] unless grazing).
    ///
    /// For a renderer's shadow rays: `Some(ZERO)` without transmission (opaque), `Some(T)` for a
    /// thin-walled material no rougher than [`SMOOTH_ALPHA`]; `None` when a straight ray does
    /// not describe what passes (a rough sheet blurs the light behind it; a volume refracts it).
    #[inline]
    pub fn straight_transmittance(&self, cos_theta: f32) -> Option<Vec3> {
        if self.transmission == 0.0 {
            return Some(Vec3::ZERO);
        }
        if !self.thin_walled || self.alpha > SMOOTH_ALPHA {
            return None;
        }
        let f = self.fresnel_outside(cos_theta.abs().min(1.0));
        Some(self.transmittance_tint() * pane_transmission(f))
    }

    /// The estimated albedos of the glossy, transmission and diffuse lobes for `wo` above the
    /// surface, by luminance: Schlick's F at cos θo for the glossy lobe (plus the pane's
    /// back-surface reflection, thin-walled), τ (1 − F_d) times the pane's 1/(1 + F_d) or the
    /// radiance's 1/η² (volumetric) for the transmission lobe, and the exact diffuse albedo.
    /// The transmission lobe's 1 − F_d is kept at least f32's ε: at a grazing `wo` it rounds to
    /// 0 while facets tilted towards `wo` still transmit, and a lobe that contributes must keep a
    /// positive probability.
    fn outside_estimates(&self, wo: Vec3) -> (f32, f32, f32) {
        let cos_o = wo.z.clamp(0.0, 1.0);
        let mut glossy = luminance(self.f0 + (self.f90 - self.f0) * schlick_weight(cos_o));
        let diffuse = luminance(self.diffuse_albedo(wo));
        let tau = luminance(self.transmittance_tint());
        let f = self.fresnel_outside(cos_o);
        let transmission = if self.thin_walled {
            glossy += tau * pane_back_reflection(f);
            if self.straight {
                0.0
            } else {
                tau * pane_transmission(f).max(f32::EPSILON)
            }
        } else if self.refracts() {
            let eta = self.eta();
            tau * (1.0 - f).max(f32::EPSILON) / (eta * eta)
        } else {
            0.0
        };
        (glossy, transmission, diffuse)
    }

    /// (glossy, transmission) probabilities of [`sample`](Self::sample)'s lobe choice for `wo`
    /// above the surface: the lobes' shares of [`outside_estimates`](Self::outside_estimates);
    /// (1, 0) for `wo` below it. The diffuse lobe has the rest.
    pub(super) fn outside_probabilities(&self, wo: Vec3) -> (f32, f32) {
        if wo.z <= 0.0 {
            return (1.0, 0.0);
        }
        let (glossy, transmission, diffuse) = self.outside_estimates(wo);
        let total = glossy + transmission + diffuse;
        if total > 0.0 {
            (glossy / total, transmission / total)
        } else {
            (1.0, 0.0)
        }
    }

    /// The probability with which [`sample`](Self::sample) chooses the transmission lobe for
    /// `wo` above the surface: its share of the three lobes' estimated albedos (by luminance;
    /// the transmission lobe's is τ (1 − F_d(cos θo)) times 1/(1 + F_d) for a thin pane or 1/η²
    /// for a volume). Positive whenever the lobe can be non-zero. Zero without transmission and
    /// for `wo` below the surface (inside a volume the choice is per microfacet).
    #[inline]
    pub fn transmission_probability(&self, wo: Vec3) -> f32 {
        if self.transmission == 0.0 {
            return 0.0;
        }
        self.outside_probabilities(wo).1
    }

    /// The thin pane's transmission lobe at `wr` = `wi` mirrored above the surface, with `wm`
    /// and `cos_vh` the half vector of `wo` and `wr` and |wo·wm|: τ (1 − F)/(1 + F) D ν.
    #[inline]
    fn pane_lobe_at(&self, wo: Vec3, wr: Vec3, wm: Vec3, cos_vh: f32) -> Vec3 {
        let f = self.fresnel_outside(cos_vh);
        self.transmittance_tint()
            * (pane_transmission(f) * ggx_d(wm, self.alpha) * visibility(wo, wr, self.alpha))
    }

    /// The generalised half vector of `wo` and `wi` on opposite sides (Walter et al. 2007,
    /// eq. 16: h ∝ −(η_o wo + η_i wi), here wo + η' wi turned to face +z), or `None` where the
    /// pair cannot refract through one facet: the facet would be seen from its back by either
    /// direction (wo·wm and cos θo, or wi·wm and cos θi, of opposite signs) or the sum vanishes.
    #[inline]
    fn refraction(&self, wo: Vec3, wi: Vec3) -> Option<Refraction> {
        let eta = self.eta();
        let etap = if wo.z > 0.0 { eta } else { 1.0 / eta };
        let h = wo + etap * wi;
        let len2 = h.length_squared();
        if len2.is_nan() || len2 <= 0.0 {
            return None;
        }
        let mut wm = h / len2.sqrt();
        if wm.z < 0.0 {
            wm = -wm;
        }
        let (dot_o, dot_i) = (wo.dot(wm), wi.dot(wm));
        (wm.z > 0.0 && dot_o * wo.z > 0.0 && dot_i * wi.z > 0.0).then_some(Refraction {
            wm,
            dot_o,
            dot_i,
            etap,
        })
    }

    /// The volumetric BTDF at a refraction pair, for radiance (Walter et al. 2007, eq. 21, with
    /// pbrt-v4's 1/η'² for `TransportMode::Radiance`):
    /// f = τ (1 − F) D(wm) G2(wo, wi) |wi·wm| |wo·wm| / (|cos θi| |cos θo| (η' wi·wm + wo·wm)²),
    /// written with ν = G2/(4 |cos θo| |cos θi|) as 4 τ (1 − F) D ν |wi·wm| |wo·wm| /
    /// (η' wi·wm + wo·wm)². F is Schlick's at the facet cosine of whichever direction is
    /// outside (the same number from both sides of the pair).
    #[inline]
    fn refraction_lobe(&self, wo: Vec3, wi: Vec3, r: &Refraction) -> Vec3 {
        let c_outside = if wo.z > 0.0 { r.dot_o } else { r.dot_i };
        let f = self.fresnel_outside(c_outside.abs().min(1.0));
        let denom = r.etap * r.dot_i + r.dot_o;
        let value = 4.0
            * ggx_d(r.wm, self.alpha)
            * visibility(wo, wi, self.alpha)
            * (r.dot_i * r.dot_o).abs()
            / (denom * denom);
        self.transmittance_tint() * ((1.0 - f) * value)
    }

    /// The density of refracting a visible normal drawn for `wo` (above or below): D_wo(wm) ·
    /// dωm/dωi with D_wo(wm) = G1(wo) |wo·wm| D(wm) / |cos θo| (Heitz 2018, eq. 3, for `wo` or
    /// its opposite) and dωm/dωi [`Refraction::jacobian`].
    #[inline]
    fn refraction_pdf(&self, wo: Vec3, r: &Refraction) -> f32 {
        smith_g1(wo, self.alpha) * r.dot_o.abs() * ggx_d(r.wm, self.alpha) / wo.z.abs()
            * r.jacobian()
    }

    /// Inside a volumetric material: the probabilities (reflect, refract) of the choice at a
    /// facet met at cosine `c` > 0, proportional to its reflectance F and to its transmitted
    /// radiance's estimate (1 − F) · lum(τ) · η² (the BTDF's 1/η'² with η' = 1/η), so that both
    /// kinds of sample carry about the same weight; F = 1 under total internal reflection, where
    /// refraction gets probability 0 and its lobe is 0 too. `None` when both are 0.
    #[inline]
    fn inside_choice(&self, c: f32) -> Option<(f32, f32)> {
        let f = self.fresnel_inside(c);
        let transmitted = if self.refracts() {
            let eta = self.eta();
            (1.0 - f) * luminance(self.transmittance_tint()) * (eta * eta)
        } else {
            0.0
        };
        let total = f + transmitted;
        (total > 0.0).then(|| (f / total, transmitted / total))
    }

    /// [`eval_lobes`](Self::eval_lobes) for a transmitting material.
    pub(super) fn transmitting_lobes(&self, wo: Vec3, wi: Vec3) -> Lobes {
        if !(wo.z != 0.0 && wi.z != 0.0) || (self.thin_walled && wo.z < 0.0) {
            return Lobes::ZERO;
        }
        if wo.z > 0.0 && wi.z > 0.0 {
            let sum = wo + wi;
            let len = sum.length();
            return self.lobes_at(wo, wi, sum / len, (0.5 * len).min(1.0));
        }
        if self.straight {
            return Lobes::ZERO;
        }
        if self.thin_walled {
            // wi below: the pane's transmission at wi mirrored.
            let wr = mirror(wi);
            let sum = wo + wr;
            let len = sum.length();
            return Lobes {
                transmission: self.pane_lobe_at(wo, wr, sum / len, (0.5 * len).min(1.0)),
                ..Lobes::ZERO
            };
        }
        if wo.z < 0.0 && wi.z < 0.0 {
            // Inside: the boundary's reflection, about the half vector turned up.
            let sum = wo + wi;
            let len = sum.length();
            let wm = -sum / len;
            let f = self.fresnel_inside((0.5 * len).min(1.0));
            return Lobes {
                glossy: Vec3::splat(f * ggx_d(wm, self.alpha) * visibility(wo, wi, self.alpha)),
                ..Lobes::ZERO
            };
        }
        if !self.refracts() {
            return Lobes::ZERO;
        }
        match self.refraction(wo, wi) {
            Some(r) => Lobes {
                transmission: self.refraction_lobe(wo, wi, &r),
                ..Lobes::ZERO
            },
            None => Lobes::ZERO,
        }
    }

    /// [`pdf`](Self::pdf) for a transmitting material.
    pub(super) fn transmitting_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !(wo.z != 0.0 && wi.z != 0.0) {
            return 0.0;
        }
        if wo.z > 0.0 {
            let (glossy, transmission) = self.outside_probabilities(wo);
            if wi.z > 0.0 {
                let diffuse = (1.0 - glossy - transmission).max(0.0);
                return glossy * self.glossy_pdf(wo, wi) + diffuse * cosine_hemisphere_pdf(wi.z);
            }
            if self.thin_walled {
                let wr = mirror(wi);
                return transmission * self.reflected_pdf(wo, (wo + wr).normalize());
            }
            if !self.refracts() {
                return 0.0;
            }
            return self
                .refraction(wo, wi)
                .map_or(0.0, |r| transmission * self.refraction_pdf(wo, &r));
        }
        if self.thin_walled {
            return 0.0;
        }
        if wi.z < 0.0 {
            // Inside, reflected: the facet is the half vector turned up; |wo·wm| = |wo + wi|/2.
            let sum = wo + wi;
            let len = sum.length();
            let wm = -sum / len;
            return self
                .inside_choice((0.5 * len).min(1.0))
                .map_or(0.0, |(reflect, _)| {
                    reflect * smith_g1(wo, self.alpha) * ggx_d(wm, self.alpha) / (4.0 * wo.z.abs())
                });
        }
        if !self.refracts() {
            return 0.0;
        }
        self.refraction(wo, wi).map_or(0.0, |r| {
            self.inside_choice(-r.dot_o)
                .map_or(0.0, |(_, refract)| refract * self.refraction_pdf(wo, &r))
        })
    }

    /// [`sample`](Self::sample) for a transmitting material.
    pub(super) fn sample_transmitting(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z > 0.0 {
            self.sample_outside(wo, u_lobe, u)
        } else if wo.z < 0.0 && !self.thin_walled {
            self.sample_inside(wo, u_lobe, u)
        } else {
            None
        }
    }

    /// Sampling for `wo` above the surface: a lobe chosen by `u_lobe` (glossy, transmission,
    /// diffuse), then a direction from it by `u`. The lobes live in opposite hemispheres
    /// (reflection above, transmission below), so the mixture density at a transmitted `wi` is
    /// the transmission lobe's alone.
    fn sample_outside(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let (glossy, transmission) = self.outside_probabilities(wo);
        let diffuse = (1.0 - glossy - transmission).max(0.0);
        if u_lobe < glossy {
            let (wi, wm, cos_vh) = self.reflect_visible_normal(wo, u)?;
            let pdf = glossy * self.reflected_pdf(wo, wm) + diffuse * cosine_hemisphere_pdf(wi.z);
            (pdf > 0.0).then(|| BsdfSample {
                wi,
                f: self.lobes_at(wo, wi, wm, cos_vh).total(),
                pdf,
                lobe: Lobe::Glossy,
            })
        } else if u_lobe < glossy + transmission {
            if self.thin_walled {
                // The reflection lobe's sample mirrored through the surface.
                let (wr, wm, cos_vh) = self.reflect_visible_normal(wo, u)?;
                let pdf = transmission * self.reflected_pdf(wo, wm);
                return (pdf > 0.0).then(|| BsdfSample {
                    wi: mirror(wr),
                    f: self.pane_lobe_at(wo, wr, wm, cos_vh),
                    pdf,
                    lobe: Lobe::Transmission,
                });
            }
            let wm = sample_visible_normal(wo, self.alpha, u);
            let dot_o = wo.dot(wm);
            if dot_o <= 0.0 {
                return None;
            }
            let wi = refract(wo, wm, dot_o, self.eta())?;
            let r = Refraction {
                wm,
                dot_o,
                dot_i: wi.dot(wm),
                etap: self.eta(),
            };
            self.refracted_sample(wo, wi, &r, transmission)
        } else {
            let wi = sample_cosine_hemisphere(u);
            let pdf = self.transmitting_pdf(wo, wi);
            (wi.z > 0.0 && pdf > 0.0).then(|| BsdfSample {
                wi,
                f: self.eval(wo, wi),
                pdf,
                lobe: Lobe::Diffuse,
            })
        }
    }

    /// The sample of a refraction through the drawn facet `r.wm`, chosen with probability
    /// `choice`: value and density at that facet (so that D cancels exactly in the weight), or
    /// `None` if the refracted direction does not cross the surface.
    fn refracted_sample(
        &self,
        wo: Vec3,
        wi: Vec3,
        r: &Refraction,
        choice: f32,
    ) -> Option<BsdfSample> {
        if wi.z * wo.z >= 0.0 || r.dot_i * wi.z <= 0.0 {
            return None;
        }
        let pdf = choice * self.refraction_pdf(wo, r);
        (pdf > 0.0 && pdf.is_finite()).then(|| BsdfSample {
            wi,
            f: self.refraction_lobe(wo, wi, r),
            pdf,
            lobe: Lobe::Transmission,
        })
    }

    /// Sampling for `wo` inside a volumetric material: a visible normal drawn for −wo (the
    /// facets seen from inside), then reflection or refraction at it, chosen by `u_lobe` with
    /// [`inside_choice`](Self::inside_choice)'s probabilities at that facet (pbrt-v4's
    /// `DielectricBxDF::Sample_f` chooses so, by R and T).
    fn sample_inside(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let wm = sample_visible_normal(-wo, self.alpha, u);
        let c = -wo.dot(wm);
        if c <= 0.0 {
            return None;
        }
        let (reflect, refract_p) = self.inside_choice(c.min(1.0))?;
        if u_lobe < reflect {
            let wi = 2.0 * wo.dot(wm) * wm - wo;
            if wi.z >= 0.0 {
                return None;
            }
            let f = self.fresnel_inside(c.min(1.0));
            let pdf =
                reflect * smith_g1(wo, self.alpha) * ggx_d(wm, self.alpha) / (4.0 * wo.z.abs());
            return (pdf > 0.0).then(|| BsdfSample {
                wi,
                f: Vec3::splat(f * ggx_d(wm, self.alpha) * visibility(wo, wi, self.alpha)),
                pdf,
                lobe: Lobe::Glossy,
            });
        }
        let etap = 1.0 / self.eta();
        let wi = refract(wo, -wm, c, etap)?;
        let r = Refraction {
            wm,
            dot_o: -c,
            dot_i: wi.dot(wm),
            etap,
        };
        self.refracted_sample(wo, wi, &r, refract_p)
    }
}

#[cfg(test)]
mod tests;
