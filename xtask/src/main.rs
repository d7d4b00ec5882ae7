//! irr's developer commands, run as `cargo xtask <command>` (the alias in `.cargo/config.toml`
//! builds this crate in release mode).
//!
//! - `cargo xtask render`: the `irr` command (crates/irr-cli) on a glTF scene, by default the
//!   Cornell box in assets/, to `out/<scene>.exr` plus a PNG preview; `cargo xtask render --help`
//!   lists the options.
//! - `cargo xtask compare`: the irradiance cache against the path tracer (speed and error) on a
//!   scene; the report goes to target/compare/<scene>/.
//! - `cargo xtask tidy`: checks the codebase's own rules (also run by `cargo test` through the
//!   `#[test]`s in `tidy.rs`).
//!
//! The workspace root is found from `CARGO_MANIFEST_DIR`, so every command works from any folder.

use clap::{Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

mod compare;
mod render;
mod tidy;

/// irr's developer commands.
#[derive(Parser)]
#[command(name = "cargo xtask", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a glTF scene to OpenEXR (linear radiance) and a PNG preview.
    Render(render::RenderCommand),
    /// Measure the irradiance cache's speed and error against the path tracer.
    Compare(compare::CompareArgs),
    /// Check the codebase's own rules: crate docs, and the one-way dependency table.
    Tidy,
}

/// The workspace root: the parent of this crate's folder.
pub fn workspace_root() -> PathBuf {
    let manifest_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    manifest_dir.parent().unwrap_or(manifest_dir).to_path_buf()
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render::run(args, &workspace_root()),
        Command::Compare(args) => compare::run(args, &workspace_root()),
        Command::Tidy => tidy::run(&workspace_root()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}
