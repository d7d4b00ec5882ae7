//! The glTF 2.0 metallic-roughness BRDF exactly as the glTF 2.0 specification's Appendix B
//! defines it, split into its diffuse and glossy lobes, with importance sampling of each; and its
//! extensions `KHR_materials_ior` and `KHR_materials_transmission` (a transmission lobe, through a
//! thin sheet or into a volume).
//!
//! # What it owns
//! - [`MetallicRoughness`]: the material's parameters (clamped) and its BSDF: [`eval`] (the
//!   whole f), [`eval_lobes`] (its diffuse, glossy and transmission parts), [`sample`] and
//!   [`pdf`] (all lobes, as a one-sample mixture), [`sample_glossy`] and [`glossy_pdf`] (the
//!   glossy lobe alone), [`diffuse_albedo`] (the diffuse lobe's stand-in for an irradiance
//!   cache), and [`straight_transmittance`] (what a smooth thin sheet passes along a shadow ray).
//! - [`microfacet`]: the Trowbridge–Reitz (GGX) distribution, the Smith masking and
//!   height-correlated visibility terms, and the visible-normal sampler in a three:
//!   [`sample_visible_normal`], [`visible_normal_pdf`], [`invert_visible_normal`].
//! - [`fresnel`]: Schlick's approximation and the dielectric diffuse base's albedo.
//! - [`basis`]: the cosine-weighted glossy lobe's coefficients in irr-sh's HSH or SH basis per
//!   view angle ([`basis::GlossyTable`]), for radiance caching (Křivánek et al. 2005), with the
//!   measured quadrature, interpolation and reconstruction errors.
//!
//! # What it must not know
//! Rays, scenes, textures, glTF files. It takes plain numbers: a base colour (linear RGB),
//! metallic and roughness in [0, 1], as a renderer reads them from a material and its textures
//! at a shading point. **Sampling functions take `u` (a point of the unit square) and `u_lobe`,
//! never an RNG**, as irr-sampling's warps do.
//!
//! # Conventions
//! - Directions are unit vectors in the local shading frame, normal along **+z**: the frame of
//!   `irr_sampling::Frame` (`Frame::from_normal(n).to_local(w)`).
//! - pbrt's convention: `wo` (towards the viewer, the specification's V) and `wi` (towards the
//!   light, L) both point **away** from the surface. (Mitsuba's `wi` is the opposite.)
//! - Without transmission the BRDF is one-sided: zero unless both directions lie strictly above
//!   the surface (a double-sided glTF material is rendered by flipping the shading normal to the
//!   viewer's side first). [`eval`] returns f alone, **not** multiplied by |cos θi|.
//! - With transmission, `wi` below the surface is transmitted light. A thin-walled material
//!   keeps the flip to the viewer's side (`wo` below gives zero). A volumetric one needs the
//!   **outward** normal unflipped: `wo` below is a viewer inside the object.
//!
//! # The model (glTF 2.0 specification, Appendix B.3)
//! With α = roughness², h = normalize(wo + wi) and w = (1 − |wo·h|)⁵:
//! - D = α² χ⁺(n·h) / (π ((n·h)²(α² − 1) + 1)²), Trowbridge–Reitz/GGX (Walter et al. 2007,
//!   "Microfacet Models for Refraction through Rough Surfaces", EGSR);
//! - ν = G2 / (4 |n·wo| |n·wi|) = 1 / (2 (|n·wo| √(α² + (1 − α²)(n·wi)²) + |n·wi| √(α² +
//!   (1 − α²)(n·wo)²))), the height-correlated Smith masking-shadowing (Heitz 2014,
//!   "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs", JCGT 3(2));
//! - specular = D ν; diffuse = base/π; F_dielectric = 0.04 + 0.96 w (ior 1.5);
//!   F_metal = base + (1 − base) w;
//! - dielectric = mix(diffuse, specular, F_dielectric) (`fresnel_mix`); metal = F_metal ·
//!   specular (`conductor_fresnel`); f = mix(dielectric, metal, metallic).
//!
//! `KHR_materials_specular`'s `specularFactor` s ([`MetallicRoughness::with_specular`]) scales
//! the dielectric's Fresnel term to F_dielectric = s (0.04 + 0.96 w), its implementation section's
//! F0 = 0.04 s and F90 = s; s = 0 leaves a pure Lambertian base (its `specularColorFactor` and
//! textures are not modelled).
//!
//! Regrouped into lobes: **diffuse** = (1 − metallic)(1 − F_dielectric) base/π and **glossy** =
//! F D ν with F Schlick's from f0 = mix(0.04 s, base, metallic) to f90 = mix(s, 1, metallic)
//! (Schlick's F is affine in f0 and f90, so the two specular terms are one). The glossy lobe is single-scattering: the specification suggests
//! multiple-scattering compensation but does not define it, and this crate leaves it out. The
//! specification's `fresnel_mix` is not energy conserving (its section B.3.6 says so): a white
//! dielectric's directional albedo reaches 1.88 at cos θo = 0.01 and α = 1e-3 (the diffuse weight
//! 1 − F(|wo·h|) stays ≈ 0.93 while the glossy lobe's F tends to 1), so a closed white furnace of
//! it does not converge; the metal's albedo never exceeds 1.
//!
//! # ior and transmission
//! - **ior** (`KHR_materials_ior`, [`with_ior`]): F0 = ((ior − 1)/(ior + 1))², computed as
//!   (ior − 1)²/(ior + 1)² so that ior 1.5 gives 0.04's bits. F90 is the specular weight, as
//!   before. ior = 0 is the extension's compatibility mode, an infinite ior: F = 1 (times the
//!   specular weight) at every angle and nothing refracts. NaN reads as 1.5. Values below 1,
//!   which the extension forbids, are raised to 1. Finite values are capped at [`MAX_IOR`].
//! - **transmission** t (`KHR_materials_transmission`, [`with_transmission`]): the dielectric
//!   base becomes mix(diffuse, specular_btdf · baseColor, t), as the extension defines. The
//!   diffuse lobe is scaled by 1 − t, and so is [`diffuse_albedo`], which keeps the irradiance
//!   cache's stand-in exact. A transmission lobe of tint τ = (1 − metallic) · t · baseColor
//!   appears on the other side (metals do not transmit). It has the glossy lobe's GGX α and
//!   Fresnel F_d = s (F0 + (1 − F0)(1 − c)⁵).
//! - **Thin-walled** (no `KHR_materials_volume`): a pane of two interfaces, as pbrt-v4's
//!   `ThinDielectricBxDF`. Summing the light's internal reflections gives transmittance
//!   T' = (1 − F)²/(1 − F²) = (1 − F)/(1 + F) and reflectance R' = F + F(1 − F)²/(1 − F²) =
//!   2F/(1 + F), so R' + T' = 1. A clear pane at normal incidence with ior 1.5 passes
//!   0.96/1.04 = 0.923 of the light behind it. The extension itself models one interface
//!   (T = 1 − F); the pane is the better model of a window.
//!
//!   The rough pane generalises this facet by facet. Each facet is treated as a smooth pane at
//!   its own angle: F = F_d(|wo·h|). The reflection lobe is D ν times F plus the back-surface
//!   term τ F(1 − F)/(1 + F). The transmission lobe is τ (1 − F)/(1 + F) D ν taken at wi
//!   mirrored through the surface: the extension's "specular lobe sampled along the line of
//!   sight", where the two refractions cancel. As α reaches the floor these become the smooth
//!   pane's delta lobes. For white clear glass the albedo is the GGX lobe's single-scattering
//!   albedo (≤ 1, and 1 when smooth).
//!
//!   For shadow rays, [`straight_transmittance`] gives τ (1 − F(cos θ))/(1 + F(cos θ)) when
//!   α ≤ [`SMOOTH_ALPHA`] (the floor).
//! - **Volumetric**: the rough dielectric BTDF of Walter et al. 2007 (eq. 21), with the
//!   height-correlated G2 and relative ior η' = η(wi's side)/η(wo's side). wo may be inside.
//!   The Fresnel term stays the specification's Schlick F rather than the exact dielectric
//!   one. It is evaluated at the facet cosine of whichever direction is **outside**, so both
//!   directions of a refraction pair get the same F. From inside, F = 1 beyond the critical
//!   angle (total internal reflection), and otherwise F is Schlick's at the refracted cosine
//!   √(1 − η² sin²θ). Inside, the boundary reflects F D ν and transmits with τ; the rest is
//!   absorbed.
//!
//!   The BTDF carries pbrt-v4's 1/η'² for **radiance** (its `TransportMode::Radiance`), the
//!   quantity a camera path needs. It is reciprocal as f(wo, wi)/η(wo's side)² =
//!   f(wi, wo)/η(wi's side)². The importance (adjoint) BTDF is f · η'².
//!
//!   Refraction uses η ≥ [`MIN_VOLUME_IOR`] = 1.01: at η = 1 the rough lobe degenerates to a
//!   delta. It is sampled by refracting a visible normal. From inside, [`sample`] chooses
//!   reflection or refraction at the drawn facet by its Fresnel weights, as pbrt-v4's
//!   `DielectricBxDF` does, so total internal reflection is never lost.
//! - From outside, [`sample`] chooses among the glossy, transmission and diffuse lobes by their
//!   estimated albedos. The transmission lobe's estimate is τ (1 − F) times 1/(1 + F) (pane)
//!   or 1/η² (volume); see [`transmission_probability`]. A transmitted sample has `wi` on the
//!   other side and the lobe [`Lobe::Transmission`]. Its weight is still f·|cos θi|/pdf.
//!
//! # Roughness floor
//! α = max(roughness², [`MIN_ALPHA`] = 1e-3). At α = 0 the GGX distribution is a Dirac delta,
//! which [`eval`] cannot return; a perfectly specular (delta) lobe is out of scope. The floor keeps
//! D finite (≤ 1/(π·10⁻⁶) ≈ 3.2e5) and leaves a ~0.1°-wide lobe that looks like a mirror; pbrt-v4
//! uses the same threshold to switch to a delta lobe instead.
//!
//! # Sampling
//! The glossy lobe is sampled by reflecting a visible normal drawn with Heitz's construction
//! (Heitz 2018, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4)), with density
//! D_wo(wm) / (4 |wo·wm|) = G1(wo) D(wm) / (4 cos θo) per unit solid angle of wi; its weight
//! f cos θi / pdf = F · G2/G1(wo) ≤ 1. The diffuse lobe is sampled cosine-weighted. [`sample`]
//! picks a lobe with [`glossy_probability`], the glossy share of the two lobes' estimated albedos,
//! and reports the mixture density, which [`pdf`] also returns for multiple importance sampling.
//!
//! # Irradiance caching: the diffuse lobe's stand-in
//! An irradiance cache stores irradiance E = ∫ L cos θi dωi and multiplies it by a reflectance;
//! the path tracer then traces the glossy lobe alone ([`sample_glossy`]). The specification's
//! diffuse lobe depends on wi through the half vector, so it is not a constant times 1/π; the
//! cache uses [`diffuse_albedo`]`(wo) / π · E`, where `diffuse_albedo` is the lobe's exact
//! directional albedo ∫ f_diffuse cos θi dωi (a degree-4 polynomial in cos θo, within 4.4e-6
//! relative). The stand-in is **exact under uniform incident light**, so the cached and the
//! path-traced images agree in a white furnace. Otherwise its relative error in the diffuse
//! lobe's reflected light is at most the first figure below for any light, and at most
//! δ × the second for light within a factor 1 ± δ of uniform (both measured by the test
//! `diffuse_stand_in_error`):
//!
//! | θo | 0° | 30° | 45° | 60° | 75° | 85° | 90° |
//! |---|---|---|---|---|---|---|---|
//! | max over wi of \|π f_d / albedo − 1\| | 0.21% | 3.1% | 8.8% | 22% | 49% | 80% | 100% |
//! | its cosine-weighted mean | 0.012% | 0.084% | 0.26% | 0.73% | 1.8% | 3.1% | 3.9% |
//!
//! The large maxima come from light arriving at grazing angles opposite a grazing view, where
//! (1 − F(|wo·h|)) tends to 0; light is rarely concentrated there, and the mean figure is the
//! typical one.
//!
//! # Example
//! ```
//! use glam::{Vec2, Vec3};
//! use irr_bsdf::MetallicRoughness;
//! use irr_sampling::{Frame, SampleKey};
//!
//! let material = MetallicRoughness::new(Vec3::new(0.8, 0.5, 0.2), 0.0, 0.4);
//! let frame = Frame::from_normal(Vec3::Y);
//! // Towards the viewer, in the shading frame (normal +z).
//! let wo = frame.to_local(Vec3::new(0.6, 0.8, 0.0));
//!
//! // Evaluate towards a light straight above: f, without the cosine.
//! let f = material.eval(wo, Vec3::Z);
//! assert!(f.min_element() > 0.0);
//! assert_eq!(material.eval(wo, -Vec3::Z), Vec3::ZERO); // below the surface
//!
//! // Sample the BRDF: the estimator's weight is f cos θi / pdf.
//! let key = SampleKey::new(1, 0, 0);
//! if let Some(s) = material.sample(wo, key.uniform(0), key.uniform_2d(1)) {
//!     let weight = s.f * s.wi.z / s.pdf;
//!     assert!(weight.min_element() >= 0.0);
//!     assert!((s.pdf - material.pdf(wo, s.wi)).abs() <= 1e-3 * s.pdf);
//!     let wi_world = frame.to_world(s.wi);
//!     assert!(wi_world.dot(Vec3::Y) > 0.0);
//! }
//! ```
//!
//! [`eval`]: MetallicRoughness::eval
//! [`eval_lobes`]: MetallicRoughness::eval_lobes
//! [`sample`]: MetallicRoughness::sample
//! [`pdf`]: MetallicRoughness::pdf
//! [`sample_glossy`]: MetallicRoughness::sample_glossy
//! [`glossy_pdf`]: MetallicRoughness::glossy_pdf
//! [`diffuse_albedo`]: MetallicRoughness::diffuse_albedo
//! [`glossy_probability`]: MetallicRoughness::glossy_probability
//! [`straight_transmittance`]: MetallicRoughness::straight_transmittance
//! [`with_ior`]: MetallicRoughness::with_ior
//! [`with_transmission`]: MetallicRoughness::with_transmission
//! [`transmission_probability`]: MetallicRoughness::transmission_probability

pub mod basis;
pub mod fresnel;
mod material;
pub mod microfacet;
#[cfg(test)]
mod testing;

pub use fresnel::{
    DIELECTRIC_F0, dielectric_diffuse_albedo, dielectric_diffuse_albedo_f0, dielectric_f0, schlick,
};
pub use material::{
    BsdfSample, Lobe, Lobes, MAX_IOR, MIN_ALPHA, MIN_VOLUME_IOR, MetallicRoughness, SMOOTH_ALPHA,
    luminance,
};
pub use microfacet::{
    ggx_d, invert_visible_normal, sample_visible_normal, smith_g1, visibility, visible_normal_pdf,
};
