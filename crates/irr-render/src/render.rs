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
//! the number of threads or the order in which tiles finish.

use crate::camera::Camera;
use crate::error::RenderError;
use crate::image::Image;
use glam::{Vec2, Vec3};
use irr_geometry::Ray;
use irr_integrator::{Integrator, RayCounter, Scene};
use irr_sampling::rng::Dimensions;
use irr_sampling::{SampleKey, correlated_multi_jitter};
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
}

impl RenderStats {
    /// Millions of rays per second of wall-clock time.
    pub fn mrays_per_second(&self) -> f64 {
        self.rays.total() as f64 / self.seconds.max(f64::MIN_POSITIVE) / 1e6
    }

    /// One line: `rendered 256×256 at 64 spp with path on 2 threads in 3.21 s: 41.9 M rays
    /// (13.1 Mrays/s)`.
    pub fn summary(&self) -> String {
        format!(
            "rendered {}×{} at {} spp with {} on {} thread{} in {:.2} s: {:.1} M rays ({:.1} Mrays/s)",
            self.width,
            self.height,
            self.spp,
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
    /// Time and rays.
    pub stats: RenderStats,
}

/// Where sample `index` of pixel (x, y) lies on the image plane: a correlated multi-jittered
/// pattern over the pixel's `spp` samples (Kensler 2013; one point per cell of a √spp grid and one
/// per stratum of each axis), the pattern chosen by (seed, x, y) and the jitter inside the cell by
/// dimension 0 of the sample's key. Stratified, so pixels crossed by an edge converge faster than
/// with independent positions, and still a function of (seed, pixel, index, spp) alone.
pub fn raster_position(settings: &RenderSettings, x: u32, y: u32, index: u32) -> Vec2 {
    let key = SampleKey::pixel(settings.seed, x, y, u64::from(index));
    let pattern = SampleKey::pixel(settings.seed, x, y, u64::MAX).bits(0) as u32;
    let u = correlated_multi_jitter(index, settings.spp, pattern, key.uniform_2d(0));
    Vec2::new(x as f32, y as f32) + u
}

/// One sample of one pixel: the radiance along the camera ray through a uniformly chosen point
/// of the pixel. Non-finite results are returned as they are (the caller counts them).
fn sample(
    scene: &Scene,
    camera: &Camera,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    (x, y, index): (u32, u32, u32),
    rays: &mut RayCounter,
) -> Vec3 {
    let key = SampleKey::pixel(settings.seed, x, y, u64::from(index));
    // Dimension 0: the point inside the pixel (box filter).
    let raster = raster_position(settings, x, y, index);
    let r = camera.ray(raster, settings.width, settings.height);
    let ray = Ray {
        origin: r.origin,
        direction: r.direction,
        t_max: r.t_max,
    };
    // Dimensions 1 and up: the integrator's.
    let mut dims = Dimensions::starting_at(key, 1);
    integrator.li(scene, &ray, &mut dims, rays)
}

/// A pixel's value: the mean of its samples, summed in index order in f64. Returns the value
/// and the number of non-finite samples (counted as black).
fn pixel(
    scene: &Scene,
    camera: &Camera,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    (x, y): (u32, u32),
    rays: &mut RayCounter,
) -> (Vec3, u64) {
    let mut sum = [0.0f64; 3];
    let mut bad = 0;
    for i in 0..settings.spp {
        let l = sample(scene, camera, integrator, settings, (x, y, i), rays);
        if l.is_finite() {
            for (s, c) in sum.iter_mut().zip(l.to_array()) {
                *s += f64::from(c);
            }
        } else {
            bad += 1;
        }
    }
    let n = f64::from(settings.spp);
    let mean = Vec3::new(
        (sum[0] / n) as f32,
        (sum[1] / n) as f32,
        (sum[2] / n) as f32,
    );
    (mean, bad)
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
    settings.validate()?;
    let tiles = tiles(settings.width, settings.height);
    let bar = progress_bar(tiles.len(), progress);
    let start = Instant::now();
    let (results, threads) = with_threads(settings.threads, || {
        tiles
            .par_iter()
            .map(|tile| {
                let mut rays = RayCounter::default();
                let mut bad = 0;
                let mut values =
                    Vec::with_capacity(((tile.x1 - tile.x0) * (tile.y1 - tile.y0)) as usize);
                for y in tile.y0..tile.y1 {
                    for x in tile.x0..tile.x1 {
                        let (v, b) = pixel(scene, camera, integrator, settings, (x, y), &mut rays);
                        values.push(v);
                        bad += b;
                    }
                }
                bar.inc(1);
                (values, rays, bad)
            })
            .collect::<Vec<_>>()
    })?;
    let seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    let mut image = Image::new(settings.width, settings.height);
    let mut rays = RayCounter::default();
    let mut non_finite_samples = 0;
    for (tile, (values, r, bad)) in tiles.iter().zip(results) {
        let mut v = values.into_iter();
        for y in tile.y0..tile.y1 {
            for x in tile.x0..tile.x1 {
                image.set(x, y, v.next().unwrap_or(Vec3::NAN));
            }
        }
        rays += r;
        non_finite_samples += bad;
    }
    Ok(RenderOutput {
        image,
        stats: RenderStats {
            integrator: integrator.name(),
            width: settings.width,
            height: settings.height,
            spp: settings.spp,
            threads,
            seconds,
            rays,
            non_finite_samples,
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
    Ok((0..settings.spp)
        .map(|i| sample(scene, camera, integrator, settings, (x, y, i), &mut rays))
        .collect())
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
    use proptest::prelude::*;

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
        };
        assert_eq!(
            s.summary(),
            "rendered 4×2 at 8 spp with path on 2 threads in 2.00 s: 4.0 M rays (2.0 Mrays/s)"
        );
    }
}
