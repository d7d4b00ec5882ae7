//! Denoising a render with Intel Open Image Denoise (OIDN): its `RT` filter on the colour, with
//! the first hit's albedo and normal ([`Aov::Albedo`], [`Aov::Normal`]) as auxiliary images,
//! HDR, quality high. This is what Blender's Cycles, V-Ray and Arnold run on a path tracer's
//! image, and what a user of an irradiance cache compares it with.
//!
//! The library is optional: the `denoise` cargo feature links it through the `oidn` crate
//! (OIDN_DIR names the folder; README, "Denoising"). In a build without the feature
//! [`DENOISER`] is `None` and [`denoise`] returns an error that says how to get one, so the
//! command line can refuse `--denoise` before rendering anything.
//!
//! # Determinism
//! The filter is a fixed convolutional network applied to the image: the same input gives the
//! same output on one machine, whatever irr's thread count (OIDN keeps its own thread pool, all
//! cores by default; the `OIDN_NUM_THREADS` environment variable limits it). Its kernels are
//! chosen by the CPU's instruction set, so two machines with different vector units (AVX-512,
//! AVX2) may differ in the last bits of the denoised image; the raw colour does not.

use crate::aov::{Aov, AovImages};
use crate::error::RenderError;
use crate::image::Image;

/// The denoiser this build links, as the summary names it; `None` without the `denoise`
/// feature.
#[cfg(feature = "denoise")]
pub const DENOISER: Option<&str> =
    Some("Intel Open Image Denoise 2 (RT filter, HDR, high quality)");
/// The denoiser this build links, as the summary names it; `None` without the `denoise`
/// feature.
#[cfg(not(feature = "denoise"))]
pub const DENOISER: Option<&str> = None;

/// Why a build without the `denoise` feature cannot denoise, and how to get one that can.
pub const NO_DENOISER: &str = "this build of irr has no denoiser: install Intel Open Image \
     Denoise with `python3 -m pip install --no-deps --target target/oidn pyoidn==2.5.1` and build \
     with the `denoise` feature (`cargo install --locked --profile dist --path crates/irr-cli \
     --features denoise`, or `cargo xtask-oidn render --denoise`; README, \"Denoising\")";

/// The AOVs the denoiser reads beside the colour.
pub const DENOISER_AOVS: [Aov; 2] = [Aov::Albedo, Aov::Normal];

/// `colour` denoised by OIDN's `RT` filter with the render's albedo and normal (both must be
/// in `aovs`, of the colour's size). Errors name the problem on one line: a missing or
/// mis-sized auxiliary image, a library that cannot start (no CPU device module beside it), or
/// a build without the denoiser ([`NO_DENOISER`]).
pub fn denoise(colour: &Image, aovs: &AovImages) -> Result<Image, RenderError> {
    let aux = |aov: Aov| {
        let image = aovs.get(aov).ok_or_else(|| {
            denoise_error(format!("the denoiser needs the {aov} image of the render"))
        })?;
        if (image.width(), image.height()) != (colour.width(), colour.height()) {
            return Err(denoise_error(format!(
                "the {aov} image is {}×{}, the colour {}×{}",
                image.width(),
                image.height(),
                colour.width(),
                colour.height()
            )));
        }
        Ok(image)
    };
    let [albedo, normal] = DENOISER_AOVS;
    run_filter(colour, aux(albedo)?, aux(normal)?)
}

fn denoise_error(problem: impl Into<String>) -> RenderError {
    RenderError::Setting {
        option: "--denoise",
        problem: problem.into(),
    }
}

#[cfg(not(feature = "denoise"))]
fn run_filter(_: &Image, _: &Image, _: &Image) -> Result<Image, RenderError> {
    Err(denoise_error(NO_DENOISER))
}

/// The image's values as OIDN's packed `FLOAT3` layout: row 0 first, three floats a pixel.
#[cfg(feature = "denoise")]
fn packed(image: &Image) -> Vec<f32> {
    image.pixels().iter().flat_map(|p| p.to_array()).collect()
}

#[cfg(feature = "denoise")]
fn run_filter(colour: &Image, albedo: &Image, normal: &Image) -> Result<Image, RenderError> {
    let oidn_error = |e: oidn::Error| {
        denoise_error(format!(
            "Intel Open Image Denoise: {}",
            crate::error::one_line(e.message())
        ))
    };
    let (w, h) = (colour.width(), colour.height());
    let device = oidn::Device::cpu().map_err(oidn_error)?;
    // Buffers made here, with errors returned: the filter's own slice setters panic when an
    // allocation fails.
    let albedo = device.create_buffer(&packed(albedo)).map_err(oidn_error)?;
    let normal = device.create_buffer(&packed(normal)).map_err(oidn_error)?;
    let mut filter = oidn::RayTracing::try_new(&device).map_err(oidn_error)?;
    filter
        .hdr(true)
        .filter_quality(oidn::Quality::High)
        .image_dimensions(w as usize, h as usize);
    filter
        .albedo_normal_buffer(albedo, normal)
        .map_err(oidn_error)?;
    let mut out = vec![0.0f32; 3 * w as usize * h as usize];
    filter
        .filter(&packed(colour), &mut out)
        .map_err(oidn_error)?;
    device.get_error().map_err(oidn_error)?;
    let pixels = out
        .chunks_exact(3)
        .map(|c| glam::Vec3::new(c[0], c[1], c[2]))
        .collect();
    Image::from_pixels(w, h, pixels)
        .ok_or_else(|| denoise_error("the denoiser returned an image of another size"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The auxiliary images are checked before the library is asked: a missing one or one of
    /// another size is an error naming it, in any build.
    #[test]
    fn missing_or_mis_sized_auxiliary_images_are_refused() {
        let colour = Image::new(4, 3);
        let mut aovs = AovImages::new();
        let e = denoise(&colour, &aovs).err().map(|e| e.to_string());
        assert_eq!(
            e.as_deref(),
            Some("--denoise: the denoiser needs the albedo image of the render")
        );
        aovs.insert(Aov::Albedo, Image::new(4, 3));
        aovs.insert(Aov::Normal, Image::new(3, 4));
        let e = denoise(&colour, &aovs).err().map(|e| e.to_string());
        assert_eq!(
            e.as_deref(),
            Some("--denoise: the normal image is 3×4, the colour 4×3")
        );
    }

    /// Without the feature the error says how to get a denoiser.
    #[cfg(not(feature = "denoise"))]
    #[test]
    fn a_build_without_the_feature_says_how_to_get_one() {
        let mut aovs = AovImages::new();
        aovs.insert(Aov::Albedo, Image::new(2, 2));
        aovs.insert(Aov::Normal, Image::new(2, 2));
        let e = denoise(&Image::new(2, 2), &aovs)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            e.starts_with("--denoise: this build of irr has no denoiser"),
            "{e}"
        );
        assert!(
            e.contains("pyoidn") && e.contains("--features denoise"),
            "{e}"
        );
        assert_eq!(DENOISER, None);
    }

    /// With the library: a flat grey plane (albedo 0.5, normal +Z) whose radiance 0.5 carries
    /// white noise comes out with a far smaller error. Measured (OIDN 2.5.1 on an AVX-512 Xeon,
    /// 8 seeds): the mean squared error falls 22.0–24.8× at relative amplitude 0.1, 47–58× at
    /// 0.3 and 118–173× at 1. The bound, 10×, is under half the least of them, so that another
    /// instruction set's kernels (AVX2) pass, while a filter that returned its input (1×) or
    /// only a mild blur would fail.
    #[cfg(feature = "denoise")]
    #[test]
    fn noise_on_a_flat_plane_is_removed() {
        use glam::Vec3;
        let (w, h) = (64, 48);
        let flat = |v: Vec3| {
            Image::from_pixels(w, h, vec![v; (w * h) as usize]).unwrap_or_else(|| Image::new(w, h))
        };
        let mut aovs = AovImages::new();
        aovs.insert(Aov::Albedo, flat(Vec3::splat(0.5)));
        aovs.insert(Aov::Normal, flat(Vec3::Z));
        let mse = |im: &Image| {
            let sum: f64 = im
                .pixels()
                .iter()
                .map(|p| f64::from((*p - Vec3::splat(0.5)).length_squared()))
                .sum();
            sum / f64::from(3 * w * h)
        };
        for seed in 0..4u64 {
            for amplitude in [0.1f32, 0.3, 1.0] {
                // Each channel 0.5 · (1 + a·u), u uniform in [−1, 1] from a counter-based key.
                let pixels = (0..w * h)
                    .map(|i| {
                        let key = irr_sampling::SampleKey::new(seed, 0, u64::from(i));
                        let u = Vec3::new(key.uniform(0), key.uniform(1), key.uniform(2));
                        (u * 2.0 - 1.0).mul_add(Vec3::splat(0.5 * amplitude), Vec3::splat(0.5))
                    })
                    .collect();
                let noisy = Image::from_pixels(w, h, pixels).unwrap_or_else(|| Image::new(w, h));
                let out = denoise(&noisy, &aovs).unwrap_or_else(|e| panic!("{e}"));
                let ratio = mse(&noisy) / mse(&out);
                assert!(
                    ratio > 10.0,
                    "seed {seed}, amplitude {amplitude}: {ratio:.1}×"
                );
            }
        }
        assert!(DENOISER.is_some());
    }
}
