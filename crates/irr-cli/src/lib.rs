//! The `irr` command, as a library and a binary: render a glTF 2.0 scene to OpenEXR and a PNG
//! preview with the irradiance cache (the default), the path tracer or ambient occlusion.
//!
//! # What it owns
//! - [`RenderArgs`]: every render option (integrator, size, samples, seed, threads, exposure,
//!   `--camera`, `--aov`, the irradiance cache's settings, `--cache`, `--show-records`,
//!   `--debug-pixel`, `--asset-root`, `--background`, `--denoise`), parsed with clap, each
//!   checked with a one-line error naming the option. A missing `--width` or `--height` follows from the other and the
//!   camera's aspect ratio.
//! - [`run`]: load, build the cache, render, denoise if asked, write the EXR (colour, AOVs, chromaticities and
//!   the render's metadata) and its PNG preview; used by the `irr` binary (scene as a positional
//!   argument, output [`default_output`], `<scene stem>.exr` in the current directory, unless
//!   `-o` says otherwise) and by `cargo xtask render` (the workspace's default scene, output in
//!   out/).
//!
//! - [`sequence`]: a walkthrough's shared cache (`--shared-cache`, its shards and its file) and
//!   `irr cache merge`, which joins shard files built by other processes.
//!
//! # What it must not know
//! How anything is rendered: it turns options into irr-render's and irr-integrator's settings
//! and calls their functions. No estimator, no file format lives here.
//!
//! # Example
//! ```
//! use clap::Parser;
//! use irr_cli::RenderArgs;
//!
//! #[derive(Parser)]
//! struct Cli {
//!     #[command(flatten)]
//!     args: RenderArgs,
//! }
//! let cli = Cli::try_parse_from(["irr", "--integrator", "path", "--spp", "4"])?;
//! assert_eq!(cli.args.spp, Some(4));
//! // A nonsense option is an error that names it, before anything is loaded.
//! let bad = Cli::try_parse_from(["irr", "--width", "0"])?;
//! let e = irr_cli::run(bad.args, "scene.gltf".as_ref(), "out.exr".as_ref()).err();
//! assert_eq!(e.as_deref(), Some("--width: must be between 1 and 16384, got 0"));
//! # Ok::<(), clap::Error>(())
//! ```

pub mod render;
pub mod sequence;

pub use render::{IcArgs, IntegratorChoice, RenderArgs, default_output, default_spp, run};
