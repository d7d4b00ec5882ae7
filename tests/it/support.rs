//! Helpers shared by the test modules.

use irr_render::Image;

/// relMSE = mean over pixels and channels of (x − r)²/(r² + 0.01): the measure of the peer
/// figures in the issues and of `cargo xtask compare`.
pub fn rel_mse(a: &Image, b: &Image) -> f64 {
    let mut sum = 0.0;
    for (x, r) in a.pixels().iter().zip(b.pixels()) {
        for c in 0..3 {
            let (x, r) = (f64::from(x[c]), f64::from(r[c]));
            sum += (x - r).powi(2) / (r * r + 0.01);
        }
    }
    sum / (a.pixels().len() * 3) as f64
}
