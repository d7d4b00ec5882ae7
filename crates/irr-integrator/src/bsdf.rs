//! The reflection at a shading point in world space, as the integrators use it: a Lambertian
//! surface, or irr-bsdf's glTF metallic-roughness model in the point's shading frame.
//!
//! A material of metallic 0 and specular weight 0 is exactly Lambertian (irr-bsdf's
//! `is_lambertian`): it keeps the Lambertian arithmetic (f = ρ/π, cosine sampling, weight ρ),
//! so the path tracer renders scenes without glossy materials as before, bit for bit (the light
//! cache's paths, whose weights now go through the drawn direction's density, differ in the
//! last bits). Every other material is
//! [`Bsdf::Glossy`]: evaluated, sampled (a lobe chosen by its weight, then a visible normal or a
//! cosine direction) and its density given for multiple importance sampling.

use crate::path::ShadingPoint;
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use irr_bsdf::MetallicRoughness;
use irr_sampling::rng::Dimensions;
use irr_sampling::{Frame, cosine_hemisphere_pdf, sample_cosine_hemisphere};
use std::f32::consts::FRAC_1_PI;

/// The BSDF at a shading point (its normals turned to the viewer's side, `ShadingPoint::new`).
#[derive(Clone, Copy, Debug)]
pub enum Bsdf {
    /// f = albedo/π.
    Lambertian {
        /// The diffuse reflectance ρ.
        albedo: Vec3,
        /// The shading normal.
        ns: Vec3,
    },
    /// glTF metallic-roughness, evaluated in the shading frame.
    Glossy {
        /// The material at the point.
        material: MetallicRoughness,
        /// The shading frame (normal `ns`).
        frame: Frame,
        /// The direction towards the viewer, in the frame.
        wo: Vec3,
        /// The factor on the BSDF's values: 1, except on glass, where a ray meets the sheet's
        /// reflection only when it did not pass straight through (`Scene::pass_probability`
        /// p), so the reflection is divided by 1 − p there.
        scale: f32,
    },
}

/// A direction drawn from a [`Bsdf`]: its contribution is `weight` times the radiance arriving
/// along `wi`.
#[derive(Clone, Copy, Debug)]
pub struct BsdfDraw {
    /// The incident direction, world space, unit.
    pub wi: Vec3,
    /// f·|cos θi| / pdf (the albedo, for a Lambertian surface).
    pub weight: Vec3,
    /// The density of `wi` per unit solid angle (for multiple importance sampling).
    pub pdf: f32,
    /// |cos θi| at the shading normal.
    pub cos: f32,
    /// Whether `wi` crosses the surface (refraction through a volume's boundary): the light
    /// comes from the side opposite the viewer's, where no light sample looks, so an emitter
    /// it finds takes the whole weight.
    pub transmitted: bool,
}

impl BsdfDraw {
    /// Whether `wi` leaves the surface on the side it should, against the geometric normal
    /// `ng` turned to the viewer: above it for a reflection, below for a transmission (a
    /// shading normal can send either under the geometric surface: no light there).
    #[inline]
    pub fn leaves(&self, ng: Vec3) -> bool {
        let d = self.wi.dot(ng);
        if self.transmitted { d < 0.0 } else { d > 0.0 }
    }

    /// The number of light samples an emitter this draw finds is weighted against (the power
    /// heuristic's): `light_samples`, or none after a transmission.
    #[inline]
    pub fn light_samples(&self, light_samples: f32) -> f32 {
        if self.transmitted { 0.0 } else { light_samples }
    }
}

impl Bsdf {
    /// The BSDF of the scene's material at `x`, towards `x.wo`.
    #[inline]
    pub fn at(scene: &Scene, x: &ShadingPoint) -> Self {
        let material = scene.material_of(x.triangle);
        // An unlit surface reflects nothing (no ray but the camera's meets it).
        if material.unlit {
            return Bsdf::Lambertian {
                albedo: Vec3::ZERO,
                ns: x.ns,
            };
        }
        if material.is_lambertian() && !material.transmits() {
            let albedo = scene.albedo(x.triangle, x.b1, x.b2);
            return Bsdf::Lambertian { albedo, ns: x.ns };
        }
        // A volume's boundary refracts by which side the light comes from: its frame's normal
        // is the outward one (the winding normal's side), so `wo` lies below it from inside.
        let ns = if material.refracts() {
            let outward = scene.geometry().geometric_normal(x.triangle);
            if x.ng.dot(outward) < 0.0 { -x.ns } else { x.ns }
        } else {
            x.ns
        };
        let frame = Frame::from_normal(ns);
        let scale = if material.passes_straight() {
            let p = scene.pass_probability(x.triangle, x.b1, x.b2, x.wo);
            // A filtered query never stops a ray where p = 1.
            if p < 1.0 { 1.0 / (1.0 - p) } else { 0.0 }
        } else {
            1.0
        };
        Bsdf::Glossy {
            material: scene.reflection(x.triangle, x.b1, x.b2),
            frame,
            wo: frame.to_local(x.wo.normalize()),
            scale,
        }
    }

    /// Whether the surface is known to reflect nothing: a black Lambertian surface. (A glossy
    /// one is treated as reflecting: its lobe reflects at grazing angles unless its specular
    /// weight, metallic factor and base colour are all zero there, a case whose draws and
    /// evaluations are zero anyway.)
    #[inline]
    pub fn is_black(&self) -> bool {
        matches!(self, Bsdf::Lambertian { albedo, .. } if *albedo == Vec3::ZERO)
    }

    /// Whether the surface is Lambertian.
    #[inline]
    pub fn is_lambertian(&self) -> bool {
        matches!(self, Bsdf::Lambertian { .. })
    }

    /// f(wo, `wi`) for a unit world direction `wi` (not multiplied by the cosine). A glossy
    /// surface reflects nothing towards or from below its shading normal.
    #[inline]
    pub fn eval(&self, wi: Vec3) -> Vec3 {
        match self {
            Bsdf::Lambertian { albedo, .. } => *albedo * FRAC_1_PI,
            Bsdf::Glossy {
                material,
                frame,
                wo,
                scale,
            } => material.eval(*wo, frame.to_local(wi)) * *scale,
        }
    }

    /// The density with which [`Bsdf::sample`] draws the unit world direction `wi`.
    #[inline]
    pub fn pdf(&self, wi: Vec3) -> f32 {
        match self {
            Bsdf::Lambertian { ns, .. } => cosine_hemisphere_pdf(wi.dot(*ns)),
            Bsdf::Glossy {
                material,
                frame,
                wo,
                ..
            } => material.pdf(*wo, frame.to_local(wi)),
        }
    }

    /// Draws an incident direction from `u`: cosine-distributed on a Lambertian surface; on a
    /// glossy one a lobe chosen with irr-bsdf's `glossy_probability` by `u.x` (rescaled to
    /// [0, 1) within the chosen lobe's share, so the draw takes two numbers on every surface),
    /// then a direction from that lobe. `None` when the glossy lobe reflects below the surface
    /// or the viewer is below the shading normal.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<BsdfDraw> {
        match self {
            Bsdf::Lambertian { albedo, ns } => {
                let wi = Frame::from_normal(*ns).to_world(sample_cosine_hemisphere(u));
                let cos = wi.dot(*ns);
                Some(BsdfDraw {
                    wi,
                    weight: *albedo,
                    pdf: cosine_hemisphere_pdf(cos),
                    cos,
                    transmitted: false,
                })
            }
            Bsdf::Glossy {
                material,
                frame,
                wo,
                scale,
            } => {
                let p = material.glossy_probability(*wo);
                let (u_lobe, x) = if u.x < p {
                    (0.0, u.x / p)
                } else {
                    (1.0, (u.x - p) / (1.0 - p))
                };
                let s = material.sample(*wo, u_lobe, Vec2::new(x.min(ONE_BELOW), u.y))?;
                Some(BsdfDraw {
                    wi: frame.to_world(s.wi),
                    weight: s.f * (*scale * s.wi.z / s.pdf),
                    pdf: s.pdf,
                    cos: s.wi.z,
                    transmitted: false,
                })
            }
        }
    }

    /// Whether the BSDF refracts (a volume's boundary): its draws may cross the surface, and
    /// take a third random number ([`Bsdf::draw`]).
    #[inline]
    pub fn refracts(&self) -> bool {
        matches!(self, Bsdf::Glossy { material, .. }
            if material.transmission() > 0.0 && !material.is_thin_walled())
    }

    /// A direction drawn from `dims`: [`Bsdf::sample`] of the next two numbers, except where
    /// the BSDF refracts, whose lobe choice (among reflection, refraction and diffuse; from
    /// inside, reflection or refraction at the drawn microfacet) takes a third, so that the
    /// streams of every other surface stay as they were.
    #[inline]
    pub fn draw(&self, dims: &mut Dimensions) -> Option<BsdfDraw> {
        let u = dims.next_2d();
        let Bsdf::Glossy {
            material,
            frame,
            wo,
            scale,
        } = self
        else {
            return self.sample(u);
        };
        if !self.refracts() {
            return self.sample(u);
        }
        let s = material.sample(*wo, dims.next_1d(), u)?;
        let cos = s.wi.z.abs();
        (s.pdf > 0.0).then(|| BsdfDraw {
            wi: frame.to_world(s.wi),
            weight: s.f * (*scale * cos / s.pdf),
            pdf: s.pdf,
            cos,
            transmitted: s.wi.z * wo.z < 0.0,
        })
    }

    /// [`Bsdf::sample`] made defensive for estimating irradiance as well as reflection: on a
    /// glossy surface, `u.x` picks cosine sampling or the BSDF's own with probability ½ each
    /// (rescaled within its half), and the draw reports the mixture's density ½ cos θ/π +
    /// ½ pdf_bsdf, so that both cos θ / pdf (≤ 2π: the irradiance's weight) and f cos θ / pdf
    /// (at most twice the BSDF sampler's) stay bounded even under a narrow lobe. On a
    /// Lambertian surface it is [`Bsdf::sample`] itself.
    #[inline]
    pub fn sample_defensive(&self, u: Vec2) -> Option<BsdfDraw> {
        let Bsdf::Glossy { frame, .. } = self else {
            return self.sample(u);
        };
        let wi = if u.x < 0.5 {
            frame.to_world(sample_cosine_hemisphere(Vec2::new(
                (2.0 * u.x).min(ONE_BELOW),
                u.y,
            )))
        } else {
            self.sample(Vec2::new((2.0 * u.x - 1.0).min(ONE_BELOW), u.y))?
                .wi
        };
        let cos = frame.to_local(wi).z;
        let pdf = 0.5 * cosine_hemisphere_pdf(cos) + 0.5 * self.pdf(wi);
        (cos > 0.0 && pdf > 0.0).then(|| BsdfDraw {
            wi,
            weight: self.eval(wi) * (cos / pdf),
            pdf,
            cos,
            transmitted: false,
        })
    }

    /// The density with which [`Bsdf::sample_defensive`] draws the unit world direction `wi`:
    /// what a light sample's weight against that draw needs.
    #[inline]
    pub fn pdf_defensive(&self, wi: Vec3) -> f32 {
        match self {
            Bsdf::Lambertian { .. } => self.pdf(wi),
            Bsdf::Glossy { frame, .. } => {
                0.5 * cosine_hemisphere_pdf(frame.to_local(wi).z) + 0.5 * self.pdf(wi)
            }
        }
    }

    /// The reflectance ρ_d by which an irradiance cache multiplies its irradiance, ρ_d/π·E, to
    /// stand for the diffuse reflection of indirect light: the albedo of a Lambertian surface
    /// (exact), irr-bsdf's `diffuse_albedo(wo)` for a glossy one (exact under uniform light;
    /// the rest, f − ρ_d/π, is [`Bsdf::residual`]'s).
    #[inline]
    pub fn diffuse_reflectance(&self) -> Vec3 {
        match self {
            Bsdf::Lambertian { albedo, .. } => *albedo,
            // From inside a volume, no diffuse base faces the viewer.
            Bsdf::Glossy { wo, .. } if wo.z <= 0.0 && self.refracts() => Vec3::ZERO,
            Bsdf::Glossy {
                material,
                wo,
                scale,
                ..
            } => material.diffuse_albedo(*wo) * *scale,
        }
    }

    /// f(wo, `wi`) − ρ_d/π, the reflection an irradiance cache's ρ_d/π·E leaves out
    /// ([`Bsdf::diffuse_reflectance`]): zero on a Lambertian surface; on a glossy one the glossy
    /// lobe plus the diffuse lobe's departure from its stand-in, which is negative where
    /// (1 − F(|wo·h|)) is below its mean, so this may be negative.
    #[inline]
    pub fn residual(&self, wi: Vec3) -> Vec3 {
        match self {
            Bsdf::Lambertian { .. } => Vec3::ZERO,
            Bsdf::Glossy {
                material,
                frame,
                wo,
                scale,
            } => {
                let local = frame.to_local(wi);
                if self.refracts() {
                    // The diffuse stand-in covers the outside's reflection only; across the
                    // boundary, and from inside, the whole BSDF is the residual.
                    let f = material.eval(*wo, local);
                    return if wo.z > 0.0 && local.z > 0.0 {
                        f - material.diffuse_albedo(*wo) * FRAC_1_PI
                    } else {
                        f
                    };
                }
                if local.z <= 0.0 {
                    return Vec3::ZERO;
                }
                (material.eval(*wo, local) - material.diffuse_albedo(*wo) * FRAC_1_PI) * *scale
            }
        }
    }

    /// The probability with which a light-cache lookup at this surface also traces a sample of
    /// [`Bsdf::residual`] (`IrradianceCacheIntegrator::gather_radiance`): the share of the
    /// albedo estimate that ρ_d leaves out (by luminance), at least [`MIN_RESIDUAL`]; 1 on a
    /// metal; on a white rough dielectric 0.04 seen head-on (so [`MIN_RESIDUAL`]), ≈ 0.07 at 60°.
    /// Zero on a Lambertian surface.
    #[inline]
    pub fn residual_probability(&self) -> f32 {
        if self.is_lambertian() {
            return 0.0;
        }
        let lum = irr_bsdf::luminance;
        let total = lum(self.albedo_estimate());
        if total <= 0.0 {
            return 1.0;
        }
        (1.0 - lum(self.diffuse_reflectance()) / total).clamp(MIN_RESIDUAL, 1.0)
    }

    /// An estimate of the directional albedo, for Russian roulette: ρ on a Lambertian
    /// surface; on a glossy one the diffuse lobe's albedo plus Schlick's F at cos θo (the glossy
    /// lobe's albedo at low roughness, an overestimate when rough); on a refracting one, which
    /// passes on what it does not reflect, the base colour's share that is transmitted or
    /// reflected, at most 1 (clear glass goes on with certainty).
    #[inline]
    pub fn albedo_estimate(&self) -> Vec3 {
        match self {
            Bsdf::Lambertian { albedo, .. } => *albedo,
            Bsdf::Glossy { material, .. } if self.refracts() => {
                let t = material.transmission() * (1.0 - material.metallic());
                (material.base_color() * t + material.specular_f90() * (1.0 - t)).min(Vec3::ONE)
            }
            Bsdf::Glossy {
                material,
                wo,
                scale,
                ..
            } => {
                let f0 = material.specular_f0();
                let w = irr_bsdf::fresnel::schlick_weight(wo.z.clamp(0.0, 1.0));
                (material.diffuse_albedo(*wo) + f0 + (material.specular_f90() - f0) * w) * *scale
            }
        }
    }
}

/// The least probability of [`Bsdf::residual_probability`]: the residual also holds the diffuse
/// lobe's departure from its stand-in, which the albedo shares do not show, so it is never
/// sampled more rarely than this (its weight 1/p stays at most 20).
pub const MIN_RESIDUAL: f32 = 0.05;

/// The largest f32 below 1: a rescaled lobe-choice number stays in [0, 1).
const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Material;
    use crate::tests::{first_surface, polygon, scene};
    use irr_geometry::Ray;
    use irr_sampling::SampleKey;

    /// A plane (y = 0, normal +y) of `material` seen at 60° from its normal.
    fn plane(material: Material) -> (Scene, ShadingPoint) {
        let s = scene(&[polygon(Vec3::ZERO, 1.0, 8, 1.0, 0)], vec![material]);
        let ray = Ray::new(Vec3::new(-0.866, 0.5, 0.0), Vec3::new(0.866, -0.5, 0.0));
        let x = ShadingPoint::new(&first_surface(&s, &ray), -ray.direction);
        (s, x)
    }

    /// A Lambertian material keeps the Lambertian arithmetic (weight ρ, density cos/π) and has
    /// no residual; a glossy one's draws agree with its density and its evaluation: the weight
    /// is f·cos/pdf for the same direction (within the relative rounding of those three
    /// evaluations of ≲ 40 operations each, 1e-4 generously), and its density is `pdf`'s.
    #[test]
    fn draws_agree_with_eval_and_pdf() {
        let (s, x) = plane(Material::diffuse(Vec3::splat(0.5)));
        let b = Bsdf::at(&s, &x);
        assert!(b.is_lambertian());
        let d = b
            .sample(Vec2::new(0.3, 0.7))
            .unwrap_or_else(|| panic!("no draw"));
        assert_eq!(d.weight, Vec3::splat(0.5));
        assert_eq!(b.residual(d.wi), Vec3::ZERO);
        assert_eq!(b.diffuse_reflectance(), Vec3::splat(0.5));
        for material in [
            Material::metallic_roughness(Vec3::new(0.9, 0.6, 0.3), 0.0, 0.4),
            Material::metallic_roughness(Vec3::new(0.9, 0.6, 0.3), 1.0, 0.2),
            Material::metallic_roughness(Vec3::new(0.9, 0.6, 0.3), 0.5, 0.8),
        ] {
            let (s, x) = plane(material);
            let b = Bsdf::at(&s, &x);
            assert!(!b.is_lambertian());
            let mut drawn = 0;
            for i in 0..64 {
                let key = SampleKey::new(7, i, 0);
                let Some(d) = b.sample(key.uniform_2d(0)) else {
                    continue;
                };
                drawn += 1;
                assert!(d.wi.dot(x.ns) > 0.0);
                let pdf = b.pdf(d.wi);
                assert!((pdf / d.pdf - 1.0).abs() < 1e-4, "{pdf} vs {}", d.pdf);
                let w = b.eval(d.wi) * d.cos / d.pdf;
                assert!(
                    ((w - d.weight).abs() / d.weight.max(Vec3::splat(1e-6))).max_element() < 1e-4,
                    "{w} vs {}",
                    d.weight
                );
                let r = b.residual(d.wi) + b.diffuse_reflectance() * FRAC_1_PI;
                assert!(((r - b.eval(d.wi)).abs()).max_element() < 1e-5 * (1.0 + r.max_element()));
            }
            assert!(drawn > 32, "{drawn} of 64 draws");
        }
    }

    /// `pdf_defensive` is the density `sample_defensive` reports for its own draws (the same
    /// sum of the same two densities: equal up to the rounding of the frame's rotation, 1e-5
    /// relative), on a Lambertian and on glossy surfaces.
    #[test]
    fn the_defensive_density_is_the_defensive_draws() {
        for material in [
            Material::diffuse(Vec3::splat(0.5)),
            Material::metallic_roughness(Vec3::new(0.9, 0.6, 0.3), 0.0, 0.4),
            Material::metallic_roughness(Vec3::new(0.9, 0.6, 0.3), 1.0, 0.1),
        ] {
            let (s, x) = plane(material);
            let b = Bsdf::at(&s, &x);
            let mut drawn = 0;
            for i in 0..64 {
                let Some(d) = b.sample_defensive(SampleKey::new(9, i, 0).uniform_2d(0)) else {
                    continue;
                };
                drawn += 1;
                let pdf = b.pdf_defensive(d.wi);
                assert!((pdf / d.pdf - 1.0).abs() < 1e-5, "{pdf} vs {}", d.pdf);
            }
            assert!(drawn > 32, "{drawn} of 64 draws");
        }
    }

    /// A material's ior reaches the BSDF both integrators shade with: the dielectric's F0 is
    /// ((ior − 1)/(ior + 1))² (irr-bsdf's `dielectric_f0`), and the default 1.5 is the
    /// specification's 0.04 exactly, in `Bsdf::at` and `Scene::reflection` alike.
    #[test]
    fn the_ior_sets_the_dielectrics_f0() {
        for (ior, f0) in [
            (1.5, 0.04),
            (1.33, irr_bsdf::dielectric_f0(1.33)),
            (2.0, 1.0 / 9.0),
        ] {
            let (s, x) = plane(Material {
                ior,
                ..Material::metallic_roughness(Vec3::ONE, 0.0, 0.5)
            });
            let Bsdf::Glossy { material, .. } = Bsdf::at(&s, &x) else {
                panic!("{ior}: not glossy");
            };
            // (ior − 1)²/(ior + 1)² in f32: a few roundings of a number near f0.
            assert!(
                (material.dielectric_f0() - f0).abs() <= 4.0 * f32::EPSILON * f0,
                "{ior}"
            );
            assert_eq!(
                material.specular_f0(),
                Vec3::splat(material.dielectric_f0())
            );
            assert_eq!(
                s.reflection(x.triangle, x.b1, x.b2).dielectric_f0(),
                material.dielectric_f0()
            );
        }
    }
}
