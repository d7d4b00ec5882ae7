//! Exact rotation of real spherical-harmonic coefficients: Ivanic & Ruedenberg's recurrence.
//!
//! A rotation R maps the coefficients of f to those of f∘Rᵀ, the function turned by R (a lobe
//! along d ends up along R d). Rotations do not mix bands, so the matrix is block-diagonal: one
//! (2l+1)×(2l+1) orthogonal block per band. Band 0 is 1. Band 1, in the (y, z, x) order of
//! Y_1^{−1}, Y_1^0, Y_1^1, is R itself with rows and columns permuted: entry (m, m') is
//! R_{p(m), p(m')} with p = (y, z, x). Band l ≥ 2 follows from band 1 and band l − 1 (Ivanic &
//! Ruedenberg 1996, "Rotation Matrices for Real Spherical Harmonics. Direct Determination by
//! Recursion", J. Phys. Chem. 100(15), their tables of u, v, w and of U, V, W, with the
//! corrections of their 1998 erratum in J. Phys. Chem. A 102):
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
//! The recurrence is bilinear in (R¹, R^{l−1}): the fast rotation's tests differentiate it
//! that way to check [`crate::fast`]'s generator. Computed in f64; building all bands up to order n costs Σ(2l+1)² entries of a
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{
        Rng, any_direction, any_rotation, gram_tolerance, max_abs_difference, norm, rotation_from,
        sphere_rule, value_error,
    };
    use crate::{Basis, MAX_ORDER};
    use glam::{DQuat, DVec3, Quat, Vec3};
    use proptest::prelude::*;

    /// The error of band l's entries, in ε: 16 l. Each step of the recurrence forms an entry
    /// from a few products of band l − 1's entries with band 1's; their errors carry over with
    /// weights |u|, |v|, |w| ≤ 1. Measured over 200 random rotations, max |(MᵀM − I)ᵢⱼ| grows as
    /// 2 l ε up to l ≈ 22, then by ≈ 1.2 per band to 214 ε at l = 31: 16 l ε (496 ε at l = 31)
    /// keeps a margin of 2.3 at the cap.
    fn entry_error(l: usize) -> f64 {
        16.0 * l as f64 * f64::EPSILON
    }

    #[test]
    fn the_identity_rotates_nothing() {
        let rotation =
            ShRotation::from_dmat3(MAX_ORDER, DMat3::IDENTITY).unwrap_or_else(|e| panic!("{e}"));
        for l in 0..MAX_ORDER {
            let block = rotation
                .block(l)
                .unwrap_or_else(|| panic!("a band below the order"));
            let width = 2 * l + 1;
            for i in 0..width {
                for j in 0..width {
                    let want = if i == j { 1.0 } else { 0.0 };
                    // With R¹ = I every product in the recurrence is exact (0 or 1 times an
                    // entry); only u, v, w are rounded square roots: one ε per term.
                    assert!(
                        (block[i * width + j] - want).abs() <= 4.0 * f64::EPSILON,
                        "l={l} ({i}, {j})"
                    );
                }
            }
        }
        assert_eq!(rotation.block(MAX_ORDER), None);
    }

    #[test]
    fn band_one_is_the_permuted_rotation() {
        let r = DMat3::from_quat(DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 2.0) / 3.0, 0.7));
        let rotation = ShRotation::from_dmat3(2, r).unwrap_or_else(|e| panic!("{e}"));
        let b = rotation
            .block(1)
            .unwrap_or_else(|| panic!("a band below the order"));
        // Rows and columns in the order y, z, x (Ivanic & Ruedenberg 1996: R¹ in terms of R).
        let rr = rotation.rotation();
        let want = [
            rr.y_axis.y,
            rr.z_axis.y,
            rr.x_axis.y,
            rr.y_axis.z,
            rr.z_axis.z,
            rr.x_axis.z,
            rr.y_axis.x,
            rr.z_axis.x,
            rr.x_axis.x,
        ];
        assert_eq!(b, want);
        // The polar iteration leaves an orthonormal input unchanged to rounding.
        assert!(max_abs_difference(&rr.to_cols_array(), &r.to_cols_array()) <= 4.0 * f64::EPSILON);
    }

    proptest! {
        /// Each block is orthogonal, so the coefficient vector's norm is kept.
        #[test]
        fn rotations_are_isometries(r in any_rotation(), seed in any::<u64>()) {
            let rotation = ShRotation::from_dmat3(MAX_ORDER, r).unwrap_or_else(|e| panic!("{e}"));
            let c = Rng::new(seed).vector(MAX_ORDER * MAX_ORDER);
            let rotated = rotation.rotate(&c).unwrap_or_else(|e| panic!("{e}"));
            // ‖Mc‖² − ‖c‖² = cᵀ(MᵀM − I)c ≤ ‖MᵀM − I‖₂ ‖c‖², and ‖MᵀM − I‖₂ ≤ (2l+1) times
            // its largest entry, ≤ 2 entry_error(l) (2l+1) at the top band; the two norms' own
            // rounding adds ≤ n² ε each.
            let l = MAX_ORDER - 1;
            let tolerance = (2.0 * entry_error(l) * (2 * l + 1) as f64
                + 2.0 * (MAX_ORDER * MAX_ORDER) as f64 * f64::EPSILON) * norm(&c);
            prop_assert!((norm(&rotated) - norm(&c)).abs() <= tolerance);
            for l in 0..MAX_ORDER {
                let band = l * l..(l + 1) * (l + 1);
                let (a, b) = (norm(&rotated[band.clone()]), norm(&c[band]));
                let tolerance = 2.0 * entry_error(l) * (2 * l + 1) as f64 * b;
                prop_assert!((a - b).abs() <= tolerance);
            }
        }

        /// The rotated reproducing kernel: M(R) Y(ω) = Y(Rω), every band up to the cap.
        #[test]
        fn rotating_the_basis_values_moves_the_direction(
            r in any_rotation(),
            d in any_direction(),
        ) {
            let basis = Basis::sh(MAX_ORDER).unwrap_or_else(|e| panic!("{e}"));
            let rotation = ShRotation::from_dmat3(MAX_ORDER, r).unwrap_or_else(|e| panic!("{e}"));
            let mut y = vec![0.0; MAX_ORDER * MAX_ORDER];
            let mut moved = y.clone();
            basis.eval_f64(d, &mut y).unwrap_or_else(|e| panic!("{e}"));
            basis.eval_f64(rotation.rotation() * d, &mut moved).unwrap_or_else(|e| panic!("{e}"));
            let rotated = rotation.rotate(&y).unwrap_or_else(|e| panic!("{e}"));
            for l in 0..MAX_ORDER {
                let width = (2 * l + 1) as f64;
                let bound = (width / (4.0 * std::f64::consts::PI)).sqrt();
                // Y(Rω)'s values are within value_error(l) ε · bound; M Y(ω) carries Y(ω)'s
                // errors (norm ≤ √(2l+1) value_error(l) ε bound) through an orthogonal block,
                // plus the block's own error times ‖Y_l‖ = bound: ≤ (2l+1) entry_error(l) bound.
                let tolerance = (value_error(l) * (1.0 + width.sqrt()) * f64::EPSILON
                    + width * entry_error(l)) * bound;
                for i in l * l..(l + 1) * (l + 1) {
                    prop_assert!((rotated[i] - moved[i]).abs() <= tolerance, "l={} i={}", l, i);
                }
            }
        }

        /// M(A) M(B) = M(AB).
        #[test]
        fn rotations_compose(a in any_rotation(), b in any_rotation(), seed in any::<u64>()) {
            let n = 12;
            let c = Rng::new(seed).vector(n * n);
            let ra = ShRotation::from_dmat3(n, a).unwrap_or_else(|e| panic!("{e}"));
            let rb = ShRotation::from_dmat3(n, b).unwrap_or_else(|e| panic!("{e}"));
            let rab = ShRotation::from_dmat3(n, a * b).unwrap_or_else(|e| panic!("{e}"));
            let twice = rb
                .rotate(&c)
                .and_then(|once_b| ra.rotate(&once_b))
                .unwrap_or_else(|e| panic!("{e}"));
            let once = rab.rotate(&c).unwrap_or_else(|e| panic!("{e}"));
            // Three matrices, each within (2l+1) entry_error(l) in norm of an orthogonal one;
            // the product AB is off by ≤ 3ε per entry, which moves band l by ≤ 3 l ε · 3 (the
            // band's generators have norm l).
            let l = n - 1;
            let tolerance = (3.0 * (2 * l + 1) as f64 * entry_error(l)
                + 9.0 * l as f64 * f64::EPSILON)
                * norm(&c);
            let difference: Vec<f64> = twice.iter().zip(&once).map(|(x, y)| x - y).collect();
            prop_assert!(norm(&difference) <= tolerance);
        }

        /// Rotating the coefficients equals projecting the rotated function f∘Rᵀ.
        #[test]
        fn rotating_equals_projecting_the_rotated_function(
            r in any_rotation(),
            seed in any::<u64>(),
        ) {
            let n = 6;
            let basis = Basis::sh(n).unwrap_or_else(|e| panic!("{e}"));
            let c = Rng::new(seed).vector(n * n);
            let rotation = ShRotation::from_dmat3(n, r).unwrap_or_else(|e| panic!("{e}"));
            let rt = rotation.rotation().transpose();
            // f∘Rᵀ is band-limited to the same order, so the rule exact for the Gram matrix
            // (n nodes, 2n − 1 angles) projects it exactly.
            let rule = sphere_rule(n, 2 * n - 1);
            let projected = crate::project(
                basis,
                rule.iter().map(|&(d, w)| {
                    (d, w, basis.reconstruct(&c, rt * d).unwrap_or_else(|e| panic!("{e}")))
                }),
            )
            .unwrap_or_else(|e| panic!("{e}"));
            let rotated = rotation.rotate(&c).unwrap_or_else(|e| panic!("{e}"));
            // The projection's bound (project tests: ‖c‖₁ (gram + (n² + value_error) √(2n−1)
            // ε)) plus the rotation's ((2l+1) entry_error(l) ‖c‖).
            let l1: f64 = c.iter().map(|x| x.abs()).sum();
            let l = n - 1;
            let tolerance = l1 * (gram_tolerance(rule.len(), n)
                + ((n * n) as f64 + value_error(l)) * ((2 * n - 1) as f64).sqrt() * f64::EPSILON)
                + (2 * l + 1) as f64 * entry_error(l) * norm(&c);
            prop_assert!(max_abs_difference(&projected, &rotated) <= tolerance);
        }
    }

    #[test]
    fn f32_rotations_are_accepted_and_rotate_rgb() {
        let q = Quat::from_axis_angle(Vec3::new(0.0, 0.6, 0.8), 1.1);
        let rotation = ShRotation::new(5, Mat3::from_quat(q)).unwrap_or_else(|e| panic!("{e}"));
        let c: Vec<Vec3> = (0..25)
            .map(|i| Vec3::new(i as f32, 1.0, -0.5 * i as f32))
            .collect();
        let rotated = rotation.rotate(&c).unwrap_or_else(|e| panic!("{e}"));
        let red = rotation
            .rotate(&c.iter().map(|v| v.x).collect::<Vec<_>>())
            .unwrap_or_else(|e| panic!("{e}"));
        for (v, r) in rotated.iter().zip(&red) {
            // The same f32 operations channel by channel.
            assert_eq!(v.x, *r);
        }
    }

    #[test]
    fn matrices_that_are_not_rotations_are_refused() {
        let r = rotation_from([0.1, 0.2, 0.3, 0.9])
            .unwrap_or_else(|| panic!("a quaternion far from 0"));
        for bad in [
            r * 1.01,
            r * DMat3::from_diagonal(DVec3::new(1.0, 1.0, -1.0)),
            DMat3::ZERO,
            DMat3::from_cols(DVec3::X, DVec3::Y, DVec3::new(0.0, 0.0, f64::NAN)),
            DMat3::from_cols(DVec3::X, DVec3::Y, DVec3::new(0.0, 0.0, f64::INFINITY)),
            // 10⁻³ off orthonormal: beyond the tolerance.
            r + DMat3::from_cols(DVec3::new(1e-3, 0.0, 0.0), DVec3::ZERO, DVec3::ZERO),
        ] {
            assert_eq!(ShRotation::from_dmat3(4, bad), Err(ShError::NotARotation));
        }
        // 10⁻⁶ off is accepted, and made orthonormal.
        let near = r + DMat3::from_cols(DVec3::new(1e-6, 0.0, 0.0), DVec3::ZERO, DVec3::ZERO);
        let rotation = ShRotation::from_dmat3(4, near).unwrap_or_else(|e| panic!("{e}"));
        let m = rotation.rotation();
        let gram = (m.transpose() * m - DMat3::IDENTITY).to_cols_array();
        assert!(gram.iter().all(|x| x.abs() <= 4.0 * f64::EPSILON));
        // A failed `set` keeps the previous rotation.
        let mut kept = rotation.clone();
        assert_eq!(kept.set_dmat3(DMat3::ZERO), Err(ShError::NotARotation));
        assert_eq!(kept, rotation);
        assert_eq!(ShRotation::from_dmat3(0, r), Err(ShError::ZeroOrder));
        assert_eq!(
            ShRotation::from_dmat3(33, r),
            Err(ShError::OrderTooLarge { order: 33 })
        );
        assert_eq!(
            rotation.rotate(&[0.0f32; 9]),
            Err(ShError::LengthMismatch {
                expected: 16,
                actual: 9
            })
        );
        let mut out = [0.0f32; 15];
        assert_eq!(
            rotation.apply(&[0.0f32; 16], &mut out),
            Err(ShError::LengthMismatch {
                expected: 16,
                actual: 15
            })
        );
    }

    #[test]
    fn set_matches_a_fresh_rotation() {
        let a = rotation_from([0.3, -0.2, 0.5, 0.4])
            .unwrap_or_else(|| panic!("a quaternion far from 0"));
        let b = rotation_from([-0.7, 0.1, 0.2, 0.6])
            .unwrap_or_else(|| panic!("a quaternion far from 0"));
        let mut rotation = ShRotation::from_dmat3(7, a).unwrap_or_else(|e| panic!("{e}"));
        rotation.set_dmat3(b).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            rotation,
            ShRotation::from_dmat3(7, b).unwrap_or_else(|e| panic!("{e}"))
        );
        let order_one = ShRotation::from_dmat3(1, b).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            order_one
                .rotate(&[2.5f64])
                .unwrap_or_else(|e| panic!("{e}")),
            vec![2.5]
        );
    }

    #[test]
    fn block_offsets_partition_the_storage() {
        let mut offset = 0;
        for l in 0..=MAX_ORDER {
            assert_eq!(block_offset(l), offset);
            offset += (2 * l + 1) * (2 * l + 1);
        }
    }
}
