//! The cache integrators' settings: the metric, the gathers, the radius limits, the bounce mode
//! and the leak guard, each with its range (`IcSettings::validate`).

use super::radius::HORIZON_CUT_COS;
use crate::path::PathSettings;
use irr_cache::{
    ErrorMetric, Hessian, MetricError, PixelRange, RadiusLimits, TabellionLamorlette, Ward,
};
use irr_sampling::HemisphereStrata;
use thiserror::Error;

/// Which weighting the cache uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MetricKind {
    /// Tabellion & Lamorlette 2004; the error parameter is κ (larger is stricter).
    #[default]
    TabellionLamorlette,
    /// Ward et al. 1988; the error parameter is a (smaller is stricter).
    Ward,
    /// Schwarzhaupt et al. 2012 (Radiance ≥ 4.2): elliptical records sized by the irradiance
    /// Hessian of the gather's triangle fan; the error parameter is a (smaller is stricter).
    Hessian,
}

/// The cache's metric as one concrete type, so one cache type serves both.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IcMetric {
    /// See [`TabellionLamorlette`].
    TabellionLamorlette(TabellionLamorlette),
    /// See [`Ward`].
    Ward(Ward),
    /// See [`Hessian`].
    Hessian(Hessian),
}

impl ErrorMetric for IcMetric {
    #[inline]
    fn influence_radius(&self, record_radius: f32) -> f32 {
        match self {
            Self::TabellionLamorlette(m) => m.influence_radius(record_radius),
            Self::Ward(m) => m.influence_radius(record_radius),
            Self::Hessian(m) => m.influence_radius(record_radius),
        }
    }
    #[inline]
    fn weight(&self, candidate: &irr_cache::Candidate) -> f64 {
        match self {
            Self::TabellionLamorlette(m) => m.weight(candidate),
            Self::Ward(m) => m.weight(candidate),
            Self::Hessian(m) => m.weight(candidate),
        }
    }
    fn radius_limits(&self, pixel_spacing: f32) -> RadiusLimits {
        match self {
            Self::TabellionLamorlette(m) => m.radius_limits(pixel_spacing),
            Self::Ward(m) => m.radius_limits(pixel_spacing),
            Self::Hessian(m) => m.radius_limits(pixel_spacing),
        }
    }
    #[inline]
    fn second_order_limit(&self) -> f64 {
        match self {
            Self::Hessian(m) => m.second_order_limit(),
            _ => 0.0,
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
    /// The occlusion-aware gradient of the gather's triangle fan (Schwarzhaupt et al. 2012;
    /// Radiance ≥ 4.2): irr-gradients' `TranslationGradient::OcclusionFan`.
    Fan,
}

/// Which statistic of a gather's hit distances sizes its record (the hits more than 10° above
/// the horizon: cos θ above `HORIZON_CUT_COS`, cos 80°).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RadiusStatistic {
    /// The harmonic mean (Ward et al. 1988; Radiance).
    HarmonicMean,
    /// The minimum (Tabellion & Lamorlette 2004; Mitsuba 0.6): never larger than the harmonic
    /// mean, so records near occluders are smaller and contact shadows sharper. The default
    /// (docs/performance.md, "The record radius statistic").
    #[default]
    Minimum,
}

impl RadiusStatistic {
    /// The statistic of `samples`' hit distances above the horizon cut (+∞ when none hit).
    pub fn of<V: irr_gradients::GatherValue>(
        self,
        samples: &irr_gradients::GatherSamples<V>,
    ) -> f32 {
        match self {
            Self::HarmonicMean => samples.harmonic_mean_distance_above(HORIZON_CUT_COS),
            Self::Minimum => samples.min_distance_above(HORIZON_CUT_COS),
        }
    }
}

/// The smallest light-cache cell, as a fraction of the view's height
/// ([`IcSettings::light_cache_cell`]).
pub const MIN_LIGHT_CACHE_CELL: f32 = 1.0 / 65536.0;

/// What a gather ray brings back from the point it hits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BounceMode {
    /// The hit point's own indirect light by a path-traced continuation (unbiased).
    PathTraced,
    /// The hit point's indirect light from the cache of the next bounce level (Radiance's
    /// `-ab`); the deepest level path-traces the rest. Its gathers are smoother than
    /// path-traced ones (an interpolated value where a path-traced one is a single noisy path).
    Cached,
    /// The hit point's reflected light from the light cache (module `light_cache`): cell means
    /// of the irradiance that camera-launched paths deposit, built before the first pass; a
    /// gather ray costs one closest-hit ray and a hash lookup. Consistent, not unbiased: the
    /// cell's blur shrinks with [`IcSettings::light_cache_cell`]. The default: on the scenes
    /// in assets/ it has less error than `Cached` in less time (docs/performance.md,
    /// "Continuations").
    #[default]
    LightCache,
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

/// Settings of [`IrradianceCacheIntegrator`](super::IrradianceCacheIntegrator) and
/// [`CachedAmbientOcclusion`](super::CachedAmbientOcclusion).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IcSettings {
    /// The metric. Default: Tabellion & Lamorlette.
    pub metric: MetricKind,
    /// The error parameter: κ for Tabellion & Lamorlette (larger is stricter; default 1, range
    /// (0, ∞)), a for Ward (smaller is stricter; typical 0.1–0.3), or a for the Hessian metric
    /// (smaller is stricter; range (0, ∞), records used within a times their radii
    /// √L·(4/|λ|)^¼, L the image's height at the record's distance; 0.5–0.85 matches κ = 1's
    /// record count on the scenes in assets/).
    pub error: f32,
    /// M, strata along θ of a first-level gather. Default: 16. Range: ≥ 1 (M·N ≤ 2²⁰).
    ///
    /// The defaults (κ = 1, 16×64, the light cache, 2 light samples, with 36 camera samples
    /// per pixel in the `irr` command) were chosen by measurement on the Cornell box and the
    /// indirect-lit room at 256²: see docs/performance.md, "The cache's defaults".
    pub strata_m: u32,
    /// N, strata along φ. Default: 64. Range: ≥ 1.
    pub strata_n: u32,
    /// Smallest record radius scale on screen, in pixels (see irr-cache's `PixelRange`).
    /// Default: 1.5. Range: (0, `pixel_max`].
    pub pixel_min: f32,
    /// Largest record radius scale on screen, in pixels. Default: 10. Range: ≥ `pixel_min`.
    pub pixel_max: f32,
    /// Smallest influence radius of a record on screen, in pixels: records are never denser
    /// than that, so the construction's repair passes, which probe a fraction of a pixel apart,
    /// cover every point the final pass's samples land on (at high κ, or Ward's a ≤ 0.1, the
    /// pixel limits alone allow records far smaller than a pixel). Default: 1.25 (see
    /// docs/performance.md, "Covering what the final pass asks"). Range: [0, ∞); 0 turns it
    /// off.
    pub influence_floor: f32,
    /// Largest record radius in world units, as a fraction of the view's image height at the
    /// record's distance (`CacheBuilder::set_view`; of the scene's bounding-box diagonal without
    /// a view), widened on a surface seen at a slant as the pixel limits are; also the radius
    /// of a record whose gather hit nothing unless the pixel limits bound it. Default: 0.25.
    /// Range: (0, ∞).
    pub world_max: f32,
    /// Smallest record radius in world units, as the same fraction as `world_max`: bounds the
    /// number of records near contact edges. Default: 1e-4. Range: [0, `world_max`].
    pub world_min: f32,
    /// The translation gradient. Default: Ward & Heckbert.
    pub gradients: GradientMode,
    /// The statistic of a gather's hit distances that sizes its record. Default: the minimum.
    pub radius_statistic: RadiusStatistic,
    /// Neighbour clamping (Křivánek et al. 2006). Default: on.
    pub neighbour_clamping: bool,
    /// The leak guard. Default: visibility.
    pub leak_guard: LeakGuard,
    /// What a gather ray brings back. Default: the light cache.
    pub bounce_mode: BounceMode,
    /// With [`BounceMode::Cached`]: how many cache levels below the first (≥ 1). Default: 1.
    pub cached_bounces: u32,
    /// With [`BounceMode::Cached`]: each deeper level's error parameter is loosened by this
    /// factor (κ divided, a multiplied) and its strata halved in each direction (at least 4×8),
    /// as Radiance loosens its accuracy per bounce. Default: 2. Range: ≥ 1.
    pub level_loosening: f32,
    /// Light samples (NEE) per camera hit for the direct light. Default: 2. Range: ≥ 1.
    pub direct_samples: u32,
    /// BSDF samples per camera hit for a glossy lobe that is path-traced (the light the cache's
    /// ρ_d/π·E leaves out) where that lobe carries all of the surface's reflection (a metal);
    /// a lobe carrying the share p of its albedo takes ⌈p²·this⌉ (one on a rough white
    /// dielectric unless seen at a grazing angle), with radiance records or without. Averaged: each costs one ray and a light-cache lookup, a fraction of a
    /// camera sample, whose shading, records and direct light they share; the direct light's
    /// MIS weighs the light samples against all of them. Default: 8: on a
    /// rough metal floor 2.9× less error than one at equal time, on the glossy room a tie
    /// (docs/performance.md, "Glossy lobes: more samples per camera sample"). Range:
    /// 1..=[`MAX_GLOSSY_SAMPLES`].
    pub glossy_samples: u32,
    /// Adaptive super-sampling of a record's gather: the target relative standard error of its
    /// irradiance, as estimated from its strata (irr-gradients' `GatherSamples::relative_error`).
    /// A gather above it spends more rays on its noisiest strata (`plan_extra_samples`), at
    /// most `gather_budget` times its strata in all. Deeper levels loosen it by
    /// `level_loosening` per level, as κ. 0: off (one ray per stratum). Default: 0.05, the
    /// error a user asks for, with the strata as the first pass and `gather_budget` as the
    /// bound (docs/performance.md, "Continuations"). Range: [0, ∞).
    pub gather_error: f32,
    /// Adaptive camera sampling in the final pass ([`crate::Integrator::pixel_error`]): a
    /// pixel stops taking samples once the relative standard error of its mean luminance,
    /// estimated from its own samples after a quarter, a half, … of the samples per pixel, is
    /// at most this. Where the cache supplies the light a pixel's samples barely differ, so
    /// they stop at the first check; samples go to the direct light's noise and to edges.
    /// 0: every pixel takes all its samples. Default: 0.01: in the indirect-lit room the same
    /// error in 14 % less time, on the Cornell box and the textured room a tie (docs/
    /// performance.md, "Adaptive camera samples"). Range: [0, ∞).
    pub pixel_error: f32,
    /// The most extra rays of a super-sampled gather, as a multiple of its strata (M·N).
    /// Default: 3. Range: [0, 64].
    pub gather_budget: f32,
    /// With [`BounceMode::LightCache`]: the most camera-launched paths that fill the light
    /// cache. Default: 5·2¹⁷ = 655360, the indirect-lit room's most efficient (docs/
    /// performance.md, "The light cache's paths, again"); scenes whose cells reach
    /// `light_cache_error` first stop before it. Range: 1 to 2²². The cache's memory is bounded
    /// whatever the paths: at most `light_cache::MAX_CELLS` cells in 516 MiB
    /// (`light_cache::TABLE_BYTES`); deposits in new cells past that are dropped and counted,
    /// and reads there path-trace.
    pub light_cache_paths: u32,
    /// With [`BounceMode::LightCache`]: the light cache's target, the relative standard error
    /// of its cells' means (`LightCache::relative_error`). Paths are added in chunks of 2¹⁴
    /// until the cells reach it and hold nearly all deposits (`LightCache::converged`), or
    /// `light_cache_paths` are spent. 0: always spend them. Default: 0.12. Range: [0, ∞).
    pub light_cache_error: f32,
    /// With [`BounceMode::LightCache`]: the width of the light cache's cells, as a fraction of
    /// the view's image height at the cell's distance, rounded to the nearest power of two
    /// (`CacheBuilder::set_view`; without a view, of the scene's bounding-box diagonal);
    /// smaller is sharper and needs more paths. Default: 1/48, which gives the scenes in
    /// assets/ (seen from 0.8 to 1.5 m through a 39° lens) cells of 2⁻⁶ m, within 4 % of the
    /// 1/64 of their diagonal their settings were measured with. Range: [2⁻¹⁶, 1].
    pub light_cache_cell: f32,
    /// Construction also probes every camera sample's own hit (not only the repair passes'
    /// lattice), so the final pass almost never gathers for itself, at the cost of a probe per
    /// sample. Default: off.
    pub fill_samples: bool,
    /// Radiance caching (Křivánek et al. 2005) for glossy lobes: the order n of the real
    /// spherical harmonics (n² coefficients per colour) in which each first-level record on a
    /// material whose lobe they take (a rough metal, module `radiance`) also stores the
    /// cosine-weighted incoming radiance of its gather. 0 (the default): off (every glossy lobe
    /// path-traced by [`IcSettings::glossy_samples`]' BSDF samples per camera sample; on a
    /// curved textured metal, records at order 10 cost 25 % more time for no gain:
    /// docs/performance.md, "Radiance caching"). Range: 0..=[`MAX_RADIANCE_ORDER`].
    pub radiance_order: u32,
    /// With radiance caching: a glossy shading point uses the records only where its lobe's
    /// relative L2 reconstruction error in the basis (irr-bsdf's `ResidualTable`, by
    /// roughness and view angle) is at most this; elsewhere the lobe is path-traced. Range:
    /// (0, 1].
    pub radiance_error: f32,
    /// With radiance caching: the coefficients of the first this many bands (this² of them)
    /// also get their translation gradients (the irradiance's walls, `--gradients`' variant),
    /// by which lookups extrapolate them, scaled by the irradiance record's gradient cap.
    /// 0 (the default): none; `radiance_order`: every coefficient. Range:
    /// 0..=`radiance_order` (docs/performance.md, "Radiance caching": on a rough metal floor
    /// they add error and move the glossy light's bias up, past zero at the tightest κ).
    pub radiance_gradients: u32,
    /// With the Hessian metric: extrapolate each record's irradiance to second order by its
    /// curvature (the tangent-plane eigenvalues of its relative Hessian; Jarosz et al. 2012),
    /// the relative correction ½ Δᵀ(H/E)Δ clamped into [−this, this]. 0 (the default): first
    /// order. Range: [0, 1], and 0 with the other metrics, whose records have no Hessian.
    pub second_order: f32,
    /// The path tracer of continuations and of the fallback.
    pub path: PathSettings,
}

/// The most BSDF samples per camera hit for a path-traced glossy lobe
/// ([`IcSettings::glossy_samples`]), a bound on the loop a user's option sizes.
pub const MAX_GLOSSY_SAMPLES: u32 = 256;

/// The highest order of radiance records (100 coefficients per colour).
pub const MAX_RADIANCE_ORDER: u32 = 10;

impl Default for IcSettings {
    fn default() -> Self {
        Self {
            metric: MetricKind::TabellionLamorlette,
            error: 1.0,
            strata_m: 16,
            strata_n: 64,
            pixel_min: 1.5,
            pixel_max: 10.0,
            influence_floor: 1.25,
            world_max: 0.25,
            world_min: 1e-4,
            gradients: GradientMode::WardHeckbert,
            radius_statistic: RadiusStatistic::Minimum,
            neighbour_clamping: true,
            leak_guard: LeakGuard::Visibility,
            bounce_mode: BounceMode::LightCache,
            cached_bounces: 1,
            level_loosening: 2.0,
            direct_samples: 2,
            glossy_samples: 8,
            gather_error: 0.05,
            pixel_error: 0.01,
            gather_budget: 3.0,
            light_cache_paths: 5 << 17,
            light_cache_error: 0.12,
            light_cache_cell: 1.0 / 48.0,
            fill_samples: false,
            radiance_order: 0,
            radiance_error: 0.1,
            radiance_gradients: 0,
            second_order: 0.0,
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

pub(super) fn setting_error(option: &'static str, problem: impl Into<String>) -> IcSettingsError {
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
        if !(self.influence_floor.is_finite() && self.influence_floor >= 0.0) {
            return Err(setting_error(
                "--influence-floor",
                format!(
                    "must be finite and non-negative, got {}",
                    self.influence_floor
                ),
            ));
        }
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
        if self.radiance_order > MAX_RADIANCE_ORDER {
            return Err(setting_error(
                "--radiance-order",
                format!(
                    "must lie in 0..={MAX_RADIANCE_ORDER} (0: off), got {}",
                    self.radiance_order
                ),
            ));
        }
        if !(self.radiance_error > 0.0 && self.radiance_error <= 1.0) {
            return Err(setting_error(
                "--radiance-error",
                format!("must lie in (0, 1], got {}", self.radiance_error),
            ));
        }
        if self.radiance_gradients > self.radiance_order {
            return Err(setting_error(
                "--radiance-gradients",
                format!(
                    "must lie in 0..=--radiance-order ({}), got {}",
                    self.radiance_order, self.radiance_gradients
                ),
            ));
        }
        if !(0.0..=1.0).contains(&self.second_order) {
            return Err(setting_error(
                "--second-order",
                format!("must lie in [0, 1], got {}", self.second_order),
            ));
        }
        if self.second_order > 0.0 && self.metric != MetricKind::Hessian {
            return Err(setting_error(
                "--second-order",
                "needs --metric hessian (only Hessian records have a curvature)",
            ));
        }
        if self.direct_samples == 0 {
            return Err(setting_error("--direct-samples", "must be at least 1"));
        }
        if !(1..=MAX_GLOSSY_SAMPLES).contains(&self.glossy_samples) {
            return Err(setting_error(
                "--glossy-samples",
                format!(
                    "must lie in 1..={MAX_GLOSSY_SAMPLES}, got {}",
                    self.glossy_samples
                ),
            ));
        }
        if !(self.gather_error.is_finite() && self.gather_error >= 0.0) {
            return Err(setting_error(
                "--gather-error",
                format!("must be finite and non-negative, got {}", self.gather_error),
            ));
        }
        if !(self.pixel_error.is_finite() && self.pixel_error >= 0.0) {
            return Err(setting_error(
                "--pixel-error",
                format!("must be finite and non-negative, got {}", self.pixel_error),
            ));
        }
        if !(0.0..=64.0).contains(&self.gather_budget) {
            return Err(setting_error(
                "--gather-budget",
                format!("must lie in [0, 64], got {}", self.gather_budget),
            ));
        }
        if !(1..=1 << 22).contains(&self.light_cache_paths) {
            return Err(setting_error(
                "--light-cache-paths",
                format!("must lie in 1..=4194304, got {}", self.light_cache_paths),
            ));
        }
        if !(self.light_cache_error.is_finite() && self.light_cache_error >= 0.0) {
            return Err(setting_error(
                "--light-cache-error",
                format!(
                    "must be finite and non-negative, got {}",
                    self.light_cache_error
                ),
            ));
        }
        if !(MIN_LIGHT_CACHE_CELL..=1.0).contains(&self.light_cache_cell) {
            return Err(setting_error(
                "--light-cache-cell",
                format!(
                    "must lie in [2^-16, 1] (a fraction of the view's height), got {}",
                    self.light_cache_cell
                ),
            ));
        }
        Ok(())
    }

    /// The number of cache levels: 1, plus `cached_bounces` in cached mode, and at most
    /// `path.max_depth` − 1. Level k holds light that reflected at least k + 2 times before
    /// reaching the camera, so a depth below 2 needs no cache at all.
    pub fn levels(&self) -> u32 {
        let wanted = match self.bounce_mode {
            BounceMode::PathTraced | BounceMode::LightCache => 1,
            BounceMode::Cached => 1 + self.cached_bounces,
        };
        wanted.min(self.path.max_depth.saturating_sub(1))
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
            MetricKind::Hessian => IcMetric::Hessian(
                Hessian::new(self.error * loosen)
                    .map_err(bad)?
                    .with_pixel_range(pixels)
                    .with_second_order(self.second_order)
                    .map_err(|e| setting_error("--second-order", e.to_string()))?,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ic::IrradianceCacheIntegrator;

    /// Nonsense settings are refused with an error naming the option.
    #[test]
    fn nonsense_settings_name_the_option() {
        let base = IcSettings::default();
        assert!(base.validate().is_ok());
        let cases: [(IcSettings, &str); 21] = [
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
                    glossy_samples: 0,
                    ..base
                },
                "--glossy-samples",
            ),
            (
                IcSettings {
                    glossy_samples: MAX_GLOSSY_SAMPLES + 1,
                    ..base
                },
                "--glossy-samples",
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
            (
                IcSettings {
                    gather_error: -0.1,
                    ..base
                },
                "--gather-error",
            ),
            (
                IcSettings {
                    gather_error: f32::NAN,
                    ..base
                },
                "--gather-error",
            ),
            (
                IcSettings {
                    gather_budget: 65.0,
                    ..base
                },
                "--gather-budget",
            ),
            (
                IcSettings {
                    radiance_order: MAX_RADIANCE_ORDER + 1,
                    ..base
                },
                "--radiance-order",
            ),
            (
                IcSettings {
                    radiance_error: 0.0,
                    ..base
                },
                "--radiance-error",
            ),
            (
                IcSettings {
                    radiance_error: f32::NAN,
                    ..base
                },
                "--radiance-error",
            ),
            (
                IcSettings {
                    radiance_order: 4,
                    radiance_gradients: 5,
                    ..base
                },
                "--radiance-gradients",
            ),
            (
                IcSettings {
                    second_order: 0.25,
                    ..base
                },
                "--second-order",
            ),
            (
                IcSettings {
                    metric: MetricKind::Hessian,
                    second_order: 1.5,
                    ..base
                },
                "--second-order",
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
        assert_eq!(sizes, vec![(16, 64), (8, 32), (4, 16), (4, 8)]);
        match (s.metric_at(0), s.metric_at(2)) {
            (Ok(IcMetric::TabellionLamorlette(a)), Ok(IcMetric::TabellionLamorlette(b))) => {
                assert_eq!((a.kappa(), b.kappa()), (1.0, 0.25));
            }
            other => panic!("{other:?}"),
        }
    }
}
