//! Normalised associated Legendre functions by their stable three-term recurrences, and
//! Gauss–Legendre quadrature.
//!
//! With K_l^m = √((2l+1)/(4π) · (l−m)!/(l+m)!) and P_l^m the associated Legendre function
//! **without** the Condon–Shortley phase (P_m^m(t) = (2m−1)!! (1−t²)^{m/2} ≥ 0), this module
//! computes Q̄_l^m(t) = K_l^m P_l^m(t) / (1−t²)^{m/2}, a polynomial in t of degree l − m. The
//! factor (1−t²)^{m/2} is left to the caller, who folds it into cos mφ and sin mφ as the real
//! and imaginary parts of (x + iy)^m (Sloan 2013, "Efficient Spherical Harmonic Evaluation",
//! JCGT 2(2)), so nothing is divided by sin θ at the poles.
//!
//! The recurrences are the usual ones for P_l^m (Press et al., Numerical Recipes 3rd ed.,
//! §6.7), rewritten for the normalised functions so that no factorial is formed
//! (the unnormalised P_31^31 would reach 61!! ≈ 10⁴²):
//!
//! - Q̄_0^0 = 1/√(4π), Q̄_m^m = √((2m+1)/(2m)) Q̄_{m−1}^{m−1};
//! - Q̄_{m+1}^m = √(2m+3) t Q̄_m^m;
//! - Q̄_l^m = a_l^m (t Q̄_{l−1}^m − b_l^m Q̄_{l−2}^m), with a_l^m = √((4l²−1)/(l²−m²)) and
//!   b_l^m = √(((l−1)²−m²)/(4(l−1)²−1)).
//!
//! Their coefficients are computed once, for every order up to [`MAX_ORDER`], in f64.

use crate::MAX_ORDER;
use std::f64::consts::PI;
use std::sync::OnceLock;

/// The recurrences' coefficients, indexed [l][m].
struct Coefficients {
    diagonal: [f64; MAX_ORDER],
    first: [f64; MAX_ORDER],
    a: [[f64; MAX_ORDER]; MAX_ORDER],
    b: [[f64; MAX_ORDER]; MAX_ORDER],
}

fn coefficients() -> &'static Coefficients {
    static TABLE: OnceLock<Coefficients> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut c = Coefficients {
            diagonal: [0.0; MAX_ORDER],
            first: [0.0; MAX_ORDER],
            a: [[0.0; MAX_ORDER]; MAX_ORDER],
            b: [[0.0; MAX_ORDER]; MAX_ORDER],
        };
        for m in 0..MAX_ORDER {
            let mf = m as f64;
            c.diagonal[m] = if m == 0 {
                1.0
            } else {
                ((2.0 * mf + 1.0) / (2.0 * mf)).sqrt()
            };
            c.first[m] = (2.0 * mf + 3.0).sqrt();
            for l in m + 2..MAX_ORDER {
                let lf = l as f64;
                c.a[l][m] = ((4.0 * lf * lf - 1.0) / (lf * lf - mf * mf)).sqrt();
                let k = lf - 1.0;
                c.b[l][m] = ((k * k - mf * mf) / (4.0 * k * k - 1.0)).sqrt();
            }
        }
        c
    })
}

/// Calls `f(l, m, Q̄_l^m(t))` for every 0 ≤ m ≤ l < n, with m in the outer loop (all of m = 0,
/// then all of m = 1, …). `n` must be at most [`MAX_ORDER`].
#[inline]
pub(crate) fn for_each_normalised(n: usize, t: f64, mut f: impl FnMut(usize, usize, f64)) {
    debug_assert!(n <= MAX_ORDER);
    let c = coefficients();
    let mut pmm = 0.5 / PI.sqrt();
    for m in 0..n {
        pmm *= c.diagonal[m];
        f(m, m, pmm);
        if m + 1 == n {
            break;
        }
        let mut p0 = pmm;
        let mut p1 = c.first[m] * t * pmm;
        f(m + 1, m, p1);
        for l in m + 2..n {
            let p2 = c.a[l][m] * (t * p1 - c.b[l][m] * p0);
            f(l, m, p2);
            p0 = p1;
            p1 = p2;
        }
    }
}

/// The k-point Gauss–Legendre rule on [−1, 1]: (node, weight) pairs, exact for polynomials of
/// degree ≤ 2k − 1. Nodes by Newton's method on P_k from Tricomi's initial guess
/// cos(π(i + 3/4)/(k + 1/2)) (Numerical Recipes 3rd ed., §4.6); converged to |Δx| < 10⁻¹⁵.
pub(crate) fn gauss_legendre(k: usize) -> Vec<(f64, f64)> {
    (0..k)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (k as f64 + 0.5)).cos();
            for _ in 0..100 {
                let (p, derivative) = legendre_and_derivative(k, x);
                let dx = p / derivative;
                x -= dx;
                if dx.abs() < 1e-15 {
                    break;
                }
            }
            // The weight from P_k' at the final node (not the one before the last step).
            let (_, derivative) = legendre_and_derivative(k, x);
            (x, 2.0 / ((1.0 - x * x) * derivative * derivative))
        })
        .collect()
}

/// P_k(x) by Bonnet's recurrence, and P_k'(x) = k (x P_k − P_{k−1}) / (x² − 1).
fn legendre_and_derivative(k: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    for j in 2..=k {
        let jf = j as f64;
        let p2 = ((2.0 * jf - 1.0) * x * p1 - (jf - 1.0) * p0) / jf;
        p0 = p1;
        p1 = p2;
    }
    (p1, k as f64 * (x * p1 - p0) / (x * x - 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Q̄_l^m through the closed forms of P_l^m (no Condon–Shortley phase) for l ≤ 3.
    fn closed_form(l: usize, m: usize, t: f64) -> f64 {
        let k = |l: f64, m: f64| {
            let ratio: f64 = ((l - m + 1.0) as u32..=(l + m) as u32)
                .map(f64::from)
                .product();
            ((2.0 * l + 1.0) / (4.0 * PI) / ratio).sqrt()
        };
        let p = match (l, m) {
            (0, 0) => 1.0,
            (1, 0) => t,
            (1, 1) => 1.0,
            (2, 0) => 0.5 * (3.0 * t * t - 1.0),
            (2, 1) => 3.0 * t,
            (2, 2) => 3.0,
            (3, 0) => 0.5 * (5.0 * t * t * t - 3.0 * t),
            (3, 1) => 1.5 * (5.0 * t * t - 1.0),
            (3, 2) => 15.0 * t,
            (3, 3) => 15.0,
            _ => unreachable!(),
        };
        k(l as f64, m as f64) * p
    }

    #[test]
    fn recurrence_matches_closed_forms() {
        for &t in &[-1.0, -0.7, 0.0, 0.3, 0.99, 1.0] {
            let mut seen = 0;
            for_each_normalised(4, t, |l, m, v| {
                seen += 1;
                let want = closed_form(l, m, t);
                // A handful of roundings in the recurrence and in the closed form, on values
                // below 3: 64 ε relative to max(1, |want|) is ample and still catches any wrong
                // coefficient (which would be off by O(1)).
                assert!(
                    (v - want).abs() <= 64.0 * f64::EPSILON * want.abs().max(1.0),
                    "l={l} m={m} t={t}: {v} vs {want}"
                );
            });
            assert_eq!(seen, 10);
        }
    }

    #[test]
    fn visits_each_pair_once_with_m_outer() {
        let mut order = Vec::new();
        for_each_normalised(3, 0.5, |l, m, _| order.push((l, m)));
        assert_eq!(order, [(0, 0), (1, 0), (2, 0), (1, 1), (2, 1), (2, 2)]);
        let mut one = Vec::new();
        for_each_normalised(1, 0.5, |l, m, _| one.push((l, m)));
        assert_eq!(one, [(0, 0)]);
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_to_degree_2k_minus_1() {
        for k in 1..=40 {
            let rule = gauss_legendre(k);
            let weight_sum: f64 = rule.iter().map(|&(_, w)| w).sum();
            // Sum of k positive weights, each rounded: error ≤ k ε · 2 (Higham, recursive sum).
            assert!(
                (weight_sum - 2.0).abs() <= 4.0 * k as f64 * f64::EPSILON,
                "k={k}: {:e}",
                weight_sum - 2.0
            );
            for degree in 0..2 * k {
                let integral: f64 = rule.iter().map(|&(x, w)| w * x.powi(degree as i32)).sum();
                let want = if degree % 2 == 1 {
                    0.0
                } else {
                    2.0 / (degree as f64 + 1.0)
                };
                // |xᵈ| ≤ 1 and Σw = 2: the sum's rounding is ≤ 2 k ε, the nodes' (|Δx| ≤ 1e-15,
                // amplified by d |x|^{d−1} ≤ d) adds ≤ 2 d · 1e-15.
                let tolerance = 2.0 * k as f64 * f64::EPSILON + 2.0 * degree as f64 * 1e-15;
                assert!(
                    (integral - want).abs() <= tolerance,
                    "k={k} degree={degree}: {integral} vs {want}"
                );
            }
            // And not beyond: degree 2k is integrated wrongly (the rule's exactness is sharp).
            // The rule's error on x^{2k} is 2^{2k+1} (k!)⁴ / ((2k+1) ((2k)!)²) ≈ π/4^k, far
            // above rounding for k ≤ 8 (≥ 4.7e-5).
            if k <= 8 {
                let d = 2 * k;
                let integral: f64 = rule.iter().map(|&(x, w)| w * x.powi(d as i32)).sum();
                assert!((integral - 2.0 / (d as f64 + 1.0)).abs() > 1e-5);
            }
        }
    }
}
