//! Benchmarks of irr-render's own work around the integrators: loading the Cornell box (parse,
//! checked accessors, BVH and light sampler), and a small render of it through the whole film
//! and tile machinery with the path tracer and with ambient occlusion (throughput in samples;
//! the summary line of `cargo xtask render` gives rays per second). Run with
//! `cargo bench -p irr-render`.

use divan::Bencher;
use divan::counter::ItemsCount;
use irr_render::{
    AmbientOcclusion, AoSettings, Integrator, LoadedScene, PathSettings, PathTracer,
    RenderSettings, load_scene, render,
};
use std::path::PathBuf;

fn main() {
    divan::main();
}

fn cornell_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../assets/cornell-box.gltf")
}

fn cornell() -> LoadedScene {
    load_scene(&cornell_path()).unwrap_or_else(|e| panic!("{e}"))
}

#[divan::bench(sample_count = 20)]
fn load_cornell_box() -> LoadedScene {
    cornell()
}

/// 32×32 pixels at 4 samples per pixel on one thread: 4096 samples per iteration.
fn bench_render(bencher: Bencher, integrator: &dyn Integrator) {
    let loaded = cornell();
    let settings = RenderSettings {
        width: 32,
        height: 32,
        spp: 4,
        seed: 1,
        threads: 1,
    };
    let camera = loaded.camera_for(settings.width, settings.height);
    bencher
        .counter(ItemsCount::new(32u32 * 32 * 4))
        .bench(|| render(&loaded.scene, &camera, integrator, &settings, false));
}

#[divan::bench(sample_count = 10)]
fn render_cornell_path(bencher: Bencher) {
    bench_render(bencher, &PathTracer::new(PathSettings::default()));
}

#[divan::bench(sample_count = 10)]
fn render_cornell_ao(bencher: Bencher) {
    bench_render(bencher, &AmbientOcclusion::new(AoSettings::default()));
}
