//! `irr SCENE [-o OUT] [options]`: renders a glTF 2.0 scene to OpenEXR plus a PNG preview.
//! `irr --help` lists every option with its default.

use clap::Parser;
use irr_cli::RenderArgs;
use std::path::PathBuf;
use std::process::ExitCode;

/// Render a glTF 2.0 scene (.gltf or .glb) to OpenEXR (linear radiance) and a PNG preview.
#[derive(Parser)]
#[command(name = "irr", version, about)]
struct Cli {
    /// The glTF 2.0 scene (.gltf or .glb)
    scene: PathBuf,
    /// Output OpenEXR file; the PNG preview is written beside it with the same stem
    /// [default: <scene stem>.exr in the current directory]
    #[arg(short, long)]
    out: Option<PathBuf>,
    #[command(flatten)]
    args: RenderArgs,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let out = cli
        .out
        .unwrap_or_else(|| irr_cli::default_output(&cli.scene));
    match irr_cli::run(cli.args, &cli.scene, &out) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}
