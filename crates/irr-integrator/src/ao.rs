//! Ambient occlusion: the fraction of the cosine-weighted hemisphere that is unoccluded within a
//! distance.

use crate::integrator::{Integrator, RayCounter};
use crate::path::ShadingPoint;
use crate::scene::Scene;
use glam::Vec3;
use irr_geometry::Ray;
use irr_sampling::rng::Dimensions;
use irr_sampling::{Frame, sample_cosine_hemisphere};

/// Settings of [`AmbientOcclusion`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AoSettings {
    /// Occluders farther than this (in scene units) do not count. Default: ∞. Range: > 0.
    pub max_distance: f32,
    /// Occlusion rays per camera sample. Default: 1. Range: ≥ 1.
    pub samples: u32,
}

impl Default for AoSettings {
    fn default() -> Self {
        Self {
            max_distance: f32::INFINITY,
            samples: 1,
        }
    }
}

/// Ambient occlusion A(x) = (1/π) ∫ V(x, ω) cos θ dω, with V = 1 where the ray from x along ω
/// travels `max_distance` without a hit. Returned as a grey radiance (A, A, A); a camera ray that
/// hits nothing returns 0.
///
/// Estimator: with ω drawn from the cosine pdf cos θ/π, V(x, ω) is an unbiased estimate of A.
#[derive(Clone, Copy, Debug, Default)]
pub struct AmbientOcclusion {
    /// The settings.
    pub settings: AoSettings,
}

impl AmbientOcclusion {
    /// An AO integrator with these settings.
    pub fn new(settings: AoSettings) -> Self {
        Self { settings }
    }
}

impl Integrator for AmbientOcclusion {
    fn name(&self) -> &'static str {
        "ao"
    }

    fn li(&self, scene: &Scene, ray: &Ray, dims: &mut Dimensions, rays: &mut RayCounter) -> Vec3 {
        // Find the surface the camera sees.
        rays.closest += 1;
        let Some(hit) = scene.intersect_camera(ray) else {
            return Vec3::ZERO;
        };
        let surface = scene.geometry().surface(ray, &hit);
        // Occlusion is measured on the side the camera looks at.
        let ShadingPoint {
            position, ng, ns, ..
        } = scene.shading_point(&surface, -ray.direction);
        let frame = Frame::from_normal(ns);
        let samples = self.settings.samples.max(1);
        let mut visible = 0u32;
        for _ in 0..samples {
            // Draw a cosine-distributed direction; V is then an unbiased estimate of A.
            let wi = frame.to_world(sample_cosine_hemisphere(dims.next_2d()));
            // A direction under the geometric surface (possible with shading normals) is occluded.
            if wi.dot(ng) <= 0.0 {
                continue;
            }
            let mut shadow = Ray::spawn(position, ng, wi);
            shadow.t_max = self.settings.max_distance;
            rays.shadow += 1;
            if !scene.occluded(&shadow) {
                visible += 1;
            }
        }
        Vec3::splat(visible as f32 / samples as f32)
    }
}
