//! Křivánek et al.'s fast approximate rotation of SH coefficients (Křivánek, Konttinen,
//! Pattanaik, Bouatouch & Žára 2006, "Fast Approximation to Spherical Harmonic Rotation",
//! SCCG, §3–4).
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
//! closed form to 10⁻¹²):
//!
//! (table: to be measured)
//!
//! A smooth function's coefficients fall off with l, so its error is smaller than the worst
//! case (see the tests). The approximation is for the small rotations between nearby records'
//! frames in radiance caching (Křivánek et al. 2005 keep them within ~10°); it is not an
//! isometry, and beyond β ≈ 1/n it is no longer useful.

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
        for l in 0..self.order {
            let band = l * l..(l + 1) * (l + 1);
            let width = 2 * l + 1;
            let mut v = [V::ZERO; 2 * MAX_ORDER - 1];
            rotate_z(&input[band.clone()], &self.gamma, &mut v[..width]);
            let mut g = [V::ZERO; 2 * MAX_ORDER - 1];
            generator(l, &v[..width], &mut g[..width]);
            let mut w = [V::ZERO; 2 * MAX_ORDER - 1];
            for i in 0..width {
                w[i] = v[i].add_scaled(g[i], beta);
            }
            if self.taylor == Taylor::Second {
                let mut gg = [V::ZERO; 2 * MAX_ORDER - 1];
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
fn rotate_z<V: Coefficient>(input: &[V], trig: &[(f64, f64)], output: &mut [V]) {
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
