//! Loads a scene the way `cargo xtask render` does (glTF, then the BVH build) and prints what it
//! holds and how long each part took, or the one-line error. For measuring the loader:
//! `/usr/bin/time -v cargo run -p irr-render --example load -- scene.gltf [--asset-root DIR]`
//! (see docs/fuzzing.md for the hostile files).

use irr_render::{LoadOptions, load_gltf_with, load_scene_with};
use std::process::ExitCode;
use std::time::Instant;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(scene) = args.first() else {
        eprintln!("usage: load SCENE [--asset-root DIR] [--no-bvh]");
        return ExitCode::FAILURE;
    };
    let asset_root = args
        .iter()
        .position(|a| a == "--asset-root")
        .and_then(|i| args.get(i + 1))
        .map(Into::into);
    let options = LoadOptions {
        asset_root,
        ..LoadOptions::default()
    };
    let started = Instant::now();
    if args.iter().any(|a| a == "--no-bvh") {
        return match load_gltf_with(scene.as_ref(), &options) {
            Ok(data) => {
                let triangles: usize = data.meshes.iter().map(|m| m.indices.len()).sum();
                let unique: usize = data.prototypes.iter().map(|m| m.indices.len()).sum();
                println!(
                    "{scene}: {triangles} triangles in {} meshes, {unique} in {} prototypes placed {} times, loaded in {:.3} s",
                    data.meshes.len(),
                    data.prototypes.len(),
                    data.instances.len(),
                    started.elapsed().as_secs_f64()
                );
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::FAILURE
            }
        };
    }
    match load_scene_with(scene.as_ref(), &options) {
        Ok(loaded) => {
            let geometry = loaded.scene.geometry();
            println!(
                "{scene}: {} triangles ({} unique), {} warnings, loaded and BVH built in {:.3} s",
                geometry.triangle_count(),
                geometry.unique_triangle_count(),
                loaded.warnings.len(),
                started.elapsed().as_secs_f64()
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
