//! `cargo xtask render`: a thin command-line layer over irr-render's library functions.
//!
//! Order of work: check the settings and that the output can be written (fail fast, before any
//! rendering), load the scene and print its warnings, render with a progress bar, print the
//! summary, write EXR + PNG (temporary files renamed into place).

use clap::{Args, ValueEnum};
use irr_render::{
    AmbientOcclusion, AoSettings, Integrator, LoadOptions, PathSettings, PathTracer,
    RenderSettings, check_exposure, check_output, load_scene_with, mean_of_samples, pixel_samples,
    remove_partial_outputs_on_signals, render, write_exr_and_png,
};
use std::path::{Path, PathBuf};

/// Which integrator estimates the radiance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum IntegratorChoice {
    /// The unbiased path tracer (next-event estimation, Russian roulette): the reference.
    Path,
    /// Ambient occlusion (cosine-weighted, unbounded distance): grey, no emitters needed.
    Ao,
}

/// Render a glTF scene to OpenEXR (linear radiance) and a PNG preview beside it.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The glTF 2.0 scene (.gltf or .glb) [default: assets/cornell-box.gltf in the workspace]
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// The integrator
    #[arg(long, value_enum, default_value_t = IntegratorChoice::Path)]
    pub integrator: IntegratorChoice,
    /// Samples per pixel (≥ 1)
    #[arg(long, default_value_t = RenderSettings::default().spp.into(), allow_negative_numbers = true)]
    pub spp: i64,
    /// Image width in pixels (1 to 16384)
    #[arg(long, default_value_t = RenderSettings::default().width.into(), allow_negative_numbers = true)]
    pub width: i64,
    /// Image height in pixels (1 to 16384)
    #[arg(long, default_value_t = RenderSettings::default().height.into(), allow_negative_numbers = true)]
    pub height: i64,
    /// Worker threads; 0 means one per core
    #[arg(long, default_value_t = RenderSettings::default().threads as i64, allow_negative_numbers = true)]
    pub threads: i64,
    /// Seed of every random number (same seed, same image, bit for bit, for any thread count)
    #[arg(long, default_value_t = RenderSettings::default().seed, allow_negative_numbers = true)]
    pub seed: u64,
    /// Output OpenEXR file; the PNG preview is written beside it with the same stem
    /// [default: out/<scene stem>.exr in the workspace]
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Maximum number of bounces of the path tracer (0: emitters seen directly only)
    #[arg(long, default_value_t = PathSettings::default().max_depth)]
    pub max_depth: u32,
    /// Exposure of the PNG preview in stops: radiance × 2^exposure, clipped to [0, 1], sRGB
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// The folder whose files the scene's buffer URIs may read (after resolving `..` and
    /// symbolic links) [default: the scene file's folder]
    #[arg(long, value_name = "DIR")]
    pub asset_root: Option<PathBuf>,
    /// Render only pixel X,Y (0,0 is the top-left) and print each sample's radiance; writes
    /// nothing
    #[arg(long, value_name = "X,Y", value_parser = parse_pixel)]
    pub debug_pixel: Option<(u32, u32)>,
}

fn parse_pixel(text: &str) -> Result<(u32, u32), String> {
    let (x, y) = text
        .split_once(',')
        .ok_or_else(|| format!("expected X,Y, got '{text}'"))?;
    let parse = |s: &str| {
        s.trim()
            .parse::<u32>()
            .map_err(|e| format!("'{s}' in '{text}': {e}"))
    };
    Ok((parse(x)?, parse(y)?))
}

/// Runs `cargo xtask render`; the error is one line naming the file or option and the problem.
pub fn run(args: RenderArgs, root: &Path) -> Result<(), String> {
    let settings =
        RenderSettings::from_options(args.width, args.height, args.spp, args.seed, args.threads)
            .map_err(|e| e.to_string())?;
    check_exposure(args.exposure).map_err(|e| e.to_string())?;
    let scene_path = args
        .scene
        .clone()
        .unwrap_or_else(|| root.join("assets").join("cornell-box.gltf"));
    let out = args.out.clone().unwrap_or_else(|| {
        let stem = scene_path
            .file_stem()
            .map_or_else(|| "render".into(), |s| s.to_string_lossy().into_owned());
        root.join("out").join(format!("{stem}.exr"))
    });
    if args.debug_pixel.is_none() {
        // Before spending minutes: is there somewhere to put the result?
        check_output(&out).map_err(|e| e.to_string())?;
    }
    let options = LoadOptions {
        asset_root: args.asset_root.clone(),
    };
    let loaded = {
        // The BVH build of a large (or badly shaped) scene can take a while: say so.
        let spinner = indicatif::ProgressBar::new_spinner();
        spinner.set_message(format!(
            "loading {} and building its BVH",
            scene_path.display()
        ));
        spinner.enable_steady_tick(std::time::Duration::from_millis(100));
        let started = std::time::Instant::now();
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
    for w in &loaded.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(note) = loaded.aspect_note(settings.width, settings.height) {
        eprintln!("warning: {note}");
    }
    if loaded.camera.is_none() {
        eprintln!(
            "note: {} has no camera: irr frames the scene's bounds from +Z with a 45° vertical field of view",
            scene_path.display()
        );
    }
    let camera = loaded.camera_for(settings.width, settings.height);
    let mut integrator: Box<dyn Integrator> = match args.integrator {
        IntegratorChoice::Path => Box::new(PathTracer::new(PathSettings {
            max_depth: args.max_depth,
            ..PathSettings::default()
        })),
        IntegratorChoice::Ao => Box::new(AmbientOcclusion::new(AoSettings::default())),
    };
    integrator.preprocess(&loaded.scene);

    if let Some((x, y)) = args.debug_pixel {
        let samples = pixel_samples(&loaded.scene, &camera, &*integrator, &settings, x, y)
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

    // From here on temporary output files may exist: delete them if the user interrupts.
    remove_partial_outputs_on_signals()?;
    let output =
        render(&loaded.scene, &camera, &*integrator, &settings, true).map_err(|e| e.to_string())?;
    eprintln!("{}", output.stats.summary());
    if output.stats.non_finite_samples > 0 {
        eprintln!(
            "warning: {} samples were NaN or infinite and counted as black; replay one with --debug-pixel",
            output.stats.non_finite_samples
        );
    }
    let (exr, png) =
        write_exr_and_png(&output.image, &out, args.exposure).map_err(|e| e.to_string())?;
    println!("wrote {} and {}", exr.display(), png.display());
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
            (cli.args.width, cli.args.height, cli.args.spp),
            (256, 256, 256)
        );
        assert_eq!(cli.args.integrator, IntegratorChoice::Path);
        // Negative sizes reach the library's range check, which names the option.
        let cli = Cli::try_parse_from(["render", "--width", "-5", "--debug-pixel", "3,4"])
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(cli.args.debug_pixel, Some((3, 4)));
        let e = run(cli.args, Path::new("/nonexistent"))
            .err()
            .unwrap_or_default();
        assert_eq!(e, "--width: must be between 1 and 16384, got -5");
    }

    /// Issue 12, item 7: a bad exposure or seed is refused before anything is loaded or
    /// rendered, naming the option.
    #[test]
    fn bad_exposure_and_seed_are_refused_up_front() {
        for exposure in ["NaN", "inf", "-inf"] {
            let option = format!("--exposure={exposure}");
            let cli = Cli::try_parse_from(["render", &option, "--scene", "/nowhere"])
                .unwrap_or_else(|e| panic!("{e}"));
            // The scene does not exist: an error about it would mean the exposure was not
            // checked first.
            let e = run(cli.args, Path::new("/nonexistent"))
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

    #[test]
    fn bad_pixels_are_refused() {
        assert!(parse_pixel("3").is_err());
        assert!(parse_pixel("3,-1").is_err());
        assert_eq!(parse_pixel(" 3, 4"), Ok((3, 4)));
    }
}
