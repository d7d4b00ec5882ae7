//! A record's hemisphere gather: one ray per stratum, what each brings back, and the record
//! with its gradients and radius inputs.

use super::builder::{Candidate, Probe};
use super::guard::GuardRecord;
use super::levels::Core;
use super::settings::GradientMode;
use super::value::{IcValue, to_rgb_record};
use crate::integrator::RayCounter;
use crate::path::ShadingPoint;
use crate::scene::Scene;
use glam::Vec3;
use irr_cache::{RadiusInputs, Record};
use irr_geometry::{Ray, SurfacePoint};
use irr_gradients::{GatherSamples, Gradients, TranslationGradient};
use irr_sampling::{Frame, HemisphereStrata, SampleKey};

/// A gather cell's traced ray: what it hit (`None`: it left the scene), its direction and the
/// cell's sample key.
pub(super) type Traced = (Option<SurfacePoint>, Vec3, SampleKey);

impl<V: IcValue> Core<V> {
    /// The gather at `x` for `level`: per cell, what its ray brings back and the hit distance.
    /// `values(traced, rays)` gives the cells' values at once (so that it can trace what they
    /// need in batches) for the cells with a ray, in cell order, each as (hit, direction, key),
    /// the hit `None` where the ray escaped; it returns one value per entry. Returns the
    /// samples (with each sample's cos θ) and the gather's frame.
    pub(super) fn gather(
        &self,
        scene: &Scene,
        strata: HemisphereStrata,
        x: &ShadingPoint,
        key: SampleKey,
        rays: &mut RayCounter,
        values: impl FnOnce(&[Traced], &mut RayCounter) -> Vec<V::Gathered>,
    ) -> Option<(GatherSamples<V::Gathered>, Frame)> {
        let frame = Frame::from_normal(x.ns);
        let cells = strata.len();
        let mut radiance = Vec::with_capacity(cells);
        let mut distance = Vec::with_capacity(cells);
        let mut cos_theta = Vec::with_capacity(cells);
        let seed = key.bits(0);
        // The cells' rays first, then the values of all cells at once (`values` can then trace
        // what they need in batches), in cell order. Below the geometric surface (a shading
        // normal tilted away) a cell has no ray.
        let mut directions = Vec::with_capacity(cells);
        let mut batch = Vec::with_capacity(cells);
        for cell in strata.cells() {
            // Independent hashed numbers per cell: the strata already stratify the directions,
            // and a per-gather Sobol sequence did not pay for its cost (docs/performance.md,
            // "Sobol sampler").
            let cell_key = SampleKey::new(seed, u64::from(cell.index(&strata)), 0);
            let local = strata.sample(cell, cell_key.uniform_2d(0));
            let w = frame.to_world(local);
            cos_theta.push(local.z.clamp(0.0, 1.0));
            let above = w.dot(x.ng) > 0.0;
            if above {
                batch.push(Ray::spawn(x.position, x.ng, w));
            }
            directions.push((w, cell_key, above));
        }
        rays.closest += batch.len() as u64;
        // A gather's rays share their origin and neighbouring cells' rays cross the same nodes:
        // one at a time in cell order (`intersect_many`) rather than as a stream, which gained
        // nothing here (docs/performance.md, "Batched paths").
        let mut hits = vec![None; batch.len()];
        scene.geometry().intersect_many(&batch, &mut hits);
        let above = directions.iter().filter(|d| d.2);
        let traced: Vec<Traced> = batch
            .iter()
            .zip(hits)
            .zip(above)
            .map(|((ray, hit), &(w, key, _))| {
                let surface = hit.map(|h| scene.geometry().surface(ray, &h));
                (surface, w, key)
            })
            .collect();
        let mut traced_values = values(&traced, rays).into_iter();
        let mut traced = traced.iter();
        for &(_, _, above) in &directions {
            let value = above
                .then(|| traced.next().zip(traced_values.next()))
                .flatten();
            let Some(((surface, _, _), value)) = value else {
                // Nothing arrives from below the surface.
                radiance.push(V::Gathered::default());
                distance.push(f32::INFINITY);
                continue;
            };
            radiance.push(value);
            distance.push(surface.as_ref().map_or(f32::INFINITY, |s| {
                (s.position - x.position).length().max(f32::MIN_POSITIVE)
            }));
        }
        let samples = GatherSamples::new(strata, radiance, distance)
            .and_then(|g| g.with_cos_theta(cos_theta))
            .ok()?;
        Some((samples, frame))
    }

    /// A record of `level` at `x` from a gather, with its radius inputs and leak-guard distance.
    /// (Its noise is the gather's: `GatherSamples::relative_error`.)
    pub(super) fn record_from(
        &self,
        level: u32,
        x: &ShadingPoint,
        samples: &GatherSamples<V::Gathered>,
        frame: &Frame,
        spacing: f32,
    ) -> (Record<V>, RadiusInputs, f32) {
        let variant = match self.settings.gradients {
            // Without gradients only E is computed.
            GradientMode::Off => None,
            GradientMode::WardHeckbert => Some(TranslationGradient::WardHeckbert),
            GradientMode::KrivanekGautron => Some(TranslationGradient::KrivanekGautron),
        };
        let record = match variant {
            None => Record::new(
                x.position,
                x.ns,
                1.0,
                V::from_gathered(samples.irradiance()),
            ),
            Some(variant) => {
                let g: Gradients<V::Gathered> = samples.gradients(variant).in_world(frame);
                Record::new(x.position, x.ns, 1.0, V::from_gathered(g.irradiance)).with_gradients(
                    g.translation.map(V::from_gathered),
                    g.rotation.map(V::from_gathered),
                )
            }
        };
        let inputs = RadiusInputs {
            distance: self.settings.radius_statistic.of(samples),
            limits: self.limits(level, spacing),
            neighbour_clamping: self.settings.neighbour_clamping,
        };
        // A gather that hit nothing has its nearest hit at the scene's diagonal rather than +∞:
        // finite (so a cache file can refuse any non-finite distance), and no query within half
        // the diagonal needs a shadow ray, as no query at any distance did with +∞.
        (record, inputs, samples.min_distance().min(self.diagonal))
    }

    /// The candidate of `probe` from its gather.
    pub(super) fn candidate(
        &self,
        probe: &Probe,
        samples: &GatherSamples<V::Gathered>,
        frame: &Frame,
        rays: RayCounter,
    ) -> Candidate {
        let (record, inputs, nearest_hit) =
            self.record_from(probe.level, &probe.x, samples, frame, probe.spacing);
        Candidate {
            level: probe.level,
            record: to_rgb_record(&record),
            inputs,
            guard: GuardRecord {
                nearest_hit,
                geometric_normal: probe.x.ng,
            },
            noise: samples.relative_error(),
            rays,
        }
    }
}
