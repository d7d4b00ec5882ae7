//! The errors of an image against the reference: relMSE with its standard error, bias, MAE,
//! the 99th percentile of the per-pixel relative error, and FLIP.

use irr_render::{Image, tone_map};

/// The errors of an image against a reference, over pixels and channels.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Metrics {
    /// Mean of (x − r)² / (r² + 0.01): the relative MSE of the peers' figures.
    pub rel_mse: f64,
    /// The standard error of `rel_mse` as an estimate of its expectation, from the spread of
    /// the means of [`BLOCK`]×[`BLOCK`]-pixel blocks (blocks, not pixels, because a cache's
    /// errors are correlated over a record's footprint; see [`metrics`]).
    pub rel_mse_se: f64,
    /// (mean x − mean r) / mean r, in percent.
    pub bias_percent: f64,
    /// Mean of |x − r|.
    pub mae: f64,
    /// 99th percentile over pixels of the per-pixel relative error |x − r| / (r + 0.01)
    /// (luminance-free: the largest channel's).
    pub p99_rel: f64,
    /// FLIP, NVIDIA's perceptual error, on the sRGB previews ([`flip_error`]); 0 where not
    /// computed.
    pub flip: f64,
}

/// The side of the blocks whose means give relMSE's standard error: larger than a cache
/// record's footprint at the default pixel limits (1.5–10 px), so that blocks are nearly
/// independent.
pub const BLOCK: u32 = 16;

/// The relMSE of each [`BLOCK`]×[`BLOCK`]-pixel block of `image` against `reference`, with
/// the block's share of the pixels: (weight, relMSE), row by row. The weighted sum of the
/// blocks' relMSE is the image's.
pub fn block_errors(image: &Image, reference: &Image) -> Vec<(f64, f64)> {
    let (w, h) = (image.width().max(1), image.height());
    let bw = w.div_ceil(BLOCK);
    let mut blocks = vec![(0.0f64, 0u32); (bw * h.div_ceil(BLOCK)) as usize];
    for (i, (x, r)) in image.pixels().iter().zip(reference.pixels()).enumerate() {
        let (px, py) = (i as u32 % w, i as u32 / w);
        let block = &mut blocks[((py / BLOCK) * bw + px / BLOCK) as usize];
        block.0 += pixel_term(*x, *r);
        block.1 += 1;
    }
    let pixels = image.pixels().len().max(1) as f64;
    blocks
        .into_iter()
        .filter(|(_, count)| *count > 0)
        .map(|(sum, count)| (f64::from(count) / pixels, sum / f64::from(count)))
        .collect()
}

/// A pixel's mean over channels of (x − r)² / (r² + 0.01).
fn pixel_term(x: glam::Vec3, r: glam::Vec3) -> f64 {
    (0..3)
        .map(|c| {
            let (x, r) = (f64::from(x[c]), f64::from(r[c]));
            (x - r) * (x - r) / (r * r + 0.01)
        })
        .sum::<f64>()
        / 3.0
}

/// The standard error of the weighted mean of independent values (weight, value):
/// SE² = B/(B − 1) · Σ w_b² (v_b − m)² with m = Σ w_b v_b, the usual estimator of a weighted
/// mean's variance from B values (0 for fewer than two).
pub fn weighted_standard_error(values: &[(f64, f64)]) -> f64 {
    let b = values.len() as f64;
    if b < 2.0 {
        return 0.0;
    }
    let mean: f64 = values.iter().map(|(w, v)| w * v).sum();
    let spread: f64 = values.iter().map(|(w, v)| (w * (v - mean)).powi(2)).sum();
    (b / (b - 1.0) * spread).sqrt()
}

/// The standard error of the difference of two images' relMSE against one reference, from
/// their blocks' paired differences ([`block_errors`] of both, same size): what the noise
/// they share (the reference's, and samples drawn with the same seed) leaves out.
pub fn paired_standard_error(a: &[(f64, f64)], b: &[(f64, f64)]) -> f64 {
    let d: Vec<(f64, f64)> = a.iter().zip(b).map(|(a, b)| (a.0, a.1 - b.1)).collect();
    weighted_standard_error(&d)
}

/// The metrics of `image` against `reference` (same size), FLIP left at 0; the standard error
/// is [`weighted_standard_error`] of its [`block_errors`].
pub fn metrics(image: &Image, reference: &Image) -> Metrics {
    let (mut abs, mut sum_x, mut sum_r) = (0.0f64, 0.0f64, 0.0f64);
    let mut per_pixel = Vec::with_capacity(image.pixels().len());
    for (x, r) in image.pixels().iter().zip(reference.pixels()) {
        let mut worst = 0.0f64;
        for c in 0..3 {
            let (x, r) = (f64::from(x[c]), f64::from(r[c]));
            abs += (x - r).abs();
            sum_x += x;
            sum_r += r;
            worst = worst.max((x - r).abs() / (r.abs() + 0.01));
        }
        per_pixel.push(worst);
    }
    let blocks = block_errors(image, reference);
    let n = (image.pixels().len() * 3).max(1) as f64;
    per_pixel.sort_by(f64::total_cmp);
    let p99 = per_pixel
        .get(((per_pixel.len() as f64 * 0.99) as usize).min(per_pixel.len().saturating_sub(1)))
        .copied()
        .unwrap_or(0.0);
    Metrics {
        rel_mse: blocks.iter().map(|(w, v)| w * v).sum(),
        rel_mse_se: weighted_standard_error(&blocks),
        bias_percent: if sum_r > 0.0 {
            100.0 * (sum_x - sum_r) / sum_r
        } else {
            0.0
        },
        mae: abs / n,
        p99_rel: p99,
        flip: 0.0,
    }
}

/// [`metrics`] with FLIP.
pub fn metrics_with_flip(image: &Image, reference: &Image) -> Metrics {
    Metrics {
        flip: flip_error(image, reference),
        ..metrics(image, reference)
    }
}

/// FLIP (Andersson et al. 2020, NVIDIA's reference implementation through `nv-flip`): the mean of
/// the per-pixel perceptual error between the sRGB previews (exposure 0) of `image` and
/// `reference`, at FLIP's default 67 pixels per degree.
pub fn flip_error(image: &Image, reference: &Image) -> f64 {
    let ldr = |im: &Image| -> Vec<u8> {
        im.pixels()
            .iter()
            .flat_map(|p| p.to_array().map(|c| tone_map(c, 0.0)))
            .collect()
    };
    let (w, h) = (image.width(), image.height());
    let a = nv_flip::FlipImageRgb8::with_data(w, h, &ldr(reference));
    let b = nv_flip::FlipImageRgb8::with_data(w, h, &ldr(image));
    let map = nv_flip::flip(a, b, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    f64::from(nv_flip::FlipPool::from_image(&map).mean())
}

/// The per-pixel relative error |x − r| / (r + 0.01) (largest channel).
pub fn relative_errors(image: &Image, reference: &Image) -> Vec<f32> {
    image
        .pixels()
        .iter()
        .zip(reference.pixels())
        .map(|(x, r)| {
            let d = (*x - *r).abs() / (r.abs() + glam::Vec3::splat(0.01));
            d.max_element()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn image(w: u32, h: u32, f: impl Fn(u32, u32) -> Vec3) -> Image {
        let pixels = (0..w * h).map(|i| f(i % w, i / w)).collect();
        Image::from_pixels(w, h, pixels).unwrap_or_else(|| panic!("size"))
    }

    /// Known answers: a reference of 1 and an image of 1 + d everywhere has relMSE d²/1.01,
    /// bias 100·d %, MAE d, p99 d/1.01, and (every block equal) a standard error of 0 up to the
    /// rounding of the block sums (each within 1024 ulps of the mean: below 1e-12 of it). With the
    /// error only in one of four 16×16 blocks, relMSE is a quarter of that, and the standard
    /// error is that of four block means (d²/1.01, 0, 0, 0): with m = d²/4.04 and w = 1/4,
    /// SE² = 4/3 · (1/16)(3m² + 9m²) = m², so SE = m. Exact to f64 rounding (1e-12 relative).
    #[test]
    fn known_answers_and_the_block_standard_error() {
        let d = 0.5f32;
        let reference = image(32, 32, |_, _| Vec3::ONE);
        let m = metrics(&image(32, 32, |_, _| Vec3::splat(1.0 + d)), &reference);
        let dd = f64::from(d);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1e-300);
        assert!(close(m.rel_mse, dd * dd / 1.01), "{m:?}");
        assert!(
            close(m.bias_percent, 100.0 * dd) && close(m.mae, dd),
            "{m:?}"
        );
        assert!(close(m.p99_rel, dd / 1.01), "{m:?}");
        assert!(m.rel_mse_se < 1e-12 * m.rel_mse, "{m:?}");
        let corner = image(32, 32, |x, y| {
            if x < 16 && y < 16 {
                Vec3::splat(1.0 + d)
            } else {
                Vec3::ONE
            }
        });
        let m = metrics(&corner, &reference);
        let quarter = dd * dd / 1.01 / 4.0;
        assert!(close(m.rel_mse, quarter), "{m:?}");
        assert!(close(m.rel_mse_se, quarter), "{m:?}");
    }
}
