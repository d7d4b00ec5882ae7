//! `cargo xtask compare`: the speed/accuracy trade of the irradiance cache against what a user
//! would otherwise run, the path tracer, raw and denoised, measured on a list of scenes.
//!
//! For each scene:
//! 1. A reference ([`reference`](mod@reference)): the path tracer at high spp, non-adaptive, as
//!    two halves of their own seeds, cached under target/compare/cache/ by everything that
//!    decides its pixels (the scene's bytes, the size, the samples, the seeds, the path
//!    tracer's settings, the renderer's source). relMSE between the halves / 4 is its own
//!    noise, printed beside every error.
//! 2. Runs, each setting with every seed of [`run_seeds`] (`--seeds`; the light cache's paths
//!    draw from the same seed as the pixels) and timed `--repeats` times, the renders
//!    interleaved round-robin over the settings ([`stats`]): a setting's errors are the means
//!    over its seeds, relMSE ± its standard error across them, and its time the mean over the
//!    seeds of each seed's median. The settings: the path tracer over spp and with its adaptive
//!    sampling, raw and denoised by OIDN; the
//!    irradiance cache along its κ ladder, raw and denoised; the Hessian metric's ladder (its
//!    accuracy a with the strata, beside the κ ladder); on a scene with glossy materials, the
//!    κ ladder with radiance records for the glossy lobes (raw and denoised) and other orders
//!    and thresholds
//!    (module `radiance` of irr-integrator's cache); and the cache's ablations (other
//!    strata, gradients, clamping, bounce modes, radius statistic, adaptive gathers). A
//!    denoised run's time includes the auxiliary images and the denoiser.
//! 3. A report in target/compare/SCENE/ (`runs.csv`, `report.md`, `plot.svg`, heat maps,
//!    crops): each method's front along its primary series, and at each error level which of
//!    the four methods is fastest, with FLIP beside relMSE ([`figures`]); it names the seeds,
//!    the repeats and the machine, and whether the defaults were tuned on the scene
//!    ([`TUNED_SCENES`]). After the last scene, a summary (target/compare/summary.md) puts the
//!    tuned scenes and the others in two tables.
//!
//! With `--layer indirect|glossy-indirect` every image, the reference's too, is that AOV of
//! the render (a denoised run denoises it), and the report goes to
//! target/compare/SCENE-LAYER/: the glossy share of the indirect light is how radiance
//! caching is judged against path-tracing the lobes.

mod figures;
pub mod metrics;
mod pictures;
mod reference;
pub mod stats;

use clap::{Args, ValueEnum};
use figures::{Curve, Group, Method, Run, level_rows, pareto_front};
use irr_render::{
    Aov, BounceMode, CacheBuilder, DENOISER, DENOISER_AOVS, GradientMode, IcSettings, Image,
    Integrator, IrradianceCacheIntegrator, LoadedScene, MetricKind, PathSettings, PathTracer,
    RadiusStatistic, RenderSettings, build_cache, denoise, load_scene, render_with_aovs,
};
use metrics::{metrics, metrics_with_flip};
use pictures::{HEAT_MAP_MAX, worst_window, write_crops, write_heat_map, write_plot};
use reference::reference;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The scenes compared by default, in assets/: the Cornell box (direct light dominates), a room
/// lit only by bounced light (what an irradiance cache is for) and a textured room (detail a
/// denoiser blurs).
pub const DEFAULT_SCENES: [&str; 3] = [
    "cornell-box.gltf",
    "indirect-room.gltf",
    "textured-room.gltf",
];

/// The scenes in assets/ the defaults were tuned on (docs/performance.md measures the cache's
/// settings on them): a figure on one of them is not a held-out result. Any other scene
/// (`--scenes`) is only reported, and the summary lists it apart.
pub const TUNED_SCENES: [&str; 4] = [
    "cornell-box.gltf",
    "indirect-room.gltf",
    "glossy-room.gltf",
    "textured-room.gltf",
];

/// Whether `scene` is one of [`TUNED_SCENES`] in the workspace's assets/ (the same file, however
/// its path is written; the workspace is this checkout's, wherever the report goes).
pub fn tuned(scene: &Path) -> bool {
    let (Ok(scene), Ok(root)) = (scene.canonicalize(), crate::workspace_root()) else {
        return false;
    };
    TUNED_SCENES.iter().any(|s| {
        root.join("assets")
            .join(s)
            .canonicalize()
            .is_ok_and(|t| t == scene)
    })
}

/// Compare the irradiance cache with the path tracer, raw and denoised, on a list of scenes.
#[derive(Args, Debug)]
pub struct CompareArgs {
    /// The glTF 2.0 scenes, comma-separated [default: assets/cornell-box.gltf,
    /// assets/indirect-room.gltf, assets/textured-room.gltf in the workspace]
    #[arg(long = "scenes", alias = "scene", value_delimiter = ',')]
    pub scenes: Vec<PathBuf>,
    /// Image width in pixels
    #[arg(long, default_value_t = 256)]
    pub width: u32,
    /// Image height in pixels
    #[arg(long, default_value_t = 256)]
    pub height: u32,
    /// A small version: 48×48, a few settings
    #[arg(long)]
    pub quick: bool,
    /// Seeds per setting (at least 2): each setting, the path tracer's too, is rendered with
    /// seeds 1 to N, and its errors are the mean over them ± the standard error across them
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(2..))]
    pub seeds: u32,
    /// Timed renders per setting and seed, interleaved round-robin over the settings; a
    /// setting's time for a seed is their median
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..))]
    pub repeats: u32,
    /// Render the references again even if cached ones exist
    #[arg(long)]
    pub fresh: bool,
    /// Samples per pixel of the reference (both halves together)
    #[arg(long)]
    pub reference_spp: Option<u32>,
    /// Worker threads; 0 means one per core
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Camera samples per pixel of the irradiance-cache runs (the default render's)
    #[arg(long, default_value_t = irr_cli::render::IC_DEFAULT_SPP as u32)]
    pub ic_spp: u32,
    /// Camera samples per pixel of the denoised irradiance-cache runs
    #[arg(long, default_value_t = DENOISED_IC_SPP)]
    pub denoised_ic_spp: u32,
    /// Light samples per camera hit of the irradiance-cache runs (the default render's)
    #[arg(long, default_value_t = IcSettings::default().direct_samples)]
    pub direct_samples: u32,
    /// Keep only the runs whose method and settings ("path spp=16", "ic+oidn kappa=1
    /// strata=16x64", …) contain this text
    #[arg(long)]
    pub only: Option<String>,
    /// More irradiance-cache settings to run, as KAPPA:MxN[:cached|:path|:light-cache] (the bounce mode;
    /// default: the default render's), comma-separated
    #[arg(long, value_delimiter = ',')]
    pub extra: Vec<String>,
    /// Also copy each report, plot, heat maps and crops to docs/compare/SCENE/ and write the
    /// scene's summary line (the cache's default run against the path tracer, linking the
    /// report) into README.md
    #[arg(long)]
    pub publish: bool,
    /// Score every run and the reference on this layer of the image: the image itself, its
    /// indirect part (the cache's share) or that part's glossy share (what radiance caching
    /// replaces); a denoised run denoises the layer. Other layers report to
    /// target/compare/SCENE-LAYER/
    #[arg(long, value_enum, default_value_t = Layer::Colour)]
    pub layer: Layer,
}

/// Which layer of each image a comparison scores ([`CompareArgs::layer`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum Layer {
    /// The image.
    #[default]
    Colour,
    /// Its indirect part (`--aov indirect`).
    Indirect,
    /// The indirect part's glossy share (`--aov glossy-indirect`).
    GlossyIndirect,
}

impl Layer {
    /// The AOV that holds it; `None` for the image itself.
    pub fn aov(self) -> Option<Aov> {
        match self {
            Layer::Colour => None,
            Layer::Indirect => Some(Aov::Indirect),
            Layer::GlossyIndirect => Some(Aov::GlossyIndirect),
        }
    }
}

/// Samples per pixel of the reference by default (both halves together).
pub const REFERENCE_SPP: u32 = 8192;

/// Samples per pixel of the reference with `--quick` (48×48): enough that the indirect-lit
/// room's reference carries under a tenth of the quick cache runs' error.
pub const QUICK_REFERENCE_SPP: u32 = 2048;

/// Camera samples per pixel of the denoised cache runs by default: the denoiser removes the
/// anti-aliasing's and the direct light's noise that the raw cache needs its 36 samples for
/// (docs/performance.md, "Denoised cache").
pub const DENOISED_IC_SPP: u32 = 16;

/// What one scene's comparison measured, for the caller (and the test).
#[derive(Debug)]
pub struct Report {
    /// Every run.
    pub runs: Vec<Run>,
    /// The reference's own relMSE.
    pub reference_noise: f64,
    /// One irradiance-cache image's own noise at the tightest ladder setting (relMSE between
    /// two seeds, halved).
    pub ic_noise: f64,
    /// The report's folder.
    pub folder: PathBuf,
    /// The scene.
    pub scene: PathBuf,
    /// Whether the defaults were tuned on it ([`TUNED_SCENES`]).
    pub tuned: bool,
}

/// Renders with the path tracer (adaptive where `path.pixel_error` > 0), denoised if asked: the
/// image, wall-clock seconds (all of it), of which the denoiser's, and rays.
fn path_render(
    loaded: &LoadedScene,
    settings: &RenderSettings,
    path: PathSettings,
    (denoised, layer): (bool, Layer),
) -> Result<(Image, f64, f64, u64), String> {
    let start = Instant::now();
    let mut pt = PathTracer::new(path);
    pt.preprocess(&loaded.scene);
    let camera = loaded.camera_for(settings.width, settings.height);
    finish(loaded, &camera, &pt, settings, (denoised, layer), start)
}

/// Renders with the irradiance cache, construction and final pass (and the denoiser) timed
/// together: the image (its `layer`), seconds, of which the denoiser's, rays and records.
pub fn ic_render(
    loaded: &LoadedScene,
    settings: &RenderSettings,
    ic: IcSettings,
    (denoised, layer): (bool, Layer),
) -> Result<(Image, f64, f64, u64, usize), String> {
    let start = Instant::now();
    let mut integrator = IrradianceCacheIntegrator::new(ic).map_err(|e| e.to_string())?;
    integrator.preprocess(&loaded.scene);
    let camera = loaded.camera_for(settings.width, settings.height);
    let build = build_cache(
        &loaded.scene,
        &camera,
        &mut integrator,
        settings,
        ic.fill_samples,
        false,
    )
    .map_err(|e| e.to_string())?;
    let (image, seconds, denoise_seconds, rays) = finish(
        loaded,
        &camera,
        &integrator,
        settings,
        (denoised, layer),
        start,
    )?;
    let records = integrator.record_counts().iter().sum();
    Ok((
        image,
        seconds,
        denoise_seconds,
        rays + build.rays().total(),
        records,
    ))
}

/// The final pass (with the denoiser's auxiliary images and the denoiser if asked), timed from
/// `start`: `layer` of its image, denoised if asked.
fn finish(
    loaded: &LoadedScene,
    camera: &irr_render::Camera,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    (denoised, layer): (bool, Layer),
    start: Instant,
) -> Result<(Image, f64, f64, u64), String> {
    let mut aovs: Vec<Aov> = if denoised {
        DENOISER_AOVS.to_vec()
    } else {
        Vec::new()
    };
    aovs.extend(layer.aov());
    let out = render_with_aovs(&loaded.scene, camera, integrator, settings, &aovs, false)
        .map_err(|e| e.to_string())?;
    let rays = out.stats.rays.total();
    let image = match layer.aov() {
        None => out.image,
        Some(aov) => out
            .aovs
            .get(aov)
            .cloned()
            .ok_or_else(|| format!("the render made no {aov} image"))?,
    };
    if !denoised {
        return Ok((image, start.elapsed().as_secs_f64(), 0.0, rays));
    }
    let before = Instant::now();
    let image = denoise(&image, &out.aovs).map_err(|e| e.to_string())?;
    let denoise_seconds = before.elapsed().as_secs_f64();
    Ok((image, start.elapsed().as_secs_f64(), denoise_seconds, rays))
}

/// One setting of the irradiance-cache sweep.
struct Sweep {
    label: String,
    group: Group,
    kappa: f32,
    settings: IcSettings,
}

/// The κ ladder: κ with M×N growing alongside (the consistency claim is about both).
fn ladder(quick: bool) -> &'static [(f32, u32, u32)] {
    if quick {
        &[(0.5, 6, 24), (1.0, 8, 32), (2.0, 12, 48)]
    } else {
        &[
            (0.25, 8, 32),
            (0.5, 12, 48),
            (1.0, 16, 64),
            (2.0, 24, 96),
            (4.0, 32, 128),
        ]
    }
}

/// The order and threshold of the radiance ladder (`radiance_sweep`).
const RADIANCE_ORDER: u32 = 6;
const RADIANCE_ERROR: f32 = 0.3;

/// Radiance caching's rows, on a scene with glossy materials: the κ ladder with radiance
/// records ([`RADIANCE_ORDER`], [`RADIANCE_ERROR`]), then other orders and thresholds at the
/// default κ.
fn radiance_sweep(base: IcSettings) -> Vec<Sweep> {
    let mut out: Vec<Sweep> = ladder(false)
        .iter()
        .map(|&(k, m, n)| Sweep {
            label: format!("radiance-order={RADIANCE_ORDER} kappa={k} strata={m}x{n}"),
            group: Group::Radiance,
            kappa: k,
            settings: IcSettings {
                error: k,
                strata_m: m,
                strata_n: n,
                radiance_order: RADIANCE_ORDER,
                radiance_error: RADIANCE_ERROR,
                ..base
            },
        })
        .collect();
    for (order, error) in [
        (4, RADIANCE_ERROR),
        (8, RADIANCE_ERROR),
        (10, RADIANCE_ERROR),
        (RADIANCE_ORDER, 0.1),
        (RADIANCE_ORDER, 1.0),
    ] {
        out.push(Sweep {
            label: format!("radiance-order={order} radiance-error={error}"),
            group: Group::Variant,
            kappa: base.error,
            settings: IcSettings {
                radiance_order: order,
                radiance_error: error,
                ..base
            },
        });
    }
    // The records with the lobes beyond them split further: the sharp lobes' noise is then
    // what is left of a pixel's (docs/performance.md, "Filtered light-cache reads").
    out.push(Sweep {
        label: format!("radiance-order=10 radiance-error={RADIANCE_ERROR} glossy-samples=32"),
        group: Group::Variant,
        kappa: base.error,
        settings: IcSettings {
            radiance_order: 10,
            radiance_error: RADIANCE_ERROR,
            glossy_samples: 32,
            ..base
        },
    });
    out
}

/// The irradiance-cache settings of the sweep: the ladder, then the ablations; with `glossy`
/// (the scene has a glossy material), one lobe sample a camera sample (`glossy-samples=1`) and
/// radiance caching's rows.
fn ic_sweep(quick: bool, glossy: bool) -> Vec<Sweep> {
    let base = IcSettings::default();
    let mut out: Vec<Sweep> = ladder(quick)
        .iter()
        .map(|&(k, m, n)| Sweep {
            label: format!("kappa={k} strata={m}x{n}"),
            group: Group::Ladder,
            kappa: k,
            settings: IcSettings {
                error: k,
                strata_m: m,
                strata_n: n,
                // The quick ladder's rungs take one ray per stratum: at 48² the default gather
                // target lifts its loose rungs to the quick reference's own noise, leaving the
                // ladder too little range for its consistency check (the full ladder keeps it).
                gather_error: if quick { 0.0 } else { base.gather_error },
                ..base
            },
        })
        .collect();
    if quick {
        return out;
    }
    for &(m, n) in &[(12u32, 48u32), (24, 96), (32, 128)] {
        out.push(Sweep {
            label: format!("strata={m}x{n}"),
            group: Group::Strata,
            kappa: base.error,
            settings: IcSettings {
                strata_m: m,
                strata_n: n,
                ..base
            },
        });
    }
    // The Hessian metric's ladder, its a chosen so that each rung's record count is near the κ
    // ladder's (on the Cornell box: a ≈ 0.85 gives κ 0.65's count, a ≈ 0.5 κ 1.06's).
    for &(a, m, n) in &[
        (2.5f32, 8u32, 32u32),
        (1.1, 12, 48),
        (0.5, 16, 64),
        (0.35, 24, 96),
        (0.25, 32, 128),
    ] {
        out.push(Sweep {
            label: format!("metric=hessian a={a} strata={m}x{n}"),
            group: Group::Hessian,
            kappa: base.error,
            settings: IcSettings {
                metric: MetricKind::Hessian,
                error: a,
                strata_m: m,
                strata_n: n,
                ..base
            },
        });
    }
    let variants = [
        (
            "gradients=off",
            IcSettings {
                gradients: GradientMode::Off,
                ..base
            },
        ),
        (
            "gradients=krivanek-gautron",
            IcSettings {
                gradients: GradientMode::KrivanekGautron,
                ..base
            },
        ),
        (
            "neighbour-clamping=off",
            IcSettings {
                neighbour_clamping: false,
                ..base
            },
        ),
        (
            "bounce=path-traced",
            IcSettings {
                bounce_mode: BounceMode::PathTraced,
                ..base
            },
        ),
        (
            "bounce=cached",
            IcSettings {
                bounce_mode: BounceMode::Cached,
                ..base
            },
        ),
        (
            "bounce=cached bounces=2",
            IcSettings {
                bounce_mode: BounceMode::Cached,
                cached_bounces: 2,
                ..base
            },
        ),
        (
            "light-cache-cell=1/128",
            IcSettings {
                light_cache_cell: 1.0 / 128.0,
                light_cache_paths: 4 * base.light_cache_paths,
                ..base
            },
        ),
        (
            "radius-statistic=harmonic",
            IcSettings {
                radius_statistic: RadiusStatistic::HarmonicMean,
                ..base
            },
        ),
        (
            "gather-error=0",
            IcSettings {
                gather_error: 0.0,
                ..base
            },
        ),
        (
            "gather-error=0.03",
            IcSettings {
                gather_error: 0.03,
                ..base
            },
        ),
        (
            "pixel-error=0",
            IcSettings {
                pixel_error: 0.0,
                ..base
            },
        ),
    ];
    for (label, settings) in variants {
        out.push(Sweep {
            label: label.into(),
            group: Group::Variant,
            kappa: base.error,
            settings,
        });
    }
    if glossy {
        // The path-traced glossy lobes with one sample a camera sample, as before
        // `--glossy-samples`, so that every glossy report shows what the split lobes buy.
        out.push(Sweep {
            label: "glossy-samples=1".into(),
            group: Group::Variant,
            kappa: base.error,
            settings: IcSettings {
                glossy_samples: 1,
                ..base
            },
        });
        out.extend(radiance_sweep(base));
    }
    out
}

/// An extra setting KAPPA:MxN[:cached|:path|:light-cache].
fn parse_extra(text: &str) -> Result<IcSettings, String> {
    let parts: Vec<&str> = text.split(':').collect();
    let bad = || format!("--extra: expected KAPPA:MxN[:cached|:path|:light-cache], got '{text}'");
    let kappa: f32 = parts.first().and_then(|k| k.parse().ok()).ok_or_else(bad)?;
    let (m, n) = parts
        .get(1)
        .and_then(|s| s.split_once('x'))
        .and_then(|(m, n)| Some((m.parse().ok()?, n.parse().ok()?)))
        .ok_or_else(bad)?;
    let bounce_mode = match parts.get(2) {
        None => IcSettings::default().bounce_mode,
        Some(&"cached") => BounceMode::Cached,
        Some(&"path") => BounceMode::PathTraced,
        Some(&"light-cache") => BounceMode::LightCache,
        Some(_) => return Err(bad()),
    };
    let s = IcSettings {
        error: kappa,
        strata_m: m,
        strata_n: n,
        bounce_mode,
        ..IcSettings::default()
    };
    s.validate().map_err(|e| format!("--extra {text}: {e}"))?;
    Ok(s)
}

/// One render to measure.
struct Job {
    method: Method,
    group: Group,
    label: String,
    kappa: f32,
    /// `None` for the path tracer.
    ic: Option<IcSettings>,
    /// The path tracer's settings (its adaptive sampling); unused by the cache.
    path: PathSettings,
    spp: u32,
}

/// A path-tracer setting with adaptive sampling: (spp, pixel error).
type Adaptive = (u32, f32);

/// The path tracer's adaptive rows: (spp, pixel error), its pixels stopping at a quarter, half
/// or all of `spp` once their mean's relative standard error reaches the target
/// ([`PathSettings::pixel_error`]); raw, then denoised. Each target is two to three times a
/// typical pixel's relative error at `spp` on the Cornell box (√relMSE: 0.018 at 256 spp, 0.009
/// at 1024), so a quiet pixel stops at a quarter of `spp` and a noisy one goes on.
fn adaptive_path(quick: bool) -> (&'static [Adaptive], &'static [Adaptive]) {
    if quick {
        (&[(64, 0.1)], &[(16, 0.2)])
    } else {
        (&[(256, 0.05), (1024, 0.02)], &[(64, 0.1), (256, 0.05)])
    }
}

/// Every render of a scene's comparison, in order.
fn jobs(args: &CompareArgs, denoiser: bool, glossy: bool) -> Result<Vec<Job>, String> {
    let mut out = Vec::new();
    let (path_spps, denoised_spps): (&[u32], &[u32]) = if args.quick {
        (&[4, 16, 64], &[4, 16])
    } else {
        (&[16, 64, 256, 1024], &[4, 16, 64, 256])
    };
    let path_job = |method: Method, spp: u32, pixel_error: f32| Job {
        method,
        group: if pixel_error > 0.0 {
            Group::Adaptive
        } else {
            Group::Spp
        },
        label: if pixel_error > 0.0 {
            format!("spp={spp} pixel-error={pixel_error}")
        } else {
            format!("spp={spp}")
        },
        kappa: f32::NAN,
        ic: None,
        path: PathSettings {
            pixel_error,
            ..PathSettings::default()
        },
        spp,
    };
    let (adaptive, adaptive_denoised) = adaptive_path(args.quick);
    for &spp in path_spps {
        out.push(path_job(Method::Path, spp, 0.0));
    }
    for &(spp, e) in adaptive {
        out.push(path_job(Method::Path, spp, e));
    }
    for &spp in denoised_spps.iter().filter(|_| denoiser) {
        out.push(path_job(Method::PathDenoised, spp, 0.0));
    }
    for &(spp, e) in adaptive_denoised.iter().filter(|_| denoiser) {
        out.push(path_job(Method::PathDenoised, spp, e));
    }
    let mut sweep = ic_sweep(args.quick, glossy);
    for extra in &args.extra {
        sweep.push(Sweep {
            label: format!("extra {extra}"),
            group: Group::Extra,
            kappa: f32::NAN,
            settings: parse_extra(extra)?,
        });
    }
    let cache_job = |sw: &Sweep, method: Method, spp: u32| Job {
        method,
        group: sw.group,
        label: sw.label.clone(),
        kappa: sw.kappa,
        ic: Some(IcSettings {
            direct_samples: args.direct_samples,
            ..sw.settings
        }),
        path: PathSettings::default(),
        spp,
    };
    for sw in &sweep {
        out.push(cache_job(sw, Method::Cache, args.ic_spp));
    }
    for sw in sweep
        .iter()
        .filter(|s| denoiser && matches!(s.group, Group::Ladder | Group::Radiance))
    {
        out.push(cache_job(sw, Method::CacheDenoised, args.denoised_ic_spp));
    }
    out.retain(|j| {
        args.only
            .as_deref()
            .is_none_or(|o| format!("{} {}", j.method.name(), j.label).contains(o))
    });
    Ok(out)
}

/// Runs `cargo xtask compare`.
pub fn run(args: CompareArgs, root: &Path) -> Result<(), String> {
    let mut reports = Vec::new();
    for scene in scenes(&args, root) {
        let report = compare(&args, &scene, root)?;
        if args.publish {
            publish(&report, root)?;
        }
        println!(
            "{}: {} settings × {} seeds × {} repeats; reference noise {:.2e}, one cache image's noise {:.2e}; wrote {} (report.md, runs.csv, seeds.csv, plot.svg, heat maps, crops)",
            scene.display(),
            report.runs.len(),
            args.seeds,
            args.repeats,
            report.reference_noise,
            report.ic_noise,
            report.folder.display()
        );
        reports.push(report);
    }
    let machine = stats::Machine::this();
    let mut md = format!(
        "## Summary\n\nSeeds 1–{} per setting, each time the median of {} interleaved runs; {}, \
         {} cores ({} logical), rendering on {} threads. The cache's default κ against the path \
         tracer's time for its error (~: beyond its runs, by its fit).\n",
        args.seeds,
        args.repeats,
        machine.model,
        machine.cores,
        machine.logical,
        rayon_threads(args.threads)
    );
    for (tuned, title) in [
        (true, "Scenes the defaults were tuned on"),
        (false, "Scenes only reported (held out)"),
    ] {
        let rows: Vec<&Report> = reports.iter().filter(|r| r.tuned == tuned).collect();
        if !rows.is_empty() {
            let _ = write!(md, "\n{title}:\n\n{}", summary_table(&rows));
        }
    }
    let path = root.join("target").join("compare").join("summary.md");
    std::fs::write(&path, &md).map_err(|e| format!("{}: {e}", path.display()))?;
    println!("{md}");
    Ok(())
}

/// One row per scene: its cache run at the default κ (the ladder's rung, else its middle one),
/// relMSE ± s.e. and seconds, and the path tracer's time, raw and denoised, for that error.
fn summary_table(reports: &[&Report]) -> String {
    let mut md = String::from(
        "| scene | ic settings | relMSE ± s.e. | ic s | path s | path+oidn s | ref. noise |\n\
         |---|---|---|---|---|---|---|\n",
    );
    let default_kappa = IcSettings::default().error;
    for report in reports {
        let ladder: Vec<&Run> = report
            .runs
            .iter()
            .filter(|r| r.method == Method::Cache && r.group == Group::Ladder)
            .collect();
        let name = report
            .scene
            .file_stem()
            .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
        let Some(ic) = ladder
            .iter()
            .find(|r| r.kappa == default_kappa)
            .or_else(|| ladder.get(ladder.len() / 2))
        else {
            let _ = writeln!(
                md,
                "| {name} | – | – | – | – | – | {:.1e} |",
                report.reference_noise
            );
            continue;
        };
        let e = ic.metrics.rel_mse;
        let time = |m: Method| {
            let t = Curve::of(m, &report.runs).and_then(|c| c.time_at(e));
            match t {
                Some(t) if t.extrapolated => format!("~{:.2}", t.seconds),
                Some(t) => format!("{:.2}", t.seconds),
                None => "–".into(),
            }
        };
        let _ = writeln!(
            md,
            "| {name} | {} | {:.2e} ± {:.1e} | {:.2} ± {:.2} | {} | {} | {:.1e} |",
            ic.label,
            e,
            ic.metrics.rel_mse_se,
            ic.seconds,
            ic.seconds_se,
            time(Method::Path),
            time(Method::PathDenoised),
            report.reference_noise
        );
    }
    md
}

/// The scenes to compare: `--scenes`, or [`DEFAULT_SCENES`] in the workspace's assets/.
fn scenes(args: &CompareArgs, root: &Path) -> Vec<PathBuf> {
    if args.scenes.is_empty() {
        DEFAULT_SCENES
            .iter()
            .map(|s| root.join("assets").join(s))
            .collect()
    } else {
        args.scenes.clone()
    }
}

/// Copies a report's files to docs/compare/SCENE/ and writes the scene's summary line
/// ([`summary_line`]) into README.md's section for the scene. The tables stay in the published
/// report.md: the README links to it.
fn publish(report: &Report, root: &Path) -> Result<(), String> {
    let stem = report
        .folder
        .file_name()
        .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    let dest = root.join("docs").join("compare").join(&stem);
    std::fs::create_dir_all(&dest).map_err(|e| format!("{}: {e}", dest.display()))?;
    for entry in std::fs::read_dir(&report.folder)
        .map_err(|e| format!("{}: {e}", report.folder.display()))?
        .flatten()
    {
        let from = entry.path();
        let keep = from
            .extension()
            .is_some_and(|e| e == "md" || e == "csv" || e == "svg" || e == "png");
        if keep && let Some(name) = from.file_name() {
            std::fs::copy(&from, dest.join(name))
                .map_err(|e| format!("{}: {e}", dest.join(name).display()))?;
        }
    }
    println!("published to {}", dest.display());
    let default_kappa = IcSettings::default().error;
    let Some(default_run) = report.runs.iter().find(|r| {
        r.method == Method::Cache && r.group == Group::Ladder && r.kappa == default_kappa
    }) else {
        println!("no cache run at the default κ: the README's {stem} line is left as it was");
        return Ok(());
    };
    let readme = root.join("README.md");
    if let Ok(text) = std::fs::read_to_string(&readme) {
        let report_md = std::fs::read_to_string(report.folder.join("report.md"))
            .map_err(|e| format!("{}: {e}", report.folder.join("report.md").display()))?;
        let line = summary_line(&stem, &report_md, &default_run.label);
        match readme_section(&text, &stem, &line) {
            Some(updated) => {
                std::fs::write(&readme, updated)
                    .map_err(|e| format!("{}: {e}", readme.display()))?;
                println!("updated the {stem} line of {}", readme.display());
            }
            None => println!(
                "{} has no <!-- compare:{stem} --> section: the scene's figures are only in docs/compare/{stem}/",
                readme.display()
            ),
        }
    }
    Ok(())
}

/// A published scene's line in the README: a link to its report, then the report's line for
/// the cache's run `label` (its error, its time, and the path tracer's times, raw and
/// denoised, for that error). Where the report has no such line (the run is off the cache's
/// front), the run's relMSE ± s.e. and seconds from the report's table.
pub fn summary_line(stem: &str, report_md: &str, label: &str) -> String {
    let link = format!("- [{stem}](docs/compare/{stem}/report.md)");
    let derived = format!("- ic {label}: ");
    if let Some(rest) = report_md
        .lines()
        .find_map(|l| l.strip_prefix(derived.as_str()))
    {
        return format!("{link}: ic {label}: {rest}");
    }
    let row = format!("| ic | {label} |");
    let cols = report_md
        .lines()
        .find(|l| l.starts_with(&row))
        .map(|l| l.split('|').map(str::trim).collect::<Vec<_>>());
    match cols {
        // | ic | label | seconds | M rays | records | relMSE ± s.e. | …
        Some(c) if c.len() > 6 => format!("{link}: ic {label}: relMSE {} in {} s.", c[6], c[3]),
        _ => format!("{link}: no ic {label} run."),
    }
}

/// `readme` with the part between `<!-- compare:STEM -->` and `<!-- /compare:STEM -->` replaced
/// by `line`; `None` when the README has no such markers.
pub fn readme_section(readme: &str, stem: &str, line: &str) -> Option<String> {
    let open = format!("<!-- compare:{stem} -->");
    let close = format!("<!-- /compare:{stem} -->");
    let start = readme.find(&open)? + open.len();
    let end = start + readme[start..].find(&close)?;
    Some(format!("{}\n{line}\n{}", &readme[..start], &readme[end..]))
}

/// Seconds as the tables print them: `~` marks a time extrapolated beyond the runs.
fn seconds_text(t: Option<figures::TimeAt>) -> String {
    match t {
        None => "–".into(),
        Some(t) if t.extrapolated => format!("~{:.2}", t.seconds),
        Some(t) => match t.flip {
            Some(f) => format!("{:.2} ({f:.3})", t.seconds),
            None => format!("{:.2}", t.seconds),
        },
    }
}

/// The seeds of the measured runs, `1..=n`: none is a reference half's
/// ([`reference::REFERENCE_SEEDS`], far above any `u32`), so no run shares samples with the
/// reference it is scored against.
pub fn run_seeds(n: u32) -> Vec<u64> {
    (1..=u64::from(n)).collect()
}

/// What the first render of one (setting, seed) measured, and the times of all its repeats.
struct Measured {
    seconds: Vec<f64>,
    denoise_seconds: Vec<f64>,
    rays: u64,
    records: usize,
    metrics: metrics::Metrics,
    /// A digest of the first render's pixels: every repeat must render the same.
    digest: u64,
}

/// A digest of an image's pixels (their bits).
fn image_digest(image: &Image) -> u64 {
    let bytes: Vec<u8> = image
        .pixels()
        .iter()
        .flat_map(|p| p.to_array().map(f32::to_bits))
        .flat_map(u32::to_le_bytes)
        .collect();
    irr_render::fingerprint(&[&bytes])
}

/// One setting's [`Run`] from its seeds' measurements: each seed's time the median of its
/// repeats, every figure the mean over the seeds, relMSE's and the time's standard errors the
/// spread across the seeds.
fn summarise(job: &Job, seeds: &[Measured]) -> Run {
    let n = seeds.len().max(1) as f64;
    let times: Vec<f64> = seeds.iter().map(|m| stats::median(&m.seconds)).collect();
    let (seconds, seconds_se) = stats::mean_and_standard_error(&times);
    let denoise: Vec<f64> = seeds
        .iter()
        .map(|m| stats::median(&m.denoise_seconds))
        .collect();
    let seed_errors: Vec<f64> = seeds.iter().map(|m| m.metrics.rel_mse).collect();
    let (rel_mse, rel_mse_se) = stats::mean_and_standard_error(&seed_errors);
    let mean =
        |f: fn(&metrics::Metrics) -> f64| seeds.iter().map(|m| f(&m.metrics)).sum::<f64>() / n;
    Run {
        method: job.method,
        label: job.label.clone(),
        group: job.group,
        kappa: job.kappa,
        seconds,
        seconds_se,
        denoise_seconds: stats::mean_and_standard_error(&denoise).0,
        rays: (seeds.iter().map(|m| m.rays as f64).sum::<f64>() / n).round() as u64,
        records: (seeds.iter().map(|m| m.records as f64).sum::<f64>() / n).round() as usize,
        metrics: metrics::Metrics {
            rel_mse,
            rel_mse_se,
            bias_percent: mean(|m| m.bias_percent),
            mae: mean(|m| m.mae),
            p99_rel: mean(|m| m.p99_rel),
            flip: mean(|m| m.flip),
        },
        seed_errors,
        times: seeds.iter().map(|m| m.seconds.clone()).collect(),
    }
}

/// The measurement behind `run`, for one scene.
pub fn compare(args: &CompareArgs, scene_path: &Path, root: &Path) -> Result<Report, String> {
    let (width, height) = if args.quick {
        (48, 48)
    } else {
        (args.width, args.height)
    };
    let seeds = run_seeds(args.seeds);
    let base = RenderSettings {
        width,
        height,
        spp: args.ic_spp,
        seed: seeds[0],
        threads: args.threads,
    };
    base.validate().map_err(|e| e.to_string())?;
    let loaded = load_scene(scene_path).map_err(|e| e.to_string())?;
    let layer = args.layer;
    let mut stem = scene_path
        .file_stem()
        .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    if let Some(aov) = layer.aov() {
        stem = format!("{stem}-{aov}");
    }
    let out_dir = root.join("target").join("compare").join(&stem);
    std::fs::create_dir_all(&out_dir).map_err(|e| format!("{}: {e}", out_dir.display()))?;
    let ref_spp = args.reference_spp.unwrap_or(if args.quick {
        QUICK_REFERENCE_SPP
    } else {
        REFERENCE_SPP
    });
    let (reference, noise, _) = reference(
        &loaded,
        &base,
        ref_spp,
        &root.join("target").join("compare").join("cache"),
        (args.fresh, layer),
    )?;
    eprintln!("{stem}: reference noise (relMSE of the reference itself): {noise:.2e}");
    let denoiser = DENOISER.is_some();
    if !denoiser {
        eprintln!(
            "note: no denoised rows: this build has no denoiser (cargo xtask-oidn compare; README, \"Denoising\")"
        );
    }

    let glossy = loaded.scene.materials().iter().any(|m| !m.is_lambertian());
    let jobs = jobs(args, denoiser, glossy)?;
    let order = stats::interleaved(jobs.len(), seeds.len(), args.repeats as usize);
    let bar = indicatif::ProgressBar::new(order.len() as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{elapsed_precise} [{wide_bar}] {pos}/{len} renders: {msg}",
    ) {
        bar.set_style(style);
    }
    // The cache's noise is measured on the tightest ladder setting, from its first two seeds.
    let noise_job = jobs
        .iter()
        .rposition(|j| j.method == Method::Cache && j.group == Group::Ladder);
    let mut measured: Vec<Vec<Measured>> = jobs.iter().map(|_| Vec::new()).collect();
    let mut images: Vec<Option<Image>> = jobs.iter().map(|_| None).collect();
    let mut second_seed: Option<Image> = None;
    let mut unstable: Vec<String> = Vec::new();
    for slot in order {
        let job = &jobs[slot.job];
        bar.set_message(format!(
            "{stem}: {} {} (seed {}, repeat {})",
            job.method.name(),
            job.label,
            seeds[slot.seed],
            slot.repeat + 1
        ));
        let settings = RenderSettings {
            spp: job.spp,
            seed: seeds[slot.seed],
            ..base
        };
        let (image, seconds, denoise_seconds, rays, records) = match job.ic {
            None => {
                let (i, s, d, r) =
                    path_render(&loaded, &settings, job.path, (job.method.denoised(), layer))?;
                (i, s, d, r, 0)
            }
            Some(ic) => ic_render(&loaded, &settings, ic, (job.method.denoised(), layer))?,
        };
        let digest = image_digest(&image);
        // The interleaved order puts every (setting, seed)'s first render in the first repeat:
        // its image is scored, the later repeats are only timed (and checked to be the same).
        match measured[slot.job].get_mut(slot.seed) {
            Some(m) => {
                m.seconds.push(seconds);
                m.denoise_seconds.push(denoise_seconds);
                if m.digest != digest {
                    unstable.push(format!(
                        "{} {} seed {}",
                        job.method.name(),
                        job.label,
                        seeds[slot.seed]
                    ));
                }
            }
            None => {
                measured[slot.job].push(Measured {
                    seconds: vec![seconds],
                    denoise_seconds: vec![denoise_seconds],
                    rays,
                    records,
                    metrics: metrics_with_flip(&image, &reference),
                    digest,
                });
                if slot.seed == 0 {
                    images[slot.job] = Some(image);
                } else if slot.seed == 1 && Some(slot.job) == noise_job {
                    second_seed = Some(image);
                }
            }
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    unstable.sort();
    unstable.dedup();
    let runs: Vec<Run> = jobs
        .iter()
        .zip(&measured)
        .map(|(job, m)| summarise(job, m))
        .collect();
    let images: Vec<Image> = images
        .into_iter()
        .map(|i| i.ok_or("a setting was never rendered"))
        .collect::<Result<_, _>>()?;
    // One cache image's own noise at the tightest ladder setting: relMSE between its images of
    // two seeds, halved (each image carries half the difference's variance).
    let ic_noise = match (noise_job, &second_seed) {
        (Some(j), Some(b)) => metrics(&images[j], b).rel_mse / 2.0,
        _ => 0.0,
    };
    let tuned = tuned(scene_path);
    let measurement = Measurement {
        seeds: &seeds,
        repeats: args.repeats,
        machine: stats::Machine::this(),
        tuned,
        unstable: &unstable,
    };
    let md = write_report(
        args,
        &stem,
        (&runs, &images, &reference),
        (noise, ic_noise),
        &measurement,
        &out_dir,
    )?;
    println!("{md}");
    Ok(Report {
        runs,
        reference_noise: noise,
        ic_noise,
        folder: out_dir,
        scene: scene_path.to_path_buf(),
        tuned,
    })
}

/// How one scene's runs were measured, as the report states it.
struct Measurement<'a> {
    seeds: &'a [u64],
    repeats: u32,
    machine: stats::Machine,
    tuned: bool,
    /// The (setting, seed)s whose repeats rendered different pixels.
    unstable: &'a [String],
}

/// Writes runs.csv (a row per setting, its means over the seeds), seeds.csv (a row per setting
/// and seed, with every repeat's time), report.md and the pictures; returns report.md's text.
fn write_report(
    args: &CompareArgs,
    stem: &str,
    (runs, images, reference): (&[Run], &[Image], &Image),
    (noise, ic_noise): (f64, f64),
    measurement: &Measurement,
    out_dir: &Path,
) -> Result<String, String> {
    let (width, height) = (reference.width(), reference.height());
    let mut csv = String::from(
        "method,settings,group,seeds,seconds,seconds_se,denoise_seconds,rays,records,rel_mse,rel_mse_se,reference_noise,bias_percent,mae,p99_rel,flip\n",
    );
    let mut seeds_csv =
        String::from("method,settings,seed,seconds_median,rel_mse,repeat_seconds\n");
    for r in runs {
        for ((seed, e), times) in measurement.seeds.iter().zip(&r.seed_errors).zip(&r.times) {
            let _ = writeln!(
                seeds_csv,
                "{},{},{seed},{:.4},{e:.6e},{}",
                r.method.name(),
                r.label,
                stats::median(times),
                times
                    .iter()
                    .map(|t| format!("{t:.4}"))
                    .collect::<Vec<_>>()
                    .join(";")
            );
        }
    }
    let machine = &measurement.machine;
    let seeds_text = measurement
        .seeds
        .iter()
        .map(u64::to_string)
        .collect::<Vec<_>>()
        .join(", ");
    let tuned = if measurement.tuned {
        "The defaults were tuned on this scene (docs/performance.md): these figures are not a \
         held-out result."
    } else {
        "The defaults were not tuned on this scene: a held-out result."
    };
    let unstable = if measurement.unstable.is_empty() {
        String::new()
    } else {
        format!(
            " **Repeats that rendered other pixels than their first** (the render is not \
             deterministic there): {}.",
            measurement.unstable.join(", ")
        )
    };
    let denoiser = match DENOISER {
        Some(name) => format!(
            "Denoised runs: {name}, {} camera samples per pixel for the cache, their time \
             including the albedo and normal images and the denoiser.",
            args.denoised_ic_spp
        ),
        None => "No denoised runs: this build has no denoiser (`cargo xtask-oidn compare`).".into(),
    };
    let scored = match args.layer.aov() {
        Some(aov) => format!(
            "Every image, the reference's too, is scored on its {aov} layer (`--aov {aov}`), \
             denoised runs denoising that layer. "
        ),
        None => String::new(),
    };
    let mut md = format!(
        "# {stem}: the irradiance cache against the path tracer, raw and denoised\n\n{tuned} \
         {scored}{width}×{height}; the cache with {} camera samples per pixel and {} light \
         sample(s) per camera hit. {denoiser} Reference: the path tracer at {} spp, \
         non-adaptive, with seeds of its own; its own relMSE {noise:.2e} (the column ref. % is \
         its share of each run's relMSE); one cache image's own noise at the tightest κ setting \
         {ic_noise:.2e} (two seeds' images). Every setting is rendered with seeds {seeds_text}: \
         each error column is the mean over them, relMSE ± its standard error across them. \
         Seconds: wall-clock, the mean over the seeds of each seed's median of {} runs, the runs \
         interleaved round-robin over the settings; {}, {} cores ({} logical), rendering on {} \
         threads.{unstable}\n\n\
         | method | settings | seconds | M rays | records | relMSE ± s.e. | ref. % | bias % | MAE | p99 rel. | FLIP |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
        args.ic_spp,
        args.direct_samples,
        args.reference_spp.unwrap_or(if args.quick {
            QUICK_REFERENCE_SPP
        } else {
            REFERENCE_SPP
        }),
        measurement.repeats,
        machine.model,
        machine.cores,
        machine.logical,
        rayon_threads(args.threads)
    );
    for r in runs {
        let m = &r.metrics;
        let _ = writeln!(
            csv,
            "{},{},{},{},{:.4},{:.4},{:.4},{},{},{:.6e},{:.6e},{:.6e},{:.4},{:.6e},{:.6e},{:.6e}",
            r.method.name(),
            r.label,
            r.group.name(),
            r.seed_errors.len(),
            r.seconds,
            r.seconds_se,
            r.denoise_seconds,
            r.rays,
            r.records,
            m.rel_mse,
            m.rel_mse_se,
            noise,
            m.bias_percent,
            m.mae,
            m.p99_rel,
            m.flip
        );
        let _ = writeln!(
            md,
            "| {} | {} | {:.2} | {:.1} | {} | {:.2e} ± {:.1e} | {:.1} | {:+.2} | {:.2e} | {:.3} | {:.4} |",
            r.method.name(),
            r.label,
            r.seconds,
            r.rays as f64 / 1e6,
            r.records,
            m.rel_mse,
            m.rel_mse_se,
            100.0 * noise / m.rel_mse.max(f64::MIN_POSITIVE),
            m.bias_percent,
            m.mae,
            m.p99_rel,
            m.flip
        );
    }
    md.push_str("\n## Derived figures\n\n");
    let curves: Vec<Curve> = Method::ALL
        .into_iter()
        .filter_map(|m| Curve::of(m, runs))
        .collect();
    let describe = |front: &[&Run]| {
        front
            .iter()
            .map(|r| {
                format!(
                    "{} ({:.2} s, {:.2e})",
                    r.label, r.seconds, r.metrics.rel_mse
                )
            })
            .collect::<Vec<_>>()
            .join("; ")
    };
    for method in Method::ALL {
        let front = pareto_front(
            runs.iter()
                .filter(|r| r.method == method && r.group.primary()),
        );
        if !front.is_empty() {
            let _ = writeln!(
                md,
                "- Front of {} ({}): {}.",
                method.name(),
                if method.cache() {
                    "its κ ladder"
                } else {
                    "its spp series"
                },
                describe(&front)
            );
        }
    }
    let all_cache = pareto_front(runs.iter().filter(|r| r.method == Method::Cache));
    if all_cache.iter().any(|r| !r.group.primary()) {
        let _ = writeln!(
            md,
            "- Front of every raw cache run, ablations included (each ablation one setting away \
             from the defaults; not used for the figures below): {}.",
            describe(&all_cache)
        );
    }
    if let Some((k, _)) = curves
        .iter()
        .find(|c| c.method == Method::Path)
        .and_then(|c| c.fit)
    {
        let _ = writeln!(
            md,
            "- Path tracer: relMSE ∝ time^{k:.2} (fit over its runs; −1 is the Monte Carlo rate); \
             its times beyond its runs (marked ~) follow the fit."
        );
    }
    let rows = level_rows(&curves);
    if !rows.is_empty() {
        md.push_str(
            "\nThe time each method needs for an error (interpolated log-log along its front; \
             FLIP there in brackets), the fastest, and the faster of the cache's two methods \
             against the denoised path tracer:\n\n\
             | relMSE | path s | path+oidn s | ic s | ic+oidn s | fastest | best cache vs path+oidn |\n\
             |---|---|---|---|---|---|---|\n",
        );
        for row in &rows {
            let fastest = row
                .fastest()
                .map_or_else(|| "–".into(), |(m, _)| m.name().to_string());
            let versus = match (row.best_cache(), row.time(Method::PathDenoised)) {
                (Some((m, c)), Some(p)) => {
                    format!("{}: {:.2}× faster", m.name(), p.seconds / c.seconds)
                }
                _ => "–".into(),
            };
            let _ = writeln!(
                md,
                "| {:.0e} | {} | {} | {} | {} | {fastest} | {versus} |",
                row.error,
                seconds_text(row.time(Method::Path)),
                seconds_text(row.time(Method::PathDenoised)),
                seconds_text(row.time(Method::Cache)),
                seconds_text(row.time(Method::CacheDenoised)),
            );
        }
        md.push('\n');
    }
    // Each run of the cache's fronts against the path tracer, raw and denoised, at its error,
    // and each run of the denoised path tracer against the cache's two methods.
    let time_of = |method: Method, e: f64| {
        curves
            .iter()
            .find(|c| c.method == method)
            .and_then(|c| c.time_at(e))
    };
    let cache = [Method::Cache, Method::CacheDenoised];
    let path = [Method::Path, Method::PathDenoised];
    for (method, others) in [
        (Method::Cache, path),
        (Method::CacheDenoised, path),
        (Method::PathDenoised, cache),
    ] {
        let front = pareto_front(
            runs.iter()
                .filter(|r| r.method == method && r.group.primary()),
        );
        for r in front {
            let e = r.metrics.rel_mse;
            let against = others
                .into_iter()
                .filter_map(|m| {
                    time_of(m, e).map(|t| {
                        format!(
                            "{} {}{:.2} s ({:.2}× this run's time{})",
                            m.name(),
                            if t.extrapolated { "~" } else { "" },
                            t.seconds,
                            t.seconds / r.seconds,
                            t.flip
                                .map_or_else(String::new, |f| format!(", FLIP {f:.4}"))
                        )
                    })
                })
                .collect::<Vec<_>>();
            if !against.is_empty() {
                let _ = writeln!(
                    md,
                    "- {} {}: relMSE {:.2e} in {:.2} s (FLIP {:.4}); for it {}.",
                    method.name(),
                    r.label,
                    e,
                    r.seconds,
                    r.metrics.flip,
                    against.join(", ")
                );
            }
        }
    }
    let mut ladder: Vec<&Run> = runs
        .iter()
        .filter(|r| r.method == Method::Cache && r.group == Group::Ladder)
        .collect();
    ladder.sort_by(|a, b| a.kappa.total_cmp(&b.kappa));
    let kappa_pts: Vec<(f64, f64)> = ladder
        .iter()
        .map(|r| (f64::from(r.kappa), r.metrics.rel_mse))
        .collect();
    if let Some((slope, _)) = figures::fit_log(&kappa_pts) {
        let _ = writeln!(
            md,
            "- Consistency: along the κ ladder relMSE ∝ κ^{slope:.2} (negative: the error falls as \
             κ tightens); each step's change ± its standard error (from the seeds' paired \
             differences, which leave out the noise two settings of one seed share): {}; bias \
             by κ: {}.",
            ladder
                .windows(2)
                .map(|w| format!(
                    "{} → {}: {:+.2e} ± {:.1e}",
                    w[0].kappa,
                    w[1].kappa,
                    w[1].metrics.rel_mse - w[0].metrics.rel_mse,
                    stats::paired_standard_error(&w[1].seed_errors, &w[0].seed_errors)
                ))
                .collect::<Vec<_>>()
                .join(", "),
            ladder
                .iter()
                .map(|r| format!("{}: {:+.2} %", r.kappa, r.metrics.bias_percent))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    write_plot(
        &out_dir.join("plot.svg"),
        runs,
        &format!("{stem} {width}×{height}: error against time"),
    )?;
    md.push_str("\n![relMSE against time](plot.svg)\n");
    write_pictures(runs, images, reference, out_dir, &mut md)?;
    for (name, text) in [("runs.csv", &csv), ("seeds.csv", &seeds_csv)] {
        std::fs::write(out_dir.join(name), text)
            .map_err(|e| format!("{}: {e}", out_dir.join(name).display()))?;
    }
    std::fs::write(out_dir.join("report.md"), &md)
        .map_err(|e| format!("{}: {e}", out_dir.join("report.md").display()))?;
    Ok(md)
}

/// Heat maps of each method near the cache's κ = 1 run's time, and crops of the windows where
/// the cache and the denoised path tracer err most.
fn write_pictures(
    runs: &[Run],
    images: &[Image],
    reference: &Image,
    out_dir: &Path,
    md: &mut String,
) -> Result<(), String> {
    let Some(shown) = runs
        .iter()
        .position(|r| r.method == Method::Cache && r.label.contains("kappa=1 "))
        .or_else(|| runs.iter().position(|r| r.method == Method::Cache))
    else {
        return Ok(());
    };
    let time = runs[shown].seconds;
    // Each method's run nearest in time (log) to the cache's shown run.
    let nearest = |method: Method| {
        runs.iter()
            .enumerate()
            .filter(|(_, r)| r.method == method && r.group.primary())
            .min_by(|a, b| {
                (a.1.seconds.ln() - time.ln())
                    .abs()
                    .total_cmp(&(b.1.seconds.ln() - time.ln()).abs())
            })
            .map(|(i, _)| i)
    };
    let mut panels: Vec<(Method, usize)> = vec![(Method::Cache, shown)];
    for m in [Method::CacheDenoised, Method::Path, Method::PathDenoised] {
        if let Some(i) = nearest(m) {
            panels.push((m, i));
        }
    }
    let mut names = Vec::new();
    for (method, i) in &panels {
        let file = format!("heat-{}.png", method.name().replace('+', "-"));
        write_heat_map(&out_dir.join(&file), &images[*i], reference)?;
        names.push(format!("![{} {}]({file})", method.name(), runs[*i].label));
    }
    let _ = write!(
        md,
        "\nHeat maps of the per-pixel relative error |x − r|/(r + 0.01) (magma, 0 to \
         {HEAT_MAP_MAX} and above), each method's run nearest in time to the cache's {}: {}.\n\n{}\n",
        runs[shown].label,
        panels
            .iter()
            .map(|(m, i)| format!(
                "{} {} ({:.2} s)",
                m.name(),
                runs[*i].label,
                runs[*i].seconds
            ))
            .collect::<Vec<_>>()
            .join(", "),
        names.join(" ")
    );
    let mut shown_images: Vec<&Image> = panels.iter().map(|(_, i)| &images[*i]).collect();
    shown_images.push(reference);
    let order = panels
        .iter()
        .map(|(m, _)| m.name())
        .chain(["reference"])
        .collect::<Vec<_>>()
        .join(", ");
    let size = 32;
    let corner = worst_window(&images[shown], reference, size);
    write_crops(&out_dir.join("crops.png"), &shown_images, corner, size)?;
    let _ = write!(
        md,
        "\nThe cache's worst {size}×{size} window (at {}, {}), ×4: {order}.\n\n![crops](crops.png)\n",
        corner.0, corner.1
    );
    if let Some(&(_, i)) = panels.iter().find(|(m, _)| *m == Method::PathDenoised) {
        let corner = worst_window(&images[i], reference, size);
        write_crops(&out_dir.join("crops-oidn.png"), &shown_images, corner, size)?;
        let _ = write!(
            md,
            "\nThe denoised path tracer's worst {size}×{size} window (at {}, {}), ×4: {order}.\n\n\
             ![crops where the denoised path tracer errs most](crops-oidn.png)\n",
            corner.0, corner.1
        );
    }
    Ok(())
}

fn rayon_threads(threads: usize) -> usize {
    if threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        threads
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `--quick` with the tests' small sample counts, every other option at its default.
    fn quick_args() -> CompareArgs {
        CompareArgs {
            scenes: Vec::new(),
            width: 48,
            height: 48,
            quick: true,
            seeds: 2,
            repeats: 1,
            fresh: false,
            reference_spp: None,
            threads: 0,
            ic_spp: 16,
            denoised_ic_spp: 4,
            direct_samples: 1,
            only: None,
            extra: Vec::new(),
            publish: false,
            layer: Layer::Colour,
        }
    }

    #[test]
    fn the_readme_section_is_replaced_between_its_markers() {
        let readme = "# irr\n<!-- compare:box -->\n| old | table |\n<!-- /compare:box -->\nend\n";
        let out = readme_section(readme, "box", "- [box](docs/compare/box/report.md): ic k=1")
            .unwrap_or_default();
        assert_eq!(
            out,
            "# irr\n<!-- compare:box -->\n- [box](docs/compare/box/report.md): ic k=1\n<!-- /compare:box -->\nend\n"
        );
        assert!(readme_section("no markers", "box", "- line").is_none());
    }

    /// The summary line links the report and carries the report's figures for the default
    /// run: its derived line where it has one, else its table row, never the tables.
    #[test]
    fn the_summary_line_links_the_report_and_quotes_its_default_run() {
        let table = "| method | settings | seconds | M rays | records | relMSE ± s.e. | ref. % |\n\
                     |---|---|---|---|---|---|---|\n\
                     | ic | kappa=0.5 strata=12x48 | 1.09 | 7.2 | 586 | 1.78e-4 ± 1.6e-5 | 4.9 |\n\
                     | ic | kappa=1 strata=16x64 | 1.39 | 9.5 | 2638 | 8.44e-5 ± 6.6e-6 | 10.4 |\n";
        let derived = "- ic kappa=1 strata=16x64: relMSE 8.44e-5 in 1.39 s (FLIP 0.0150); for it path 36.57 s (26.30× this run's time, FLIP 0.0118).\n";
        let report = format!("# box\n\n{table}\n{derived}\n![plot](plot.svg)\n");
        assert_eq!(
            summary_line("box", &report, "kappa=1 strata=16x64"),
            "- [box](docs/compare/box/report.md): ic kappa=1 strata=16x64: relMSE 8.44e-5 in 1.39 s (FLIP 0.0150); for it path 36.57 s (26.30× this run's time, FLIP 0.0118)."
        );
        assert_eq!(
            summary_line("box", table, "kappa=1 strata=16x64"),
            "- [box](docs/compare/box/report.md): ic kappa=1 strata=16x64: relMSE 8.44e-5 ± 6.6e-6 in 1.39 s."
        );
        assert_eq!(
            summary_line("box", table, "kappa=2 strata=24x96"),
            "- [box](docs/compare/box/report.md): no ic kappa=2 strata=24x96 run."
        );
        // The line is one line: no table, list or picture of the report comes with it.
        assert!(!summary_line("box", &report, "kappa=1 strata=16x64").contains('\n'));
    }

    /// The four scenes the defaults were tuned on are tuned however their path is written; a
    /// scene of assets/ not among them, and a missing file, are not.
    #[test]
    fn tuned_scenes_are_told_from_reported_ones() {
        let assets = crate::workspace_root()
            .unwrap_or_else(|e| panic!("{e}"))
            .join("assets");
        for scene in TUNED_SCENES {
            assert!(tuned(&assets.join(scene)), "{scene}");
        }
        assert!(tuned(&assets.join("../assets/cornell-box.gltf")));
        assert!(!tuned(&assets.join("detail-room.gltf")));
        assert!(!tuned(&assets.join("no-such-scene.gltf")));
    }

    /// `--layer glossy-indirect` on the glossy room: the report goes to its own folder and says
    /// which layer it scores, and the runs are scored on that layer of both images. On this
    /// scene the glossy light is about 3 % of the image (its mean 0.0034 against 0.11 at 256²),
    /// so scoring the image against the layer's reference (or the reverse) would read a bias of
    /// about +3000 % (−97 %); the path tracer's 4-spp glossy layer against its own reference is
    /// off by its noise only, which over 48×48 pixels is far below the 50 % asserted.
    #[test]
    fn compare_scores_the_layer_it_is_asked_for() {
        let root = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let workspace = crate::workspace_root().unwrap_or_else(|e| panic!("{e}"));
        let args = CompareArgs {
            reference_spp: Some(256),
            only: Some("path spp=".into()),
            layer: Layer::GlossyIndirect,
            ..quick_args()
        };
        let path = workspace.join("assets").join("glossy-room.gltf");
        let report = compare(&args, &path, root.path()).unwrap_or_else(|e| panic!("{e}"));
        assert!(
            report.folder.ends_with("glossy-room-glossy-indirect"),
            "{}",
            report.folder.display()
        );
        let md = std::fs::read_to_string(report.folder.join("report.md"))
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(md.contains("scored on its glossy-indirect layer"), "{md}");
        assert!(!report.runs.is_empty());
        for run in &report.runs {
            let m = &run.metrics;
            assert!(m.rel_mse.is_finite(), "{}: {m:?}", run.label);
            assert!(m.bias_percent.abs() < 50.0, "{}: {m:?}", run.label);
        }
    }

    /// `cargo xtask compare --quick` on every default scene with two seeds: the report's files
    /// exist, the CSVs parse with every error finite, a row per run (and per run and seed), and
    /// the error falls along the cache's κ ladder. Two settings of one seed share its samples
    /// and the reference, so their errors share noise: each step is judged by the seeds' paired
    /// differences ([`stats::paired_standard_error`]), allowed to rise by Student's t times
    /// that standard error, and from the first step to the last the error must fall by more.
    #[test]
    fn quick_compare_writes_a_sound_report_for_every_scene_raw_and_denoised() {
        let root = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let workspace = crate::workspace_root().unwrap_or_else(|e| panic!("{e}"));
        for scene in DEFAULT_SCENES {
            let args = quick_args();
            let path = workspace.join("assets").join(scene);
            let report = compare(&args, &path, root.path()).unwrap_or_else(|e| panic!("{e}"));
            let mut files = vec![
                "runs.csv",
                "seeds.csv",
                "report.md",
                "plot.svg",
                "heat-ic.png",
                "heat-path.png",
                "crops.png",
            ];
            if DENOISER.is_some() {
                files.extend(["heat-ic-oidn.png", "heat-path-oidn.png", "crops-oidn.png"]);
            }
            for file in files {
                assert!(
                    report.folder.join(file).is_file(),
                    "{scene}: {file} missing"
                );
            }
            let csv = std::fs::read_to_string(report.folder.join("runs.csv")).unwrap_or_default();
            let mut rows = 0;
            for line in csv.lines().skip(1) {
                let cols: Vec<&str> = line.split(',').collect();
                assert_eq!(cols.len(), 16, "{line}");
                for c in &cols[3..] {
                    let v: f64 = c.parse().unwrap_or(f64::NAN);
                    assert!(v.is_finite(), "{line}");
                }
                rows += 1;
            }
            assert_eq!(rows, report.runs.len());
            let by_seed =
                std::fs::read_to_string(report.folder.join("seeds.csv")).unwrap_or_default();
            assert_eq!(
                by_seed.lines().count() - 1,
                report.runs.len() * args.seeds as usize
            );
            assert!(report.tuned, "{scene}");
            for m in Method::ALL
                .into_iter()
                .filter(|m| !m.denoised() || DENOISER.is_some())
            {
                assert!(
                    report.runs.iter().any(|r| r.method == m),
                    "{scene}: no {m:?}"
                );
            }
            let ladder: Vec<&Run> = report
                .runs
                .iter()
                .filter(|r| r.method == Method::Cache && r.group == Group::Ladder)
                .collect();
            assert!(ladder.len() >= 3);
            // Both claims are one-sided (no step rises, the whole ladder falls): Student's t at
            // 95 % one-sided with 1 degree of freedom (two seeds' paired differences) is 6.31.
            assert_eq!(args.seeds, 2);
            let t = 6.31;
            let errors: Vec<f64> = ladder.iter().map(|r| r.metrics.rel_mse).collect();
            let allowed =
                |a: &Run, b: &Run| t * stats::paired_standard_error(&a.seed_errors, &b.seed_errors);
            for w in ladder.windows(2) {
                assert!(
                    w[1].metrics.rel_mse <= w[0].metrics.rel_mse + allowed(w[0], w[1]),
                    "{scene}: {errors:?}, step allowance {:.2e}",
                    allowed(w[0], w[1])
                );
            }
            let (first, last) = (ladder[0], ladder[ladder.len() - 1]);
            assert!(
                last.metrics.rel_mse + allowed(first, last) < first.metrics.rel_mse,
                "{scene}: {errors:?}, allowance {:.2e}",
                allowed(first, last)
            );
        }
    }
}
