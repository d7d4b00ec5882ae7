//! Benchmarks of the cache alone: one interpolation query and one insertion against caches of
//! 10³, 10⁵ and 10⁶ RGB records spread over surfaces as a renderer places them, and the memory per
//! record (printed before the timings).
//!
//! The scene is a 10 m room (six walls) holding 24 boxes; records lie on the visible faces,
//! uniformly by area, with radii around twice the mean record spacing (times a log-uniform factor
//! in [½, 2]), so that a query sees a few records, as with κ = 1 in a real render. Queries are
//! surface points with their normals. Run with `cargo bench -p irr-cache`.

use divan::Bencher;
use glam::Vec3;
use irr_cache::{IrradianceCache, Record, Rgb, TabellionLamorlette};

fn main() {
    for n in SIZES {
        let scene = Scene::new();
        let cache = scene.cache(n);
        let (nodes, entries) = cache.octree_counts();
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
            "{n:>8} records: {:.1} bytes/record ({} for the record itself), {:.2} octree entries/record, {nodes} nodes; {:.0}% of queries hit, {:.1} records per hit",
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

/// SplitMix64 (Steele, Lea & Flood 2014): a deterministic stream of uniform numbers.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn f(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// A rectangle: origin + s·u + t·v for s, t in [0, 1), facing `normal`.
struct Quad {
    origin: Vec3,
    u: Vec3,
    v: Vec3,
    normal: Vec3,
}

struct Scene {
    quads: Vec<Quad>,
    /// Cumulative areas, for picking a quad by area.
    cdf: Vec<f32>,
}

impl Scene {
    fn new() -> Self {
        let mut quads = Vec::new();
        let mut quad = |origin: Vec3, u: Vec3, v: Vec3, normal: Vec3| {
            quads.push(Quad {
                origin,
                u,
                v,
                normal,
            })
        };
        // The room's six walls, facing inwards.
        let s = 10.0;
        for axis in 0..3 {
            let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
            let (mut u, mut v) = (Vec3::ZERO, Vec3::ZERO);
            u[a] = s;
            v[b] = s;
            let mut n = Vec3::ZERO;
            n[axis] = 1.0;
            quad(Vec3::ZERO, u, v, n);
            let mut o = Vec3::ZERO;
            o[axis] = s;
            quad(o, u, v, -n);
        }
        // 24 boxes on the floor (y = 0): top and four sides.
        let mut rng = Rng(7);
        for _ in 0..24 {
            let size = Vec3::new(
                0.3 + 1.7 * rng.f(),
                0.3 + 2.0 * rng.f(),
                0.3 + 1.7 * rng.f(),
            );
            let min = Vec3::new(rng.f() * (s - size.x), 0.0, rng.f() * (s - size.z));
            let max = min + size;
            let (x, y, z) = (Vec3::X * size.x, Vec3::Y * size.y, Vec3::Z * size.z);
            quad(Vec3::new(min.x, max.y, min.z), x, z, Vec3::Y);
            quad(min, y, z, -Vec3::X);
            quad(Vec3::new(max.x, min.y, min.z), y, z, Vec3::X);
            quad(min, x, y, -Vec3::Z);
            quad(Vec3::new(min.x, min.y, max.z), x, y, Vec3::Z);
        }
        let mut total = 0.0;
        let cdf = quads
            .iter()
            .map(|q| {
                total += q.u.cross(q.v).length();
                total
            })
            .collect();
        Self { quads, cdf }
    }

    fn area(&self) -> f32 {
        self.cdf.last().copied().unwrap_or(0.0)
    }

    /// A point on the surfaces, uniform by area, and its normal.
    fn point(&self, rng: &mut Rng) -> (Vec3, Vec3) {
        let x = rng.f() * self.area();
        let i = self.cdf.partition_point(|&c| c <= x).min(self.quads.len() - 1);
        let q = &self.quads[i];
        (q.origin + q.u * rng.f() + q.v * rng.f(), q.normal)
    }

    /// `n` records as a renderer would place them (see the file's docs).
    fn records(&self, n: usize, seed: u64) -> Vec<Record<Rgb>> {
        let spacing = (self.area() / n as f32).sqrt();
        let mut rng = Rng(seed);
        (0..n)
            .map(|_| {
                let (p, normal) = self.point(&mut rng);
                let radius = 2.0 * spacing * 2f32.powf(2.0 * rng.f() - 1.0);
                let e = Rgb::new(rng.f(), rng.f(), rng.f());
                let g = [Rgb::splat(0.01 * rng.f()); 3];
                Record::new(p, normal, radius, e).with_gradients(g, g)
            })
            .collect()
    }

    fn cache(&self, n: usize) -> IrradianceCache<Rgb, TabellionLamorlette> {
        let mut cache = IrradianceCache::new(TabellionLamorlette::default());
        if let Err((i, e)) = cache.extend(self.records(n, 1)) {
            panic!("record {i}: {e}");
        }
        cache
    }

    fn queries(&self, n: usize, seed: u64) -> Vec<(Vec3, Vec3)> {
        let mut rng = Rng(seed);
        (0..n).map(|_| self.point(&mut rng)).collect()
    }
}

/// One `interpolate` at a surface point (cycling through 4096 of them).
#[divan::bench(args = SIZES, sample_count = 50)]
fn query(bencher: Bencher, n: usize) {
    let scene = Scene::new();
    let cache = scene.cache(n);
    let queries = scene.queries(4096, 99);
    let mut i = 0;
    bencher.bench_local(|| {
        i = (i + 1) & 4095;
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
    bencher
        .with_inputs(|| cache.clone())
        .bench_local_refs(|c| {
            for r in &new {
                let _ = divan::black_box(c.insert(*r));
            }
        });
}
