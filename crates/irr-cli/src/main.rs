//! `irr SCENE [-o OUT] [options]`: renders a glTF 2.0 scene to OpenEXR plus a PNG preview.
//! `irr --help` lists every option with its default.
//!
//! `irr cache merge SHARD… -o OUT`: joins the shard files of a walkthrough's shared cache
//! (`--shared-cache --shards S --shard I --cache FILE`) into the sequence's cache file. (A
//! scene file named `cache` is given as `./cache`.)

use clap::{Parser, Subcommand};
use irr_cli::RenderArgs;
use std::path::PathBuf;
use std::process::ExitCode;

/// Render a glTF 2.0 scene (.gltf or .glb) to OpenEXR (linear radiance) and a PNG preview.
/// `irr cache merge --help`: join the shards of a walkthrough's shared cache.
#[derive(Parser)]
#[command(name = "irr", version, about)]
struct Cli {
    /// The glTF 2.0 scene (.gltf or .glb)
    scene: PathBuf,
    /// Output OpenEXR file; the PNG preview is written beside it with the same stem
    /// [default: the scene's stem with .exr, in the current directory]
    #[arg(short, long)]
    out: Option<PathBuf>,
    #[command(flatten)]
    args: RenderArgs,
}

/// Work on cache files.
#[derive(Parser)]
#[command(name = "irr cache", bin_name = "irr cache", version)]
struct CacheCli {
    #[command(subcommand)]
    command: CacheCommand,
}

#[derive(Subcommand)]
enum CacheCommand {
    /// Join the shard files of one sequence's shared cache, in any order, into the sequence's
    /// cache file (the shards in index order, a record repeated by a later shard dropped): the
    /// same bytes whichever machine built which shard
    Merge {
        /// The shard files (every shard of the sequence, once)
        #[arg(required = true)]
        shards: Vec<PathBuf>,
        /// The sequence's cache file to write
        #[arg(short, long)]
        out: PathBuf,
    },
}

fn main() -> ExitCode {
    let result = if std::env::args_os().nth(1).is_some_and(|a| a == "cache") {
        let cli = CacheCli::parse_from(std::env::args_os().skip(1));
        match cli.command {
            CacheCommand::Merge { shards, out } => {
                irr_cli::sequence::merge(&shards, &out).map(|summary| eprintln!("{summary}"))
            }
        }
    } else {
        let cli = Cli::parse();
        let out = cli
            .out
            .unwrap_or_else(|| irr_cli::default_output(&cli.scene));
        irr_cli::run(cli.args, &cli.scene, &out)
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}
