//! Exact rotation of real SH coefficients through z-y-z Euler angles, the rotation about y
//! written as turns about z between two fixed quarter turns about x:
//!
//! R_z(α) R_y(β) R_z(γ) = R_z(α) · R_x(−π/2) R_z(β) R_x(π/2) · R_z(γ),
//!
//! (R_x(−π/2) maps z to y, so conjugating a turn about z by it turns about y). Rotations of SH
//! coefficients compose as the rotations do, so the coefficients turn by three cheap turns
//! about z (each pair (c^m, c^{−m}) by mθ) and two dense blocks per band, the quarter turns',
//! which are the same for every rotation and are built once ([`crate::ShRotation`]'s
//! recurrence). Nothing is built per rotation but 3n sines and cosines, where
//! [`crate::ShRotation::new`] runs its recurrence over Σ(2l+1)² entries in f64: the cost a
//! radiance cache pays for each record read at a differently oriented point.

use crate::MAX_ORDER;
use crate::error::{ShError, check_len, check_order};
use crate::fast::{ZyzAngles, rotate_z};
use crate::rotation::{ShRotation, block_offset};
use crate::value::Coefficient;
use glam::{DMat3, Mat3};
use std::sync::OnceLock;

/// The quarter turns about x, +π/2 and −π/2, at the highest order (a band's block does not
/// depend on the order).
fn quarter_turns() -> &'static (Vec<f64>, Vec<f64>) {
    static TURNS: OnceLock<(Vec<f64>, Vec<f64>)> = OnceLock::new();
    TURNS.get_or_init(|| {
        let blocks = |angle: f64| {
            ShRotation::from_dmat3(MAX_ORDER, DMat3::from_rotation_x(angle))
                .map(|r| {
                    (0..MAX_ORDER)
                        .flat_map(|l| r.block(l).unwrap_or(&[]).to_vec())
                        .collect()
                })
                .unwrap_or_default()
        };
        (
            blocks(std::f64::consts::FRAC_PI_2),
            blocks(-std::f64::consts::FRAC_PI_2),
        )
    })
}

/// The exact rotation of order-n SH coefficients by R_z(α) R_y(β) R_z(γ) (module docs): the
/// same map as [`ShRotation`], coefficients of f to those of f∘Rᵀ. Holds no heap memory.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZyzRotation {
    order: usize,
    /// (cos mθ, sin mθ) for m < n, for θ = α, β and γ.
    alpha: [(f64, f64); MAX_ORDER],
    beta: [(f64, f64); MAX_ORDER],
    gamma: [(f64, f64); MAX_ORDER],
}

impl ZyzRotation {
    /// The rotation of order-n SH coefficients by `rotation` (checked and made orthonormal as
    /// [`ShRotation`] does).
    pub fn new(order: usize, rotation: Mat3) -> Result<Self, ShError> {
        Self::from_angles(order, ZyzAngles::from_rotation(rotation)?)
    }

    /// The rotation by R_z(α) R_y(β) R_z(γ). Errors if an angle is not finite.
    pub fn from_angles(order: usize, angles: ZyzAngles) -> Result<Self, ShError> {
        let order = check_order(order)?;
        if !(angles.alpha.is_finite() && angles.beta.is_finite() && angles.gamma.is_finite()) {
            return Err(ShError::NotARotation);
        }
        let trig = |theta: f64| {
            let mut t = [(1.0, 0.0); MAX_ORDER];
            for (m, e) in t.iter_mut().enumerate().take(order).skip(1) {
                let (s, c) = (m as f64 * theta).sin_cos();
                *e = (c, s);
            }
            t
        };
        Ok(Self {
            order,
            alpha: trig(angles.alpha),
            beta: trig(angles.beta),
            gamma: trig(angles.gamma),
        })
    }

    /// The order n.
    pub fn order(&self) -> usize {
        self.order
    }

    /// `output` = the rotated `input` (both n² coefficients).
    pub fn apply<V: Coefficient>(&self, input: &[V], output: &mut [V]) -> Result<(), ShError> {
        let count = self.order * self.order;
        check_len(count, input.len())?;
        check_len(count, output.len())?;
        let (plus, minus) = quarter_turns();
        if plus.len() < block_offset(self.order) || minus.len() < block_offset(self.order) {
            return Err(ShError::NotARotation);
        }
        // One band's worth of scratch, on the stack; each band overwrites the first 2l+1.
        let mut a = [V::ZERO; 2 * MAX_ORDER - 1];
        let mut b = a;
        for l in 0..self.order {
            let band = l * l..(l + 1) * (l + 1);
            let width = 2 * l + 1;
            let blocks = block_offset(l)..block_offset(l + 1);
            rotate_z(&input[band.clone()], &self.gamma, &mut a[..width]);
            dense(&plus[blocks.clone()], &a[..width], &mut b[..width]);
            rotate_z(&b[..width], &self.beta, &mut a[..width]);
            dense(&minus[blocks], &a[..width], &mut b[..width]);
            rotate_z(&b[..width], &self.alpha, &mut output[band]);
        }
        Ok(())
    }
}

/// `output` = `block` (row-major, `input.len()` square) times `input`.
fn dense<V: Coefficient>(block: &[f64], input: &[V], output: &mut [V]) {
    for (row, out) in block.chunks_exact(input.len()).zip(output.iter_mut()) {
        *out = row
            .iter()
            .zip(input)
            .fold(V::ZERO, |sum, (&r, &c)| sum.add_scaled(c, r));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// The same map as the recurrence's matrix for rotations over all of SO(3) (angles on a
    /// grid, including β = 0 and π), at every order: the two differ by f64 rounding of
    /// O(n) products per entry plus f32 rounding of the inputs (coefficients ≤ 1: 1e-5).
    #[test]
    fn matches_the_recurrence() {
        for order in 1..=MAX_ORDER {
            let input: Vec<Vec3> = (0..order * order)
                .map(|k| Vec3::new(1.0 / (1 + k) as f32, ((k * 7) % 5) as f32 / 5.0 - 0.4, 0.3))
                .collect();
            for (alpha, beta, gamma) in [
                (0.0, 0.0, 0.0),
                (0.3, 0.0, -1.1),
                (1.0, 0.5, 2.0),
                (-2.5, 1.2, 0.7),
                (0.1, std::f64::consts::PI, 0.4),
                (3.0, 2.9, -3.0),
            ] {
                let angles = ZyzAngles { alpha, beta, gamma };
                let exact = ShRotation::from_dmat3(order, angles.to_dmat3())
                    .unwrap_or_else(|e| panic!("{e}"))
                    .rotate(&input)
                    .unwrap_or_else(|e| panic!("{e}"));
                let mut got = vec![Vec3::ZERO; input.len()];
                ZyzRotation::from_angles(order, angles)
                    .unwrap_or_else(|e| panic!("{e}"))
                    .apply(&input, &mut got)
                    .unwrap_or_else(|e| panic!("{e}"));
                for (k, (g, e)) in got.iter().zip(&exact).enumerate() {
                    assert!(
                        (*g - *e).abs().max_element() < 1e-5,
                        "order {order}, angles {angles:?}, coefficient {k}: {g} vs {e}"
                    );
                }
            }
        }
    }

    /// Errors as the recurrence's: lengths, orders and matrices that are not rotations.
    #[test]
    fn bad_input_is_refused() {
        assert!(ZyzRotation::new(0, Mat3::IDENTITY).is_err());
        assert!(ZyzRotation::new(MAX_ORDER + 1, Mat3::IDENTITY).is_err());
        assert!(ZyzRotation::new(3, Mat3::from_diagonal(Vec3::new(1.0, 1.0, -1.0))).is_err());
        let r = ZyzRotation::new(3, Mat3::IDENTITY).unwrap_or_else(|e| panic!("{e}"));
        let mut out = vec![0.0f32; 9];
        assert!(r.apply(&[0.0f32; 4], &mut out).is_err());
    }
}
