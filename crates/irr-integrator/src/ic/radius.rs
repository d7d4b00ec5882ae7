//! How large a record may be: the world and pixel limits, and a probe's predicted radius from
//! a coarse distance-only gather.

use super::builder::{PROBE_M, PROBE_N, Probe};
use super::guard::Query;
use super::levels::Core;
use super::value::IcValue;
use crate::integrator::RayCounter;
use crate::scene::Scene;
use glam::Vec3;
use irr_cache::{ErrorMetric, RadiusLimits};
use irr_geometry::Ray;
use irr_sampling::{Frame, HemisphereStrata, SampleKey};

/// cos 80°: hits less than 10° above the horizon do not size a record (Mitsuba 0.6 uses 0.173;
/// Radiance skips them too). See `GatherSamples::harmonic_mean_distance_above`.
pub const HORIZON_CUT_COS: f32 = 0.173_648_18;

impl<V: IcValue> Core<V> {
    /// World-space limits of level `level`; level 0 also takes the pixel limits at `spacing`.
    pub(super) fn limits(&self, level: u32, spacing: f32) -> RadiusLimits {
        let world = RadiusLimits {
            min: self.settings.world_min * self.diagonal,
            max: (self.settings.world_max * self.diagonal).max(f32::MIN_POSITIVE),
        };
        if level > 0 {
            return world;
        }
        let pixel = self.levels[0].cache.metric().radius_limits(spacing);
        let max = pixel.max.min(world.max);
        let min = pixel.min.max(world.min).min(max);
        RadiusLimits { min, max }
    }

    /// See [`CacheBuilder::probe`].
    pub(super) fn probe(
        &self,
        scene: &Scene,
        level: u32,
        ray: &Ray,
        spread: f32,
        key: SampleKey,
        rays: &mut RayCounter,
    ) -> Option<Probe> {
        let li = level as usize;
        if li >= self.levels.len() {
            return None;
        }
        let (x, t) = self.walk(scene, level, ray, key, rays)?;
        if level > 0 && scene.albedo(x.triangle, x.b1, x.b2) == Vec3::ZERO {
            // A black surface reflects nothing: the level above never looks it up.
            return None;
        }
        let mut guard = 0;
        let covered = self.covers(scene, li, &Query::from(&x), &mut guard);
        rays.shadow += guard;
        if covered {
            return None;
        }
        // The predicted radius: the harmonic mean distance of a coarse distance-only gather
        // (as the full gather will compute it), the neighbours' first-half clamp and the limits.
        let mut spent = RayCounter::default();
        let strata = HemisphereStrata::new(PROBE_M, PROBE_N).ok()?;
        let frame = Frame::from_normal(x.ns);
        let seed = key.bits(0xfe);
        let mut batch = Vec::with_capacity(strata.len());
        for cell in strata.cells() {
            let u = SampleKey::new(seed, u64::from(cell.index(&strata)), 0).uniform_2d(0);
            let local = strata.sample(cell, u);
            if local.z <= HORIZON_CUT_COS {
                continue;
            }
            let w = frame.to_world(local);
            if w.dot(x.ng) > 0.0 {
                batch.push(Ray::spawn(x.position, x.ng, w));
            }
        }
        let count = batch.len() as u32;
        spent.closest += u64::from(count);
        let mut hits = vec![None; batch.len()];
        scene.geometry().intersect_many(&batch, &mut hits);
        let mut inv_sum = 0.0f64;
        for (r, hit) in batch.iter().zip(hits) {
            if let Some(hit) = hit {
                let d = (scene.geometry().surface(r, &hit).position - x.position).length();
                inv_sum += 1.0 / f64::from(d.max(f32::MIN_POSITIVE));
            }
        }
        let spacing = spread * t;
        let limits = self.limits(level, spacing);
        let h = if inv_sum > 0.0 {
            (f64::from(count) / inv_sum) as f32
        } else {
            limits.max
        };
        let mut g = h.min(limits.max);
        if self.settings.neighbour_clamping {
            g = self.levels[li]
                .cache
                .neighbour_clamped_radius(x.position, g);
        }
        *rays += spent;
        Some(Probe {
            level,
            x,
            spacing,
            key,
            predicted_radius: limits.clamp(g).max(f32::MIN_POSITIVE),
            rays: spent,
        })
    }
}
