//! Cache construction as the renderer drives it: probes, selection, full gathers, ordered
//! commits.
//!
//! # Construction, deterministic and parallel
//! The renderer drives construction through [`CacheBuilder`]: in each pass the cache is
//! read-only; [`CacheBuilder::probe`] tells, in parallel, whether a camera ray's hit is covered
//! and if not predicts its record's radius from a cheap 4×8 distance-only gather;
//! [`CacheBuilder::select`] keeps, in pixel order, the probes whose predicted spheres do not cover
//! each other; [`CacheBuilder::complete`] gathers for those in parallel; and
//! [`CacheBuilder::commit`] inserts the candidates in the order given (pixel order), dropping any
//! that an earlier candidate of the same pass already covers. A candidate depends only on the
//! cache before its pass and on its own sample key, and selection and commits run in a fixed
//! order, so the cache (and the image) are the same bit for bit whatever
//! the thread count. The final shading pass only reads; a shading point that no record covers
//! (rare: an edge pixel's jittered sample, or a record shrunk by neighbour clamping) gets a gather
//! of its own, used and not stored.

use super::guard::GuardRecord;
use super::light_cache::{CacheView, LightCacheCounts, LightDeposit, LightPathTracer};
use crate::integrator::{Integrator, RayCounter};
use crate::path::ShadingPoint;
use crate::scene::Scene;
use glam::Vec3;
use irr_cache::{RadiusInputs, Record, Rgb};
use irr_geometry::Ray;
use irr_sampling::SampleKey;

/// A record computed in a construction pass, waiting for [`CacheBuilder::commit`].
#[derive(Clone, Debug)]
pub struct Candidate {
    pub(super) level: u32,
    pub(super) record: Record<Rgb>,
    pub(super) inputs: RadiusInputs,
    pub(super) guard: GuardRecord,
    /// The estimated relative standard error of its irradiance, from its gather's strata
    /// (`GatherSamples::relative_error`).
    pub(super) noise: f32,
    /// With radiance caching, on the first level: its gather's coefficients (module
    /// `radiance`).
    pub(super) radiance: Option<Vec<Vec3>>,
    /// Gather rays (and their continuations) this candidate cost.
    pub rays: RayCounter,
}

impl Candidate {
    /// The cache level it belongs to (0: the camera's).
    pub fn level(&self) -> u32 {
        self.level
    }
    /// Where it was computed.
    pub fn position(&self) -> Vec3 {
        self.record.position
    }
    /// The estimated relative standard error of its irradiance (its gather's own noise).
    pub fn noise(&self) -> f32 {
        self.noise
    }
}

/// A level-0 record as the debug view (`--show-records`) draws it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DisplayRecord {
    /// Where it was computed.
    pub position: Vec3,
    /// Its surface normal.
    pub normal: Vec3,
    /// The radius within which it has a weight.
    pub influence_radius: f32,
    /// The estimated relative standard error of its irradiance (its gather's own noise).
    pub noise: f32,
}

/// A point of a construction pass that no record covers, with a cheap prediction of the radius
/// its record will get (a distance-only gather of 4×8 rays, `PROBE_M`×`PROBE_N`). The renderer
/// selects among a pass's probes ([`CacheBuilder::select`]) before any full gather is paid for,
/// so few full gathers are wasted on candidates that cover each other.
#[derive(Clone, Debug)]
pub struct Probe {
    pub(super) level: u32,
    pub(super) x: ShadingPoint,
    pub(super) spacing: f32,
    /// How much wider the pixel's footprint is on the surface than across the view
    /// (`spacing` over the perpendicular footprint, ≥ 1; 1 below the first level).
    pub(super) slant: f32,
    pub(super) key: SampleKey,
    pub(super) predicted_radius: f32,
    /// Rays the probe cost.
    pub rays: RayCounter,
}

impl Probe {
    /// The cache level (0: the camera's).
    pub fn level(&self) -> u32 {
        self.level
    }
    /// The radius its record is predicted to get.
    pub fn predicted_radius(&self) -> f32 {
        self.predicted_radius
    }
}

/// Strata of a probe's distance-only gather along θ.
pub(super) const PROBE_M: u32 = 4;
/// Strata of a probe's distance-only gather along φ.
pub(super) const PROBE_N: u32 = 8;

/// The final pass's samples that no record of the cache covered, and the gathers made for them
/// (the irradiance cache's samples share them within a pixel, so there may be fewer).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FinalPassMisses {
    /// Samples that no record covered.
    pub samples: u64,
    /// Of those, samples that read the records within their pixel's reach.
    pub within_reach: u64,
    /// Gathers made for the rest.
    pub gathers: u64,
}

/// What one commit did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CommitStats {
    /// Candidates inserted.
    pub inserted: u64,
    /// Candidates dropped because an earlier candidate of the same pass covered them.
    pub dropped: u64,
    /// Rays spent on the dropped candidates' gathers (wasted work).
    pub dropped_rays: u64,
    /// Candidates the cache refused (not finite: a NaN in a gather); should be 0.
    pub refused: u64,
    /// Shadow rays traced by the leak guard while committing.
    pub guard_rays: u64,
}

impl std::ops::AddAssign for CommitStats {
    fn add_assign(&mut self, o: Self) {
        self.inserted += o.inserted;
        self.dropped += o.dropped;
        self.dropped_rays += o.dropped_rays;
        self.refused += o.refused;
        self.guard_rays += o.guard_rays;
    }
}

/// What the renderer needs to drive deterministic cache construction (see the module docs): the
/// cache levels to build, a read-only candidate computation per camera ray, and an ordered
/// commit. Threads, tiles and pixel order are the renderer's.
pub trait CacheBuilder: Integrator + Send {
    /// How many cache levels there are; the renderer builds them from the deepest (`levels() −
    /// 1`) to 0, because a level's gathers read the level below.
    fn levels(&self) -> u32;

    /// The probe of level `level` for this camera ray, or `None` when the cache already covers
    /// the point (or the ray hits nothing). Level 0 uses the camera ray's first hit, where a
    /// pixel spans `spread`·t across the view (`spread`: the pixel's size per unit distance
    /// along the ray; the record's pixel limits take its footprint on the surface from it);
    /// level L ≥ 1 the point reached by L cosine-distributed bounces. Every random number comes
    /// from `key`. Read-only: many threads call it at once.
    fn probe(
        &self,
        scene: &Scene,
        level: u32,
        ray: &Ray,
        spread: f32,
        key: SampleKey,
        rays: &mut RayCounter,
    ) -> Option<Probe>;

    /// The probes worth a full gather, in the order given: a probe is skipped when the predicted
    /// sphere of an earlier selected probe covers it. Sequential and deterministic.
    fn select(&self, probes: Vec<Probe>) -> Vec<Probe>;

    /// The candidate record of a selected probe: the full gather, its gradients and radius
    /// inputs. Read-only: many threads call it at once.
    fn complete(&self, scene: &Scene, probe: &Probe, rays: &mut RayCounter) -> Option<Candidate>;

    /// Inserts `candidates` in the order given, dropping each one an earlier record covers.
    fn commit(&mut self, scene: &Scene, candidates: Vec<Candidate>) -> CommitStats;

    /// Records per level.
    fn record_counts(&self) -> Vec<usize>;

    /// Sizes the cache's lengths by `view`, the camera whose paths fill the light cache: the
    /// light cache's cells and the records' world limits follow what the image shows at each
    /// point (module `light_cache`, `Core::length_at`) rather than the scene's bounds, so that
    /// geometry far from anything the camera sees changes neither. The renderer calls it before
    /// the light cache's paths and the first pass, with the same view wherever a cache is
    /// rebuilt; without it the lengths are fractions of the scene's diagonal. Replaces a light
    /// cache filled under another view.
    fn set_view(&mut self, view: CacheView) {
        let _ = view;
    }

    /// How many camera-launched paths fill the light cache before the first pass (0: the
    /// integrator has none; `BounceMode::LightCache`).
    fn light_paths(&self) -> u32 {
        0
    }

    /// What traces the light cache's paths (`None` without one): each path's deposits, all its
    /// randomness from its key, to hand to [`CacheBuilder::add_light_paths`] in path order. A
    /// value apart from the builder, so the renderer traces the next paths in parallel while
    /// the builder adds the last ones.
    fn light_path_tracer(&self) -> Option<LightPathTracer> {
        None
    }

    /// Adds traced paths to the light cache, in the order given (the renderer gives path
    /// order, so the cell sums are the same bits for any thread count). `occluded` traces a
    /// batch of shadow rays (whether each deposit sees its cell's anchor: `LightCache::add_paths`)
    /// and may do so in parallel; the return value is the number of rays it was given.
    fn add_light_paths(
        &mut self,
        paths: Vec<Vec<LightDeposit>>,
        occluded: &dyn Fn(&[Ray]) -> Vec<bool>,
    ) -> u64 {
        let _ = (paths, occluded);
        0
    }

    /// Ends the light cache's construction once every path is added (`LightCache::settle`):
    /// before the first read.
    fn settle_light_cache(&mut self) {}

    /// What the light cache holds.
    fn light_cache_counts(&self) -> LightCacheCounts {
        LightCacheCounts::default()
    }

    /// The relative standard error of the light cache's cells (`LightCache::relative_error`).
    fn light_cache_error(&self) -> f64 {
        0.0
    }

    /// Whether the light cache has met its target (`LightCache::converged`): the renderer adds
    /// no more paths. Asked after each chunk of paths, so the answer, and the cache, depend on
    /// the paths alone, never on the threads.
    fn light_cache_converged(&self) -> bool {
        true
    }

    /// With radiance caching: the first level's records that hold coefficients, the basis'
    /// order n and the bytes of their coefficients (3n² f32 each); `None` when off.
    fn radiance_records(&self) -> Option<(usize, usize, usize)> {
        None
    }

    /// What the final pass found that no record covered so far.
    fn final_pass_misses(&self) -> FinalPassMisses;

    /// Every level-0 record's position, normal, influence radius and noise (for the debug
    /// view).
    fn records_for_display(&self) -> Vec<DisplayRecord>;

    /// The estimated relative standard error of the irradiance of each record of `level`, by
    /// record id (its gather's own noise; empty for a level the integrator does not have).
    fn record_noise(&self, level: usize) -> &[f32];

    /// The smallest influence radius a level-0 record can have, in pixels (of the footprint on
    /// its surface): what the renderer's coverage probes must resolve.
    fn smallest_influence_pixels(&self) -> f32;
}

/// The parts of [`CacheBuilder`] both cached integrators share, forwarded to their `core`.
macro_rules! forward_to_core {
    () => {
        fn probe(
            &self,
            scene: &Scene,
            level: u32,
            ray: &Ray,
            spread: f32,
            key: SampleKey,
            rays: &mut RayCounter,
        ) -> Option<Probe> {
            // A level the integrator does not have (AO has one) probes nothing.
            self.core.probe(scene, level, ray, spread, key, rays)
        }

        fn select(&self, probes: Vec<Probe>) -> Vec<Probe> {
            self.core.select(probes)
        }

        fn commit(&mut self, scene: &Scene, candidates: Vec<Candidate>) -> CommitStats {
            self.core.commit(scene, candidates)
        }

        fn record_counts(&self) -> Vec<usize> {
            self.core.levels.iter().map(|l| l.cache.len()).collect()
        }

        fn final_pass_misses(&self) -> FinalPassMisses {
            FinalPassMisses {
                samples: self.core.misses.load(Ordering::Relaxed),
                within_reach: self.core.fallbacks_within.load(Ordering::Relaxed),
                gathers: self.core.fallbacks.load(Ordering::Relaxed),
            }
        }

        fn records_for_display(&self) -> Vec<DisplayRecord> {
            display(&self.core)
        }

        fn record_noise(&self, level: usize) -> &[f32] {
            self.core.levels.get(level).map_or(&[], |l| &l.noise)
        }

        fn smallest_influence_pixels(&self) -> f32 {
            self.core.smallest_influence_pixels()
        }
    };
}
pub(super) use forward_to_core;
