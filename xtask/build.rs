//! - `IRR_RENDERER_DIGEST`: a digest (FNV-1a, 64 bits) of the source of every crate that renders
//!   and of Cargo.lock, so that `cargo xtask compare` renders its cached reference again when
//!   the renderer that made it has changed.
//! - With the `denoise` feature: records Intel Open Image Denoise's folder (OIDN_DIR/lib, which
//!   irr-render's build script checks) as a run-time search path of this package's binary and
//!   tests, so they start without LD_LIBRARY_PATH.

use std::path::{Path, PathBuf};

/// The crates whose source decides a reference's pixels.
const RENDERER: [&str; 9] = [
    "irr-geometry",
    "irr-sampling",
    "irr-sh",
    "irr-bsdf",
    "irr-cache",
    "irr-gradients",
    "irr-scene",
    "irr-integrator",
    "irr-render",
];

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            files(&path, out);
        } else {
            out.push(path);
        }
    }
}

fn fnv(bytes: &[u8], mut h: u64) -> u64 {
    for &b in bytes {
        h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

fn main() {
    let manifest = std::env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default();
    let root = Path::new(&manifest).join("..");
    let mut paths = vec![root.join("Cargo.lock")];
    for name in RENDERER {
        let dir = root.join("crates").join(name);
        println!("cargo::rerun-if-changed={}", dir.join("src").display());
        println!(
            "cargo::rerun-if-changed={}",
            dir.join("Cargo.toml").display()
        );
        paths.push(dir.join("Cargo.toml"));
        files(&dir.join("src"), &mut paths);
    }
    println!(
        "cargo::rerun-if-changed={}",
        root.join("Cargo.lock").display()
    );
    paths.sort();
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for path in &paths {
        let relative = path.strip_prefix(&root).unwrap_or(path);
        h = fnv(relative.to_string_lossy().as_bytes(), h);
        h = fnv(&std::fs::read(path).unwrap_or_default(), h);
    }
    println!("cargo::rustc-env=IRR_RENDERER_DIGEST={h:016x}");

    println!("cargo::rerun-if-env-changed=OIDN_DIR");
    if let (Some(_), Some(dir)) = (
        std::env::var_os("CARGO_FEATURE_DENOISE"),
        std::env::var_os("OIDN_DIR"),
    ) {
        let lib = Path::new(&dir).join("lib");
        println!("cargo::rustc-link-arg=-Wl,-rpath,{}", lib.display());
    }
}
