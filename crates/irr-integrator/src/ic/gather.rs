//! A record's hemisphere gather: one ray per stratum, what each brings back, and the record
//! with its gradients and radius inputs.

use super::builder::{Candidate, Probe};
use super::guard::GuardRecord;
use super::levels::Core;
use super::settings::{GradientMode, MetricKind};
use super::value::{IcValue, to_rgb_record};
use crate::integrator::RayCounter;
use crate::path::ShadingPoint;
use crate::scene::Scene;
use glam::Vec3;
use irr_cache::{RadiusInputs, Record};
use irr_geometry::{Ray, SurfacePoint};
use irr_gradients::{
    CellSamples, Curvature, GatherSamples, Gradients, TranslationGradient, plan_extra_samples,
};
use irr_sampling::{Cell, Frame, HemisphereStrata, SampleKey};

/// The smallest minor radius as a fraction of the major: Radiance's 2:1 cap on the anisotropy
/// (a longer ellipse trusts one eigenvalue of a noisy Hessian too far).
const MIN_ASPECT: f64 = 0.5;

/// A gather cell's traced ray: what it hit (`None`: it left the scene), its direction and the
/// cell's sample key.
pub(super) type Traced = (Option<SurfacePoint>, Vec3, SampleKey);

/// More rays for a gather's noisiest strata until its estimated relative error reaches a
/// target (irr-gradients' `plan_extra_samples`): the target and the most extra rays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct SuperSampling {
    pub(super) target: f32,
    pub(super) cap: u32,
}

impl<V: IcValue> Core<V> {
    /// The super-sampling of `level`'s gathers: `gather_error` loosened by `level_loosening`
    /// per level, at most `gather_budget` times the level's strata; `None` when off.
    pub(super) fn super_sampling(&self, level: usize) -> Option<SuperSampling> {
        let s = &self.settings;
        let strata = self.levels.get(level)?.strata;
        (s.gather_error > 0.0 && s.gather_budget > 0.0).then(|| SuperSampling {
            target: s.gather_error * s.level_loosening.powi(level as i32),
            cap: (s.gather_budget * strata.len() as f32) as u32,
        })
    }

    /// The gather at `x` for `level`: per cell, what its rays bring back and the hit distance.
    /// `values(traced, rays)` gives the values of a batch of rays at once (so that it can trace
    /// what they need in batches), in order, each ray as (hit, direction, key), the hit `None`
    /// where the ray escaped; it returns one value per entry. First one ray per cell; then, with
    /// `more`, the extra rays its plan gives the noisiest cells, in one batch (cell, then sample
    /// order). With `log`, every ray's (cell, direction in the frame, value) is appended to
    /// it, those below the surface with a zero value. Returns the samples (each cell's mean and nearest hit; each first sample's cos θ),
    /// the first rays' samples alone if there were more (the record's radius comes from those,
    /// so that super-sampling does not move records) and the gather's frame.
    #[expect(
        clippy::type_complexity,
        reason = "the gather, the pilot's samples and the frame, used together by each caller"
    )]
    #[expect(
        clippy::too_many_arguments,
        reason = "the ray log is an optional output beside the gather's inputs"
    )]
    pub(super) fn gather(
        &self,
        scene: &Scene,
        (strata, more): (HemisphereStrata, Option<SuperSampling>),
        x: &ShadingPoint,
        key: SampleKey,
        rays: &mut RayCounter,
        mut log: Option<&mut Vec<(u32, Vec3, V::Gathered)>>,
        mut values: impl FnMut(&[Traced], &mut RayCounter) -> Vec<V::Gathered>,
    ) -> Option<(
        GatherSamples<V::Gathered>,
        Option<GatherSamples<V::Gathered>>,
        Frame,
    )> {
        let frame = Frame::from_normal(x.ns);
        let seed = key.bits(0);
        // The ray of sample `index` of `cell`, or `None` below the geometric surface (a shading
        // normal tilted away): nothing arrives from there. Independent hashed numbers per cell
        // and sample: the strata already stratify the directions, and a per-gather Sobol
        // sequence did not pay for its cost (docs/performance.md, "Sobol sampler").
        let ray_of = |cell: Cell, index: u64| {
            let cell_key = SampleKey::new(seed, u64::from(cell.index(&strata)), index);
            let local = strata.sample(cell, cell_key.uniform_2d(0));
            let w = frame.to_world(local);
            let ray = (w.dot(x.ng) > 0.0).then(|| Ray::spawn(x.position, x.ng, w));
            (ray, w, cell_key, local)
        };
        // The Hessian metric's triangle fan needs each cell's direction; the other metrics
        // only its cos θ.
        let fan = self.settings.metric == MetricKind::Hessian
            || self.settings.gradients == GradientMode::Fan;
        let attach = |g: GatherSamples<V::Gathered>, local: &[Vec3]| {
            if fan {
                g.with_directions(local.to_vec())
            } else {
                g.with_cos_theta(local.iter().map(|w| w.z.clamp(0.0, 1.0)).collect())
            }
        };
        // Traces `batch` (each ray's direction and key in `meta`) and returns each ray's
        // (value, distance), in order. A gather's rays share their origin and neighbouring
        // cells' rays cross the same nodes: one at a time in cell order (`intersect_many`)
        // rather than as a stream, which gained nothing here (docs/performance.md, "Batched
        // paths").
        let mut trace = |batch: &[Ray], meta: &[(Vec3, SampleKey)], rays: &mut RayCounter| {
            rays.closest += batch.len() as u64;
            let mut hits = vec![None; batch.len()];
            scene.intersect_many(batch, &mut hits);
            let traced: Vec<Traced> = batch
                .iter()
                .zip(hits)
                .zip(meta)
                .map(|((ray, hit), &(w, key))| {
                    (hit.map(|h| scene.geometry().surface(ray, &h)), w, key)
                })
                .collect();
            let v = values(&traced, rays);
            traced
                .iter()
                .zip(v)
                .map(|((surface, _, _), value)| {
                    let distance = surface.as_ref().map_or(f32::INFINITY, |s| {
                        (s.position - x.position).length().max(f32::MIN_POSITIVE)
                    });
                    (value, distance)
                })
                .collect::<Vec<_>>()
        };
        // The first ray of every cell.
        let mut local = Vec::with_capacity(strata.len());
        let mut below = Vec::with_capacity(strata.len());
        let mut batch = Vec::with_capacity(strata.len());
        let mut meta = Vec::with_capacity(strata.len());
        for cell in strata.cells() {
            let (ray, w, k, dir) = ray_of(cell, 0);
            local.push(dir);
            below.push(ray.is_none());
            if let Some(ray) = ray {
                batch.push(ray);
                meta.push((w, k));
            }
        }
        let mut traced = trace(&batch, &meta, rays).into_iter();
        let (radiance, distance): (Vec<_>, Vec<_>) = below
            .iter()
            .map(|&b| {
                if b {
                    (V::Gathered::default(), f32::INFINITY)
                } else {
                    traced
                        .next()
                        .unwrap_or((V::Gathered::default(), f32::INFINITY))
                }
            })
            .unzip();
        if let Some(log) = log.as_deref_mut() {
            log.extend(
                local
                    .iter()
                    .zip(&radiance)
                    .enumerate()
                    .map(|(i, (w, v))| (i as u32, *w, *v)),
            );
        }
        let Some(more) = more else {
            let pilot = GatherSamples::new(strata, radiance, distance)
                .and_then(|g| attach(g, &local))
                .ok()?;
            return Some((pilot, None, frame));
        };
        let mut cells: Vec<CellSamples<V::Gathered>> = radiance
            .into_iter()
            .zip(distance)
            .map(|(value, distance)| CellSamples::first(value, distance))
            .collect();
        let pilot = GatherSamples::from_cells(strata, &cells)
            .and_then(|g| attach(g, &local))
            .ok()?;
        // The extra rays of the plan, all in one batch.
        let plan = plan_extra_samples(&pilot, &below, more.target, more.cap);
        let (mut extra, mut extra_meta, mut owner) = (Vec::new(), Vec::new(), Vec::new());
        for (cell, &count) in strata.cells().zip(&plan) {
            let i = cell.index(&strata) as usize;
            for index in 1..=u64::from(count) {
                match ray_of(cell, index) {
                    (Some(ray), w, k, dir) => {
                        extra.push(ray);
                        extra_meta.push((w, k));
                        owner.push((i, dir));
                    }
                    // Part of a cell can lie below the geometric surface: nothing arrives
                    // from there.
                    (None, _, _, dir) => {
                        cells[i].push(V::Gathered::default(), f32::INFINITY);
                        if let Some(log) = log.as_deref_mut() {
                            log.push((i as u32, dir, V::Gathered::default()));
                        }
                    }
                }
            }
        }
        if extra.is_empty() {
            return Some((pilot, None, frame));
        }
        for (&(i, dir), (value, distance)) in owner.iter().zip(trace(&extra, &extra_meta, rays)) {
            cells[i].push(value, distance);
            if let Some(log) = log.as_deref_mut() {
                log.push((i as u32, dir, value));
            }
        }
        let samples = GatherSamples::from_cells(strata, &cells)
            .and_then(|g| attach(g, &local))
            .ok()?;
        Some((samples, Some(pilot), frame))
    }

    /// A record of `level` at `x` from a gather, with its radius inputs and leak-guard distance:
    /// E and the gradients from all its `samples`, the radius from its `pilot`'s if it was
    /// super-sampled (the first ray of each cell: super-sampling does not move records), the
    /// guard's nearest hit from all. (Its noise is the gather's:
    /// `GatherSamples::relative_error`.)
    pub(super) fn record_from(
        &self,
        level: u32,
        x: &ShadingPoint,
        (samples, pilot): (
            &GatherSamples<V::Gathered>,
            Option<&GatherSamples<V::Gathered>>,
        ),
        frame: &Frame,
        (spacing, slant): (f32, f32),
    ) -> (Record<V>, RadiusInputs, f32) {
        if self.settings.metric == MetricKind::Hessian {
            let (record, distance) = self.hessian_record(x, (samples, pilot), frame);
            let inputs = RadiusInputs {
                distance,
                limits: self.limits(level, spacing, x.position, slant),
                neighbour_clamping: self.settings.neighbour_clamping,
            };
            return (record, inputs, samples.min_distance().min(self.diagonal));
        }
        let variant = match self.settings.gradients {
            // Without gradients only E is computed.
            GradientMode::Off => None,
            GradientMode::WardHeckbert => Some(TranslationGradient::WardHeckbert),
            GradientMode::KrivanekGautron => Some(TranslationGradient::KrivanekGautron),
            GradientMode::Fan => Some(TranslationGradient::OcclusionFan),
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
                irr_gather_record::record(x.position, x.ns, 1.0, &g)
            }
        };
        let inputs = RadiusInputs {
            distance: self.settings.radius_statistic.of(pilot.unwrap_or(samples)),
            limits: self.limits(level, spacing, x.position, slant),
            neighbour_clamping: self.settings.neighbour_clamping,
        };
        // A gather that hit nothing has its nearest hit at the scene's diagonal rather than +∞:
        // finite (so a cache file can refuse any non-finite distance), and no query within half
        // the diagonal needs a shadow ray, as no query at any distance did with +∞.
        (record, inputs, samples.min_distance().min(self.diagonal))
    }

    /// A Hessian-metric record at `x` and its major radius (before the pipeline's limits):
    /// the triangle fan of the first rays (`pilot`, or `samples` when not super-sampled) gives
    /// the tangent curvature; the translation gradient is `--gradients`' (with `fan`, the
    /// occlusion-aware gradient of the fan of all `samples`).
    ///
    /// Radii: Radiance's rᵢ = (4/|λᵢ|)^¼ (Schwarzhaupt et al. 2012: the radius that bounds a
    /// record's integrated second-order error), which scales as √length, made a length by the
    /// length L the record's world limits are fractions of (`Core::length_at`: the view's image
    /// height at the record's distance, or the scene's diagonal without a view): rᵢ =
    /// √L·(4/|λᵢ|)^¼ — Radiance's radii in units where what the image shows there is 1, so a
    /// scene drawn at any scale gets the same records, and a far ground plane or a scene larger
    /// than the view changes none. The major radius comes from the smaller |λ| (+∞ for a flat
    /// direction: the pipeline's limits bound it); the minor is at least half the major
    /// (Radiance's 2:1 cap), along the direction of the larger |λ|.
    fn hessian_record(
        &self,
        x: &ShadingPoint,
        (samples, pilot): (
            &GatherSamples<V::Gathered>,
            Option<&GatherSamples<V::Gathered>>,
        ),
        frame: &Frame,
    ) -> (Record<V>, f32) {
        // The curvature from the first rays' fan; without super-sampling that fan is also the
        // one `--gradients fan` reads, so it is computed once.
        let (hessian, own) = match pilot {
            None => {
                let fan = samples.fan();
                (fan.hessian, Some(fan))
            }
            Some(p) => (p.fan().hessian, None),
        };
        let curvature = Curvature::of(&hessian);
        let scale = f64::from(self.length_at(x.position)).sqrt();
        let radius = |lambda: f64| {
            if lambda > 0.0 {
                scale * (4.0 / lambda).sqrt().sqrt()
            } else {
                f64::INFINITY
            }
        };
        let (major, minor) = (radius(curvature.minor), radius(curvature.major));
        let aspect = if major.is_finite() {
            (minor / major).clamp(MIN_ASPECT, 1.0) as f32
        } else if minor.is_finite() {
            MIN_ASPECT as f32
        } else {
            1.0
        };
        let tangent = frame.to_world(curvature.axis.as_vec3());
        let translation = match self.settings.gradients {
            GradientMode::Off => None,
            GradientMode::WardHeckbert => {
                Some(samples.translation_gradient(TranslationGradient::WardHeckbert))
            }
            GradientMode::KrivanekGautron => {
                Some(samples.translation_gradient(TranslationGradient::KrivanekGautron))
            }
            GradientMode::Fan => Some(own.unwrap_or_else(|| samples.fan()).gradient),
        };
        let record = if let Some(translation) = translation {
            let g = Gradients {
                irradiance: samples.irradiance(),
                rotation: samples.rotation_gradient(),
                translation,
            }
            .in_world(frame);
            irr_gather_record::record(x.position, x.ns, 1.0, &g)
        } else {
            Record::new(
                x.position,
                x.ns,
                1.0,
                V::from_gathered(samples.irradiance()),
            )
        };
        // The curvature along the minor axis and across it, for second-order lookups
        // (`IcSettings::second_order`; ignored at lookup otherwise).
        let curvature = curvature.signed.map(|c| c as f32);
        let curvature = if curvature.iter().all(|c| c.is_finite()) {
            curvature
        } else {
            [0.0; 2]
        };
        (
            record
                .with_ellipse(aspect, tangent)
                .with_curvature(curvature),
            major as f32,
        )
    }

    /// The candidate of `probe` from its gather.
    pub(super) fn candidate(
        &self,
        probe: &Probe,
        (samples, pilot): (
            &GatherSamples<V::Gathered>,
            Option<&GatherSamples<V::Gathered>>,
        ),
        frame: &Frame,
        rays: RayCounter,
    ) -> Candidate {
        let (record, inputs, nearest_hit) = self.record_from(
            probe.level,
            &probe.x,
            (samples, pilot),
            frame,
            (probe.spacing, probe.slant),
        );
        Candidate {
            level: probe.level,
            record: to_rgb_record(&record),
            inputs,
            guard: GuardRecord {
                nearest_hit,
                geometric_normal: probe.x.ng,
            },
            noise: samples.relative_error(),
            radiance: None,
            rays,
        }
    }
}
