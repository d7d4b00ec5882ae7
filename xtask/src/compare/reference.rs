//! The reference every run is scored against: the path tracer at high spp, as two halves of
//! their own seeds, cached under target/compare/cache/ by everything that decides its pixels.

use irr_render::{Image, LoadedScene, PathSettings, RenderSettings, write_exr_and_png};
use std::path::{Path, PathBuf};

use super::metrics::metrics;
use super::{Layer, path_render};

/// The seeds of the reference's two halves: above any run's seed (`super::run_seeds`, at most
/// `u32::MAX`), since a run that shared a half's seed would draw that half's first samples per
/// pixel, and its error against it would read low.
pub const REFERENCE_SEEDS: [u64; 2] = [0x5eed_0000_0000_0001, 0x5eed_0000_0000_0002];

/// The path tracer's settings for the reference: the defaults, and never adaptive (a pixel that
/// stops on its own samples is biased slightly; the reference must not be).
pub fn reference_path() -> PathSettings {
    PathSettings {
        pixel_error: 0.0,
        ..PathSettings::default()
    }
}

/// A digest of the source of every crate that renders (geometry, sampling, cache, gradients,
/// integrator, render) and of Cargo.lock, from xtask's build script: a reference rendered by
/// another build of the renderer is not reused.
pub const RENDERER_DIGEST: &str = env!("IRR_RENDERER_DIGEST");

/// What decides the reference's pixels, as text (written beside the image, and hashed into
/// its file name): every byte the scene was read from, the size, the samples, the seeds, the
/// path tracer's settings, the renderer's source and the layer (named unless the image itself).
pub fn reference_key(
    loaded: &LoadedScene,
    width: u32,
    height: u32,
    spp: u32,
    layer: Layer,
) -> String {
    let mut key = format!(
        "scene digest {:016x}; {width}x{height}; {spp} spp as 2 halves, seeds {REFERENCE_SEEDS:?}; \
         {:?}; renderer source {RENDERER_DIGEST}",
        loaded.digest,
        reference_path()
    );
    if let Some(aov) = layer.aov() {
        key.push_str(&format!("; layer {aov}"));
    }
    key
}

/// The reference image (mean of two halves; its `layer`) and its own relMSE, from the cache
/// or rendered (unless `fresh`).
pub fn reference(
    loaded: &LoadedScene,
    base: &RenderSettings,
    spp: u32,
    cache_dir: &Path,
    (fresh, layer): (bool, Layer),
) -> Result<(Image, f64, PathBuf), String> {
    let key = reference_key(loaded, base.width, base.height, spp, layer);
    let hash = irr_render::fingerprint(&[key.as_bytes()]);
    let path = cache_dir.join(format!("reference-{hash:016x}.exr"));
    let noise_path = cache_dir.join(format!("reference-{hash:016x}.noise"));
    let key_path = cache_dir.join(format!("reference-{hash:016x}.key"));
    if !fresh
        && path.exists()
        && std::fs::read_to_string(&key_path).is_ok_and(|k| k.trim() == key)
        && let (Ok(image), Ok(noise)) =
            (Image::read_exr(&path), std::fs::read_to_string(&noise_path))
        && let Ok(noise) = noise.trim().parse::<f64>()
    {
        eprintln!("reference: {} (cached)", path.display());
        return Ok((image, noise, path));
    }
    let half = (spp / 2).max(1);
    eprintln!(
        "reference: path tracer, 2 × {half} spp at {}×{} (cached at {})",
        base.width,
        base.height,
        path.display()
    );
    let [a, b] = REFERENCE_SEEDS.map(|seed| RenderSettings {
        spp: half,
        seed,
        ..*base
    });
    let (ia, ..) = path_render(loaded, &a, reference_path(), (false, layer))?;
    let (ib, ..) = path_render(loaded, &b, reference_path(), (false, layer))?;
    let pixels = ia
        .pixels()
        .iter()
        .zip(ib.pixels())
        .map(|(x, y)| (*x + *y) * 0.5)
        .collect();
    let image = Image::from_pixels(base.width, base.height, pixels)
        .ok_or("reference halves differ in size")?;
    // relMSE(a, b) ≈ 2 × relMSE(half) = 4 × relMSE(reference), with the reference (≈ b) as r.
    let noise = metrics(&ia, &ib).rel_mse / 4.0;
    std::fs::create_dir_all(cache_dir).map_err(|e| format!("{}: {e}", cache_dir.display()))?;
    write_exr_and_png(&image, &path, 0.0).map_err(|e| e.to_string())?;
    std::fs::write(&noise_path, format!("{noise:e}\n"))
        .map_err(|e| format!("{}: {e}", noise_path.display()))?;
    std::fs::write(&key_path, format!("{key}\n"))
        .map_err(|e| format!("{}: {e}", key_path.display()))?;
    Ok((image, noise, path))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The runs' seeds, for any `--seeds`, are none of the reference's, and the reference is
    /// not adaptive.
    #[test]
    fn seeds_are_disjoint_and_the_reference_is_not_adaptive() {
        for n in [2, 3, 1000] {
            let seeds = super::super::run_seeds(n);
            assert!(REFERENCE_SEEDS.iter().all(|s| !seeds.contains(s)), "{n}");
        }
        // run_seeds is 1..=n, so its largest is n: every reference seed lies above u32::MAX.
        assert!(REFERENCE_SEEDS.iter().all(|&s| s > u64::from(u32::MAX)));
        assert_eq!(reference_path().pixel_error, 0.0);
    }

    /// The key names the renderer's source digest, the seeds and the path tracer's settings,
    /// and changes with the size, the spp and the scene's bytes.
    #[test]
    fn the_key_covers_the_renderer_and_the_settings() {
        let root = crate::workspace_root().unwrap_or_else(|e| panic!("{e}"));
        let a = irr_render::load_scene(&root.join("assets/cornell-box.gltf"))
            .unwrap_or_else(|e| panic!("{e}"));
        let b = irr_render::load_scene(&root.join("assets/indirect-room.gltf"))
            .unwrap_or_else(|e| panic!("{e}"));
        let key = reference_key(&a, 48, 48, 512, Layer::Colour);
        assert!(
            key.contains(RENDERER_DIGEST) && RENDERER_DIGEST.len() == 16,
            "{key}"
        );
        assert!(key.contains(&format!("{:?}", reference_path())), "{key}");
        assert!(key.contains(&format!("{REFERENCE_SEEDS:?}")), "{key}");
        for other in [
            reference_key(&a, 48, 40, 512, Layer::Colour),
            reference_key(&a, 48, 48, 1024, Layer::Colour),
            reference_key(&b, 48, 48, 512, Layer::Colour),
            reference_key(&a, 48, 48, 512, Layer::Indirect),
            reference_key(&a, 48, 48, 512, Layer::GlossyIndirect),
        ] {
            assert_ne!(key, other);
        }
    }
}
