//! `cargo xtask walkthrough`: a camera path through a static scene, rendered by the cache with
//! one cache shared by the frames, by the cache with a cache per frame, and by the path tracer
//! (and the path tracer denoised, in a build with the denoiser) at about the shared cache's time
//! per frame; each scored by its frames' error against a reference and by its **temporal
//! error**, how much a surface point's radiance changes from one frame to the next.
//!
//! Temporal error: each pixel of frame f + 1 is carried into frame f through the reference's
//! depth (the distance along the pixel's centre ray) and the two cameras, and frame f is read
//! there bilinearly; a pixel whose four neighbours' reference depths disagree with the carried
//! point's distance by over 1 % is a disocclusion (or an edge) and is left out. On Lambertian
//! surfaces the same point has the same radiance from any view, so an exact sequence scores only
//! the bilinear reading's error: the reference's own row is that floor (plus its noise), and
//! the next row the floor alone, the noise estimated from one half of each reference.
//! relMSE = mean((L₁ − L₀)² / (m² + 0.01)), m the two values' mean, averaged over the pairs.
//! A frame's error is relMSE = mean((x − r)² / (r² + 0.01)) against its reference frame.

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
    /// Camera samples per pixel of the denoised shared-cache row (built with the denoiser)
    #[arg(long, default_value_t = crate::compare::DENOISED_IC_SPP)]
    pub denoised_ic_spp: u32,
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
    let mut references = Vec::new();
    let mut first_halves = Vec::new();
    let mut depths = Vec::new();
    let mut reference_noise = 0.0;
    for camera in &cameras {
        let mut halves = Vec::new();
        for seed in REFERENCE_SEEDS {
            let s = settings((args.reference_spp / 2).max(1), seed);
            let out = render_with_aovs(&loaded.scene, camera, &pt, &s, &[Aov::Depth], false)
                .map_err(|e| e.to_string())?;
            halves.push(out);
        }
        let (a, b) = (&halves[0].image, &halves[1].image);
        let mean: Vec<Vec3> = a
            .pixels()
            .iter()
            .zip(b.pixels())
            .map(|(x, y)| 0.5 * (*x + *y))
            .collect();
        let mean = Image::from_pixels(args.size, args.size, mean).ok_or("reference size")?;
        // relMSE of the mean of two halves: the halves' difference squared, over 4.
        reference_noise += rel_mse(a, b, &mean) / 4.0;
        depths.push(
            halves[0]
                .aovs
                .get(Aov::Depth)
                .cloned()
                .ok_or("the reference has no depth")?,
        );
        first_halves.push(halves[0].image.clone());
        references.push(mean);
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
    // The same cache, its frames denoised (at compare's denoised camera samples).
    if DENOISER.is_some() {
        let start = Instant::now();
        let denoised_spp = args.denoised_ic_spp.max(1);
        let (frames, _) = render_frames(
            &loaded,
            &cameras,
            &shared,
            &settings(denoised_spp, RUN_SEED),
            true,
        )?;
        runs.push(Run {
            name: format!("ic + OIDN, shared cache, {denoised_spp} spp"),
            frames,
            indirect: None,
            seconds: built + start.elapsed().as_secs_f64(),
        });
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
    // The path tracer at about the shared cache's time: its rate from a 16-spp frame.
    let probe = Instant::now();
    render_frames(&loaded, &cameras[..1], &pt, &settings(16, RUN_SEED), false)?;
    let per_spp = probe.elapsed().as_secs_f64() / 16.0;
    let per_frame = runs[0].seconds / f64::from(args.frames);
    let path_spp = ((per_frame / per_spp.max(1e-9)) as u32).clamp(1, 4096);
    for denoised in [false, true] {
        if denoised && DENOISER.is_none() {
            continue;
        }
        let start = Instant::now();
        let (frames, indirect) = render_frames(
            &loaded,
            &cameras,
            &pt,
            &settings(path_spp, RUN_SEED),
            denoised,
        )?;
        runs.push(Run {
            name: format!(
                "path{}, {path_spp} spp",
                if denoised { " + OIDN" } else { "" }
            ),
            frames,
            indirect,
            seconds: start.elapsed().as_secs_f64(),
        });
    }
    // The report.
    let mut report = format!(
        "# Walkthrough: {}\n\n{} frames at {} fps, {}², {} spp for the cache runs, 2 threads unless \
         --threads; references 2 × {} spp (own relMSE {:.2e}). Temporal relMSE between consecutive \
         frames, each carried into the other by the reference's depth (module docs of \
         xtask/src/walkthrough.rs), of the image and of its indirect part.\n\n| run | seconds | \
         frame relMSE | temporal relMSE | temporal relMSE, indirect |\n|---|---|---|---|---|\n",
        scene.display(),
        args.frames,
        args.fps,
        args.size,
        spp,
        args.reference_spp / 2,
        reference_noise
    );
    let floor = temporal(&references, &depths, &cameras);
    let _ = writeln!(
        report,
        "| reference (the measure's floor) | — | — | {floor:.3e} | — |"
    );
    // Independent noise of variance v in each frame adds about 2v/(m² + 0.01) to a pair's
    // score; a half-sample reference has twice the mean's variance, so the floor without the
    // references' noise is about 2·T(means) − T(halves).
    let half = temporal(&first_halves, &depths, &cameras);
    let _ = writeln!(
        report,
        "| the floor, the references' noise removed (2·T(reference) − T(one half), T(one half) {half:.3e}) | — | — | {:.3e} | — |",
        2.0 * floor - half
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
            || "—".to_string(),
            |i| format!("{:.3e}", temporal(i, &depths, &cameras)),
        );
        let _ = writeln!(
            report,
            "| {} | {:.2} | {:.3e} | {:.3e} | {indirect} |",
            r.name,
            r.seconds,
            error,
            temporal(&r.frames, &depths, &cameras)
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

/// The temporal relMSE of `frames` (module docs), carried by `depths` through `cameras`.
pub fn temporal(frames: &[Image], depths: &[Image], cameras: &[Camera]) -> f64 {
    let pairs = frames.len().saturating_sub(1);
    if pairs == 0 {
        return 0.0;
    }
    let mut total = 0.0;
    for f in 0..pairs {
        total += pair_error(
            (&frames[f], &depths[f], &cameras[f]),
            (&frames[f + 1], &depths[f + 1], &cameras[f + 1]),
        );
    }
    total / pairs as f64
}

/// The temporal relMSE of one pair: frame `b`'s pixels carried into frame `a`.
fn pair_error(
    (image_a, depth_a, camera_a): (&Image, &Image, &Camera),
    (image_b, depth_b, camera_b): (&Image, &Image, &Camera),
) -> f64 {
    let (w, h) = (image_b.width(), image_b.height());
    let tan = (0.5 * camera_b.yfov).tan();
    let aspect = w as f32 / h as f32;
    let (mut sum, mut count) = (0.0f64, 0usize);
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
            let carried = image_a.get(x0, y0) * ((1.0 - fx) * (1.0 - fy))
                + image_a.get(x0 + 1, y0) * (fx * (1.0 - fy))
                + image_a.get(x0, y0 + 1) * ((1.0 - fx) * fy)
                + image_a.get(x0 + 1, y0 + 1) * (fx * fy);
            let now = image_b.get(x, y);
            for k in 0..3 {
                let (p, q) = (f64::from(carried[k]), f64::from(now[k]));
                let m = 0.5 * (p + q);
                sum += (q - p).powi(2) / (m * m + 0.01);
            }
            count += 3;
        }
    }
    if count == 0 { 0.0 } else { sum / count as f64 }
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

    /// A flat wall 2 m in front of a camera that slides sideways by 1 cm, its radiance a
    /// function of the wall's position (so a view-independent, exact sequence): carried
    /// between the frames it scores only the bilinear reading's error, which for a radiance
    /// linear in position is zero up to f32 rounding; a sequence whose second frame is
    /// brighter by 10 % everywhere scores ≈ (0.1/1.05)² relative (m the pair's mean).
    #[test]
    fn a_view_independent_sequence_scores_zero_and_a_change_does_not() {
        let size = 16;
        let a = Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 0.8)
            .unwrap_or_else(|| panic!("camera"));
        let b = Camera {
            position: Vec3::new(0.01, 0.0, 0.0),
            ..a
        };
        let frame = |camera: &Camera, gain: f32| {
            let tan = (0.5 * camera.yfov).tan();
            let (mut image, mut depth) = (Vec::new(), Vec::new());
            for y in 0..size {
                for x in 0..size {
                    let nx = 2.0 * (x as f32 + 0.5) / size as f32 - 1.0;
                    let ny = 1.0 - 2.0 * (y as f32 + 0.5) / size as f32;
                    let d = (camera.right * nx * tan + camera.up * ny * tan + camera.forward)
                        .normalize();
                    // The wall z = −2.
                    let t = 2.0 / -d.z;
                    let p = camera.position + d * t;
                    image.push(Vec3::splat(gain * (1.0 + 0.1 * p.x + 0.05 * p.y)));
                    depth.push(Vec3::splat(t));
                }
            }
            (
                Image::from_pixels(size, size, image).unwrap_or_else(|| panic!("image")),
                Image::from_pixels(size, size, depth).unwrap_or_else(|| panic!("depth")),
            )
        };
        let (ia, da) = frame(&a, 1.0);
        let (ib, db) = frame(&b, 1.0);
        let exact = temporal(&[ia.clone(), ib], &[da.clone(), db.clone()], &[a, b]);
        assert!(exact < 1e-10, "{exact}");
        let (ic, _) = frame(&b, 1.1);
        let changed = temporal(&[ia, ic], &[da, db], &[a, b]);
        let want = (0.1f64 / 1.05).powi(2);
        assert!((changed / want - 1.0).abs() < 0.05, "{changed} vs {want}");
    }
}
