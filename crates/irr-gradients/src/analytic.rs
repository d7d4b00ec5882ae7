//! Test support: the closed-form irradiance from a uniformly emitting convex polygon, and a tiny
//! ray caster that turns such a scene into a [`GatherSamples`] with the real stratified sampler.
//!
//! Lambert's formula in Arvo's form (Arvo 1995, "Applications of Irradiance Tensors to the
//! Simulation of Non-Lambertian Phenomena", the irradiance from a polygonal luminaire):
//! E(x, n) = (L/2) · |Σᵢ Θᵢ (Γᵢ · n)|, over the edges of the polygon clipped to the half-space
//! above the tangent plane at x, with Θᵢ the angle edge i subtends at x and Γᵢ the unit normal of
//! the plane through x and edge i. Everything is in f64, so that central differences of it with
//! steps of 1e-4 of the smallest distance are exact to ~1e-8 relative (see `known_answers`).

use crate::GatherSamples;
use glam::DVec3;
use irr_sampling::{Frame, HemisphereStrata, SampleKey};

/// A proptest configuration with a fixed seed (the project's tests are deterministic) and no
/// regression files.
pub fn fixed_config(cases: u32, seed: u64) -> proptest::test_runner::Config {
    proptest::test_runner::Config {
        cases,
        rng_seed: proptest::test_runner::RngSeed::Fixed(seed),
        failure_persistence: None,
        ..proptest::test_runner::Config::default()
    }
}

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton's iteration on Pₙ; Golub–Welsch would do
/// as well): exact for polynomials of degree 2n − 1.
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 0.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// The angle step of the rotation differences (see `known_answers` for the error bound).
pub const ROTATION_STEP: f64 = 1e-6;

/// One emitting convex planar polygon of uniform radiance (emitting on both faces), and
/// optionally an infinite non-emitting plane (a "ceiling") that gives the misses a finite distance.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The emitter's vertices, in order around it (either winding).
    pub emitter: Vec<DVec3>,
    /// The emitter's radiance.
    pub radiance: f64,
    /// A point of the ceiling plane and its normal, if any.
    pub ceiling: Option<(DVec3, DVec3)>,
}

/// Rodrigues' rotation of `v` about the unit `axis` by `angle`.
pub fn rotate(v: DVec3, axis: DVec3, angle: f64) -> DVec3 {
    let (s, c) = angle.sin_cos();
    v * c + axis.cross(v) * s + axis * axis.dot(v) * (1.0 - c)
}

impl Scene {
    /// The scene moved by the rigid transform y ↦ q(y) + t, with q a rotation (`rotate` about
    /// `axis` by `angle`), or scaled about the origin by `scale`.
    pub fn transformed(&self, axis: DVec3, angle: f64, t: DVec3, scale: f64) -> Self {
        let map = |y: DVec3| rotate(y, axis, angle) * scale + t;
        Self {
            emitter: self.emitter.iter().map(|&y| map(y)).collect(),
            radiance: self.radiance,
            ceiling: self.ceiling.map(|(p, n)| (map(p), rotate(n, axis, angle))),
        }
    }

    /// E(x, n) by Lambert's formula (Arvo's form), `n` a unit normal.
    pub fn irradiance(&self, x: DVec3, n: DVec3) -> f64 {
        let poly = clip_above(&self.emitter, x, n);
        if poly.len() < 3 {
            return 0.0;
        }
        let mut sum = 0.0;
        for i in 0..poly.len() {
            let a = (poly[i] - x).normalize();
            let b = (poly[(i + 1) % poly.len()] - x).normalize();
            let cross = a.cross(b);
            let len = cross.length();
            if len == 0.0 {
                // An edge on a line through x subtends no angle.
                continue;
            }
            // Θ from atan2 stays exact for tiny and for near-π angles, unlike acos(a·b).
            let theta = len.atan2(a.dot(b));
            sum += theta * cross.dot(n) / len;
        }
        0.5 * self.radiance * sum.abs()
    }

    /// Central differences of the closed form: (∇ₜE, ∇ᵣE) in the local frame of `frame` at `x`.
    /// `h` is the translation step (a length); the rotation step is the angle `ROTATION_STEP`.
    pub fn finite_differences(&self, x: DVec3, frame: &Frame, h: f64) -> ([f64; 3], [f64; 3]) {
        let axes = [frame.s, frame.t, frame.n].map(|a| a.as_dvec3().normalize());
        let n = axes[2];
        let mut t = [0.0; 3];
        let mut r = [0.0; 3];
        for a in 0..3 {
            t[a] = (self.irradiance(x + axes[a] * h, n) - self.irradiance(x - axes[a] * h, n))
                / (2.0 * h);
        }
        let ha = ROTATION_STEP;
        for a in 0..2 {
            r[a] = (self.irradiance(x, rotate(n, axes[a], ha))
                - self.irradiance(x, rotate(n, axes[a], -ha)))
                / (2.0 * ha);
        }
        (t, r)
    }

    /// The nearest hit along the ray (o, d): (radiance, distance), or (0, ∞) for a miss.
    pub fn trace(&self, o: DVec3, d: DVec3) -> (f64, f64) {
        let mut best = (0.0, f64::INFINITY);
        if let Some(t) = intersect_polygon(o, d, &self.emitter) {
            best = (self.radiance, t);
        }
        if let Some((p, n)) = self.ceiling
            && let Some(t) = intersect_plane(o, d, p, n)
            && t < best.1
        {
            best = (0.0, t);
        }
        best
    }

    /// One gather at `x` with the frame `frame`: a ray per cell through the real stratified
    /// sampler, its 2D point drawn from `key` at dimension `cell.index`.
    pub fn gather(
        &self,
        x: DVec3,
        frame: &Frame,
        strata: HemisphereStrata,
        key: SampleKey,
    ) -> GatherSamples<f32> {
        GatherSamples::from_fn(strata, |cell| {
            let u = key.uniform_2d(cell.index(&strata));
            let d = frame
                .to_world(strata.sample(cell, u))
                .as_dvec3()
                .normalize();
            let (l, r) = self.trace(x, d);
            (l as f32, (r as f32).max(f32::MIN_POSITIVE))
        })
        .unwrap_or_else(|e| panic!("{e}"))
    }
}

/// Sutherland–Hodgman clipping of a convex polygon to the half-space (y − x)·n ≥ 0.
pub fn clip_above(poly: &[DVec3], x: DVec3, n: DVec3) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for i in 0..poly.len() {
        let a = poly[i];
        let b = poly[(i + 1) % poly.len()];
        let (da, db) = ((a - x).dot(n), (b - x).dot(n));
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            out.push(a + (b - a) * (da / (da - db)));
        }
    }
    out
}

/// Distance along (o, d) to a convex planar polygon, if the ray hits it (either face).
fn intersect_polygon(o: DVec3, d: DVec3, poly: &[DVec3]) -> Option<f64> {
    let m = (poly[1] - poly[0]).cross(poly[2] - poly[0]);
    let denom = d.dot(m);
    if denom == 0.0 {
        return None;
    }
    let t = (poly[0] - o).dot(m) / denom;
    if t.is_nan() || t <= 0.0 {
        return None;
    }
    let h = o + d * t;
    for i in 0..poly.len() {
        let a = poly[i];
        let b = poly[(i + 1) % poly.len()];
        if (b - a).cross(h - a).dot(m) < 0.0 {
            return None;
        }
    }
    Some(t)
}

/// Distance along (o, d) to the plane through `p` with normal `n`, if ahead.
fn intersect_plane(o: DVec3, d: DVec3, p: DVec3, n: DVec3) -> Option<f64> {
    let denom = d.dot(n);
    if denom == 0.0 {
        return None;
    }
    let t = (p - o).dot(n) / denom;
    (t > 0.0).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// A square of half-side a centred overhead at height h against the known on-axis formula
    /// for a square: E = 4L·[a/√(a²+h²)]·atan(a/√(a²+h²)) (from Arvo's form: four edges each
    /// subtending 2·atan(a/√(a²+h²)) with Γ·n = a/√(a²+h²)). A large square tends to E = πL.
    #[test]
    fn lambert_formula_matches_known_cases() {
        for (a, h) in [(0.5, 1.0), (2.0, 0.1), (0.01, 3.0)] {
            let sq = Scene {
                emitter: vec![
                    DVec3::new(-a, -a, h),
                    DVec3::new(a, -a, h),
                    DVec3::new(a, a, h),
                    DVec3::new(-a, a, h),
                ],
                radiance: 1.0,
                ceiling: None,
            };
            let q = (a * a + h * h).sqrt();
            let expected = 4.0 * (a / q) * (a / q).atan();
            let got = sq.irradiance(DVec3::ZERO, DVec3::Z);
            // f64 evaluation of a handful of terms: relative error ≲ 1e-15; 1e-12 is generous.
            assert!(
                (got - expected).abs() <= 1e-12 * expected,
                "{got} vs {expected}"
            );
        }
        let huge = Scene {
            emitter: vec![
                DVec3::new(-1e6, -1e6, 1.0),
                DVec3::new(1e6, -1e6, 1.0),
                DVec3::new(1e6, 1e6, 1.0),
                DVec3::new(-1e6, 1e6, 1.0),
            ],
            radiance: 1.0,
            ceiling: None,
        };
        // The missing solid angle is that of the hemisphere's rim beyond 1e6: E = π(1 − O(1e-6)).
        let e = huge.irradiance(DVec3::ZERO, DVec3::Z);
        assert!((e - PI).abs() < 1e-5, "{e}");
        // Below the horizon entirely: nothing.
        let below = huge.transformed(DVec3::X, 0.0, DVec3::new(0.0, 0.0, -2.0), 1.0);
        assert_eq!(below.irradiance(DVec3::ZERO, DVec3::Z), 0.0);
    }

    /// The ray caster agrees with the formula: with many strata, the gather's irradiance
    /// converges to the closed form. Stratified estimate of a 0/1 visibility: only the cells
    /// straddling the emitter's outline are random; with 64×200 cells the outline crosses
    /// ~O(M + N) ≈ 500 cells, each with variance ≤ ¼·(π/(MN))², so σ ≤ √500·½·π/12800 ≈ 2.7e-3;
    /// 5σ ≈ 1.4e-2.
    #[test]
    fn gather_converges_to_the_formula() {
        let scene = Scene {
            emitter: vec![
                DVec3::new(-0.2, -0.3, 1.0),
                DVec3::new(0.8, -0.3, 1.0),
                DVec3::new(0.8, 0.7, 1.2),
                DVec3::new(-0.2, 0.7, 1.2),
            ],
            radiance: 1.0,
            ceiling: Some((DVec3::new(0.0, 0.0, 2.0), DVec3::Z)),
        };
        let strata = HemisphereStrata::new(64, 200).unwrap_or_else(|e| panic!("{e}"));
        let frame = Frame::from_normal(glam::Vec3::Z);
        let g = scene.gather(DVec3::ZERO, &frame, strata, SampleKey::new(1, 2, 3));
        let e = f64::from(g.irradiance());
        let exact = scene.irradiance(DVec3::ZERO, DVec3::Z);
        assert!((e - exact).abs() < 1.4e-2, "{e} vs {exact}");
    }
}
