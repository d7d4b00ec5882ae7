//! Benchmarks of the cache alone: one interpolation query and one insertion against caches of
//! 10³, 10⁵ and 10⁶ RGB records spread over surfaces as a renderer places them, and the memory per
//! record (printed before the timings).
//!
//! The scene (benches/support/scene.rs) is a 10 m room (six walls) holding 24 boxes; records lie
//! on the visible faces, uniformly by area, with radii around twice the mean record spacing (times
//! a log-uniform factor in [½, 2]), so that a query sees a few records, as with κ = 1 in a real
//! render. Queries are surface points with their normals, in random order (the worst case for the
//! CPU caches) and in a spatially coherent order (as a renderer issues them). Run with
//! `cargo bench -p irr-cache`.

use divan::Bencher;
use irr_cache::{Record, Rgb};

#[path = "support/scene.rs"]
mod scene;
use scene::Scene;

fn main() {
    for n in SIZES {
        let scene = Scene::new();
        let cache = scene.cache(n);
        let (cells, entries) = cache.octree_counts();
        let queries = scene.queries(4096, 99);
        let hits = queries
            .iter()
            .filter(|(p, nn)| cache.interpolate(*p, *nn).is_some())
            .count();
        let used: u32 = queries
            .iter()
            .filter_map(|(p, nn)| cache.interpolate(*p, *nn))
            .map(|h| h.count)
            .sum();
        println!(
            "{n:>8} records: {:.1} bytes/record ({} for the record itself), {:.2} octree entries/record, {cells} cells; {:.0}% of queries hit, {:.1} records per hit",
            cache.memory_bytes() as f64 / n as f64,
            size_of::<Record<Rgb>>(),
            entries as f64 / n as f64,
            100.0 * hits as f64 / queries.len() as f64,
            f64::from(used) / hits.max(1) as f64,
        );
    }
    divan::main();
}

const SIZES: [usize; 3] = [1_000, 100_000, 1_000_000];

/// One `interpolate` at a surface point, the points in random order (cycling through 2¹⁶ of them,
/// so the data they touch does not stay in the CPU caches): the worst case.
#[divan::bench(args = SIZES, sample_count = 100, sample_size = 256)]
fn query_random(bencher: Bencher, n: usize) {
    let scene = Scene::new();
    let cache = scene.cache(n);
    let queries = scene.queries(1 << 16, 99);
    let mut i = 0;
    bencher.bench_local(|| {
        i = (i + 1) & ((1 << 16) - 1);
        let (p, normal) = queries[i];
        cache.interpolate(divan::black_box(p), normal)
    });
}

/// One `interpolate`, the points in a spatially coherent order (2²⁰ points along a Morton curve),
/// as a renderer's successive shading points in a tile reach the cache.
#[divan::bench(args = SIZES, sample_count = 100, sample_size = 256)]
fn query_coherent(bencher: Bencher, n: usize) {
    let scene = Scene::new();
    let cache = scene.cache(n);
    let queries = scene.coherent_queries(1 << 20, 99);
    let mut i = 0;
    bencher.bench_local(|| {
        i = (i + 1) & ((1 << 20) - 1);
        let (p, normal) = queries[i];
        cache.interpolate(divan::black_box(p), normal)
    });
}

/// One `insert` into a cache of n records (a batch of 1000 new records per sample, into a fresh
/// clone of the cache; the clone is not timed). Divide the reported time by 1000.
#[divan::bench(args = SIZES, sample_count = 10, sample_size = 1)]
fn insert_1000(bencher: Bencher, n: usize) {
    let scene = Scene::new();
    let cache = scene.cache(n);
    let new = scene.records(1000, 2);
    bencher.with_inputs(|| cache.clone()).bench_local_refs(|c| {
        for r in &new {
            let _ = divan::black_box(c.insert(*r));
        }
    });
}
