//! The interface every integrator implements, the ray counter it reports into, and what a
//! camera ray sees first ([`first_hit`], for a renderer's auxiliary images).

use crate::path::Radiance;
use crate::scene::Scene;
use glam::Vec3;
use irr_geometry::{Ray, SurfacePoint};
use irr_sampling::rng::Dimensions;
use std::ops::AddAssign;

/// Rays traced, by kind. Each thread keeps its own and the renderer adds them up.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounter {
    /// Closest-hit queries (camera rays and path extensions, gather rays).
    pub closest: u64,
    /// Occlusion queries (shadow rays, ambient-occlusion rays).
    pub shadow: u64,
}

impl RayCounter {
    /// All rays.
    #[inline]
    pub fn total(&self) -> u64 {
        self.closest + self.shadow
    }
}

impl AddAssign for RayCounter {
    fn add_assign(&mut self, rhs: Self) {
        self.closest += rhs.closest;
        self.shadow += rhs.shadow;
    }
}

/// How a renderer hands camera samples to an integrator's batched calls
/// ([`Integrator::li_many`], [`Integrator::li_split_many`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Batching {
    /// A tile's pixels, one sample index at a time: every answer is its ray's alone (`li`'s,
    /// bit for bit). The path tracer traces such a batch's paths together.
    #[default]
    BySampleIndex,
    /// One pixel's samples at a time, in index order, at most [`PIXEL_BATCH`] per call: the
    /// integrator may share work between them (the irradiance cache looks its records up once
    /// per pixel), so an answer depends on its pixel's other samples in the call, never on other
    /// pixels'. A renderer that replays a pixel makes the same calls.
    ByPixel,
}

/// The most samples of one pixel in one call, with [`Batching::ByPixel`] (a pixel with more
/// samples takes several calls, each of consecutive indices).
pub const PIXEL_BATCH: usize = 1024;

/// Answers "what radiance arrives along this ray?" (pbrt-v4's `RayIntegrator::Li`).
///
/// Tiles, threads, progress and output are the renderer's business, not the integrator's.
pub trait Integrator: Sync {
    /// A short name for logs and file names ("path", "ao", ...).
    fn name(&self) -> &'static str;

    /// Work before the final pass (Mitsuba 0.6 runs the irradiance cache's overture here). The
    /// default does nothing.
    fn preprocess(&mut self, _scene: &Scene) {}

    /// The radiance arriving at `ray.origin` from direction `ray.direction` (so travelling along
    /// −`ray.direction`). Every random number comes from `dims`, so the estimate depends only on
    /// the sample's key; `rays` counts the rays traced.
    fn li(&self, scene: &Scene, ray: &Ray, dims: &mut Dimensions, rays: &mut RayCounter) -> Vec3;

    /// [`Integrator::li`] split by the light paths each part carries: `emitted` (the first
    /// surface's own emission), `direct` (light reflected once, there) and `indirect` (reflected
    /// at least twice); see [`Radiance`]. It draws the same random numbers as `li`, and
    /// `li_split(…).total()` is `li(…)` bit for bit, so a renderer may take the colour from either.
    ///
    /// The default, for an integrator with no such split (ambient occlusion), puts the whole
    /// estimate in `emitted`.
    fn li_split(
        &self,
        scene: &Scene,
        ray: &Ray,
        dims: &mut Dimensions,
        rays: &mut RayCounter,
    ) -> Radiance {
        Radiance {
            emitted: self.li(scene, ray, dims, rays),
            ..Radiance::default()
        }
    }

    /// Adaptive camera sampling: the relative standard error of a pixel's mean luminance at
    /// which the renderer may stop giving it samples before its `spp` (checked after rounds of
    /// doubling size from a quarter of `spp`, from the pixel's own samples), 0 for every pixel
    /// taking all of them. The default: 0 (the path tracer stays the unbiased reference: a
    /// rule that stops on a pixel's own samples biases it slightly).
    fn pixel_error(&self) -> f32 {
        0.0
    }

    /// How the renderer should batch camera samples for [`Integrator::li_many`] and
    /// [`Integrator::li_split_many`]. The default: [`Batching::BySampleIndex`].
    fn batching(&self) -> Batching {
        Batching::BySampleIndex
    }

    /// [`Integrator::li`] for many rays, batched as [`Integrator::batching`] says. With
    /// [`Batching::BySampleIndex`], `out[i]` and `dims[i]` come out exactly as `li` leaves them
    /// for `rays[i]` and `dims[i]`, and `rays` counts the same rays. An integrator overrides it
    /// to trace the rays' paths together (the path tracer traces each bounce of all its paths as
    /// one batch); the default calls `li` for each ray in turn.
    ///
    /// # Panics
    /// If the three slices differ in length.
    fn li_many(
        &self,
        scene: &Scene,
        camera_rays: &[Ray],
        dims: &mut [Dimensions],
        out: &mut [Vec3],
        rays: &mut RayCounter,
    ) {
        li_each(self, scene, camera_rays, dims, out, rays);
    }

    /// [`Integrator::li_split`] for many rays, batched as [`Integrator::batching`] says;
    /// `li_split_many(…)[i].total()` is `li_many`'s `out[i]` bit for bit for the same batch, so a
    /// renderer may take the colour from either. The default calls `li_split` for each ray.
    ///
    /// # Panics
    /// If the three slices differ in length.
    fn li_split_many(
        &self,
        scene: &Scene,
        camera_rays: &[Ray],
        dims: &mut [Dimensions],
        out: &mut [Radiance],
        rays: &mut RayCounter,
    ) {
        assert!(
            camera_rays.len() == dims.len() && dims.len() == out.len(),
            "one dimension stream and one answer per ray"
        );
        for ((ray, d), o) in camera_rays.iter().zip(dims).zip(out) {
            *o = self.li_split(scene, ray, d, rays);
        }
    }

    /// [`Integrator::li_split_many`] that also reports what each camera ray met first
    /// (`first[i]`, `None` for a miss), for a renderer's albedo, normal and depth images
    /// (pbrt-v4's `VisibleSurface`). `out` and `dims` come out as `li_split_many` leaves them.
    /// The default traces each camera ray's first hit once more ([`first_hit`]); an integrator
    /// that finds it anyway (the path tracer, the irradiance cache) overrides this so that the
    /// images cost no ray.
    ///
    /// # Panics
    /// If the four slices differ in length.
    fn li_split_many_first_hits(
        &self,
        scene: &Scene,
        camera_rays: &[Ray],
        dims: &mut [Dimensions],
        out: &mut [Radiance],
        first: &mut [Option<FirstHit>],
        rays: &mut RayCounter,
    ) {
        assert_eq!(camera_rays.len(), first.len(), "one first hit per ray");
        self.li_split_many(scene, camera_rays, dims, out, rays);
        for (ray, f) in camera_rays.iter().zip(first) {
            *f = first_hit(scene, ray, rays);
        }
    }
}

/// [`Integrator::li`] of `integrator` for each ray in turn, as `li_many`'s default does.
///
/// # Panics
/// If the three slices differ in length.
pub(crate) fn li_each<I: Integrator + ?Sized>(
    integrator: &I,
    scene: &Scene,
    camera_rays: &[Ray],
    dims: &mut [Dimensions],
    out: &mut [Vec3],
    rays: &mut RayCounter,
) {
    assert!(
        camera_rays.len() == dims.len() && dims.len() == out.len(),
        "one dimension stream and one answer per ray"
    );
    for ((ray, d), o) in camera_rays.iter().zip(dims).zip(out) {
        *o = integrator.li(scene, ray, d, rays);
    }
}

/// What a ray meets first: the surface data a denoiser or a compositor reads beside the
/// radiance (albedo, normal, depth).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstHit {
    /// The hit's parameter along the ray, in units of the direction's length: the distance
    /// from the ray's origin in scene units for a unit direction (camera rays have one).
    pub distance: f32,
    /// The diffuse reflectance ρ of the surface hit, in [0, 1].
    pub albedo: Vec3,
    /// The unit shading normal at the hit, in world space, turned to the side the ray comes
    /// from (reflection is two-sided; Cycles' normal pass does the same).
    pub normal: Vec3,
}

/// The first surface along `ray`, or `None` if it hits nothing: one closest-hit query,
/// counted in `rays`. Uses no random numbers, so calling it beside an integrator leaves the
/// integrator's estimate unchanged.
pub fn first_hit(scene: &Scene, ray: &Ray, rays: &mut RayCounter) -> Option<FirstHit> {
    rays.closest += 1;
    let hit = scene.intersect_camera(ray)?;
    let surface = scene.geometry().surface(ray, &hit);
    Some(FirstHit::at(scene, &surface, -ray.direction, hit.t))
}

impl FirstHit {
    /// The first hit at `surface`, seen from direction `wo` (towards the ray's origin; any
    /// length) at parameter `t` along the ray.
    pub fn at(scene: &Scene, surface: &SurfacePoint, wo: Vec3, t: f32) -> Self {
        FirstHit {
            distance: t,
            albedo: scene.albedo(surface.triangle, surface.b1, surface.b2),
            normal: scene.shading_point(surface, wo).ns,
        }
    }
}
