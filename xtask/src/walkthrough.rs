//! `cargo xtask walkthrough`: a camera path through a static scene, rendered by the cache with
//! one cache shared by the frames, by the cache with a cache per frame, and by the path tracer
//! (and the path tracer denoised, in a build with the denoiser) at about the shared cache's time
//! per frame; each scored by its frames' error against a reference and by its **temporal
//! error**, how much a surface point's radiance changes from one frame to the next.
//!
//! Temporal error: how much a frame's error changes from one frame to the next where the two
//! frames see the same surface point, as relMSE against the reference's own change. Each pixel
//! of frame f + 1 is carried into frame f through the reference's depth (the distance along the
//! pixel's centre ray) and the two cameras, and frame f is read there bilinearly; a pixel whose
//! four neighbours' reference depths disagree with the carried point's distance by over 1 % is
//! a disocclusion (or an edge) and is left out. With e = x − r a frame's error against its
//! reference and C the carrying, a pair scores mean((e₁ − C e₀)² / (r₁² + 0.01)), that is,
//! (x₁ − C x₀) against (r₁ − C r₀): the run's change between the frames against the reference's.
//! C is linear, so the bilinear reading's own error is in both and cancels: an exact sequence
//! scores zero, and so does an error that stays on its surface point (a record's splotch seen
//! from a moving camera), while an error drawn afresh each frame (sampling noise, a denoiser's
//! blotches) scores about twice its frame relMSE. The references' own noise adds the same term
//! to every row; it is measured from the two halves of each reference ((h₁ − h₂)/2 has the
//! mean's noise and nothing else) and removed. A score pools every pair's carried pixels; its
//! standard error comes from the spread of 16×16-pixel blocks (compare's blocks).
//! A frame's error is relMSE = mean((x − r)² / (r² + 0.01)) against its reference frame.

use crate::compare::metrics::{BLOCK, paired_standard_error};
use clap::Args;
use glam::Vec3;
use irr_render::{
    Aov, CacheContents, CacheOrigin, Camera, DENOISER, DENOISER_AOVS, IcSettings, Image,
    Integrator, IrradianceCacheIntegrator, KeyFrames, LoadedScene, PathSettings, PathTracer,
    RenderSettings, build_cache, build_cache_shard, build_light_cache, build_shared_cache, denoise,
    load_scene, merge_shards, render_with_aovs,
};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Render a camera path with a shared cache, a cache per frame and the path tracer, and measure
/// each frame's error and the error between frames.
#[derive(Args, Debug)]
pub struct WalkthroughArgs {
    /// The glTF scene, its camera animated [default: assets/cornell-dolly.gltf]
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Frames rendered (A..B, B excluded)
    #[arg(long, default_value_t = 16)]
    pub frames: u32,
    /// Frames per second
    #[arg(long, default_value_t = 16.0)]
    pub fps: f64,
    /// Image width and height in pixels
    #[arg(long, default_value_t = 128)]
    pub size: u32,
    /// Samples per pixel of each reference frame (two halves of their own seeds)
    #[arg(long, default_value_t = 1024)]
    pub reference_spp: u32,
    /// The shared cache's key frames: every K-th and the last
    #[arg(long, default_value_t = 4)]
    pub cache_every: u32,
    /// Camera samples per pixel of the denoised shared-cache rows (built with the denoiser),
    /// comma-separated: a row each, each followed by the denoised path tracer at its time
    #[arg(long, value_delimiter = ',', default_values_t = [crate::compare::DENOISED_IC_SPP])]
    pub denoised_ic_spp: Vec<u32>,
    /// Also the shared cache built in S shards, each into an empty cache, joined (a farm's
    /// construction, here on one machine); 1 or 0: not
    #[arg(long, default_value_t = 2)]
    pub shards: u32,
    /// Worker threads; 0 means one per core
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
}

/// The seeds of a reference frame's halves and of every run.
const REFERENCE_SEEDS: [u64; 2] = [0x7e1f_0001, 0x7e1f_0002];
const RUN_SEED: u64 = 0x7e1f_0100;

/// One method's frames, their indirect part (not for a denoised run) and its time.
struct Run {
    name: String,
    frames: Vec<Image>,
    indirect: Option<Vec<Image>>,
    seconds: f64,
}

/// `cargo xtask walkthrough`: renders, scores and reports (module docs).
pub fn run(args: WalkthroughArgs, root: &Path) -> Result<(), String> {
    if args.frames < 2 || args.size == 0 || args.cache_every == 0 {
        return Err("--frames must be at least 2, --size and --cache-every at least 1".into());
    }
    if !(args.fps.is_finite() && args.fps > 0.0) {
        return Err(format!("--fps: must be finite and > 0, got {}", args.fps));
    }
    let scene = args
        .scene
        .clone()
        .unwrap_or_else(|| root.join("assets").join("cornell-dolly.gltf"));
    let loaded = load_scene(&scene).map_err(|e| e.to_string())?;
    if loaded.camera_path(None).is_none() {
        return Err(format!(
            "{}: no animation moves its camera",
            scene.display()
        ));
    }
    let cameras = (0..args.frames)
        .map(|f| {
            loaded
                .choose_camera_at(None, Some(f64::from(f) / args.fps))
                .map_err(|e| e.to_string())?
                .ok_or_else(|| format!("{}: no camera", scene.display()))
        })
        .collect::<Result<Vec<Camera>, String>>()?;
    let settings = |spp: u32, seed: u64| RenderSettings {
        width: args.size,
        height: args.size,
        spp,
        seed,
        threads: args.threads,
    };
    // References, with the depth that carries pixels between frames.
    eprintln!(
        "references: {} frames, 2 × {} spp",
        args.frames,
        args.reference_spp / 2
    );
    let pt = PathTracer::new(PathSettings::default());
    let (mut references, mut noises, mut depths) = (Vec::new(), Vec::new(), Vec::new());
    let (mut indirect_references, mut indirect_noises) = (Vec::new(), Vec::new());
    let mut reference_noise = 0.0;
    for camera in &cameras {
        let mut halves = Vec::new();
        for seed in REFERENCE_SEEDS {
            let s = settings((args.reference_spp / 2).max(1), seed);
            let out = render_with_aovs(
                &loaded.scene,
                camera,
                &pt,
                &s,
                &[Aov::Depth, Aov::Indirect],
                false,
            )
            .map_err(|e| e.to_string())?;
            halves.push(out);
        }
        let (a, b) = (&halves[0].image, &halves[1].image);
        let (mean, noise) = mean_and_noise(a, b)?;
        // relMSE of the mean of two halves: the halves' difference squared, over 4.
        reference_noise += rel_mse(a, b, &mean) / 4.0;
        references.push(mean);
        noises.push(noise);
        let indirect = |k: usize| halves[k].aovs.get(Aov::Indirect).ok_or("no indirect image");
        let (mean, noise) = mean_and_noise(indirect(0)?, indirect(1)?)?;
        indirect_references.push(mean);
        indirect_noises.push(noise);
        depths.push(
            halves[0]
                .aovs
                .get(Aov::Depth)
                .cloned()
                .ok_or("the reference has no depth")?,
        );
    }
    reference_noise /= f64::from(args.frames);
    let ic_settings = IcSettings::default();
    let spp = irr_cli::render::IC_DEFAULT_SPP as u32;
    let mut runs = Vec::new();
    // The shared cache.
    let start = Instant::now();
    let mut shared = IrradianceCacheIntegrator::new(ic_settings).map_err(|e| e.to_string())?;
    shared.preprocess(&loaded.scene);
    let mut keys: Vec<usize> = (0..cameras.len())
        .step_by(args.cache_every as usize)
        .collect();
    if keys.last() != Some(&(cameras.len() - 1)) {
        keys.push(cameras.len() - 1);
    }
    let key_cameras: Vec<Camera> = keys.iter().map(|&k| cameras[k]).collect();
    build_shared_cache(
        &loaded.scene,
        &key_cameras,
        &mut shared,
        &settings(spp, RUN_SEED),
        false,
        false,
    )
    .map_err(|e| e.to_string())?;
    let built = start.elapsed().as_secs_f64();
    let (frames, indirect) =
        render_frames(&loaded, &cameras, &shared, &settings(spp, RUN_SEED), false)?;
    runs.push(Run {
        name: format!(
            "ic, shared cache (key frames every {}; {} records, {built:.2} s of construction)",
            args.cache_every,
            shared.cache(0).map_or(0, |c| c.len())
        ),
        frames,
        indirect,
        seconds: start.elapsed().as_secs_f64(),
    });
    if args.shards > 1 {
        runs.push(sharded(
            &loaded,
            &cameras,
            &key_cameras,
            args.shards,
            &settings(spp, RUN_SEED),
        )?);
    }
    // A cache per frame.
    let start = Instant::now();
    let (mut frames, mut indirect) = (Vec::new(), Vec::new());
    for camera in &cameras {
        let mut ic = IrradianceCacheIntegrator::new(ic_settings).map_err(|e| e.to_string())?;
        ic.preprocess(&loaded.scene);
        let s = settings(spp, RUN_SEED);
        build_cache(&loaded.scene, camera, &mut ic, &s, false, false).map_err(|e| e.to_string())?;
        let (f, i) = render_frames(&loaded, std::slice::from_ref(camera), &ic, &s, false)?;
        frames.extend(f);
        indirect.extend(i.unwrap_or_default());
    }
    runs.push(Run {
        name: "ic, a cache per frame".into(),
        frames,
        indirect: Some(indirect),
        seconds: start.elapsed().as_secs_f64(),
    });
    // The path tracer at about the shared cache's time per frame: its rate from a 16-spp
    // frame first, then from its whole row.
    let probe = Instant::now();
    render_frames(&loaded, &cameras[..1], &pt, &settings(16, RUN_SEED), false)?;
    let mut per_spp = probe.elapsed().as_secs_f64() / 16.0;
    let spp_for = |seconds: f64, per_spp: f64| {
        ((seconds / f64::from(args.frames) / per_spp.max(1e-9)) as u32).clamp(1, 4096)
    };
    let path_spp = spp_for(runs[0].seconds, per_spp);
    let path = path_run(&loaded, &cameras, &pt, &settings(path_spp, RUN_SEED), false)?;
    per_spp = path.seconds / f64::from(args.frames * path_spp);
    runs.push(path);
    // The shared cache's frames denoised, at each of the given camera samples, each followed
    // by the denoised path tracer at its time per frame.
    if DENOISER.is_some() {
        for &denoised_spp in &args.denoised_ic_spp {
            let denoised_spp = denoised_spp.max(1);
            let start = Instant::now();
            let (frames, _) = render_frames(
                &loaded,
                &cameras,
                &shared,
                &settings(denoised_spp, RUN_SEED),
                true,
            )?;
            let seconds = built + start.elapsed().as_secs_f64();
            runs.push(Run {
                name: format!("ic + OIDN, shared cache, {denoised_spp} spp"),
                frames,
                indirect: None,
                seconds,
            });
            let s = settings(spp_for(seconds, per_spp), RUN_SEED);
            runs.push(path_run(&loaded, &cameras, &pt, &s, true)?);
        }
    }
    // The report.
    let mut report = format!(
        "# Walkthrough: {}\n\n{} frames at {} fps, {}², {} spp for the cache runs, 2 threads unless \
         --threads; references 2 × {} spp (own relMSE {:.2e}). Temporal relMSE between consecutive \
         frames: the change of each frame's error where both frames see the same point, carried by \
         the reference's depth, against the reference's own change (module docs of \
         xtask/src/walkthrough.rs), of the image and of its indirect part; the references' noise \
         removed from every score.\n\n| run | seconds | \
         frame relMSE | temporal relMSE | temporal relMSE, indirect |\n|---|---|---|---|---|\n",
        scene.display(),
        args.frames,
        args.fps,
        args.size,
        spp,
        args.reference_spp / 2,
        reference_noise
    );
    // What the references' own noise adds to every row's temporal score (module docs).
    let noise = temporal_blocks(&noises, &references, &depths, &cameras);
    let indirect_noise = temporal_blocks(&indirect_noises, &indirect_references, &depths, &cameras);
    // A row's score less the references' noise, ± the standard error of the difference (the
    // blocks paired: both over the same carried pixels).
    let less_noise = |row: &[(f64, f64)], noise: &[(f64, f64)]| {
        let score: f64 = row.iter().zip(noise).map(|(r, n)| r.0 * (r.1 - n.1)).sum();
        format!("{score:.3e} ± {:.1e}", paired_standard_error(row, noise))
    };
    let sum = |blocks: &[(f64, f64)]| blocks.iter().map(|(w, v)| w * v).sum::<f64>();
    let _ = writeln!(
        report,
        "| the references' noise (removed from every row) | — | {reference_noise:.3e} | {:.3e} | {:.3e} |",
        sum(&noise),
        sum(&indirect_noise)
    );
    for r in &runs {
        let error = r
            .frames
            .iter()
            .zip(&references)
            .map(|(x, reference)| rel_mse(x, reference, reference))
            .sum::<f64>()
            / f64::from(args.frames)
            - reference_noise;
        let indirect = r.indirect.as_ref().map_or_else(
            || Ok("—".to_string()),
            |i| {
                let errors = errors_of(i, &indirect_references)?;
                let t = temporal_blocks(&errors, &indirect_references, &depths, &cameras);
                Ok::<_, String>(less_noise(&t, &indirect_noise))
            },
        )?;
        let errors = errors_of(&r.frames, &references)?;
        let _ = writeln!(
            report,
            "| {} | {:.2} | {:.3e} | {} | {indirect} |",
            r.name,
            r.seconds,
            error,
            less_noise(
                &temporal_blocks(&errors, &references, &depths, &cameras),
                &noise
            )
        );
    }
    let stem = scene
        .file_stem()
        .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    let dir = root.join("target").join("walkthrough").join(&stem);
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let path = dir.join("report.md");
    std::fs::write(&path, &report).map_err(|e| format!("{}: {e}", path.display()))?;
    println!("{report}");
    println!("wrote {}", path.display());
    Ok(())
}

/// The shared cache built as a farm builds it: each of `shards` contiguous runs of the key views
/// into an empty cache (one after the other here), joined by `merge_shards`, read into a fresh
/// integrator with the light cache rebuilt from the first key view; then every frame.
fn sharded(
    loaded: &LoadedScene,
    cameras: &[Camera],
    key_cameras: &[Camera],
    shards: u32,
    settings: &RenderSettings,
) -> Result<Run, String> {
    if shards as usize > key_cameras.len() {
        return Err(format!(
            "--shards {shards}: only {} key frames",
            key_cameras.len()
        ));
    }
    let start = Instant::now();
    let ic_settings = IcSettings::default();
    let keys = KeyFrames {
        camera: None,
        times: (0..key_cameras.len()).map(|k| k as f64).collect(),
    };
    let mut built = Vec::new();
    for index in 0..shards {
        let mut ic = IrradianceCacheIntegrator::new(ic_settings).map_err(|e| e.to_string())?;
        ic.preprocess(&loaded.scene);
        build_cache_shard(
            &loaded.scene,
            key_cameras,
            keys.shard(index, shards),
            &mut ic,
            settings,
            false,
            false,
        )
        .map_err(|e| e.to_string())?;
        let origin = CacheOrigin::Shard {
            index,
            shards,
            keys: keys.clone(),
        };
        built.push((
            PathBuf::from(format!("shard {index}")),
            CacheContents::of(&ic, 0, origin)?,
        ));
    }
    let (merged, report) = merge_shards(built).map_err(|e| e.to_string())?;
    let records = merged.record_count();
    let mut ic = IrradianceCacheIntegrator::new(ic_settings).map_err(|e| e.to_string())?;
    ic.preprocess(&loaded.scene);
    ic.load_levels(merged.file(&ic_settings)?)
        .map_err(|e| e.to_string())?;
    build_light_cache(&loaded.scene, &key_cameras[0], &mut ic, settings)
        .map_err(|e| e.to_string())?;
    let construction = start.elapsed().as_secs_f64();
    let (frames, indirect) = render_frames(loaded, cameras, &ic, settings, false)?;
    let per_shard: Vec<String> = report.shard_records.iter().map(usize::to_string).collect();
    Ok(Run {
        name: format!(
            "ic, shared cache in {shards} shards ({records} = {} records, {construction:.2} s of construction on one machine)",
            per_shard.join(" + ")
        ),
        frames,
        indirect,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// The path tracer's row: every frame at `settings`, denoised with `denoised`.
fn path_run(
    loaded: &LoadedScene,
    cameras: &[Camera],
    pt: &PathTracer,
    settings: &RenderSettings,
    denoised: bool,
) -> Result<Run, String> {
    let start = Instant::now();
    let (frames, indirect) = render_frames(loaded, cameras, pt, settings, denoised)?;
    Ok(Run {
        name: format!(
            "path{}, {} spp",
            if denoised { " + OIDN" } else { "" },
            settings.spp
        ),
        frames,
        indirect,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Each camera's image by `integrator`, denoised by OIDN with `denoised`, and its indirect part
/// (without `denoised`).
fn render_frames(
    loaded: &LoadedScene,
    cameras: &[Camera],
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    denoised: bool,
) -> Result<(Vec<Image>, Option<Vec<Image>>), String> {
    let (mut images, mut indirect) = (Vec::new(), Vec::new());
    for camera in cameras {
        let aovs: &[Aov] = if denoised {
            &DENOISER_AOVS
        } else {
            &[Aov::Indirect]
        };
        let out = render_with_aovs(&loaded.scene, camera, integrator, settings, aovs, false)
            .map_err(|e| e.to_string())?;
        if denoised {
            images.push(denoise(&out.image, &out.aovs).map_err(|e| e.to_string())?);
        } else {
            indirect.push(
                out.aovs
                    .get(Aov::Indirect)
                    .cloned()
                    .ok_or("no indirect image")?,
            );
            images.push(out.image);
        }
    }
    Ok((images, (!denoised).then_some(indirect)))
}

/// mean((x − y)² / (r² + 0.01)) over every pixel and channel.
fn rel_mse(x: &Image, y: &Image, r: &Image) -> f64 {
    let mut sum = 0.0;
    for ((a, b), c) in x.pixels().iter().zip(y.pixels()).zip(r.pixels()) {
        for k in 0..3 {
            let (a, b, c) = (f64::from(a[k]), f64::from(b[k]), f64::from(c[k]));
            sum += (a - b).powi(2) / (c * c + 0.01);
        }
    }
    sum / (3 * x.pixels().len()).max(1) as f64
}

/// The two halves' mean, the reference, and their half difference (a − b)/2, which has the
/// mean's noise (for independent halves) and none of its signal.
fn mean_and_noise(a: &Image, b: &Image) -> Result<(Image, Image), String> {
    let (mean, noise): (Vec<Vec3>, Vec<Vec3>) = a
        .pixels()
        .iter()
        .zip(b.pixels())
        .map(|(x, y)| (0.5 * (*x + *y), 0.5 * (*x - *y)))
        .unzip();
    let image = |pixels| Image::from_pixels(a.width(), a.height(), pixels).ok_or("reference size");
    Ok((image(mean)?, image(noise)?))
}

/// Each frame's error x − r against its reference.
fn errors_of(frames: &[Image], references: &[Image]) -> Result<Vec<Image>, String> {
    frames
        .iter()
        .zip(references)
        .map(|(x, r)| {
            let pixels = x.pixels().iter().zip(r.pixels()).map(|(a, b)| *a - *b);
            Image::from_pixels(x.width(), x.height(), pixels.collect()).ok_or_else(|| {
                format!(
                    "a frame of {}×{} against a reference of {}×{}",
                    x.width(),
                    x.height(),
                    r.width(),
                    r.height()
                )
            })
        })
        .collect()
}

/// The temporal relMSE (module docs) of a sequence whose frames err by `errors` against
/// `references` (each pair's later frame carried into the earlier by `depths` through
/// `cameras`: mean((e₁ − C e₀)² / (r₁² + 0.01)) over every pair's carried pixels), by
/// [`BLOCK`]×[`BLOCK`]-pixel blocks of the later frames' raster, each over every pair: (the block's share of the carried pixels, its score), whose weighted sum is the score
/// and whose spread gives its standard error (blocks as compare's metrics use them: a
/// record's, or a denoiser's, errors are correlated over a few pixels, not over a block).
fn temporal_blocks(
    errors: &[Image],
    references: &[Image],
    depths: &[Image],
    cameras: &[Camera],
) -> Vec<(f64, f64)> {
    let Some(first) = errors.first() else {
        return Vec::new();
    };
    let (w, h) = (first.width(), first.height());
    let bw = w.div_ceil(BLOCK);
    let mut blocks = vec![(0.0f64, 0usize); (bw * h.div_ceil(BLOCK)) as usize];
    for f in 0..errors.len().saturating_sub(1) {
        pair_error(
            (&errors[f], &depths[f], &cameras[f]),
            (&errors[f + 1], &depths[f + 1], &cameras[f + 1]),
            &references[f + 1],
            |x, y, term| {
                let block = &mut blocks[((y / BLOCK) * bw + x / BLOCK) as usize];
                block.0 += term;
                block.1 += 1;
            },
        );
    }
    let total = blocks.iter().map(|b| b.1).sum::<usize>().max(1) as f64;
    blocks
        .iter()
        .map(|&(sum, n)| (n as f64 / total, if n == 0 { 0.0 } else { sum / n as f64 }))
        .collect()
}

/// One pair's terms: frame `b`'s errors against frame `a`'s carried to them, relative to
/// `reference_b` (the later frame's reference), each pixel and channel's handed to `add` with
/// the pixel of `b` it belongs to.
fn pair_error(
    (error_a, depth_a, camera_a): (&Image, &Image, &Camera),
    (error_b, depth_b, camera_b): (&Image, &Image, &Camera),
    reference_b: &Image,
    mut add: impl FnMut(u32, u32, f64),
) {
    let (w, h) = (error_b.width(), error_b.height());
    let tan = (0.5 * camera_b.yfov).tan();
    let aspect = w as f32 / h as f32;
    for y in 0..h {
        for x in 0..w {
            let ndc_x = 2.0 * (x as f32 + 0.5) / w as f32 - 1.0;
            let ndc_y = 1.0 - 2.0 * (y as f32 + 0.5) / h as f32;
            let direction = (camera_b.right * (ndc_x * tan * aspect)
                + camera_b.up * (ndc_y * tan)
                + camera_b.forward)
                .normalize();
            let point = camera_b.position + direction * depth_b.get(x, y).x;
            let Some((xa, ya)) = raster_of(camera_a, point, w, h) else {
                continue;
            };
            let expect = (point - camera_a.position).length();
            let (x0, y0) = (xa.floor() as u32, ya.floor() as u32);
            let corners = [(x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1)];
            if corners
                .iter()
                .any(|&(cx, cy)| (depth_a.get(cx, cy).x - expect).abs() > 0.01 * expect)
            {
                continue;
            }
            let (fx, fy) = (xa - x0 as f32, ya - y0 as f32);
            let carried = error_a.get(x0, y0) * ((1.0 - fx) * (1.0 - fy))
                + error_a.get(x0 + 1, y0) * (fx * (1.0 - fy))
                + error_a.get(x0, y0 + 1) * ((1.0 - fx) * fy)
                + error_a.get(x0 + 1, y0 + 1) * (fx * fy);
            let (now, r) = (error_b.get(x, y), reference_b.get(x, y));
            for k in 0..3 {
                let (p, q, r) = (f64::from(carried[k]), f64::from(now[k]), f64::from(r[k]));
                add(x, y, (q - p).powi(2) / (r * r + 0.01));
            }
        }
    }
}

/// Where `point` lands on `camera`'s `w` × `h` image, in pixel-centre coordinates (pixel (x, y)'s
/// centre at (x, y)), if in front of the camera and inside the pixel centres' hull.
fn raster_of(camera: &Camera, point: Vec3, w: u32, h: u32) -> Option<(f32, f32)> {
    let v = point - camera.position;
    let z = v.dot(camera.forward);
    if z <= 0.0 {
        return None;
    }
    let tan = (0.5 * camera.yfov).tan();
    let aspect = w as f32 / h as f32;
    let x = (v.dot(camera.right) / (z * tan * aspect) + 1.0) * 0.5 * w as f32 - 0.5;
    let y = (1.0 - v.dot(camera.up) / (z * tan)) * 0.5 * h as f32 - 0.5;
    (x >= 0.0 && y >= 0.0 && x < (w - 1) as f32 && y < (h - 1) as f32).then_some((x, y))
}

#[cfg(test)]
mod tests {
    use super::*;

    const SIZE: u32 = 16;

    /// The temporal score: the blocks' weighted sum.
    fn temporal(
        errors: &[Image],
        references: &[Image],
        depths: &[Image],
        cameras: &[Camera],
    ) -> f64 {
        temporal_blocks(errors, references, depths, cameras)
            .iter()
            .map(|(w, v)| w * v)
            .sum()
    }

    /// A flat wall 2 m in front of `camera` (the plane z = −2): the image of `radiance(p)` and the
    /// depth of each pixel's centre ray.
    fn wall(camera: &Camera, radiance: impl Fn(Vec3) -> f32) -> (Image, Image) {
        let tan = (0.5 * camera.yfov).tan();
        let (mut image, mut depth) = (Vec::new(), Vec::new());
        for y in 0..SIZE {
            for x in 0..SIZE {
                let nx = 2.0 * (x as f32 + 0.5) / SIZE as f32 - 1.0;
                let ny = 1.0 - 2.0 * (y as f32 + 0.5) / SIZE as f32;
                let d =
                    (camera.right * nx * tan + camera.up * ny * tan + camera.forward).normalize();
                let t = 2.0 / -d.z;
                image.push(Vec3::splat(radiance(camera.position + d * t)));
                depth.push(Vec3::splat(t));
            }
        }
        let of = |pixels| Image::from_pixels(SIZE, SIZE, pixels).unwrap_or_else(|| panic!());
        (of(image), of(depth))
    }

    /// Two views of the wall, the second 1 cm to the right (a third of a pixel at 16²).
    fn cameras() -> [Camera; 2] {
        let a = Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 0.8)
            .unwrap_or_else(|| panic!("camera"));
        let b = Camera {
            position: Vec3::new(0.01, 0.0, 0.0),
            ..a
        };
        [a, b]
    }

    /// The reference is curved (a ripple of 8 cm period), so the bilinear reading errs; the
    /// run's error is linear in the wall's position, so it is carried exactly. An error that
    /// stays on its surface point scores zero (f32 rounding: errors of 1e-2 carried with
    /// weights rounded at 2⁻²⁴, squared, far below 1e-10), though the reference's own change
    /// between the frames does not: that was the old measure's floor.
    #[test]
    fn an_error_that_stays_on_its_surface_point_scores_zero() {
        let cams = cameras();
        let reference = |p: Vec3| 1.0 + 0.5 * (p.x * 78.5).sin() * (p.y * 78.5).cos();
        let run = |p: Vec3| reference(p) + 0.01 + 0.02 * p.x - 0.01 * p.y;
        let (ra, da) = wall(&cams[0], reference);
        let (rb, db) = wall(&cams[1], reference);
        let (xa, _) = wall(&cams[0], run);
        let (xb, _) = wall(&cams[1], run);
        let (refs, depths) = ([ra, rb], [da, db]);
        let errors = errors_of(&[xa, xb], &refs).unwrap_or_else(|e| panic!("{e}"));
        let score = temporal(&errors, &refs, &depths, &cams);
        assert!(score < 1e-10, "{score}");
        // The reference's own change, carried the same way, is far from zero.
        let raw = temporal(&refs, &refs, &depths, &cams);
        assert!(raw > 1e-4, "{raw}");
    }

    /// An error drawn afresh in each frame scores its change: +δ in the first frame and −δ in
    /// the second give (2δ)² / (r² + 0.01) at every pixel carried, exactly (the carrying of a
    /// constant is the constant, its weights summing to 1 up to 2⁻²³).
    #[test]
    fn an_error_that_changes_scores_its_change() {
        let cams = cameras();
        let (delta, level) = (0.05f32, 0.8f32);
        let (ra, da) = wall(&cams[0], |_| level);
        let (rb, db) = wall(&cams[1], |_| level);
        let (xa, _) = wall(&cams[0], |_| level + delta);
        let (xb, _) = wall(&cams[1], |_| level - delta);
        let (refs, depths) = ([ra, rb], [da, db]);
        let errors = errors_of(&[xa, xb], &refs).unwrap_or_else(|e| panic!("{e}"));
        let score = temporal(&errors, &refs, &depths, &cams);
        let want = f64::from(2.0 * delta).powi(2) / (f64::from(level).powi(2) + 0.01);
        assert!((score / want - 1.0).abs() < 1e-5, "{score} vs {want}");
    }

    /// The half difference of two halves has their mean's noise and none of the signal.
    #[test]
    fn the_half_difference_holds_only_the_noise() {
        let px = |v: &[f32]| {
            Image::from_pixels(2, 1, v.iter().map(|&x| Vec3::splat(x)).collect())
                .unwrap_or_else(|| panic!())
        };
        let (mean, noise) =
            mean_and_noise(&px(&[1.0, 3.0]), &px(&[0.5, 3.0])).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(mean.get(0, 0).x, 0.75);
        assert_eq!(noise.get(0, 0).x, 0.25);
        assert_eq!(noise.get(1, 0).x, 0.0);
    }
}
