//! The value a gather carries per cell (radiance in, irradiance and gradients out): a small trait
//! of this crate's own, so that irr-gradients needs nothing from irr-cache.
//!
//! The estimators only add, subtract and scale values; the checks on the input (finiteness) and
//! the gradient-based radius limit (one bound per channel) also read the channels one by one.

use glam::{Vec3, Vec3A, Vec4};
use std::ops::{Add, Mul, Sub};

/// A radiance or irradiance value: a scalar, RGB, or any fixed set of `f32` channels.
///
/// Implemented for `f32` (one channel), `glam::Vec3` and `Vec3A` (RGB) and `glam::Vec4`. Another
/// spectral type needs only the arithmetic and channel access below; `Default` must be zero.
pub trait GatherValue:
    Copy + Default + Add<Output = Self> + Sub<Output = Self> + Mul<f32, Output = Self>
{
    /// How many channels a value has.
    const CHANNELS: usize;

    /// Channel `i` (`i < CHANNELS`).
    fn channel(self, i: usize) -> f32;

    /// The channel-wise product (for a cell's sum of squared deviations).
    fn hadamard(self, other: Self) -> Self;

    /// Whether every channel is finite (no NaN, no infinity).
    #[inline]
    fn is_finite(self) -> bool {
        (0..Self::CHANNELS).all(|i| self.channel(i).is_finite())
    }
}

impl GatherValue for f32 {
    const CHANNELS: usize = 1;

    #[inline]
    fn channel(self, _i: usize) -> f32 {
        self
    }

    #[inline]
    fn hadamard(self, other: Self) -> Self {
        self * other
    }
}

impl GatherValue for Vec3 {
    const CHANNELS: usize = 3;

    #[inline]
    fn channel(self, i: usize) -> f32 {
        self[i]
    }

    #[inline]
    fn hadamard(self, other: Self) -> Self {
        self * other
    }
}

impl GatherValue for Vec3A {
    const CHANNELS: usize = 3;

    #[inline]
    fn channel(self, i: usize) -> f32 {
        self[i]
    }

    #[inline]
    fn hadamard(self, other: Self) -> Self {
        self * other
    }
}

impl GatherValue for Vec4 {
    const CHANNELS: usize = 4;

    #[inline]
    fn channel(self, i: usize) -> f32 {
        self[i]
    }

    #[inline]
    fn hadamard(self, other: Self) -> Self {
        self * other
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channels_read_back() {
        assert_eq!(2.5f32.channel(0), 2.5);
        let v = Vec3::new(1.0, 2.0, 3.0);
        assert_eq!(
            (0..3).map(|i| v.channel(i)).collect::<Vec<_>>(),
            [1.0, 2.0, 3.0]
        );
        let w = Vec4::new(1.0, 2.0, 3.0, 4.0);
        assert_eq!(w.channel(3), 4.0);
        assert!(Vec3A::new(1.0, 2.0, 3.0).is_finite());
        assert!(!Vec3::new(1.0, f32::NAN, 3.0).is_finite());
        assert!(!f32::INFINITY.is_finite());
        assert_eq!(f32::default(), 0.0);
    }
}
