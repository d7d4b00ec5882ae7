//! The render command shared by `irr` and `cargo xtask render`: a thin command-line layer over
//! irr-render's library functions.
//!
//! Order of work: check the settings and that the output can be written (fail fast, before any
//! rendering), load the scene and print its warnings, render with a progress bar, print the
//! summary, write EXR + PNG (temporary files renamed into place).

use crate::sequence::{Shared, shared_cache};
use clap::{Args, ValueEnum};
use irr_render::MAX_SHARDS;
use irr_render::{
    AmbientOcclusion, AoSettings, Aov, BounceMode, CacheBuilder, CachedAmbientOcclusion, Camera,
    DENOISER, DENOISER_AOVS, ExrMetadata, GradientMode, IcSettings, Integrator,
    IrradianceCacheIntegrator, LeakGuard, LoadOptions, LoadedScene, MetricKind, NO_DENOISER,
    PathSettings, PathTracer, RadiusStatistic, RenderSettings, build_cache, build_light_cache,
    check_exposure, check_output, check_output_file, denoise, fingerprint, load_scene_with,
    mark_records, mean_of_samples, pixel_samples, read_cache_file,
    remove_partial_outputs_on_signals, render_with_aovs, write_cache_file, write_exr_and_png,
    write_render,
};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Which integrator estimates the radiance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum IntegratorChoice {
    /// The irradiance cache: emission + direct light (NEE) + indirect light interpolated from
    /// sparse hemisphere gathers. The default.
    Ic,
    /// The unbiased path tracer (next-event estimation, Russian roulette): the reference.
    Path,
    /// Ambient occlusion (cosine-weighted, unbounded distance): grey, no emitters needed.
    Ao,
    /// Ambient occlusion through the irradiance cache (scalar records).
    IcAo,
}

/// The cache's error metric.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MetricChoice {
    /// Tabellion & Lamorlette 2004: --error is κ (larger is stricter)
    TabellionLamorlette,
    /// Ward et al. 1988: --error is a (smaller is stricter)
    Ward,
    /// Schwarzhaupt et al. 2012 (Radiance 4.2): elliptical records sized by the irradiance
    /// Hessian, with occlusion-aware gradients; --error is a (smaller is stricter)
    Hessian,
}

/// The records' translation gradient.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum GradientChoice {
    /// No gradients
    Off,
    /// Ward & Heckbert 1992
    WardHeckbert,
    /// Křivánek et al. 2005
    KrivanekGautron,
    /// The occlusion-aware gradient of the gather's triangle fan (Schwarzhaupt et al. 2012)
    Fan,
}

/// The statistic of a gather's hit distances that sizes its record.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum RadiusChoice {
    /// The harmonic mean (Ward et al. 1988; Radiance)
    Harmonic,
    /// The minimum (Tabellion & Lamorlette 2004; Mitsuba 0.6)
    Minimum,
}

/// What a gather ray brings back beyond the direct light at its hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum BounceChoice {
    /// A path-traced continuation (unbiased)
    PathTraced,
    /// The next bounce level's cache (Radiance's -ab)
    Cached,
    /// The light cache: cell means of the irradiance that camera-launched paths deposit
    LightCache,
}

/// Options of the irradiance-cache integrators (`ic`, `ic-ao`); defaults from `IcSettings`.
#[derive(Args, Debug, Clone)]
pub struct IcArgs {
    /// The error metric
    #[arg(long, value_enum, default_value_t = MetricChoice::TabellionLamorlette)]
    pub metric: MetricChoice,
    /// The error parameter: κ for tabellion-lamorlette (> 0, larger is stricter), a for ward
    /// (> 0, smaller is stricter), a for hessian (> 0, smaller is stricter: a record is used
    /// within a times its radii, which are Radiance's (4/|λ|)^¼ in units of the image's
    /// height at the record's distance)
    #[arg(long, default_value_t = IcSettings::default().error, allow_negative_numbers = true)]
    pub error: f32,
    /// Hemisphere strata M×N of a gather (M along θ, N along φ)
    #[arg(long, value_name = "MxN", default_value = "16x64", value_parser = parse_strata)]
    pub strata: (u32, u32),
    /// Record radius limits in pixels, MIN,MAX (the metric's distance scale on screen)
    #[arg(long, value_name = "MIN,MAX", default_value = "1.5,10", value_parser = parse_pair)]
    pub pixel_spacing: (f32, f32),
    /// Smallest influence radius of a record on screen, in pixels (0: none)
    #[arg(long, default_value_t = IcSettings::default().influence_floor, allow_negative_numbers = true)]
    pub influence_floor: f32,
    /// Largest record radius, as a fraction of the image's height at the record's distance
    #[arg(long, default_value_t = IcSettings::default().world_max, allow_negative_numbers = true)]
    pub world_max: f32,
    /// Smallest record radius, as a fraction of the image's height at the record's distance
    #[arg(long, default_value_t = IcSettings::default().world_min, allow_negative_numbers = true)]
    pub world_min: f32,
    /// The records' translation gradient
    #[arg(long, value_enum, default_value_t = GradientChoice::WardHeckbert)]
    pub gradients: GradientChoice,
    /// The statistic of a gather's hit distances (above 10° of the horizon) that sizes its record
    #[arg(long, value_enum, default_value_t = RadiusChoice::Minimum)]
    pub radius_statistic: RadiusChoice,
    /// Turn neighbour clamping (Křivánek et al. 2006) off
    #[arg(long)]
    pub no_neighbour_clamping: bool,
    /// Turn the leak guard (a visibility test between query and record) off
    #[arg(long)]
    pub no_leak_guard: bool,
    /// What a gather ray brings back from the point it hits
    #[arg(long, value_enum, default_value_t = BounceChoice::LightCache)]
    pub bounce_mode: BounceChoice,
    /// With --bounce-mode cached: cache levels below the first (1 to 8)
    #[arg(long, default_value_t = IcSettings::default().cached_bounces)]
    pub bounces: u32,
    /// With --bounce-mode light-cache: the most camera-launched paths that fill it (1 to
    /// 4194304)
    #[arg(long, default_value_t = IcSettings::default().light_cache_paths)]
    pub light_cache_paths: u32,
    /// With --bounce-mode light-cache: its target, the relative standard error of its cells'
    /// means; paths are added until they reach it or --light-cache-paths are spent (0: always
    /// spend them)
    #[arg(long, default_value_t = IcSettings::default().light_cache_error, allow_negative_numbers = true)]
    pub light_cache_error: f32,
    /// With --bounce-mode light-cache: its cells' width as a fraction of the image's height at
    /// their distance, rounded to a power of two (2^-16 to 1; smaller is sharper and needs more
    /// paths)
    #[arg(long, default_value_t = IcSettings::default().light_cache_cell, allow_negative_numbers = true)]
    pub light_cache_cell: f32,
    /// Light samples per camera hit for the direct light (≥ 1)
    #[arg(long, default_value_t = IcSettings::default().direct_samples)]
    pub direct_samples: u32,
    /// BSDF samples per camera hit for a path-traced glossy lobe that carries all of the
    /// surface's reflection (a metal), 1 to 256; a lobe carrying the share p of the albedo
    /// takes ⌈p²·this⌉ (with --radiance-order too, beyond the records). Each adds a ray; the camera sample's other work is shared
    #[arg(long, default_value_t = IcSettings::default().glossy_samples)]
    pub glossy_samples: u32,
    /// Adaptive gathers: the target relative standard error of a record's irradiance (e.g.
    /// 0.05), estimated from its strata; a gather above it spends more rays on its noisiest
    /// strata. Deeper levels loosen it as they loosen --error. 0: one ray per stratum
    #[arg(long, default_value_t = IcSettings::default().gather_error, allow_negative_numbers = true)]
    pub gather_error: f32,
    /// Adaptive camera samples (ic): a pixel stops taking samples once the relative standard
    /// error of its mean luminance, checked after a quarter, a half, … of --spp, is at most this
    /// (e.g. 0.02). 0: every pixel takes --spp
    #[arg(long, default_value_t = IcSettings::default().pixel_error, allow_negative_numbers = true)]
    pub pixel_error: f32,
    /// With --gather-error: the most extra rays of a gather, as a multiple of its strata (0 to
    /// 64)
    #[arg(long, default_value_t = IcSettings::default().gather_budget, allow_negative_numbers = true)]
    pub gather_budget: f32,
    /// Also build records at every camera sample's own hit, not only at pixel centres (the final
    /// pass then almost never gathers for itself)
    #[arg(long)]
    pub fill_samples: bool,
    /// Radiance caching of glossy lobes (Křivánek et al. 2005): each record on a rough metal
    /// also stores its gather's incoming light in real spherical harmonics of this order (N²
    /// coefficients per colour, N ≤ 10; 10 with --radiance-error 0.3 is the measured choice),
    /// and a point whose lobe the order holds reflects their interpolation instead of
    /// path-tracing its lobe. 0: off
    #[arg(long, default_value_t = IcSettings::default().radiance_order)]
    pub radiance_order: u32,
    /// With --radiance-order: a glossy point uses the records where its lobe's relative
    /// reconstruction error in the basis (by roughness and view angle) is at most this, in
    /// (0, 1]; elsewhere its lobe is path-traced. Larger: more points cached, more bias
    #[arg(long, default_value_t = IcSettings::default().radiance_error, allow_negative_numbers = true)]
    pub radiance_error: f32,
    /// With --radiance-order: the coefficients of the first BANDS bands (BANDS² of them) get
    /// translation gradients (capped as the irradiance's), by which lookups extrapolate them;
    /// 0..=N, N: every coefficient (0 by default: measured to add error and bias;
    /// docs/performance.md, "Radiance caching")
    #[arg(long, value_name = "BANDS", default_value_t = IcSettings::default().radiance_gradients)]
    pub radiance_gradients: u32,
    /// With --metric hessian: extrapolate each record to second order by its curvature (the
    /// eigenvalues of its relative irradiance Hessian), the correction clamped to this fraction
    /// of the record's irradiance, in [0, 1] (e.g. 0.1). 0: first order
    #[arg(long, value_name = "LIMIT", default_value_t = IcSettings::default().second_order, allow_negative_numbers = true)]
    pub second_order: f32,
    /// Write a second image, OUT-records.exr/.png (OUT the output's stem), with every record marked: a dot, and
    /// a ring of its influence radius in the colour of its noise (the estimated relative
    /// standard error of its irradiance: blue 0, green 5 %, yellow 10 %, red 20 % and more)
    #[arg(long)]
    pub show_records: bool,
    /// A persistent cache (--integrator ic): read the records from FILE if it exists (it must
    /// have been written for the same scene, camera, image size and cache settings), and write
    /// them there after the render
    #[arg(long, value_name = "FILE")]
    pub cache: Option<PathBuf>,
}

impl IcArgs {
    /// The settings, checked (an error names the option).
    pub fn settings(&self, max_depth: u32) -> Result<IcSettings, String> {
        let s = IcSettings {
            metric: match self.metric {
                MetricChoice::TabellionLamorlette => MetricKind::TabellionLamorlette,
                MetricChoice::Ward => MetricKind::Ward,
                MetricChoice::Hessian => MetricKind::Hessian,
            },
            error: self.error,
            strata_m: self.strata.0,
            strata_n: self.strata.1,
            pixel_min: self.pixel_spacing.0,
            pixel_max: self.pixel_spacing.1,
            influence_floor: self.influence_floor,
            world_max: self.world_max,
            world_min: self.world_min,
            gradients: match self.gradients {
                GradientChoice::Off => GradientMode::Off,
                GradientChoice::WardHeckbert => GradientMode::WardHeckbert,
                GradientChoice::KrivanekGautron => GradientMode::KrivanekGautron,
                GradientChoice::Fan => GradientMode::Fan,
            },
            radius_statistic: match self.radius_statistic {
                RadiusChoice::Harmonic => RadiusStatistic::HarmonicMean,
                RadiusChoice::Minimum => RadiusStatistic::Minimum,
            },
            neighbour_clamping: !self.no_neighbour_clamping,
            leak_guard: if self.no_leak_guard {
                LeakGuard::Off
            } else {
                LeakGuard::Visibility
            },
            bounce_mode: match self.bounce_mode {
                BounceChoice::PathTraced => BounceMode::PathTraced,
                BounceChoice::Cached => BounceMode::Cached,
                BounceChoice::LightCache => BounceMode::LightCache,
            },
            light_cache_paths: self.light_cache_paths,
            light_cache_error: self.light_cache_error,
            light_cache_cell: self.light_cache_cell,
            cached_bounces: self.bounces,
            direct_samples: self.direct_samples,
            glossy_samples: self.glossy_samples,
            gather_error: self.gather_error,
            pixel_error: self.pixel_error,
            gather_budget: self.gather_budget,
            fill_samples: self.fill_samples,
            radiance_order: self.radiance_order,
            radiance_error: self.radiance_error,
            radiance_gradients: self.radiance_gradients,
            second_order: self.second_order,
            path: PathSettings {
                max_depth,
                ..PathSettings::default()
            },
            ..IcSettings::default()
        };
        s.validate().map_err(|e| e.to_string())?;
        Ok(s)
    }
}

fn parse_strata(text: &str) -> Result<(u32, u32), String> {
    let (m, n) = text
        .split_once(['x', '×'])
        .ok_or_else(|| format!("expected MxN, e.g. 16x64, got '{text}'"))?;
    let parse = |s: &str| {
        s.trim()
            .parse::<u32>()
            .map_err(|e| format!("'{s}' in '{text}': {e}"))
    };
    Ok((parse(m)?, parse(n)?))
}

fn parse_pair(text: &str) -> Result<(f32, f32), String> {
    let (a, b) = text
        .split_once(',')
        .ok_or_else(|| format!("expected MIN,MAX, got '{text}'"))?;
    let parse = |s: &str| {
        s.trim()
            .parse::<f32>()
            .map_err(|e| format!("'{s}' in '{text}': {e}"))
    };
    Ok((parse(a)?, parse(b)?))
}

/// Render a glTF scene to OpenEXR (linear radiance) and a PNG preview beside it.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The integrator
    #[arg(long, value_enum, default_value_t = IntegratorChoice::Ic)]
    pub integrator: IntegratorChoice,
    /// Samples per pixel (≥ 1) [default: 256 for path and ao, 36 for ic and ic-ao: camera
    /// samples for anti-aliasing and direct light; the cache makes the indirect light smooth]
    #[arg(long, allow_negative_numbers = true)]
    pub spp: Option<i64>,
    /// Image width in pixels (1 to 16384) [default: --height × the camera's aspect ratio, or
    /// 256 without --height]
    #[arg(long, allow_negative_numbers = true)]
    pub width: Option<i64>,
    /// Image height in pixels (1 to 16384) [default: the width ÷ the camera's aspect ratio
    /// (glTF's aspectRatio, 1 for a camera without one)]
    #[arg(long, allow_negative_numbers = true)]
    pub height: Option<i64>,
    /// The scene's perspective camera to render through, numbered from 0 in depth-first order
    /// of the scene's nodes [default: 0, or a camera framing the scene if the file has none]
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub camera: Option<usize>,
    /// Auxiliary images written as further layers of the EXR, comma-separated, any of: albedo,
    /// normal, depth, emitted, direct, indirect, glossy-indirect (the part of indirect the first
    /// surface's glossy lobes reflect) (layers albedo.R/G/B, normal.X/Y/Z, depth.Z,
    /// emitted.R/G/B, …; each averaged over the pixel's samples like the colour)
    #[arg(long, value_name = "AOV,...", value_delimiter = ',', value_parser = parse_aov)]
    pub aov: Vec<Aov>,
    /// Denoise the colour with Intel Open Image Denoise (its RT filter, HDR, with the albedo
    /// and normal AOVs, which are written too); the EXR keeps the raw colour as the layer
    /// noisy.R/G/B. Needs a build with the `denoise` feature (README, "Denoising")
    #[arg(long)]
    pub denoise: bool,
    /// Worker threads; 0 means one per core
    #[arg(long, default_value_t = RenderSettings::default().threads as i64, allow_negative_numbers = true)]
    pub threads: i64,
    /// Seed of every random number (same seed, same image, bit for bit, for any thread count)
    #[arg(long, default_value_t = RenderSettings::default().seed, allow_negative_numbers = true)]
    pub seed: u64,
    /// Maximum number of reflections a light path may make, for the path tracer and the
    /// irradiance cache alike (0: emitters seen directly only; 1: plus the direct light)
    #[arg(long, default_value_t = PathSettings::default().max_depth)]
    pub max_depth: u32,
    /// Exposure of the PNG preview in stops: radiance × 2^exposure, clipped to [0, 1], sRGB
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// The folder whose files the scene's buffer URIs may read (after resolving `..` and
    /// symbolic links) [default: the scene file's folder]
    #[arg(long, value_name = "DIR")]
    pub asset_root: Option<PathBuf>,
    /// The most memory the scene may take, its arrays and BVH (e.g. 12G, 512M; K, M, G and T
    /// are powers of 1024): a larger scene is refused with its figure before it is built
    /// [default: 3/4 of this machine's memory]
    #[arg(long, value_name = "SIZE", value_parser = parse_size)]
    pub max_memory: Option<u64>,
    /// Constant background radiance R,G,B (W·sr⁻¹·m⁻² per channel, each finite and ≥ 0), seen
    /// by camera rays and by every ray that leaves the scene, so it lights the scene too
    #[arg(long, value_name = "R,G,B", default_value = "0,0,0", value_parser = parse_background,
          allow_hyphen_values = true)]
    pub background: [f32; 3],
    /// Render only pixel X,Y (0,0 is the top-left) and print each sample's radiance; writes
    /// nothing
    #[arg(long, value_name = "X,Y", value_parser = parse_pixel, allow_hyphen_values = true)]
    pub debug_pixel: Option<(u32, u32)>,
    /// Render frames A..B of the camera's animation (B excluded; A..=B includes it), frame f at
    /// f / --fps seconds, each to the output named with its #### (any run of #) replaced by the
    /// zero-padded frame number, or with .NNNN before the extension if it has none
    #[arg(long, value_name = "A..B", value_parser = parse_frames, conflicts_with = "frame")]
    pub frames: Option<(u32, u32)>,
    /// Render one frame of the camera's animation, at N / --fps seconds, to the output as named
    #[arg(long, value_name = "N")]
    pub frame: Option<u32>,
    /// Frames per second of --frames and --frame (finite, > 0)
    #[arg(long, default_value_t = DEFAULT_FPS, allow_negative_numbers = true)]
    pub fps: f64,
    /// With --frames and --integrator ic: one cache for the whole sequence, built from the
    /// views of every --cache-every-th frame and the last, then read by every frame without
    /// adding records, so the indirect light does not flicker from frame to frame
    #[arg(long)]
    pub shared_cache: bool,
    /// With --shared-cache: the spacing of the frames whose views build the cache (≥ 1)
    #[arg(long, value_name = "K", default_value_t = DEFAULT_CACHE_EVERY)]
    pub cache_every: u32,
    /// With --shared-cache: build the cache in S shards, each from a contiguous run of the key
    /// frames into an empty cache, joined in order (what a farm does with --shard and `irr
    /// cache merge`; the same bits). More shards: more records where runs overlap
    #[arg(long, value_name = "S", default_value_t = 1)]
    pub shards: u32,
    /// With --shared-cache, --shards S and --cache FILE: build only shard I (0 to S − 1) and
    /// write it to FILE, rendering nothing; `irr cache merge` joins the shard files into the
    /// sequence's cache, which --cache then reads for any of the frames
    #[arg(long, value_name = "I")]
    pub shard: Option<u32>,
    /// The irradiance cache's options
    #[command(flatten)]
    pub ic: IcArgs,
}

/// Frames per second of an animation by default (film's rate).
pub const DEFAULT_FPS: f64 = 24.0;

/// The spacing of a shared cache's key frames by default.
pub const DEFAULT_CACHE_EVERY: u32 = 10;

/// The most frames one `--frames` range may hold.
pub const MAX_FRAMES: u32 = 1_000_000;

/// `A..B` (B excluded) or `A..=B` as the first frame and one past the last.
fn parse_frames(text: &str) -> Result<(u32, u32), String> {
    let (a, b, inclusive) = if let Some((a, b)) = text.split_once("..=") {
        (a, b, true)
    } else if let Some((a, b)) = text.split_once("..") {
        (a, b, false)
    } else {
        return Err(format!("expected A..B or A..=B, e.g. 0..120, got '{text}'"));
    };
    let parse = |s: &str| {
        s.trim()
            .parse::<u32>()
            .map_err(|e| format!("'{s}' in '{text}': {e}"))
    };
    let (a, b) = (parse(a)?, parse(b)?);
    let end = if inclusive { b.checked_add(1) } else { Some(b) }
        .ok_or_else(|| format!("'{text}': the last frame is too large"))?;
    if end <= a {
        return Err(format!("'{text}' holds no frame"));
    }
    if end - a > MAX_FRAMES {
        return Err(format!(
            "'{text}' holds {} frames; at most {MAX_FRAMES}",
            end - a
        ));
    }
    Ok((a, end))
}

/// Frame `frame`'s output: `out` with its first run of `#` replaced by the frame number
/// zero-padded to the run's length, or with `.NNNN` before the extension if it has no `#`.
pub fn frame_output(out: &Path, frame: u32) -> PathBuf {
    let name = out
        .file_name()
        .map_or_else(|| "render.exr".into(), |n| n.to_string_lossy().into_owned());
    let named = match name.find('#') {
        Some(start) => {
            let run = name[start..].chars().take_while(|&c| c == '#').count();
            format!(
                "{}{frame:0run$}{}",
                &name[..start],
                &name[start + run..],
                run = run
            )
        }
        None => {
            let path = Path::new(&name);
            let stem = path
                .file_stem()
                .map_or_else(|| "render".into(), |s| s.to_string_lossy().into_owned());
            match path.extension() {
                Some(ext) => format!("{stem}.{frame:04}.{}", ext.to_string_lossy()),
                None => format!("{stem}.{frame:04}"),
            }
        }
    };
    out.with_file_name(named)
}

/// The default samples per pixel of `choice`.
pub fn default_spp(choice: IntegratorChoice) -> i64 {
    match choice {
        IntegratorChoice::Path | IntegratorChoice::Ao => RenderSettings::default().spp.into(),
        IntegratorChoice::Ic | IntegratorChoice::IcAo => IC_DEFAULT_SPP,
    }
}

/// The largest persistent cache file read (10⁸ records of 120 bytes would be 12 GB; a cache
/// file beyond 4 GiB is refused rather than read).
pub const MAX_CACHE_FILE_BYTES: u64 = 4 << 30;

/// Camera samples per pixel of the irradiance cache by default (see `default_spp`).
pub const IC_DEFAULT_SPP: i64 = 36;

fn parse_aov(text: &str) -> Result<Aov, String> {
    Aov::from_name(text)
}

/// The output `irr SCENE` writes without `-o`: `<scene stem>.exr` in the current directory.
pub fn default_output(scene: &Path) -> PathBuf {
    let stem = scene
        .file_stem()
        .map_or_else(|| "render".into(), |s| s.to_string_lossy().into_owned());
    PathBuf::from(format!("{stem}.exr"))
}

fn parse_pixel(text: &str) -> Result<(u32, u32), String> {
    let (x, y) = text
        .split_once(',')
        .ok_or_else(|| format!("expected X,Y, got '{text}'"))?;
    let parse = |s: &str| {
        let s = s.trim();
        match s.parse::<i64>() {
            Ok(v) if v < 0 => Err(format!(
                "'{s}' in '{text}': pixel coordinates start at 0 (the top-left pixel is 0,0)"
            )),
            _ => s
                .parse::<u32>()
                .map_err(|e| format!("'{s}' in '{text}': {e}")),
        }
    };
    Ok((parse(x)?, parse(y)?))
}

/// Parses `--max-memory SIZE`: a positive number of bytes, with an optional suffix K, M, G or T
/// (powers of 1024; "GiB", "GB" and "g" read the same).
fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let split = t.find(|c: char| c.is_ascii_alphabetic()).unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let shift = match unit.to_ascii_lowercase().as_str() {
        "" | "b" => 0,
        "k" | "kb" | "kib" => 10,
        "m" | "mb" | "mib" => 20,
        "g" | "gb" | "gib" => 30,
        "t" | "tb" | "tib" => 40,
        _ => {
            return Err(format!(
                "'{text}': expected a size such as 12G, 512M or 1048576 (K, M, G, T: powers of 1024)"
            ));
        }
    };
    let value: f64 = number
        .trim()
        .parse()
        .map_err(|_| format!("'{text}': expected a number before the unit, e.g. 12G"))?;
    let bytes = value * (1u64 << shift) as f64;
    // Below 2⁶³ bytes, so the cast cannot saturate; NaN fails the test.
    if !(1.0..9.2e18).contains(&bytes) {
        return Err(format!(
            "'{text}': the memory limit must be at least 1 byte and below 8 EiB"
        ));
    }
    Ok(bytes as u64)
}

/// Parses `--background R,G,B`: three finite, non-negative numbers.
fn parse_background(text: &str) -> Result<[f32; 3], String> {
    let parts: Vec<&str> = text.split(',').collect();
    let [r, g, b] = parts[..] else {
        return Err(format!(
            "expected three numbers R,G,B, e.g. 0.5,0.6,0.8, got '{text}'"
        ));
    };
    let parse = |s: &str| {
        let v = s
            .trim()
            .parse::<f32>()
            .map_err(|e| format!("'{}' in '{text}': {e}", s.trim()))?;
        if v.is_finite() && v >= 0.0 {
            Ok(v)
        } else {
            Err(format!(
                "'{}' in '{text}': a radiance must be finite and ≥ 0",
                s.trim()
            ))
        }
    };
    Ok([parse(r)?, parse(g)?, parse(b)?])
}

/// What a persistent cache's records depend on, hashed: every byte the scene was read from
/// (`digest`, the scene file and the buffers and images it names), the camera and the image
/// size, the cache's settings (their Debug text: every field, floats to the last bit), the
/// background (the cache stores its light too) and the seed (every gather's random numbers);
/// with `fill_samples`, the samples per pixel as well (its candidates are the camera samples).
pub fn cache_fingerprint(
    digest: u64,
    camera: &Camera,
    settings: &RenderSettings,
    ic: &IcSettings,
    background: [f32; 3],
) -> u64 {
    let view = format!("{camera:?} {}x{}", settings.width, settings.height);
    let spp = if ic.fill_samples { settings.spp } else { 0 };
    let rest = format!(
        "{ic:?} background {background:?} seed {} spp {spp}",
        settings.seed
    );
    fingerprint(&[&digest.to_le_bytes(), view.as_bytes(), rest.as_bytes()])
}

/// The debug view's output (`--show-records`): `<out stem>-records.exr`, beside `out`.
fn records_output(out: &Path) -> PathBuf {
    let stem = out
        .file_stem()
        .map_or_else(|| "render".into(), |s| s.to_string_lossy().into_owned());
    out.with_file_name(format!("{stem}-records.exr"))
}

/// Renders `scene_path` to `out` (OpenEXR, with the PNG preview beside it); the error is one
/// line naming the file or option and the problem.
pub fn run(args: RenderArgs, scene_path: &Path, out: &Path) -> Result<(), String> {
    let spp = args.spp.unwrap_or_else(|| default_spp(args.integrator));
    // Every option checked before the scene is loaded; the size is final once the camera's
    // aspect ratio is known.
    let (width, height) =
        RenderSettings::image_size(args.width, args.height, None).map_err(|e| e.to_string())?;
    RenderSettings::from_options(width.into(), height.into(), spp, args.seed, args.threads)
        .map_err(|e| e.to_string())?;
    check_exposure(args.exposure).map_err(|e| e.to_string())?;
    if !(args.fps.is_finite() && args.fps > 0.0) {
        return Err(format!("--fps: must be finite and > 0, got {}", args.fps));
    }
    if args.shared_cache {
        if args.frames.is_none() {
            return Err("--shared-cache: a cache shared by frames needs --frames A..B".into());
        }
        if args.integrator != IntegratorChoice::Ic {
            return Err("--shared-cache: works with --integrator ic only".into());
        }
        if args.cache_every == 0 {
            return Err("--cache-every: must be at least 1".into());
        }
        // The shared cache travels in irr's cache file format (between shards, and to the
        // frames), which holds irradiance records only.
        if args.ic.radiance_order > 0 {
            return Err("--shared-cache: a shared cache holds irradiance records only; use --radiance-order 0".into());
        }
    } else if args.shards != 1 || args.shard.is_some() {
        return Err("--shards, --shard: split the construction of a --shared-cache".into());
    }
    if !(1..=MAX_SHARDS).contains(&args.shards) {
        return Err(format!(
            "--shards: must be 1 to {MAX_SHARDS}, got {}",
            args.shards
        ));
    }
    if let Some(i) = args.shard
        && i >= args.shards
    {
        return Err(format!(
            "--shard: {i} is not below --shards {}",
            args.shards
        ));
    }
    if args.shard.is_some() && args.ic.cache.is_none() {
        return Err("--shard: name the shard's file with --cache FILE".into());
    }
    if args.frames.is_some() {
        if args.debug_pixel.is_some() {
            return Err("--debug-pixel: pick one frame with --frame N, not --frames".into());
        }
        // A view's cache file is fingerprinted to one camera: each frame would overwrite it.
        if args.ic.cache.is_some() && !args.shared_cache {
            return Err(
                "--cache: a view's cache file belongs to one camera; with --frames, add --shared-cache for one cache file for every frame"
                    .into(),
            );
        }
    }
    if args.denoise {
        if DENOISER.is_none() {
            return Err(format!("--denoise: {NO_DENOISER}"));
        }
        if args.debug_pixel.is_some() {
            return Err("--denoise: --debug-pixel writes no image to denoise".into());
        }
    }
    let ic_settings = match args.integrator {
        IntegratorChoice::Ic | IntegratorChoice::IcAo => Some(args.ic.settings(args.max_depth)?),
        _ => None,
    };
    if args.ic.cache.is_some() && args.integrator != IntegratorChoice::Ic {
        return Err("--cache: a persistent cache works with --integrator ic only".into());
    }
    // A cache file holds irradiance records only: a render read back from one would path-trace
    // the lobes the first one reflected from radiance records, a different image.
    if args.ic.cache.is_some() && args.ic.radiance_order > 0 {
        return Err(
            "--cache: cache files do not hold radiance records; use --radiance-order 0 with --cache"
                .into(),
        );
    }
    let scene_path = scene_path.to_path_buf();
    // Each frame's output (one entry, `out` itself, without --frames) and its time.
    let views: Vec<(PathBuf, Option<f64>)> = match args.frames {
        Some((a, b)) => (a..b)
            .map(|f| (frame_output(out, f), Some(f64::from(f) / args.fps)))
            .collect(),
        None => vec![(
            out.to_path_buf(),
            args.frame.map(|f| f64::from(f) / args.fps),
        )],
    };
    if args.debug_pixel.is_none() {
        // Before spending minutes: is there somewhere to put every result?
        for (out, _) in &views {
            check_output(out).map_err(|e| e.to_string())?;
            if args.ic.show_records {
                check_output(&records_output(out)).map_err(|e| e.to_string())?;
            }
        }
        if let Some(path) = &args.ic.cache {
            check_output_file(path).map_err(|e| format!("--cache: {e}"))?;
        }
    }
    let options = LoadOptions {
        asset_root: args.asset_root.clone(),
        max_memory: args.max_memory,
    };
    let loaded = {
        // The BVH build of a large (or badly shaped) scene can take a while: say so.
        let spinner = indicatif::ProgressBar::new_spinner();
        spinner.set_message(format!(
            "loading {} and building its BVH",
            scene_path.display()
        ));
        spinner.enable_steady_tick(std::time::Duration::from_millis(100));
        let started = Instant::now();
        let loaded = load_scene_with(&scene_path, &options);
        spinner.finish_and_clear();
        if started.elapsed().as_secs_f64() > 1.0 {
            eprintln!(
                "loaded {} and built its BVH in {:.1} s",
                scene_path.display(),
                started.elapsed().as_secs_f64()
            );
        }
        loaded.map_err(|e| e.to_string())?
    };
    let mut loaded = loaded;
    loaded.scene = loaded
        .scene
        .with_background(glam::Vec3::from_array(args.background))
        .map_err(|e| format!("--background: {e}"))?;
    for w in &loaded.warnings {
        eprintln!("warning: {w}");
    }
    if views.iter().any(|(_, t)| t.is_some()) {
        match loaded.camera_path(args.camera) {
            Some(path) => {
                let (start, end) = path.span();
                eprintln!(
                    "note: the camera's animation runs from {start} s to {end} s (frames {} to {} at {} fps)",
                    (f64::from(start) * args.fps).floor(),
                    (f64::from(end) * args.fps).ceil(),
                    args.fps
                );
            }
            None => eprintln!(
                "warning: {}: no animation moves the camera: every frame shows the same view",
                scene_path.display()
            ),
        }
    }
    if args.debug_pixel.is_none() {
        // From here on temporary output files may exist: delete them if the user interrupts.
        remove_partial_outputs_on_signals()?;
    }
    let shared = match (args.shared_cache, args.frames, ic_settings) {
        (true, Some(frames), Some(s)) => match shared_cache(&args, &loaded, frames, spp, s)? {
            Shared::Frames(ic) => Some(ic),
            Shared::ShardOnly => return Ok(()),
        },
        _ => None,
    };
    let shared = shared.as_deref();
    for (out, time) in &views {
        render_view(
            &args,
            &loaded,
            (&scene_path, out, *time),
            (spp, ic_settings),
            shared,
        )?;
    }
    Ok(())
}

/// The render settings of a view through `camera` (the file's, if it has one): the options'
/// size, the missing side from the camera's aspect ratio, and `spp` samples.
pub(crate) fn view_settings(
    args: &RenderArgs,
    camera: Option<&Camera>,
    spp: i64,
) -> Result<RenderSettings, String> {
    let (width, height) = RenderSettings::image_size(
        args.width,
        args.height,
        camera.and_then(|c| c.aspect_ratio_in_file),
    )
    .map_err(|e| e.to_string())?;
    RenderSettings::from_options(width.into(), height.into(), spp, args.seed, args.threads)
        .map_err(|e| e.to_string())
}

/// Renders one view of the loaded scene: through the chosen camera at `time` seconds of its
/// animation (`None`: the rest pose), to `out`.
fn render_view(
    args: &RenderArgs,
    loaded: &LoadedScene,
    (scene_path, out, time): (&Path, &Path, Option<f64>),
    (spp, ic_settings): (i64, Option<IcSettings>),
    shared: Option<&IrradianceCacheIntegrator>,
) -> Result<(), String> {
    let file_camera = loaded
        .choose_camera_at(args.camera, time)
        .map_err(|e| e.to_string())?;
    let settings = view_settings(args, file_camera.as_ref(), spp)?;
    let (width, height) = (settings.width, settings.height);
    if let Some((x, y)) = args.debug_pixel
        && (x >= width || y >= height)
    {
        return Err(format!(
            "--debug-pixel: pixel ({x}, {y}) is outside the {width}×{height} image"
        ));
    }
    if let Some(note) = file_camera.and_then(|c| loaded.aspect_note(&c, width, height)) {
        eprintln!("warning: {note}");
    }
    if loaded.cameras.len() > 1 {
        let i = args.camera.unwrap_or(0);
        let which = loaded
            .cameras
            .get(i)
            .map(|c| c.describe())
            .unwrap_or_default();
        eprintln!(
            "note: {} has {} perspective cameras; rendering through camera {i} ({which}); --camera N picks another",
            scene_path.display(),
            loaded.cameras.len()
        );
    }
    let camera = match file_camera {
        Some(c) => c,
        None => {
            eprintln!(
                "note: {} has no camera: irr frames the scene's bounds (without any triangle that alone stretches them {}×, such as a far ground plane) from +Z (a scene flat in y or x from above or from +X, tilted 45°) with a 45° vertical field of view",
                scene_path.display(),
                irr_render::OUTLIER_SPAN
            );
            Camera::framing(
                loaded.bounds.0,
                loaded.bounds.1,
                width as f32 / height as f32,
            )
        }
    };
    // (A shared cache's file is the sequence's, read and written before the frames.)
    let cache_fingerprint = match (&args.ic.cache, ic_settings) {
        (Some(_), Some(s)) if shared.is_none() => Some(cache_fingerprint(
            loaded.digest,
            &camera,
            &settings,
            &s,
            args.background,
        )),
        _ => None,
    };
    // A cache read from a file with the same fingerprint is what the same construction built,
    // every level of it: the passes are not run again.
    let mut cache_read = false;
    let mut ic_integrator = match (args.integrator, ic_settings, shared) {
        (IntegratorChoice::Ic, Some(s), None) => {
            let mut ic = IrradianceCacheIntegrator::new(s).map_err(|e| e.to_string())?;
            if let (Some(path), Some(fp)) = (&args.ic.cache, cache_fingerprint)
                && std::fs::symlink_metadata(path).is_ok()
            {
                let levels = read_cache_file(path, fp, &s, MAX_CACHE_FILE_BYTES)
                    .map_err(|e| e.to_string())?;
                let records: usize = levels.iter().map(|l| l.cache.len()).sum();
                eprintln!(
                    "read {records} records from {}: no construction pass",
                    path.display()
                );
                ic.load_levels(levels).map_err(|e| e.to_string())?;
                cache_read = true;
            }
            Some(ic)
        }
        _ => None,
    };
    let mut ao_integrator = match (args.integrator, ic_settings) {
        (IntegratorChoice::IcAo, Some(s)) if shared.is_none() => Some(
            CachedAmbientOcclusion::new(s, AoSettings::default().max_distance)
                .map_err(|e| e.to_string())?,
        ),
        _ => None,
    };
    let started = Instant::now();
    let mut plain: Box<dyn Integrator> = match args.integrator {
        IntegratorChoice::Ao => Box::new(AmbientOcclusion::new(AoSettings::default())),
        _ => Box::new(PathTracer::new(PathSettings {
            max_depth: args.max_depth,
            ..PathSettings::default()
        })),
    };
    plain.preprocess(&loaded.scene);
    let mut builder: Option<&mut dyn CacheBuilder> = match (&mut ic_integrator, &mut ao_integrator)
    {
        (Some(ic), _) => Some(ic),
        (_, Some(ao)) => Some(ao),
        _ => None,
    };
    if let Some(b) = builder.as_deref_mut() {
        b.preprocess(&loaded.scene);
    }
    // A cache read back keeps its records, not its light cache: rebuilt (the same bits, from
    // the same seed) for the final pass's own gathers.
    if let Some(b) = builder.as_deref_mut()
        && cache_read
        && let Some(light) =
            build_light_cache(&loaded.scene, &camera, b, &settings).map_err(|e| e.to_string())?
    {
        eprintln!(
            "rebuilt the light cache for the final pass: {} paths in {:.2} s",
            light.counts.paths, light.seconds
        );
    }
    if let Some(b) = builder.as_deref_mut()
        && !cache_read
    {
        let stats = build_cache(
            &loaded.scene,
            &camera,
            b,
            &settings,
            ic_settings.is_some_and(|s| s.fill_samples),
            args.debug_pixel.is_none(),
        )
        .map_err(|e| e.to_string())?;
        eprintln!("{}", stats.summary());
    }
    // A shared cache was built for every frame: this frame only reads it.
    let builder: Option<&dyn CacheBuilder> = builder
        .map(|b| &*b)
        .or(shared.map(|s| s as &dyn CacheBuilder));
    let integrator: &dyn Integrator = match builder {
        Some(b) => b,
        None => &*plain,
    };

    if let Some((x, y)) = args.debug_pixel {
        let samples = pixel_samples(&loaded.scene, &camera, integrator, &settings, x, y)
            .map_err(|e| e.to_string())?;
        for (i, l) in samples.iter().enumerate() {
            println!("sample {i}: {} {} {}", l.x, l.y, l.z);
        }
        let mean = mean_of_samples(&samples);
        println!(
            "pixel ({x}, {y}), seed {}, {} samples: mean {} {} {}",
            settings.seed, settings.spp, mean.x, mean.y, mean.z
        );
        return Ok(());
    }

    let mut aovs = args.aov.clone();
    if args.denoise {
        aovs.extend(DENOISER_AOVS);
    }
    let mut output = render_with_aovs(&loaded.scene, &camera, integrator, &settings, &aovs, true)
        .map_err(|e| e.to_string())?;
    eprintln!("{}", output.stats.summary());
    if let (true, Some(name)) = (args.denoise, DENOISER) {
        let denoise_started = Instant::now();
        let denoised = denoise(&output.image, &output.aovs).map_err(|e| e.to_string())?;
        let raw = std::mem::replace(&mut output.image, denoised);
        output.aovs.insert(Aov::Noisy, raw);
        eprintln!(
            "denoised with {name} in {:.2} s",
            denoise_started.elapsed().as_secs_f64()
        );
    }
    let render_seconds = started.elapsed().as_secs_f64();
    let mean = output.image.mean();
    eprintln!("image mean radiance: {} {} {}", mean.x, mean.y, mean.z);
    // (A shared cache's counts add up over the frames: printed per frame they would mislead.)
    if let Some(b) = builder.filter(|_| shared.is_none()) {
        let misses = b.final_pass_misses();
        let samples =
            u64::from(settings.width) * u64::from(settings.height) * u64::from(settings.spp);
        let share = |n: u64| 100.0 * n as f64 / samples.max(1) as f64;
        eprintln!(
            "cache queries: {:.3} % of camera samples found no record ({}); {} read the records within their pixel's reach; {} gathers for the rest ({:.3} % of samples)",
            share(misses.samples),
            misses.samples,
            misses.within_reach,
            misses.gathers,
            share(misses.gathers)
        );
    }
    if output.stats.non_finite_samples > 0 {
        eprintln!(
            "warning: {} samples were NaN or infinite and counted as black; replay one with --debug-pixel",
            output.stats.non_finite_samples
        );
    }
    let metadata = ExrMetadata {
        software: format!("irr {}", env!("CARGO_PKG_VERSION")),
        scene: scene_path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
        integrator: output.stats.integrator.to_string(),
        settings: match (args.integrator, ic_settings) {
            (IntegratorChoice::Ic, Some(s)) => format!("{s:?}"),
            (IntegratorChoice::IcAo, Some(s)) => format!(
                "{s:?}, ambient occlusion max_distance: {}",
                AoSettings::default().max_distance
            ),
            (IntegratorChoice::Ao, _) => format!("{:?}", AoSettings::default()),
            _ => format!(
                "{:?}",
                PathSettings {
                    max_depth: args.max_depth,
                    ..PathSettings::default()
                }
            ),
        } + &match (args.denoise, DENOISER) {
            (true, Some(name)) => format!("; denoised by {name}, the raw colour in noisy.R/G/B"),
            _ => String::new(),
        },
        spp: settings.spp,
        seed: settings.seed,
        render_seconds,
        camera,
    };
    let (exr, png) = write_render(&output.image, &output.aovs, &metadata, out, args.exposure)
        .map_err(|e| e.to_string())?;
    println!("wrote {} and {}", exr.display(), png.display());
    if let (true, Some(b)) = (args.ic.show_records, builder) {
        let view = mark_records(&output.image, &camera, &b.records_for_display());
        let (exr, png) = write_exr_and_png(&view, &records_output(out), args.exposure)
            .map_err(|e| e.to_string())?;
        println!(
            "wrote {} and {} (records marked)",
            exr.display(),
            png.display()
        );
    }
    if let (Some(path), Some(fp), Some(ic)) = (&args.ic.cache, cache_fingerprint, &ic_integrator)
        && !cache_read
    {
        write_cache_file(path, fp, ic).map_err(|e| e.to_string())?;
        println!("wrote the cache's records to {}", path.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: RenderArgs,
    }

    #[test]
    fn defaults_and_negative_numbers_parse() {
        let cli = Cli::try_parse_from(["render"]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            (
                cli.args.width,
                cli.args.height,
                cli.args.spp,
                cli.args.camera
            ),
            (None, None, None, None)
        );
        assert!(cli.args.aov.is_empty());
        assert_eq!(cli.args.integrator, IntegratorChoice::Ic);
        assert_eq!(default_spp(IntegratorChoice::Path), 256);
        assert_eq!(
            cli.args.ic.settings(cli.args.max_depth),
            Ok(IcSettings::default())
        );
        // Negative sizes reach the library's range check, which names the option.
        let cli = Cli::try_parse_from(["render", "--width", "-5", "--debug-pixel", "3,4"])
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(cli.args.debug_pixel, Some((3, 4)));
        let e = run(
            cli.args,
            Path::new("/nonexistent/scene.gltf"),
            Path::new("/nonexistent/out.exr"),
        )
        .err()
        .unwrap_or_default();
        assert_eq!(e, "--width: must be between 1 and 16384, got -5");
    }

    /// A bad exposure or seed is refused before anything is loaded or
    /// rendered, naming the option.
    #[test]
    fn bad_exposure_and_seed_are_refused_up_front() {
        for exposure in ["NaN", "inf", "-inf"] {
            let option = format!("--exposure={exposure}");
            let cli = Cli::try_parse_from(["render", &option]).unwrap_or_else(|e| panic!("{e}"));
            // The scene does not exist: an error about it would mean the exposure was not
            // checked first.
            let e = run(
                cli.args,
                Path::new("/nowhere/scene.gltf"),
                Path::new("/nowhere/out.exr"),
            )
            .err()
            .unwrap_or_default();
            assert!(
                e.starts_with("--exposure: must be a finite number of stops"),
                "{exposure}: {e}"
            );
        }
        let e = Cli::try_parse_from(["render", "--seed", "-1"])
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("'-1'") && e.contains("--seed"), "{e}");
        assert!(!e.contains("unexpected argument"), "{e}");
    }

    /// `--aov` takes a comma-separated list; a name it does not know is refused by the parser,
    /// naming the option, the bad value and every valid name.
    #[test]
    fn aov_lists_parse_and_bad_names_list_the_valid_ones() {
        let cli = Cli::try_parse_from(["render", "--aov", "albedo,normal", "--aov", "depth"])
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(cli.args.aov, [Aov::Albedo, Aov::Normal, Aov::Depth]);
        let e = Cli::try_parse_from(["render", "--aov", "albedo,foo"])
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("--aov") && e.contains("'foo'"), "{e}");
        assert!(
            e.contains("albedo, normal, depth, emitted, direct, indirect, glossy-indirect"),
            "{e}"
        );
        assert_eq!(
            default_output(Path::new("/a/b/scene.gltf")),
            Path::new("scene.exr")
        );
    }

    /// `--background`: black by default, three finite non-negative numbers otherwise, anything
    /// else refused by clap with a message that names the option and the problem.
    #[test]
    fn backgrounds_parse_and_bad_ones_are_refused() {
        let cli = Cli::try_parse_from(["render"]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(cli.args.background, [0.0; 3]);
        let cli = Cli::try_parse_from(["render", "--background", "0.5, 1,2e1"])
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(cli.args.background, [0.5, 1.0, 20.0]);
        for (bad, why) in [
            ("1,2", "expected three numbers"),
            ("1,2,3,4", "expected three numbers"),
            ("1,x,3", "'x' in '1,x,3'"),
            ("1,-2,3", "finite and ≥ 0"),
            ("-1,2,3", "finite and ≥ 0"),
            ("1,2,NaN", "finite and ≥ 0"),
            ("inf,2,3", "finite and ≥ 0"),
        ] {
            let e = Cli::try_parse_from(["render", "--background", bad])
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default();
            assert!(e.contains("--background") && e.contains(why), "{bad}: {e}");
        }
    }

    /// `--background` reaches the scene: assets/ao-plane.gltf is a plane of albedo 0.5 under
    /// nothing, filling the camera's view, so under a background L every path-traced sample is
    /// 0.5·L (the cosine sample always escapes; one f32 product, exact here: 0.5 times a power
    /// of two), and so is every pixel of the EXR written.
    #[test]
    fn the_background_lights_the_scene() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let out = dir.path().join("plane.exr");
        let cli = Cli::try_parse_from([
            "render",
            "--integrator",
            "path",
            "--width",
            "4",
            "--height",
            "4",
            "--spp",
            "2",
            "--background",
            "0.5,1,2",
        ])
        .unwrap_or_else(|e| panic!("{e}"));
        let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/ao-plane.gltf");
        run(cli.args, &scene, &out).unwrap_or_else(|e| panic!("{e}"));
        let image = irr_render::Image::read_exr(&out).unwrap_or_else(|e| panic!("{e}"));
        assert!(
            image
                .pixels()
                .iter()
                .all(|p| *p == glam::Vec3::new(0.25, 0.5, 1.0)),
            "{:?}",
            image.pixels()
        );
    }

    #[test]
    fn bad_pixels_are_refused() {
        assert!(parse_pixel("3").is_err());
        assert!(parse_pixel("3,-1").is_err());
        assert_eq!(parse_pixel(" 3, 4"), Ok((3, 4)));
        assert_eq!(parse_size("12G"), Ok(12 << 30));
        assert_eq!(parse_size("1.5 GiB"), Ok(3 << 29));
        assert_eq!(parse_size("512m"), Ok(512 << 20));
        assert_eq!(parse_size("1048576"), Ok(1 << 20));
        for bad in ["", "G", "12X", "-1G", "0", "nanG", "1e30", "inf"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }
}
