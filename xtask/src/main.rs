//! irr's developer commands, run as `cargo xtask <command>` (the alias in `.cargo/config.toml`
//! builds this crate in release mode).
//!
//! - `cargo xtask render`: the `irr` command (crates/irr-cli) on a glTF scene, by default the
//!   Cornell box in assets/, to `out/SCENE.exr` plus a PNG preview; `cargo xtask render --help`
//!   lists the options.
//! - `cargo xtask compare`: the irradiance cache against the path tracer (speed and error) on a
//!   scene; the report goes to target/compare/SCENE/.
//! - `cargo xtask walkthrough`: a camera path rendered with a shared cache, a cache per frame
//!   and the path tracer, each frame's error and the error between frames (flicker); the report
//!   goes to target/walkthrough/SCENE/.
//! - `cargo xtask tidy`: checks the codebase's own rules (also run by `cargo test` through the
//!   `#[test]`s in `tidy.rs`).
//!
//! The workspace root is found at run time ([`workspace_root`]): from the folder that `cargo run`
//! names in `CARGO_MANIFEST_DIR` (this crate's, in the checkout `cargo xtask` was typed in), else
//! from the current directory, walking up to the first `Cargo.toml` with a `[workspace]` table.
//! No path of the machine that compiled xtask is built in, so every command works from any folder
//! of any checkout.

use clap::{Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

mod compare;
mod render;
mod tidy;
mod walkthrough;

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
    Render(Box<render::RenderCommand>),
    /// Measure the irradiance cache's speed and error against the path tracer.
    Compare(compare::CompareArgs),
    /// Check the codebase's own rules: crate docs, and the one-way dependency table.
    Tidy,
    /// Render a camera path with a shared cache, a cache per frame and the path tracer, and
    /// measure each frame's error and the change between frames (flicker).
    Walkthrough(walkthrough::WalkthroughArgs),
}

/// The workspace root, found at run time (see the crate docs): the first folder at or above
/// `CARGO_MANIFEST_DIR` (set by `cargo run` for the process it starts), or else above the
/// current directory, whose `Cargo.toml` has a `[workspace]` table.
pub fn workspace_root() -> Result<PathBuf, String> {
    let start = match std::env::var_os("CARGO_MANIFEST_DIR") {
        Some(dir) => PathBuf::from(dir),
        None => std::env::current_dir()
            .map_err(|e| format!("cannot read the current directory: {e}"))?,
    };
    find_workspace_root(&start).ok_or_else(|| {
        format!(
            "no Cargo workspace at or above {}: run cargo xtask inside the irr checkout",
            start.display()
        )
    })
}

/// The first folder at or above `start` whose `Cargo.toml` has a `[workspace]` table.
pub fn find_workspace_root(start: &Path) -> Option<PathBuf> {
    start
        .ancestors()
        .find(|dir| {
            std::fs::read_to_string(dir.join("Cargo.toml"))
                .is_ok_and(|text| text.lines().any(|l| l.trim() == "[workspace]"))
        })
        .map(Path::to_path_buf)
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = workspace_root().and_then(|root| match cli.command {
        Command::Render(args) => render::run(*args, &root),
        Command::Compare(args) => compare::run(args, &root),
        Command::Tidy => tidy::run(&root),
        Command::Walkthrough(args) => walkthrough::run(args, &root),
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The root is found by walking up from any folder inside the workspace, and a folder
    /// outside any workspace has none.
    #[test]
    fn workspace_root_is_found_from_inside_and_not_outside() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let root = dir.path().join("ws");
        let deep = root.join("crates/a/src");
        std::fs::create_dir_all(&deep).unwrap_or_else(|e| panic!("{e}"));
        std::fs::write(root.join("Cargo.toml"), "[workspace]\nmembers = []\n")
            .unwrap_or_else(|e| panic!("{e}"));
        // A member's own manifest has no [workspace] table: the walk goes past it.
        std::fs::write(
            root.join("crates/a/Cargo.toml"),
            "[package]\nname = \"a\"\n",
        )
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(find_workspace_root(&deep), Some(root.clone()));
        assert_eq!(find_workspace_root(&root), Some(root));
        assert_eq!(find_workspace_root(dir.path()), None);
        // This checkout's root holds the default scene.
        let this = workspace_root().unwrap_or_else(|e| panic!("{e}"));
        assert!(this.join("assets/cornell-box.gltf").is_file());
    }
}
