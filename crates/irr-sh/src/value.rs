//! What a coefficient may be: a scalar or a colour.

use glam::{DVec3, Vec3};

/// A value that can be projected, reconstructed and rotated: a vector space over the reals.
/// Implemented for `f32`, `f64`, `Vec3` (RGB) and `DVec3`.
///
/// The basis values and rotation entries are f64; an f32 value takes each product's scale
/// rounded to f32 once.
pub trait Coefficient: Copy {
    /// The zero value.
    const ZERO: Self;

    /// `self + value · scale`.
    fn add_scaled(self, value: Self, scale: f64) -> Self;
}

impl Coefficient for f32 {
    const ZERO: Self = 0.0;

    #[inline]
    fn add_scaled(self, value: Self, scale: f64) -> Self {
        self + value * scale as f32
    }
}

impl Coefficient for f64 {
    const ZERO: Self = 0.0;

    #[inline]
    fn add_scaled(self, value: Self, scale: f64) -> Self {
        self + value * scale
    }
}

impl Coefficient for Vec3 {
    const ZERO: Self = Vec3::ZERO;

    #[inline]
    fn add_scaled(self, value: Self, scale: f64) -> Self {
        self + value * scale as f32
    }
}

impl Coefficient for DVec3 {
    const ZERO: Self = DVec3::ZERO;

    #[inline]
    fn add_scaled(self, value: Self, scale: f64) -> Self {
        self + value * scale
    }
}
