//! What both cached integrators share: the cache levels, construction's walks, selection and
//! commits.

use super::IcMetric;
use super::builder::{Candidate, CommitStats, DisplayRecord, Probe};
use super::guard::{GuardRecord, Query};
use super::light_cache::CacheView;
use super::radiance::{RadianceCaching, holds_head_on, least_roughness_held, may_take};
use super::settings::{IcSettings, IcSettingsError};
use super::value::{IcValue, convert_record};
use crate::integrator::RayCounter;
use crate::path::ShadingPoint;
use crate::scene::Scene;
use glam::Vec3;
use irr_cache::{ErrorMetric, InsertError, IrradianceCache, Record};
use irr_geometry::Ray;
use irr_sampling::{Frame, HemisphereStrata, SampleKey, sample_cosine_hemisphere};
use std::collections::HashMap;
use std::sync::atomic::AtomicU64;

/// A first-level record's radiance slot when it holds no coefficients (`Level::radiance_slot`).
const NO_COEFFICIENTS: u32 = u32::MAX;

/// One level of cache: the records, what the leak guard keeps of each and the level's gather
/// settings.
#[derive(Clone, Debug)]
pub(super) struct Level<V: IcValue> {
    pub(super) cache: IrradianceCache<V, IcMetric>,
    /// Per record (by id).
    pub(super) guard: Vec<GuardRecord>,
    /// Per record (by id): the estimated relative standard error of its irradiance.
    pub(super) noise: Vec<f32>,
    /// With radiance caching, on the first level: the coefficients and their gradients
    /// (`RadianceCaching::stride()` each, module `radiance`) of the records that hold them;
    /// empty otherwise.
    pub(super) radiance: Vec<Vec3>,
    /// With radiance caching, on the first level: per record (by id), the index of its
    /// coefficients in `radiance`, or [`NO_COEFFICIENTS`] for a record made on a material the
    /// records do not reflect (`RadianceCaching::holds`); empty otherwise.
    pub(super) radiance_slot: Vec<u32>,
    pub(super) strata: HemisphereStrata,
}

/// The shared machinery of both cached integrators: levels, gathers, the leak guard.
#[derive(Debug)]
pub(super) struct Core<V: IcValue> {
    pub(super) settings: IcSettings,
    pub(super) levels: Vec<Level<V>>,
    /// The scene's bounding-box diagonal (world units), set by `preprocess`.
    pub(super) diagonal: f32,
    /// The view the records' and the light cache's lengths follow (`CacheBuilder::set_view`);
    /// `None`: they follow the scene's diagonal.
    pub(super) view: Option<CacheView>,
    /// The strata of the final pass's own gathers (where no record covers a shading point): a
    /// quarter of the first level's in each direction, at least 4×8. Its estimate of E is as
    /// unbiased as a record's, only noisier, and it serves one pixel only.
    pub(super) fallback_strata: HemisphereStrata,
    /// The final pass's samples that no record of the cache covered.
    pub(super) misses: AtomicU64,
    /// Of those, the samples that read the records within their pixel's reach
    /// (`IrradianceCache::interpolate_within`).
    pub(super) fallbacks_within: AtomicU64,
    /// The final pass's own gathers for the rest.
    pub(super) fallbacks: AtomicU64,
    /// Radiance caching of glossy lobes, when on and the scene has a glossy material (set by
    /// `set_scene`).
    pub(super) radiance: Option<RadianceCaching>,
}

impl<V: IcValue> Core<V> {
    pub(super) fn new(settings: IcSettings) -> Result<Self, IcSettingsError> {
        settings.validate()?;
        let levels = (0..settings.levels())
            .map(|l| {
                Ok(Level {
                    cache: IrradianceCache::new(settings.metric_at(l)?),
                    guard: Vec::new(),
                    noise: Vec::new(),
                    radiance: Vec::new(),
                    radiance_slot: Vec::new(),
                    strata: settings.strata_at(l)?,
                })
            })
            .collect::<Result<Vec<_>, IcSettingsError>>()?;
        Ok(Self {
            fallback_strata: settings.strata_at(2)?,
            settings,
            levels,
            diagonal: 1.0,
            view: None,
            misses: AtomicU64::new(0),
            fallbacks_within: AtomicU64::new(0),
            fallbacks: AtomicU64::new(0),
            radiance: None,
        })
    }

    /// The length the world limits of a record at `x` are fractions of: the view's image
    /// height at x's distance (what the image shows there), or the scene's diagonal without a
    /// view.
    #[inline]
    pub(super) fn length_at(&self, x: Vec3) -> f32 {
        match self.view {
            Some(view) => {
                let h = view.height_at(x);
                if h.is_finite() && h > 0.0 {
                    h
                } else {
                    self.diagonal
                }
            }
            None => self.diagonal,
        }
    }

    /// The scene's diagonal; with `radiance_order` > 0 and a glossy material in the scene, the
    /// radiance caching tables (module `radiance`; the order was validated, so the table
    /// cannot fail).
    pub(super) fn set_scene(&mut self, scene: &Scene) {
        let (lo, hi) = scene.geometry().bounds();
        let d = (hi - lo).length();
        self.diagonal = if d.is_finite() && d > 0.0 { d } else { 1.0 };
        let order = self.settings.radiance_order as usize;
        // The roughness each material the records may take reaches (module `radiance`, "Which
        // lobes"): its factor, or up to it under a metallic-roughness texture (whose green
        // channel scales it down); the table holds those, and none is built without one.
        let max_error = self.settings.radiance_error;
        // One quadrature per distinct roughness, however many materials share it.
        let mut held: HashMap<u32, bool> = HashMap::new();
        let mut least: HashMap<u32, f32> = HashMap::new();
        let ranges: Vec<(f32, f32)> = if order > 0 && !self.levels.is_empty() {
            scene
                .materials()
                .iter()
                .filter(|m| {
                    may_take(m)
                        && *held
                            .entry(m.roughness.to_bits())
                            .or_insert_with(|| holds_head_on(order, max_error, m.roughness))
                })
                .map(|m| match m.metallic_roughness_texture {
                    // Below the least roughness the order holds no lobe is taken: no rows.
                    Some(_) => (
                        *least
                            .entry(m.roughness.to_bits())
                            .or_insert_with(|| least_roughness_held(order, max_error, m.roughness)),
                        m.roughness,
                    ),
                    None => (m.roughness, m.roughness),
                })
                .collect()
        } else {
            Vec::new()
        };
        self.radiance = (!ranges.is_empty())
            .then(|| {
                let gradients = self.settings.radiance_gradients as usize;
                RadianceCaching::new(order, max_error, &ranges, gradients).ok()
            })
            .flatten();
    }

    /// The coefficients of record `id` of `level`, when it has them.
    pub(super) fn coefficients<'a>(&self, level: &'a Level<V>, id: u32) -> Option<&'a [Vec3]> {
        let stride = self.radiance.as_ref()?.stride();
        let slot = *level.radiance_slot.get(id as usize)?;
        if slot == NO_COEFFICIENTS {
            return None;
        }
        let start = slot as usize * stride;
        level.radiance.get(start..start + stride)
    }

    /// Follows `level` cosine bounces from the camera ray's first hit; the shading point there
    /// and the distance of the last segment (the camera's for level 0).
    pub(super) fn walk(
        &self,
        scene: &Scene,
        level: u32,
        ray: &Ray,
        key: SampleKey,
        rays: &mut RayCounter,
    ) -> Option<(ShadingPoint, f32)> {
        rays.closest += 1;
        // The camera's ray; an unlit surface it meets is seen, not lit: no record there, and
        // no walk from it.
        let hit = scene.intersect_camera(ray)?;
        if scene.is_unlit(hit.triangle) {
            return None;
        }
        let surface = scene.geometry().surface(ray, &hit);
        let mut t = (surface.position - ray.origin).length();
        let mut x = scene.shading_point(&surface, -ray.direction.normalize());
        for bounce in 0..level {
            let w = Frame::from_normal(x.ns)
                .to_world(sample_cosine_hemisphere(key.uniform_2d(1 + bounce)));
            if w.dot(x.ng) <= 0.0 {
                return None;
            }
            let r = Ray::spawn(x.position, x.ng, w);
            rays.closest += 1;
            let hit = scene.intersect(&r)?;
            let surface = scene.geometry().surface(&r, &hit);
            t = (surface.position - x.position).length();
            x = scene.shading_point(&surface, -w);
        }
        Some((x, t))
    }

    /// See [`CacheBuilder::select`].
    pub(super) fn select(&self, probes: Vec<Probe>) -> Vec<Probe> {
        let mut chosen: Vec<Probe> = Vec::new();
        let mut planned: Option<IrradianceCache<f32, IcMetric>> = None;
        for probe in probes {
            let Some(level) = self.levels.get(probe.level as usize) else {
                continue;
            };
            let plan = planned.get_or_insert_with(|| IrradianceCache::new(*level.cache.metric()));
            if plan.covers(probe.x.position, probe.x.ns) {
                continue;
            }
            if plan
                .insert(Record::new(
                    probe.x.position,
                    probe.x.ns,
                    probe.predicted_radius,
                    0.0,
                ))
                .is_ok()
            {
                chosen.push(probe);
            }
        }
        chosen
    }

    /// Commits candidates in order (see [`CacheBuilder::commit`]).
    pub(super) fn commit(&mut self, scene: &Scene, candidates: Vec<Candidate>) -> CommitStats {
        let mut stats = CommitStats::default();
        for c in candidates {
            let level = c.level as usize;
            if level >= self.levels.len() {
                stats.refused += 1;
                continue;
            }
            let record = convert_record::<V>(&c.record);
            let mut guard = 0;
            let at = Query {
                p: record.position,
                ns: record.normal,
                ng: c.guard.geometric_normal,
            };
            if self.covers(scene, level, &at, &mut guard) {
                stats.dropped += 1;
                stats.dropped_rays += c.rays.total();
                stats.guard_rays += guard;
                continue;
            }
            stats.guard_rays += guard;
            let l = &mut self.levels[level];
            match l.cache.insert_with_radius(record, &c.inputs) {
                Ok((id, placement)) => {
                    debug_assert_eq!(id as usize, l.guard.len());
                    l.guard.push(c.guard);
                    l.noise.push(c.noise);
                    // With radiance caching every first-level record has a slot, which names
                    // its coefficients where its material is one the records reflect
                    // (`complete`).
                    if let Some(r) = self.radiance.as_ref().filter(|_| level == 0) {
                        match c.radiance {
                            Some(mut coefficients) => {
                                r.cap_gradients(&mut coefficients, &placement.gradient_scale);
                                l.radiance_slot.push((l.radiance.len() / r.stride()) as u32);
                                l.radiance.extend(coefficients);
                            }
                            None => l.radiance_slot.push(NO_COEFFICIENTS),
                        }
                    }
                    stats.inserted += 1;
                }
                Err(InsertError::Full) | Err(_) => stats.refused += 1,
            }
        }
        stats
    }
}

pub(super) fn display<V: IcValue>(core: &Core<V>) -> Vec<DisplayRecord> {
    core.levels.first().map_or_else(Vec::new, |l| {
        l.cache
            .records()
            .iter()
            .zip(&l.noise)
            .map(|(r, &noise)| DisplayRecord {
                position: r.position,
                normal: r.normal,
                influence_radius: l.cache.metric().influence_radius(r.radius),
                noise,
            })
            .collect()
    })
}
