//! The irradiance-cache integrator (Ward, Rubinstein & Clear 1988; Ward & Heckbert 1992;
//! Tabellion & Lamorlette 2004; Křivánek et al. 2006), and ambient occlusion through the same
//! cache.
//!
//! # What each part of a pixel carries
//! The radiance leaving the first surface x₀ towards the camera is split exactly as
//! [`crate::PathTracer::li_split`] splits it (see [`crate::path`]):
//! - `emitted`: Le(x₀), or the background B when the camera ray leaves the scene: paths `L E`
//!   and `L B`;
//! - `direct`: next-event estimation at x₀ ([`IcSettings::direct_samples`] light samples), paths
//!   `L D E`. NEE alone covers every such path (the light sampler reaches every point of every
//!   emitting triangle, and every punctual light), so no BSDF-sampled emitter hit is needed;
//! - `indirect`: (ρ(x₀)/π)·E_ind(x₀), paths `L D D+ E` and `L D+ B`, with E_ind interpolated
//!   from the cache. **The background's light that reflects is here**, as in the path tracer:
//!   the cache stores the irradiance due to the background as well as to reflected light
//!   (Radiance, likewise, computes its sky's diffuse light in the ambient calculation), so a
//!   gather ray that leaves the scene brings back B.
//!
//! A record's gather at x traces one cosine-distributed ray per cell of an M×N
//! [`HemisphereStrata`]; the radiance a ray brings back from the point x₁ it hits is what x₁
//! *reflects* towards x (its emission excluded: that is x's `direct`): NEE at x₁ plus x₁'s own
//! indirect part, either path-traced ([`BounceMode::PathTraced`], `PathTracer::reflected`) or
//! looked up in the cache of the next bounce level ([`BounceMode::Cached`], Radiance's `-ab`).
//! A ray that hits nothing brings back the background B. Punctual lights reach the gathers
//! through the NEE at x₁ (`sample_light`, shared with the path tracer).
//! The deepest cached level's gathers always path-trace the rest, so no bounce is cut off and
//! the image converges to the path tracer's as the error parameter tightens.
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
//!
//! # Leaks
//! [`LeakGuard::Visibility`]: each record keeps the nearest hit distance oᵢ of its whole gather
//! (horizon rays included). A query farther than oᵢ/2 from the record may have an occluder
//! between them, so a shadow ray between the two decides; closer than oᵢ/2 nothing can be
//! (every direction from pᵢ was free for at least oᵢ, up to the angular gap between sampled
//! directions, which for a wall is a factor 1/cos(gap) ≈ 1.02 at 32×128, far inside the factor
//! 2). A record on the lit side of a 1 mm wall therefore never lights the dark side.

use crate::integrator::{Integrator, RayCounter};
use crate::path::{PathSettings, PathTracer, Radiance, ShadingPoint, first_surface, sample_light};
use crate::scene::Scene;
use glam::Vec3;
use irr_cache::{
    CacheValue, ErrorMetric, InsertError, IrradianceCache, MetricError, PixelRange, RadiusInputs,
    RadiusLimits, Record, RecordId, Rgb, TabellionLamorlette, Ward,
};
use irr_geometry::{Ray, SurfacePoint};
use irr_gradients::{GatherSamples, GatherValue, Gradients, TranslationGradient};
use irr_sampling::rng::Dimensions;
use irr_sampling::{Frame, HemisphereStrata, SampleKey, sample_cosine_hemisphere};
use std::f32::consts::FRAC_1_PI;
use std::sync::atomic::{AtomicU64, Ordering};
use thiserror::Error;

/// A gather cell's traced ray: what it hit (`None`: it left the scene), its direction and the
/// cell's sample key.
type Traced = (Option<SurfacePoint>, Vec3, SampleKey);

/// cos 80°: hits less than 10° above the horizon do not size a record (Mitsuba 0.6 uses 0.173;
/// Radiance skips them too). See `GatherSamples::harmonic_mean_distance_above`.
pub const HORIZON_CUT_COS: f32 = 0.173_648_18;

/// The stream of the final pass's own gathers (see `SampleKey::new`).
const FALLBACK_STREAM: u64 = 0x1c_fa11;

/// Which weighting the cache uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MetricKind {
    /// Tabellion & Lamorlette 2004; the error parameter is κ (larger is stricter).
    #[default]
    TabellionLamorlette,
    /// Ward et al. 1988; the error parameter is a (smaller is stricter).
    Ward,
}

/// The cache's metric as one concrete type, so one cache type serves both.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IcMetric {
    /// See [`TabellionLamorlette`].
    TabellionLamorlette(TabellionLamorlette),
    /// See [`Ward`].
    Ward(Ward),
}

impl ErrorMetric for IcMetric {
    #[inline]
    fn influence_radius(&self, record_radius: f32) -> f32 {
        match self {
            Self::TabellionLamorlette(m) => m.influence_radius(record_radius),
            Self::Ward(m) => m.influence_radius(record_radius),
        }
    }
    #[inline]
    fn weight(&self, candidate: &irr_cache::Candidate) -> f64 {
        match self {
            Self::TabellionLamorlette(m) => m.weight(candidate),
            Self::Ward(m) => m.weight(candidate),
        }
    }
    fn radius_limits(&self, pixel_spacing: f32) -> RadiusLimits {
        match self {
            Self::TabellionLamorlette(m) => m.radius_limits(pixel_spacing),
            Self::Ward(m) => m.radius_limits(pixel_spacing),
        }
    }
}

/// Which translation gradient records carry (the rotation gradient comes with either).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum GradientMode {
    /// No gradients: records are interpolated as constants.
    Off,
    /// Ward & Heckbert 1992 (Radiance).
    #[default]
    WardHeckbert,
    /// Křivánek et al. 2005 in Křivánek & Gautron's form (Mitsuba 0.6).
    KrivanekGautron,
}

/// What a gather ray brings back beyond the direct light at its hit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BounceMode {
    /// The hit point's own indirect light by a path-traced continuation (unbiased).
    #[default]
    PathTraced,
    /// The hit point's indirect light from the cache of the next bounce level (Radiance's
    /// `-ab`); the deepest level path-traces the rest.
    Cached,
}

/// How records are kept from lighting points they cannot see.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LeakGuard {
    /// No test beyond the metric's.
    Off,
    /// A shadow ray between query and record when the query is farther than half the record's
    /// nearest gather hit (see the module docs).
    #[default]
    Visibility,
}

/// Settings of [`IrradianceCacheIntegrator`] and [`CachedAmbientOcclusion`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IcSettings {
    /// The metric. Default: Tabellion & Lamorlette.
    pub metric: MetricKind,
    /// The error parameter: κ for Tabellion & Lamorlette (larger is stricter; default 1, range
    /// (0, ∞)), or a for Ward (smaller is stricter; typical 0.1–0.3).
    pub error: f32,
    /// M, strata along θ of a first-level gather. Default: 12. Range: ≥ 1 (M·N ≤ 2²⁰).
    ///
    /// The defaults (κ = 1, 12×48, with 64 camera samples per pixel in `cargo xtask render`)
    /// were chosen by `cargo xtask compare` on the Cornell box at 128×128 against a 4096-spp
    /// path-traced reference: relMSE 3.2e-4 in 5.2 s (2 loaded cores), where 8×32 gave 4.8e-4
    /// in 3.7 s, and the path tracer needs about 670 spp (≈ 22 s) for 3.2e-4. See the closing
    /// note of the integrator issue and docs/compare.md.
    pub strata_m: u32,
    /// N, strata along φ. Default: 48. Range: ≥ 1.
    pub strata_n: u32,
    /// Smallest record radius scale on screen, in pixels (see irr-cache's `PixelRange`).
    /// Default: 1.5. Range: (0, `pixel_max`].
    pub pixel_min: f32,
    /// Largest record radius scale on screen, in pixels. Default: 10. Range: ≥ `pixel_min`.
    pub pixel_max: f32,
    /// Largest record radius in world units, as a fraction of the scene's bounding-box diagonal
    /// (also the radius of a record whose gather hit nothing). Default: 0.25. Range: (0, ∞).
    pub world_max: f32,
    /// Smallest record radius in world units, as a fraction of the diagonal (bounds the number
    /// of records near contact edges). Default: 1e-4. Range: [0, `world_max`].
    pub world_min: f32,
    /// The translation gradient. Default: Ward & Heckbert.
    pub gradients: GradientMode,
    /// Neighbour clamping (Křivánek et al. 2006). Default: on.
    pub neighbour_clamping: bool,
    /// The leak guard. Default: visibility.
    pub leak_guard: LeakGuard,
    /// What a gather ray brings back. Default: path-traced.
    pub bounce_mode: BounceMode,
    /// With [`BounceMode::Cached`]: how many cache levels below the first (≥ 1). Default: 1.
    pub cached_bounces: u32,
    /// With [`BounceMode::Cached`]: each deeper level's error parameter is loosened by this
    /// factor (κ divided, a multiplied) and its strata halved in each direction (at least 4×8),
    /// as Radiance loosens its accuracy per bounce. Default: 2. Range: ≥ 1.
    pub level_loosening: f32,
    /// Light samples (NEE) per camera hit for the direct light. Default: 1. Range: ≥ 1.
    pub direct_samples: u32,
    /// Construction also checks every camera sample's own hit (not only pixel centres), so the
    /// final pass almost never gathers for itself. Default: off. Measured on the Cornell box at
    /// 128×128, 64 spp: 4.25 s and relMSE 3.24e-4 with it (1988 records), 3.77 s and 3.28e-4
    /// without (1015 records), the final pass's own gathers (1 % of samples, at a quarter of the
    /// strata each way) costing less than checking every sample during construction.
    pub fill_samples: bool,
    /// The path tracer of continuations and of the fallback.
    pub path: PathSettings,
}

impl Default for IcSettings {
    fn default() -> Self {
        Self {
            metric: MetricKind::TabellionLamorlette,
            error: 1.0,
            strata_m: 12,
            strata_n: 48,
            pixel_min: 1.5,
            pixel_max: 10.0,
            world_max: 0.25,
            world_min: 1e-4,
            gradients: GradientMode::WardHeckbert,
            neighbour_clamping: true,
            leak_guard: LeakGuard::Visibility,
            bounce_mode: BounceMode::PathTraced,
            cached_bounces: 1,
            level_loosening: 2.0,
            direct_samples: 1,
            fill_samples: false,
            path: PathSettings::default(),
        }
    }
}

/// Settings that cannot be used, each naming the option.
#[derive(Clone, Debug, PartialEq, Error)]
#[error("{option}: {problem}")]
pub struct IcSettingsError {
    /// The option (CLI spelling).
    pub option: &'static str,
    /// What is wrong.
    pub problem: String,
}

fn setting_error(option: &'static str, problem: impl Into<String>) -> IcSettingsError {
    IcSettingsError {
        option,
        problem: problem.into(),
    }
}

impl IcSettings {
    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<(), IcSettingsError> {
        self.metric_at(0)?;
        HemisphereStrata::new(self.strata_m, self.strata_n).map_err(|e| {
            setting_error(
                "--strata",
                format!("{e} (got {}x{})", self.strata_m, self.strata_n),
            )
        })?;
        PixelRange::new(self.pixel_min, self.pixel_max)
            .map_err(|e| setting_error("--pixel-spacing", e.to_string()))?;
        if !(self.world_max.is_finite() && self.world_max > 0.0) {
            return Err(setting_error(
                "--world-max",
                format!("must be positive and finite, got {}", self.world_max),
            ));
        }
        if !(self.world_min.is_finite()
            && self.world_min >= 0.0
            && self.world_min <= self.world_max)
        {
            return Err(setting_error(
                "--world-min",
                format!(
                    "must lie in [0, world max = {}], got {}",
                    self.world_max, self.world_min
                ),
            ));
        }
        if self.bounce_mode == BounceMode::Cached && !(1..=8).contains(&self.cached_bounces) {
            return Err(setting_error(
                "--bounces",
                format!("must lie in 1..=8, got {}", self.cached_bounces),
            ));
        }
        if !(self.level_loosening.is_finite() && self.level_loosening >= 1.0) {
            return Err(setting_error(
                "--level-loosening",
                format!("must be finite and >= 1, got {}", self.level_loosening),
            ));
        }
        if self.direct_samples == 0 {
            return Err(setting_error("--direct-samples", "must be at least 1"));
        }
        Ok(())
    }

    /// The number of cache levels: 1, plus `cached_bounces` in cached mode.
    pub fn levels(&self) -> u32 {
        match self.bounce_mode {
            BounceMode::PathTraced => 1,
            BounceMode::Cached => 1 + self.cached_bounces,
        }
    }

    /// The metric of level `level` (0: the camera's), loosened per level.
    pub fn metric_at(&self, level: u32) -> Result<IcMetric, IcSettingsError> {
        let loosen = self.level_loosening.powi(level as i32);
        let pixels = PixelRange::new(self.pixel_min, self.pixel_max)
            .map_err(|e| setting_error("--pixel-spacing", e.to_string()))?;
        let bad = |e: MetricError| setting_error("--error", e.to_string());
        Ok(match self.metric {
            MetricKind::TabellionLamorlette => IcMetric::TabellionLamorlette(
                TabellionLamorlette::new(self.error / loosen)
                    .map_err(bad)?
                    .with_pixel_range(pixels),
            ),
            MetricKind::Ward => IcMetric::Ward(
                Ward::new(self.error * loosen)
                    .map_err(bad)?
                    .with_pixel_range(pixels),
            ),
        })
    }

    /// The strata of level `level`: halved in each direction per level, at least 4×8 (or the
    /// first level's, if smaller).
    pub fn strata_at(&self, level: u32) -> Result<HemisphereStrata, IcSettingsError> {
        let m = (self.strata_m >> level.min(31)).max(self.strata_m.min(4));
        let n = (self.strata_n >> level.min(31)).max(self.strata_n.min(8));
        HemisphereStrata::new(m, n)
            .map_err(|e| setting_error("--strata", format!("{e} (got {m}x{n})")))
    }
}

/// A value the integrator's caches hold: irradiance ([`Rgb`], gathered as `Vec3`) or ambient
/// occlusion (`f32`). Converts between irr-gradients' and irr-cache's value types.
pub trait IcValue: CacheValue {
    /// The gather's per-cell value type.
    type Gathered: GatherValue + Send + Sync;
    /// The cached value of a gathered one.
    fn from_gathered(g: Self::Gathered) -> Self;
    /// The gathered value of a cached one.
    fn to_gathered(self) -> Self::Gathered;
}

impl IcValue for Rgb {
    type Gathered = Vec3;
    #[inline]
    fn from_gathered(g: Vec3) -> Self {
        Rgb::from(g)
    }
    #[inline]
    fn to_gathered(self) -> Vec3 {
        Vec3::from_array(self.0)
    }
}

impl IcValue for f32 {
    type Gathered = f32;
    #[inline]
    fn from_gathered(g: f32) -> Self {
        g
    }
    #[inline]
    fn to_gathered(self) -> f32 {
        self
    }
}

/// One level of cache: the records, their leak-guard distances and the level's gather settings.
#[derive(Clone, Debug)]
struct Level<V: IcValue> {
    cache: IrradianceCache<V, IcMetric>,
    /// Per record (by id): the nearest hit distance of its whole gather (+∞ if none).
    occluder: Vec<f32>,
    strata: HemisphereStrata,
}

/// A record computed in a construction pass, waiting for [`CacheBuilder::commit`].
#[derive(Clone, Debug)]
pub struct Candidate {
    level: u32,
    record: Record<Rgb>,
    inputs: RadiusInputs,
    occluder: f32,
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
}

/// A point of a construction pass that no record covers, with a cheap prediction of the radius
/// its record will get (a distance-only gather of [`PROBE_M`]×[`PROBE_N`] rays). The renderer
/// selects among a pass's probes ([`CacheBuilder::select`]) before any full gather is paid for,
/// so few full gathers are wasted on candidates that cover each other.
#[derive(Clone, Debug)]
pub struct Probe {
    level: u32,
    x: ShadingPoint,
    spacing: f32,
    key: SampleKey,
    predicted_radius: f32,
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
pub const PROBE_M: u32 = 4;
/// Strata of a probe's distance-only gather along φ.
pub const PROBE_N: u32 = 8;

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
    /// the point (or the ray hits nothing). Level 0 uses the camera ray's first hit, whose pixel
    /// footprint is `spread`·t (`spread`: the pixel's size per unit distance along the ray);
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

    /// The final pass's shading points that no record covered (each gathered for itself).
    fn fallback_gathers(&self) -> u64;

    /// Every level-0 record's position, radius and influence radius (for the debug view).
    fn records_for_display(&self) -> Vec<(Vec3, Vec3, f32)>;
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

        fn fallback_gathers(&self) -> u64 {
            self.core.fallbacks.load(Ordering::Relaxed)
        }

        fn records_for_display(&self) -> Vec<(Vec3, Vec3, f32)> {
            display(&self.core)
        }
    };
}

/// The shared machinery of both cached integrators: levels, gathers, the leak guard.
#[derive(Debug)]
struct Core<V: IcValue> {
    settings: IcSettings,
    levels: Vec<Level<V>>,
    /// The scene's bounding-box diagonal (world units), set by `preprocess`.
    diagonal: f32,
    /// The strata of the final pass's own gathers (where no record covers a shading point): a
    /// quarter of the first level's in each direction, at least 4×8. Its estimate of E is as
    /// unbiased as a record's, only noisier, and it is used for one sample, not interpolated.
    fallback_strata: HemisphereStrata,
    fallbacks: AtomicU64,
}

impl<V: IcValue> Core<V> {
    fn new(settings: IcSettings) -> Result<Self, IcSettingsError> {
        settings.validate()?;
        let levels = (0..settings.levels())
            .map(|l| {
                Ok(Level {
                    cache: IrradianceCache::new(settings.metric_at(l)?),
                    occluder: Vec::new(),
                    strata: settings.strata_at(l)?,
                })
            })
            .collect::<Result<Vec<_>, IcSettingsError>>()?;
        Ok(Self {
            fallback_strata: settings.strata_at(2)?,
            settings,
            levels,
            diagonal: 1.0,
            fallbacks: AtomicU64::new(0),
        })
    }

    fn set_scene(&mut self, scene: &Scene) {
        let (lo, hi) = scene.geometry().bounds();
        let d = (hi - lo).length();
        self.diagonal = if d.is_finite() && d > 0.0 { d } else { 1.0 };
    }

    /// World-space limits of level `level`; level 0 also takes the pixel limits at `spacing`.
    fn limits(&self, level: u32, spacing: f32) -> RadiusLimits {
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

    /// Whether record `id` of `level` may be used at (p, n): the leak guard.
    fn visible(
        &self,
        scene: &Scene,
        level: &Level<V>,
        id: RecordId,
        record: &Record<V>,
        (p, n): (Vec3, Vec3),
        rays: &mut u64,
    ) -> bool {
        if self.settings.leak_guard == LeakGuard::Off {
            return true;
        }
        let o = level.occluder.get(id as usize).copied().unwrap_or(0.0);
        let d = (p - record.position).length();
        if d <= 0.5 * o {
            return true;
        }
        *rays += 1;
        let ray = Ray::spawn_to(record.position, record.normal, p, n);
        !scene.geometry().occluded(&ray)
    }

    /// The interpolated value of `level` at (p, n), leak guard applied.
    fn lookup(
        &self,
        scene: &Scene,
        level: usize,
        p: Vec3,
        n: Vec3,
        rays: &mut RayCounter,
    ) -> Option<V> {
        let l = &self.levels[level];
        let mut guard = 0;
        let v = l
            .cache
            .interpolate_filtered(p, n, |id, r| {
                self.visible(scene, l, id, r, (p, n), &mut guard)
            })
            .map(|i| i.value);
        rays.shadow += guard;
        v
    }

    /// Whether `level` covers (p, n), leak guard applied.
    fn covers(&self, scene: &Scene, level: usize, p: Vec3, n: Vec3, rays: &mut u64) -> bool {
        let l = &self.levels[level];
        l.cache
            .covers_filtered(p, n, |id, r| self.visible(scene, l, id, r, (p, n), rays))
    }

    /// The gather at `x` for `level`: per cell, what its ray brings back and the hit distance.
    /// `values(traced, rays)` gives the cells' values at once (so that it can trace what they
    /// need in batches) for the cells with a ray, in cell order, each as (hit, direction, key),
    /// the hit `None` where the ray escaped; it returns one value per entry. Returns the
    /// samples (with each sample's cos θ) and the gather's frame.
    fn gather(
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
            // Independent numbers per cell. Cell k as sample k of a per-gather Sobol sequence
            // (as a pixel's samples are) stratified the cells' continuations too: on the
            // Cornell box (256², defaults, five seeds) relMSE 0.94× but time 1.11×: a 2D Sobol
            // draw costs several times a hashed one (about 130 instructions against 20).
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
        // nothing here (cache construction, one core, 10⁶-triangle scenes of
        // `docs/make-huge-scene.py`: closed room 1.01×, open heightfield 0.92×).
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
    fn record_from(
        &self,
        level: u32,
        x: &ShadingPoint,
        samples: &GatherSamples<V::Gathered>,
        frame: &Frame,
        spacing: f32,
    ) -> (Record<V>, RadiusInputs, f32) {
        let variant = match self.settings.gradients {
            GradientMode::Off | GradientMode::WardHeckbert => TranslationGradient::WardHeckbert,
            GradientMode::KrivanekGautron => TranslationGradient::KrivanekGautron,
        };
        let g: Gradients<V::Gathered> = samples.gradients(variant).in_world(frame);
        let (translation, rotation) = match self.settings.gradients {
            GradientMode::Off => ([V::zero(); 3], [V::zero(); 3]),
            _ => (
                g.translation.map(V::from_gathered),
                g.rotation.map(V::from_gathered),
            ),
        };
        let record = Record::new(x.position, x.ns, 1.0, V::from_gathered(g.irradiance))
            .with_gradients(translation, rotation);
        let inputs = RadiusInputs {
            distance: samples.harmonic_mean_distance_above(HORIZON_CUT_COS),
            limits: self.limits(level, spacing),
            neighbour_clamping: self.settings.neighbour_clamping,
        };
        (record, inputs, samples.min_distance())
    }

    /// The candidate of `probe` from its gather.
    fn candidate(
        &self,
        probe: &Probe,
        samples: &GatherSamples<V::Gathered>,
        frame: &Frame,
        rays: RayCounter,
    ) -> Candidate {
        let (record, inputs, occluder) =
            self.record_from(probe.level, &probe.x, samples, frame, probe.spacing);
        Candidate {
            level: probe.level,
            record: to_rgb_record(&record),
            inputs,
            occluder,
            rays,
        }
    }

    /// Follows `level` cosine bounces from the camera ray's first hit; the shading point there
    /// and the distance of the last segment (the camera's for level 0).
    fn walk(
        &self,
        scene: &Scene,
        level: u32,
        ray: &Ray,
        key: SampleKey,
        rays: &mut RayCounter,
    ) -> Option<(ShadingPoint, f32)> {
        rays.closest += 1;
        let hit = scene.geometry().intersect(ray)?;
        let surface = scene.geometry().surface(ray, &hit);
        let mut t = (surface.position - ray.origin).length();
        let mut x = ShadingPoint::new(&surface, -ray.direction.normalize());
        for bounce in 0..level {
            let w = Frame::from_normal(x.ns)
                .to_world(sample_cosine_hemisphere(key.uniform_2d(1 + bounce)));
            if w.dot(x.ng) <= 0.0 {
                return None;
            }
            let r = Ray::spawn(x.position, x.ng, w);
            rays.closest += 1;
            let hit = scene.geometry().intersect(&r)?;
            let surface = scene.geometry().surface(&r, &hit);
            t = (surface.position - x.position).length();
            x = ShadingPoint::new(&surface, -w);
        }
        Some((x, t))
    }

    /// See [`CacheBuilder::probe`].
    fn probe(
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
        let covered = self.covers(scene, li, x.position, x.ns, &mut guard);
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

    /// See [`CacheBuilder::select`].
    fn select(&self, probes: Vec<Probe>) -> Vec<Probe> {
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
    fn commit(&mut self, scene: &Scene, candidates: Vec<Candidate>) -> CommitStats {
        let mut stats = CommitStats::default();
        for c in candidates {
            let level = c.level as usize;
            if level >= self.levels.len() {
                stats.refused += 1;
                continue;
            }
            let record = convert_record::<V>(&c.record);
            let mut guard = 0;
            if self.covers(scene, level, record.position, record.normal, &mut guard) {
                stats.dropped += 1;
                stats.dropped_rays += c.rays.total();
                stats.guard_rays += guard;
                continue;
            }
            stats.guard_rays += guard;
            let l = &mut self.levels[level];
            match l.cache.insert_with_radius(record, &c.inputs) {
                Ok((id, _)) => {
                    debug_assert_eq!(id as usize, l.occluder.len());
                    l.occluder.push(c.occluder);
                    stats.inserted += 1;
                }
                Err(InsertError::Full) | Err(_) => stats.refused += 1,
            }
        }
        stats
    }
}

/// A record of `Rgb` (how candidates travel) as a record of `V` (the first channel for a scalar).
fn convert_record<V: IcValue>(r: &Record<Rgb>) -> Record<V> {
    let conv = |v: &Rgb| V::from_fn(|i| v.0[i.min(2)]);
    Record {
        position: r.position,
        normal: r.normal,
        radius: r.radius,
        unclamped_radius: r.unclamped_radius,
        min_radius: r.min_radius,
        value: conv(&r.value),
        translation_gradient: r.translation_gradient.each_ref().map(conv),
        rotation_gradient: r.rotation_gradient.each_ref().map(conv),
    }
}

/// A record of `V` as the `Rgb` record a candidate carries (a scalar in every channel).
fn to_rgb_record<V: IcValue>(r: &Record<V>) -> Record<Rgb> {
    let conv = |v: &V| {
        let c = v.channels();
        Rgb::new(c[0], c[1.min(c.len() - 1)], c[2.min(c.len() - 1)])
    };
    Record {
        position: r.position,
        normal: r.normal,
        radius: r.radius,
        unclamped_radius: r.unclamped_radius,
        min_radius: r.min_radius,
        value: conv(&r.value),
        translation_gradient: r.translation_gradient.each_ref().map(conv),
        rotation_gradient: r.rotation_gradient.each_ref().map(conv),
    }
}

/// Direct light at `x` by next-event estimation alone: the mean of `samples` light samples of
/// f·Le·cos θ / pdf (unbiased: the light sampler reaches every point of every emitting triangle
/// and every punctual light; the background's light is not direct, see the module docs).
pub fn direct_nee(
    scene: &Scene,
    x: &ShadingPoint,
    samples: u32,
    dims: &mut Dimensions,
    rays: &mut RayCounter,
) -> Vec3 {
    let albedo = scene.albedo(x.triangle, x.b1, x.b2);
    if albedo == Vec3::ZERO || scene.lights().is_empty() {
        return Vec3::ZERO;
    }
    let f = albedo * FRAC_1_PI;
    let mut sum = Vec3::ZERO;
    for _ in 0..samples {
        if let Some(nee) = sample_light(scene, x, dims, rays) {
            sum += f * nee.le * (nee.cos_surface / nee.pdf);
        }
    }
    sum / samples as f32
}

/// The irradiance-cache integrator: emission + direct light (NEE) + (ρ/π)·E_ind from the cache.
/// See the module docs for what each part carries and how the cache is built.
#[derive(Debug)]
pub struct IrradianceCacheIntegrator {
    core: Core<Rgb>,
    path: PathTracer,
}

impl IrradianceCacheIntegrator {
    /// An integrator with an empty cache; refuses settings out of range.
    pub fn new(settings: IcSettings) -> Result<Self, IcSettingsError> {
        Ok(Self {
            path: PathTracer::new(settings.path),
            core: Core::new(settings)?,
        })
    }

    /// The settings.
    pub fn settings(&self) -> &IcSettings {
        &self.core.settings
    }

    /// The cache of level `level` (0: the camera's), if it exists.
    pub fn cache(&self, level: usize) -> Option<&IrradianceCache<Rgb, IcMetric>> {
        self.core.levels.get(level).map(|l| &l.cache)
    }

    /// Replaces the first level's cache with `records` (a persistent cache read back), each
    /// with the leak-guard distance given beside it; the deeper levels are emptied.
    pub fn load_records(
        &mut self,
        cache: IrradianceCache<Rgb, IcMetric>,
        occluders: Vec<f32>,
    ) -> Result<(), IcSettingsError> {
        if occluders.len() != cache.len() {
            return Err(setting_error(
                "--cache",
                format!(
                    "{} records but {} leak-guard distances",
                    cache.len(),
                    occluders.len()
                ),
            ));
        }
        if let Some(l) = self.core.levels.first_mut() {
            l.cache = cache;
            l.occluder = occluders;
        }
        Ok(())
    }

    /// The leak-guard distances of the first level's records, by record id.
    pub fn occluder_distances(&self) -> &[f32] {
        self.core.levels.first().map_or(&[], |l| &l.occluder)
    }

    /// The radiance along `ray` split as [`PathTracer::li_split`] splits it: `emitted` (Le of
    /// the first surface x₀), `direct` (NEE at x₀) and `indirect` ((ρ/π)·E_ind(x₀) from the
    /// cache, or from a gather of its own where no record covers x₀: not stored, the final pass
    /// only reads). Each part estimates the same light paths as the path tracer's part of the
    /// same name (module docs).
    pub fn li_split(
        &self,
        scene: &Scene,
        ray: &Ray,
        dims: &mut Dimensions,
        rays: &mut RayCounter,
    ) -> Radiance {
        let (surface, wo, emitted) = match first_surface(scene, ray, rays) {
            Ok(first) => first,
            Err(background) => return background,
        };
        let x = ShadingPoint::new(&surface, wo);
        // Direct light: NEE at x₀.
        let direct = direct_nee(scene, &x, self.core.settings.direct_samples, dims, rays);
        // The cache holds irradiance, so the (textured) albedo of x₀ itself multiplies it,
        // never a record's.
        let albedo = scene.albedo(x.triangle, x.b1, x.b2);
        if albedo == Vec3::ZERO {
            return Radiance {
                emitted,
                direct,
                indirect: Vec3::ZERO,
            };
        }
        let e = match self.core.lookup(scene, 0, x.position, x.ns, rays) {
            Some(e) => e.to_gathered(),
            None => {
                // The fallback gather's own key: a hash of this sample's key and the cursor's
                // position, so it depends only on the sample (the pixel, the index, the seed).
                let key = SampleKey::new(dims.key().bits(dims.position()), FALLBACK_STREAM, 0);
                self.core.fallbacks.fetch_add(1, Ordering::Relaxed);
                self.gather_irradiance(scene, 0, &x, key, rays)
                    .map(|g| g.irradiance())
                    .unwrap_or(Vec3::ZERO)
            }
        };
        Radiance {
            emitted,
            direct,
            indirect: albedo * FRAC_1_PI * e,
        }
    }

    /// What the gather rays of `level` bring back ([`IrradianceCacheIntegrator::gather_radiance`]
    /// for each); where the geometry streams (`Geometry::streams`), path-traced continuations
    /// (`BounceMode::PathTraced`, and on the deepest level) all at once, with
    /// `PathTracer::reflected_many`.
    fn gather_radiances(
        &self,
        scene: &Scene,
        level: usize,
        traced: &[Traced],
        rays: &mut RayCounter,
    ) -> Vec<Vec3> {
        if !(self.path_traced(level) && scene.geometry().streams()) {
            return traced
                .iter()
                .map(|(hit, w, k)| self.gather_radiance(scene, level, hit.as_ref(), *w, *k, rays))
                .collect();
        }
        // The same dimensions `gather_radiance` gives each continuation.
        let (starts, mut dims): (Vec<(SurfacePoint, Vec3)>, Vec<Dimensions>) = traced
            .iter()
            .filter_map(|(hit, w, k)| hit.map(|s| ((s, -*w), Dimensions::starting_at(*k, 1))))
            .unzip();
        let mut reflected = vec![Radiance::default(); starts.len()];
        self.path
            .reflected_many(scene, &starts, &mut dims, &mut reflected, rays);
        let mut reflected = reflected.into_iter();
        traced
            .iter()
            .map(|(hit, _, _)| match hit {
                // (`reflected` has one entry per hit, so `next` always has one here.)
                Some(_) => reflected
                    .next()
                    .map_or(Vec3::ZERO, |r| r.direct + r.indirect),
                // The ray left the scene: the background's light belongs to `indirect`.
                None => scene.background(),
            })
            .collect()
    }

    /// Whether a gather ray of `level` continues as a path-traced path (`BounceMode::PathTraced`,
    /// and on the deepest level) rather than through the next level's cache.
    fn path_traced(&self, level: usize) -> bool {
        self.core.settings.bounce_mode == BounceMode::PathTraced
            || level + 1 >= self.core.levels.len()
    }

    /// What a gather ray of `level` brings back from `hit` travelling against `w`: what the
    /// hit point reflects (its emission excluded), or the background if the ray hit nothing.
    fn gather_radiance(
        &self,
        scene: &Scene,
        level: usize,
        hit: Option<&SurfacePoint>,
        w: Vec3,
        key: SampleKey,
        rays: &mut RayCounter,
    ) -> Vec3 {
        let Some(surface) = hit else {
            // The ray left the scene: the background's light belongs to `indirect`.
            return scene.background();
        };
        let mut dims = Dimensions::starting_at(key, 1);
        if self.path_traced(level) {
            let r = self.path.reflected(scene, surface, -w, &mut dims, rays);
            return r.direct + r.indirect;
        }
        // Cached: NEE at the hit plus its indirect light from the next level's cache; where
        // that cache has no record, a path-traced continuation (unbiased) instead.
        let x = ShadingPoint::new(surface, -w);
        let direct = direct_nee(scene, &x, 1, &mut dims, rays);
        let albedo = scene.albedo(x.triangle, x.b1, x.b2);
        if albedo == Vec3::ZERO {
            return direct;
        }
        match self.core.lookup(scene, level + 1, x.position, x.ns, rays) {
            Some(e) => direct + albedo * FRAC_1_PI * e.to_gathered(),
            None => {
                let r = self.path.reflected(scene, surface, -w, &mut dims, rays);
                direct + r.indirect
            }
        }
    }

    /// E_ind at x for `level` by a gather of its own (the fallback of the final pass).
    fn gather_irradiance(
        &self,
        scene: &Scene,
        level: usize,
        x: &ShadingPoint,
        key: SampleKey,
        rays: &mut RayCounter,
    ) -> Option<GatherSamples<Vec3>> {
        self.core
            .gather(
                scene,
                self.core.fallback_strata,
                x,
                key,
                rays,
                |traced, rays| self.gather_radiances(scene, level, traced, rays),
            )
            .map(|(g, _)| g)
    }
}

impl Integrator for IrradianceCacheIntegrator {
    fn name(&self) -> &'static str {
        "ic"
    }

    fn preprocess(&mut self, scene: &Scene) {
        self.core.set_scene(scene);
    }

    fn li(&self, scene: &Scene, ray: &Ray, dims: &mut Dimensions, rays: &mut RayCounter) -> Vec3 {
        self.li_split(scene, ray, dims, rays).total()
    }

    fn li_split(
        &self,
        scene: &Scene,
        ray: &Ray,
        dims: &mut Dimensions,
        rays: &mut RayCounter,
    ) -> Radiance {
        IrradianceCacheIntegrator::li_split(self, scene, ray, dims, rays)
    }
}

impl CacheBuilder for IrradianceCacheIntegrator {
    fn levels(&self) -> u32 {
        self.core.levels.len() as u32
    }

    fn complete(&self, scene: &Scene, probe: &Probe, rays: &mut RayCounter) -> Option<Candidate> {
        let li = probe.level as usize;
        let mut spent = RayCounter::default();
        let (samples, frame) = self.core.gather(
            scene,
            self.core.levels[li].strata,
            &probe.x,
            probe.key,
            &mut spent,
            |traced, r| self.gather_radiances(scene, li, traced, r),
        )?;
        *rays += spent;
        Some(self.core.candidate(probe, &samples, &frame, spent))
    }

    forward_to_core!();
}

fn display<V: IcValue>(core: &Core<V>) -> Vec<(Vec3, Vec3, f32)> {
    core.levels.first().map_or_else(Vec::new, |l| {
        l.cache
            .records()
            .iter()
            .map(|r| {
                (
                    r.position,
                    r.normal,
                    l.cache.metric().influence_radius(r.radius),
                )
            })
            .collect()
    })
}

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
    /// levels do not apply to AO: the settings' bounce mode is ignored (one level).
    pub fn new(settings: IcSettings, max_distance: f32) -> Result<Self, IcSettingsError> {
        if max_distance.is_nan() || max_distance <= 0.0 {
            return Err(setting_error(
                "--ao-distance",
                format!("must be positive, got {max_distance}"),
            ));
        }
        let settings = IcSettings {
            bounce_mode: BounceMode::PathTraced,
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
        self.core.gather(scene, strata, x, key, rays, |traced, _| {
            let value = |hit: &Option<SurfacePoint>| match hit {
                Some(s) if (s.position - x.position).length() < max => 0.0,
                _ => FRAC_1_PI,
            };
            traced.iter().map(|(hit, _, _)| value(hit)).collect()
        })
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
        let Some(hit) = scene.geometry().intersect(ray) else {
            return Vec3::ZERO;
        };
        let surface = scene.geometry().surface(ray, &hit);
        let x = ShadingPoint::new(&surface, -ray.direction.normalize());
        let a = match self.core.lookup(scene, 0, x.position, x.ns, rays) {
            Some(a) => a,
            None => {
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
    fn levels(&self) -> u32 {
        1
    }

    fn complete(&self, scene: &Scene, probe: &Probe, rays: &mut RayCounter) -> Option<Candidate> {
        let mut spent = RayCounter::default();
        let strata = self.core.levels.first()?.strata;
        let (samples, frame) =
            self.occlusion_gather(scene, strata, &probe.x, probe.key, &mut spent)?;
        *rays += spent;
        Some(self.core.candidate(probe, &samples, &frame, spent))
    }

    forward_to_core!();
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Nonsense settings are refused with an error naming the option.
    #[test]
    fn nonsense_settings_name_the_option() {
        let base = IcSettings::default();
        assert!(base.validate().is_ok());
        let cases: [(IcSettings, &str); 10] = [
            (IcSettings { error: 0.0, ..base }, "--error"),
            (
                IcSettings {
                    error: -1.0,
                    ..base
                },
                "--error",
            ),
            (
                IcSettings {
                    error: f32::NAN,
                    ..base
                },
                "--error",
            ),
            (
                IcSettings {
                    strata_m: 0,
                    ..base
                },
                "--strata",
            ),
            (
                IcSettings {
                    strata_n: 0,
                    ..base
                },
                "--strata",
            ),
            (
                IcSettings {
                    strata_m: 2048,
                    strata_n: 2048,
                    ..base
                },
                "--strata",
            ),
            (
                IcSettings {
                    pixel_min: 5.0,
                    pixel_max: 1.0,
                    ..base
                },
                "--pixel-spacing",
            ),
            (
                IcSettings {
                    world_max: f32::INFINITY,
                    ..base
                },
                "--world-max",
            ),
            (
                IcSettings {
                    world_min: 1.0,
                    world_max: 0.5,
                    ..base
                },
                "--world-min",
            ),
            (
                IcSettings {
                    direct_samples: 0,
                    ..base
                },
                "--direct-samples",
            ),
        ];
        for (s, option) in cases {
            let e = s
                .validate()
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default();
            assert!(e.starts_with(option), "{option}: {e}");
        }
        let cached = IcSettings {
            bounce_mode: BounceMode::Cached,
            cached_bounces: 0,
            ..base
        };
        assert!(cached.validate().is_err());
        assert!(IrradianceCacheIntegrator::new(IcSettings { error: 0.0, ..base }).is_err());
    }

    /// The strata of deeper levels halve per level down to 4×8, and the metric loosens.
    #[test]
    fn levels_loosen() {
        let s = IcSettings {
            bounce_mode: BounceMode::Cached,
            cached_bounces: 3,
            ..IcSettings::default()
        };
        let sizes: Vec<(u32, u32)> = (0..4)
            .map(|l| s.strata_at(l).map(|st| (st.m(), st.n())).unwrap_or((0, 0)))
            .collect();
        assert_eq!(sizes, vec![(12, 48), (6, 24), (4, 12), (4, 8)]);
        match (s.metric_at(0), s.metric_at(2)) {
            (Ok(IcMetric::TabellionLamorlette(a)), Ok(IcMetric::TabellionLamorlette(b))) => {
                assert_eq!((a.kappa(), b.kappa()), (1.0, 0.25));
            }
            other => panic!("{other:?}"),
        }
    }
}
