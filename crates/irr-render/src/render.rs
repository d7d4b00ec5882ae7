//! Rendering: the film, its tiles, the thread pool, the progress bar and the summary.
//!
//! # What a pixel's value means
//! Pixel (x, y) (row 0 at the top) holds the radiance arriving at the camera through the pixel's
//! square [x, x+1) × [y, y+1) of the image plane, averaged over that square with a **box
//! filter**: each sample picks a point of the square, uniformly distributed and stratified with
//! the pixel's other samples ([`raster_position`]), traces the camera ray through it, and the pixel is the plain mean of its
//! samples' radiance, in W·sr⁻¹·m⁻² per channel. No filter crosses pixel boundaries.
//!
//! # Determinism
//! Sample `i` of pixel (x, y) uses only `SampleKey::pixel(seed, x, y, i)`: dimension 0 for the
//! jitter of its position in the pixel (a correlated multi-jittered pattern over the pixel's spp
//! samples, see [`raster_position`]), the dimensions from 1 on for the integrator: those come
//! from the pixel's shuffled, Owen-scrambled Sobol sequence (`irr_sampling::sobol`), so the
//! pixel's samples are stratified in every pair of dimensions (light choice and point, the BSDF
//! direction, …) and direct light converges faster than with independent numbers. Each pixel's samples are
//! summed in index order by one thread, in f64, so the image is the same bit for bit whatever
//! the number of threads or the order in which tiles finish. (A tile hands the integrator its
//! pixels' samples of one index together, `Integrator::li_many`, whose answers are `li`'s bit
//! for bit.) The AOVs ([`render_with_aovs`])
//! are summed the same way, sample by sample beside the colour.
//!
//! # Adaptive sampling
//! An integrator may ask for it ([`Integrator::pixel_error`]; the irradiance cache's
//! `--pixel-error`). A pixel then takes its samples in rounds, a quarter of `spp`, then up to a
//! half, then all ([`sample_rounds`]), and stops after a round when the relative standard error
//! of its mean luminance, from its own samples, is under the target and the rays through its
//! four corners meet one surface ([`corners_agree`]): a pixel that an outline crosses never
//! stops early, since its first samples can all fall on one side of it and agree. Its value is
//! the mean of the samples it took. The decision reads that pixel's samples and the scene
//! alone, so the image is still the same for any thread count, and `--debug-pixel` replays it.
//! The sample indices, and their positions in the pixel, are those of the full `spp`: a pixel
//! that stops early has taken the first ones of its shuffled pattern. What neither test sees is
//! an object smaller than a pixel that no corner meets and no early sample found: such a pixel
//! stops with a quarter of the chances of finding it that all its samples had.

use crate::aov::{Aov, AovImages, normalise_aovs};
use crate::error::RenderError;
use crate::image::Image;
use glam::{Vec2, Vec3};
use irr_geometry::Ray;
use irr_integrator::{Batching, FirstHit, Integrator, PIXEL_BATCH, Radiance, RayCounter, Scene};
use irr_sampling::rng::Dimensions;
use irr_sampling::{Cmj, PixelKeys, SampleKey};
use irr_scene::{Camera, Projection};
use rayon::prelude::*;
use std::time::Instant;

/// The side of the square tiles the image is cut into (the last row and column of tiles may be
/// smaller). Small enough to balance two cores on a 256×256 image, large enough that a tile's
/// bookkeeping is negligible beside its rays.
pub const TILE_SIZE: u32 = 16;

/// The largest width or height accepted: 2¹⁴ pixels. The film of the largest image,
/// 16384² pixels × 12 bytes, is 3 GiB: still in memory on a workstation.
pub const MAX_DIMENSION: u32 = 1 << 14;

/// The largest thread count accepted.
pub const MAX_THREADS: usize = 1024;

/// The aspect ratio (width / height) assumed for a camera without glTF's `aspectRatio` when only
/// one of width and height is given: square.
pub const DEFAULT_ASPECT_RATIO: f32 = 1.0;

/// How to render: image size, samples per pixel, seed and threads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderSettings {
    /// Image width in pixels. Default: 256. Range: 1 to [`MAX_DIMENSION`].
    pub width: u32,
    /// Image height in pixels. Default: 256. Range: 1 to [`MAX_DIMENSION`].
    pub height: u32,
    /// Samples per pixel. Default: 256 (the Cornell box at 256×256 looks converged). Range: 1
    /// to `u32::MAX`.
    pub spp: u32,
    /// Seed of every random number. Default: 0. Range: any `u64`.
    pub seed: u64,
    /// Worker threads; 0 uses rayon's global pool (one thread per core). Default: 0. Range: 0
    /// to [`MAX_THREADS`].
    pub threads: usize,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 256,
            height: 256,
            spp: 256,
            seed: 0,
            threads: 0,
        }
    }
}

fn in_range(option: &'static str, value: i64, lo: i64, hi: i64) -> Result<i64, RenderError> {
    if value < lo || value > hi {
        return Err(RenderError::Setting {
            option,
            problem: format!("must be between {lo} and {hi}, got {value}"),
        });
    }
    Ok(value)
}

impl RenderSettings {
    /// Settings from signed numbers as a user typed them, each checked against its range so
    /// that zero or negative sizes give an error naming the option (`--width: must be between
    /// 1 and 16384, got -5`).
    pub fn from_options(
        width: i64,
        height: i64,
        spp: i64,
        seed: u64,
        threads: i64,
    ) -> Result<Self, RenderError> {
        let dim = i64::from(MAX_DIMENSION);
        Ok(Self {
            width: in_range("--width", width, 1, dim)? as u32,
            height: in_range("--height", height, 1, dim)? as u32,
            spp: in_range("--spp", spp, 1, i64::from(u32::MAX))? as u32,
            seed,
            threads: in_range("--threads", threads, 0, MAX_THREADS as i64)? as usize,
        })
    }

    /// The image size from `--width` and `--height` as given, either possibly missing, and the
    /// camera's aspect ratio (width / height; glTF's `aspectRatio`, `None` for a camera without
    /// one): both given, both kept; one given, the other is it divided (or multiplied) by the
    /// aspect ratio, rounded, at least 1; neither, the default width (256) and the height from
    /// the aspect ratio. Without a usable aspect ratio (missing, not finite or not positive),
    /// [`DEFAULT_ASPECT_RATIO`]. A given size out of range, or a derived one beyond
    /// [`MAX_DIMENSION`], is an error naming the option.
    pub fn image_size(
        width: Option<i64>,
        height: Option<i64>,
        aspect: Option<f32>,
    ) -> Result<(u32, u32), RenderError> {
        let dim = i64::from(MAX_DIMENSION);
        let width = width.map(|w| in_range("--width", w, 1, dim)).transpose()?;
        let height = height
            .map(|h| in_range("--height", h, 1, dim))
            .transpose()?;
        let aspect = f64::from(
            aspect
                .filter(|a| a.is_finite() && *a > 0.0)
                .unwrap_or(DEFAULT_ASPECT_RATIO),
        );
        let derive = |option: &'static str, given: i64, other: &str, value: f64| {
            // Round to the nearest pixel, at least one.
            let n = value.round().max(1.0);
            if n > dim as f64 {
                return Err(RenderError::Setting {
                    option,
                    problem: format!(
                        "{given} with the camera's aspect ratio {aspect} gives a {other} of {n}, more than {dim}; give --{other} too"
                    ),
                });
            }
            Ok(n as i64)
        };
        let (w, h) = match (width, height) {
            (Some(w), Some(h)) => (w, h),
            (Some(w), None) => (w, derive("--width", w, "height", w as f64 / aspect)?),
            (None, Some(h)) => (derive("--height", h, "width", h as f64 * aspect)?, h),
            (None, None) => {
                let w = i64::from(Self::default().width);
                (w, derive("--width", w, "height", w as f64 / aspect)?)
            }
        };
        Ok((w as u32, h as u32))
    }

    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<(), RenderError> {
        Self::from_options(
            i64::from(self.width),
            i64::from(self.height),
            i64::from(self.spp),
            self.seed,
            self.threads as i64,
        )
        .map(drop)
    }
}

/// What a render cost.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderStats {
    /// The integrator's name.
    pub integrator: &'static str,
    /// Image size.
    pub width: u32,
    /// Image size.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Threads that rendered.
    pub threads: usize,
    /// Wall-clock time of the render, in seconds.
    pub seconds: f64,
    /// Rays traced, by kind.
    pub rays: RayCounter,
    /// Samples whose radiance was NaN or infinite; each counted as black.
    pub non_finite_samples: u64,
    /// Camera samples taken: width·height·spp, or fewer with adaptive sampling
    /// ([`Integrator::pixel_error`]).
    pub samples: u64,
}

impl RenderStats {
    /// Millions of rays per second of wall-clock time.
    pub fn mrays_per_second(&self) -> f64 {
        self.rays.total() as f64 / self.seconds.max(f64::MIN_POSITIVE) / 1e6
    }

    /// One line: `rendered 256×256 at 64 spp with path on 2 threads in 3.21 s: 41.9 M rays
    /// (13.1 Mrays/s)`; with adaptive sampling, `at 36 spp (10.4 on average)`.
    pub fn summary(&self) -> String {
        let pixels = u64::from(self.width) * u64::from(self.height);
        let spp = if self.samples == pixels * u64::from(self.spp) {
            format!("{} spp", self.spp)
        } else {
            format!(
                "{} spp ({:.1} on average)",
                self.spp,
                self.samples as f64 / pixels.max(1) as f64
            )
        };
        format!(
            "rendered {}×{} at {} with {} on {} thread{} in {:.2} s: {:.1} M rays ({:.1} Mrays/s)",
            self.width,
            self.height,
            spp,
            self.integrator,
            self.threads,
            if self.threads == 1 { "" } else { "s" },
            self.seconds,
            self.rays.total() as f64 / 1e6,
            self.mrays_per_second()
        )
    }
}

/// A rendered image and what it cost.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// The image: radiance, row 0 at the top.
    pub image: Image,
    /// The AOVs asked of [`render_with_aovs`] (none from [`render`]).
    pub aovs: AovImages,
    /// Time and rays.
    pub stats: RenderStats,
}

/// Where sample `index` of pixel (x, y) lies on the image plane: a correlated multi-jittered
/// pattern over the pixel's `spp` samples (Kensler 2013; one point per cell of a √spp grid and one
/// per stratum of each axis), the pattern chosen by (seed, x, y) and the jitter inside the cell by
/// dimension 0 of the sample's key. Stratified, so pixels crossed by an edge converge faster than
/// with independent positions, and still a function of (seed, pixel, index, spp) alone.
pub fn raster_position(settings: &RenderSettings, x: u32, y: u32, index: u32) -> Vec2 {
    PixelSampler::new(settings, (x, y)).raster(index).0
}

/// What the samples of one pixel share: their keys' hash prefix and their jitter pattern, each
/// computed once per pixel rather than once per sample (the same values, bit for bit).
#[derive(Clone, Copy, Debug)]
struct PixelSampler {
    origin: Vec2,
    keys: PixelKeys,
    pattern: Cmj,
}

impl PixelSampler {
    fn new(settings: &RenderSettings, (x, y): (u32, u32)) -> Self {
        let pattern = SampleKey::pixel(settings.seed, x, y, u64::MAX).bits(0) as u32;
        Self {
            origin: Vec2::new(x as f32, y as f32),
            keys: SampleKey::pixel_keys(settings.seed, x, y),
            pattern: Cmj::new(settings.spp, pattern),
        }
    }

    /// Sample `index`'s raster position ([`raster_position`]) and key.
    #[inline]
    fn raster(&self, index: u32) -> (Vec2, SampleKey) {
        let key = self.keys.sample(u64::from(index));
        // Dimension 0: the point inside the pixel (box filter).
        let u = self.pattern.point(index, key.uniform_2d(0));
        (self.origin + u, key)
    }

    /// The camera ray of sample `index`, its distance from the centre of projection to its
    /// origin, and the sample's dimensions from 1 on, the integrator's (one key for both).
    #[inline]
    fn camera_sample(&self, projection: &Projection, index: u32) -> (Ray, f32, Dimensions) {
        let (raster, key) = self.raster(index);
        let r = projection.ray(raster);
        let ray = Ray {
            origin: r.origin,
            direction: r.direction,
            t_max: r.t_max,
        };
        (ray, r.origin_distance, Dimensions::starting_at(key, 1))
    }
}

/// What the AOVs need of each sample.
#[derive(Clone, Copy, Debug, Default)]
struct Wants {
    /// The integrator's split of the colour.
    split: bool,
    /// The camera ray's first hit.
    first_hit: bool,
}

impl Wants {
    fn of(aovs: &[Aov]) -> Self {
        Self {
            split: aovs.iter().any(|a| a.needs_split()),
            first_hit: aovs.iter().any(|a| a.needs_first_hit()),
        }
    }
}

/// The camera rays of samples `indices` of pixel (x, y), their distances from the centre of
/// projection to their origins, and their dimensions from 1 on, into the three vectors
/// (cleared first).
fn pixel_batch(
    camera: &Camera,
    settings: &RenderSettings,
    (x, y): (u32, u32),
    indices: std::ops::Range<u32>,
    (rays, origins, dims): (&mut Vec<Ray>, &mut Vec<f32>, &mut Vec<Dimensions>),
) {
    rays.clear();
    origins.clear();
    dims.clear();
    let sampler = PixelSampler::new(settings, (x, y));
    let projection = camera.projection(settings.width, settings.height);
    for i in indices {
        let (ray, origin, d) = sampler.camera_sample(&projection, i);
        rays.push(ray);
        origins.push(origin);
        dims.push(d);
    }
}

/// A pixel's sample indices in rounds, after each of which it may stop: with adaptive sampling
/// ([`Integrator::pixel_error`] > 0) rounds ending at ⌈spp/4⌉, twice that, … and `spp`, so a
/// pixel takes a quarter of its samples, then half, then all, as its own samples say; without,
/// one round of every sample.
fn sample_rounds(integrator: &dyn Integrator, spp: u32) -> Vec<std::ops::Range<u32>> {
    let mut ends = Vec::new();
    if integrator.pixel_error() > 0.0 {
        let mut n = spp.div_ceil(4);
        while n < spp {
            ends.push(n);
            n = n.saturating_mul(2);
        }
    }
    ends.push(spp);
    let mut start = 0;
    ends.into_iter()
        .map(|end| {
            let round = start..end;
            start = end;
            round
        })
        .collect()
}

/// Whether a pixel stops after the round that brought its samples to `moments`: its samples'
/// spread is under the integrator's target and its four corners see one surface
/// ([`corners_agree`], traced once, on the first round that meets the target, into `corners`).
fn pixel_done(
    scene: &Scene,
    camera: &Camera,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    (pixel, moments): ((u32, u32), &Moments),
    corners: &mut Option<bool>,
    rays: &mut RayCounter,
) -> bool {
    let target = integrator.pixel_error();
    target > 0.0
        && moments.converged(target)
        && *corners.get_or_insert_with(|| corners_agree(scene, camera, settings, pixel, rays))
}

/// The cosine of the largest angle between two corners' geometric normals that still counts as
/// one surface (25°): a curved, tessellated surface turns by far less across a pixel, a crease
/// or the edge between a wall and the floor by more.
const CORNER_NORMAL_COS: f32 = 0.906;

/// The largest ratio of two corners' hit distances that still counts as one surface: a plane
/// at grazing incidence changes its distance across a pixel by a few per cent at most at the
/// image sizes rendered, a silhouette in front of a farther surface by far more.
const CORNER_DISTANCE_RATIO: f32 = 1.1;

/// Whether the rays through the four corners of pixel (x, y) all miss, or all hit one
/// material at distances within [`CORNER_DISTANCE_RATIO`] and with geometric normals within
/// [`CORNER_NORMAL_COS`] of each other. A silhouette or a change of material that crosses the
/// pixel crosses its boundary, and so almost always separates two corners: adaptive sampling's
/// spread test alone misses such a pixel when its first samples all fall on one side (an
/// emitter's outline, its first quarter of samples all on the light).
fn corners_agree(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    (x, y): (u32, u32),
    rays: &mut RayCounter,
) -> bool {
    let projection = camera.projection(settings.width, settings.height);
    let seen = [(0, 0), (1, 0), (0, 1), (1, 1)].map(|(dx, dy)| {
        let r = projection.ray(Vec2::new((x + dx) as f32, (y + dy) as f32));
        let ray = Ray {
            origin: r.origin,
            direction: r.direction,
            t_max: r.t_max,
        };
        rays.closest += 1;
        scene.intersect_camera(&ray).map(|hit| {
            let surface = scene.geometry().surface(&ray, &hit);
            (surface.material_id, surface.geometric_normal, hit.t)
        })
    });
    let Some(first) = seen[0] else {
        return seen.iter().all(Option::is_none);
    };
    seen.iter().all(|corner| {
        corner.is_some_and(|(material, normal, t)| {
            material == first.0
                && normal.dot(first.1) >= CORNER_NORMAL_COS
                && t.max(first.2) <= CORNER_DISTANCE_RATIO * t.min(first.2)
        })
    })
}

/// A pixel's running luminance sums, for adaptive sampling's stopping rule.
#[derive(Clone, Copy, Debug, Default)]
struct Moments {
    n: u32,
    sum: f64,
    squares: f64,
}

impl Moments {
    /// Adds a sample's radiance (a non-finite one as black, as the pixel counts it).
    fn add(&mut self, l: Vec3) {
        let y = if l.is_finite() {
            f64::from(irr_integrator::luminance(l))
        } else {
            0.0
        };
        self.n += 1;
        self.sum += y;
        self.squares += y * y;
    }

    /// Whether the relative standard error of the mean luminance is at most `target`:
    /// s²/n ≤ target²·ȳ², with s² the unbiased sample variance. Scale-free (a pixel ten times
    /// brighter with ten times the spread stops alike), and a pixel whose samples agree,
    /// black ones included, stops at the first check.
    fn converged(&self, target: f32) -> bool {
        if self.n < 2 {
            return false;
        }
        let n = f64::from(self.n);
        let mean = self.sum / n;
        let variance = ((self.squares - n * mean * mean) / (n - 1.0)).max(0.0);
        variance / n <= (f64::from(target) * mean).powi(2)
    }
}

/// Per-channel sums in f64, added to in sample order.
#[derive(Clone, Copy, Debug, Default)]
struct Sum3([f64; 3]);

impl Sum3 {
    fn add(&mut self, v: Vec3) {
        for (s, c) in self.0.iter_mut().zip(v.to_array()) {
            *s += f64::from(c);
        }
    }

    fn mean(&self, n: f64) -> Vec3 {
        Vec3::new(
            (self.0[0] / n) as f32,
            (self.0[1] / n) as f32,
            (self.0[2] / n) as f32,
        )
    }
}

/// A pixel's sums of its samples' first hits (the albedo, normal and depth AOVs), in sample
/// order.
#[derive(Clone, Copy, Debug, Default)]
struct FirstHitSums {
    albedo: Sum3,
    normal: Sum3,
    depth: f64,
    hits: u32,
}

impl FirstHitSums {
    /// Adds a sample's first hit, `origin` being its camera ray's origin's distance from the
    /// centre of projection.
    fn add(&mut self, hit: &FirstHit, origin: f32) {
        self.albedo.add(hit.albedo);
        self.normal.add(hit.normal);
        self.depth += f64::from(origin + hit.distance);
        self.hits += 1;
    }

    /// The pixel's value of a first-hit AOV over `n` samples: albedo and normal averaged over
    /// all samples, depth over those that hit (+∞ if none did); `None` for the other AOVs.
    fn value(&self, aov: Aov, n: f64) -> Option<Vec3> {
        match aov {
            Aov::Albedo => Some(self.albedo.mean(n)),
            Aov::Normal => Some(self.normal.mean(n)),
            Aov::Depth if self.hits == 0 => Some(Vec3::INFINITY),
            Aov::Depth => Some(Vec3::splat((self.depth / f64::from(self.hits)) as f32)),
            _ => None,
        }
    }
}

/// The values of `tile`'s pixels, row by row: each the mean of its samples, summed in index
/// order in f64. The samples go to the integrator a sample index at a time, the tile's
/// samples of that index in one `Integrator::li_many` call (the path tracer traces their paths
/// together, a bounce at a time, which lets a large scene's rays overlap their waits for
/// memory); each sample's value is `li`'s, bit for bit. With `first` (a
/// [`Batching::BySampleIndex`] integrator only), each pixel's first hits are summed there too,
/// as the integrator reports them. With adaptive sampling ([`Integrator::pixel_error`]) each
/// pixel takes its samples on its own, in rounds ([`for_each_sample`]). Returns the values, the
/// number of non-finite samples (counted as black) and the number of samples.
fn tile_pixels(
    scene: &Scene,
    camera: &Camera,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    tile: &Tile,
    rays: &mut RayCounter,
    mut first: Option<&mut [FirstHitSums]>,
) -> (Vec<Vec3>, u64, u64) {
    let pixels: Vec<(u32, u32)> = (tile.y0..tile.y1)
        .flat_map(|y| (tile.x0..tile.x1).map(move |x| (x, y)))
        .collect();
    if integrator.batching() == Batching::ByPixel || integrator.pixel_error() > 0.0 {
        let (mut bad, mut samples) = (0, 0);
        let values = pixels
            .iter()
            .map(|&pixel| {
                let (value, b, n) =
                    pixel_radiance(scene, camera, integrator, settings, pixel, rays);
                bad += b;
                samples += u64::from(n);
                value
            })
            .collect();
        return (values, bad, samples);
    }
    let mut sums = vec![Sum3::default(); pixels.len()];
    let mut bad = 0;
    let (mut camera_rays, mut origins, mut dims) = (Vec::new(), Vec::new(), Vec::new());
    let mut out = vec![Vec3::ZERO; pixels.len()];
    let (mut split, mut hits) = (Vec::new(), Vec::new());
    let samplers: Vec<PixelSampler> = pixels
        .iter()
        .map(|&p| PixelSampler::new(settings, p))
        .collect();
    let projection = camera.projection(settings.width, settings.height);
    for i in 0..settings.spp {
        camera_rays.clear();
        origins.clear();
        dims.clear();
        for sampler in &samplers {
            let (ray, origin, d) = sampler.camera_sample(&projection, i);
            camera_rays.push(ray);
            origins.push(origin);
            dims.push(d);
        }
        if let Some(first) = first.as_deref_mut() {
            // The split's total is `li_many`'s answer bit for bit; the first hits draw no
            // random numbers.
            split.resize(pixels.len(), Radiance::default());
            hits.resize(pixels.len(), None);
            integrator.li_split_many_first_hits(
                scene,
                &camera_rays,
                &mut dims,
                &mut split,
                &mut hits,
                rays,
            );
            for (((o, r), h), (f, origin)) in out
                .iter_mut()
                .zip(&split)
                .zip(&hits)
                .zip(first.iter_mut().zip(&origins))
            {
                *o = r.total();
                if let Some(h) = h {
                    f.add(h, *origin);
                }
            }
        } else {
            integrator.li_many(scene, &camera_rays, &mut dims, &mut out, rays);
        }
        for (sum, &l) in sums.iter_mut().zip(&out) {
            if l.is_finite() {
                sum.add(l);
            } else {
                bad += 1;
            }
        }
    }
    let n = f64::from(settings.spp);
    let samples = pixels.len() as u64 * u64::from(settings.spp);
    (sums.iter().map(|s| s.mean(n)).collect(), bad, samples)
}

/// A pixel's value with AOVs: the colour (the same bits as [`tile_pixels`] gives) and one value
/// per entry of `aovs`, pushed onto `out` in that order (see the module docs of `aov` for what
/// each is); also the number of non-finite samples and the number of samples.
#[expect(
    clippy::too_many_arguments,
    reason = "the render's context (scene, camera, integrator, settings) plus this pixel's outputs"
)]
fn pixel_with_aovs(
    scene: &Scene,
    camera: &Camera,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    aovs: &[Aov],
    (x, y): (u32, u32),
    rays: &mut RayCounter,
    out: &mut Vec<Vec3>,
) -> (Vec3, u64, u32) {
    let wants = Wants::of(aovs);
    let [
        mut colour,
        mut emitted,
        mut direct,
        mut indirect,
        mut glossy,
    ] = [Sum3::default(); 5];
    let mut seen = FirstHitSums::default();
    let mut bad = 0;
    let (mut camera_rays, mut origins, mut dims) = (Vec::new(), Vec::new(), Vec::new());
    let (mut split, mut plain, mut first) = (Vec::new(), Vec::new(), Vec::new());
    let mut moments = Moments::default();
    let mut corners = None;
    let chunks = sample_rounds(integrator, settings.spp)
        .into_iter()
        .flat_map(|round| {
            let last = round.end;
            round_chunks(integrator, round).map(move |c| (c.end == last, c))
        });
    for (ends_round, chunk) in chunks {
        pixel_batch(
            camera,
            settings,
            (x, y),
            chunk,
            (&mut camera_rays, &mut origins, &mut dims),
        );
        // The colour from the split when the split or the first hits are wanted (the same bits
        // as `li_many`'s), from `li_many` otherwise. The integrator reports the first hits it
        // finds anyway (they draw no random numbers: the estimate is unchanged).
        split.clear();
        first.clear();
        if wants.first_hit {
            split.resize(camera_rays.len(), Radiance::default());
            first.resize(camera_rays.len(), None);
            integrator.li_split_many_first_hits(
                scene,
                &camera_rays,
                &mut dims,
                &mut split,
                &mut first,
                rays,
            );
        } else if wants.split {
            split.resize(camera_rays.len(), Radiance::default());
            integrator.li_split_many(scene, &camera_rays, &mut dims, &mut split, rays);
        } else {
            plain.clear();
            plain.resize(camera_rays.len(), Vec3::ZERO);
            integrator.li_many(scene, &camera_rays, &mut dims, &mut plain, rays);
            split.extend(plain.iter().map(|&l| Radiance {
                emitted: l,
                ..Radiance::default()
            }));
        }
        for (i, (r, origin)) in split.iter().zip(&origins).enumerate() {
            let l = if wants.split || wants.first_hit {
                r.total()
            } else {
                r.emitted
            };
            moments.add(l);
            // A non-finite colour counts as black, in its parts too (if the sum is finite, so
            // is every part: an infinite or NaN part makes the sum infinite or NaN).
            if l.is_finite() {
                colour.add(l);
                emitted.add(r.emitted);
                direct.add(r.direct);
                indirect.add(r.indirect);
                glossy.add(r.glossy);
            } else {
                bad += 1;
            }
            if let Some(Some(h)) = first.get(i) {
                seen.add(h, *origin);
            }
        }
        if ends_round
            && pixel_done(
                scene,
                camera,
                integrator,
                settings,
                ((x, y), &moments),
                &mut corners,
                rays,
            )
        {
            break;
        }
    }
    let n = f64::from(moments.n);
    for &aov in aovs {
        out.push(match aov {
            Aov::Albedo | Aov::Normal | Aov::Depth => seen.value(aov, n).unwrap_or(Vec3::NAN),
            Aov::Emitted => emitted.mean(n),
            Aov::Direct => direct.mean(n),
            Aov::Indirect => indirect.mean(n),
            Aov::GlossyIndirect => glossy.mean(n),
            // Never requested from a render (normalise_aovs keeps Aov::ALL's), but it is the
            // colour as rendered.
            Aov::Noisy => colour.mean(n),
        });
    }
    (colour.mean(n), bad, moments.n)
}

/// How a round of a pixel's sample indices ([`sample_rounds`]) is handed to `integrator` when
/// its samples are computed pixel by pixel: in [`PIXEL_BATCH`] chunks for a
/// [`Batching::ByPixel`] integrator, one at a time for the others (whose answers are each ray's
/// alone, so the tiles' batches of one index give the same).
fn round_chunks(
    integrator: &dyn Integrator,
    round: std::ops::Range<u32>,
) -> Box<dyn Iterator<Item = std::ops::Range<u32>>> {
    match integrator.batching() {
        Batching::ByPixel => {
            let step = PIXEL_BATCH as u32;
            let (start, end) = (round.start, round.end);
            Box::new(
                (0..(end - start).div_ceil(step)).map(move |k| {
                    start + k * step..(start + k * step).saturating_add(step).min(end)
                }),
            )
        }
        Batching::BySampleIndex => Box::new(round.map(|i| i..i + 1)),
    }
}

/// Calls `f` with every sample's radiance of pixel (x, y), in index order, as the tiles
/// compute it, and returns how many there were (fewer than `spp` where adaptive sampling
/// stopped the pixel).
fn for_each_sample(
    scene: &Scene,
    camera: &Camera,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    pixel: (u32, u32),
    rays: &mut RayCounter,
    mut f: impl FnMut(Vec3),
) -> u32 {
    let (mut camera_rays, mut origins, mut dims) = (Vec::new(), Vec::new(), Vec::new());
    let mut out = Vec::new();
    let mut moments = Moments::default();
    let mut corners = None;
    for round in sample_rounds(integrator, settings.spp) {
        for chunk in round_chunks(integrator, round) {
            pixel_batch(
                camera,
                settings,
                pixel,
                chunk,
                (&mut camera_rays, &mut origins, &mut dims),
            );
            out.clear();
            out.resize(camera_rays.len(), Vec3::ZERO);
            integrator.li_many(scene, &camera_rays, &mut dims, &mut out, rays);
            for &l in &out {
                moments.add(l);
                f(l);
            }
        }
        if pixel_done(
            scene,
            camera,
            integrator,
            settings,
            (pixel, &moments),
            &mut corners,
            rays,
        ) {
            break;
        }
    }
    moments.n
}

/// A pixel's value from its samples (summed in index order in f64, non-finite ones counted and
/// left out), the number of non-finite samples and the number of samples.
fn pixel_radiance(
    scene: &Scene,
    camera: &Camera,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    pixel: (u32, u32),
    rays: &mut RayCounter,
) -> (Vec3, u64, u32) {
    let mut sum = Sum3::default();
    let mut bad = 0;
    let n = for_each_sample(scene, camera, integrator, settings, pixel, rays, |l| {
        if l.is_finite() {
            sum.add(l);
        } else {
            bad += 1;
        }
    });
    (sum.mean(f64::from(n)), bad, n)
}

/// A rectangle of pixels `[x0, x1) × [y0, y1)`.
#[derive(Clone, Copy, Debug)]
struct Tile {
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
}

fn tiles(width: u32, height: u32) -> Vec<Tile> {
    let mut out = Vec::new();
    for y0 in (0..height).step_by(TILE_SIZE as usize) {
        for x0 in (0..width).step_by(TILE_SIZE as usize) {
            out.push(Tile {
                x0,
                y0,
                x1: (x0 + TILE_SIZE).min(width),
                y1: (y0 + TILE_SIZE).min(height),
            });
        }
    }
    out
}

fn progress_bar(tiles: usize, show: bool) -> indicatif::ProgressBar {
    if !show {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(tiles as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{elapsed_precise} [{wide_bar}] {pos}/{len} tiles, {eta} left",
    ) {
        bar.set_style(style);
    }
    bar
}

/// Runs `work` on a pool of `threads` threads (0: rayon's global pool); returns its result and
/// the number of threads it had.
pub(crate) fn with_threads<T: Send>(
    threads: usize,
    work: impl FnOnce() -> T + Send,
) -> Result<(T, usize), RenderError> {
    if threads == 0 {
        return Ok((work(), rayon::current_num_threads()));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| RenderError::Setting {
            option: "--threads",
            problem: format!("cannot start {threads} threads: {e}"),
        })?;
    Ok((pool.install(work), threads))
}

/// Renders `scene` through `camera` with `integrator`: the image is cut into
/// [`TILE_SIZE`]-square tiles rendered in parallel (rayon), with a progress bar on the terminal
/// when `progress` is true (indicatif hides it when stderr is not a terminal).
///
/// Integrators with a preprocessing pass ([`Integrator::preprocess`]) must have run it before.
pub fn render(
    scene: &Scene,
    camera: &Camera,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    progress: bool,
) -> Result<RenderOutput, RenderError> {
    render_with_aovs(scene, camera, integrator, settings, &[], progress)
}

/// [`render`], plus the AOVs in `aovs` (repeats ignored) in [`RenderOutput::aovs`]. The colour
/// is the same, bit for bit, with or without AOVs; albedo, normal and depth trace each camera
/// ray once more (counted in the statistics' rays).
pub fn render_with_aovs(
    scene: &Scene,
    camera: &Camera,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    aovs: &[Aov],
    progress: bool,
) -> Result<RenderOutput, RenderError> {
    settings.validate()?;
    let aovs = normalise_aovs(aovs);
    // Only first-hit AOVs, for an integrator whose answers are each ray's alone: the tiles'
    // batches of one sample index, the first hits reported by the integrator.
    let batched_first_hits = !aovs.is_empty()
        && !Wants::of(&aovs).split
        && integrator.batching() == Batching::BySampleIndex
        && integrator.pixel_error() <= 0.0;
    let tiles = tiles(settings.width, settings.height);
    let bar = progress_bar(tiles.len(), progress);
    let start = Instant::now();
    let (results, threads) = with_threads(settings.threads, || {
        tiles
            .par_iter()
            .map(|tile| {
                let mut rays = RayCounter::default();
                let (mut bad, mut samples) = (0, 0u64);
                let count = ((tile.x1 - tile.x0) * (tile.y1 - tile.y0)) as usize;
                let mut extra = Vec::with_capacity(count * aovs.len());
                let values = if aovs.is_empty() || batched_first_hits {
                    let mut first =
                        vec![FirstHitSums::default(); count * usize::from(batched_first_hits)];
                    let (values, b, taken) = tile_pixels(
                        scene,
                        camera,
                        integrator,
                        settings,
                        tile,
                        &mut rays,
                        batched_first_hits.then_some(first.as_mut_slice()),
                    );
                    let n = f64::from(settings.spp);
                    for f in &first {
                        extra.extend(aovs.iter().filter_map(|&a| f.value(a, n)));
                    }
                    bad += b;
                    samples += taken;
                    values
                } else {
                    let mut values = Vec::with_capacity(count);
                    for y in tile.y0..tile.y1 {
                        for x in tile.x0..tile.x1 {
                            let (v, b, n) = pixel_with_aovs(
                                scene,
                                camera,
                                integrator,
                                settings,
                                &aovs,
                                (x, y),
                                &mut rays,
                                &mut extra,
                            );
                            values.push(v);
                            bad += b;
                            samples += u64::from(n);
                        }
                    }
                    values
                };
                bar.inc(1);
                (values, extra, rays, bad, samples)
            })
            .collect::<Vec<_>>()
    })?;
    let seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    let mut image = Image::new(settings.width, settings.height);
    let mut layers: Vec<Image> = aovs
        .iter()
        .map(|_| Image::new(settings.width, settings.height))
        .collect();
    let mut rays = RayCounter::default();
    let (mut non_finite_samples, mut samples) = (0, 0);
    for (tile, (values, extra, r, bad, n)) in tiles.iter().zip(results) {
        let mut v = values.into_iter();
        let mut e = extra.into_iter();
        for y in tile.y0..tile.y1 {
            for x in tile.x0..tile.x1 {
                image.set(x, y, v.next().unwrap_or(Vec3::NAN));
                for layer in &mut layers {
                    layer.set(x, y, e.next().unwrap_or(Vec3::NAN));
                }
            }
        }
        rays += r;
        non_finite_samples += bad;
        samples += n;
    }
    let mut images = AovImages::new();
    for (aov, layer) in aovs.iter().zip(layers) {
        images.insert(*aov, layer);
    }
    Ok(RenderOutput {
        image,
        aovs: images,
        stats: RenderStats {
            integrator: integrator.name(),
            width: settings.width,
            height: settings.height,
            spp: settings.spp,
            threads,
            seconds,
            rays,
            non_finite_samples,
            samples,
        },
    })
}

/// The radiance of every sample of pixel (x, y), in index order, exactly as [`render`] computes
/// them (`--debug-pixel`): their mean (summed in f64, non-finite samples as black) is the
/// rendered pixel's value bit for bit.
pub fn pixel_samples(
    scene: &Scene,
    camera: &Camera,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    x: u32,
    y: u32,
) -> Result<Vec<Vec3>, RenderError> {
    settings.validate()?;
    if x >= settings.width || y >= settings.height {
        return Err(RenderError::Setting {
            option: "--debug-pixel",
            problem: format!(
                "pixel ({x}, {y}) is outside the {}×{} image",
                settings.width, settings.height
            ),
        });
    }
    let mut rays = RayCounter::default();
    let mut samples = Vec::new();
    for_each_sample(
        scene,
        camera,
        integrator,
        settings,
        (x, y),
        &mut rays,
        |l| samples.push(l),
    );
    Ok(samples)
}

/// The mean of samples as [`render`] forms a pixel: summed in index order in f64, non-finite
/// samples counted as black.
pub fn mean_of_samples(samples: &[Vec3]) -> Vec3 {
    let mut sum = [0.0f64; 3];
    for l in samples.iter().filter(|l| l.is_finite()) {
        for (s, c) in sum.iter_mut().zip(l.to_array()) {
            *s += f64::from(c);
        }
    }
    let n = samples.len().max(1) as f64;
    Vec3::new(
        (sum[0] / n) as f32,
        (sum[1] / n) as f32,
        (sum[2] / n) as f32,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat4;
    use irr_geometry::{Geometry, TriangleMesh};
    use irr_integrator::{AmbientOcclusion, AoSettings, Material, PathSettings, PathTracer};
    use proptest::prelude::*;

    /// The unit roundoff of f32, 2⁻²⁴.
    const U: f32 = f32::EPSILON / 2.0;

    /// A 400 m square at z = −`distance`, facing +z, of albedo `albedo`, with an emitting
    /// square of radiance 1 far behind the camera (at z = +50, facing −z) so the split parts are
    /// not all zero; and a camera at the origin looking down −z (yfov 0.5 rad, `znear`).
    fn plane_scene(distance: f32, albedo: Vec3, znear: f32) -> (Scene, Camera) {
        let square = |z: f32, half: f32, material: u32, flip: bool| TriangleMesh {
            positions: vec![
                Vec3::new(-half, -half, z),
                Vec3::new(half, -half, z),
                Vec3::new(half, half, z),
                Vec3::new(-half, half, z),
            ],
            indices: if flip {
                vec![[0, 2, 1], [0, 3, 2]]
            } else {
                vec![[0, 1, 2], [0, 2, 3]]
            },
            normals: None,
            material_ids: vec![material; 2],
        };
        let meshes = [
            square(-distance, 200.0, 0, false),
            square(50.0, 5.0, 1, true),
        ];
        let geometry = Geometry::build(&meshes).unwrap_or_else(|e| panic!("{e}"));
        let light = Material::emitter(Vec3::ONE);
        let scene = Scene::new(geometry, vec![Material::diffuse(albedo), light])
            .unwrap_or_else(|e| panic!("{e}"));
        let mut camera =
            Camera::from_node(Mat4::IDENTITY, 0.5).unwrap_or_else(|| panic!("degenerate"));
        camera.znear = znear;
        (scene, camera)
    }

    /// 3 × 2 tiles, so that several threads share the work.
    fn small(threads: usize) -> RenderSettings {
        RenderSettings {
            width: 2 * TILE_SIZE + 3,
            height: TILE_SIZE + 4,
            spp: 3,
            seed: 3,
            threads,
        }
    }

    /// Albedo, normal and depth of a plane of known albedo at a known distance, facing the
    /// camera, which every camera ray hits.
    #[test]
    fn first_hit_aovs_of_a_plane_are_its_albedo_normal_and_distance() {
        let (albedo, distance, znear) = (Vec3::new(0.2, 0.5, 0.8), 3.0, 0.25);
        let (scene, camera) = plane_scene(distance, albedo, znear);
        let settings = small(2);
        let pt = PathTracer::new(PathSettings::default());
        let all = [Aov::Albedo, Aov::Normal, Aov::Depth];
        let out = render_with_aovs(&scene, &camera, &pt, &settings, &all, false)
            .unwrap_or_else(|e| panic!("{e}"));
        let get = |aov| out.aovs.get(aov).unwrap_or_else(|| panic!("no {aov}"));
        for y in 0..settings.height {
            for x in 0..settings.width {
                // Every sample sees the same albedo: the f64 sum of spp copies divided by spp
                // is exact, so the mean is the albedo to the last bit.
                assert_eq!(get(Aov::Albedo).get(x, y), albedo);
                // The normal of an axis-aligned triangle, normalised: (0, 0, k/√(k²)), one
                // rounding in k², one in the square root and one in the division: within 3
                // ulps of 1, under 4·2⁻²³ = 4.8e-7.
                let n = get(Aov::Normal).get(x, y);
                assert!(
                    (n - Vec3::Z).abs().max_element() < 4.8e-7,
                    "({x}, {y}): {n}"
                );
                // Depth: the distance from the centre of projection to the plane along each
                // sample's ray, distance / cos θ, averaged over the samples. The reference
                // takes each ray's f32 direction (relative error ~2u in cos θ); the renderer's
                // hit distance carries the intersection's few-ulp bound plus the near-plane
                // offset, and both means round once: 16u relative covers the lot.
                let expected: f64 = (0..settings.spp)
                    .map(|i| {
                        let r = camera.ray(
                            raster_position(&settings, x, y, i),
                            settings.width,
                            settings.height,
                        );
                        f64::from(distance) / f64::from(-r.direction.z)
                    })
                    .sum::<f64>()
                    / f64::from(settings.spp);
                let d = get(Aov::Depth).get(x, y);
                assert_eq!(d.x, d.y);
                let error = (f64::from(d.x) - expected).abs() / expected;
                assert!(error < 16.0 * f64::from(U), "({x}, {y}): {d} vs {expected}");
            }
        }
        // A camera facing away from the plane (and the light's back) meets nothing: albedo and
        // normal are 0 and depth is +∞.
        let away = Camera {
            position: Vec3::new(0.0, 0.0, 60.0),
            forward: Vec3::Z,
            right: Vec3::NEG_X,
            ..camera
        };
        let out = render_with_aovs(&scene, &away, &pt, &settings, &all, false)
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(
            out.aovs
                .get(Aov::Albedo)
                .is_some_and(|i| i.pixels().iter().all(|p| *p == Vec3::ZERO))
        );
        assert!(
            out.aovs
                .get(Aov::Normal)
                .is_some_and(|i| i.pixels().iter().all(|p| *p == Vec3::ZERO))
        );
        assert!(
            out.aovs
                .get(Aov::Depth)
                .is_some_and(|i| i.pixels().iter().all(|p| *p == Vec3::INFINITY))
        );
    }

    /// The split parts sum to the colour within f32 rounding, the colour is the same bits with
    /// and without AOVs, and every AOV is the same bits for one thread or three.
    #[test]
    fn split_aovs_sum_to_the_colour_and_nothing_depends_on_threads() {
        let (scene, camera) = plane_scene(3.0, Vec3::splat(0.7), 0.0);
        let pt = PathTracer::new(PathSettings::default());
        let all = Aov::ALL;
        let one = render_with_aovs(&scene, &camera, &pt, &small(1), &all, false)
            .unwrap_or_else(|e| panic!("{e}"));
        let three = render_with_aovs(&scene, &camera, &pt, &small(3), &all, false)
            .unwrap_or_else(|e| panic!("{e}"));
        let plain =
            render(&scene, &camera, &pt, &small(2), false).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(one.image, plain.image);
        assert_eq!(three.image, plain.image);
        assert_eq!(one.aovs, three.aovs);
        let part = |a| one.aovs.get(a).unwrap_or_else(|| panic!("no {a}")).pixels();
        let mut lit = 0;
        for (i, c) in plain.image.pixels().iter().enumerate() {
            let sum = part(Aov::Emitted)[i] + part(Aov::Direct)[i] + part(Aov::Indirect)[i];
            // Every part is ≥ 0. Per sample the colour is fl(fl(e + d) + i): within 2u of the
            // exact sum; the f64 sums add ~spp·2⁻⁵³ (negligible); the colour and each part's
            // mean are rounded to f32 once (u each, relative to at most the total); the sum
            // above rounds twice more (2u). In all under 6u of the total, and 8u bounds it.
            let bound = 8.0 * U * c.max(sum);
            assert!(
                ((sum - *c).abs() - bound).max_element() <= 0.0,
                "pixel {i}: {sum} vs {c}"
            );
            lit += usize::from(part(Aov::Direct)[i].max_element() > 0.0);
        }
        // The light behind the camera lights the plane: the direct part is not empty.
        assert!(lit > 0, "no direct light anywhere: the test checks nothing");
        // Ambient occlusion has no split: all of it is `emitted`.
        let ao = AmbientOcclusion::new(AoSettings::default());
        let out = render_with_aovs(&scene, &camera, &ao, &small(2), &all, false)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(out.aovs.get(Aov::Emitted), Some(&out.image));
        assert!(
            out.aovs
                .get(Aov::Direct)
                .is_some_and(|i| i.pixels().iter().all(|p| *p == Vec3::ZERO))
        );
        let plain =
            render(&scene, &camera, &ao, &small(2), false).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(out.image, plain.image);
    }

    /// The path tracer with adaptive sampling switched on (no integrator of the renderer's own
    /// tests asks for it otherwise).
    struct Adaptive(PathTracer, f32);

    impl Integrator for Adaptive {
        fn name(&self) -> &'static str {
            "adaptive"
        }
        fn li(
            &self,
            scene: &Scene,
            ray: &Ray,
            dims: &mut Dimensions,
            rays: &mut RayCounter,
        ) -> Vec3 {
            self.0.li(scene, ray, dims, rays)
        }
        fn li_split(
            &self,
            scene: &Scene,
            ray: &Ray,
            dims: &mut Dimensions,
            rays: &mut RayCounter,
        ) -> Radiance {
            self.0.li_split(scene, ray, dims, rays)
        }
        fn pixel_error(&self) -> f32 {
            self.1
        }
    }

    /// Rounds end at ⌈spp/4⌉, doubling, and spp; one round without adaptive sampling; no
    /// overflow at the largest spp.
    #[test]
    fn adaptive_rounds_double_from_a_quarter() {
        let pt = PathTracer::new(PathSettings::default());
        let on = Adaptive(PathTracer::new(PathSettings::default()), 0.1);
        assert_eq!(sample_rounds(&pt, 36), vec![0..36]);
        assert_eq!(sample_rounds(&on, 36), vec![0..9, 9..18, 18..36]);
        assert_eq!(sample_rounds(&on, 64), vec![0..16, 16..32, 32..64]);
        assert_eq!(sample_rounds(&on, 1), vec![0..1]);
        assert_eq!(sample_rounds(&on, 3), vec![0..1, 1..2, 2..3]);
        let last = sample_rounds(&on, u32::MAX);
        assert_eq!(last.first().map(|r| r.end), Some(u32::MAX.div_ceil(4)));
        assert_eq!(last.last().map(|r| r.end), Some(u32::MAX));
        assert!(last.windows(2).all(|w| w[0].end == w[1].start));
    }

    /// The stopping rule's known answer: samples alternating 0 and y (luminance y) have mean
    /// y/2 and unbiased variance n·y²/(4(n − 1)) for even n, so the relative standard error of
    /// the mean is 1/√(n − 1) whatever y: converged at target T exactly when n ≥ 1 + 1/T².
    /// Identical samples, black ones included, converge at n = 2; one sample never does.
    #[test]
    fn the_stopping_rule_reads_the_relative_standard_error() {
        for y in [1e-4f32, 1.0, 1e4] {
            let mut m = Moments::default();
            for i in 0..26 {
                m.add(if i % 2 == 0 {
                    Vec3::ZERO
                } else {
                    Vec3::splat(y)
                });
            }
            // n = 26: relative error 1/5.
            assert!(m.converged(0.2001), "{y}");
            assert!(!m.converged(0.1999), "{y}");
        }
        let mut same = Moments::default();
        same.add(Vec3::splat(0.3));
        assert!(!same.converged(1.0));
        same.add(Vec3::splat(0.3));
        assert!(same.converged(1e-6));
        let mut black = Moments::default();
        black.add(Vec3::ZERO);
        black.add(Vec3::NAN);
        assert!(black.converged(1e-6));
    }

    /// A plane of two materials meeting at x = 0, straight ahead: a pixel whose corners lie on
    /// both halves disagrees, one inside a half agrees, and a pixel beyond the plane's edge
    /// (corners on the plane and off it) disagrees.
    #[test]
    fn corners_see_an_edge_between_materials_and_a_silhouette() {
        let half = |x0: f32, x1: f32, material: u32| TriangleMesh {
            positions: vec![
                Vec3::new(x0, -1.0, -3.0),
                Vec3::new(x1, -1.0, -3.0),
                Vec3::new(x1, 1.0, -3.0),
                Vec3::new(x0, 1.0, -3.0),
            ],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            normals: None,
            material_ids: vec![material; 2],
        };
        let geometry = Geometry::build(&[half(-1.0, 0.0, 0), half(0.0, 1.0, 1)])
            .unwrap_or_else(|e| panic!("{e}"));
        let scene = Scene::new(
            geometry,
            vec![
                Material::diffuse(Vec3::splat(0.5)),
                Material::diffuse(Vec3::splat(0.5)),
            ],
        )
        .unwrap_or_else(|e| panic!("{e}"));
        // yfov 0.5 rad at distance 3: the image spans 2·3·tan(0.25) = 1.53 units, inside the
        // plane's height; 64 pixels wide and high.
        let camera = Camera::from_node(Mat4::IDENTITY, 0.5).unwrap_or_else(|| panic!("camera"));
        let settings = RenderSettings {
            width: 64,
            height: 64,
            spp: 1,
            seed: 0,
            threads: 1,
        };
        let mut rays = RayCounter::default();
        let mut agree = |x, y| corners_agree(&scene, &camera, &settings, (x, y), &mut rays);
        // Pixel 31 spans raster x 31..32, the image's centre column x = 32 is the material edge.
        assert!(agree(10, 30) && agree(50, 30) && agree(30, 30));
        // The corner at raster x = 32 lies on the edge itself and may meet either half.
        for y in [10, 30] {
            let (left, right) = (agree(31, y), agree(32, y));
            assert!(!left || !right, "row {y}");
        }
        // Four corner rays a pixel.
        assert_eq!(rays.closest, 4 * 7);
        // A wider view (yfov 1.2 rad: 4.1 units across) sees past the plane's edges at x = ±1.
        let wide = Camera::from_node(Mat4::IDENTITY, 1.2).unwrap_or_else(|| panic!("camera"));
        let mut rays = RayCounter::default();
        let mut wide_agree = |x| corners_agree(&scene, &wide, &settings, (x, 32), &mut rays);
        let outline: Vec<u32> = (0..64).filter(|&x| !wide_agree(x)).collect();
        // The plane's edges at x = ±1 fall at raster 32 ± 32/2.05 ≈ 16.4 and 47.6, the
        // materials' at 32: each splits one pixel (or lands on a corner, splitting none).
        assert!(
            outline.iter().all(|&x| [16, 31, 32, 47].contains(&x)) && outline.len() >= 2,
            "{outline:?}"
        );
        assert!(wide_agree(2) && wide_agree(24) && wide_agree(60));
    }

    /// An adaptive render is the same for any thread count, takes fewer samples than spp
    /// where its pixels agree, and replays: `pixel_samples` gives each pixel's samples as the
    /// render took them, their mean the pixel bit for bit.
    #[test]
    fn adaptive_sampling_stops_pixels_and_replays_them() {
        let (scene, camera) = plane_scene(3.0, Vec3::splat(0.5), 0.25);
        let on = Adaptive(PathTracer::new(PathSettings::default()), 0.2);
        let settings = |threads| RenderSettings {
            spp: 16,
            ..small(threads)
        };
        let one =
            render(&scene, &camera, &on, &settings(1), false).unwrap_or_else(|e| panic!("{e}"));
        let three =
            render(&scene, &camera, &on, &settings(3), false).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(one.image, three.image);
        assert_eq!(one.stats.samples, three.stats.samples);
        let s = settings(2);
        let full = u64::from(s.width) * u64::from(s.height) * u64::from(s.spp);
        assert!(one.stats.samples < full, "{} of {full}", one.stats.samples);
        assert!(one.stats.samples >= full / 4);
        let aovs = render_with_aovs(&scene, &camera, &on, &s, &Aov::ALL, false)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(aovs.image, one.image);
        let mut counts = std::collections::BTreeSet::new();
        for (x, y) in [(0, 0), (5, 7), (s.width - 1, s.height - 1), (17, 3)] {
            let samples =
                pixel_samples(&scene, &camera, &on, &s, x, y).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(mean_of_samples(&samples), one.image.get(x, y), "({x}, {y})");
            counts.insert(samples.len());
        }
        assert!(
            counts.iter().all(|&n| [4, 8, 16].contains(&n)),
            "{counts:?}"
        );
    }

    #[test]
    fn image_size_follows_the_aspect_ratio() {
        let size =
            |w, h, aspect| RenderSettings::image_size(w, h, aspect).map_err(|e| e.to_string());
        assert_eq!(size(Some(320), None, Some(16.0 / 9.0)), Ok((320, 180)));
        assert_eq!(size(None, Some(180), Some(16.0 / 9.0)), Ok((320, 180)));
        assert_eq!(size(None, None, Some(2.0)), Ok((256, 128)));
        assert_eq!(size(None, None, None), Ok((256, 256)));
        // Both given: both kept, whatever the camera says.
        assert_eq!(size(Some(10), Some(30), Some(2.0)), Ok((10, 30)));
        // No usable aspect ratio: square.
        for bad in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert_eq!(size(Some(64), None, Some(bad)), Ok((64, 64)));
        }
        // At least one pixel.
        assert_eq!(size(Some(3), None, Some(1000.0)), Ok((3, 1)));
        let e = |r: Result<(u32, u32), String>| r.err().unwrap_or_default();
        assert_eq!(
            e(size(Some(0), None, None)),
            "--width: must be between 1 and 16384, got 0"
        );
        assert_eq!(
            e(size(Some(8), Some(-2), None)),
            "--height: must be between 1 and 16384, got -2"
        );
        let too_tall = e(size(Some(16384), None, Some(0.5)));
        assert!(
            too_tall.starts_with(
                "--width: 16384 with the camera's aspect ratio 0.5 gives a height of 32768"
            ),
            "{too_tall}"
        );
    }

    proptest! {
        /// The tiles cover every pixel exactly once.
        #[test]
        fn tiles_partition_the_image(w in 1u32..100, h in 1u32..100) {
            let mut seen = vec![0u8; (w * h) as usize];
            for t in tiles(w, h) {
                prop_assert!(t.x1 - t.x0 <= TILE_SIZE && t.y1 - t.y0 <= TILE_SIZE);
                for y in t.y0..t.y1 {
                    for x in t.x0..t.x1 {
                        seen[(y * w + x) as usize] += 1;
                    }
                }
            }
            prop_assert!(seen.iter().all(|&s| s == 1));
        }
    }

    #[test]
    fn settings_out_of_range_name_the_option() {
        for (w, h, spp, threads, option) in [
            (0, 16, 1, 0, "--width"),
            (-5, 16, 1, 0, "--width"),
            (16, 0, 1, 0, "--height"),
            (16, -1, 1, 0, "--height"),
            (16, 16, 0, 0, "--spp"),
            (16, 16, -3, 0, "--spp"),
            (16, 16, 1, -1, "--threads"),
            (1 << 20, 16, 1, 0, "--width"),
        ] {
            let e = RenderSettings::from_options(w, h, spp, 0, threads)
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default();
            assert!(e.starts_with(&format!("{option}: must be between")), "{e}");
        }
        assert!(RenderSettings::default().validate().is_ok());
        let zero = RenderSettings {
            spp: 0,
            ..RenderSettings::default()
        };
        assert!(zero.validate().is_err());
    }

    #[test]
    fn summary_reads_well() {
        let s = RenderStats {
            integrator: "path",
            width: 4,
            height: 2,
            spp: 8,
            threads: 2,
            seconds: 2.0,
            rays: RayCounter {
                closest: 3_000_000,
                shadow: 1_000_000,
            },
            non_finite_samples: 0,
            samples: 64,
        };
        assert_eq!(
            s.summary(),
            "rendered 4×2 at 8 spp with path on 2 threads in 2.00 s: 4.0 M rays (2.0 Mrays/s)"
        );
        // Adaptive sampling took 21 of the 64 samples.
        let adaptive = RenderStats { samples: 21, ..s };
        assert_eq!(
            adaptive.summary(),
            "rendered 4×2 at 8 spp (2.6 on average) with path on 2 threads in 2.00 s: 4.0 M rays (2.0 Mrays/s)"
        );
    }
}
