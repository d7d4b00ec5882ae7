//! Ambient occlusion through the irradiance cache's machinery (scalar records).

use super::FALLBACK_STREAM;
use super::builder::{
    CacheBuilder, Candidate, CommitStats, DisplayRecord, FinalPassMisses, Probe, forward_to_core,
};
use super::guard::Query;
use super::levels::{Core, display};
use super::light_cache::CacheView;
use super::settings::{BounceMode, IcSettings, IcSettingsError, setting_error};
use crate::integrator::{Integrator, RayCounter};
use crate::path::PathSettings;
use crate::path::ShadingPoint;
use crate::scene::Scene;
use glam::Vec3;
use irr_geometry::{Ray, SurfacePoint};
use irr_gradients::GatherSamples;
use irr_sampling::rng::Dimensions;
use irr_sampling::{Frame, HemisphereStrata, SampleKey};
use std::f32::consts::FRAC_1_PI;
use std::sync::atomic::Ordering;

/// Ambient occlusion through the irradiance cache (scalar records): A(x) = (1/π)∫V cos θ dω
/// interpolated from sparse gathers, with their gradients (the gather's value per cell is 1/π
/// where the ray travels `max_distance` unoccluded, so the gather's E is A itself).
#[derive(Debug)]
pub struct CachedAmbientOcclusion {
    core: Core<f32>,
    max_distance: f32,
}

impl CachedAmbientOcclusion {
    /// AO through a cache; `max_distance` as [`crate::AoSettings::max_distance`]. Cached bounce
    /// levels and the path depth do not apply to AO: the settings' bounce mode and path settings
    /// are ignored (one level).
    pub fn new(settings: IcSettings, max_distance: f32) -> Result<Self, IcSettingsError> {
        if max_distance.is_nan() || max_distance <= 0.0 {
            return Err(setting_error(
                "--ao-distance",
                format!("must be positive, got {max_distance}"),
            ));
        }
        // Occlusion is not light: no bounce levels, and the path depth does not apply.
        let settings = IcSettings {
            bounce_mode: BounceMode::PathTraced,
            path: PathSettings::default(),
            ..settings
        };
        Ok(Self {
            core: Core::new(settings)?,
            max_distance,
        })
    }

    fn occlusion_gather(
        &self,
        scene: &Scene,
        strata: HemisphereStrata,
        x: &ShadingPoint,
        key: SampleKey,
        rays: &mut RayCounter,
    ) -> Option<(GatherSamples<f32>, Frame)> {
        let max = self.max_distance;
        self.core
            .gather(scene, (strata, None), x, key, rays, None, |traced, _| {
                let value = |hit: &Option<SurfacePoint>| match hit {
                    Some(s) if (s.position - x.position).length() < max => 0.0,
                    _ => FRAC_1_PI,
                };
                traced.iter().map(|(hit, _, _)| value(hit)).collect()
            })
            .map(|(samples, _, frame)| (samples, frame))
    }
}

impl Integrator for CachedAmbientOcclusion {
    fn name(&self) -> &'static str {
        "ic-ao"
    }

    fn preprocess(&mut self, scene: &Scene) {
        self.core.set_scene(scene);
    }

    fn li(&self, scene: &Scene, ray: &Ray, dims: &mut Dimensions, rays: &mut RayCounter) -> Vec3 {
        rays.closest += 1;
        let Some(hit) = scene.intersect_camera(ray) else {
            return Vec3::ZERO;
        };
        let surface = scene.geometry().surface(ray, &hit);
        let x = scene.shading_point(&surface, -ray.direction.normalize());
        let a = match self.core.lookup(scene, 0, &Query::from(&x), rays) {
            Some(a) => a,
            None => {
                self.core.misses.fetch_add(1, Ordering::Relaxed);
                self.core.fallbacks.fetch_add(1, Ordering::Relaxed);
                let key = SampleKey::new(dims.key().bits(dims.position()), FALLBACK_STREAM, 0);
                self.occlusion_gather(scene, self.core.fallback_strata, &x, key, rays)
                    .map(|(g, _)| g.irradiance())
                    .unwrap_or(0.0)
            }
        };
        Vec3::splat(a.clamp(0.0, 1.0))
    }
}

impl CacheBuilder for CachedAmbientOcclusion {
    fn set_view(&mut self, view: CacheView) {
        self.core.view = Some(view);
    }

    fn levels(&self) -> u32 {
        1
    }

    fn complete(&self, scene: &Scene, probe: &Probe, rays: &mut RayCounter) -> Option<Candidate> {
        let mut spent = RayCounter::default();
        let strata = self.core.levels.first()?.strata;
        let (samples, frame) =
            self.occlusion_gather(scene, strata, &probe.x, probe.key, &mut spent)?;
        *rays += spent;
        Some(self.core.candidate(probe, (&samples, None), &frame, spent))
    }

    forward_to_core!();
}
