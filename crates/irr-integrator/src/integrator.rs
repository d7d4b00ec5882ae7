//! The interface every integrator implements, and the ray counter it reports into.

use crate::scene::Scene;
use glam::Vec3;
use irr_geometry::Ray;
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
}
