//! Křivánek et al.'s fast approximate rotation of SH coefficients (Křivánek, Konttinen,
//! Pattanaik, Bouatouch & Žára 2006, "Fast Approximation to Spherical Harmonic Rotation",
//! SCCG).
//!
//! The rotation is split into Euler angles, R = R_z(α) R_y(β) R_z(γ). A rotation about z by θ
//! is exact and cheap on real SH: it turns each pair (c_l^m, c_l^{−m}) by mθ,
//! (a, b) ↦ (a cos mθ − b sin mθ, a sin mθ + b cos mθ). The rotation about y by β is the
//! matrix exponential exp(β G) of its generator G (per band, real antisymmetric), and is
//! replaced by its Taylor polynomial, I + β G (first order) or I + β G + β² G²/2 (second
//! order). G is tridiagonal in |m|: with c_0 = √(l(l+1)/2) and c_m = √((l−m)(l+m+1))/2 for
//! m ≥ 1,
//!
//! - G_{m+1,m} = c_m and G_{m,m+1} = −c_m (cosine functions, m ≥ 0),
//! - G_{−(m+1),−m} = c_m and G_{−m,−(m+1)} = −c_m (sine functions, m ≥ 1),
//!
//! so the approximation costs O(n²) where the exact rotation costs O(n³). (These are the
//! angular-momentum ladder coefficients √(l(l+1) − m(m+1)), written for this crate's real basis
//! without the Condon–Shortley phase; the tests check them against the derivative of Ivanic &
//! Ruedenberg's recurrence and against finite differences of the exact rotation.)
//!
//! **Error.** The Z rotations are orthogonal and G is normal with eigenvalues i k, |k| ≤ l, so
//! the largest relative error over all coefficient vectors, ‖fast(c) − exact(c)‖/‖c‖, is
//! exactly max_{k < n} |p(iβk) − e^{iβk}| with p the Taylor polynomial:
//! [`FastRotation::error_norm`]. It is ≈ (β(n−1))²/2 to first order and ≈ (β(n−1))³/6 to
//! second. Measured against the exact rotation (the tests' power iteration agrees with the
//! closed form to 10⁻¹⁰):
//!
//! | β | n = 3, 1st | n = 3, 2nd | n = 5, 1st | n = 5, 2nd | n = 10, 1st | n = 10, 2nd |
//! |---|---|---|---|---|---|---|
//! | 1°  | 6.1e-4 | 7.1e-6 | 2.4e-3 | 5.7e-5 | 1.2e-2 | 6.5e-4 |
//! | 5°  | 1.5e-2 | 8.9e-4 | 6.1e-2 | 7.1e-3 | 3.0e-1 | 8.0e-2 |
//! | 10° | 6.1e-2 | 7.1e-3 | 2.4e-1 | 5.6e-2 | 1.2    | 6.2e-1 |
//! | 20° | 2.4e-1 | 5.6e-2 | 9.2e-1 | 4.4e-1 | 3.7    | 4.3    |
//!
//! A smooth function's coefficients fall off with l, so it loses far less than the worst case.
//! The clamped cosine max(cos θ, 0) at n = 5, turned by β about y (relative L² error of its
//! coefficients, first / second order): 2.5e-4 / 3.9e-6 at 1°, 6.3e-3 / 4.9e-4 at 5°,
//! 2.5e-2 / 3.9e-3 at 10°, 9.9e-2 / 3.0e-2 at 20°.
//!
//! The approximation suits the small rotations between nearby records' frames in radiance
//! caching. It is not an isometry, and once β(n−1) nears 1 radian its error is of the order of
//! the signal (the second order is then no better than the first: 20° at n = 10).

use crate::MAX_ORDER;
use crate::error::{ShError, check_len, check_order};
use crate::rotation::orthonormalised;
use crate::value::Coefficient;
use glam::{DMat3, Mat3};
use std::sync::OnceLock;

/// How many terms of the Taylor expansion of the rotation about y to keep.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Taylor {
    /// I + β G.
    First,
    /// I + β G + β² G²/2.
    Second,
}

/// Euler angles of a rotation in the z-y-z convention: R = R_z(alpha) R_y(beta) R_z(gamma),
/// beta in [0, π].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZyzAngles {
    /// The last rotation about z, in radians.
    pub alpha: f64,
    /// The rotation about y, in [0, π].
    pub beta: f64,
    /// The first rotation about z, in radians.
    pub gamma: f64,
}

impl ZyzAngles {
    /// The angles of `rotation` (checked and made orthonormal as [`crate::ShRotation`] does).
    pub fn from_rotation(rotation: Mat3) -> Result<Self, ShError> {
        Self::from_dmat3(rotation.as_dmat3())
    }

    /// [`ZyzAngles::from_rotation`] with an f64 matrix.
    ///
    /// The third column of R_z(α) R_y(β) R_z(γ) is (cos α sin β, sin α sin β, cos β), which
    /// gives β and α. γ is then read from R_y(−β) R_z(−α) R = R_z(γ), so an α made inaccurate
    /// by a tiny sin β (near β = 0 or π) is compensated by γ, and the angles reproduce R to
    /// rounding at every β.
    pub fn from_dmat3(rotation: DMat3) -> Result<Self, ShError> {
        let r = orthonormalised(rotation)?;
        let axis = r.z_axis;
        let beta = axis.x.hypot(axis.y).atan2(axis.z);
        let alpha = axis.y.atan2(axis.x);
        let rest = DMat3::from_rotation_y(-beta) * DMat3::from_rotation_z(-alpha) * r;
        let gamma = rest.x_axis.y.atan2(rest.x_axis.x);
        Ok(Self { alpha, beta, gamma })
    }

    /// The rotation R_z(alpha) R_y(beta) R_z(gamma).
    pub fn to_dmat3(&self) -> DMat3 {
        DMat3::from_rotation_z(self.alpha)
            * DMat3::from_rotation_y(self.beta)
            * DMat3::from_rotation_z(self.gamma)
    }
}

/// The fast approximate rotation of order-n SH coefficients (module docs). Rotates as
/// [`crate::ShRotation`] does, coefficients of f to those of f∘Rᵀ, with the error
/// [`FastRotation::error_norm`]. Holds no heap memory.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FastRotation {
    order: usize,
    angles: ZyzAngles,
    taylor: Taylor,
    /// (cos mα, sin mα) and (cos mγ, sin mγ) for m < n.
    alpha: [(f64, f64); MAX_ORDER],
    gamma: [(f64, f64); MAX_ORDER],
}

impl FastRotation {
    /// The approximate rotation of order-n SH coefficients by `rotation`.
    pub fn new(order: usize, rotation: Mat3, taylor: Taylor) -> Result<Self, ShError> {
        Self::from_angles(order, ZyzAngles::from_rotation(rotation)?, taylor)
    }

    /// [`FastRotation::new`] with an f64 matrix.
    pub fn from_dmat3(order: usize, rotation: DMat3, taylor: Taylor) -> Result<Self, ShError> {
        Self::from_angles(order, ZyzAngles::from_dmat3(rotation)?, taylor)
    }

    /// The approximate rotation by R_z(α) R_y(β) R_z(γ). Errors if an angle is not finite.
    pub fn from_angles(order: usize, angles: ZyzAngles, taylor: Taylor) -> Result<Self, ShError> {
        let order = check_order(order)?;
        if !(angles.alpha.is_finite() && angles.beta.is_finite() && angles.gamma.is_finite()) {
            return Err(ShError::NotARotation);
        }
        let mut alpha = [(1.0, 0.0); MAX_ORDER];
        let mut gamma = [(1.0, 0.0); MAX_ORDER];
        for m in 1..order {
            let (s, c) = (m as f64 * angles.alpha).sin_cos();
            alpha[m] = (c, s);
            let (s, c) = (m as f64 * angles.gamma).sin_cos();
            gamma[m] = (c, s);
        }
        Ok(Self {
            order,
            angles,
            taylor,
            alpha,
            gamma,
        })
    }

    /// The order n.
    pub fn order(&self) -> usize {
        self.order
    }

    /// The Euler angles.
    pub fn angles(&self) -> ZyzAngles {
        self.angles
    }

    /// The Taylor order used.
    pub fn taylor(&self) -> Taylor {
        self.taylor
    }

    /// The largest relative error of this approximation against the exact rotation,
    /// max over c of ‖fast(c) − exact(c)‖/‖c‖ ([`FastRotation::error_norm_for`]).
    pub fn error_norm(&self) -> f64 {
        Self::error_norm_for(self.angles.beta, self.order, self.taylor)
    }

    /// The largest relative error of the approximation with angle β about y at order n:
    /// max_{k < n} |p(iβk) − e^{iβk}|, with p the Taylor polynomial (module docs). Exact, not a
    /// bound: it is the operator 2-norm of the difference.
    pub fn error_norm_for(beta: f64, order: usize, taylor: Taylor) -> f64 {
        let kept = match taylor {
            Taylor::First => 1,
            Taylor::Second => 2,
        };
        (0..order)
            .map(|k| taylor_remainder(beta * k as f64, kept))
            .fold(0.0, f64::max)
    }

    /// `output` = the approximately rotated `input` (both n² coefficients).
    pub fn apply<V: Coefficient>(&self, input: &[V], output: &mut [V]) -> Result<(), ShError> {
        let count = self.order * self.order;
        check_len(count, input.len())?;
        check_len(count, output.len())?;
        let beta = self.angles.beta;
        // One band's worth of scratch, on the stack; each band overwrites the first 2l+1.
        let mut v = [V::ZERO; 2 * MAX_ORDER - 1];
        let mut g = v;
        let mut w = v;
        let mut gg = v;
        for l in 0..self.order {
            let band = l * l..(l + 1) * (l + 1);
            let width = 2 * l + 1;
            rotate_z(&input[band.clone()], &self.gamma, &mut v[..width]);
            generator(l, &v[..width], &mut g[..width]);
            for i in 0..width {
                w[i] = v[i].add_scaled(g[i], beta);
            }
            if self.taylor == Taylor::Second {
                generator(l, &g[..width], &mut gg[..width]);
                for i in 0..width {
                    w[i] = w[i].add_scaled(gg[i], 0.5 * beta * beta);
                }
            }
            rotate_z(&w[..width], &self.alpha, &mut output[band]);
        }
        Ok(())
    }

    /// [`FastRotation::apply`] into a new vector.
    pub fn rotate<V: Coefficient>(&self, input: &[V]) -> Result<Vec<V>, ShError> {
        let mut output = vec![V::ZERO; self.order * self.order];
        self.apply(input, &mut output)?;
        Ok(output)
    }
}

/// One band (`input`, 2l+1 values, m = −l..l) turned about z: each pair (c^m, c^{−m}) by mθ,
/// with `trig[m]` = (cos mθ, sin mθ).
pub(crate) fn rotate_z<V: Coefficient>(input: &[V], trig: &[(f64, f64)], output: &mut [V]) {
    let l = input.len() / 2;
    output[l] = input[l];
    for m in 1..=l {
        let (a, b) = (input[l + m], input[l - m]);
        let (c, s) = trig[m];
        output[l + m] = V::ZERO.add_scaled(a, c).add_scaled(b, -s);
        output[l - m] = V::ZERO.add_scaled(a, s).add_scaled(b, c);
    }
}

/// c_m of band l (module docs): G's entries next to the diagonal.
fn ladder(l: usize, m: usize) -> f64 {
    static TABLE: OnceLock<[[f64; MAX_ORDER]; MAX_ORDER]> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = [[0.0; MAX_ORDER]; MAX_ORDER];
        for (l, row) in t.iter_mut().enumerate() {
            let lf = l as f64;
            row[0] = (lf * (lf + 1.0) / 2.0).sqrt();
            for (m, c) in row.iter_mut().enumerate().take(l + 1).skip(1) {
                let mf = m as f64;
                *c = ((lf - mf) * (lf + mf + 1.0)).sqrt() / 2.0;
            }
        }
        t
    })[l][m]
}

/// `output` = G `input` for one band l (2l+1 values, m = −l..l).
pub(crate) fn generator<V: Coefficient>(l: usize, input: &[V], output: &mut [V]) {
    // Cosine functions, m ≥ 0 (row l + m): G_{m,m−1} = c_{m−1}, G_{m,m+1} = −c_m.
    for m in 0..=l {
        let mut sum = V::ZERO;
        if m >= 1 {
            sum = sum.add_scaled(input[l + m - 1], ladder(l, m - 1));
        }
        if m < l {
            sum = sum.add_scaled(input[l + m + 1], -ladder(l, m));
        }
        output[l + m] = sum;
    }
    // Sine functions, m ≥ 1 (row l − m): G_{−m,−(m−1)} = c_{m−1} (none to m = 0),
    // G_{−m,−(m+1)} = −c_m.
    for m in 1..=l {
        let mut sum = V::ZERO;
        if m >= 2 {
            sum = sum.add_scaled(input[l - (m - 1)], ladder(l, m - 1));
        }
        if m < l {
            sum = sum.add_scaled(input[l - (m + 1)], -ladder(l, m));
        }
        output[l - m] = sum;
    }
}

/// |Σ_{k>p} (ix)^k/k!| = |e^{ix} − Σ_{k≤p} (ix)^k/k!|: the error of the p-term Taylor
/// polynomial of e^{ix}. For |x| ≤ 1 by the series itself (no cancellation; 25 more terms
/// leave a tail below 10⁻²⁵), beyond directly.
fn taylor_remainder(x: f64, kept: usize) -> f64 {
    if x.abs() <= 1.0 {
        let (mut re, mut im) = (0.0, 0.0);
        let mut term = 1.0;
        for k in 1..=kept + 25 {
            term *= x / k as f64;
            if k > kept {
                match k % 4 {
                    0 => re += term,
                    1 => im += term,
                    2 => re -= term,
                    _ => im -= term,
                }
            }
        }
        re.hypot(im)
    } else {
        let (s, c) = x.sin_cos();
        let polynomial_re = if kept >= 2 { 1.0 - x * x / 2.0 } else { 1.0 };
        (c - polynomial_re).hypot(s - x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Basis;
    use crate::rotation::{ShRotation, band_one, next_band};
    use crate::testutil::{
        Rng, any_rotation, hemisphere_rule, max_abs_difference, norm, spectral_norm,
    };
    use proptest::prelude::*;
    use std::f64::consts::PI;

    /// Band l of G as a dense (2l+1)² matrix, row-major, from `generator`.
    fn dense_generator(l: usize) -> Vec<f64> {
        let width = 2 * l + 1;
        let mut g = vec![0.0; width * width];
        for j in 0..width {
            let mut e = vec![0.0; width];
            e[j] = 1.0;
            let mut column = vec![0.0; width];
            generator(l, &e, &mut column);
            for i in 0..width {
                g[i * width + j] = column[i];
            }
        }
        g
    }

    fn identity(width: usize) -> Vec<f64> {
        (0..width * width)
            .map(|ij| if ij / width == ij % width { 1.0 } else { 0.0 })
            .collect()
    }

    #[test]
    fn generator_is_the_derivative_of_ivanic_ruedenbergs_recurrence() {
        // R^l(β) = F(R¹(β), R^{l−1}(β)) with F bilinear, so at β = 0 (every band the identity)
        // dR^l = F(dR¹, I) + F(I, dR^{l−1}); dR¹ is band 1 of dR_y/dβ = [[0,0,1],[0,0,0],[−1,0,0]].
        let dry = DMat3::from_cols(
            glam::DVec3::new(0.0, 0.0, -1.0),
            glam::DVec3::ZERO,
            glam::DVec3::new(1.0, 0.0, 0.0),
        );
        let d1 = band_one(dry);
        let i1 = identity(3);
        assert_eq!(d1.to_vec(), dense_generator(1));
        let mut previous = d1.to_vec();
        for l in 2..MAX_ORDER {
            let width = 2 * l + 1;
            let mut a = vec![0.0; width * width];
            let mut b = vec![0.0; width * width];
            next_band(&d1, &identity(2 * l - 1), l, &mut a);
            next_band(&i1, &previous, l, &mut b);
            let derivative: Vec<f64> = a.iter().zip(&b).map(|(x, y)| x + y).collect();
            // Entries up to √(l(l+1)/2) < l, each formed by a few products of exact entries
            // and square roots: 8 l ε absolute, growing by the previous band's error (which the
            // closed form does not share): 8 l² ε in all.
            let tolerance = 8.0 * (l * l) as f64 * f64::EPSILON;
            assert!(
                max_abs_difference(&derivative, &dense_generator(l)) <= tolerance,
                "band {l}"
            );
            previous = derivative;
        }
    }

    #[test]
    fn generator_matches_finite_differences_of_the_exact_rotation() {
        let n = 11;
        let h = 1e-4;
        let plus =
            ShRotation::from_dmat3(n, DMat3::from_rotation_y(h)).unwrap_or_else(|e| panic!("{e}"));
        let minus =
            ShRotation::from_dmat3(n, DMat3::from_rotation_y(-h)).unwrap_or_else(|e| panic!("{e}"));
        for l in 1..n {
            let difference: Vec<f64> = plus
                .block(l)
                .unwrap_or_else(|| panic!("a band below the order"))
                .iter()
                .zip(
                    minus
                        .block(l)
                        .unwrap_or_else(|| panic!("a band below the order")),
                )
                .map(|(a, b)| (a - b) / (2.0 * h))
                .collect();
            // The central difference of exp(βG) is off by ‖G³‖ h²/6 ≤ l³ h²/6; each exact
            // entry's rounding (≤ 16 l ε, rotation tests) is divided by h.
            let lf = l as f64;
            let tolerance = lf.powi(3) * h * h / 6.0 + 2.0 * 16.0 * lf * f64::EPSILON / h;
            assert!(
                max_abs_difference(&difference, &dense_generator(l)) <= tolerance,
                "band {l}"
            );
        }
    }

    /// Entries' error of the matrices rebuilt from angles: a few roundings of products of
    /// sines and cosines, plus the polar step's: 16 ε.
    const ANGLE_TOLERANCE: f64 = 16.0 * f64::EPSILON;

    proptest! {
        #[test]
        fn euler_angles_rebuild_the_rotation(r in any_rotation()) {
            let angles = ZyzAngles::from_dmat3(r).unwrap_or_else(|e| panic!("{e}"));
            prop_assert!((0.0..=PI).contains(&angles.beta));
            let rebuilt = angles.to_dmat3();
            let difference = max_abs_difference(&rebuilt.to_cols_array(), &r.to_cols_array());
            prop_assert!(difference <= ANGLE_TOLERANCE);
        }

        /// Without a rotation about y the Taylor polynomial is exact: the fast rotation is the
        /// exact one, to rounding.
        #[test]
        fn rotations_about_z_are_exact(angle in -10.0f64..10.0, seed in any::<u64>()) {
            let n = 9;
            let r = DMat3::from_rotation_z(angle);
            let c = Rng::new(seed).vector(n * n);
            let exact = ShRotation::from_dmat3(n, r)
                .and_then(|rotation| rotation.rotate(&c))
                .unwrap_or_else(|e| panic!("{e}"));
            for taylor in [Taylor::First, Taylor::Second] {
                let fast = FastRotation::from_dmat3(n, r, taylor).unwrap_or_else(|e| panic!("{e}"));
                prop_assert_eq!(fast.angles().beta, 0.0);
                let approximate = fast.rotate(&c).unwrap_or_else(|e| panic!("{e}"));
                // Two rotations of each pair by mθ (exact: by I&R's recurrence, entries within
                // 16 l ε; fast: cos and sin of mα, mγ, each ≤ l·2 ε from the angle's error):
                // 32 l ε per entry of a pair, on ‖c‖.
                let tolerance = 32.0 * (n - 1) as f64 * f64::EPSILON * norm(&c);
                prop_assert!(max_abs_difference(&exact, &approximate) <= tolerance);
            }
        }
    }

    #[test]
    fn euler_angles_at_the_poles() {
        for r in [
            DMat3::IDENTITY,
            DMat3::from_rotation_z(2.0),
            DMat3::from_rotation_y(PI),
            DMat3::from_rotation_x(PI),
            DMat3::from_rotation_z(0.4)
                * DMat3::from_rotation_y(1e-9)
                * DMat3::from_rotation_z(-1.3),
            DMat3::from_rotation_z(0.4)
                * DMat3::from_rotation_y(PI - 1e-9)
                * DMat3::from_rotation_z(1.0),
        ] {
            let rebuilt = ZyzAngles::from_dmat3(r)
                .unwrap_or_else(|e| panic!("{e}"))
                .to_dmat3();
            assert!(
                max_abs_difference(&rebuilt.to_cols_array(), &r.to_cols_array()) <= ANGLE_TOLERANCE,
                "{r}"
            );
        }
        assert_eq!(
            ZyzAngles::from_dmat3(DMat3::ZERO),
            Err(ShError::NotARotation)
        );
    }

    /// The dense matrix of band l of a rotation, column by column from `apply`.
    fn band_matrix(order: usize, l: usize, apply: impl Fn(&[f64]) -> Vec<f64>) -> Vec<f64> {
        let width = 2 * l + 1;
        let mut out = vec![0.0; width * width];
        for j in 0..width {
            let mut e = vec![0.0; order * order];
            e[l * l + j] = 1.0;
            let column = apply(&e);
            for i in 0..width {
                out[i * width + j] = column[l * l + i];
            }
        }
        out
    }

    /// max over bands of ‖fast − exact‖₂, measured by power iteration.
    fn measured_error(order: usize, r: DMat3, taylor: Taylor) -> f64 {
        let exact = ShRotation::from_dmat3(order, r).unwrap_or_else(|e| panic!("{e}"));
        let fast = FastRotation::from_dmat3(order, r, taylor).unwrap_or_else(|e| panic!("{e}"));
        (0..order)
            .map(|l| {
                let a = band_matrix(order, l, |c| {
                    exact.rotate(c).unwrap_or_else(|e| panic!("{e}"))
                });
                let b = band_matrix(order, l, |c| {
                    fast.rotate(c).unwrap_or_else(|e| panic!("{e}"))
                });
                let d: Vec<f64> = a.iter().zip(&b).map(|(x, y)| x - y).collect();
                spectral_norm(&d, 2 * l + 1)
            })
            .fold(0.0, f64::max)
    }

    /// The table in the module docs: (β in degrees, [n = 3, 5, 10] × [first, second]).
    const TABLE: [(f64, [&str; 6]); 4] = [
        (
            1.0,
            ["6.1e-4", "7.1e-6", "2.4e-3", "5.7e-5", "1.2e-2", "6.5e-4"],
        ),
        (
            5.0,
            ["1.5e-2", "8.9e-4", "6.1e-2", "7.1e-3", "3.0e-1", "8.0e-2"],
        ),
        (
            10.0,
            ["6.1e-2", "7.1e-3", "2.4e-1", "5.6e-2", "1.2e0", "6.2e-1"],
        ),
        (
            20.0,
            ["2.4e-1", "5.6e-2", "9.2e-1", "4.4e-1", "3.7e0", "4.3e0"],
        ),
    ];

    #[test]
    fn measured_error_is_the_closed_form_and_the_table() {
        let mut rng = Rng::new(7);
        let mut rows = Vec::new();
        for (degrees, row) in TABLE {
            let beta = degrees.to_radians();
            let mut printed = Vec::new();
            for n in [3, 5, 10] {
                for taylor in [Taylor::First, Taylor::Second] {
                    let (alpha, gamma) = (PI * rng.signed(), PI * rng.signed());
                    let r = ZyzAngles { alpha, beta, gamma }.to_dmat3();
                    let measured = measured_error(n, r, taylor);
                    let closed = FastRotation::error_norm_for(beta, n, taylor);
                    // Power iteration converges to the top singular value to ~1e-12 relative
                    // here (the ratio of the two largest is ≤ ((n−2)/(n−1))² for k = ±(n−1));
                    // the exact matrices' rounding adds ≤ 16 l ε · (2l+1).
                    assert!(
                        (measured - closed).abs()
                            <= 1e-10 * closed + 16.0 * 9.0 * 19.0 * f64::EPSILON,
                        "β={degrees}° n={n} {taylor:?}: measured {measured:e}, closed form {closed:e}"
                    );
                    printed.push(format!("{closed:.1e}"));
                }
            }
            println!("{degrees}°: {}", printed.join(" | "));
            rows.push((printed, row));
        }
        for (printed, row) in rows {
            assert_eq!(printed, row, "update the table in the module docs");
        }
    }

    /// The relative error on a smooth function, the clamped cosine max(cos θ, 0) in SH of
    /// order 5, whose coefficients fall off as l⁻²·⁵: far below the worst case. Pinned to the
    /// module docs' second table.
    #[test]
    fn a_smooth_function_loses_less_than_the_worst_case() {
        let n = 5;
        let basis = Basis::sh(n).unwrap_or_else(|e| panic!("{e}"));
        // Exact for z · Y_l^m on z ≥ 0 (basis tests).
        let c = crate::project(
            basis,
            hemisphere_rule(n, 2 * n - 1)
                .into_iter()
                .map(|(d, w)| (d, w, d.z)),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let mut printed = Vec::new();
        for degrees in [1.0f64, 5.0, 10.0, 20.0] {
            let r = DMat3::from_rotation_y(degrees.to_radians());
            let exact = ShRotation::from_dmat3(n, r)
                .unwrap_or_else(|e| panic!("{e}"))
                .rotate(&c)
                .unwrap_or_else(|e| panic!("{e}"));
            for taylor in [Taylor::First, Taylor::Second] {
                let fast = FastRotation::from_dmat3(n, r, taylor).unwrap_or_else(|e| panic!("{e}"));
                let approximate = fast.rotate(&c).unwrap_or_else(|e| panic!("{e}"));
                let difference: Vec<f64> =
                    exact.iter().zip(&approximate).map(|(a, b)| a - b).collect();
                let relative = norm(&difference) / norm(&c);
                assert!(relative < 0.5 * fast.error_norm(), "{degrees}° {taylor:?}");
                printed.push(format!("{relative:.1e}"));
            }
        }
        println!("clamped cosine, n = 5: {}", printed.join(" | "));
        assert_eq!(
            printed,
            [
                "2.5e-4", "3.9e-6", "6.3e-3", "4.9e-4", "2.5e-2", "3.9e-3", "9.9e-2", "3.0e-2"
            ],
            "update the module docs"
        );
    }

    #[test]
    fn bad_input_is_refused() {
        let r = DMat3::from_rotation_y(0.1);
        assert_eq!(
            FastRotation::from_dmat3(0, r, Taylor::First),
            Err(ShError::ZeroOrder)
        );
        assert_eq!(
            FastRotation::from_dmat3(MAX_ORDER + 1, r, Taylor::First),
            Err(ShError::OrderTooLarge {
                order: MAX_ORDER + 1
            })
        );
        assert_eq!(
            FastRotation::from_dmat3(4, r * 2.0, Taylor::First),
            Err(ShError::NotARotation)
        );
        let angles = ZyzAngles {
            alpha: 0.0,
            beta: f64::NAN,
            gamma: 0.0,
        };
        assert_eq!(
            FastRotation::from_angles(4, angles, Taylor::Second),
            Err(ShError::NotARotation)
        );
        let fast = FastRotation::new(4, Mat3::from_rotation_y(0.1), Taylor::Second)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            fast.rotate(&[0.0f32; 9]),
            Err(ShError::LengthMismatch {
                expected: 16,
                actual: 9
            })
        );
        let mut out = [0.0f64; 17];
        assert_eq!(
            fast.apply(&[0.0f64; 16], &mut out),
            Err(ShError::LengthMismatch {
                expected: 16,
                actual: 17
            })
        );
        // Order 1 is the constant: untouched.
        let one = FastRotation::from_dmat3(1, r, Taylor::First).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            one.rotate(&[3.0f64]).unwrap_or_else(|e| panic!("{e}")),
            vec![3.0]
        );
        assert_eq!(one.error_norm(), 0.0);
    }

    #[test]
    fn the_error_norm_grows_with_the_angle_and_the_order() {
        for taylor in [Taylor::First, Taylor::Second] {
            assert_eq!(FastRotation::error_norm_for(0.0, 10, taylor), 0.0);
            let mut previous = 0.0;
            for step in 1..=30 {
                let e = FastRotation::error_norm_for(0.01 * step as f64, 8, taylor);
                assert!(e > previous);
                previous = e;
            }
            assert!(
                FastRotation::error_norm_for(0.1, 9, taylor)
                    > FastRotation::error_norm_for(0.1, 8, taylor)
            );
        }
        // Small angles: (βl)²/2 and (βl)³/6 to leading order, with relative corrections of
        // order (βl)² ≈ 10⁻⁶ here.
        let (beta, l) = (1e-4, 9.0);
        let first = FastRotation::error_norm_for(beta, 10, Taylor::First);
        let second = FastRotation::error_norm_for(beta, 10, Taylor::Second);
        assert!((first / ((beta * l).powi(2) / 2.0) - 1.0).abs() < 1e-3);
        assert!((second / ((beta * l).powi(3) / 6.0) - 1.0).abs() < 1e-3);
    }
}
