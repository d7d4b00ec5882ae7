//! `cargo xtask compare`: the speed/accuracy trade of the irradiance cache against the path
//! tracer, measured on any scene.
//!
//! 1. A reference: the path tracer at high spp, rendered as two independent halves (different
//!    seeds) whose mean is the reference; the relMSE between the halves, divided by 4, is the
//!    reference's own noise (each half has twice the reference's variance, and the difference
//!    of two independent halves four times), printed so that errors below it are read as such.
//!    Cached under target/compare/cache/, keyed by the scene file's bytes and the settings.
//! 2. Sweeps: the irradiance cache over its error parameter, hemisphere resolution, gradients,
//!    neighbour clamping and bounce mode; the path tracer over spp. Each run: wall time, rays,
//!    records and its error against the reference (see [`Metrics`]).
//! 3. A report in target/compare/<scene>/: `runs.csv`, `report.md` and the derived figures.

use clap::Args;
use irr_render::{
    BounceMode, CacheBuilder, GradientMode, IcSettings, Image, Integrator,
    IrradianceCacheIntegrator, PathSettings, PathTracer, RenderSettings, build_cache, load_scene,
    render, write_exr_and_png,
};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Compare the irradiance cache with the path tracer on one scene.
#[derive(Args, Debug)]
pub struct CompareArgs {
    /// The glTF 2.0 scene [default: assets/cornell-box.gltf in the workspace]
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Image width in pixels
    #[arg(long, default_value_t = 256)]
    pub width: u32,
    /// Image height in pixels
    #[arg(long, default_value_t = 256)]
    pub height: u32,
    /// A small version: 64×64, a few settings (under a minute on 2 cores)
    #[arg(long)]
    pub quick: bool,
    /// Render the reference again even if a cached one exists
    #[arg(long)]
    pub fresh: bool,
    /// Samples per pixel of the reference (both halves together)
    #[arg(long)]
    pub reference_spp: Option<u32>,
    /// Worker threads; 0 means one per core
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Camera samples per pixel of the irradiance-cache runs
    #[arg(long, default_value_t = 16)]
    pub ic_spp: u32,
    /// Light samples per camera hit of the irradiance-cache runs
    #[arg(long, default_value_t = 1)]
    pub direct_samples: u32,
    /// Run only the irradiance-cache settings whose label contains this text and no path
    /// tracer, or (with `path`) only the path tracer
    #[arg(long)]
    pub only: Option<String>,
    /// More irradiance-cache settings to run, as KAPPA:MxN[:cached], comma-separated
    #[arg(long, value_delimiter = ',')]
    pub extra: Vec<String>,
}

/// The errors of an image against a reference, over pixels and channels.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Metrics {
    /// Mean of (x − r)² / (r² + 0.01): the relative MSE of the peers' figures.
    pub rel_mse: f64,
    /// (mean x − mean r) / mean r, in percent.
    pub bias_percent: f64,
    /// Mean of |x − r|.
    pub mae: f64,
    /// 99th percentile over pixels of the per-pixel relative error |x − r| / (r + 0.01)
    /// (luminance-free: the largest channel's).
    pub p99_rel: f64,
}

/// The metrics of `image` against `reference` (same size).
pub fn metrics(image: &Image, reference: &Image) -> Metrics {
    let (mut se, mut abs, mut sum_x, mut sum_r) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut per_pixel = Vec::with_capacity(image.pixels().len());
    for (x, r) in image.pixels().iter().zip(reference.pixels()) {
        let mut worst = 0.0f64;
        for c in 0..3 {
            let (x, r) = (f64::from(x[c]), f64::from(r[c]));
            let d = x - r;
            se += d * d / (r * r + 0.01);
            abs += d.abs();
            sum_x += x;
            sum_r += r;
            worst = worst.max(d.abs() / (r.abs() + 0.01));
        }
        per_pixel.push(worst);
    }
    let n = (image.pixels().len() * 3).max(1) as f64;
    per_pixel.sort_by(f64::total_cmp);
    let p99 = per_pixel
        .get(((per_pixel.len() as f64 * 0.99) as usize).min(per_pixel.len().saturating_sub(1)))
        .copied()
        .unwrap_or(0.0);
    Metrics {
        rel_mse: se / n,
        bias_percent: if sum_r > 0.0 {
            100.0 * (sum_x - sum_r) / sum_r
        } else {
            0.0
        },
        mae: abs / n,
        p99_rel: p99,
    }
}

/// FNV-1a of `bytes` (the reference cache's key).
fn fnv(bytes: &[u8], mut h: u64) -> u64 {
    for &b in bytes {
        h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// One measured run.
#[derive(Clone, Debug)]
pub struct Run {
    /// "ic" or "path".
    pub integrator: &'static str,
    /// The settings, as a label.
    pub label: String,
    /// Wall-clock seconds (cache construction and final pass).
    pub seconds: f64,
    /// Rays traced.
    pub rays: u64,
    /// Records (0 for the path tracer).
    pub records: usize,
    /// Errors against the reference.
    pub metrics: Metrics,
}

/// Renders with the path tracer.
fn path_render(
    loaded: &irr_render::LoadedScene,
    settings: &RenderSettings,
) -> Result<(Image, f64, u64), String> {
    let mut pt = PathTracer::new(PathSettings::default());
    pt.preprocess(&loaded.scene);
    let camera = loaded.camera_for(settings.width, settings.height);
    let out = render(&loaded.scene, &camera, &pt, settings, false).map_err(|e| e.to_string())?;
    Ok((out.image, out.stats.seconds, out.stats.rays.total()))
}

/// Renders with the irradiance cache: construction and final pass, timed together.
pub fn ic_render(
    loaded: &irr_render::LoadedScene,
    settings: &RenderSettings,
    ic: IcSettings,
) -> Result<(Image, f64, u64, usize), String> {
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
    let out =
        render(&loaded.scene, &camera, &integrator, settings, false).map_err(|e| e.to_string())?;
    let rays = build.rays().total() + out.stats.rays.total();
    let records = integrator.record_counts().iter().sum();
    Ok((out.image, start.elapsed().as_secs_f64(), rays, records))
}

/// The reference image (mean of two halves) and its own relMSE, from the cache or rendered.
fn reference(
    loaded: &irr_render::LoadedScene,
    scene_bytes: &[u8],
    settings: &RenderSettings,
    spp: u32,
    cache_dir: &Path,
    fresh: bool,
) -> Result<(Image, f64), String> {
    let key = format!(
        "{}x{}-{}spp-seed{}-v1",
        settings.width, settings.height, spp, settings.seed
    );
    let hash = fnv(key.as_bytes(), fnv(scene_bytes, 0xcbf2_9ce4_8422_2325));
    let path = cache_dir.join(format!("reference-{hash:016x}.exr"));
    let noise_path = cache_dir.join(format!("reference-{hash:016x}.noise"));
    if !fresh
        && path.exists()
        && let (Ok(image), Ok(noise)) =
            (Image::read_exr(&path), std::fs::read_to_string(&noise_path))
        && let Ok(noise) = noise.trim().parse::<f64>()
    {
        eprintln!("reference: {} (cached)", path.display());
        return Ok((image, noise));
    }
    let half = (spp / 2).max(1);
    eprintln!(
        "reference: path tracer, 2 × {half} spp at {}×{} (cached at {})",
        settings.width,
        settings.height,
        path.display()
    );
    let a = RenderSettings {
        spp: half,
        ..*settings
    };
    let b = RenderSettings {
        spp: half,
        seed: settings.seed ^ 0x5eed_0000_0000_0001,
        ..*settings
    };
    let (ia, _, _) = path_render(loaded, &a)?;
    let (ib, _, _) = path_render(loaded, &b)?;
    let pixels = ia
        .pixels()
        .iter()
        .zip(ib.pixels())
        .map(|(x, y)| (*x + *y) * 0.5)
        .collect();
    let image = Image::from_pixels(settings.width, settings.height, pixels)
        .ok_or("reference halves differ in size")?;
    // relMSE(a, b) ≈ 2 × relMSE(half) = 4 × relMSE(reference), with the reference (≈ b) as r.
    let noise = metrics(&ia, &ib).rel_mse / 4.0;
    std::fs::create_dir_all(cache_dir).map_err(|e| format!("{}: {e}", cache_dir.display()))?;
    write_exr_and_png(&image, &path, 0.0).map_err(|e| e.to_string())?;
    std::fs::write(&noise_path, format!("{noise:e}\n"))
        .map_err(|e| format!("{}: {e}", noise_path.display()))?;
    Ok((image, noise))
}

/// The irradiance-cache settings of the sweep, each with a label.
fn ic_sweep(quick: bool) -> Vec<(String, IcSettings)> {
    let base = IcSettings::default();
    let mut out = Vec::new();
    let kappas: &[f32] = if quick {
        &[0.5, 1.0, 2.0]
    } else {
        &[0.25, 0.5, 1.0, 2.0, 4.0]
    };
    for &k in kappas {
        out.push((format!("kappa={k}"), IcSettings { error: k, ..base }));
    }
    let strata: &[(u32, u32)] = if quick {
        &[(8, 32), (32, 128)]
    } else {
        &[(8, 32), (32, 128), (48, 192)]
    };
    for &(m, n) in strata {
        out.push((
            format!("strata={m}x{n}"),
            IcSettings {
                strata_m: m,
                strata_n: n,
                ..base
            },
        ));
    }
    out.push((
        "gradients=off".into(),
        IcSettings {
            gradients: GradientMode::Off,
            ..base
        },
    ));
    out.push((
        "neighbour-clamping=off".into(),
        IcSettings {
            neighbour_clamping: false,
            ..base
        },
    ));
    out.push((
        "bounce=cached".into(),
        IcSettings {
            bounce_mode: BounceMode::Cached,
            ..base
        },
    ));
    if !quick {
        // The consistency ladder: error parameter and hemisphere resolution tightened together.
        for (k, m, n) in [(2.0, 24, 96), (4.0, 32, 128), (8.0, 48, 192)] {
            out.push((
                format!("kappa={k},strata={m}x{n}"),
                IcSettings {
                    error: k,
                    strata_m: m,
                    strata_n: n,
                    ..base
                },
            ));
        }
    }
    out
}

/// An extra setting KAPPA:MxN[:cached].
fn parse_extra(text: &str) -> Result<IcSettings, String> {
    let parts: Vec<&str> = text.split(':').collect();
    let bad = || format!("--extra: expected KAPPA:MxN[:cached], got '{text}'");
    let kappa: f32 = parts.first().and_then(|k| k.parse().ok()).ok_or_else(bad)?;
    let (m, n) = parts
        .get(1)
        .and_then(|s| s.split_once('x'))
        .and_then(|(m, n)| Some((m.parse().ok()?, n.parse().ok()?)))
        .ok_or_else(bad)?;
    let cached = match parts.get(2) {
        None => false,
        Some(&"cached") => true,
        Some(_) => return Err(bad()),
    };
    let s = IcSettings {
        error: kappa,
        strata_m: m,
        strata_n: n,
        bounce_mode: if cached {
            BounceMode::Cached
        } else {
            BounceMode::PathTraced
        },
        ..IcSettings::default()
    };
    s.validate().map_err(|e| format!("--extra {text}: {e}"))?;
    Ok(s)
}

/// Runs `cargo xtask compare`.
pub fn run(args: CompareArgs, root: &Path) -> Result<(), String> {
    let scene_path = args
        .scene
        .clone()
        .unwrap_or_else(|| root.join("assets").join("cornell-box.gltf"));
    let scene_bytes =
        std::fs::read(&scene_path).map_err(|e| format!("{}: {e}", scene_path.display()))?;
    let (width, height) = if args.quick {
        (64, 64)
    } else {
        (args.width, args.height)
    };
    let settings = RenderSettings {
        width,
        height,
        spp: 16,
        seed: 0,
        threads: args.threads,
    };
    settings.validate().map_err(|e| e.to_string())?;
    let loaded = load_scene(&scene_path).map_err(|e| e.to_string())?;
    let stem = scene_path
        .file_stem()
        .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    let out_dir = root.join("target").join("compare").join(&stem);
    std::fs::create_dir_all(&out_dir).map_err(|e| format!("{}: {e}", out_dir.display()))?;
    let ref_spp = args
        .reference_spp
        .unwrap_or(if args.quick { 1024 } else { 8192 });
    let (reference, noise) = reference(
        &loaded,
        &scene_bytes,
        &settings,
        ref_spp,
        &root.join("target").join("compare").join("cache"),
        args.fresh,
    )?;
    eprintln!("reference noise (relMSE of the reference itself): {noise:.2e}");

    let mut runs = Vec::new();
    let pt_spps: &[u32] = if args.quick {
        &[4, 16, 64]
    } else {
        &[16, 64, 256, 1024]
    };
    let path_runs = args.only.as_deref().is_none_or(|o| o == "path");
    for &spp in pt_spps.iter().filter(|_| path_runs) {
        let s = RenderSettings { spp, ..settings };
        let (image, seconds, rays) = path_render(&loaded, &s)?;
        let m = metrics(&image, &reference);
        eprintln!(
            "path spp={spp}: {seconds:.2} s, relMSE {:.2e}, bias {:+.2} %",
            m.rel_mse, m.bias_percent
        );
        runs.push(Run {
            integrator: "path",
            label: format!("spp={spp}"),
            seconds,
            rays,
            records: 0,
            metrics: m,
        });
    }
    let settings = RenderSettings {
        spp: args.ic_spp,
        ..settings
    };
    let mut sweep = ic_sweep(args.quick);
    for extra in &args.extra {
        sweep.push((format!("extra {extra}"), parse_extra(extra)?));
    }
    for (label, ic) in sweep {
        if args.only.as_deref().is_some_and(|o| !label.contains(o)) {
            continue;
        }
        let ic = IcSettings {
            direct_samples: args.direct_samples,
            ..ic
        };
        let (image, seconds, rays, records) = ic_render(&loaded, &settings, ic)?;
        let m = metrics(&image, &reference);
        eprintln!(
            "ic {label}: {seconds:.2} s, {records} records, relMSE {:.2e}, bias {:+.2} %",
            m.rel_mse, m.bias_percent
        );
        runs.push(Run {
            integrator: "ic",
            label,
            seconds,
            rays,
            records,
            metrics: m,
        });
    }

    let mut csv =
        String::from("integrator,settings,seconds,rays,records,rel_mse,bias_percent,mae,p99_rel\n");
    let mut md = format!(
        "# {stem}: irradiance cache vs path tracer ({width}×{height}, {} camera spp for the cache)\n\n\
         Reference: path tracer, {ref_spp} spp; its own relMSE {noise:.2e}.\n\n\
         | integrator | settings | seconds | M rays | records | relMSE | bias % | MAE | p99 rel. |\n\
         |---|---|---|---|---|---|---|---|---|\n",
        settings.spp
    );
    for r in &runs {
        let m = &r.metrics;
        let _ = writeln!(
            csv,
            "{},{},{:.4},{},{},{:.6e},{:.4},{:.6e},{:.6e}",
            r.integrator,
            r.label,
            r.seconds,
            r.rays,
            r.records,
            m.rel_mse,
            m.bias_percent,
            m.mae,
            m.p99_rel
        );
        let _ = writeln!(
            md,
            "| {} | {} | {:.2} | {:.1} | {} | {:.2e} | {:+.2} | {:.2e} | {:.3} |",
            r.integrator,
            r.label,
            r.seconds,
            r.rays as f64 / 1e6,
            r.records,
            m.rel_mse,
            m.bias_percent,
            m.mae,
            m.p99_rel
        );
    }
    let csv_path = out_dir.join("runs.csv");
    let md_path = out_dir.join("report.md");
    std::fs::write(&csv_path, csv).map_err(|e| format!("{}: {e}", csv_path.display()))?;
    std::fs::write(&md_path, &md).map_err(|e| format!("{}: {e}", md_path.display()))?;
    println!("{md}");
    println!("wrote {} and {}", csv_path.display(), md_path.display());
    Ok(())
}
