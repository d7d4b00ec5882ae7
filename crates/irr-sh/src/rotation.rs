//! Exact rotation of real spherical-harmonic coefficients: Ivanic & Ruedenberg's recurrence.
//!
//! A rotation R maps the coefficients of f to those of f∘Rᵀ, the function turned by R (a lobe
//! along d ends up along R d). Rotations do not mix bands, so the matrix is block-diagonal: one
//! (2l+1)×(2l+1) orthogonal block per band. Band 0 is 1. Band 1, in the (y, z, x) order of
//! Y_1^{−1}, Y_1^0, Y_1^1, is R itself with rows and columns permuted: entry (m, m') is
//! R[p(m)][p(m')] with p = (y, z, x). Band l ≥ 2 follows from band 1 and band l − 1 (Ivanic &
//! Ruedenberg 1996, "Rotation Matrices for Real Spherical Harmonics. Direct Determination by
//! Recursion", J. Phys. Chem. 100(15), eq. 8.1–8.5 and Table 2, with the corrections of their
//! 1998 erratum, J. Phys. Chem. A 102(45)):
//!
//! R^l_{m,m'} = u U + v V + w W, with
//!
//! - d = δ_{m,0}; D = (l+m')(l−m') if |m'| < l, else 2l(2l−1);
//! - u = √((l+m)(l−m)/D), v = ½ √((1+d)(l+|m|−1)(l+|m|)/D) (1−2d),
//!   w = −½ √((l−|m|−1)(l−|m|)/D) (1−d);
//! - P(i, a, b) = R¹_{i,0} R^{l−1}_{a,b} for |b| < l; R¹_{i,1} R^{l−1}_{a,l−1} − R¹_{i,−1}
//!   R^{l−1}_{a,−l+1} for b = l; R¹_{i,1} R^{l−1}_{a,−l+1} + R¹_{i,−1} R^{l−1}_{a,l−1} for b = −l;
//! - U = P(0, m, m');
//! - V = P(1, 1, m') + P(−1, −1, m') for m = 0; P(1, m−1, m') √(1+δ_{m,1}) − P(−1, −m+1, m')
//!   (1−δ_{m,1}) for m > 0; P(1, m+1, m') (1−δ_{m,−1}) + P(−1, −m−1, m') √(1+δ_{m,−1}) for m < 0;
//! - W = P(1, m+1, m') + P(−1, −m−1, m') for m > 0; P(1, m−1, m') − P(−1, −m+1, m') for m < 0
//!   (w = 0 for m = 0).
//!
//! The recurrence is bilinear in (R¹, R^{l−1}), which [`crate::fast`] uses to check its
//! derivative. Computed in f64; building all bands up to order n costs Σ(2l+1)² entries of a
//! few products each, O(n³), and applying them as much again.

use crate::error::{ShError, check_len, check_order};
use crate::value::Coefficient;
use glam::{DMat3, Mat3};

/// How far from orthonormal a rotation matrix may be: max |(MᵀM − I)ᵢⱼ| ≤ 10⁻⁴. An f32 matrix
/// built from a quaternion or an orthonormal frame is orthonormal to ~10⁻⁷; the slack admits
/// such a matrix after a few products. Accepted matrices are made exactly orthonormal (to f64
/// rounding) before use.
pub const ROTATION_TOLERANCE: f64 = 1e-4;

/// The exact rotation of SH coefficients of order n, as its block-diagonal matrix.
#[derive(Clone, Debug, PartialEq)]
pub struct ShRotation {
    order: usize,
    rotation: DMat3,
    /// Band l's (2l+1)² entries, row-major, at offset Σ_{k<l} (2k+1)² = l(4l²−1)/3.
    blocks: Vec<f64>,
}

impl ShRotation {
    /// The rotation of order-n SH coefficients by `rotation` (see [`ShRotation::from_dmat3`]).
    pub fn new(order: usize, rotation: Mat3) -> Result<Self, ShError> {
        Self::from_dmat3(order, rotation.as_dmat3())
    }

    /// The rotation of order-n SH coefficients by `rotation`: coefficients of f become those of
    /// f∘Rᵀ. Errors if the order is unsupported or the matrix is not a rotation within
    /// [`ROTATION_TOLERANCE`].
    pub fn from_dmat3(order: usize, rotation: DMat3) -> Result<Self, ShError> {
        let order = check_order(order)?;
        let mut this = Self {
            order,
            rotation: DMat3::IDENTITY,
            blocks: vec![0.0; block_offset(order)],
        };
        this.set_dmat3(rotation)?;
        Ok(this)
    }

    /// Rebuilds the matrix for another rotation, reusing the storage (no allocation). On error
    /// the previous rotation is kept.
    pub fn set(&mut self, rotation: Mat3) -> Result<(), ShError> {
        self.set_dmat3(rotation.as_dmat3())
    }

    /// [`ShRotation::set`] with an f64 matrix.
    pub fn set_dmat3(&mut self, rotation: DMat3) -> Result<(), ShError> {
        let r = orthonormalised(rotation)?;
        self.rotation = r;
        self.blocks[0] = 1.0;
        if self.order == 1 {
            return Ok(());
        }
        let r1 = band_one(r);
        self.blocks[1..10].copy_from_slice(&r1);
        for l in 2..self.order {
            let (done, rest) = self.blocks.split_at_mut(block_offset(l));
            let previous = &done[block_offset(l - 1)..];
            next_band(&r1, previous, l, &mut rest[..(2 * l + 1) * (2 * l + 1)]);
        }
        Ok(())
    }

    /// The order n.
    pub fn order(&self) -> usize {
        self.order
    }

    /// The rotation, as made orthonormal.
    pub fn rotation(&self) -> DMat3 {
        self.rotation
    }

    /// Band l's (2l+1)×(2l+1) block, row-major (row m + l, column m' + l), or `None` if l ≥ n.
    pub fn block(&self, l: usize) -> Option<&[f64]> {
        (l < self.order).then(|| &self.blocks[block_offset(l)..block_offset(l + 1)])
    }

    /// `output` = the rotated `input` (both n² coefficients).
    pub fn apply<V: Coefficient>(&self, input: &[V], output: &mut [V]) -> Result<(), ShError> {
        let count = self.order * self.order;
        check_len(count, input.len())?;
        check_len(count, output.len())?;
        for l in 0..self.order {
            let width = 2 * l + 1;
            let block = &self.blocks[block_offset(l)..block_offset(l + 1)];
            let band = l * l..(l + 1) * (l + 1);
            for (row, out) in block.chunks_exact(width).zip(&mut output[band.clone()]) {
                *out = row
                    .iter()
                    .zip(&input[band.clone()])
                    .fold(V::ZERO, |sum, (&r, &c)| sum.add_scaled(c, r));
            }
        }
        Ok(())
    }

    /// [`ShRotation::apply`] into a new vector.
    pub fn rotate<V: Coefficient>(&self, input: &[V]) -> Result<Vec<V>, ShError> {
        let mut output = vec![V::ZERO; self.order * self.order];
        self.apply(input, &mut output)?;
        Ok(output)
    }
}

/// Σ_{k<l} (2k+1)² = l(4l² − 1)/3: where band l's block starts.
pub(crate) const fn block_offset(l: usize) -> usize {
    (4 * l * l * l - l) / 3
}

/// `rotation` checked (finite, orthonormal within [`ROTATION_TOLERANCE`], determinant > 0)
/// and made orthonormal by Newton's iteration for the polar factor, M ← (M + M⁻ᵀ)/2 (Higham
/// 1986, "Computing the Polar Decomposition—with Applications", SIAM J. Sci. Stat. Comput. 7(4)):
/// it converges quadratically, from 10⁻⁴ to rounding in three steps.
pub(crate) fn orthonormalised(rotation: DMat3) -> Result<DMat3, ShError> {
    if !rotation.is_finite() || rotation.determinant() <= 0.0 {
        return Err(ShError::NotARotation);
    }
    let gram = rotation.transpose() * rotation - DMat3::IDENTITY;
    let deviation = gram
        .to_cols_array()
        .iter()
        .fold(0.0f64, |a, &x| a.max(x.abs()));
    if deviation > ROTATION_TOLERANCE {
        return Err(ShError::NotARotation);
    }
    let mut m = rotation;
    for _ in 0..3 {
        m = (m + m.inverse().transpose()) * 0.5;
    }
    Ok(m)
}

/// Band 1's block: R with rows and columns in the order (y, z, x), row-major.
pub(crate) fn band_one(r: DMat3) -> [f64; 9] {
    const P: [usize; 3] = [1, 2, 0];
    let mut b = [0.0; 9];
    for (i, &pi) in P.iter().enumerate() {
        for (j, &pj) in P.iter().enumerate() {
            b[3 * i + j] = r.col(pj)[pi];
        }
    }
    b
}

/// Band l's block (row-major, (2l+1)²) from band 1's (`r1`) and band l − 1's (`previous`), by
/// Ivanic & Ruedenberg's recurrence (module docs). Bilinear in (`r1`, `previous`).
pub(crate) fn next_band(r1: &[f64], previous: &[f64], l: usize, out: &mut [f64]) {
    let li = l as isize;
    let width = 2 * l + 1;
    let previous_width = 2 * l - 1;
    let one = |i: isize, j: isize| r1[((i + 1) * 3 + j + 1) as usize];
    let prev = |a: isize, b: isize| {
        previous[(a + li - 1) as usize * previous_width + (b + li - 1) as usize]
    };
    let p = |i: isize, a: isize, b: isize| {
        if b == li {
            one(i, 1) * prev(a, li - 1) - one(i, -1) * prev(a, -li + 1)
        } else if b == -li {
            one(i, 1) * prev(a, -li + 1) + one(i, -1) * prev(a, li - 1)
        } else {
            one(i, 0) * prev(a, b)
        }
    };
    let delta = |a: isize, b: isize| if a == b { 1.0 } else { 0.0 };
    let lf = l as f64;
    for m in -li..=li {
        for n in -li..=li {
            let (mf, nf, am) = (m as f64, n as f64, m.unsigned_abs() as f64);
            let d = delta(m, 0);
            let denominator = if n.abs() < li {
                (lf + nf) * (lf - nf)
            } else {
                2.0 * lf * (2.0 * lf - 1.0)
            };
            let u = ((lf + mf) * (lf - mf) / denominator).sqrt();
            let v = 0.5
                * ((1.0 + d) * (lf + am - 1.0) * (lf + am) / denominator).sqrt()
                * (1.0 - 2.0 * d);
            let w = -0.5 * ((lf - am - 1.0) * (lf - am) / denominator).sqrt() * (1.0 - d);
            // Each term only where its coefficient is non-zero: elsewhere its indices would
            // fall outside band l − 1.
            let mut value = 0.0;
            if u != 0.0 {
                value += u * p(0, m, n);
            }
            if v != 0.0 {
                let big_v = match m {
                    0 => p(1, 1, n) + p(-1, -1, n),
                    m if m > 0 => {
                        p(1, m - 1, n) * (1.0 + delta(m, 1)).sqrt()
                            - p(-1, -m + 1, n) * (1.0 - delta(m, 1))
                    }
                    m => {
                        p(1, m + 1, n) * (1.0 - delta(m, -1))
                            + p(-1, -m - 1, n) * (1.0 + delta(m, -1)).sqrt()
                    }
                };
                value += v * big_v;
            }
            if w != 0.0 {
                let big_w = if m > 0 {
                    p(1, m + 1, n) + p(-1, -m - 1, n)
                } else {
                    p(1, m - 1, n) - p(-1, -m + 1, n)
                };
                value += w * big_w;
            }
            out[(m + li) as usize * width + (n + li) as usize] = value;
        }
    }
}
