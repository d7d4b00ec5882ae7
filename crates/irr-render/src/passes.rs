//! Deterministic parallel construction of an irradiance cache: the pixel passes that drive an
//! integrator's [`CacheBuilder`].
//!
//! # The passes
//! Each cache level is built from the deepest (its records are read by the gathers of the level
//! above) to level 0. A level is built in passes over a coarse-to-fine grid: stride 16, then the
//! points of stride 8 not already visited, and so on down to stride 1. Level 0's grid is the
//! image's pixels; a deeper level's is a [`DEEP_GRID`]² grid over the view whatever the image's
//! size, each point the start of a random bounce path. In a pass:
//! 1. the cache is read-only; every pixel of the pass asks [`CacheBuilder::probe`] whether the
//!    hit of its camera ray (through the pixel's centre; for a deeper level, the end of a random
//!    bounce path from there) is covered, and if not for a predicted radius, in parallel on the
//!    rayon pool;
//! 2. [`CacheBuilder::select`] keeps, in pixel order (row-major), the probes whose predicted
//!    spheres do not cover each other;
//! 3. [`CacheBuilder::complete`] gathers for the selected probes, in parallel;
//! 4. [`CacheBuilder::commit`] inserts the candidates in pixel order, each dropped if an earlier
//!    one of the same pass already covers it.
//!
//! Each finer stride runs as three sub-lattice passes whose points lie 2s apart. Repair passes
//! follow (neighbour clamping shrinks earlier records as later ones arrive): level 0's probe a
//! lattice of every 1/k of a pixel ([`coverage_lattice`], k ≤ [`MAX_COVERAGE_LATTICE`]) until
//! none is uncovered, a deeper level's walk its grid again until fewer than [`DEEP_UNCOVERED`]
//! of the walks end uncovered; at most [`MAX_REPAIR_PASSES`] each.
//!
//! A candidate depends only on the cache before its pass and on its own [`SampleKey`]
//! (seed, level stream, pixel), and commits run in a fixed order, so the cache is the same bit
//! for bit whatever the number of threads. With [`irr_integrator::IcSettings::fill_samples`],
//! one more pass visits every camera sample's own jittered ray. The coarse passes spread the
//! records over the image before the fine ones fill the gaps, so few candidates of a pass cover
//! each other (the dropped share is reported: the wasted gather work).

use crate::error::RenderError;
use crate::render::RenderSettings;
use glam::Vec2;
use irr_geometry::Ray;
use irr_integrator::{
    CacheBuilder, CacheView, Candidate, CommitStats, DisplayRecord, LightCacheCounts, LightDeposit,
    LightPathTracer, Probe, RayCounter, Scene, surface_spacing,
};
use irr_sampling::SampleKey;
use irr_scene::Camera;
use rayon::prelude::*;
use std::time::Instant;

/// The first stride of the pixel passes (pixels 16 apart).
pub const FIRST_STRIDE: u32 = 16;

/// The side of the grid of image points a deeper level's walks start from (see `build_cache`).
pub const DEEP_GRID: u32 = 64;

/// A deeper level's repair passes stop when fewer than this share of a pass's walks end at a
/// point no record covers (each walk is new, so some always may; an uncovered point costs the
/// level above a path-traced continuation, not an error).
pub const DEEP_UNCOVERED: f64 = 0.01;

/// The walks of level `level` from the grid points `cells` of the DEEP_GRID² grid: camera rays
/// through the cells' centres, each with its own key (`round` 0 for the coarse-to-fine passes,
/// then one per repair pass, so each repair pass walks new paths).
fn deep_jobs(
    camera: &Camera,
    settings: &RenderSettings,
    level: u32,
    round: u32,
    cells: &[(u32, u32)],
) -> Vec<(Ray, f32, SampleKey)> {
    let scale = Vec2::new(
        settings.width as f32 / DEEP_GRID as f32,
        settings.height as f32 / DEEP_GRID as f32,
    );
    let stream = CACHE_STREAM + u64::from(level) + (u64::from(round) << 16);
    cells
        .iter()
        .map(|&(i, j)| {
            let raster = (Vec2::new(i as f32, j as f32) + Vec2::splat(0.5)) * scale;
            let ray = camera_ray(camera, settings, raster);
            let spread = pixel_spread(camera, settings.height, ray.direction);
            let index = u64::from(j) * u64::from(DEEP_GRID) + u64::from(i);
            (ray, spread, SampleKey::new(settings.seed, stream, index))
        })
        .collect()
}

/// The stream of the construction passes' keys: level L uses `CACHE_STREAM + L`, and the pass
/// over every camera sample `CACHE_STREAM + 0xff`.
pub const CACHE_STREAM: u64 = 0x1c_0000;

/// The stream of the repair passes' keys.
const REPAIR_STREAM: u64 = CACHE_STREAM + 0xfe;

/// The streams of the light cache's paths: path i's bounces draw from
/// (`LIGHT_CACHE_STREAM`, i), its point on the image from (`LIGHT_CACHE_STREAM` + 1, i).
const LIGHT_CACHE_STREAM: u64 = CACHE_STREAM + 0x1c00;

/// Light-cache paths traced between two hand-overs to the integrator: the deposits held at
/// once stay bounded (at most 16 per path, about 8 MB) whatever the path count.
const LIGHT_CACHE_CHUNK: u32 = 1 << 14;

/// Fills the integrator's light cache, if it has one ([`CacheBuilder::light_paths`]), on
/// `settings.threads` threads: what [`build_cache`] does first, and all a render from a cache
/// file read back needs to rebuild (the file keeps the records, not the light cache, which the
/// final pass's own gathers read). The same bits as [`build_cache`]'s, for the same seed.
pub fn build_light_cache(
    scene: &Scene,
    camera: &Camera,
    builder: &mut dyn CacheBuilder,
    settings: &RenderSettings,
) -> Result<Option<LightCacheStats>, RenderError> {
    settings.validate()?;
    builder.set_view(cache_view(camera));
    let paths = builder.light_paths();
    if paths == 0 {
        return Ok(None);
    }
    let (stats, _) = crate::render::with_threads(settings.threads, || {
        trace_light_cache(scene, camera, builder, settings, paths)
    })?;
    Ok(Some(stats))
}

/// The view a cache sizes its lengths by ([`CacheBuilder::set_view`]): the camera that launches
/// the light cache's paths.
pub fn cache_view(camera: &Camera) -> CacheView {
    CacheView {
        position: camera.position,
        height_per_distance: 2.0 * (0.5 * camera.yfov).tan(),
        height: 0.0,
    }
}

/// Fills the integrator's light cache with at most `paths` camera-launched paths, each from a
/// uniformly random point of the image, in chunks of [`LIGHT_CACHE_CHUNK`] until the integrator
/// says it has converged: traced in parallel, added in path order (so the cells' sums, and the
/// chunk it stops after, are the same for any thread count). A chunk is traced while the one
/// before it is added (adding is sequential); when the cache converges with that one, the
/// chunk traced beside it is dropped, so the cache holds the same chunks as if each waited.
fn trace_light_cache(
    scene: &Scene,
    camera: &Camera,
    builder: &mut dyn CacheBuilder,
    settings: &RenderSettings,
    paths: u32,
) -> LightCacheStats {
    let start = Instant::now();
    let mut rays = RayCounter::default();
    let size = Vec2::new(settings.width as f32, settings.height as f32);
    let tracer = builder.light_path_tracer();
    let trace = |chunk: std::ops::Range<u32>, tracer: LightPathTracer| {
        let traced: Vec<(Vec<LightDeposit>, RayCounter)> = chunk
            .into_par_iter()
            .with_min_len(64)
            .map(|i| {
                let raster = SampleKey::new(settings.seed, LIGHT_CACHE_STREAM + 1, u64::from(i))
                    .uniform_2d(0)
                    * size;
                let ray = camera_ray(camera, settings, raster);
                let key = SampleKey::new(settings.seed, LIGHT_CACHE_STREAM, u64::from(i));
                let mut r = RayCounter::default();
                (tracer.trace(scene, &ray, key, &mut r), r)
            })
            .collect();
        let mut rays = RayCounter::default();
        let deposits = traced
            .into_iter()
            .map(|(d, r)| {
                rays += r;
                d
            })
            .collect::<Vec<_>>();
        (deposits, rays)
    };
    let mut pending: Option<Vec<Vec<LightDeposit>>> = None;
    let mut first = 0u32;
    loop {
        let next = tracer
            .filter(|_| first < paths)
            .map(|t| (first..paths.min(first.saturating_add(LIGHT_CACHE_CHUNK)), t));
        let (traced, converged) = rayon::join(
            || next.clone().map(|(chunk, t)| trace(chunk, t)),
            || {
                pending.take().map(|p| {
                    // Whether each deposit sees its cell's anchor, in parallel.
                    let occluded = |rays: &[Ray]| -> Vec<bool> {
                        rays.par_chunks(64)
                            .flat_map_iter(|chunk| {
                                let mut hidden = vec![false; chunk.len()];
                                scene.occluded_stream(chunk, &mut hidden);
                                hidden
                            })
                            .collect()
                    };
                    let shadow = builder.add_light_paths(p, &occluded);
                    (builder.light_cache_converged(), shadow)
                })
            },
        );
        if let Some((_, r)) = &traced {
            rays += *r;
        }
        let converged = converged.map(|(converged, shadow)| {
            rays.shadow += shadow;
            converged
        });
        if converged == Some(true) {
            break;
        }
        match (traced, next) {
            (Some((deposits, _)), Some((chunk, _))) => {
                pending = Some(deposits);
                first = chunk.end;
            }
            _ => break,
        }
    }
    builder.settle_light_cache();
    LightCacheStats {
        counts: builder.light_cache_counts(),
        error: builder.light_cache_error(),
        rays,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// One construction pass.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PassStats {
    /// The cache level.
    pub level: u32,
    /// The pixel stride (0 for the pass over every sample).
    pub stride: u32,
    /// Camera rays (pixels or samples) visited.
    pub visited: u64,
    /// Points no record covered (each probed with a coarse distance-only gather).
    pub probes: u64,
    /// Candidates computed (the probes selected for a full gather).
    pub candidates: u64,
    /// What the commit did.
    pub commit: CommitStats,
    /// Rays traced while computing candidates.
    pub rays: RayCounter,
    /// Wall-clock seconds of the pass (candidates and commit).
    pub seconds: f64,
}

/// What building the cache cost.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CacheBuildStats {
    /// Every pass, in order.
    pub passes: Vec<PassStats>,
    /// Wall-clock seconds of all passes.
    pub seconds: f64,
    /// Records per level after construction.
    pub records: Vec<usize>,
    /// Per level, the median and the 90th percentile of its records' noise: the estimated
    /// relative standard error of each record's irradiance (its gather's own).
    pub noise: Vec<(f32, f32)>,
    /// The light cache, when the integrator has one: what it holds, its rays and seconds.
    pub light: Option<LightCacheStats>,
    /// With radiance caching: records with coefficients, the order, their bytes.
    pub radiance: Option<(usize, usize, usize)>,
}

/// What building the light cache did (`BounceMode::LightCache`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LightCacheStats {
    /// Paths, deposits and cells.
    pub counts: LightCacheCounts,
    /// The relative standard error of its cells' means (`LightCache::relative_error`).
    pub error: f64,
    /// The paths' rays.
    pub rays: RayCounter,
    /// Wall-clock seconds.
    pub seconds: f64,
}

impl CacheBuildStats {
    /// All rays traced during construction.
    pub fn rays(&self) -> RayCounter {
        let mut r = self.light.map_or_else(RayCounter::default, |l| l.rays);
        for p in &self.passes {
            r += p.rays;
            r.shadow += p.commit.guard_rays;
        }
        r
    }

    /// The share of the passes' rays spent on candidates that were dropped at commit (the
    /// light cache's rays are not the passes').
    pub fn wasted_share(&self) -> f64 {
        let dropped: u64 = self.passes.iter().map(|p| p.commit.dropped_rays).sum();
        let light = self.light.map_or(0, |l| l.rays.total());
        let all = self.rays().total() - light;
        if all == 0 {
            0.0
        } else {
            dropped as f64 / all as f64
        }
    }

    /// One line: records (and their noise), passes, time, rays, waste.
    pub fn summary(&self) -> String {
        let inserted: u64 = self.passes.iter().map(|p| p.commit.inserted).sum();
        let dropped: u64 = self.passes.iter().map(|p| p.commit.dropped).sum();
        format!(
            "cache: {} records ({}) in {} passes, {:.2} s, {:.1} M rays; {} candidates dropped as covered ({:.1} % of construction rays wasted)",
            inserted,
            self.records
                .iter()
                .enumerate()
                .map(|(l, n)| match self.noise.get(l) {
                    Some((median, p90)) if *n > 0 => format!(
                        "level {l}: {n}, noise {:.1} % median, {:.1} % at the 90th percentile",
                        100.0 * median,
                        100.0 * p90
                    ),
                    _ => format!("level {l}: {n}"),
                })
                .collect::<Vec<_>>()
                .join("; "),
            self.passes.len(),
            self.seconds,
            self.rays().total() as f64 / 1e6,
            dropped,
            100.0 * self.wasted_share()
        ) + &self.radiance.map_or_else(String::new, |(records, order, bytes)| {
            format!(
                "; radiance records: {records} of order {order} ({:.1} MB of coefficients)",
                bytes as f64 / 1e6
            )
        }) + &self.light.map_or_else(String::new, |l| {
            format!(
                "; light cache: {} paths, {} deposits in {} cells ({} used, {} split by walls, {:.1} % error{}), {:.2} s",
                l.counts.paths,
                l.counts.deposits,
                l.counts.cells,
                l.counts.used_cells,
                l.counts.split,
                100.0 * l.error,
                if l.counts.dropped > 0 {
                    format!(
                        "; table full: {} deposits in new cells dropped, their reads path-traced",
                        l.counts.dropped
                    )
                } else {
                    String::new()
                },
                l.seconds
            )
        })
    }
}

/// The pixel footprint per unit distance along a camera ray of unit direction `direction`: the
/// pixel's height on the plane at depth z is 2·tan(yfov/2)·z/H, and z = t·(direction·forward).
pub fn pixel_spread(camera: &Camera, height: u32, direction: glam::Vec3) -> f32 {
    let per_depth = 2.0 * (0.5 * camera.yfov).tan() / height.max(1) as f32;
    per_depth * direction.dot(camera.forward).max(0.0)
}

/// The passes of stride `stride`: for the first stride, its whole grid; for a finer one, the
/// three sub-lattices of its grid that the coarser grid does not hold ((s, 0), (0, s) and (s, s)
/// modulo 2s), each its own pass so that a pass's pixels lie at least 2s apart. Each in
/// row-major order.
fn pass_lattices(width: u32, height: u32, stride: u32) -> Vec<Vec<(u32, u32)>> {
    let grid = |ox: u32, oy: u32, step: u32| -> Vec<(u32, u32)> {
        (oy..height)
            .step_by(step as usize)
            .flat_map(|y| (ox..width).step_by(step as usize).map(move |x| (x, y)))
            .collect()
    };
    if stride >= FIRST_STRIDE {
        return vec![grid(0, 0, stride)];
    }
    let coarse = 2 * stride;
    [(stride, 0), (0, stride), (stride, stride)]
        .into_iter()
        .map(|(ox, oy)| grid(ox, oy, coarse))
        .filter(|p| !p.is_empty())
        .collect()
}

/// The most repair passes after construction (see `build_cache`).
pub const MAX_REPAIR_PASSES: u32 = 16;

/// The finest lattice of the repair passes' probes: every quarter of a pixel.
pub const MAX_COVERAGE_LATTICE: u32 = 4;

/// How finely the repair passes probe (every 1/k of a pixel in x and y) for records whose
/// influence radius is at least `smallest` pixels: every point of the image plane then lies
/// within half the smallest influence radius of a probe (the farthest point of a lattice cell
/// of side 1/k is √2/(2k) from its corners); at most [`MAX_COVERAGE_LATTICE`]. Gaps between
/// spheres narrower than the lattice can remain (three tangent spheres of influence r leave
/// one of inscribed radius (2/√3 − 1)·r): a camera sample there lies within its pixel of a
/// sphere that covered a probe, and the final pass reads across that (irr-integrator's
/// `ic/pixel.rs`).
pub fn coverage_lattice(smallest: f32) -> u32 {
    let k = (std::f32::consts::SQRT_2 / smallest).ceil();
    if k.is_finite() && k >= 1.0 {
        (k as u32).min(MAX_COVERAGE_LATTICE)
    } else {
        MAX_COVERAGE_LATTICE
    }
}

/// The repair passes' probes: the camera rays through every point (i/k, j/k) of the image plane,
/// 0 ≤ i ≤ k·width, 0 ≤ j ≤ k·height, row by row, each with its own key.
fn repair_lattice(
    camera: &Camera,
    settings: &RenderSettings,
    k: u32,
) -> Vec<(Ray, f32, SampleKey)> {
    let (w, h) = (settings.width * k + 1, settings.height * k + 1);
    let mut jobs = Vec::with_capacity(w as usize * h as usize);
    for j in 0..h {
        for i in 0..w {
            let raster = Vec2::new(i as f32 / k as f32, j as f32 / k as f32);
            let ray = camera_ray(camera, settings, raster);
            let spread = pixel_spread(camera, settings.height, ray.direction);
            let index = u64::from(j) * u64::from(w) + u64::from(i);
            jobs.push((
                ray,
                spread,
                SampleKey::new(settings.seed, REPAIR_STREAM, index),
            ));
        }
    }
    jobs
}

/// A camera ray through raster point `raster`.
fn camera_ray(camera: &Camera, settings: &RenderSettings, raster: Vec2) -> Ray {
    let r = camera.ray(raster, settings.width, settings.height);
    Ray {
        origin: r.origin,
        direction: r.direction,
        t_max: r.t_max,
    }
}

/// The key views of a shared cache, for sizing each first-level record by the view that needs
/// it smallest (one view: nothing to do).
struct Views<'a> {
    cameras: &'a [Camera],
    width: u32,
    height: u32,
}

impl Views<'_> {
    /// `spread`, the pixel's size per unit distance along the camera ray `ray`, scaled so that
    /// the point the ray hits takes the smallest pixel footprint on its surface
    /// (`surface_spacing`) that any of the views has there, among those that see it: from the
    /// same side of its surface as `ray`, inside their image and depth range, and unoccluded. So
    /// a record's pixel limits are those of whichever key frame needs the smaller radius, not
    /// only those of the view whose pass made it. Unchanged with one view, for a miss, and where
    /// no other view sees the point smaller. One closest-hit ray, and a shadow ray for each view
    /// that would see it smaller, in order of footprint, until one sees it.
    fn spread(&self, scene: &Scene, ray: &Ray, spread: f32, rays: &mut RayCounter) -> f32 {
        if self.cameras.len() < 2 {
            return spread;
        }
        rays.closest += 1;
        let Some(hit) = scene.intersect_camera(ray) else {
            return spread;
        };
        let surface = scene.geometry().surface(ray, &hit);
        let (p, ng) = (surface.position, surface.geometric_normal);
        let own = surface_spacing(spread * hit.t, ray.direction, ng);
        let side = ng.dot(ray.origin - p);
        let aspect = self.width as f32 / self.height.max(1) as f32;
        let mut smaller: Vec<(f32, &Camera)> = self
            .cameras
            .iter()
            .filter_map(|c| {
                let d = p - c.position;
                let z = d.dot(c.forward);
                let tan_half = (0.5 * c.yfov).tan();
                let inside = z > c.znear
                    && c.zfar.is_none_or(|f| z < f)
                    && d.dot(c.right).abs() <= z * tan_half * aspect
                    && d.dot(c.up).abs() <= z * tan_half;
                let same_side = ng.dot(-d) * side > 0.0;
                // A pixel spans 2·tan(yfov/2)·z/H across the view at depth z.
                let per_depth = 2.0 * tan_half / self.height.max(1) as f32;
                let spacing = surface_spacing(per_depth * z, d, ng);
                (inside && same_side && spacing < own).then_some((spacing, c))
            })
            .collect();
        smaller.sort_by(|a, b| a.0.total_cmp(&b.0));
        for (spacing, c) in smaller {
            let back = (c.position - p).normalize_or_zero();
            rays.shadow += 1;
            if !scene.occluded(&Ray::spawn_to(p, ng, c.position, back)) {
                return spread * (spacing / own);
            }
        }
        spread
    }
}

/// Runs one pass: probes in parallel, the ordered selection, the selected probes' full gathers
/// in parallel, then the ordered commit.
fn run_pass(
    scene: &Scene,
    builder: &mut dyn CacheBuilder,
    (level, stride): (u32, u32),
    jobs: &[(Ray, f32, SampleKey)],
    views: &Views<'_>,
) -> PassStats {
    let start = Instant::now();
    let shared: &dyn CacheBuilder = builder;
    // Chunks keep the per-task overhead small; collect() keeps the jobs' order.
    let probed: Vec<(Vec<Probe>, RayCounter)> = jobs
        .par_chunks(64)
        .map(|chunk| {
            let mut rays = RayCounter::default();
            let found = chunk
                .iter()
                .filter_map(|(ray, spread, key)| {
                    let spread = if level == 0 {
                        views.spread(scene, ray, *spread, &mut rays)
                    } else {
                        *spread
                    };
                    shared.probe(scene, level, ray, spread, *key, &mut rays)
                })
                .collect();
            (found, rays)
        })
        .collect();
    let mut rays = RayCounter::default();
    let mut probes = Vec::new();
    for (found, r) in probed {
        rays += r;
        probes.extend(found);
    }
    let probe_count = probes.len() as u64;
    let selected = shared.select(probes);
    let completed: Vec<(Option<Candidate>, RayCounter)> = selected
        .par_iter()
        .with_max_len(1)
        .map(|probe| {
            let mut r = RayCounter::default();
            (shared.complete(scene, probe, &mut r), r)
        })
        .collect();
    let mut candidates = Vec::with_capacity(completed.len());
    for (c, r) in completed {
        rays += r;
        candidates.extend(c);
    }
    let count = candidates.len() as u64;
    let commit = builder.commit(scene, candidates);
    PassStats {
        level,
        stride,
        visited: jobs.len() as u64,
        probes: probe_count,
        candidates: count,
        commit,
        rays,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// Builds every level of `builder`'s cache in deterministic parallel passes (see the module
/// docs), on `settings.threads` threads, with a progress bar when `progress` is true.
pub fn build_cache(
    scene: &Scene,
    camera: &Camera,
    builder: &mut dyn CacheBuilder,
    settings: &RenderSettings,
    fill_samples: bool,
    progress: bool,
) -> Result<CacheBuildStats, RenderError> {
    build_shared_cache(
        scene,
        std::slice::from_ref(camera),
        builder,
        settings,
        fill_samples,
        progress,
    )
}

/// [`build_cache`] for several views of one static scene, a walkthrough's key frames: the light
/// cache from the first view's camera paths, then each view's construction passes in turn,
/// each adding records only where the cache so far does not cover its points. A first-level
/// record's pixel limits are those of whichever view sees its point smallest (among the views
/// that see it), not only of the view whose pass made it, so a frame close to a surface finds
/// records as fine as its own cache would have. The frames then render from the cache
/// without adding to it, so each frame's image depends on the views given and on itself, not
/// on which frames are rendered or in what order. Refused without a view.
pub fn build_shared_cache(
    scene: &Scene,
    cameras: &[Camera],
    builder: &mut dyn CacheBuilder,
    settings: &RenderSettings,
    fill_samples: bool,
    progress: bool,
) -> Result<CacheBuildStats, RenderError> {
    build_cache_shard(
        scene,
        cameras,
        0..cameras.len(),
        builder,
        settings,
        fill_samples,
        progress,
    )
}

/// One shard of a shared cache: [`build_shared_cache`]'s passes for the views `shard` of
/// `cameras` only, into `builder`'s (empty) cache, with the light cache still from the first
/// of all `cameras` (so every shard's gathers see the same light cache, wherever it runs).
/// Shards built independently and joined by irr-render's `merge_shards` make a sequence's
/// cache that no machine had to build whole. Refused without a view or with a range outside
/// `cameras`.
pub fn build_cache_shard(
    scene: &Scene,
    cameras: &[Camera],
    shard: std::ops::Range<usize>,
    builder: &mut dyn CacheBuilder,
    settings: &RenderSettings,
    fill_samples: bool,
    progress: bool,
) -> Result<CacheBuildStats, RenderError> {
    settings.validate()?;
    let Some(first) = cameras.first() else {
        return Err(RenderError::Setting {
            option: "--frames",
            problem: "a shared cache needs at least one view".into(),
        });
    };
    let Some(views) = cameras.get(shard.clone()).filter(|v| !v.is_empty()) else {
        return Err(RenderError::Setting {
            option: "--shards",
            problem: format!(
                "shard {shard:?} is empty or outside the {} key frames",
                cameras.len()
            ),
        });
    };
    builder.set_view(cache_view(first));
    let start = Instant::now();
    let mut stats = CacheBuildStats::default();
    let bar = if progress {
        let bar = indicatif::ProgressBar::new_spinner();
        bar.set_message("building the irradiance cache");
        bar.enable_steady_tick(std::time::Duration::from_millis(200));
        bar
    } else {
        indicatif::ProgressBar::hidden()
    };
    crate::render::with_threads(settings.threads, || {
        let paths = builder.light_paths();
        if paths > 0 {
            bar.set_message(format!("building the light cache: {paths} paths"));
            stats.light = Some(trace_light_cache(scene, first, builder, settings, paths));
        }
        for camera in views {
            view_passes(
                scene,
                (camera, cameras),
                builder,
                settings,
                fill_samples,
                &bar,
                &mut stats,
            );
        }
    })?;
    bar.finish_and_clear();
    stats.seconds = start.elapsed().as_secs_f64();
    stats.records = builder.record_counts();
    stats.radiance = builder.radiance_records();
    stats.noise = (0..stats.records.len())
        .map(|l| median_and_p90(builder.record_noise(l)))
        .collect();
    Ok(stats)
}

/// One view's construction passes (module docs): the deeper levels from its walks, level 0 from
/// its pixels, coarse to fine, the camera samples with `fill_samples`, and the repair passes.
fn view_passes(
    scene: &Scene,
    (camera, views): (&Camera, &[Camera]),
    builder: &mut dyn CacheBuilder,
    settings: &RenderSettings,
    fill_samples: bool,
    bar: &indicatif::ProgressBar,
    stats: &mut CacheBuildStats,
) {
    let levels = builder.levels();
    let (w, h) = (settings.width, settings.height);
    let views = Views {
        cameras: views,
        width: w,
        height: h,
    };
    let one = Views {
        cameras: &[],
        width: w,
        height: h,
    };
    {
        let centre_jobs = |level: u32, pixels: &[(u32, u32)]| -> Vec<(Ray, f32, SampleKey)> {
            pixels
                .iter()
                .map(|&(x, y)| {
                    let ray =
                        camera_ray(camera, settings, Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                    let spread = pixel_spread(camera, h, ray.direction);
                    let key = SampleKey::new(
                        settings.seed,
                        CACHE_STREAM + u64::from(level),
                        u64::from(y) * u64::from(w) + u64::from(x),
                    );
                    (ray, spread, key)
                })
                .collect()
        };
        for level in (1..levels).rev() {
            // A deeper level's records lie where the level above's gathers land, all over the
            // scene rather than where the camera looks: its walks start on a DEEP_GRID² grid
            // of the image whatever the image's size, coarse to fine as the pixel passes, then
            // repeat from new keys until almost every walk ends covered.
            let mut stride = FIRST_STRIDE;
            while stride >= 1 {
                for lattice in pass_lattices(DEEP_GRID, DEEP_GRID, stride) {
                    let jobs = deep_jobs(camera, settings, level, 0, &lattice);
                    bar.set_message(format!(
                        "building the irradiance cache: level {level}, stride {stride}, {} walks",
                        jobs.len()
                    ));
                    stats
                        .passes
                        .push(run_pass(scene, builder, (level, stride), &jobs, &one));
                }
                stride /= 2;
            }
            let grid: Vec<(u32, u32)> = (0..DEEP_GRID)
                .flat_map(|y| (0..DEEP_GRID).map(move |x| (x, y)))
                .collect();
            for round in 1..=MAX_REPAIR_PASSES {
                let jobs = deep_jobs(camera, settings, level, round, &grid);
                bar.set_message(format!(
                    "building the irradiance cache: level {level}, repair"
                ));
                let pass = run_pass(scene, builder, (level, 1), &jobs, &one);
                let done = (pass.probes as f64) < DEEP_UNCOVERED * jobs.len() as f64;
                stats.passes.push(pass);
                if done {
                    break;
                }
            }
        }
        let mut stride = FIRST_STRIDE;
        while stride >= 1 {
            for lattice in pass_lattices(w, h, stride) {
                let jobs = centre_jobs(0, &lattice);
                bar.set_message(format!(
                    "building the irradiance cache: level 0, stride {stride}, {} pixels",
                    jobs.len()
                ));
                stats
                    .passes
                    .push(run_pass(scene, builder, (0, stride), &jobs, &views));
            }
            stride /= 2;
        }
        if fill_samples {
            // Every camera sample's own ray, as the final pass will trace it: one pass per
            // sample index, so that a pixel's later samples find its earlier ones' records.
            for i in 0..settings.spp {
                let mut jobs = Vec::with_capacity((w * h) as usize);
                for y in 0..h {
                    for x in 0..w {
                        let raster = crate::render::raster_position(settings, x, y, i);
                        let ray = camera_ray(camera, settings, raster);
                        let spread = pixel_spread(camera, h, ray.direction);
                        let index = (u64::from(y) * u64::from(w) + u64::from(x))
                            * u64::from(settings.spp)
                            + u64::from(i);
                        let key = SampleKey::new(settings.seed, CACHE_STREAM + 0xff, index);
                        jobs.push((ray, spread, key));
                    }
                }
                bar.set_message(format!("building the irradiance cache: camera samples {i}"));
                stats
                    .passes
                    .push(run_pass(scene, builder, (0, 0), &jobs, &views));
            }
        }
        // Neighbour clamping shrinks earlier records as later ones arrive, which can uncover
        // points the earlier passes saw covered, and pixel centres say nothing of the rest of
        // their pixels: repair passes probe a lattice of every 1/k of a pixel, k from the
        // smallest record's influence (`coverage_lattice`), until none is uncovered, at most
        // MAX_REPAIR_PASSES times; the final pass reads the records within a pixel of any point
        // still uncovered, and gathers where none is.
        let k = coverage_lattice(builder.smallest_influence_pixels());
        let lattice = repair_lattice(camera, settings, k);
        for _ in 0..MAX_REPAIR_PASSES {
            bar.set_message("building the irradiance cache: repair pass");
            let pass = run_pass(scene, builder, (0, 1), &lattice, &views);
            let done = pass.probes == 0;
            stats.passes.push(pass);
            if done {
                break;
            }
        }
    }
}

/// The median and the 90th percentile of `values` (nearest rank; 0 for none).
fn median_and_p90(values: &[f32]) -> (f32, f32) {
    let mut sorted = values.to_vec();
    sorted.sort_by(f32::total_cmp);
    let rank = |q: f32| {
        let i = ((q * sorted.len() as f32).ceil() as usize).clamp(1, sorted.len().max(1)) - 1;
        sorted.get(i).copied().unwrap_or(0.0)
    };
    (rank(0.5), rank(0.9))
}

/// The debug view of a cache (`--show-records`): a copy of `image` with each record at its
/// projected position marked by a bright dot, and its sphere of influence by a ring of its
/// projected radius in the colour of its noise (`noise_colour`: blue for a quiet record,
/// through green and yellow, to red for 20 % and more). Records behind the camera or off the
/// image are skipped.
pub fn mark_records(
    image: &crate::image::Image,
    camera: &Camera,
    records: &[DisplayRecord],
) -> crate::image::Image {
    let (w, h) = (image.width(), image.height());
    let mut out = image.clone();
    let tan = (0.5 * camera.yfov).tan();
    let aspect = w as f32 / h.max(1) as f32;
    let bright = image
        .pixels()
        .iter()
        .map(|p| p.max_element())
        .fold(0.0f32, f32::max)
        .max(1.0);
    let mut plot = |x: f32, y: f32, c: glam::Vec3| {
        if x >= 0.0 && y >= 0.0 && (x as u32) < w && (y as u32) < h {
            out.set(x as u32, y as u32, c);
        }
    };
    for r in records {
        let (p, influence) = (r.position, r.influence_radius);
        let d = p - camera.position;
        let depth = d.dot(camera.forward);
        if depth.is_nan() || depth <= 0.0 {
            continue;
        }
        let ndc_x = d.dot(camera.right) / (depth * tan * aspect);
        let ndc_y = d.dot(camera.up) / (depth * tan);
        let x = (ndc_x + 1.0) * 0.5 * w as f32;
        let y = (1.0 - ndc_y) * 0.5 * h as f32;
        // At most 1 in every channel, so the PNG preview (clipped at 1) keeps its hue.
        let colour = noise_colour(r.noise);
        // The ring: the influence radius in pixels at that depth.
        let radius = influence / (depth * 2.0 * tan / h as f32);
        let steps = (radius * 6.3).clamp(8.0, 512.0) as u32;
        for i in 0..steps {
            let a = i as f32 / steps as f32 * std::f32::consts::TAU;
            plot(x + radius * a.cos(), y + radius * a.sin(), colour);
        }
        plot(x, y, glam::Vec3::splat(bright));
    }
    out
}

/// The debug view's colour for a record's noise (relative standard error): blue at 0, green at
/// 5 %, yellow at 10 %, red at 20 % and above, linear in between.
pub fn noise_colour(noise: f32) -> glam::Vec3 {
    use glam::Vec3;
    let stops = [
        (0.0, Vec3::new(0.1, 0.3, 1.0)),
        (0.05, Vec3::new(0.1, 1.0, 0.2)),
        (0.1, Vec3::new(1.0, 1.0, 0.1)),
        (0.2, Vec3::new(1.0, 0.1, 0.1)),
    ];
    let noise = if noise.is_nan() { 1.0 } else { noise };
    for w in stops.windows(2) {
        let ((a, ca), (b, cb)) = (w[0], w[1]);
        if noise <= b {
            return ca.lerp(cb, ((noise - a) / (b - a)).clamp(0.0, 1.0));
        }
    }
    stops[stops.len() - 1].1
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A shared cache's views size a point by the view that sees it smallest: the Cornell box's
    /// camera and the same camera moved 40 % of the way to the back wall both look straight at
    /// the wall's centre, so the near view's footprint there is the far one's times z_near/t
    /// (the same cosine; t the far ray's hit distance), and the far view's spread shrinks by
    /// that ratio, to f32 rounding
    /// (a few ulps of the divisions: 1e-5 relative). A view turned away, one behind the wall
    /// (the other side of its surface) or one alone leaves the spread as it is.
    #[test]
    fn a_point_takes_the_footprint_of_the_view_that_sees_it_smallest() {
        let loaded = crate::load_scene(&irr_scene::testutil::assets().join("cornell-box.gltf"))
            .unwrap_or_else(|e| panic!("{e}"));
        let (w, h) = (64u32, 64u32);
        let settings = RenderSettings {
            width: w,
            height: h,
            spp: 1,
            seed: 1,
            threads: 1,
        };
        let far = loaded.camera_for(w, h);
        let ray = camera_ray(&far, &settings, Vec2::new(32.0, 32.0));
        let spread = pixel_spread(&far, h, ray.direction);
        let hit = loaded
            .scene
            .intersect(&ray)
            .unwrap_or_else(|| panic!("the centre ray hits the back wall"));
        let wall = ray.at(hit.t);
        let z_far = (wall - far.position).dot(far.forward);
        let near = Camera {
            position: far.position + far.forward * (0.4 * z_far),
            ..far
        };
        let z_near = (wall - near.position).dot(near.forward);
        let views = |cameras: &[Camera]| {
            let v = Views {
                cameras,
                width: w,
                height: h,
            };
            v.spread(&loaded.scene, &ray, spread, &mut RayCounter::default())
        };
        let shrunk = views(&[far, near]);
        // The probe sizes the far view's footprint as spread·t, t measured from the ray's
        // origin on the near plane (as the walk measures it); the near view's is its per-depth
        // size times z_near, which equals `spread` on the centre ray.
        let expected = spread * z_near / hit.t;
        assert!(
            (shrunk / expected - 1.0).abs() < 1e-5,
            "{shrunk} against {expected}"
        );
        let away = Camera {
            forward: -near.forward,
            right: -near.right,
            ..near
        };
        let behind = Camera {
            position: wall + far.forward * 0.5,
            forward: -far.forward,
            right: -far.right,
            ..far
        };
        assert_eq!(views(&[far, away]), spread);
        assert_eq!(views(&[far, behind]), spread);
        assert_eq!(views(&[near]), spread);
    }

    /// The passes visit every pixel exactly once, coarse grid first.
    #[test]
    fn passes_partition_the_image() {
        for (w, h) in [(1, 1), (17, 5), (64, 33), (100, 100)] {
            let mut seen = vec![0u8; (w * h) as usize];
            let mut stride = FIRST_STRIDE;
            while stride >= 1 {
                for lattice in pass_lattices(w, h, stride) {
                    for (x, y) in lattice {
                        assert!(x % stride == 0 && y % stride == 0);
                        seen[(y * w + x) as usize] += 1;
                    }
                }
                stride /= 2;
            }
            assert!(seen.iter().all(|&s| s == 1), "{w}×{h}");
        }
    }
}
