//! How large a record may be: the world and pixel limits, and a probe's predicted radius from
//! a coarse distance-only gather.

use super::builder::{PROBE_M, PROBE_N, Probe};
use super::guard::Query;
use super::levels::Core;
use super::settings::RadiusStatistic;
use super::value::IcValue;
use crate::bsdf::Bsdf;
use crate::integrator::RayCounter;
use crate::scene::Scene;
use glam::Vec3;
use irr_cache::{ErrorMetric, RadiusLimits};
use irr_geometry::Ray;
use irr_sampling::{Frame, HemisphereStrata, SampleKey};

/// cos 80°: hits less than 10° above the horizon do not size a record (Mitsuba 0.6 uses 0.173;
/// Radiance skips them too). See `GatherSamples::harmonic_mean_distance_above`.
pub(super) const HORIZON_CUT_COS: f32 = 0.173_648_18;

impl<V: IcValue> Core<V> {
    /// World-space limits of a record of level `level` at `x`: fractions of
    /// [`Core::length_at`] x, measured across the view as the pixel limits are (widened by
    /// `slant` on a surface seen at a slant, `surface_spacing`'s factor); level 0 also takes the
    /// pixel limits at `spacing`.
    pub(super) fn limits(&self, level: u32, spacing: f32, x: Vec3, slant: f32) -> RadiusLimits {
        let length = self.length_at(x) * slant;
        let world = RadiusLimits {
            min: self.settings.world_min * length,
            max: (self.settings.world_max * length).max(f32::MIN_POSITIVE),
        };
        let Some(pixel) = self.pixel_limits(level, spacing, length) else {
            return world;
        };
        let max = pixel.max.min(world.max);
        let min = pixel.min.max(world.min).min(max);
        RadiusLimits { min, max }
    }

    /// The pixel limits of level `level` at `spacing`. Level 0: the metric's, raised to the
    /// influence floor, which keeps every sphere of influence at least `influence_floor` pixels
    /// wide (both metrics' influence is proportional to the radius), so that the repair passes'
    /// probes, a fraction of a pixel apart, leave no gap between records for the final pass's
    /// samples to fall into. A deeper level is not seen by the camera: its limits are those of
    /// a view [`DEEP_RESOLUTION`] pixels across `length` ([`Core::length_at`] the record),
    /// whatever the image's size.
    fn pixel_limits(&self, level: u32, spacing: f32, length: f32) -> Option<RadiusLimits> {
        if level > 0 {
            let metric = self.levels.get(level as usize)?.cache.metric();
            return Some(metric.radius_limits(length / DEEP_RESOLUTION));
        }
        let metric = self.levels.first()?.cache.metric();
        let mut pixel = metric.radius_limits(spacing);
        let floor = self.settings.influence_floor * spacing / metric.influence_radius(1.0);
        if floor.is_finite() && floor > pixel.min {
            pixel.min = floor;
            pixel.max = pixel.max.max(floor);
        }
        Some(pixel)
    }

    /// See [`CacheBuilder::smallest_influence_pixels`].
    pub(super) fn smallest_influence_pixels(&self) -> f32 {
        // The level-0 pixel limits at a spacing of one unit are in pixels.
        match (
            self.levels.first(),
            self.pixel_limits(0, 1.0, self.diagonal),
        ) {
            (Some(l), Some(pixel)) => l.cache.metric().influence_radius(pixel.min),
            _ => 0.0,
        }
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
        if level > 0
            && (scene.albedo(x.triangle, x.b1, x.b2) == Vec3::ZERO
                || !scene.material_of(x.triangle).is_lambertian())
        {
            // A black surface reflects nothing, and a glossy one's light is path-traced: the
            // level above never looks either up.
            return None;
        }
        if level == 0 && V::READ_THROUGH_REFLECTANCE {
            let bsdf = Bsdf::at(scene, &x);
            // Irradiance multiplies x₀'s diffuse reflectance: a metal or a black surface, seen
            // from the camera, never reads a record, unless its lobe is reflected from the
            // radiance records (module `radiance`).
            if bsdf.diffuse_reflectance() == Vec3::ZERO
                && !self
                    .radiance
                    .as_ref()
                    .is_some_and(|r| r.covers(&bsdf, bsdf.residual_probability()))
            {
                return None;
            }
        }
        let mut guard = 0;
        let covered = self.covers(scene, li, &Query::from(&x), &mut guard);
        rays.shadow += guard;
        if covered {
            return None;
        }
        // The predicted radius: the distance statistic of a coarse distance-only gather (as the
        // full gather will compute it), the neighbours' first-half clamp and the limits.
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
        scene.intersect_many(&batch, &mut hits);
        let (mut inv_sum, mut nearest) = (0.0f64, f32::INFINITY);
        for (r, hit) in batch.iter().zip(hits) {
            if let Some(hit) = hit {
                let d = (scene.geometry().surface(r, &hit).position - x.position).length();
                inv_sum += 1.0 / f64::from(d.max(f32::MIN_POSITIVE));
                nearest = nearest.min(d);
            }
        }
        let spacing = surface_spacing(spread * t, ray.direction, x.ng);
        let slant = if level == 0 && spread * t > 0.0 {
            (spacing / (spread * t)).max(1.0)
        } else {
            1.0
        };
        let limits = self.limits(level, spacing, x.position, slant);
        let h = match self.settings.radius_statistic {
            _ if inv_sum == 0.0 => limits.max,
            RadiusStatistic::HarmonicMean => (f64::from(count) / inv_sum) as f32,
            RadiusStatistic::Minimum => nearest,
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
            slant,
            key,
            predicted_radius: limits.clamp(g).max(f32::MIN_POSITIVE),
            rays: spent,
        })
    }
}

/// The resolution (pixels across the view's image height at the record's distance, or across
/// the scene's diagonal without a view) whose pixel limits size the records of the levels below
/// the first: their density does not depend on the image's size.
pub const DEEP_RESOLUTION: f32 = 512.0;

/// The smallest cosine of the angle between the view and the surface that [`surface_spacing`]
/// takes: beyond ~89°, a pixel's footprint is a sliver whose area says little about its width.
const MIN_FOOTPRINT_COS: f32 = 1.0 / 64.0;

/// The size of a pixel's footprint on the surface, as pbrt-v2 sizes it: √(area of the
/// footprint), where a pixel spanning `perpendicular` across the view covers an area
/// `perpendicular`²/cos θ of a surface seen at θ from its normal `ng`. So a record of radius
/// k·spacing covers the same screen area (πk² pixels) on a grazing floor as on a wall facing the
/// camera: along the slant its projection shrinks by cos θ, across it grows by 1/√cos θ.
pub fn surface_spacing(perpendicular: f32, view: Vec3, ng: Vec3) -> f32 {
    let cos = (view.normalize_or_zero().dot(ng.normalize_or_zero())).abs();
    perpendicular / cos.max(MIN_FOOTPRINT_COS).sqrt()
}
