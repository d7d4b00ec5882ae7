//! Conversion between hemispherical and spherical harmonics, to rotate HSH coefficients.
//!
//! HSH are not closed under rotation: a rotated hemisphere function is no longer a function of
//! the same hemisphere. Gautron et al. 2004 rotate HSH coefficients through SH: convert to SH,
//! rotate exactly there, convert back, with conversion matrices computed once per pair of
//! orders by projection. With T_{ji} = ∫_{z≥0} H_j Y_i dω:
//!
//! - **SH → HSH** is exact: a sphere function's restriction to the upper hemisphere has HSH
//!   coefficients hⱼ = ∫_{z≥0} f Hⱼ = Σᵢ T_{ji} cᵢ.
//! - **HSH → SH** must say what the function is below the horizon, and then loses what SH of
//!   order n_sh cannot represent of the extended function. [`Extension::Zero`] extends by zero
//!   (T itself, read the other way): cᵢ = Σⱼ T_{ji} hⱼ, a step at the horizon whose SH series
//!   converges slowly (Gibbs ringing). [`Extension::Mirror`] extends evenly,
//!   f(x, y, −z) = f(x, y, z): continuous at the horizon, so its SH series converges faster;
//!   since Y_l^m(x, y, −z) = (−1)^{l+m} Y_l^m(x, y, z), cᵢ = (1 + (−1)^{l+m}) Σⱼ T_{ji} hⱼ.
//!   After a small rotation the strip that rises above the horizon then holds the mirror image
//!   of the radiance just above it instead of black.
//!
//! **Measured round-trip error** (HSH → SH → HSH, no rotation; relative L² error of the HSH
//! coefficients; from the tests, which assert these values):
//!
//! | n_hsh | n_sh | worst case, zero | worst case, mirror | 1, zero | 1, mirror | cos θ, zero | cos θ, mirror |
//! |---|---|---|---|---|---|---|---|
//! | 3 | 3 | 1.0 | 1.0 | 2.5e-1 | 0 | 6.3e-2 | 1.3e-1 |
//! | 3 | 6 | 4.9e-1 | 2.5e-1 | 1.4e-1 | 0 | 1.6e-2 | 3.1e-2 |
//! | 3 | 12 | 2.3e-1 | 2.7e-2 | 7.5e-2 | 0 | 1.7e-3 | 3.4e-3 |
//! | 3 | 24 | 1.2e-1 | 6.2e-3 | 3.9e-2 | 0 | 2.0e-4 | 3.9e-4 |
//! | 5 | 5 | 1.0 | 1.0 | 1.9e-1 | 0 | 3.1e-2 | 6.3e-2 |
//! | 5 | 10 | 7.6e-1 | 7.2e-1 | 1.2e-1 | 0 | 1.1e-2 | 2.3e-2 |
//! | 5 | 20 | 3.9e-1 | 1.2e-1 | 7.3e-2 | 0 | 1.6e-3 | 3.3e-3 |
//!
//! - With n_sh = n_hsh some HSH function is lost entirely (worst case 1.0): SH need more bands
//!   than HSH to resolve the hemisphere's edge. Take n_sh ≥ 4 n_hsh.
//! - A function that does not vanish at the horizon (the constant 1) has a step there when
//!   extended by zero, and its error only halves when n_sh doubles; the mirror extension makes
//!   it exact.
//! - A function that vanishes at the horizon (cos θ) is continuous when extended by zero, and
//!   its error falls ≈ 8× per doubling; the mirror extension has a kink there too and twice
//!   the error.
//!
//! So the extension should match what the coefficients hold: **zero** for cosine-weighted
//! radiance L cos θ, which vanishes at the horizon, **mirror** for radiance itself (the crate
//! docs compare the two for a query whose normal is tilted from the record's).
//!
//! A rotation adds no error of its own (it is exact in SH), but directions that rise above the
//! horizon bring the extension's guess with them. For a smooth "sky" that does not vanish at
//! the horizon, 1 + 0.6x + 0.9z + 0.4z², in HSH of order 4, against the HSH projection of the
//! turned sky (relative L² error, zero / mirror):
//!
//! | n_sh | no rotation | 5° about y |
//! |---|---|---|
//! | 8  | 7.8e-2 / 1.0e-2 | 6.1e-2 / 1.6e-2 |
//! | 16 | 4.5e-2 / 3.2e-3 | 3.2e-2 / 1.6e-2 |
//! | 32 | 2.3e-2 / 1.0e-3 | 2.3e-2 / 2.1e-2 |
//!
//! The mirror's 5° error stays at ≈ 2 % whatever n_sh: it is the difference between the mirror
//! image and this sky's true values below the horizon, which no conversion can know.
//!
//! **Quadrature.** By the φ integral only pairs of the same m and the same kind (cos or sin)
//! couple, each with the same 2π ∫₀¹ H̄_{l}^m(x) Ȳ_{l'}^m(x) dx, x = cos θ, where H̄ and Ȳ are
//! the θ parts. That integrand is a polynomial times (x(1+x))^{m/2} (1−x)^m: for odd m it has a
//! square root at x = 0. With x = u² it becomes a polynomial in u times √(1+u²), analytic on
//! [0, 1] with its nearest singularities at u = ±i, so Gauss–Legendre in u converges
//! geometrically (the error falls by ≈ 4.6² per added node; the polynomial part needs
//! 2(n_hsh + n_sh) nodes). The rule below uses 2(n_hsh + n_sh) + 32 nodes; the tests check that
//! doubling them changes no entry by more than rounding.

use crate::error::{ShError, check_len, check_order};
use crate::legendre::{for_each_normalised, gauss_legendre};
use crate::rotation::ShRotation;
use crate::value::Coefficient;
use crate::{MAX_ORDER, index};
use std::f64::consts::{SQRT_2, TAU};

/// What a hemisphere function is taken to be below the horizon when it is converted to SH.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Extension {
    /// Zero below the horizon: the projection of the HSH function, as it is, onto SH.
    Zero,
    /// The mirror image of the upper hemisphere: f(x, y, −z) = f(x, y, z).
    Mirror,
}

/// The matrices between HSH of order n_hsh and SH of order n_sh (module docs). Computed once;
/// then conversions cost Σ_m (n_hsh − m)(n_sh − m) products per value each way.
#[derive(Clone, Debug, PartialEq)]
pub struct HemisphereConversion {
    hsh_order: usize,
    sh_order: usize,
    extension: Extension,
    /// For m = 0..min(n_hsh, n_sh): the (n_hsh − m)×(n_sh − m) block of T, row l_hsh − m,
    /// column l_sh − m, row-major; shared by +m (cosines) and −m (sines).
    blocks: Vec<Vec<f64>>,
}

impl HemisphereConversion {
    /// The conversion between HSH of order `hsh_order` and SH of order `sh_order`, with the
    /// given extension below the horizon. An SH order above the HSH order loses less (module
    /// docs); one below it drops the HSH bands it lacks.
    pub fn new(hsh_order: usize, sh_order: usize, extension: Extension) -> Result<Self, ShError> {
        let hsh_order = check_order(hsh_order)?;
        let sh_order = check_order(sh_order)?;
        Ok(Self {
            hsh_order,
            sh_order,
            extension,
            blocks: transfer_blocks(hsh_order, sh_order, 2 * (hsh_order + sh_order) + 32),
        })
    }

    /// The HSH order n_hsh.
    pub fn hsh_order(&self) -> usize {
        self.hsh_order
    }

    /// The SH order n_sh.
    pub fn sh_order(&self) -> usize {
        self.sh_order
    }

    /// The extension below the horizon.
    pub fn extension(&self) -> Extension {
        self.extension
    }

    /// The entry T_{ji} = ∫_{z≥0} H_j Y_i dω, for HSH index j and SH index i (0 where they
    /// differ in m).
    pub fn transfer(&self, hsh: (usize, isize), sh: (usize, isize)) -> f64 {
        let ((lh, mh), (ls, ms)) = (hsh, sh);
        let m = mh.unsigned_abs();
        if mh != ms || lh >= self.hsh_order || ls >= self.sh_order || m > lh || m > ls {
            return 0.0;
        }
        self.blocks[m][(lh - m) * (self.sh_order - m) + (ls - m)]
    }

    /// `sh` (n_sh² values) = the SH coefficients of the extended HSH function `hsh` (n_hsh²).
    pub fn to_sh<V: Coefficient>(&self, hsh: &[V], sh: &mut [V]) -> Result<(), ShError> {
        check_len(self.hsh_order * self.hsh_order, hsh.len())?;
        check_len(self.sh_order * self.sh_order, sh.len())?;
        sh.fill(V::ZERO);
        for (m, block) in self.blocks.iter().enumerate() {
            let width = self.sh_order - m;
            for ls in m..self.sh_order {
                let factor = match self.extension {
                    Extension::Zero => 1.0,
                    Extension::Mirror if (ls + m) % 2 == 0 => 2.0,
                    Extension::Mirror => 0.0,
                };
                for sign in signs(m) {
                    let mut sum = V::ZERO;
                    for lh in m..self.hsh_order {
                        let t = block[(lh - m) * width + (ls - m)];
                        sum = sum.add_scaled(hsh[index(lh, sign * m as isize)], factor * t);
                    }
                    sh[index(ls, sign * m as isize)] = sum;
                }
            }
        }
        Ok(())
    }

    /// `hsh` (n_hsh² values) = the HSH coefficients of the SH function `sh` (n_sh²) on the
    /// upper hemisphere. Exact: no extension is involved.
    pub fn to_hsh<V: Coefficient>(&self, sh: &[V], hsh: &mut [V]) -> Result<(), ShError> {
        check_len(self.sh_order * self.sh_order, sh.len())?;
        check_len(self.hsh_order * self.hsh_order, hsh.len())?;
        hsh.fill(V::ZERO);
        for (m, block) in self.blocks.iter().enumerate() {
            let width = self.sh_order - m;
            for lh in m..self.hsh_order {
                for sign in signs(m) {
                    let row = &block[(lh - m) * width..(lh - m + 1) * width];
                    let sum = row.iter().enumerate().fold(V::ZERO, |sum, (k, &t)| {
                        sum.add_scaled(sh[index(m + k, sign * m as isize)], t)
                    });
                    hsh[index(lh, sign * m as isize)] = sum;
                }
            }
        }
        Ok(())
    }

    /// HSH coefficients rotated through SH: [`HemisphereConversion::to_sh`], the exact
    /// `rotation` (whose order must be n_sh), [`HemisphereConversion::to_hsh`]. Allocates two
    /// SH vectors; call the three steps with your own buffers (or a [`crate::FastRotation`])
    /// to avoid that.
    pub fn rotate_hsh<V: Coefficient>(
        &self,
        rotation: &ShRotation,
        hsh: &[V],
    ) -> Result<Vec<V>, ShError> {
        let count = self.sh_order * self.sh_order;
        check_len(count, rotation.order() * rotation.order())?;
        let mut sh = vec![V::ZERO; count];
        self.to_sh(hsh, &mut sh)?;
        let rotated = rotation.rotate(&sh)?;
        let mut out = vec![V::ZERO; self.hsh_order * self.hsh_order];
        self.to_hsh(&rotated, &mut out)?;
        Ok(out)
    }
}

/// +1 (the cosine function) and, for m > 0, −1 (the sine function).
fn signs(m: usize) -> impl Iterator<Item = isize> {
    [1, -1].into_iter().take(if m == 0 { 1 } else { 2 })
}

/// The blocks of T (see [`HemisphereConversion`]) by `nodes`-point Gauss–Legendre in u, x = u².
pub(crate) fn transfer_blocks(hsh_order: usize, sh_order: usize, nodes: usize) -> Vec<Vec<f64>> {
    let shared = hsh_order.min(sh_order);
    let mut blocks: Vec<Vec<f64>> = (0..shared)
        .map(|m| vec![0.0; (hsh_order - m) * (sh_order - m)])
        .collect();
    let mut hsh = [[0.0; MAX_ORDER]; MAX_ORDER];
    let mut sh = [[0.0; MAX_ORDER]; MAX_ORDER];
    for (s, w) in gauss_legendre(nodes) {
        // u = (s + 1)/2 on [0, 1], x = u², dx = 2u du = u ds.
        let u = 0.5 * (s + 1.0);
        let x = u * u;
        let weight = TAU * w * u;
        // θ parts: Ȳ_l^m = Q̄_l^m(x) (1 − x²)^{m/2}, H̄_l^m = √2 Q̄_l^m(2x − 1) (2√(x(1−x)))^m
        // (basis module); the φ integral of either kind's (√2 cos mφ)² or 1 is 2π (in `weight`).
        let (sin_sh, sin_hsh) = ((1.0 - x * x).sqrt(), 2.0 * (x * (1.0 - x)).sqrt());
        for_each_normalised(sh_order, x, |l, m, p| sh[l][m] = p * sin_sh.powi(m as i32));
        for_each_normalised(hsh_order, 2.0 * x - 1.0, |l, m, p| {
            hsh[l][m] = SQRT_2 * p * sin_hsh.powi(m as i32);
        });
        for (m, block) in blocks.iter_mut().enumerate() {
            let width = sh_order - m;
            for lh in m..hsh_order {
                let h = weight * hsh[lh][m];
                for ls in m..sh_order {
                    block[(lh - m) * width + (ls - m)] += h * sh[ls][m];
                }
            }
        }
    }
    blocks
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Basis;
    use crate::testutil::{
        Rng, hemisphere_rule, hemisphere_rule_squared, largest_eigenvalue, max_abs_difference,
        norm, rotation_from,
    };
    use glam::{DMat3, DVec3};

    #[test]
    fn the_quadrature_has_converged() {
        for (nh, ns) in [(1, 1), (3, 7), (8, 8), (10, 20), (MAX_ORDER, MAX_ORDER)] {
            let nodes = 2 * (nh + ns) + 32;
            let a = transfer_blocks(nh, ns, nodes);
            let b = transfer_blocks(nh, ns, 2 * nodes);
            for (x, y) in a.iter().zip(&b) {
                // |T_ji| ≤ 1 (Cauchy–Schwarz over the hemisphere, where H_j has norm 1 and Y_i
                // at most 1), and each is a sum of `nodes` terms whose absolute values add up
                // to ≤ 1 as well: rounding ≤ 2 · 2 nodes ε between the two rules. Anything
                // beyond is quadrature error.
                let tolerance = 4.0 * (2 * nodes) as f64 * f64::EPSILON;
                assert!(
                    max_abs_difference(x, y) <= tolerance,
                    "n_hsh={nh} n_sh={ns}"
                );
            }
        }
    }

    #[test]
    fn the_blocks_match_the_evaluated_bases() {
        // T_ji = ∫_{z≥0} H_j Y_i by brute force over directions, from the public evaluators:
        // x = cos θ = u² with converged Gauss–Legendre in u (the blocks' own rule, so the same
        // quadrature error, below rounding: test above), and p equally spaced φ, exact for the
        // trigonometric degree ≤ (n_hsh − 1) + (n_sh − 1) < p of the φ part.
        let (nh, ns) = (4, 6);
        let conversion =
            HemisphereConversion::new(nh, ns, Extension::Zero).unwrap_or_else(|e| panic!("{e}"));
        let rule = hemisphere_rule_squared(2 * (nh + ns) + 32, nh + ns);
        let (hsh, sh) = (
            Basis::hsh(nh).unwrap_or_else(|e| panic!("{e}")),
            Basis::sh(ns).unwrap_or_else(|e| panic!("{e}")),
        );
        let mut brute = vec![0.0; nh * nh * ns * ns];
        let (mut h, mut y) = (vec![0.0; nh * nh], vec![0.0; ns * ns]);
        for &(d, w) in &rule {
            hsh.eval_f64(d, &mut h).unwrap_or_else(|e| panic!("{e}"));
            sh.eval_f64(d, &mut y).unwrap_or_else(|e| panic!("{e}"));
            for j in 0..nh * nh {
                for i in 0..ns * ns {
                    brute[j * ns * ns + i] += w * h[j] * y[i];
                }
            }
        }
        for lh in 0..nh {
            for mh in -(lh as isize)..=lh as isize {
                for ls in 0..ns {
                    for ms in -(ls as isize)..=ls as isize {
                        let got = conversion.transfer((lh, mh), (ls, ms));
                        let want = brute[index(lh, mh) * ns * ns + index(ls, ms)];
                        // A sum over 84 · 10 points of products below 2 with weights summing to
                        // 2π: the Gram entries' bound (basis tests), ≤ 10⁻¹² here.
                        assert!(
                            (got - want).abs() <= 1e-12,
                            "({lh},{mh}) ({ls},{ms}): {got} vs {want}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn sh_to_hsh_is_the_restriction() {
        // A band-limited sphere function's HSH coefficients, projected directly over z ≥ 0 (the
        // squared rule converges on H_l^m's square roots at the horizon) and through T.
        let (nh, ns) = (5, 4);
        let conversion =
            HemisphereConversion::new(nh, ns, Extension::Mirror).unwrap_or_else(|e| panic!("{e}"));
        let c = Rng::new(11).vector(ns * ns);
        let sh = Basis::sh(ns).unwrap_or_else(|e| panic!("{e}"));
        let rule = hemisphere_rule_squared(2 * (nh + ns) + 32, nh + ns);
        let direct = crate::project(
            Basis::hsh(nh).unwrap_or_else(|e| panic!("{e}")),
            rule.iter().map(|&(d, w)| {
                (
                    d,
                    w,
                    sh.reconstruct(&c, d).unwrap_or_else(|e| panic!("{e}")),
                )
            }),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let mut through = vec![0.0; nh * nh];
        conversion
            .to_hsh(&c, &mut through)
            .unwrap_or_else(|e| panic!("{e}"));
        // ‖c‖₁ times the entries' tolerance above.
        let tolerance = 1e-12 * c.iter().map(|x| x.abs()).sum::<f64>();
        assert!(max_abs_difference(&direct, &through) <= tolerance);
    }

    #[test]
    fn hsh_to_sh_projects_the_extended_function() {
        // The SH coefficients of the zero- and mirror-extended HSH function, projected over
        // the whole sphere by brute force, with the squared rule on each hemisphere.
        let (nh, ns) = (3, 5);
        let h = Rng::new(12).vector(nh * nh);
        let hsh = Basis::hsh(nh).unwrap_or_else(|e| panic!("{e}"));
        let upper = hemisphere_rule_squared(2 * (nh + ns) + 32, nh + ns);
        for extension in [Extension::Zero, Extension::Mirror] {
            let conversion =
                HemisphereConversion::new(nh, ns, extension).unwrap_or_else(|e| panic!("{e}"));
            let mut sh = vec![0.0; ns * ns];
            conversion
                .to_sh(&h, &mut sh)
                .unwrap_or_else(|e| panic!("{e}"));
            let lower = upper.iter().map(|&(d, w)| {
                let value = match extension {
                    Extension::Zero => 0.0,
                    Extension::Mirror => hsh.reconstruct(&h, d).unwrap_or_else(|e| panic!("{e}")),
                };
                (DVec3::new(d.x, d.y, -d.z), w, value)
            });
            let brute = crate::project(
                Basis::sh(ns).unwrap_or_else(|e| panic!("{e}")),
                upper
                    .iter()
                    .map(|&(d, w)| {
                        (
                            d,
                            w,
                            hsh.reconstruct(&h, d).unwrap_or_else(|e| panic!("{e}")),
                        )
                    })
                    .chain(lower),
            )
            .unwrap_or_else(|e| panic!("{e}"));
            let tolerance = 2e-12 * h.iter().map(|x| x.abs()).sum::<f64>();
            assert!(
                max_abs_difference(&brute, &sh) <= tolerance,
                "{extension:?}"
            );
        }
    }

    /// The worst relative round-trip error max ‖h − T D Tᵀ h‖/‖h‖: the largest eigenvalue of
    /// the symmetric I − T D Tᵀ (D the extension's factors), block by block in m.
    fn worst_round_trip(c: &HemisphereConversion) -> f64 {
        let mut worst = 0.0f64;
        for (m, block) in c.blocks.iter().enumerate() {
            let (rows, columns) = (c.hsh_order - m, c.sh_order - m);
            let mut e = vec![0.0; rows * rows];
            for i in 0..rows {
                for j in 0..rows {
                    let kept: f64 = (0..columns)
                        .map(|k| {
                            let factor = match c.extension {
                                Extension::Zero => 1.0,
                                Extension::Mirror if (2 * m + k) % 2 == 0 => 2.0,
                                Extension::Mirror => 0.0,
                            };
                            block[i * columns + k] * factor * block[j * columns + k]
                        })
                        .sum();
                    e[i * rows + j] = f64::from(u8::from(i == j)) - kept;
                }
            }
            worst = worst.max(largest_eigenvalue(&e, rows));
        }
        worst
    }

    fn round_trip_error(c: &HemisphereConversion, h: &[f64]) -> f64 {
        let mut sh = vec![0.0; c.sh_order * c.sh_order];
        c.to_sh(h, &mut sh).unwrap_or_else(|e| panic!("{e}"));
        let mut back = vec![0.0; h.len()];
        c.to_hsh(&sh, &mut back).unwrap_or_else(|e| panic!("{e}"));
        let d: Vec<f64> = back.iter().zip(h).map(|(a, b)| a - b).collect();
        norm(&d) / norm(h)
    }

    /// The module docs' table: (n_hsh, n_sh, [worst zero, worst mirror, constant zero,
    /// constant mirror, cos θ zero, cos θ mirror]).
    const TABLE: [(usize, usize, [&str; 6]); 7] = [
        (3, 3, ["1.0e0", "1.0e0", "2.5e-1", "0", "6.3e-2", "1.3e-1"]),
        (
            3,
            6,
            ["4.9e-1", "2.5e-1", "1.4e-1", "0", "1.6e-2", "3.1e-2"],
        ),
        (
            3,
            12,
            ["2.3e-1", "2.7e-2", "7.5e-2", "0", "1.7e-3", "3.4e-3"],
        ),
        (
            3,
            24,
            ["1.2e-1", "6.2e-3", "3.9e-2", "0", "2.0e-4", "3.9e-4"],
        ),
        (5, 5, ["1.0e0", "1.0e0", "1.9e-1", "0", "3.1e-2", "6.3e-2"]),
        (
            5,
            10,
            ["7.6e-1", "7.2e-1", "1.2e-1", "0", "1.1e-2", "2.3e-2"],
        ),
        (
            5,
            20,
            ["3.9e-1", "1.2e-1", "7.3e-2", "0", "1.6e-3", "3.3e-3"],
        ),
    ];

    #[test]
    fn round_trip_errors_are_the_table() {
        let mut rows = Vec::new();
        for (nh, ns, row) in TABLE {
            let basis = Basis::hsh(nh).unwrap_or_else(|e| panic!("{e}"));
            // 1 and z are polynomials of degree ≤ 1 in cos θ: with H_l^m, of degree ≤ n_hsh,
            // which n_hsh nodes integrate exactly (basis tests).
            let rule = hemisphere_rule(nh, 2 * nh - 1);
            let constant = crate::project(basis, rule.iter().map(|&(d, w)| (d, w, 1.0)))
                .unwrap_or_else(|e| panic!("{e}"));
            let cosine = crate::project(basis, rule.iter().map(|&(d, w)| (d, w, d.z)))
                .unwrap_or_else(|e| panic!("{e}"));
            let mut printed = Vec::new();
            let conversions = [Extension::Zero, Extension::Mirror]
                .map(|e| HemisphereConversion::new(nh, ns, e).unwrap_or_else(|e| panic!("{e}")));
            for c in &conversions {
                printed.push(worst_round_trip(c));
            }
            for h in [&constant, &cosine] {
                for c in &conversions {
                    printed.push(round_trip_error(c, h));
                }
            }
            let printed: Vec<String> = printed
                .iter()
                .map(|&e| {
                    if e < 1e-12 {
                        "0".into()
                    } else {
                        format!("{e:.1e}")
                    }
                })
                .collect();
            println!("n_hsh {nh}, n_sh {ns}: {}", printed.join(" | "));
            rows.push((printed, row));
        }
        for (printed, row) in rows {
            assert_eq!(printed, row, "update the table in the module docs");
        }
    }

    #[test]
    fn rotations_about_z_commute_with_the_conversion() {
        // R_z keeps the hemisphere, and T couples only equal m: through SH, a rotation about z
        // is the round trip followed by the same rotation of the HSH pairs, whose matrix is the
        // SH one's (the pairs turn by mα in both bases).
        let (nh, ns) = (4, 8);
        let conversion =
            HemisphereConversion::new(nh, ns, Extension::Zero).unwrap_or_else(|e| panic!("{e}"));
        let h = Rng::new(13).vector(nh * nh);
        let rz = DMat3::from_rotation_z(0.8);
        let rotated = conversion
            .rotate_hsh(
                &ShRotation::from_dmat3(ns, rz).unwrap_or_else(|e| panic!("{e}")),
                &h,
            )
            .unwrap_or_else(|e| panic!("{e}"));
        let mut sh = vec![0.0; ns * ns];
        conversion
            .to_sh(&h, &mut sh)
            .unwrap_or_else(|e| panic!("{e}"));
        let mut round_trip = vec![0.0; nh * nh];
        conversion
            .to_hsh(&sh, &mut round_trip)
            .unwrap_or_else(|e| panic!("{e}"));
        let want = ShRotation::from_dmat3(nh, rz)
            .unwrap_or_else(|e| panic!("{e}"))
            .rotate(&round_trip)
            .unwrap_or_else(|e| panic!("{e}"));
        // Two routes through the same few dozen products of entries below 1: 10⁻¹³.
        assert!(max_abs_difference(&rotated, &want) <= 1e-13 * norm(&h));
        // And the identity rotation is the round trip itself.
        let same = conversion
            .rotate_hsh(
                &ShRotation::from_dmat3(ns, DMat3::IDENTITY).unwrap_or_else(|e| panic!("{e}")),
                &h,
            )
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(max_abs_difference(&same, &round_trip) <= 1e-13 * norm(&h));
    }

    #[test]
    fn a_small_tilt_through_sh() {
        // A sphere function's HSH coefficients, turned through SH, against the HSH projection
        // of the turned function: what the conversion loses plus what enters from below the
        // horizon (where HSH know nothing). Without a rotation, the round trip alone. Pinned
        // as a regression; the module docs quote it.
        let nh = 4;
        let sky = |d: DVec3| 1.0 + 0.6 * d.x + 0.9 * d.z + 0.4 * d.z * d.z;
        let hsh = Basis::hsh(nh).unwrap_or_else(|e| panic!("{e}"));
        let half = 5f64.to_radians() / 2.0;
        let tilt = rotation_from([0.0, half.sin(), 0.0, half.cos()])
            .unwrap_or_else(|| panic!("a quaternion far from 0"));
        let mut rows = Vec::new();
        for ns in [8, 16, 32] {
            let rule = hemisphere_rule_squared(2 * (nh + ns) + 32, nh + ns);
            let mut printed = Vec::new();
            for r in [DMat3::IDENTITY, tilt] {
                let h = crate::project(hsh, rule.iter().map(|&(d, w)| (d, w, sky(d))))
                    .unwrap_or_else(|e| panic!("{e}"));
                let want = crate::project(
                    hsh,
                    rule.iter().map(|&(d, w)| (d, w, sky(r.transpose() * d))),
                )
                .unwrap_or_else(|e| panic!("{e}"));
                for extension in [Extension::Zero, Extension::Mirror] {
                    let conversion = HemisphereConversion::new(nh, ns, extension)
                        .unwrap_or_else(|e| panic!("{e}"));
                    let rotation = ShRotation::from_dmat3(ns, r).unwrap_or_else(|e| panic!("{e}"));
                    let got = conversion
                        .rotate_hsh(&rotation, &h)
                        .unwrap_or_else(|e| panic!("{e}"));
                    let d: Vec<f64> = got.iter().zip(&want).map(|(a, b)| a - b).collect();
                    printed.push(format!("{:.1e}", norm(&d) / norm(&want)));
                }
            }
            println!("sky, n_hsh 4, n_sh {ns}: {}", printed.join(" | "));
            rows.push(printed);
        }
        assert_eq!(
            rows,
            [
                ["7.8e-2", "1.0e-2", "6.1e-2", "1.6e-2"],
                ["4.5e-2", "3.2e-3", "3.2e-2", "1.6e-2"],
                ["2.3e-2", "1.0e-3", "2.3e-2", "2.1e-2"],
            ]
        );
    }

    #[test]
    fn bad_input_is_refused() {
        assert_eq!(
            HemisphereConversion::new(0, 3, Extension::Zero),
            Err(ShError::ZeroOrder)
        );
        assert_eq!(
            HemisphereConversion::new(3, 33, Extension::Zero),
            Err(ShError::OrderTooLarge { order: 33 })
        );
        let c =
            HemisphereConversion::new(3, 5, Extension::Mirror).unwrap_or_else(|e| panic!("{e}"));
        let mut sh = vec![0.0f32; 25];
        assert_eq!(
            c.to_sh(&[0.0f32; 8], &mut sh),
            Err(ShError::LengthMismatch {
                expected: 9,
                actual: 8
            })
        );
        let mut hsh = vec![0.0f32; 9];
        assert_eq!(
            c.to_hsh(&[0.0f32; 16], &mut hsh),
            Err(ShError::LengthMismatch {
                expected: 25,
                actual: 16
            })
        );
        let rotation = ShRotation::from_dmat3(4, DMat3::IDENTITY).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            c.rotate_hsh(&rotation, &[0.0f32; 9]),
            Err(ShError::LengthMismatch {
                expected: 25,
                actual: 16
            })
        );
        // An SH order below the HSH order keeps the bands they share.
        let low =
            HemisphereConversion::new(5, 2, Extension::Zero).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(low.transfer((0, 0), (1, 0)), low.blocks[0][1]);
        assert!(low.transfer((0, 0), (1, 0)) > 0.1);
        assert_eq!(low.transfer((4, 3), (1, 1)), 0.0);
        assert_eq!(low.transfer((4, 3), (4, 3)), 0.0);
    }
}
