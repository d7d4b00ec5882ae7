//! Conversion between hemispherical and spherical harmonics, to rotate HSH coefficients.
//!
//! HSH are not closed under rotation: a rotated hemisphere function is no longer a function of
//! the same hemisphere. Gautron et al. 2004 (§5) rotate HSH coefficients through SH: convert to
//! SH, rotate exactly there, convert back, with conversion matrices computed once per pair of
//! orders by projection. With T_{ji} = ∫_{z≥0} H_j Y_i dω:
//!
//! - **SH → HSH** is exact: a sphere function's restriction to the upper hemisphere has HSH
//!   coefficients hⱼ = ∫_{z≥0} f Hⱼ = Σᵢ T_{ji} cᵢ.
//! - **HSH → SH** must say what the function is below the horizon, and then loses what SH of
//!   order n_sh cannot represent of the extended function. [`Extension::Zero`] (Gautron et al.'s
//!   choice) extends by zero: cᵢ = Σⱼ T_{ji} hⱼ, a step at the horizon whose SH series converges
//!   slowly (Gibbs ringing). [`Extension::Mirror`] extends evenly, f(x, y, −z) = f(x, y, z):
//!   continuous at the horizon, so its SH series converges faster; since Y_l^m(x, y, −z) =
//!   (−1)^{l+m} Y_l^m(x, y, z), cᵢ = (1 + (−1)^{l+m}) Σⱼ T_{ji} hⱼ. After a small rotation the
//!   strip that rises above the horizon then holds the mirror image of the radiance just above
//!   it instead of black.
//!
//! **Measured round-trip error** (HSH → SH → HSH, no rotation; relative L² error of the HSH
//! coefficients; from the tests, which assert these values):
//!
//! | n_hsh | n_sh | worst case, zero | worst case, mirror | cos θ, zero | cos θ, mirror |
//! |---|---|---|---|---|---|
//! | 3 | 3 | TODO |
//!
//! A rotation adds no error of its own (it is exact in SH), so this is the error a rotation
//! through SH introduces on top of what enters across the horizon.
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
    /// Zero below the horizon (Gautron et al. 2004).
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
