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
    IrradianceCacheIntegrator, PathSettings, PathTracer, RadiusStatistic, RenderSettings,
    build_cache, load_scene, render, tone_map, write_exr_and_png,
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
    /// A small version: 48×48, a few settings (under a minute on 2 cores)
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
    /// Camera samples per pixel of the irradiance-cache runs (the default render's)
    #[arg(long, default_value_t = irr_cli::render::IC_DEFAULT_SPP as u32)]
    pub ic_spp: u32,
    /// Light samples per camera hit of the irradiance-cache runs (the default render's)
    #[arg(long, default_value_t = IcSettings::default().direct_samples)]
    pub direct_samples: u32,
    /// Run only the irradiance-cache settings whose label contains this text and no path
    /// tracer, or (with `path`) only the path tracer
    #[arg(long)]
    pub only: Option<String>,
    /// More irradiance-cache settings to run, as KAPPA:MxN[:cached|:path] (the bounce mode;
    /// default: the default render's), comma-separated
    #[arg(long, value_delimiter = ',')]
    pub extra: Vec<String>,
    /// Also copy the report, plot, heat maps and crops to docs/compare/<scene>/ (what the README
    /// shows)
    #[arg(long)]
    pub publish: bool,
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
    /// FLIP, NVIDIA's perceptual error, on the sRGB previews ([`flip_error`]); 0 where not
    /// computed.
    pub flip: f64,
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
        flip: 0.0,
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
    /// The sweep group ("path", "kappa" for the consistency ladder, "strata", "variant").
    pub group: &'static str,
    /// The error parameter (NaN for the path tracer).
    pub kappa: f32,
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
        "{}x{}-{}spp-seed{}-v2",
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
    // Seeds of their own: a half with a run's seed would draw the same samples as that run (the
    // first N of its sequence per pixel), and the run's error against it would read too low.
    let a = RenderSettings {
        spp: half,
        seed: settings.seed ^ 0x5eed_0000_0000_0002,
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

/// One setting of the irradiance-cache sweep: a label, its group (`kappa` is the consistency
/// ladder, the error parameter with the gathers growing alongside), and the settings.
struct Sweep {
    label: String,
    group: &'static str,
    kappa: f32,
    settings: IcSettings,
}

/// The irradiance-cache settings of the sweep.
fn ic_sweep(quick: bool) -> Vec<Sweep> {
    let base = IcSettings::default();
    let mut out = Vec::new();
    // The ladder: κ with M×N growing alongside (the consistency claim is about both).
    let ladder: &[(f32, u32, u32)] = if quick {
        &[(0.5, 6, 24), (1.0, 8, 32), (2.0, 12, 48)]
    } else {
        &[
            (0.25, 6, 24),
            (0.5, 8, 32),
            (1.0, 12, 48),
            (2.0, 16, 64),
            (4.0, 24, 96),
        ]
    };
    for &(k, m, n) in ladder {
        out.push(Sweep {
            label: format!("kappa={k} strata={m}x{n}"),
            group: "kappa",
            kappa: k,
            settings: IcSettings {
                error: k,
                strata_m: m,
                strata_n: n,
                ..base
            },
        });
    }
    if quick {
        return out;
    }
    for &(m, n) in &[(8u32, 32u32), (16, 64), (32, 128)] {
        out.push(Sweep {
            label: format!("strata={m}x{n}"),
            group: "strata",
            kappa: base.error,
            settings: IcSettings {
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
            "bounces=2",
            IcSettings {
                cached_bounces: 2,
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
    ];
    for (label, settings) in variants {
        out.push(Sweep {
            label: label.into(),
            group: "variant",
            kappa: base.error,
            settings,
        });
    }
    out
}

/// An extra setting KAPPA:MxN[:cached|:path].
fn parse_extra(text: &str) -> Result<IcSettings, String> {
    let parts: Vec<&str> = text.split(':').collect();
    let bad = || format!("--extra: expected KAPPA:MxN[:cached|:path], got '{text}'");
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

/// FLIP (Andersson et al. 2020, NVIDIA's reference implementation through `nv-flip`): the mean of
/// the per-pixel perceptual error between the sRGB previews (exposure 0) of `image` and
/// `reference`, at FLIP's default 67 pixels per degree.
pub fn flip_error(image: &Image, reference: &Image) -> f64 {
    let ldr = |im: &Image| -> Vec<u8> {
        im.pixels()
            .iter()
            .flat_map(|p| p.to_array().map(|c| tone_map(c, 0.0)))
            .collect()
    };
    let (w, h) = (image.width(), image.height());
    let a = nv_flip::FlipImageRgb8::with_data(w, h, &ldr(reference));
    let b = nv_flip::FlipImageRgb8::with_data(w, h, &ldr(image));
    let map = nv_flip::flip(a, b, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    f64::from(nv_flip::FlipPool::from_image(&map).mean())
}

/// Writes an 8-bit RGB PNG.
fn write_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<(), String> {
    let file = std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder
        .write_header()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    writer
        .write_image_data(rgb)
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// The per-pixel relative error |x − r| / (r + 0.01) (largest channel).
fn relative_errors(image: &Image, reference: &Image) -> Vec<f32> {
    image
        .pixels()
        .iter()
        .zip(reference.pixels())
        .map(|(x, r)| {
            let d = (*x - *r).abs() / (r.abs() + glam::Vec3::splat(0.01));
            d.max_element()
        })
        .collect()
}

/// The upper end of the heat maps' scale: a relative error of 0.25 or more is the brightest.
pub const HEAT_MAP_MAX: f32 = 0.25;

/// A heat map of the per-pixel relative error, through FLIP's magma colour map, 0 (black) to
/// [`HEAT_MAP_MAX`] (white-yellow).
fn write_heat_map(path: &Path, image: &Image, reference: &Image) -> Result<(), String> {
    let lut = nv_flip::magma_lut().to_vec();
    let rgb: Vec<u8> = relative_errors(image, reference)
        .into_iter()
        .flat_map(|e| {
            let i = ((e / HEAT_MAP_MAX).clamp(0.0, 1.0) * 255.0) as usize;
            [lut[3 * i], lut[3 * i + 1], lut[3 * i + 2]]
        })
        .collect();
    write_png(path, image.width(), image.height(), &rgb)
}

/// Side-by-side crops (×4) of the window of `size` pixels where `image` errs most: the image,
/// the path tracer's image at a similar time, and the reference.
fn write_crops(
    path: &Path,
    panels: [&Image; 3],
    reference: &Image,
    size: u32,
) -> Result<(u32, u32), String> {
    let image = panels[0];
    let (w, h) = (image.width(), image.height());
    let size = size.min(w).min(h);
    let err = relative_errors(image, reference);
    let mut best = (0u32, 0u32, -1.0f64);
    let step = (size / 4).max(1);
    for y0 in (0..=h - size).step_by(step as usize) {
        for x0 in (0..=w - size).step_by(step as usize) {
            let mut sum = 0.0f64;
            for y in y0..y0 + size {
                for x in x0..x0 + size {
                    sum += f64::from(err[(y * w + x) as usize]);
                }
            }
            if sum > best.2 {
                best = (x0, y0, sum);
            }
        }
    }
    let (x0, y0, _) = best;
    let zoom = 4u32;
    let (pw, ph) = (3 * size * zoom + 2 * zoom, size * zoom);
    let mut rgb = vec![255u8; (pw * ph * 3) as usize];
    for (k, panel) in panels.iter().enumerate() {
        let ox = k as u32 * (size * zoom + zoom);
        for y in 0..size * zoom {
            for x in 0..size * zoom {
                let v = panel.get(x0 + x / zoom, y0 + y / zoom);
                let at = ((y * pw + ox + x) * 3) as usize;
                for c in 0..3 {
                    rgb[at + c] = tone_map(v[c], 0.0);
                }
            }
        }
    }
    write_png(path, pw, ph, &rgb)?;
    Ok((x0, y0))
}

/// Log-log plot of relMSE against seconds for both integrators, as SVG (plotters; text needs no
/// font file in SVG), each point labelled with its settings.
fn write_plot(path: &Path, runs: &[Run], title: &str) -> Result<(), String> {
    use plotters::prelude::*;
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let t_min = runs
        .iter()
        .map(|r| r.seconds)
        .fold(f64::INFINITY, f64::min)
        .max(1e-3);
    let t_max = runs
        .iter()
        .map(|r| r.seconds)
        .fold(0.0, f64::max)
        .max(t_min * 2.0);
    let e_min = runs
        .iter()
        .map(|r| r.metrics.rel_mse)
        .fold(f64::INFINITY, f64::min)
        .max(1e-9);
    let e_max = runs
        .iter()
        .map(|r| r.metrics.rel_mse)
        .fold(0.0, f64::max)
        .max(e_min * 2.0);
    let root = SVGBackend::new(path, (900, 640)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(20)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (t_min * 0.7..t_max * 1.4).log_scale(),
            (e_min * 0.7..e_max * 1.4).log_scale(),
        )
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc("wall-clock seconds (construction + final pass)")
        .y_desc("relMSE against the reference")
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(|e| err(&e))?;
    for (name, colour) in [("path", BLUE), ("ic", RED)] {
        let mut pts: Vec<(f64, f64, String)> = runs
            .iter()
            .filter(|r| r.integrator == name)
            .map(|r| (r.seconds, r.metrics.rel_mse, r.label.clone()))
            .collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        if name == "path" {
            chart
                .draw_series(LineSeries::new(pts.iter().map(|p| (p.0, p.1)), colour))
                .map_err(|e| err(&e))?
                .label("path tracer")
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
        } else {
            chart
                .draw_series(std::iter::once(Circle::new((0.0, 0.0), 0, colour)))
                .map_err(|e| err(&e))?
                .label("irradiance cache")
                .legend(move |(x, y)| Circle::new((x + 10, y), 4, colour.filled()));
        }
        chart
            .draw_series(pts.iter().map(|p| {
                EmptyElement::at((p.0, p.1))
                    + Circle::new((0, 0), 4, colour.filled())
                    + Text::new(p.2.clone(), (6, -6), ("sans-serif", 11).into_font())
            }))
            .map_err(|e| err(&e))?;
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.9))
        .draw()
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// log-log interpolation of `x` at `y` along the points (x, y), sorted by x; `None` outside them.
fn interpolate_log(points: &[(f64, f64)], y: f64) -> Option<f64> {
    points.windows(2).find_map(|w| {
        let ((x0, y0), (x1, y1)) = (w[0], w[1]);
        let (lo, hi) = (y0.min(y1), y0.max(y1));
        if y < lo || y > hi || y0 == y1 {
            return None;
        }
        let t = (y.ln() - y0.ln()) / (y1.ln() - y0.ln());
        Some((x0.ln() + t * (x1.ln() - x0.ln())).exp())
    })
}

/// Least-squares slope and intercept of ln y against ln x.
fn fit_log(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let n = points.len() as f64;
    if n < 2.0 {
        return None;
    }
    let (sx, sy) = points
        .iter()
        .fold((0.0, 0.0), |a, p| (a.0 + p.0.ln(), a.1 + p.1.ln()));
    let (mx, my) = (sx / n, sy / n);
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for p in points {
        sxy += (p.0.ln() - mx) * (p.1.ln() - my);
        sxx += (p.0.ln() - mx).powi(2);
    }
    (sxx > 0.0).then(|| {
        let slope = sxy / sxx;
        (slope, my - slope * mx)
    })
}

/// What `run` measured, for the caller (and the test).
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
}

/// Runs `cargo xtask compare`.
pub fn run(args: CompareArgs, root: &Path) -> Result<(), String> {
    let report = compare(&args, root)?;
    if args.publish {
        let stem = report
            .folder
            .file_name()
            .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
        let dest = root.join("docs").join("compare").join(stem);
        std::fs::create_dir_all(&dest).map_err(|e| format!("{}: {e}", dest.display()))?;
        for file in [
            "report.md",
            "runs.csv",
            "plot.svg",
            "heat-ic.png",
            "heat-path.png",
            "crops.png",
        ] {
            let from = report.folder.join(file);
            if from.exists() {
                std::fs::copy(&from, dest.join(file))
                    .map_err(|e| format!("{}: {e}", dest.join(file).display()))?;
            }
        }
        println!("published to {}", dest.display());
        let readme = root.join("README.md");
        if let Ok(text) = std::fs::read_to_string(&readme) {
            let report_md = std::fs::read_to_string(report.folder.join("report.md"))
                .map_err(|e| format!("{}: {e}", report.folder.join("report.md").display()))?;
            let stem = dest
                .file_name()
                .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
            if let Some(updated) = readme_section(&text, &stem, &report_md) {
                std::fs::write(&readme, updated)
                    .map_err(|e| format!("{}: {e}", readme.display()))?;
                println!("updated the {stem} section of {}", readme.display());
            }
        }
    }
    println!(
        "{} runs; reference noise {:.2e}, one cache image's noise {:.2e}; wrote {} (report.md, runs.csv, plot.svg, heat maps, crops)",
        report.runs.len(),
        report.reference_noise,
        report.ic_noise,
        report.folder.display()
    );
    Ok(())
}

/// `readme` with the part between `<!-- compare:STEM -->` and `<!-- /compare:STEM -->` replaced
/// by the report's table and derived figures (its picture links pointed at docs/compare/STEM/);
/// `None` when the README has no such markers.
pub fn readme_section(readme: &str, stem: &str, report_md: &str) -> Option<String> {
    let open = format!("<!-- compare:{stem} -->");
    let close = format!("<!-- /compare:{stem} -->");
    let start = readme.find(&open)? + open.len();
    let end = start + readme[start..].find(&close)?;
    let mut body = String::from("\n");
    for line in report_md.lines() {
        let keep = line.starts_with('|') || line.starts_with("- ") || line.starts_with("![");
        if keep {
            body.push_str(&line.replace("](", &format!("](docs/compare/{stem}/")));
            body.push('\n');
        }
    }
    Some(format!("{}{body}{}", &readme[..start], &readme[end..]))
}

/// The measurement behind `run`.
pub fn compare(args: &CompareArgs, root: &Path) -> Result<Report, String> {
    let scene_path = args
        .scene
        .clone()
        .unwrap_or_else(|| root.join("assets").join("cornell-box.gltf"));
    let scene_bytes =
        std::fs::read(&scene_path).map_err(|e| format!("{}: {e}", scene_path.display()))?;
    let (width, height) = if args.quick {
        (48, 48)
    } else {
        (args.width, args.height)
    };
    let base = RenderSettings {
        width,
        height,
        spp: args.ic_spp,
        seed: 0,
        threads: args.threads,
    };
    base.validate().map_err(|e| e.to_string())?;
    let loaded = load_scene(&scene_path).map_err(|e| e.to_string())?;
    let stem = scene_path
        .file_stem()
        .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    let out_dir = root.join("target").join("compare").join(&stem);
    std::fs::create_dir_all(&out_dir).map_err(|e| format!("{}: {e}", out_dir.display()))?;
    let ref_spp = args
        .reference_spp
        .unwrap_or(if args.quick { 512 } else { 8192 });
    let (reference, noise) = reference(
        &loaded,
        &scene_bytes,
        &base,
        ref_spp,
        &root.join("target").join("compare").join("cache"),
        args.fresh,
    )?;
    eprintln!("reference noise (relMSE of the reference itself): {noise:.2e}");

    let path_spps: &[u32] = if args.quick {
        &[4, 16, 64]
    } else {
        &[16, 64, 256, 1024]
    };
    let path_runs = args.only.as_deref().is_none_or(|o| o == "path");
    let mut sweep = ic_sweep(args.quick);
    for extra in &args.extra {
        sweep.push(Sweep {
            label: format!("extra {extra}"),
            group: "extra",
            kappa: f32::NAN,
            settings: parse_extra(extra)?,
        });
    }
    sweep.retain(|s| args.only.as_deref().is_none_or(|o| s.label.contains(o)));
    let total = if path_runs { path_spps.len() } else { 0 } + sweep.len();
    let bar = indicatif::ProgressBar::new(total as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{elapsed_precise} [{wide_bar}] {pos}/{len} runs: {msg}",
    ) {
        bar.set_style(style);
    }
    let mut runs = Vec::new();
    let mut path_images: Vec<(f64, Image)> = Vec::new();
    for &spp in path_spps.iter().filter(|_| path_runs) {
        bar.set_message(format!("path spp={spp}"));
        let s = RenderSettings { spp, ..base };
        let (image, seconds, rays) = path_render(&loaded, &s)?;
        let m = Metrics {
            flip: flip_error(&image, &reference),
            ..metrics(&image, &reference)
        };
        runs.push(Run {
            integrator: "path",
            label: format!("spp={spp}"),
            group: "path",
            kappa: f32::NAN,
            seconds,
            rays,
            records: 0,
            metrics: m,
        });
        path_images.push((seconds, image));
        bar.inc(1);
    }
    let mut ic_images: Vec<(String, Image)> = Vec::new();
    for sw in &sweep {
        bar.set_message(format!("ic {}", sw.label));
        let ic = IcSettings {
            direct_samples: args.direct_samples,
            ..sw.settings
        };
        let (image, seconds, rays, records) = ic_render(&loaded, &base, ic)?;
        let m = Metrics {
            flip: flip_error(&image, &reference),
            ..metrics(&image, &reference)
        };
        runs.push(Run {
            integrator: "ic",
            label: sw.label.clone(),
            group: sw.group,
            kappa: sw.kappa,
            seconds,
            rays,
            records,
            metrics: m,
        });
        ic_images.push((sw.label.clone(), image));
        bar.inc(1);
    }
    bar.finish_and_clear();
    // One cache image's own noise at the tightest ladder setting: the same settings with two
    // other seeds, relMSE(a, b)/2 (each image carries half the difference's variance).
    let ic_noise = match sweep.iter().rfind(|s| s.group == "kappa") {
        Some(tight) => {
            let ic = IcSettings {
                direct_samples: args.direct_samples,
                ..tight.settings
            };
            let (a, ..) = ic_render(&loaded, &RenderSettings { seed: 101, ..base }, ic)?;
            let (b, ..) = ic_render(&loaded, &RenderSettings { seed: 202, ..base }, ic)?;
            metrics(&a, &b).rel_mse / 2.0
        }
        None => 0.0,
    };

    // The report.
    let mut csv = String::from(
        "integrator,settings,group,seconds,rays,records,rel_mse,bias_percent,mae,p99_rel,flip\n",
    );
    let mut md = format!(
        "# {stem}: irradiance cache against the path tracer\n\n\
         {width}×{height}; the cache with {} camera samples per pixel and {} light sample(s) per \
         camera hit. Reference: the path tracer at {ref_spp} spp, its own relMSE {noise:.2e}; one \
         cache image's own noise at the tightest κ setting {ic_noise:.2e}. Times are wall-clock \
         on this machine ({} threads).\n\n\
         | integrator | settings | seconds | M rays | records | relMSE | bias % | MAE | p99 rel. | FLIP |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
        args.ic_spp,
        args.direct_samples,
        rayon_threads(args.threads)
    );
    for r in &runs {
        let m = &r.metrics;
        let _ = writeln!(
            csv,
            "{},{},{},{:.4},{},{},{:.6e},{:.4},{:.6e},{:.6e},{:.6e}",
            r.integrator,
            r.label,
            r.group,
            r.seconds,
            r.rays,
            r.records,
            m.rel_mse,
            m.bias_percent,
            m.mae,
            m.p99_rel,
            m.flip
        );
        let _ = writeln!(
            md,
            "| {} | {} | {:.2} | {:.1} | {} | {:.2e} | {:+.2} | {:.2e} | {:.3} | {:.4} |",
            r.integrator,
            r.label,
            r.seconds,
            r.rays as f64 / 1e6,
            r.records,
            m.rel_mse,
            m.bias_percent,
            m.mae,
            m.p99_rel,
            m.flip
        );
    }
    // Derived figures.
    let mut path_pts: Vec<(f64, f64)> = runs
        .iter()
        .filter(|r| r.integrator == "path")
        .map(|r| (r.seconds, r.metrics.rel_mse))
        .collect();
    path_pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut ladder: Vec<&Run> = runs.iter().filter(|r| r.group == "kappa").collect();
    ladder.sort_by(|a, b| a.kappa.total_cmp(&b.kappa));
    // The cache's best trade: the runs no faster run beats in error (the Pareto front), in
    // order of time; its error falls along it, so log-log interpolation is well posed.
    let mut by_time: Vec<&Run> = runs.iter().filter(|r| r.integrator == "ic").collect();
    by_time.sort_by(|a, b| a.seconds.total_cmp(&b.seconds));
    let mut front: Vec<&Run> = Vec::new();
    for r in by_time {
        if front
            .last()
            .is_none_or(|f| r.metrics.rel_mse < f.metrics.rel_mse)
        {
            front.push(r);
        }
    }
    let ic_pts: Vec<(f64, f64)> = front
        .iter()
        .map(|r| (r.seconds, r.metrics.rel_mse))
        .collect();
    md.push_str("\n## Derived figures\n\n");
    let _ = writeln!(
        md,
        "- The cache's Pareto front (no faster run has a lower error): {}.",
        front
            .iter()
            .map(|r| format!(
                "{} ({:.2} s, {:.2e})",
                r.label, r.seconds, r.metrics.rel_mse
            ))
            .collect::<Vec<_>>()
            .join("; ")
    );
    // The path tracer's time at an error: its curve, extended by its own fit (relMSE ∝ t^slope).
    let path_fit = fit_log(&path_pts);
    let path_time = |e: f64| -> Option<f64> {
        interpolate_log(&path_pts, e).or_else(|| path_fit.map(|(k, c)| ((e.ln() - c) / k).exp()))
    };
    if let Some((k, _)) = path_fit {
        let _ = writeln!(
            md,
            "- Path tracer: relMSE ∝ time^{k:.2} (fit over its runs; −1 is the Monte Carlo rate)."
        );
    }
    for target in [1e-2, 1e-3, 2.3e-4] {
        let ic = interpolate_log(&ic_pts, target);
        let pt = path_time(target);
        let line = match (ic, pt) {
            (Some(ic), Some(pt)) => format!(
                "- At relMSE {target:.1e}: cache {ic:.2} s, path tracer {pt:.2} s: speed-up {:.1}×.",
                pt / ic
            ),
            (None, Some(pt)) => format!(
                "- At relMSE {target:.1e}: path tracer {pt:.2} s; the cache's runs do not reach this error (their range: {}).",
                ic_range(&ic_pts)
            ),
            _ => format!("- At relMSE {target:.1e}: outside the measured curves."),
        };
        md.push_str(&line);
        md.push('\n');
    }
    for r in &front {
        if let Some(pt) = path_time(r.metrics.rel_mse) {
            let _ = writeln!(
                md,
                "- {}: relMSE {:.2e} in {:.2} s; the path tracer needs {pt:.2} s for it: speed-up {:.1}×.",
                r.label,
                r.metrics.rel_mse,
                r.seconds,
                pt / r.seconds
            );
        }
    }
    let kappa_pts: Vec<(f64, f64)> = ladder
        .iter()
        .map(|r| (f64::from(r.kappa), r.metrics.rel_mse))
        .collect();
    if let Some((slope, _)) = fit_log(&kappa_pts) {
        let _ = writeln!(
            md,
            "- Consistency: along the κ ladder relMSE ∝ κ^{slope:.2} (negative: the error falls as κ \
             tightens); bias by κ: {}.",
            ladder
                .iter()
                .map(|r| format!("{}: {:+.2} %", r.kappa, r.metrics.bias_percent))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    // Pictures: the plot, heat maps of the default-like cache run and the path tracer at a
    // similar time, and crops of the cache's worst region.
    let plot = out_dir.join("plot.svg");
    write_plot(
        &plot,
        &runs,
        &format!("{stem} {width}×{height}: error against time"),
    )?;
    md.push_str("\n![relMSE against time](plot.svg)\n");
    let shown = ic_images
        .iter()
        .find(|(l, _)| l.contains("kappa=1 "))
        .or_else(|| ic_images.first());
    if let Some((label, image)) = shown {
        let ic_run_time = runs
            .iter()
            .find(|r| r.integrator == "ic" && &r.label == label)
            .map_or(0.0, |r| r.seconds);
        let similar = path_images
            .iter()
            .min_by(|a, b| {
                (a.0.ln() - ic_run_time.ln())
                    .abs()
                    .total_cmp(&(b.0.ln() - ic_run_time.ln()).abs())
            })
            .map(|(_, im)| im)
            .unwrap_or(image);
        write_heat_map(&out_dir.join("heat-ic.png"), image, &reference)?;
        write_heat_map(&out_dir.join("heat-path.png"), similar, &reference)?;
        let (x0, y0) = write_crops(
            &out_dir.join("crops.png"),
            [image, similar, &reference],
            &reference,
            32,
        )?;
        let _ = write!(
            md,
            "\nHeat maps of the per-pixel relative error |x − r|/(r + 0.01) (magma, 0 to \
             {HEAT_MAP_MAX} and above): the cache ({label}) and the path tracer at the nearest \
             time.\n\n![cache](heat-ic.png) ![path](heat-path.png)\n\n\
             The cache's worst 32×32 window (at {x0}, {y0}), ×4: cache, path tracer at a similar \
             time, reference.\n\n![crops](crops.png)\n"
        );
    }
    let csv_path = out_dir.join("runs.csv");
    let md_path = out_dir.join("report.md");
    std::fs::write(&csv_path, csv).map_err(|e| format!("{}: {e}", csv_path.display()))?;
    std::fs::write(&md_path, &md).map_err(|e| format!("{}: {e}", md_path.display()))?;
    println!("{md}");
    Ok(Report {
        runs,
        reference_noise: noise,
        ic_noise,
        folder: out_dir,
    })
}

fn ic_range(points: &[(f64, f64)]) -> String {
    let lo = points.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    let hi = points.iter().map(|p| p.1).fold(0.0, f64::max);
    format!("{lo:.1e} to {hi:.1e}")
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

    /// `cargo xtask compare --quick` on the Cornell box: the report's files exist, the CSV parses
    /// with every error finite, and the error falls along the cache's κ ladder within the
    /// measured noise (each step may rise by at most twice one image's own noise plus the
    /// reference's: two independent noisy estimates of falling errors).
    #[test]
    fn the_readme_section_is_replaced_between_its_markers() {
        let readme = "# irr\n<!-- compare:box -->\nold\n<!-- /compare:box -->\nend\n";
        let report = "# box\n\ntext\n| a | b |\n|---|---|\n- figure\n![plot](plot.svg)\n";
        let out = readme_section(readme, "box", report).unwrap_or_default();
        assert_eq!(
            out,
            "# irr\n<!-- compare:box -->\n| a | b |\n|---|---|\n- figure\n![plot](docs/compare/box/plot.svg)\n<!-- /compare:box -->\nend\n"
        );
        assert!(readme_section("no markers", "box", report).is_none());
    }

    #[test]
    fn quick_compare_writes_a_sound_report() {
        let root = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let scene = crate::workspace_root()
            .unwrap_or_else(|e| panic!("{e}"))
            .join("assets")
            .join("cornell-box.gltf");
        let args = CompareArgs {
            scene: Some(scene),
            width: 48,
            height: 48,
            quick: true,
            fresh: false,
            reference_spp: None,
            threads: 0,
            ic_spp: 16,
            direct_samples: 1,
            only: None,
            extra: Vec::new(),
            publish: false,
        };
        let report = compare(&args, root.path()).unwrap_or_else(|e| panic!("{e}"));
        for file in [
            "runs.csv",
            "report.md",
            "plot.svg",
            "heat-ic.png",
            "heat-path.png",
            "crops.png",
        ] {
            assert!(report.folder.join(file).is_file(), "{file} missing");
        }
        let csv = std::fs::read_to_string(report.folder.join("runs.csv")).unwrap_or_default();
        let mut rows = 0;
        for line in csv.lines().skip(1) {
            let cols: Vec<&str> = line.split(',').collect();
            assert_eq!(cols.len(), 11, "{line}");
            for c in &cols[3..] {
                let v: f64 = c.parse().unwrap_or(f64::NAN);
                assert!(v.is_finite(), "{line}");
            }
            rows += 1;
        }
        assert_eq!(rows, report.runs.len());
        let ladder: Vec<f64> = report
            .runs
            .iter()
            .filter(|r| r.group == "kappa")
            .map(|r| r.metrics.rel_mse)
            .collect();
        assert!(ladder.len() >= 3);
        let allowance = 2.0 * (report.ic_noise + report.reference_noise);
        for w in ladder.windows(2) {
            assert!(
                w[1] <= w[0] + allowance,
                "{ladder:?} (allowance {allowance:.2e})"
            );
        }
        assert!(ladder[ladder.len() - 1] < ladder[0], "{ladder:?}");
    }
}
