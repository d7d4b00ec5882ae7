//! A synthetic scene for the benchmarks: a 10 m room (six walls) holding 24 boxes, records on the
//! visible faces uniformly by area, with radii around twice the mean record spacing (times a
//! log-uniform factor in [½, 2]), so that a query sees a few records, as with κ = 1 in a real
//! render.

use glam::Vec3;
use irr_cache::{IrradianceCache, Record, Rgb, TabellionLamorlette};

/// SplitMix64 (Steele, Lea & Flood 2014): a deterministic stream of uniform numbers.
pub struct Rng(u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn f(&mut self) -> f32 {
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

pub struct Scene {
    quads: Vec<Quad>,
    /// Cumulative areas, for picking a quad by area.
    cdf: Vec<f32>,
}

impl Scene {
    pub fn new() -> Self {
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

    pub fn area(&self) -> f32 {
        self.cdf.last().copied().unwrap_or(0.0)
    }

    /// A point on the surfaces, uniform by area, and its normal.
    pub fn point(&self, rng: &mut Rng) -> (Vec3, Vec3) {
        let x = rng.f() * self.area();
        let i = self
            .cdf
            .partition_point(|&c| c <= x)
            .min(self.quads.len() - 1);
        let q = &self.quads[i];
        (q.origin + q.u * rng.f() + q.v * rng.f(), q.normal)
    }

    /// `n` records as a renderer would place them (see the file's docs).
    pub fn records(&self, n: usize, seed: u64) -> Vec<Record<Rgb>> {
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

    pub fn cache(&self, n: usize) -> IrradianceCache<Rgb, TabellionLamorlette> {
        let mut cache = IrradianceCache::new(TabellionLamorlette::default());
        if let Err(e) = cache.extend(self.records(n, 1)) {
            panic!("{e}");
        }
        cache
    }

    /// `n` query points with their normals, in random order.
    pub fn queries(&self, n: usize, seed: u64) -> Vec<(Vec3, Vec3)> {
        let mut rng = Rng(seed);
        (0..n).map(|_| self.point(&mut rng)).collect()
    }

    /// `n` query points in a spatially coherent order, as a renderer's successive shading points
    /// in a tile: sorted along a Morton (Z-order) curve over the room at 2⁻¹⁰ of its size.
    pub fn coherent_queries(&self, n: usize, seed: u64) -> Vec<(Vec3, Vec3)> {
        let mut q = self.queries(n, seed);
        q.sort_by_key(|(p, _)| morton(*p * (1024.0 / 10.0)));
        q
    }
}

/// The Morton code of a point's integer cell (10 bits per axis).
fn morton(p: Vec3) -> u32 {
    let spread = |v: f32| {
        let mut x = (v.clamp(0.0, 1023.0) as u32) & 0x3ff;
        x = (x | (x << 16)) & 0x0300_00ff;
        x = (x | (x << 8)) & 0x0300_f00f;
        x = (x | (x << 4)) & 0x030c_30c3;
        (x | (x << 2)) & 0x0924_9249
    };
    spread(p.x) | (spread(p.y) << 1) | (spread(p.z) << 2)
}
