//! Benchmarks of what a radiance-cache lookup pays per record whose normal differs from the
//! query's: building the rotation between the two frames and applying it to the record's RGB
//! coefficients, exactly (Ivanic–Ruedenberg, or z-y-z with fixed quarter turns) or by Křivánek et
//! al.'s fast z-y-z rotation, at the
//! orders a radiance cache uses.
//!
//! Run with `cargo bench -p irr-sh`.

use divan::Bencher;
use glam::{Mat3, Vec3};
use irr_sh::{FastRotation, ShRotation, Taylor, ZyzRotation};

fn main() {
    divan::main();
}

/// A small rotation (about 5°, about a tilted axis): neighbouring records' frames on a curved
/// surface.
fn rotation() -> Mat3 {
    Mat3::from_axis_angle(Vec3::new(0.3, 0.5, 0.8).normalize(), 5f32.to_radians())
}

/// RGB coefficients of order `order`, varied.
fn coefficients(order: usize) -> Vec<Vec3> {
    (0..order * order)
        .map(|k| Vec3::new(1.0 / (1 + k) as f32, 0.5, (k % 3) as f32))
        .collect()
}

/// Times `rotate` (build a rotation of `rotation()` and apply it to the input) at `order`.
fn build_and_apply(
    bencher: Bencher,
    order: usize,
    rotate: impl Fn(Mat3, &[Vec3], &mut [Vec3]) -> Result<(), irr_sh::ShError>,
) {
    let input = coefficients(order);
    let mut output = vec![Vec3::ZERO; input.len()];
    bencher.bench_local(|| {
        rotate(divan::black_box(rotation()), &input, &mut output).unwrap_or_else(|e| panic!("{e}"));
        divan::black_box(&output);
    });
}

#[divan::bench(args = [4, 6, 8, 10])]
fn exact_build_and_apply(bencher: Bencher, order: usize) {
    build_and_apply(bencher, order, |r, input, output| {
        ShRotation::new(order, r)?.apply(input, output)
    });
}

#[divan::bench(args = [4, 6, 8, 10])]
fn exact_apply(bencher: Bencher, order: usize) {
    let input = coefficients(order);
    let mut output = vec![Vec3::ZERO; input.len()];
    let r = ShRotation::new(order, rotation()).unwrap_or_else(|e| panic!("{e}"));
    bencher.bench_local(|| {
        r.apply(divan::black_box(&input), &mut output)
            .unwrap_or_else(|e| panic!("{e}"));
        divan::black_box(&output);
    });
}

#[divan::bench(args = [4, 6, 8, 10])]
fn zyz_build_and_apply(bencher: Bencher, order: usize) {
    build_and_apply(bencher, order, |r, input, output| {
        ZyzRotation::new(order, r)?.apply(input, output)
    });
}

#[divan::bench(args = [4, 6, 8, 10])]
fn fast_build_and_apply(bencher: Bencher, order: usize) {
    build_and_apply(bencher, order, |r, input, output| {
        FastRotation::new(order, r, Taylor::First)?.apply(input, output)
    });
}
