//! Benchmarks of the gradient estimators: the cost of one record's gradients (both variants), of
//! the triangle fan, and of building a gather, for the sample counts an irradiance cache uses (256 to 4096 cells).
//!
//! Run with `cargo bench -p irr-gradients`.

use divan::Bencher;
use glam::Vec3;
use irr_gradients::{GatherSamples, TranslationGradient};
use irr_sampling::{HemisphereStrata, SampleKey};

fn main() {
    divan::main();
}

/// A gather with varied radiance and distances (no two neighbours equal), so every wall term
/// is computed.
fn gather(samples: u32) -> GatherSamples<Vec3> {
    let strata = HemisphereStrata::with_sample_count(samples).unwrap_or_else(|e| panic!("{e}"));
    let key = SampleKey::new(1, 2, 3);
    GatherSamples::from_fn(strata, |cell| {
        let u = key.uniform_2d(cell.index(&strata));
        let r = if u.x < 0.1 { f32::INFINITY } else { 0.1 + u.x };
        (Vec3::new(u.x, u.y, u.x * u.y), r)
    })
    .unwrap_or_else(|e| panic!("{e}"))
}

#[divan::bench(args = [256, 1024, 4096])]
fn gradients_ward_heckbert(bencher: Bencher, samples: u32) {
    let g = gather(samples);
    bencher.bench(|| divan::black_box(&g).gradients(TranslationGradient::WardHeckbert));
}

#[divan::bench(args = [256, 1024, 4096])]
fn gradients_krivanek_gautron(bencher: Bencher, samples: u32) {
    let g = gather(samples);
    bencher.bench(|| divan::black_box(&g).gradients(TranslationGradient::KrivanekGautron));
}

/// The triangle fan (the Hessian metric's curvature and occlusion-aware gradient), once per
/// record.
#[divan::bench(args = [256, 1024, 4096])]
fn triangle_fan(bencher: Bencher, samples: u32) {
    let g = gather(samples);
    bencher.bench(|| divan::black_box(&g).fan());
}

#[divan::bench(args = [1024])]
fn irradiance_and_distances(bencher: Bencher, samples: u32) {
    let g = gather(samples);
    bencher.bench(|| {
        let g = divan::black_box(&g);
        (g.irradiance(), g.harmonic_mean_distance(), g.min_distance())
    });
}
