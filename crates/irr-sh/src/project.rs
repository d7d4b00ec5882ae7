//! Projection of a set of weighted samples onto a basis: cᵢ = Σₛ wₛ Lₛ Bᵢ(ωₛ).
//!
//! The weight wₛ is the solid angle the sample stands for (1/pdf for one sample drawn with a
//! pdf over solid angle, divided by the number of samples): the sum is then a quadrature, or a
//! Monte Carlo estimate, of cᵢ = ∫ L(ω) Bᵢ(ω) dω.

use crate::basis::Basis;
use crate::error::ShError;
use crate::value::Coefficient;
use glam::DVec3;

/// A projection in progress: add samples one at a time, read the coefficients, [`clear`] and
/// reuse the storage for the next gather (no allocation after [`Projection::new`]).
///
/// [`clear`]: Projection::clear
#[derive(Clone, Debug)]
pub struct Projection<V> {
    basis: Basis,
    coefficients: Vec<V>,
}

impl<V: Coefficient> Projection<V> {
    /// An empty projection onto `basis`: every coefficient zero.
    pub fn new(basis: Basis) -> Self {
        Self {
            basis,
            coefficients: vec![V::ZERO; basis.coefficient_count()],
        }
    }

    /// Adds `weight · value · Bᵢ(direction)` to every coefficient cᵢ. `weight` is the solid
    /// angle the sample represents. The weight and value are used as given: a NaN poisons the
    /// coefficients, as it would any sum. Errors (and adds nothing) if the direction is zero or
    /// not finite.
    pub fn add(
        &mut self,
        direction: impl Into<DVec3>,
        weight: f64,
        value: V,
    ) -> Result<(), ShError> {
        let coefficients = &mut self.coefficients;
        self.basis.visit(direction.into(), |i, y| {
            coefficients[i] = coefficients[i].add_scaled(value, weight * y);
        })
    }

    /// The basis projected onto.
    pub fn basis(&self) -> Basis {
        self.basis
    }

    /// The coefficients so far, in [`crate::index`] order.
    pub fn coefficients(&self) -> &[V] {
        &self.coefficients
    }

    /// The coefficients, consuming the projection.
    pub fn into_coefficients(self) -> Vec<V> {
        self.coefficients
    }

    /// Sets every coefficient back to zero.
    pub fn clear(&mut self) {
        self.coefficients.fill(V::ZERO);
    }
}

/// The coefficients Σₛ wₛ Lₛ Bᵢ(ωₛ) of the samples (direction ωₛ, weight wₛ = solid angle
/// represented, value Lₛ). Errors on the first invalid direction.
pub fn project<V, D>(
    basis: Basis,
    samples: impl IntoIterator<Item = (D, f64, V)>,
) -> Result<Vec<V>, ShError>
where
    V: Coefficient,
    D: Into<DVec3>,
{
    let mut projection = Projection::new(basis);
    for (direction, weight, value) in samples {
        projection.add(direction, weight, value)?;
    }
    Ok(projection.into_coefficients())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{
        Rng, gram_tolerance, hemisphere_rule, hemisphere_rule_squared, sphere_rule, value_error,
    };
    use glam::Vec3;
    use std::f64::consts::PI;

    /// The bound on |c' − c| when the band-limited f = Σ cⱼ Bⱼ (order n) is projected with an
    /// exact rule of `points` points: Σⱼ cⱼ (Gᵢⱼ − δᵢⱼ) is within ‖c‖₁ gram_tolerance, and
    /// f's own rounding, ≤ (n² + value_error) ε ‖c‖₁ max|B| (a sum of n² products of values
    /// with their error), moves cᵢ by ≤ that times Σ w |Bᵢ| ≤ √(Σw) — together ≤ ‖c‖₁ (gram +
    /// (n² + value_error) √(2n−1) ε). `epsilon` is the unit roundoff of the arithmetic.
    fn projection_tolerance(points: usize, n: usize, c: &[f64], epsilon: f64) -> f64 {
        let l1: f64 = c.iter().map(|x| x.abs()).sum();
        let gram = gram_tolerance(points, n) / f64::EPSILON;
        let f = ((n * n) as f64 + value_error(n - 1)) * ((2 * n - 1) as f64).sqrt();
        l1 * (gram + f) * epsilon
    }

    #[test]
    fn projecting_a_band_limited_function_recovers_it() {
        let mut rng = Rng::new(1);
        for (basis, rule) in [
            (
                Basis::sh(8).unwrap_or_else(|e| panic!("{e}")),
                sphere_rule(8, 15),
            ),
            (
                Basis::hsh(8).unwrap_or_else(|e| panic!("{e}")),
                hemisphere_rule(8, 15),
            ),
            (
                Basis::sh(1).unwrap_or_else(|e| panic!("{e}")),
                sphere_rule(1, 1),
            ),
        ] {
            // f = Σ cⱼ Bⱼ; f · Bᵢ has the degree of a Gram entry, so the rules (n nodes, 2n − 1
            // angles: see the orthonormality tests) are exact for it.
            let c = rng.vector(basis.coefficient_count());
            let samples = rule.iter().map(|&(d, w)| {
                (
                    d,
                    w,
                    basis.reconstruct(&c, d).unwrap_or_else(|e| panic!("{e}")),
                )
            });
            let projected = project(basis, samples).unwrap_or_else(|e| panic!("{e}"));
            let tolerance = projection_tolerance(rule.len(), basis.order(), &c, f64::EPSILON);
            for (a, b) in projected.iter().zip(&c) {
                assert!((a - b).abs() <= tolerance, "{basis:?}: {a} vs {b}");
            }
            // And the reconstruction of the projection is f, anywhere on the domain.
            let d = DVec3::new(0.3, -0.4, 0.5);
            let f = basis.reconstruct(&c, d).unwrap_or_else(|e| panic!("{e}"));
            let g = basis
                .reconstruct(&projected, d)
                .unwrap_or_else(|e| panic!("{e}"));
            let bound = (((2 * basis.order()) as f64 - 1.0) / (2.0 * PI)).sqrt();
            assert!((f - g).abs() <= tolerance * basis.coefficient_count() as f64 * bound);
        }
    }

    #[test]
    fn rgb_in_f32_projects_each_channel() {
        // Three band-limited channels projected as one Vec3 in f32 arithmetic agree with the
        // f64 projection of each channel to the same bound with f32's unit roundoff (the basis
        // values are f64; every f32 product and sum rounds at 2⁻²⁴).
        let basis = Basis::hsh(5).unwrap_or_else(|e| panic!("{e}"));
        let rule = hemisphere_rule(5, 9);
        let mut rng = Rng::new(2);
        let channels: Vec<Vec<f64>> = (0..3).map(|_| rng.vector(25)).collect();
        let mut rgb = Projection::<Vec3>::new(basis);
        let mut scalar: Vec<Projection<f64>> = (0..3).map(|_| Projection::new(basis)).collect();
        for &(d, w) in &rule {
            let v: Vec<f64> = channels
                .iter()
                .map(|c| basis.reconstruct(c, d).unwrap_or_else(|e| panic!("{e}")))
                .collect();
            rgb.add(d, w, Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32))
                .unwrap_or_else(|e| panic!("{e}"));
            for (p, &v) in scalar.iter_mut().zip(&v) {
                p.add(d, w, v).unwrap_or_else(|e| panic!("{e}"));
            }
        }
        for (channel, (c, p)) in channels.iter().zip(&scalar).enumerate() {
            let tolerance = projection_tolerance(rule.len(), 5, c, f64::from(f32::EPSILON));
            for (i, (exact, &want)) in p.coefficients().iter().zip(c).enumerate() {
                let got = f64::from(rgb.coefficients()[i][channel]);
                assert!((got - want).abs() <= tolerance, "{i}: {got} vs {want}");
                let tolerance_f64 = projection_tolerance(rule.len(), 5, c, f64::EPSILON);
                assert!((exact - want).abs() <= tolerance_f64);
            }
        }
    }

    #[test]
    fn a_projection_can_be_cleared_and_reused() {
        let basis = Basis::sh(4).unwrap_or_else(|e| panic!("{e}"));
        let samples = [
            (DVec3::Z, 1.0, 2.0f32),
            (DVec3::new(1.0, 1.0, 0.0), 0.5, -1.0),
        ];
        let once = project(basis, samples).unwrap_or_else(|e| panic!("{e}"));
        let mut projection = Projection::new(basis);
        projection
            .add(DVec3::X, 3.0, 7.0f32)
            .unwrap_or_else(|e| panic!("{e}"));
        projection.clear();
        assert!(projection.coefficients().iter().all(|&c| c == 0.0));
        for (d, w, v) in samples {
            projection.add(d, w, v).unwrap_or_else(|e| panic!("{e}"));
        }
        assert_eq!(projection.coefficients(), once.as_slice());
        // A bad direction is refused and adds nothing.
        assert_eq!(
            projection.add(DVec3::splat(f64::NAN), 1.0, 1.0),
            Err(ShError::InvalidDirection)
        );
        assert_eq!(projection.into_coefficients(), once);
        assert_eq!(
            project(basis, [(Vec3::ZERO, 1.0, 1.0f32)]),
            Err(ShError::InvalidDirection)
        );
    }

    /// One cosine-stratified gather as irr-sampling's `HemisphereStrata` lays it out: cell (j, k)
    /// is the image of [j/M, (j+1)/M) × [k/N, (k+1)/N) under the cosine warp
    /// (sin²θ = u₁, φ = 2πu₂), with one jittered sample per cell. Returns (direction, cos θ).
    fn stratified_gather(m: usize, n: usize, rng: &mut Rng) -> Vec<(DVec3, f64)> {
        let mut out = Vec::with_capacity(m * n);
        for j in 0..m {
            for k in 0..n {
                let u1 = (j as f64 + rng.uniform()) / m as f64;
                let u2 = (k as f64 + rng.uniform()) / n as f64;
                let (sin_theta, cos_theta) = (u1.sqrt(), (1.0 - u1).sqrt());
                let phi = 2.0 * PI * u2;
                let d = DVec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta);
                out.push((d, cos_theta));
            }
        }
        out
    }

    /// The two ways of projecting a cosine-stratified gather (crate docs) on a synthetic
    /// radiance field: both unbiased; the 1/cos θ weights have the larger spread.
    #[test]
    fn stratified_gather_estimators() {
        let basis = Basis::hsh(3).unwrap_or_else(|e| panic!("{e}"));
        // A smooth positive radiance field, with some structure in every coefficient.
        let radiance = |d: DVec3| 1.0 + 0.5 * d.x - 0.3 * d.y + 0.8 * d.z * d.z + 0.2 * d.x * d.z;
        // The true coefficients of L and of L cos θ, by a converged quadrature (x = u² puts
        // nodes near the horizon, where H_l^m with odd m have a square root).
        let fine = hemisphere_rule_squared(64, 64);
        let truth = project(basis, fine.iter().map(|&(d, w)| (d, w, radiance(d))))
            .unwrap_or_else(|e| panic!("{e}"));
        let truth_cos = project(basis, fine.iter().map(|&(d, w)| (d, w, radiance(d) * d.z)))
            .unwrap_or_else(|e| panic!("{e}"));
        let (m, n, runs) = (8, 25, 2000);
        let cell = PI / (m * n) as f64;
        let mut rng = Rng::new(3);
        let mut stats = [(vec![0.0; 9], vec![0.0; 9]), (vec![0.0; 9], vec![0.0; 9])];
        for _ in 0..runs {
            let gather = stratified_gather(m, n, &mut rng);
            let plain = project(
                basis,
                gather.iter().map(|&(d, c)| (d, cell / c, radiance(d))),
            )
            .unwrap_or_else(|e| panic!("{e}"));
            let weighted = project(basis, gather.iter().map(|&(d, _)| (d, cell, radiance(d))))
                .unwrap_or_else(|e| panic!("{e}"));
            for ((sum, squares), (estimate, want)) in stats
                .iter_mut()
                .zip([(&plain, &truth), (&weighted, &truth_cos)])
            {
                for i in 0..9 {
                    let e = estimate[i] - want[i];
                    sum[i] += e;
                    squares[i] += e * e;
                }
            }
        }
        let mut rms = [0.0; 2];
        for (s, ((sum, squares), want)) in stats.iter().zip([&truth, &truth_cos]).enumerate() {
            let scale = want.iter().map(|x| x * x).sum::<f64>().sqrt();
            let mut mse = 0.0;
            for i in 0..9 {
                let mean = sum[i] / runs as f64;
                let variance = squares[i] / runs as f64 - mean * mean;
                // Unbiased: the mean error is within 5 standard errors of zero (a fixed seed, so
                // this is a check of this run, not a probability).
                assert!(
                    mean.abs() <= 5.0 * (variance / runs as f64).sqrt() + 1e-12,
                    "estimator {s}, coefficient {i}: mean error {mean:e}"
                );
                mse += squares[i] / runs as f64;
            }
            rms[s] = mse.sqrt() / scale;
        }
        println!(
            "relative RMS error, 8×25 gather: 1/cos θ weights {:.4}, cos-weighted {:.4}",
            rms[0], rms[1]
        );
        assert!(rms[0] > 2.0 * rms[1], "{rms:?}");
    }
}
