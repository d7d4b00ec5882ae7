//! Helpers shared by the unit tests: quadrature rules over the sphere and hemisphere, a
//! deterministic random source, random rotations, small linear algebra.

use crate::legendre::gauss_legendre;
use glam::{DMat3, DQuat, DVec3};
use proptest::prelude::*;
use std::f64::consts::TAU;

/// Directions and weights of the product rule: `k`-point Gauss–Legendre in cos θ over [−1, 1]
/// times `p` equally spaced φ. Exact for f(cos θ) g(φ) with f a polynomial of degree ≤ 2k − 1
/// and g a trigonometric polynomial of degree < p.
pub fn sphere_rule(k: usize, p: usize) -> Vec<(DVec3, f64)> {
    product_rule(gauss_legendre(k), p)
}

/// The same over the upper hemisphere: Gauss–Legendre mapped to cos θ ∈ [0, 1].
pub fn hemisphere_rule(k: usize, p: usize) -> Vec<(DVec3, f64)> {
    let rule = gauss_legendre(k)
        .into_iter()
        .map(|(x, w)| (0.5 * (x + 1.0), 0.5 * w))
        .collect();
    product_rule(rule, p)
}

/// The upper hemisphere with x = cos θ = u², u by `k`-point Gauss–Legendre on [0, 1]: for
/// integrands with a √x at the horizon (module hemisphere).
pub fn hemisphere_rule_squared(k: usize, p: usize) -> Vec<(DVec3, f64)> {
    let rule = gauss_legendre(k)
        .into_iter()
        .map(|(s, w)| {
            let u = 0.5 * (s + 1.0);
            (u * u, w * u)
        })
        .collect();
    product_rule(rule, p)
}

fn product_rule(z_rule: Vec<(f64, f64)>, p: usize) -> Vec<(DVec3, f64)> {
    let mut out = Vec::with_capacity(z_rule.len() * p);
    for (z, wz) in z_rule {
        let s = (1.0 - z * z).max(0.0).sqrt();
        for j in 0..p {
            let phi = TAU * j as f64 / p as f64;
            out.push((
                DVec3::new(s * phi.cos(), s * phi.sin(), z),
                wz * TAU / p as f64,
            ));
        }
    }
    out
}

/// SplitMix64 (Steele, Lea & Flood 2014): a fixed, seedable stream for deterministic tests.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [−1, 1).
    pub fn signed(&mut self) -> f64 {
        2.0 * self.uniform() - 1.0
    }

    pub fn vector(&mut self, len: usize) -> Vec<f64> {
        (0..len).map(|_| self.signed()).collect()
    }
}

/// A rotation from four numbers: the normalised quaternion, or None if they are too close to 0
/// to give a well-defined one.
pub fn rotation_from(q: [f64; 4]) -> Option<DMat3> {
    let q = DQuat::from_xyzw(q[0], q[1], q[2], q[3]);
    (q.length() > 0.1).then(|| DMat3::from_quat(q.normalize()))
}

/// Random rotations, spread over SO(3) (normalised quaternions from the 4-cube).
pub fn any_rotation() -> impl Strategy<Value = DMat3> {
    proptest::array::uniform4(-1.0f64..1.0).prop_filter_map("degenerate quaternion", rotation_from)
}

/// Random unit directions.
pub fn any_direction() -> impl Strategy<Value = DVec3> {
    proptest::array::uniform3(-1.0f64..1.0).prop_filter_map("short vector", |v| {
        let v = DVec3::from_array(v);
        (v.length() > 0.1).then(|| v.normalize())
    })
}

pub fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

pub fn max_abs_difference(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// The largest eigenvalue of the symmetric positive semi-definite `a` (size × size, row-major)
/// by power iteration from a fixed start, with the Rayleigh quotient.
pub fn largest_eigenvalue(a: &[f64], size: usize) -> f64 {
    let mut rng = Rng::new(0x5eed);
    let mut v = rng.vector(size);
    let mut lambda = 0.0;
    for _ in 0..2000 {
        let n = norm(&v);
        if n == 0.0 {
            return 0.0;
        }
        v.iter_mut().for_each(|x| *x /= n);
        let w: Vec<f64> = (0..size)
            .map(|i| (0..size).map(|j| a[i * size + j] * v[j]).sum())
            .collect();
        lambda = v.iter().zip(&w).map(|(x, y)| x * y).sum();
        v = w;
    }
    lambda
}

/// The largest singular value of the `size`×`size` matrix `a` (row-major): √λ_max(AᵀA).
pub fn spectral_norm(a: &[f64], size: usize) -> f64 {
    let ata: Vec<f64> = (0..size * size)
        .map(|ij| {
            let (i, j) = (ij / size, ij % size);
            (0..size).map(|k| a[k * size + i] * a[k * size + j]).sum()
        })
        .collect();
    largest_eigenvalue(&ata, size).max(0.0).sqrt()
}

/// Each basis value's rounding error, as a multiple of ε times its band's bound
/// √((2l+1)/(4π)) (√((2l+1)/(2π)) for HSH): (l+1)². The forward recurrence takes l steps,
/// each adding a few roundings, and carries an earlier error with a factor that grows at
/// most linearly in l (neither Legendre solution dominates on [−1, 1]): O(l²). Measured over
/// 20 000 directions through the addition theorem (basis tests), the band sums' worst relative
/// error is ≈ (l+1)² ε, twice the per-value error, so (l+1)² per value holds with a
/// factor-2 margin.
pub fn value_error(l: usize) -> f64 {
    ((l + 1) * (l + 1)) as f64
}

/// The rounding bound for a Gram entry Σ_q w_q Bᵢ Bⱼ over K points of an exact rule:
/// recursive summation adds ≤ K ε Σ|w Bᵢ Bⱼ| ≤ K ε (Higham 2002, ch. 4; Cauchy–Schwarz with
/// Σ w Bᵢ² = 1 exactly), and each value's own error δ ≤ value_error(l) ε √((2l+1)/(4π))
/// adds Σ w |δᵢ Bⱼ| ≤ max|δᵢ| √(Σw) ≤ value_error(l) ε √(2l+1), twice (for i and j). HSH's
/// bound is √2 larger and its Σw half: the same.
pub fn gram_tolerance(points: usize, n: usize) -> f64 {
    let l = n - 1;
    (points as f64 + 2.0 * value_error(l) * ((2 * l + 1) as f64).sqrt()) * f64::EPSILON
}
