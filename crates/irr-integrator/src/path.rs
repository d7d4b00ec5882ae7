//! The unbiased reference: a path tracer with next-event estimation and multiple importance
//! sampling on Lambertian surfaces.
//!
//! # Which light paths each part carries
//! Number the path's surface vertices x₀ (the one the camera ray hits), x₁, x₂, … Every
//! contribution ends at an emitter vertex reached either by next-event estimation (NEE) from xₖ or
//! by the BSDF-sampled ray from xₖ hitting an emitter at xₖ₊₁; the two are combined by the power
//! heuristic, so each path is counted once in total weight. [`Radiance`] splits the estimate by the
//! vertex the light *reflects* at last before the camera, i.e. by the number of bounces:
//!
//! - `emitted`: Le(x₀ → camera). Paths `L E` (Heckbert's notation).
//! - `direct`: light that reflects once, at x₀: NEE from x₀ plus, MIS-weighted, the emission
//!   found at x₁ by x₀'s BSDF sample. Paths `L D E`.
//! - `indirect`: light that reflects at least twice: everything from NEE at x₁ and emission at x₂
//!   on. Paths `L D D+ E`.
//!
//! So `indirect` is exactly (ρ(x₀)/π)·E_ind(x₀), where E_ind is the irradiance at x₀ due to
//! radiance *reflected* (not emitted) by the surfaces x₀ sees: the quantity the irradiance cache
//! stores. An integrator that takes `emitted` and `direct` from here and replaces `indirect` by a
//! cache lookup counts every path once: the cache's gather rays must then exclude the emission of
//! the points they hit (it belongs to `direct`).

use crate::integrator::{Integrator, RayCounter};
use crate::scene::Scene;
use glam::Vec3;
use irr_geometry::{Ray, SurfacePoint};
use irr_sampling::rng::Dimensions;
use irr_sampling::{Frame, cosine_hemisphere_pdf, sample_cosine_hemisphere};
use std::f32::consts::FRAC_1_PI;
use std::ops::Add;

/// Settings of [`PathTracer`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PathSettings {
    /// Maximum number of bounces: paths of up to this many reflections are counted (0: emission
    /// seen directly only; 1: plus direct lighting). Default: 64. Range: any `u32`.
    pub max_depth: u32,
    /// The bounce from which Russian roulette may end a path. Default: 3. Range: any `u32`.
    pub rr_start: u32,
}

impl Default for PathSettings {
    fn default() -> Self {
        Self {
            max_depth: 64,
            rr_start: 3,
        }
    }
}

/// The radiance estimate split by the number of bounces (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Radiance {
    /// Emission of the first surface, seen directly.
    pub emitted: Vec3,
    /// Light reflected once, at the first surface.
    pub direct: Vec3,
    /// Light reflected two or more times.
    pub indirect: Vec3,
}

impl Radiance {
    /// The sum of the three parts.
    #[inline]
    pub fn total(&self) -> Vec3 {
        self.emitted + self.direct + self.indirect
    }
}

impl Add for Radiance {
    type Output = Radiance;
    fn add(self, rhs: Radiance) -> Radiance {
        Radiance {
            emitted: self.emitted + rhs.emitted,
            direct: self.direct + rhs.direct,
            indirect: self.indirect + rhs.indirect,
        }
    }
}

/// The power heuristic with β = 2 (Veach 1997, eq. 9.13), for one sample from each strategy.
#[inline]
pub fn power_heuristic(pdf_f: f32, pdf_g: f32) -> f32 {
    let f2 = pdf_f * pdf_f;
    let g2 = pdf_g * pdf_g;
    if f2.is_infinite() {
        return 1.0;
    }
    if f2 + g2 == 0.0 { 0.0 } else { f2 / (f2 + g2) }
}

/// A surface point prepared for shading: normals turned to the side the light leaves towards.
#[derive(Clone, Copy, Debug)]
pub struct ShadingPoint {
    /// The point.
    pub position: Vec3,
    /// The winding normal, turned to the side of `wo`.
    pub ng: Vec3,
    /// The shading normal, turned to the same side as `ng`.
    pub ns: Vec3,
    /// The triangle.
    pub triangle: u32,
    /// The point's barycentric coordinate of vertex 1 (textures are read there).
    pub b1: f32,
    /// The point's barycentric coordinate of vertex 2.
    pub b2: f32,
}

impl ShadingPoint {
    /// Turns the normals of `surface` to the side of `wo` (reflection is two-sided).
    #[inline]
    pub fn new(surface: &SurfacePoint, wo: Vec3) -> Self {
        let ng = if surface.geometric_normal.dot(wo) < 0.0 {
            -surface.geometric_normal
        } else {
            surface.geometric_normal
        };
        let ns = if surface.shading_normal.dot(ng) < 0.0 {
            -surface.shading_normal
        } else {
            surface.shading_normal
        };
        Self {
            position: surface.position,
            ng,
            ns,
            triangle: surface.triangle,
            b1: surface.b1,
            b2: surface.b2,
        }
    }
}

/// One next-event-estimation sample that reached its point unoccluded (see [`sample_light`]).
#[derive(Clone, Copy, Debug)]
pub struct LightArrival {
    /// The radiance the emitter sends towards the shading point.
    pub le: Vec3,
    /// cos θ at the shading point (shading normal), > 0.
    pub cos_surface: f32,
    /// The light sample's density per unit solid angle at the shading point, finite and > 0.
    pub pdf: f32,
}

/// One next-event-estimation sample at `x`: an emitter chosen by power and a point on it
/// uniformly by area (two dimensions of `dims`, always drawn), then a shadow ray. `None` when
/// the sample carries no light: no emitter, a direction below the shading or the geometric
/// surface, the emitter's back, or an occluder. The path tracer weighs the arrival against BSDF
/// sampling; the irradiance cache's direct light takes it alone.
pub fn sample_light(
    scene: &Scene,
    x: &ShadingPoint,
    dims: &mut Dimensions,
    rays: &mut RayCounter,
) -> Option<LightArrival> {
    let u_light = dims.next_1d();
    let u_point = dims.next_2d();
    let ls = scene.lights().sample(scene.geometry(), u_light, u_point)?;
    let to_light = ls.position - x.position;
    let dist2 = to_light.length_squared();
    let wi = to_light / dist2.sqrt();
    let cos_surface = wi.dot(x.ns);
    let cos_light = ls.normal.dot(wi).abs();
    let le = scene.emitted(ls.triangle, ls.b1, ls.b2, ls.normal, -wi);
    // Only directions above both the shading and the geometric surface carry light.
    if !(cos_surface > 0.0
        && wi.dot(x.ng) > 0.0
        && cos_light > 0.0
        && le != Vec3::ZERO
        && dist2 > 0.0)
    {
        return None;
    }
    let pdf = ls.pdf_area * dist2 / cos_light;
    let shadow = Ray::spawn_to(x.position, x.ng, ls.position, ls.normal);
    rays.shadow += 1;
    (pdf.is_finite() && !scene.geometry().occluded(&shadow)).then_some(LightArrival {
        le,
        cos_surface,
        pdf,
    })
}

/// The path-traced reference: Lambertian BSDF, NEE on area lights combined with BSDF sampling by
/// MIS, Russian roulette after `rr_start` bounces (unbiased: survivors are divided by the survival
/// probability).
#[derive(Clone, Copy, Debug, Default)]
pub struct PathTracer {
    /// The settings.
    pub settings: PathSettings,
}

impl PathTracer {
    /// A path tracer with these settings.
    pub fn new(settings: PathSettings) -> Self {
        Self { settings }
    }

    /// The radiance along `ray`, split by bounce count.
    pub fn li_split(
        &self,
        scene: &Scene,
        ray: &Ray,
        dims: &mut Dimensions,
        rays: &mut RayCounter,
    ) -> Radiance {
        rays.closest += 1;
        let Some(hit) = scene.geometry().intersect(ray) else {
            return Radiance::default();
        };
        let surface = scene.geometry().surface(ray, &hit);
        let wo = -ray.direction.normalize();
        let emitted = scene.emitted(
            surface.triangle,
            surface.b1,
            surface.b2,
            surface.geometric_normal,
            wo,
        );
        let mut out = self.reflected(scene, &surface, wo, dims, rays);
        out.emitted = emitted;
        out
    }

    /// The radiance leaving `surface` towards `wo` by reflection (its own emission excluded),
    /// split into `direct` (reflected once, here) and `indirect` (reflected here and before).
    ///
    /// This is the estimator of the light a final-gather ray brings back to an irradiance-cache
    /// record: what x₁ reflects towards x₀.
    pub fn reflected(
        &self,
        scene: &Scene,
        surface: &SurfacePoint,
        wo: Vec3,
        dims: &mut Dimensions,
        rays: &mut RayCounter,
    ) -> Radiance {
        let mut out = Radiance::default();
        let mut x = ShadingPoint::new(surface, wo);
        // β: the path throughput from the camera to the current vertex.
        let mut beta = Vec3::ONE;
        for depth in 0..self.settings.max_depth {
            // Bounce number depth+1 reflects at x: light arriving here has reflected depth+1
            // times by the time it reaches the camera. Bounce 1 is "direct", later ones "indirect".
            let albedo = scene.albedo(x.triangle, x.b1, x.b2);
            if albedo == Vec3::ZERO {
                break;
            }
            let f = albedo * FRAC_1_PI;
            let mut contribution = Vec3::ZERO;

            // Next-event estimation: pick a point on an emitter by power and area, and add its
            // light if it is visible, weighted against BSDF sampling by the power heuristic.
            if let Some(nee) = sample_light(scene, &x, dims, rays) {
                let w = power_heuristic(nee.pdf, cosine_hemisphere_pdf(nee.cos_surface));
                contribution += f * nee.le * (nee.cos_surface * w / nee.pdf);
            }

            // BSDF sampling: a cosine-distributed direction. For the Lambertian BSDF,
            // f·cos θ / pdf = ρ, so the throughput is multiplied by the albedo.
            let wi = Frame::from_normal(x.ns).to_world(sample_cosine_hemisphere(dims.next_2d()));
            let cos_surface = wi.dot(x.ns);
            let pdf_bsdf = cosine_hemisphere_pdf(cos_surface);
            // A shading normal can send the direction under the geometric surface: end the path
            // there rather than let light leak through.
            let sampled_ok = pdf_bsdf > 0.0 && wi.dot(x.ng) > 0.0;
            let mut next = None;
            if sampled_ok {
                let ray = Ray::spawn(x.position, x.ng, wi);
                rays.closest += 1;
                if let Some(hit) = scene.geometry().intersect(&ray) {
                    let surface = scene.geometry().surface(&ray, &hit);
                    // Emission found by the BSDF sample, weighted against NEE.
                    let le = scene.emitted(
                        surface.triangle,
                        surface.b1,
                        surface.b2,
                        surface.geometric_normal,
                        -wi,
                    );
                    if le != Vec3::ZERO {
                        let dist2 = (surface.position - x.position).length_squared();
                        let cos_light = surface.geometric_normal.dot(wi).abs();
                        let pdf_light =
                            scene.lights().pdf_area(surface.triangle) * dist2 / cos_light;
                        let w = if pdf_light.is_finite() {
                            power_heuristic(pdf_bsdf, pdf_light)
                        } else {
                            0.0
                        };
                        contribution += albedo * le * w;
                    }
                    next = Some(surface);
                }
            }

            // Add what reached this vertex, through the throughput, to the right part.
            if depth == 0 {
                out.direct += beta * contribution;
            } else {
                out.indirect += beta * contribution;
            }

            let Some(surface) = next else { break };
            beta *= albedo;
            x = ShadingPoint::new(&surface, -wi);

            // Russian roulette: past rr_start bounces, continue with probability q = min(1,
            // max β) and divide the survivors by q, so the expectation is unchanged.
            if depth + 1 >= self.settings.rr_start {
                let q = beta.max_element().min(1.0);
                if dims.next_1d() >= q {
                    break;
                }
                beta /= q;
            }
        }
        out
    }
}

impl Integrator for PathTracer {
    fn name(&self) -> &'static str {
        "path"
    }

    fn li(&self, scene: &Scene, ray: &Ray, dims: &mut Dimensions, rays: &mut RayCounter) -> Vec3 {
        self.li_split(scene, ray, dims, rays).total()
    }

    fn li_split(
        &self,
        scene: &Scene,
        ray: &Ray,
        dims: &mut Dimensions,
        rays: &mut RayCounter,
    ) -> Radiance {
        PathTracer::li_split(self, scene, ray, dims, rays)
    }
}
