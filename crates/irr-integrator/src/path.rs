//! The unbiased reference: a path tracer with next-event estimation and multiple importance
//! sampling, on the glTF metallic-roughness BSDF (module `bsdf`; Lambertian surfaces keep the
//! Lambertian arithmetic, cosine sampling with weight ρ).
//!
//! # Which light paths each part carries
//! Number the path's surface vertices x₀ (the one the camera ray hits), x₁, x₂, … The light
//! comes from three kinds of source: emitting triangles, punctual lights (points and directions:
//! delta distributions), and the background (a constant radiance B in every direction in which a
//! ray leaves the scene). An emitting triangle is reached either by next-event estimation (NEE)
//! from xₖ or by the BSDF-sampled ray from xₖ hitting it at xₖ₊₁; the two are combined by the
//! power heuristic, so each path is counted once in total weight. A punctual light is reached by
//! NEE only (no sampled direction can hit a point or a single direction), so its NEE sample has
//! weight 1. The background is reached by BSDF sampling only (no light sample picks it; cosine
//! sampling is the right importance sampling for a uniform environment), so an escaping BSDF ray
//! has weight 1. [`Radiance`] splits the estimate by the vertex the light *reflects* at last
//! before the camera, i.e. by the number of bounces, and by the source:
//!
//! - `emitted`: Le(x₀ → camera), or B when the camera ray leaves the scene. Paths `L E` and
//!   `L B` (Heckbert's notation, with B for the background).
//! - `direct`: light from the emitting triangles and the punctual lights that reflects once, at
//!   x₀: NEE from x₀ plus, MIS-weighted, the emission found at x₁ by x₀'s BSDF sample. Paths
//!   `L D E`.
//! - `indirect`: everything else: light that reflects at least twice (NEE at x₁ and emission at
//!   x₂ on, paths `L D D+ E`), and **all the background's light that reflects** (paths `L D+ B`,
//!   the background's once-reflected light `L D B` included: x₀'s BSDF sample escaping).
//! - `glossy`: the part of `indirect` that x₀ reflects through f − ρ_d/π, the BSDF minus the
//!   diffuse stand-in ρ_d/π an irradiance cache multiplies its irradiance by (`Bsdf::residual`):
//!   x₀'s BSDF sample carries the share residual·cos θ/pdf of its weight f·cos θ/pdf, and every
//!   indirect contribution behind it counts through that share. Only a camera path
//!   ([`PathTracer::li_split`]) keeps it; it draws no random number.
//!
//! So `indirect` is exactly ∫ f(x₀) L_ind cos θ dω, which on a Lambertian x₀ is (ρ(x₀)/π)·E_ind(x₀),
//! where E_ind is the irradiance at x₀ due to all
//! the radiance arriving there *except* what the light sampler's emitters send straight to it:
//! the radiance reflected by the surfaces x₀ sees, and the background where x₀ sees no surface.
//! That is the quantity the irradiance cache stores: its gather rays bring back what the point
//! they hit reflects (excluding that point's emission: it belongs to `direct`), and the
//! background when they hit nothing. An integrator that takes `emitted` and `direct` from here
//! and replaces `indirect` by a cache lookup counts every path once.

use crate::bsdf::Bsdf;
use crate::integrator::{FirstHit, Integrator, RayCounter, li_each};
use crate::light::LightSample;
use crate::scene::Scene;
use glam::Vec3;
use irr_geometry::{Hit, Ray, SurfacePoint};
use irr_sampling::cosine_hemisphere_pdf;
use irr_sampling::rng::Dimensions;
use std::f32::consts::FRAC_1_PI;
use std::ops::Add;

/// Settings of [`PathTracer`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathSettings {
    /// Maximum number of bounces: paths of up to this many reflections are counted (0: emission
    /// seen directly only; 1: plus direct lighting). Default: 64. Range: any `u32`.
    pub max_depth: u32,
    /// The bounce from which Russian roulette may end a path. Default: 5, as Mitsuba 3's
    /// `rr_depth` (docs/performance.md, "Russian roulette"). Range: any `u32`.
    pub rr_start: u32,
    /// Adaptive camera sampling ([`Integrator::pixel_error`]): the relative standard error of
    /// a pixel's mean luminance at which it may stop before its `spp`. Default: 0, every pixel
    /// takes every sample (the unbiased reference). Range: finite, ≥ 0.
    pub pixel_error: f32,
}

impl Default for PathSettings {
    fn default() -> Self {
        Self {
            max_depth: 64,
            rr_start: 5,
            pixel_error: 0.0,
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
    /// Of `indirect`, the part whose last reflection, at the first surface, is by its BSDF
    /// minus the diffuse stand-in an irradiance cache covers, f − ρ_d/π ([`Bsdf::residual`]):
    /// the glossy lobes' indirect light (zero on a Lambertian surface; it may be negative where
    /// the diffuse lobe falls below its stand-in). Not added again by [`Radiance::total`].
    pub glossy: Vec3,
}

impl Radiance {
    /// The sum of the three parts (`glossy` is within `indirect`).
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
            glossy: self.glossy + rhs.glossy,
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

/// The power heuristic's weight of emission that a BSDF draw of density `pdf_bsdf` from `from`
/// along the unit direction `wi` found at `surface`, against `light_samples` light samples'
/// density for that point (each the light sampler's, per unit solid angle at `from`); 0 where
/// that density is not finite (the emitter seen edge-on).
#[inline]
pub(crate) fn emission_weight(
    scene: &Scene,
    surface: &SurfacePoint,
    (from, wi): (Vec3, Vec3),
    pdf_bsdf: f32,
    light_samples: f32,
) -> f32 {
    let dist2 = (surface.position - from).length_squared();
    let cos_light = surface.geometric_normal.dot(wi).abs();
    let pdf_light = scene.lights().pdf_area(surface.triangle) * dist2 / cos_light;
    if pdf_light.is_finite() {
        power_heuristic(pdf_bsdf, light_samples * pdf_light)
    } else {
        0.0
    }
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
    /// The direction the light leaves towards (back along the ray that found the point), of
    /// whatever length the caller gave; [`crate::Bsdf::at`] normalises it where a BSDF needs it.
    pub wo: Vec3,
}

impl ShadingPoint {
    /// Turns the normals of `surface` to the side of `wo` (reflection is two-sided; any length).
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
            wo,
        }
    }
}

/// One next-event-estimation sample that reached its point unoccluded (see [`sample_light`]).
///
/// Its contribution to the light reflected at the point is f·`le`·`cos_surface`/`pdf` (f the
/// BSDF) for every kind of light: for an emitting triangle `le` is a radiance and `pdf` a density
/// per unit solid angle; for a punctual light (`delta`) `le` is the irradiance it gives a surface
/// facing it (I·falloff/r², or E) and `pdf` the probability of choosing it.
#[derive(Clone, Copy, Debug)]
pub struct LightArrival {
    /// The unit direction from the shading point towards the light.
    pub wi: Vec3,
    /// The radiance the emitter sends towards the shading point, or, for a punctual light, the
    /// irradiance it gives a surface at the point facing it.
    pub le: Vec3,
    /// cos θ at the shading point (shading normal), > 0.
    pub cos_surface: f32,
    /// The light sample's density per unit solid angle at the shading point, or, for a
    /// punctual light, the probability of having chosen it; finite and > 0.
    pub pdf: f32,
    /// Whether the light is punctual (a delta distribution): no BSDF sample can reach it, so
    /// multiple importance sampling gives this sample weight 1.
    pub delta: bool,
}

/// One next-event-estimation sample at `x`: a light chosen by power and, on an emitting
/// triangle, a point uniformly by area (two draws of `dims`, a 1-D one for the choice and a 2-D
/// one for the point, always both, whatever the light chosen), then a shadow ray. `None` when
/// the sample carries no light: no light, a direction below the shading or the geometric
/// surface, the emitter's back, outside a spot's cone, or an occluder. The path tracer weighs
/// the arrival against BSDF sampling; the irradiance cache's direct light takes it alone.
pub fn sample_light(
    scene: &Scene,
    x: &ShadingPoint,
    dims: &mut Dimensions,
    rays: &mut RayCounter,
) -> Option<LightArrival> {
    let (arrival, shadow) = light_sample(scene, x, dims)?;
    rays.shadow += 1;
    (!scene.occluded(&shadow)).then_some(arrival)
}

/// [`sample_light`] up to its shadow ray, untraced and uncounted: the arrival, which counts
/// only if the ray is unoccluded, and the ray. (A batch of paths traces its shadow rays
/// together: [`PathTracer::reflected_many`].)
pub(crate) fn light_sample(
    scene: &Scene,
    x: &ShadingPoint,
    dims: &mut Dimensions,
) -> Option<(LightArrival, Ray)> {
    let u_light = dims.next_1d();
    let u_point = dims.next_2d();
    match scene.lights().sample(scene.geometry(), u_light, u_point)? {
        LightSample::Area {
            position,
            normal,
            triangle,
            b1,
            b2,
            pdf_area,
        } => {
            let to_light = position - x.position;
            let dist2 = to_light.length_squared();
            let wi = to_light / dist2.sqrt();
            let cos_surface = wi.dot(x.ns);
            let cos_light = normal.dot(wi).abs();
            let le = scene.emitted_to_light_sample(triangle, (b1, b2), normal, -wi);
            // Only directions above both the shading and the geometric surface carry light.
            if !(cos_surface > 0.0
                && wi.dot(x.ng) > 0.0
                && cos_light > 0.0
                && le != Vec3::ZERO
                && dist2 > 0.0)
            {
                return None;
            }
            let pdf = pdf_area * dist2 / cos_light;
            let shadow = Ray::spawn_to(x.position, x.ng, position, normal);
            let arrival = LightArrival {
                wi,
                le,
                cos_surface,
                pdf,
                delta: false,
            };
            pdf.is_finite().then_some((arrival, shadow))
        }
        LightSample::Punctual { light, probability } => {
            let incidence = light.incidence(x.position)?;
            let wi = incidence.wi;
            let cos_surface = wi.dot(x.ns);
            if !(cos_surface > 0.0
                && wi.dot(x.ng) > 0.0
                && incidence.irradiance != Vec3::ZERO
                && probability > 0.0)
            {
                return None;
            }
            // A point has no surface to offset the ray's end from: the segment ends exactly at
            // the light (a zero normal leaves `spawn_to`'s end unmoved), and a hit counts only if
            // provably before it. A directional light is at infinity: a ray with no end.
            let shadow = match incidence.position {
                Some(p) => Ray::spawn_to(x.position, x.ng, p, Vec3::ZERO),
                None => Ray::spawn(x.position, x.ng, wi),
            };
            let arrival = LightArrival {
                wi,
                le: incidence.irradiance,
                cos_surface,
                pdf: probability,
                delta: true,
            };
            Some((arrival, shadow))
        }
    }
}

/// What a camera ray meets first, as both integrators' `li_split` start: the surface, the
/// direction back to the camera and the radiance the surface emits towards it (an unlit
/// surface's colour, `Scene::is_unlit`: all the camera sees of it, so no path goes on from it);
/// or, for a ray that leaves the scene, the finished estimate: the background seen directly (a
/// path `L B`, all `emitted`). Counts the ray.
pub(crate) fn first_surface(
    scene: &Scene,
    ray: &Ray,
    rays: &mut RayCounter,
) -> Result<(SurfacePoint, Vec3, Vec3, f32), Radiance> {
    rays.closest += 1;
    let Some(hit) = scene.intersect_camera(ray) else {
        return Err(Radiance {
            emitted: scene.background(),
            ..Radiance::default()
        });
    };
    let surface = scene.geometry().surface(ray, &hit);
    let wo = -ray.direction.normalize();
    let emitted = if scene.is_unlit(hit.triangle) {
        scene.albedo(surface.triangle, surface.b1, surface.b2)
    } else {
        scene.emitted_at(&surface, wo)
    };
    Ok((surface, wo, emitted, hit.t))
}

/// The path-traced reference: the metallic-roughness BSDF (module `bsdf`), NEE on area and punctual lights combined with BSDF
/// sampling by MIS, the background found by BSDF sampling, Russian roulette after `rr_start`
/// bounces (unbiased: survivors are divided by the survival probability).
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

    /// The radiance along `ray`, split by bounce count and source (see the module docs).
    pub fn li_split(
        &self,
        scene: &Scene,
        ray: &Ray,
        dims: &mut Dimensions,
        rays: &mut RayCounter,
    ) -> Radiance {
        self.li_split_first_hit(scene, ray, dims, rays).0
    }

    /// [`PathTracer::li_split`] and what the ray met first (`None` for a miss), found on the
    /// way: no ray more.
    pub fn li_split_first_hit(
        &self,
        scene: &Scene,
        ray: &Ray,
        dims: &mut Dimensions,
        rays: &mut RayCounter,
    ) -> (Radiance, Option<FirstHit>) {
        let (surface, wo, emitted, t) = match first_surface(scene, ray, rays) {
            Ok(first) => first,
            Err(background) => return (background, None),
        };
        let first = FirstHit::at(scene, &surface, wo, t);
        if scene.is_unlit(surface.triangle) {
            let seen = Radiance {
                emitted,
                ..Radiance::default()
            };
            return (seen, Some(first));
        }
        let mut out = self.walk(
            scene,
            Path::new(scene, &surface, wo, *dims, true),
            dims,
            rays,
        );
        out.emitted = emitted;
        (out, Some(first))
    }

    /// The radiance leaving `surface` towards `wo` by reflection (its own emission excluded),
    /// split into `direct` (the light sampler's emitters' light reflected once, here) and
    /// `indirect` (reflected here and before, and the background's light reflected here).
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
        self.walk(
            scene,
            Path::new(scene, surface, wo, *dims, false),
            dims,
            rays,
        )
    }

    /// Follows `path` to its end; `dims` takes its dimensions' final state.
    fn walk(
        &self,
        scene: &Scene,
        mut path: Path,
        dims: &mut Dimensions,
        rays: &mut RayCounter,
    ) -> Radiance {
        while let Some(b) = self.begin(scene, &mut path, rays) {
            let occluded = b.shadow.is_some_and(|r| scene.occluded(&r));
            let hit = b.ray.and_then(|r| scene.intersect(&r));
            if !self.end(scene, &mut path, &b, occluded, hit) {
                break;
            }
        }
        *dims = path.dims;
        path.out
    }

    /// [`PathTracer::reflected`] for many points at once: `out[i]` and `dims[i]` (drawn from
    /// as `reflected` draws) come out exactly as `reflected` leaves them for `starts[i]` (a
    /// surface and the direction `wo` the light leaves towards) and `dims[i]`, and `rays`
    /// counts the same rays. The paths advance a bounce at a time, each bounce's shadow rays
    /// and then its BSDF rays traced in one batch (`Geometry::occluded_stream`,
    /// `Geometry::intersect_stream`), which on a large scene keeps several rays in flight.
    ///
    /// # Panics
    /// If the three slices differ in length.
    pub fn reflected_many(
        &self,
        scene: &Scene,
        starts: &[(SurfacePoint, Vec3)],
        dims: &mut [Dimensions],
        out: &mut [Radiance],
        rays: &mut RayCounter,
    ) {
        assert!(
            starts.len() == dims.len() && dims.len() == out.len(),
            "one dimension stream and one answer per start"
        );
        let mut paths: Vec<Path> = starts
            .iter()
            .zip(dims.iter())
            .map(|((surface, wo), d)| Path::new(scene, surface, *wo, *d, false))
            .collect();
        // The paths still going, in order, and this bounce's work for each.
        let mut live: Vec<usize> = (0..paths.len()).collect();
        let mut bounces: Vec<(usize, Bounce)> = Vec::with_capacity(live.len());
        let (mut shadows, mut bsdf) = (Vec::new(), Vec::new());
        let (mut occluded, mut hits) = (Vec::new(), Vec::new());
        while !live.is_empty() {
            bounces.clear();
            shadows.clear();
            bsdf.clear();
            for &i in &live {
                if let Some(b) = self.begin(scene, &mut paths[i], rays) {
                    shadows.extend(b.shadow);
                    bsdf.extend(b.ray);
                    bounces.push((i, b));
                }
            }
            occluded.clear();
            occluded.resize(shadows.len(), false);
            scene.occluded_stream(&shadows, &mut occluded);
            hits.clear();
            hits.resize(bsdf.len(), None);
            scene.intersect_stream(&bsdf, &mut hits);
            let (mut occluded, mut hits) = (occluded.iter(), hits.iter());
            live.clear();
            for (i, b) in &bounces {
                let blocked = b.shadow.is_some() && occluded.next().copied().unwrap_or(true);
                let hit = b.ray.and_then(|_| hits.next().copied().flatten());
                if self.end(scene, &mut paths[*i], b, blocked, hit) {
                    live.push(*i);
                }
            }
        }
        for ((path, d), o) in paths.into_iter().zip(dims).zip(out) {
            *d = path.dims;
            *o = path.out;
        }
    }

    /// The first half of a bounce of `path` at its vertex: the light sample (its shadow ray
    /// untraced) and the BSDF sample (its ray untraced), with the rays counted. `None` when
    /// the path ends here (no bounce left, or a black surface).
    #[inline(always)]
    fn begin(&self, scene: &Scene, path: &mut Path, rays: &mut RayCounter) -> Option<Bounce> {
        if path.depth >= self.settings.max_depth {
            return None;
        }
        // Bounce number depth+1 reflects at x: light arriving here has reflected depth+1
        // times by the time it reaches the camera. Bounce 1 is "direct", later ones "indirect".
        let x = &path.x;
        let bsdf = Bsdf::at(scene, x);
        if bsdf.is_black() {
            return None;
        }
        // Next-event estimation: pick a light by power (and a point on a triangle by area);
        // its light counts if the shadow ray is unoccluded (`end`).
        let (nee, shadow) = light_sample(scene, x, &mut path.dims).unzip();
        rays.shadow += u64::from(shadow.is_some());
        // The BSDF towards the light and the density with which BSDF sampling would have
        // found that direction, for the power heuristic (a Lambertian surface's: ρ/π and
        // cos/π).
        let (nee_f, nee_pdf_bsdf) = match (&bsdf, &nee) {
            (Bsdf::Lambertian { albedo, .. }, Some(n)) => {
                (*albedo * FRAC_1_PI, cosine_hemisphere_pdf(n.cos_surface))
            }
            (_, Some(n)) => (bsdf.eval(n.wi), bsdf.pdf(n.wi)),
            (_, None) => (Vec3::ZERO, 0.0),
        };
        // BSDF sampling: a cosine-distributed direction on a Lambertian surface, a lobe and a
        // direction from it on a glossy one.
        let draw = bsdf.draw(&mut path.dims);
        // A shading normal can send the direction under the geometric surface (or a
        // refraction above it): end the path there rather than let light leak through.
        let (wi, weight, pdf_bsdf) =
            draw.map_or((Vec3::ZERO, Vec3::ZERO, 0.0), |d| (d.wi, d.weight, d.pdf));
        let ray = draw
            .filter(|d| pdf_bsdf > 0.0 && d.leaves(x.ng))
            .map(|_| Ray::spawn(x.position, x.ng, wi));
        rays.closest += u64::from(ray.is_some());
        // The share of that weight the residual f − ρ_d/π carries, at x₀ of a camera path:
        // (f − ρ_d/π)·cos/pdf, from the draw's own f·cos/pdf (no second evaluation of f).
        let residual = match draw {
            Some(d) if path.glossy && path.depth == 0 && d.transmitted => d.weight,
            Some(d) if path.glossy && path.depth == 0 && !bsdf.is_lambertian() => {
                d.weight - bsdf.diffuse_reflectance() * (FRAC_1_PI * d.cos / d.pdf)
            }
            _ => Vec3::ZERO,
        };
        Some(Bounce {
            weight,
            residual,
            nee,
            nee_f,
            nee_pdf_bsdf,
            shadow,
            wi,
            pdf_bsdf,
            light_samples: draw.map_or(1.0, |d| d.light_samples(1.0)),
            ray,
        })
    }

    /// The second half of bounce `b` of `path`, given whether its shadow ray was `occluded`
    /// and what its BSDF ray hit: adds the light that reached the vertex, moves the path on.
    /// Returns whether it goes on.
    #[inline(always)]
    fn end(
        &self,
        scene: &Scene,
        path: &mut Path,
        b: &Bounce,
        occluded: bool,
        hit: Option<Hit>,
    ) -> bool {
        // Inside an absorbing volume, the segment to the hit keeps e^(−σd) of the light.
        let tr = if b.ray.is_some() {
            scene.segment_transmittance(&path.x, b.wi, hit.map(|h| h.t))
        } else {
            Vec3::ONE
        };
        let weight = b.weight * tr;
        let residual = b.residual * tr;
        let mut contribution = Vec3::ZERO;
        // The light sample, weighted against BSDF sampling by the power heuristic; a punctual
        // light has no BSDF-sampling strategy, so its weight is 1.
        if let Some(nee) = b.nee.filter(|_| !occluded) {
            let w = if nee.delta {
                1.0
            } else {
                power_heuristic(nee.pdf, b.nee_pdf_bsdf)
            };
            contribution += b.nee_f * nee.le * (nee.cos_surface * w / nee.pdf);
        }
        // The BSDF sample's weight f·cos θ / pdf multiplies the throughput (for the Lambertian
        // BSDF it is the albedo).
        let mut next = None;
        let mut escaped = Vec3::ZERO;
        if let Some(ray) = &b.ray {
            match hit {
                // The ray leaves the scene: the background, found by BSDF sampling alone (no
                // light sample picks it), so with weight 1.
                None => escaped = weight * scene.background(),
                Some(hit) => {
                    let surface = scene.geometry().surface(ray, &hit);
                    // Emission found by the BSDF sample, weighted against NEE.
                    let le = scene.emitted_at(&surface, -b.wi);
                    if le != Vec3::ZERO {
                        let ray = (path.x.position, b.wi);
                        let w = emission_weight(scene, &surface, ray, b.pdf_bsdf, b.light_samples);
                        contribution += weight * le * w;
                    }
                    next = Some(surface);
                }
            }
        }
        // Add what reached this vertex, through the throughput, to the right part: the
        // emitters' light reflected here for the first time is `direct` at the first vertex;
        // the background's light is `indirect` at every vertex (module docs).
        let beta = path.beta;
        if path.depth == 0 {
            path.out.direct += beta * contribution;
            // x₀'s escaping sample through the residual's share of its weight.
            if b.ray.is_some() && hit.is_none() {
                path.out.glossy += residual * scene.background();
            }
        } else {
            path.out.indirect += beta * contribution;
            path.out.glossy += path.glossy_beta * (contribution + escaped);
        }
        path.out.indirect += beta * escaped;

        let Some(surface) = next else { return false };
        path.beta *= weight;
        path.glossy_beta = if path.depth == 0 {
            residual
        } else {
            path.glossy_beta * weight
        };
        path.x = scene.shading_point(&surface, -b.wi);
        path.depth += 1;
        // Russian roulette: past rr_start bounces, continue with probability q = min(1, max β)
        // and divide the survivors by q, so the expectation is unchanged.
        if path.depth >= self.settings.rr_start {
            let q = path.beta.max_element().min(1.0);
            if path.dims.next_1d() >= q {
                return false;
            }
            path.beta /= q;
            path.glossy_beta /= q;
        }
        true
    }
}

/// A path between bounces ([`PathTracer::reflected`]): its vertex, its throughput β from the
/// camera to the vertex, its random dimensions, what it has gathered, and the bounces made;
/// with `glossy` (a camera path), also the throughput through x₀'s residual f − ρ_d/π (module
/// docs, `glossy`).
struct Path {
    x: ShadingPoint,
    beta: Vec3,
    glossy: bool,
    glossy_beta: Vec3,
    dims: Dimensions,
    out: Radiance,
    depth: u32,
}

impl Path {
    fn new(
        scene: &Scene,
        surface: &SurfacePoint,
        wo: Vec3,
        dims: Dimensions,
        glossy: bool,
    ) -> Path {
        Path {
            x: scene.shading_point(surface, wo),
            beta: Vec3::ONE,
            glossy,
            glossy_beta: Vec3::ZERO,
            dims,
            out: Radiance::default(),
            depth: 0,
        }
    }
}

/// The rays of one bounce ([`PathTracer::begin`]) and what `end` needs of it: the light sample
/// with the BSDF's value and density towards it, its shadow ray, and the BSDF sample (its
/// weight f·cos/pdf, at x₀ of a camera path the residual's share of it) and its ray (none when
/// the direction is below the surface).
struct Bounce {
    weight: Vec3,
    residual: Vec3,
    nee: Option<LightArrival>,
    nee_f: Vec3,
    nee_pdf_bsdf: f32,
    shadow: Option<Ray>,
    wi: Vec3,
    pdf_bsdf: f32,
    /// The light samples an emitter the BSDF's ray finds is weighed against (none after a
    /// refraction: `BsdfDraw::light_samples`).
    light_samples: f32,
    ray: Option<Ray>,
}

impl Integrator for PathTracer {
    fn name(&self) -> &'static str {
        "path"
    }

    fn li(&self, scene: &Scene, ray: &Ray, dims: &mut Dimensions, rays: &mut RayCounter) -> Vec3 {
        self.li_split(scene, ray, dims, rays).total()
    }

    fn pixel_error(&self) -> f32 {
        self.settings.pixel_error
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

    /// The first hits come from the paths' own first intersections.
    fn li_split_many_first_hits(
        &self,
        scene: &Scene,
        camera_rays: &[Ray],
        dims: &mut [Dimensions],
        out: &mut [Radiance],
        first: &mut [Option<FirstHit>],
        rays: &mut RayCounter,
    ) {
        assert!(
            camera_rays.len() == dims.len() && dims.len() == out.len() && out.len() == first.len(),
            "one dimension stream, answer and first hit per ray"
        );
        for (((ray, d), o), f) in camera_rays.iter().zip(dims).zip(out).zip(first) {
            (*o, *f) = self.li_split_first_hit(scene, ray, d, rays);
        }
    }

    /// Where the geometry streams (`Geometry::streams`: a large scene), the camera rays' first
    /// surfaces one at a time (neighbouring camera rays cross the same nodes), then the paths
    /// from them together ([`PathTracer::reflected_many`]); elsewhere `li` for each ray.
    fn li_many(
        &self,
        scene: &Scene,
        camera_rays: &[Ray],
        dims: &mut [Dimensions],
        out: &mut [Vec3],
        rays: &mut RayCounter,
    ) {
        if !scene.geometry().streams() {
            return li_each(self, scene, camera_rays, dims, out, rays);
        }
        assert!(
            camera_rays.len() == dims.len() && dims.len() == out.len(),
            "one dimension stream and one answer per ray"
        );
        // (index, emission seen) of the rays that hit a surface, and where their paths start.
        let mut hit = Vec::with_capacity(camera_rays.len());
        let mut starts = Vec::with_capacity(camera_rays.len());
        for (i, ray) in camera_rays.iter().enumerate() {
            match first_surface(scene, ray, rays) {
                Ok((surface, _, emitted, _)) if scene.is_unlit(surface.triangle) => {
                    out[i] = emitted;
                }
                Ok((surface, wo, emitted, _)) => {
                    hit.push((i, emitted));
                    starts.push((surface, wo));
                }
                Err(background) => out[i] = background.total(),
            }
        }
        let mut path_dims: Vec<Dimensions> = hit.iter().map(|&(i, _)| dims[i]).collect();
        let mut reflected = vec![Radiance::default(); starts.len()];
        self.reflected_many(scene, &starts, &mut path_dims, &mut reflected, rays);
        for ((&(i, emitted), d), r) in hit.iter().zip(path_dims).zip(reflected) {
            dims[i] = d;
            // As `li_split` assembles it.
            out[i] = Radiance { emitted, ..r }.total();
        }
    }
}
