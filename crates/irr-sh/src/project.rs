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
        Rng, gram_tolerance, hemisphere_rule, hemisphere_rule_squared, rotation_from, sphere_rule,
        value_error,
    };
    use crate::{Extension, HemisphereConversion, ShRotation};
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
    /// (sin²θ = u₁, φ = 2πu₂), with one jittered sample per cell. Returns (direction, cos θ, j).
    fn stratified_gather(m: usize, n: usize, rng: &mut Rng) -> Vec<(DVec3, f64, usize)> {
        let mut out = Vec::with_capacity(m * n);
        for j in 0..m {
            for k in 0..n {
                let u1 = (j as f64 + rng.uniform()) / m as f64;
                let u2 = (k as f64 + rng.uniform()) / n as f64;
                let (sin_theta, cos_theta) = (u1.sqrt(), (1.0 - u1).sqrt());
                let phi = 2.0 * PI * u2;
                let d = DVec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta);
                out.push((d, cos_theta, j));
            }
        }
        out
    }

    /// Three ways of projecting a cosine-stratified gather (crate docs) on a synthetic radiance
    /// field, over 2000 gathers of 8×25: radiance with the 1/cos θ weights (unbiased, large
    /// spread), cosine-weighted radiance with the uniform weights (unbiased, small spread), and
    /// radiance with each cell's solid angle as the weight (bounded, biased). Their relative
    /// bias and RMS error are pinned to the numbers the crate docs quote.
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
        // A cell's solid angle: (2π/N)(cos θⱼ − cos θⱼ₊₁), with cos θⱼ = √(1 − j/M).
        let solid_angle = |j: usize| {
            let bound = |j: usize| (1.0 - j as f64 / m as f64).sqrt();
            2.0 * PI / n as f64 * (bound(j) - bound(j + 1))
        };
        let truths = [&truth, &truth_cos, &truth];
        let mut sums = [[0.0; 9]; 3];
        let mut squares = [[0.0; 9]; 3];
        let mut rng = Rng::new(3);
        for _ in 0..runs {
            let gather = stratified_gather(m, n, &mut rng);
            let estimates = [
                gather
                    .iter()
                    .map(|&(d, c, _)| (d, cell / c, radiance(d)))
                    .collect::<Vec<_>>(),
                gather
                    .iter()
                    .map(|&(d, _, _)| (d, cell, radiance(d)))
                    .collect(),
                gather
                    .iter()
                    .map(|&(d, _, j)| (d, solid_angle(j), radiance(d)))
                    .collect(),
            ]
            .map(|samples| project(basis, samples).unwrap_or_else(|e| panic!("{e}")));
            for s in 0..3 {
                for i in 0..9 {
                    let e = estimates[s][i] - truths[s][i];
                    sums[s][i] += e;
                    squares[s][i] += e * e;
                }
            }
        }
        let mut printed = Vec::new();
        for s in 0..3 {
            let scale = truths[s].iter().map(|x| x * x).sum::<f64>().sqrt();
            let mut bias = 0.0;
            let mut mse = 0.0;
            for i in 0..9 {
                let mean = sums[s][i] / runs as f64;
                let variance = squares[s][i] / runs as f64 - mean * mean;
                if s < 2 {
                    // Unbiased: the mean error is within 5 standard errors of zero (a fixed
                    // seed, so this checks this run, not a probability).
                    assert!(
                        mean.abs() <= 5.0 * (variance / runs as f64).sqrt(),
                        "estimator {s}, coefficient {i}: mean error {mean:e}"
                    );
                }
                bias += mean * mean;
                mse += squares[s][i] / runs as f64;
            }
            printed.push(format!("{:.1e}", bias.sqrt() / scale));
            printed.push(format!("{:.1e}", mse.sqrt() / scale));
        }
        println!(
            "8×25 gathers, (bias, RMS) for 1/cos θ, cos-weighted, cell solid angle: {printed:?}"
        );
        assert_eq!(
            printed,
            ["3.4e-3", "2.5e-1", "3.4e-4", "2.8e-2", "1.5e-1", "1.6e-1"],
            "update the crate docs"
        );
    }

    /// Irradiance at a query whose normal is tilted from the record's, from the record's HSH
    /// coefficients rotated through SH (order 16) into the query's frame, on the same field:
    /// cosine-weighted coefficients keep the record's cosine, radiance coefficients take the
    /// query's. Relative errors (no rotation at all, cosine-weighted with the zero extension,
    /// radiance with the mirror extension, radiance with the zero extension), pinned to the
    /// numbers the crate docs quote.
    #[test]
    fn a_tilted_query_needs_radiance_not_cosine_weighted_radiance() {
        let n = 3;
        let basis = Basis::hsh(n).unwrap_or_else(|e| panic!("{e}"));
        let radiance = |d: DVec3| 1.0 + 0.5 * d.x - 0.3 * d.y + 0.8 * d.z * d.z + 0.2 * d.x * d.z;
        let fine = hemisphere_rule_squared(64, 64);
        let coefficients = |f: &dyn Fn(DVec3) -> f64| {
            project(basis, fine.iter().map(|&(d, w)| (d, w, f(d))))
                .unwrap_or_else(|e| panic!("{e}"))
        };
        let plain = coefficients(&radiance);
        let weighted = coefficients(&|d| radiance(d) * d.z);
        // cos θ is in the span of H_0^0 and H_1^0, so E = Σ hᵢ kᵢ exactly for radiance hᵢ.
        let cosine = coefficients(&|d| d.z);
        let record: f64 = fine.iter().map(|&(d, w)| w * radiance(d) * d.z).sum();
        let conversion = |e| HemisphereConversion::new(n, 16, e).unwrap_or_else(|e| panic!("{e}"));
        let (zero, mirror) = (conversion(Extension::Zero), conversion(Extension::Mirror));
        let mut printed = Vec::new();
        for degrees in [5.0f64, 10.0, 20.0] {
            let half = degrees.to_radians() / 2.0;
            let r = rotation_from([half.sin(), 0.0, 0.0, half.cos()])
                .unwrap_or_else(|| panic!("a quaternion far from 0"));
            let rotation = ShRotation::from_dmat3(16, r).unwrap_or_else(|e| panic!("{e}"));
            // The query sees L(Rᵀω) in its own frame.
            let truth: f64 = fine
                .iter()
                .map(|&(d, w)| w * radiance(r.transpose() * d) * d.z)
                .sum();
            let turned = |c: &HemisphereConversion, h: &[f64]| {
                c.rotate_hsh(&rotation, h).unwrap_or_else(|e| panic!("{e}"))
            };
            let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
            let estimates = [
                record,
                turned(&zero, &weighted)[0] * (2.0 * PI).sqrt(),
                dot(&turned(&mirror, &plain), &cosine),
                dot(&turned(&zero, &plain), &cosine),
            ];
            printed.extend(estimates.map(|e| format!("{:+.1e}", e / truth - 1.0)));
        }
        println!("tilted query, irradiance's relative error: {printed:?}");
        assert_eq!(
            printed,
            [
                "+1.4e-2", "+1.1e-2", "+5.3e-4", "-6.5e-4", // 5°
                "+3.0e-2", "+2.2e-2", "+1.1e-3", "-3.7e-3", // 10°
                "+7.0e-2", "+4.0e-2", "+2.2e-3", "-1.7e-2", // 20°
            ],
            "update the crate docs"
        );
    }

    /// The crate docs' claim: projected onto cos θ (exactly in HSH of order ≥ 2), the 1/cos θ
    /// weights cancel and the irradiance is irr's own π/(MN) Σ L, gather by gather.
    #[test]
    fn radiance_coefficients_give_back_the_gathers_irradiance() {
        let basis = Basis::hsh(4).unwrap_or_else(|e| panic!("{e}"));
        let cosine = project(
            basis,
            hemisphere_rule(4, 7).into_iter().map(|(d, w)| (d, w, d.z)),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let (m, n) = (6, 19);
        let cell = PI / (m * n) as f64;
        let mut rng = Rng::new(4);
        let gather = stratified_gather(m, n, &mut rng);
        let values: Vec<f64> = gather.iter().map(|_| 3.0 * rng.uniform()).collect();
        let h = project(
            basis,
            gather
                .iter()
                .zip(&values)
                .map(|(&(d, c, _), &v)| (d, cell / c, v)),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let from_coefficients: f64 = h.iter().zip(&cosine).map(|(a, b)| a * b).sum();
        let direct: f64 = cell * values.iter().sum::<f64>();
        // Σᵢ hᵢ kᵢ = Σₛ wₛ Lₛ (Σᵢ Hᵢ(ωₛ) kᵢ) with Σᵢ Hᵢ kᵢ = cos θ up to the Gram rounding
        // (≤ 10⁻¹³ here); the largest weight, 1/cos θ of the grazing sample, multiplies it.
        let largest_weight = gather.iter().map(|&(_, c, _)| cell / c).fold(0.0, f64::max);
        let tolerance = 1e-13 * largest_weight * values.iter().sum::<f64>() + 1e-13 * direct;
        assert!(
            (from_coefficients - direct).abs() <= tolerance,
            "{from_coefficients} vs {direct}"
        );
    }
}
