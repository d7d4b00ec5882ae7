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
//!   `L D E`. On a Lambertian x₀ NEE alone covers every such path (the light sampler reaches
//!   every point of every emitting triangle, and every punctual light), so no BSDF-sampled
//!   emitter hit is needed; on a glossy one the BSDF sample of "Glossy surfaces" joins it by
//!   multiple importance sampling;
//! - `indirect`: (ρ(x₀)/π)·E_ind(x₀), paths `L D D+ E` and `L D+ B`, with E_ind interpolated
//!   from the cache (on a glossy x₀, see "Glossy surfaces" below). **The background's light that reflects is here**, as in the path tracer:
//!   the cache stores the irradiance due to the background as well as to reflected light
//!   (Radiance, likewise, computes its sky's diffuse light in the ambient calculation), so a
//!   gather ray that leaves the scene brings back B.
//!
//!
//! # Glossy surfaces
//! The cache holds irradiance, which stands exactly for a Lambertian surface's reflection only.
//! On a glossy x₀ (the glTF metallic-roughness model, module `bsdf`) the cache supplies
//! ρ_d/π·E_ind with ρ_d the diffuse lobe's directional albedo (irr-bsdf's `diffuse_albedo`,
//! exact under uniform light), and ⌈p²·K⌉ samples of x₀'s BSDF per camera sample supply the rest
//! (`IcSettings::glossy_samples` = K, p the residual's share of the albedo, `lobe_samples`;
//! sub-samples of the camera sample's, stratified together, `SampleKey::subsample`):
//! the light each ray's hit reflects, brought back as a level-0 gather ray brings it (from the
//! light cache by default: its cells filtered by a box two cells wide, and a glossy hit's own
//! residual continued through the cache, `gather_radiance`'s `lobe` read), weighted by the
//! residual f − ρ_d/π (which holds the glossy lobe and
//! the diffuse lobe's departure from its stand-in, and may be negative), so that the two
//! together estimate ∫ f L_ind cos and the image converges to the path tracer's (with the
//! light cache, as its cells shrink). The same samples' emitter hits join the direct light by
//! multiple importance sampling against the light samples (with both sample counts). A gather
//! ray that hits a glossy surface takes ρ_d/π·Ē from the light cache (which glossy vertices
//! fill too) and, with the probability
//! `Bsdf::residual_probability` (weighted by its inverse), one path-traced sample of the same
//! residual (`residual`); with the other bounce modes it path-traces the hit's light with the
//! whole BSDF.
//!
//! # Normal textures
//! A record, its gather's hemisphere and its lookups use the shading normal the normal texture
//! gives (`Scene::shading_point`), as Radiance and Mitsuba 0.6 do: the cache then stays
//! consistent with the path tracer, at the price of records as close as the normal texture's
//! variation asks where it tilts the normal quickly. (Records on the unperturbed normal, carried
//! to the textured one by the rotation gradient, would be cheaper but keep a bias of second order
//! in the tilt that no error parameter removes.)
//!
//! # Hessian records
//! With [`MetricKind::Hessian`] (`--metric hessian`) a record is an ellipse on its tangent plane
//! (Schwarzhaupt, Jensen & Jarosz 2012; Radiance ≥ 4.2): its gather keeps each ray's direction,
//! irr-gradients' triangle fan over the hit points gives the relative irradiance Hessian, and
//! its tangent block's eigenvalues λ give the radii √L·(4/|λ|)^¼ (L the image's height at the
//! record's distance, or the scene's diagonal without a view: the radii stay lengths, so the
//! image does not depend on the unit), the minor one along the direction of fastest curvature
//! and at least half the major. The same fan gives the
//! occlusion-aware translation gradient. The radius pipeline (gradient limit, pixel and world
//! limits, neighbour clamping) acts on the major radius; the metric uses a record within the
//! ellipse scaled by the accuracy a (`irr_cache::Hessian`). Records are placed where the
//! irradiance curves, not where geometry is near: large on open walls, small at contact
//! shadows and light boundaries.
//!
//! A record's gather at x traces one cosine-distributed ray per cell of an M×N
//! [`HemisphereStrata`](irr_sampling::HemisphereStrata); the radiance a ray brings back from the point x₁ it hits is what x₁
//! *reflects* towards x (its emission excluded: that is x's `direct`): (ρ(x₁)/π) times the
//! irradiance of x₁'s cell in the light cache ([`BounceMode::LightCache`], the default; module
//! `light_cache`), or NEE at x₁ plus x₁'s own indirect part, either path-traced
//! ([`BounceMode::PathTraced`], `PathTracer::reflected`) or looked up in the cache of the next
//! bounce level ([`BounceMode::Cached`], Radiance's `-ab`).
//! A ray that hits nothing brings back the background B. Punctual lights reach the gathers
//! through the NEE at x₁ (`sample_light`, shared with the path tracer).
//! The deepest cached level's gathers always path-trace the rest, and a light-cache cell too
//! sparse to be read is path-traced through, so no bounce is cut off and the image converges to
//! the path tracer's as the error parameter (and the light cache's cell) tightens.
//!
//! Files: `settings` (the options), `builder` (the interface construction runs through),
//! `light_cache` (the continuations' light cache),
//! `levels` (the cache levels, walks, selection, commits), `gather` (a record's hemisphere
//! gather), `radius` (limits and predicted radii), `lookup` and `guard` (interpolation and the
//! leak guard), `value` (the cached value types), `ao` (cached ambient occlusion).

pub use ao::CachedAmbientOcclusion;
pub use builder::{CacheBuilder, Candidate, CommitStats, DisplayRecord, FinalPassMisses, Probe};
pub use guard::GuardRecord;
pub use light_cache::{
    CELL_BYTES, CONVERGED_SHARE, CacheView, DEEPER_READS, FILTER_CELLS, LightCache,
    LightCacheCounts, LightDeposit, LightPathTracer, MAX_CELLS, MIN_DEPOSITS, SIDES_APART,
    TABLE_BYTES,
};
pub use radius::surface_spacing;
pub use settings::{
    BounceMode, GradientMode, IcMetric, IcSettings, IcSettingsError, LeakGuard, MAX_GLOSSY_SAMPLES,
    MAX_RADIANCE_ORDER, MetricKind, RadiusStatistic,
};
pub use value::IcValue;

use crate::bsdf::Bsdf;
use crate::integrator::{Batching, FirstHit, Integrator, RayCounter};
use crate::path::{
    PathSettings, PathTracer, Radiance, ShadingPoint, emission_weight, power_heuristic,
    sample_light,
};
use crate::scene::Scene;
use builder::forward_to_core;
use gather::Traced;
use glam::{Vec2, Vec3};
use guard::Query;
use irr_cache::{IrradianceCache, Rgb};
use irr_gather_record::GatheredValue;
use irr_geometry::{Ray, SurfacePoint};
use irr_gradients::TranslationGradient;
use irr_sampling::SampleKey;
use irr_sampling::rng::Dimensions;
use levels::{Core, display};
use radiance::glossy_radius_scale;
use settings::setting_error;
use std::f32::consts::FRAC_1_PI;
use std::sync::atomic::Ordering;

mod ao;
mod builder;
mod gather;
mod guard;
mod levels;
mod light_cache;
mod lookup;
mod pixel;
mod radiance;
mod radius;
mod settings;
mod value;

/// One level of a cache read back ([`IrradianceCacheIntegrator::load_levels`]): the records and,
/// by record id, what the leak guard keeps of each.
#[derive(Clone, Debug)]
pub struct CachedLevel {
    /// The records.
    pub cache: IrradianceCache<Rgb, IcMetric>,
    /// The leak guard's data, one entry per record.
    pub guard: Vec<GuardRecord>,
    /// The estimated relative standard error of each record's irradiance, one per record.
    pub noise: Vec<f32>,
}

/// The stream of the final pass's own gathers (see `SampleKey::new`).
const FALLBACK_STREAM: u64 = 0x1c_fa11;

/// The stream of the keys of a glossy x₀'s BSDF-sample continuations (`glossy_sample`).
const GLOSSY_STREAM: u64 = 0x6c_0551;

/// A lobe sample's read of the light cache (`gather_radiance`'s `lobe`), drawn from `dims`: the
/// filter's point in the unit square (stratified with the lobe's other samples where `dims` is
/// a pixel's) and a key of its own, `index` telling the camera hit's read (0) from a glossy
/// hit's residual's (1).
fn lobe_read(dims: &mut Dimensions, index: u64) -> (SampleKey, Option<Vec2>) {
    let filter = dims.next_2d();
    let key = SampleKey::new(dims.key().bits(dims.position()), GLOSSY_STREAM, index);
    dims.next_1d();
    (key, Some(filter))
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
    direct_light(scene, x, &Bsdf::at(scene, x), samples, 0, dims, rays)
}

/// [`direct_nee`] for the BSDF `bsdf` at `x`. With `bsdf_samples` = m > 0, each light sample of
/// an emitting triangle is weighted by the power heuristic against the m BSDF samples (Veach
/// 1997, eq. 9.13 with sample counts: w = (n·p_light)² / ((n·p_light)² + (m·p_bsdf)²) for n
/// light samples), and the caller adds each BSDF sample's emitter hit with the complementary
/// weight ([`IrradianceCacheIntegrator::glossy_lobe`]); with 0, no weighting.
fn direct_light(
    scene: &Scene,
    x: &ShadingPoint,
    bsdf: &Bsdf,
    samples: u32,
    bsdf_samples: u32,
    dims: &mut Dimensions,
    rays: &mut RayCounter,
) -> Vec3 {
    if bsdf.is_black() || scene.lights().is_empty() {
        return Vec3::ZERO;
    }
    let mut sum = Vec3::ZERO;
    for _ in 0..samples {
        if let Some(nee) = sample_light(scene, x, dims, rays) {
            let w = if bsdf_samples > 0 && !nee.delta {
                let n_pdf = samples as f32 * nee.pdf;
                power_heuristic(n_pdf, bsdf_samples as f32 * bsdf.pdf(nee.wi))
            } else {
                1.0
            };
            sum += bsdf.eval(nee.wi) * nee.le * (nee.cos_surface * w / nee.pdf);
        }
    }
    sum / samples as f32
}

/// The irradiance-cache integrator: emission + direct light (NEE) + (ρ/π)·E_ind from the cache.
/// See the module docs for what each part carries and how the cache is built.
#[derive(Debug)]
pub struct IrradianceCacheIntegrator {
    core: Core<Rgb>,
    /// With `BounceMode::LightCache`, the continuations' cache (empty until the renderer fills
    /// it through [`CacheBuilder::add_light_paths`]).
    light: LightCache,
}

impl IrradianceCacheIntegrator {
    /// An empty light cache for the view (`CacheBuilder::set_view`) or, without one, of cells
    /// a fraction of the scene's diagonal.
    fn empty_light_cache(&self) -> LightCache {
        let fraction = self.core.settings.light_cache_cell;
        match self.core.view {
            Some(view) => LightCache::for_view(view, fraction),
            None => LightCache::new(self.core.diagonal * fraction),
        }
    }

    /// An integrator with an empty cache; refuses settings out of range.
    pub fn new(settings: IcSettings) -> Result<Self, IcSettingsError> {
        Ok(Self {
            core: Core::new(settings)?,
            light: LightCache::new(1.0),
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

    /// Replaces every level's cache with `levels` (a persistent cache read back), deepest last,
    /// each record with the leak guard's data given beside it (by record id). Refused, and
    /// nothing changed, unless there is one per level and one guard entry per record.
    pub fn load_levels(&mut self, levels: Vec<CachedLevel>) -> Result<(), IcSettingsError> {
        if levels.len() != self.core.levels.len() {
            return Err(setting_error(
                "--cache",
                format!(
                    "{} cache levels, but these settings have {}",
                    levels.len(),
                    self.core.levels.len()
                ),
            ));
        }
        if let Some((i, l)) = levels
            .iter()
            .enumerate()
            .find(|(_, l)| l.guard.len() != l.cache.len() || l.noise.len() != l.cache.len())
        {
            return Err(setting_error(
                "--cache",
                format!(
                    "level {i}: {} records but {} leak-guard and {} noise entries",
                    l.cache.len(),
                    l.guard.len(),
                    l.noise.len()
                ),
            ));
        }
        for (level, read) in self.core.levels.iter_mut().zip(levels) {
            level.cache = read.cache;
            level.guard = read.guard;
            level.noise = read.noise;
        }
        Ok(())
    }

    /// What the leak guard keeps of level `level`'s records, by record id (empty for a level
    /// the integrator does not have).
    pub fn guard_records(&self, level: usize) -> &[GuardRecord] {
        self.core.levels.get(level).map_or(&[], |l| &l.guard)
    }

    /// The radiance along `ray` split as [`PathTracer::li_split`] splits it: `emitted` (Le of
    /// the first surface x₀), `direct` (NEE at x₀) and `indirect` ((ρ/π)·E_ind(x₀) from the
    /// cache, or from a gather of its own where no record covers x₀: not stored, the final pass
    /// only reads). Each part estimates the same light paths as the path tracer's part of the
    /// same name (module docs). One sample alone, as a pixel of one sample (the renderer hands
    /// the integrator a pixel's samples together: `li_split_many`, module `pixel`).
    pub fn li_split(
        &self,
        scene: &Scene,
        ray: &Ray,
        dims: &mut Dimensions,
        rays: &mut RayCounter,
    ) -> Radiance {
        let mut out = [Radiance::default()];
        self.li_split_pixel(
            scene,
            std::slice::from_ref(ray),
            std::slice::from_mut(dims),
            &mut out,
            None,
            rays,
        );
        out[0]
    }

    /// What the gather rays of `level` bring back ([`IrradianceCacheIntegrator::gather_radiance`]
    /// for each); where the geometry streams (`Geometry::streams`) and every continuation is
    /// path-traced (`path_traced`), all at once, with `PathTracer::reflected_many`.
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
                .map(|(hit, w, k)| {
                    self.gather_radiance(scene, level, hit.as_ref(), *w, (*k, None), rays)
                })
                .collect();
        }
        // The same dimensions `gather_radiance` gives each continuation.
        let (starts, mut dims): (Vec<(SurfacePoint, Vec3)>, Vec<Dimensions>) = traced
            .iter()
            .filter_map(|(hit, w, k)| hit.map(|s| ((s, -*w), Dimensions::starting_at(*k, 1))))
            .unzip();
        let mut reflected = vec![Radiance::default(); starts.len()];
        self.continuation(level)
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

    /// The path tracer of `level`'s continuations. What a gather ray of level k brings back from
    /// the point x_{k+1} it hits is light reflected there and before: the (k + 2)-th reflection
    /// from the camera on, so its path may reflect at most `max_depth` − (k + 1) times.
    fn continuation(&self, level: usize) -> PathTracer {
        let path = self.core.settings.path;
        PathTracer::new(PathSettings {
            max_depth: path.max_depth.saturating_sub(level as u32 + 1),
            ..path
        })
    }

    /// Whether every gather ray of `level` continues as a path-traced path
    /// (`BounceMode::PathTraced`; the deepest level of `BounceMode::Cached`; and
    /// `BounceMode::LightCache` while its light cache is empty) rather than through a cache.
    fn path_traced(&self, level: usize) -> bool {
        match self.core.settings.bounce_mode {
            BounceMode::PathTraced => true,
            BounceMode::LightCache => self.light.is_empty(),
            BounceMode::Cached => level + 1 >= self.core.levels.len(),
        }
    }

    /// What a gather ray of `level` brings back from `hit` travelling against `w`: what the
    /// hit point reflects (its emission excluded), or the background if the ray hit nothing.
    /// With `lobe` (a camera hit's lobe sample, and the point of the unit square it draws for
    /// the read) the light cache is read filtered (`LightCache::irradiance_filtered`), and a
    /// glossy hit's residual goes on through the light cache (`residual`): a lobe's samples
    /// gather near a few points, where one cell's frozen noise, or one path, would show.
    fn gather_radiance(
        &self,
        scene: &Scene,
        level: usize,
        hit: Option<&SurfacePoint>,
        w: Vec3,
        (key, lobe): (SampleKey, Option<Vec2>),
        rays: &mut RayCounter,
    ) -> Vec3 {
        let Some(surface) = hit else {
            // The ray left the scene: the background's light belongs to `indirect`.
            return scene.background();
        };
        let mut dims = Dimensions::starting_at(key, 1);
        let x = scene.shading_point(surface, -w);
        // The caches hold irradiance, which stands for a Lambertian surface's reflection only:
        // a glossy hit takes the diffuse lobe's share from the light cache and samples the rest
        // (below); with the other bounce modes its light is path-traced with its whole BSDF.
        let material = scene.material_of(x.triangle);
        let lambertian = material.is_lambertian();
        let albedo = scene.albedo(x.triangle, x.b1, x.b2);
        // Light cache: what the hit reflects is (ρ/π)·E from its cell, direct light included.
        // Where the cell is too sparse, the path-traced continuation below.
        if self.core.settings.bounce_mode == BounceMode::LightCache {
            if lambertian && albedo == Vec3::ZERO {
                return Vec3::ZERO;
            }
            let read = match lobe {
                // `level` reflections deeper than a gather ray's hit (`residual`).
                Some(u) => self.light.irradiance_filtered(scene, &x, u, level, rays),
                None => self.light.irradiance(scene, &x, rays),
            };
            if let Some(e) = read {
                if lambertian {
                    return albedo * FRAC_1_PI * e;
                }
                // A glossy hit: the diffuse lobe's share from the cell, and the rest of its
                // BSDF path-traced with probability p, weighted by 1/p (unbiased).
                let bsdf = Bsdf::at(scene, &x);
                let shared = bsdf.diffuse_reflectance() * FRAC_1_PI * e;
                let p = bsdf.residual_probability();
                if dims.next_1d() >= p {
                    return shared;
                }
                let residual =
                    self.residual(scene, level, (&x, &bsdf), lobe.is_some(), &mut dims, rays);
                return shared + residual / p;
            }
        }
        // Cached: NEE at the hit plus its indirect light from the next level's cache. Where that
        // cache has no record (or on the deepest level), a path-traced continuation instead,
        // which brings its own NEE: the light at the hit is sampled once either way.
        let cached = if self.path_traced(level)
            || !lambertian
            || albedo == Vec3::ZERO
            || self.core.settings.bounce_mode != BounceMode::Cached
        {
            None
        } else {
            self.core.lookup(scene, level + 1, &Query::from(&x), rays)
        };
        match cached {
            Some(e) => {
                direct_nee(scene, &x, 1, &mut dims, rays) + albedo * FRAC_1_PI * e.to_gathered()
            }
            None => {
                let r = self
                    .continuation(level)
                    .reflected(scene, surface, -w, &mut dims, rays);
                r.direct + r.indirect
            }
        }
    }
}

impl IrradianceCacheIntegrator {
    /// How many BSDF samples a camera hit with `bsdf` spends on its path-traced lobe:
    /// ⌈K·p²⌉ for `IcSettings::glossy_samples` = K and p the share of its albedo the cache's
    /// ρ_d/π·E leaves out (`Bsdf::residual_probability`): K on a metal, one on a rough
    /// dielectric unless seen at a grazing angle; the same for the lobes beyond radiance
    /// records. Splitting pays where the lobe's variance (∝ p²) is most of the pixel's; the
    /// efficiency-optimal factor (√(cost ratio × V_lobe / V_rest)) would grow as p where the
    /// rest's variance is alike, but measured, p² reaches the same error sooner than p on both
    /// glossy test scenes, and K on every lobe beyond the records costs the glossy room 23 %
    /// more time for 3 % less error (docs/performance.md, "Glossy lobes: more samples per
    /// camera sample", "Radiance caching").
    fn lobe_samples(&self, bsdf: &Bsdf) -> u32 {
        self.lobe_samples_for(bsdf.residual_probability())
    }

    /// [`IrradianceCacheIntegrator::lobe_samples`] for a lobe carrying the share `p`.
    fn lobe_samples_for(&self, p: f32) -> u32 {
        let k = self.core.settings.glossy_samples.max(1);
        ((k as f32 * p * p).ceil() as u32).clamp(1, k)
    }

    /// [`IrradianceCacheIntegrator::glossy_sample`] averaged over `count` BSDF samples (the
    /// caller's `lobe_samples`, which it also weighs its direct light against; lobe splitting:
    /// each costs a ray and a light-cache lookup, while the camera sample's shading, records and
    /// direct light are shared); with `mis`, the emitter hits are weighted against
    /// `light_samples` light samples as [`direct_light`] weighs those against all of them.
    fn glossy_lobe(
        &self,
        scene: &Scene,
        x: &ShadingPoint,
        (bsdf, whole): (&Bsdf, bool),
        (light_samples, count, mis): (u32, u32, bool),
        dims: &mut Dimensions,
        rays: &mut RayCounter,
    ) -> (Vec3, Vec3, Vec3) {
        let count = count.max(1);
        let samples = (light_samples, if mis { count } else { 0 });
        let mut sum = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
        // The samples split the camera sample (`SampleKey::subsample`): in a pixel's sequence
        // they are one aligned block, a net over the lobe's sample square rather than `count`
        // independent points, and with the other camera samples' a net again.
        let bits = count.next_power_of_two().trailing_zeros();
        let (key, first) = (dims.key(), dims.position());
        let mut last = first;
        for j in 0..count {
            let mut own = Dimensions::starting_at(key.subsample(j, bits), first);
            let (direct, indirect, glossy) =
                self.glossy_sample(scene, x, (bsdf, whole), samples, &mut own, rays);
            sum = (sum.0 + direct, sum.1 + indirect, sum.2 + glossy);
            last = last.max(own.position());
        }
        *dims = Dimensions::starting_at(key, last);
        let inverse = 1.0 / count as f32;
        (sum.0 * inverse, sum.1 * inverse, sum.2 * inverse)
    }

    /// The light a glossy x₀ reflects that the cache's ρ_d/π·E does not stand for, by one
    /// sample of its BSDF (drawn from `dims`): (`direct`, `indirect`, `glossy`, the part of
    /// `indirect` through f − ρ_d/π: all of it unless `whole`). With `bsdf_samples` = m > 0
    /// (the direct light's `light_samples` were weighted by [`direct_light`]'s power heuristic
    /// against m BSDF samples, this one of them), an emitter that the sampled ray meets counts
    /// towards `direct` with the complementary weight. The light that the point it meets
    /// reflects (as a level-0 gather ray brings it back, `gather_radiance`: from the light cache
    /// by default), or the background, counts towards `indirect` through the residual BSDF
    /// f − ρ_d/π (`Bsdf::residual`), so that with ρ_d/π·E from the cache x₀ reflects
    /// ∫ f L_ind cos exactly in expectation: the image converges to the path tracer's. With
    /// `whole` (no cache level supplies ρ_d/π·E) through the whole BSDF instead.
    fn glossy_sample(
        &self,
        scene: &Scene,
        x: &ShadingPoint,
        (bsdf, whole): (&Bsdf, bool),
        (light_samples, bsdf_samples): (u32, u32),
        dims: &mut Dimensions,
        rays: &mut RayCounter,
    ) -> (Vec3, Vec3, Vec3) {
        let Some(draw) = bsdf.draw(dims) else {
            return (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
        };
        if !draw.leaves(x.ng) {
            return (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
        }
        let ray = Ray::spawn(x.position, x.ng, draw.wi);
        rays.closest += 1;
        let hit = scene.intersect(&ray);
        // Inside an absorbing volume, the segment to the hit keeps e^(−σd) of the light.
        let tr = scene.segment_transmittance(x, draw.wi, hit.map(|h| h.t));
        let share = bsdf.residual(draw.wi) * (tr * draw.cos / draw.pdf);
        let residual = if whole { draw.weight * tr } else { share };
        let Some(hit) = hit else {
            // The background's light belongs to `indirect`.
            let b = scene.background();
            return (Vec3::ZERO, residual * b, share * b);
        };
        let surface = scene.geometry().surface(&ray, &hit);
        let mut direct = Vec3::ZERO;
        let le = scene.emitted_at(&surface, -draw.wi);
        if le != Vec3::ZERO && bsdf_samples > 0 && light_samples > 0 {
            let ray = (x.position, draw.wi);
            // With m BSDF samples the heuristic weighs m·p_bsdf (`direct_light`).
            let pdf = bsdf_samples as f32 * draw.pdf;
            let w = emission_weight(
                scene,
                &surface,
                ray,
                pdf,
                draw.light_samples(light_samples as f32),
            );
            direct = draw.weight * tr * le * w;
        }
        // What the hit reflects, as a level-0 gather ray would bring it back (from the light
        // cache by default: filtered cell means rather than one path), with randomness of its
        // own but for the filter's point, stratified with the lobe's other samples.
        let lobe = lobe_read(dims, 0);
        let reflected = self.gather_radiance(scene, 0, Some(&surface), draw.wi, lobe, rays);
        (direct, residual * reflected, share * reflected)
    }
}

impl IrradianceCacheIntegrator {
    /// What a glossy gather hit `x` of `level` reflects through its residual BSDF f − ρ_d/π
    /// (`Bsdf::residual`), the part a light-cache cell's ρ_d/π·Ē leaves out: one light sample
    /// and one BSDF sample, weighted by the power heuristic for the emitters' light, and the
    /// light the BSDF sample's hit reflects, path-traced one reflection deeper than the
    /// gather's own continuation (`continuation(level)` counts the reflection at `x`). For a
    /// `lobe` sample's hit, that light comes back as a gather ray of the next level brings it,
    /// from the light cache's filtered cells (recursively, for a glossy hit): a path there
    /// costs a ray per reflection, and its noise, weighted by 1/p, dominated the glossy room's
    /// lobes (docs/performance.md, "Filtered light-cache reads").
    fn residual(
        &self,
        scene: &Scene,
        level: usize,
        (x, bsdf): (&ShadingPoint, &Bsdf),
        lobe: bool,
        dims: &mut Dimensions,
        rays: &mut RayCounter,
    ) -> Vec3 {
        let depth = self.continuation(level).settings.max_depth;
        if depth == 0 {
            return Vec3::ZERO;
        }
        let mut value = Vec3::ZERO;
        if let Some(nee) = sample_light(scene, x, dims, rays) {
            let w = if nee.delta {
                1.0
            } else {
                power_heuristic(nee.pdf, bsdf.pdf(nee.wi))
            };
            value += bsdf.residual(nee.wi) * nee.le * (nee.cos_surface * w / nee.pdf);
        }
        let Some(draw) = bsdf.draw(dims) else {
            return value;
        };
        if !draw.leaves(x.ng) {
            return value;
        }
        let ray = Ray::spawn(x.position, x.ng, draw.wi);
        rays.closest += 1;
        let hit = scene.intersect(&ray);
        let tr = scene.segment_transmittance(x, draw.wi, hit.map(|h| h.t));
        let weight = bsdf.residual(draw.wi) * (tr * draw.cos / draw.pdf);
        let Some(hit) = hit else {
            return value + weight * scene.background();
        };
        let surface = scene.geometry().surface(&ray, &hit);
        let le = scene.emitted_at(&surface, -draw.wi);
        if le != Vec3::ZERO {
            value += weight
                * le
                * emission_weight(
                    scene,
                    &surface,
                    (x.position, draw.wi),
                    draw.pdf,
                    draw.light_samples(1.0),
                );
        }
        if lobe {
            let read = lobe_read(dims, 1);
            let r = self.gather_radiance(scene, level + 1, Some(&surface), draw.wi, read, rays);
            return value + weight * r;
        }
        let deeper = PathTracer::new(PathSettings {
            max_depth: depth - 1,
            ..self.core.settings.path
        });
        let r = deeper.reflected(scene, &surface, -draw.wi, dims, rays);
        value + weight * (r.direct + r.indirect)
    }
}

impl Integrator for IrradianceCacheIntegrator {
    fn name(&self) -> &'static str {
        "ic"
    }

    fn preprocess(&mut self, scene: &Scene) {
        self.core.set_scene(scene);
        self.light = self.empty_light_cache();
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

    fn pixel_error(&self) -> f32 {
        self.core.settings.pixel_error
    }

    /// A pixel's samples share their cache lookups (module `pixel`).
    fn batching(&self) -> Batching {
        Batching::ByPixel
    }

    fn li_many(
        &self,
        scene: &Scene,
        camera_rays: &[Ray],
        dims: &mut [Dimensions],
        out: &mut [Vec3],
        rays: &mut RayCounter,
    ) {
        let mut split = vec![Radiance::default(); camera_rays.len()];
        self.li_split_pixel(scene, camera_rays, dims, &mut split, None, rays);
        for (o, s) in out.iter_mut().zip(split) {
            *o = s.total();
        }
    }

    fn li_split_many(
        &self,
        scene: &Scene,
        camera_rays: &[Ray],
        dims: &mut [Dimensions],
        out: &mut [Radiance],
        rays: &mut RayCounter,
    ) {
        self.li_split_pixel(scene, camera_rays, dims, out, None, rays);
    }

    /// The first hits come from the samples' own camera-ray intersections.
    fn li_split_many_first_hits(
        &self,
        scene: &Scene,
        camera_rays: &[Ray],
        dims: &mut [Dimensions],
        out: &mut [Radiance],
        first: &mut [Option<FirstHit>],
        rays: &mut RayCounter,
    ) {
        first.fill(None);
        self.li_split_pixel(scene, camera_rays, dims, out, Some(first), rays);
    }
}

impl CacheBuilder for IrradianceCacheIntegrator {
    fn levels(&self) -> u32 {
        self.core.levels.len() as u32
    }

    fn complete(&self, scene: &Scene, probe: &Probe, rays: &mut RayCounter) -> Option<Candidate> {
        let li = probe.level as usize;
        let mut spent = RayCounter::default();
        // With radiance caching, a first-level record on a material whose lobe the records
        // reflect also keeps its rays' coefficients.
        let radiance = self
            .core
            .radiance
            .as_ref()
            .filter(|r| li == 0 && r.holds(scene.material_of(probe.x.triangle)));
        let mut log = Vec::new();
        let (samples, pilot, frame) = self.core.gather(
            scene,
            (self.core.levels[li].strata, self.core.super_sampling(li)),
            &probe.x,
            probe.key,
            &mut spent,
            radiance.is_some().then_some(&mut log),
            |traced, r| self.gather_radiances(scene, li, traced, r),
        )?;
        *rays += spent;
        let mut candidate = self
            .core
            .candidate(probe, (&samples, pilot.as_ref()), &frame, spent);
        let variant = match self.core.settings.gradients {
            GradientMode::Off => None,
            GradientMode::WardHeckbert | GradientMode::Fan => {
                Some(TranslationGradient::WardHeckbert)
            }
            GradientMode::KrivanekGautron => Some(TranslationGradient::KrivanekGautron),
        };
        candidate.radiance = radiance.map(|r| r.project(&samples, &log, &frame, variant));
        // A record read through a lobe is valid over a smaller region than its irradiance
        // (module `radiance`, "Records placed for glossy light").
        if candidate.radiance.is_some()
            && let Bsdf::Glossy { material, .. } = Bsdf::at(scene, &probe.x)
        {
            candidate.inputs.distance *= glossy_radius_scale(material.alpha());
        }
        Some(candidate)
    }

    fn set_view(&mut self, view: CacheView) {
        if self.core.view != Some(view) {
            self.core.view = Some(view);
            self.light = self.empty_light_cache();
        }
    }

    fn light_paths(&self) -> u32 {
        match self.core.settings.bounce_mode {
            BounceMode::LightCache => self.core.settings.light_cache_paths,
            BounceMode::PathTraced | BounceMode::Cached => 0,
        }
    }

    fn light_path_tracer(&self) -> Option<LightPathTracer> {
        let path = self.core.settings.path;
        (self.light_paths() > 0).then(|| self.light.tracer((path.max_depth, path.rr_start)))
    }

    fn add_light_paths(
        &mut self,
        paths: Vec<Vec<LightDeposit>>,
        occluded: &dyn Fn(&[Ray]) -> Vec<bool>,
    ) -> u64 {
        self.light.add_paths(&paths, occluded)
    }

    fn radiance_records(&self) -> Option<(usize, usize, usize)> {
        let radiance = self.core.radiance.as_ref()?;
        let stored = self.core.levels.first().map_or(0, |l| l.radiance.len());
        Some((
            stored / radiance.stride(),
            radiance.order(),
            stored * size_of::<Vec3>(),
        ))
    }

    fn light_cache_counts(&self) -> LightCacheCounts {
        self.light.counts()
    }

    fn settle_light_cache(&mut self) {
        self.light.settle();
    }

    fn light_cache_error(&self) -> f64 {
        self.light.relative_error()
    }

    fn light_cache_converged(&self) -> bool {
        let target = self.core.settings.light_cache_error;
        target > 0.0 && self.light.converged(f64::from(target))
    }

    forward_to_core!();
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tests::{first_surface, furnace, sphere_with_light};
    use irr_bsdf::MetallicRoughness;
    use irr_sampling::Frame;

    /// What a level-0 gather ray (not a lobe sample's read) brings back from `hit` along `w`.
    fn gather(
        ic: &IrradianceCacheIntegrator,
        scene: &Scene,
        (hit, w): (&SurfacePoint, Vec3),
        key: SampleKey,
        rays: &mut RayCounter,
    ) -> Vec3 {
        ic.gather_radiance(scene, 0, Some(hit), w, (key, None), rays)
    }

    /// A path-traced lobe takes ⌈p²·K⌉ BSDF samples, with radiance records or without: K on a metal
    /// (p = 1), one on a rough white dielectric seen head-on (p = 0.05), never fewer as the view
    /// grows grazing (Schlick's F, so p, grows towards the horizon), always within 1..=K.
    #[test]
    fn lobe_samples_follow_the_residuals_share() {
        let k = 8;
        let ic = IrradianceCacheIntegrator::new(IcSettings {
            glossy_samples: k,
            ..IcSettings::default()
        })
        .unwrap_or_else(|e| panic!("{e}"));
        let glossy = |material, cos_o: f32| Bsdf::Glossy {
            material,
            frame: Frame::from_normal(Vec3::Z),
            wo: Vec3::new((1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o),
            scale: 1.0,
        };
        let metal = MetallicRoughness::new(Vec3::new(1.0, 0.77, 0.34), 1.0, 0.3);
        let dielectric = MetallicRoughness::new(Vec3::splat(0.8), 0.0, 1.0);
        assert_eq!(ic.lobe_samples(&glossy(metal, 0.7)), k);
        assert_eq!(ic.lobe_samples(&glossy(dielectric, 1.0)), 1);
        let mut last = 1;
        for i in (1..=20).rev() {
            let n = ic.lobe_samples(&glossy(dielectric, i as f32 / 20.0));
            assert!(
                (last..=k).contains(&n),
                "cos θo {}: {n} after {last}",
                i as f32 / 20.0
            );
            last = n;
        }
        assert!(last > 1, "a grazing view's lobe takes more than one sample");
    }

    /// In cached mode a gather ray whose hit the next level does not cover brings back a
    /// path-traced continuation, whose own light sample is the hit's direct light: the light
    /// there is sampled once, so the value and the rays are exactly the continuation's.
    #[test]
    fn a_cached_gather_ray_without_a_record_samples_the_light_once() {
        let scene = sphere_with_light();
        let ic = IrradianceCacheIntegrator::new(IcSettings {
            bounce_mode: BounceMode::Cached,
            ..IcSettings::default()
        })
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(ic.core.levels.len(), 2);
        let ray = Ray::new(Vec3::ZERO, Vec3::new(0.3, -1.0, 0.2).normalize());
        let hit = first_surface(&scene, &ray);
        for k in 0..64 {
            let key = SampleKey::new(9, k, 0);
            let mut gathered = RayCounter::default();
            let value = gather(&ic, &scene, (&hit, ray.direction), key, &mut gathered);
            let mut traced = RayCounter::default();
            let mut dims = Dimensions::starting_at(key, 1);
            let r =
                ic.continuation(0)
                    .reflected(&scene, &hit, -ray.direction, &mut dims, &mut traced);
            assert_eq!(value, r.direct + r.indirect, "sample {k}");
            assert_eq!(gathered, traced, "sample {k}");
        }
    }

    /// In light-cache mode a gather ray brings back (ρ/π)·Ē from its hit's cell, with no ray
    /// of its own, once the cell holds enough deposits; before any path has filled the cache it
    /// brings back the path-traced continuation, value and rays exactly.
    #[test]
    fn a_light_cached_gather_ray_reads_its_cell_or_path_traces() {
        let scene = sphere_with_light();
        let mut ic = IrradianceCacheIntegrator::new(IcSettings {
            bounce_mode: BounceMode::LightCache,
            ..IcSettings::default()
        })
        .unwrap_or_else(|e| panic!("{e}"));
        ic.preprocess(&scene);
        let ray = Ray::new(Vec3::ZERO, Vec3::new(0.3, -1.0, 0.2).normalize());
        let hit = first_surface(&scene, &ray);
        let key = SampleKey::new(9, 1, 0);
        let mut gathered = RayCounter::default();
        let value = gather(&ic, &scene, (&hit, ray.direction), key, &mut gathered);
        let mut traced = RayCounter::default();
        let mut dims = Dimensions::starting_at(key, 1);
        let r = ic
            .continuation(0)
            .reflected(&scene, &hit, -ray.direction, &mut dims, &mut traced);
        assert_eq!(value, r.direct + r.indirect);
        assert_eq!(gathered, traced);
        // Paths from the same ray all start in the hit's cell.
        let paths: Vec<Vec<LightDeposit>> = (0..MIN_DEPOSITS as u64)
            .map(|i| {
                ic.light_path_tracer()
                    .unwrap_or_else(|| panic!("a light cache"))
                    .trace(
                        &scene,
                        &ray,
                        SampleKey::new(9, i, 0),
                        &mut RayCounter::default(),
                    )
            })
            .collect();
        let occluded = |rays: &[Ray]| rays.iter().map(|r| scene.occluded(r)).collect();
        ic.add_light_paths(paths, &occluded);
        let x = ShadingPoint::new(&hit, -ray.direction);
        let e = ic
            .light
            .irradiance(&scene, &x, &mut RayCounter::default())
            .unwrap_or_else(|| panic!("the hit's cell holds {MIN_DEPOSITS} deposits"));
        let mut read = RayCounter::default();
        let value = gather(&ic, &scene, (&hit, ray.direction), key, &mut read);
        assert_eq!(value, Vec3::splat(0.6) * FRAC_1_PI * e);
        assert_eq!(read, RayCounter::default());
    }

    /// A record's noise is calibrated: in a white furnace (a closed sphere that emits Le and
    /// reflects ρ everywhere) every direction sees the same mean radiance, so the estimator's
    /// structure term is 0 and E[V̂] is the variance of E exactly (irr-gradients' `noise`
    /// module). K = 2000 gathers of 6×24 at one point with path-traced continuations: the mean
    /// of V̂ over them against the sample variance of their E. The ratio's relative standard
    /// error combines the sample variance's, √(2/(K − 1)) (E, a sum of 144 cells, is nearly
    /// normal), and the mean of V̂'s, its own spread / √K; the bound is 6 of them.
    #[test]
    fn a_records_noise_is_the_spread_of_its_irradiance() {
        let rho = 0.6f32;
        let scene = furnace(Vec3::ZERO, rho, 1.0);
        let ic = IrradianceCacheIntegrator::new(IcSettings {
            bounce_mode: BounceMode::PathTraced,
            strata_m: 6,
            strata_n: 24,
            ..IcSettings::default()
        })
        .unwrap_or_else(|e| panic!("{e}"));
        let ray = Ray::new(Vec3::ZERO, Vec3::new(0.3, -1.0, 0.2).normalize());
        let hit = first_surface(&scene, &ray);
        let x = ShadingPoint::new(&hit, -ray.direction);
        let strata = ic.core.levels[0].strata;
        let k = 2000u64;
        let (mut e_sum, mut e2_sum, mut v_sum, mut v2_sum) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for g in 0..k {
            let mut rays = RayCounter::default();
            let (samples, ..) = ic
                .core
                .gather(
                    &scene,
                    (strata, None),
                    &x,
                    SampleKey::new(5, g, 0),
                    &mut rays,
                    None,
                    |t, r| ic.gather_radiances(&scene, 0, t, r),
                )
                .unwrap_or_else(|| panic!("gather {g}"));
            let e = f64::from(samples.irradiance().x);
            let v = samples.irradiance_variance(0);
            e_sum += e;
            e2_sum += e * e;
            v_sum += v;
            v2_sum += v * v;
        }
        let kf = k as f64;
        let spread = (e2_sum - e_sum * e_sum / kf) / (kf - 1.0);
        let mean_v = v_sum / kf;
        let sd_v = ((v2_sum / kf - mean_v * mean_v).max(0.0)).sqrt();
        let se = (2.0 / (kf - 1.0) + (sd_v / mean_v).powi(2) / kf).sqrt();
        let ratio = mean_v / spread;
        assert!(
            (ratio - 1.0).abs() < 6.0 * se,
            "mean V̂ {mean_v:.3e}, variance of E {spread:.3e}: ratio {ratio:.3} (bound ±{:.3})",
            6.0 * se
        );
    }
}
