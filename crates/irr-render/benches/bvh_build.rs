//! The BVH build on a hostile scene, triangles nested about one centroid, each
//! 1.0001 times the one before (a 3.6 MB file at 10⁵). obvhs's PLOC merges one pair per pass on
//! such input (every smaller box ties as a nearest neighbour), so the build is quadratic: about
//! 5 s at 10⁴, 14 s at 2·10⁴ and 77 s at 4·10⁴ on the 2-core development machine. Run with
//! `cargo bench -p irr-render --bench bvh_build`.
//!
//! Sizes 10⁴, 10⁵ and 10⁶ are benchmarked; until irr-geometry's build is near-linear on this
//! input, the two larger sizes would run for many minutes and hours, so they are skipped unless
//! `IRR_BENCH_NESTED_MAX` is raised (e.g. `IRR_BENCH_NESTED_MAX=1000000`).

use divan::Bencher;
use glam::Vec3;
use irr_geometry::{Geometry, TriangleMesh};

fn main() {
    divan::main();
}

/// `n` triangles about the centroid (0, −1/3, 0), triangle i scaled by 1.0001^i (1.00001^i above
/// 10⁵ triangles: 1.0001^(10⁶) overflows f32, and irr-geometry would drop the infinite ones).
fn nested(n: usize) -> TriangleMesh {
    let ratio = if n > 100_000 { 1.000_01 } else { 1.0001 };
    let centroid = Vec3::new(0.0, -1.0 / 3.0, 0.0);
    let base = [
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    let mut positions = Vec::with_capacity(3 * n);
    let mut scale = 1.0f32;
    for _ in 0..n {
        positions.extend(base.map(|p| centroid + (p - centroid) * scale));
        scale *= ratio;
    }
    TriangleMesh {
        indices: (0..n as u32)
            .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
            .collect(),
        positions,
        normals: None,
        material_ids: vec![0; n],
    }
}

fn max_size() -> usize {
    std::env::var("IRR_BENCH_NESTED_MAX")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(10_000)
}

#[divan::bench(args = [10_000, 100_000, 1_000_000], sample_count = 3, sample_size = 1)]
fn nested_same_centroid(bencher: Bencher, n: usize) {
    if n > max_size() {
        eprintln!(
            "skipped {n} nested triangles (IRR_BENCH_NESTED_MAX is {})",
            max_size()
        );
        return;
    }
    let mesh = [nested(n)];
    bencher.bench_local(|| Geometry::build(&mesh).map(|g| g.report().dropped_degenerate));
}
