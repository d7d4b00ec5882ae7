//! `cargo xtask render`: the `irr` command (irr-cli's `run`, the same code and options) with the
//! workspace's defaults: the Cornell box in assets/ as the scene, and out/SCENE-STEM.exr as
//! the output, both under the workspace root found at run time.

use clap::Args;
use irr_cli::RenderArgs;
use std::path::{Path, PathBuf};

/// Render a glTF scene to OpenEXR (linear radiance) and a PNG preview beside it.
#[derive(Args, Debug)]
pub struct RenderCommand {
    /// The glTF 2.0 scene (.gltf or .glb) [default: assets/cornell-box.gltf in the workspace]
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Output OpenEXR file; the PNG preview is written beside it with the same stem
    /// [default: out/SCENE-STEM.exr in the workspace]
    #[arg(short, long)]
    pub out: Option<PathBuf>,
    /// Every option of `irr`
    #[command(flatten)]
    pub args: RenderArgs,
}

/// Runs `cargo xtask render` from the workspace root `root`.
pub fn run(command: RenderCommand, root: &Path) -> Result<(), String> {
    let scene = command
        .scene
        .unwrap_or_else(|| root.join("assets").join("cornell-box.gltf"));
    let out = command.out.unwrap_or_else(|| {
        let stem = scene
            .file_stem()
            .map_or_else(|| "render".into(), |s| s.to_string_lossy().into_owned());
        root.join("out").join(format!("{stem}.exr"))
    });
    irr_cli::run(command.args, &scene, &out)
}
