//! The glTF 2.0 metallic-roughness BRDF exactly as the glTF 2.0 specification's Appendix B
//! defines it, split into its diffuse and glossy lobes, with importance sampling of each.
//!
//! # What it owns
//! - [`MetallicRoughness`]: the material's parameters (clamped) and its BRDF: [`eval`] (the
//!   whole f), [`eval_lobes`] (its diffuse and glossy parts), [`sample`] and [`pdf`] (both lobes,
//!   as a one-sample mixture), [`sample_glossy`] and [`glossy_pdf`] (the glossy lobe alone), and
//!   [`diffuse_albedo`] (the diffuse lobe's stand-in for an irradiance cache).
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
//! - The BRDF is one-sided: zero unless both directions lie strictly above the surface (a
//!   double-sided glTF material is rendered by flipping the shading normal to the viewer's side
//!   first). [`eval`] returns f alone, **not** multiplied by cos θi.
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
