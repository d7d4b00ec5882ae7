//! The values a cache stores: a small vector space over `f32` channels.
//!
//! A record stores a value E and its two gradients as `[V; 3]` (the derivative along x, y and z),
//! so the cache only needs a vector space: zero, addition, scaling, and access to the channels.
//! Implemented here for [`Rgb`] irradiance, for a scalar `f32` (ambient occlusion) and for
//! `[f32; N]` (a vector of coefficients, e.g. spherical harmonics for radiance caching).

use glam::Vec3;
use std::fmt::Debug;

/// A value the cache can store and interpolate: a vector space over `f32` channels.
///
/// Interpolation accumulates weighted sums in `f64` ([`CacheValue::Wide`]) and rounds to `f32`
/// once at the end, which is what makes the rounding bounds of the interpolation tight (see
/// `IrradianceCache::interpolate`).
pub trait CacheValue: Copy + Debug + PartialEq + Send + Sync + 'static {
    /// Number of `f32` channels.
    const CHANNELS: usize;
    /// Type tag written in cache files; together with [`CacheValue::CHANNELS`] it identifies the
    /// value type, so a file written for one type is refused by another.
    const TAG: u32;
    /// Whether the quantity is non-negative by nature (irradiance, occlusion). If so, a record with
    /// a negative channel is rejected at insertion, and each record's gradient-extrapolated value is
    /// clamped at zero per channel before it is weighted (as Mitsuba 0.6 does): a steep gradient
    /// must not extrapolate to negative light.
    const NON_NEGATIVE: bool;
    /// The same value with `f64` channels: the accumulator of weighted sums.
    type Wide: Copy + AsRef<[f64]> + AsMut<[f64]>;

    /// The channels, `CHANNELS` of them.
    fn channels(&self) -> &[f32];
    /// The value whose channel `i` is `f(i)`, for `i` in `0..CHANNELS`.
    fn from_fn(f: impl FnMut(usize) -> f32) -> Self;
    /// The zero accumulator.
    fn wide_zero() -> Self::Wide;

    /// The zero value.
    #[inline]
    fn zero() -> Self {
        Self::from_fn(|_| 0.0)
    }
    /// Channel-wise sum.
    #[inline]
    fn add(self, other: Self) -> Self {
        let (a, b) = (self.channels(), other.channels());
        Self::from_fn(|i| a[i] + b[i])
    }
    /// Every channel multiplied by `s`.
    #[inline]
    fn scale(self, s: f32) -> Self {
        let a = self.channels();
        Self::from_fn(|i| a[i] * s)
    }
}

/// Linear RGB irradiance (or any three non-negative channels).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(transparent)]
pub struct Rgb(pub [f32; 3]);

impl Rgb {
    /// The colour (r, g, b).
    #[inline]
    pub const fn new(r: f32, g: f32, b: f32) -> Self {
        Self([r, g, b])
    }
    /// The same value in every channel.
    #[inline]
    pub const fn splat(v: f32) -> Self {
        Self([v; 3])
    }
}

impl From<Vec3> for Rgb {
    #[inline]
    fn from(v: Vec3) -> Self {
        Self(v.to_array())
    }
}

impl From<Rgb> for Vec3 {
    #[inline]
    fn from(c: Rgb) -> Self {
        Vec3::from_array(c.0)
    }
}

impl CacheValue for Rgb {
    const CHANNELS: usize = 3;
    const TAG: u32 = 1;
    const NON_NEGATIVE: bool = true;
    type Wide = [f64; 3];

    #[inline]
    fn channels(&self) -> &[f32] {
        &self.0
    }
    #[inline]
    fn from_fn(f: impl FnMut(usize) -> f32) -> Self {
        Self(std::array::from_fn(f))
    }
    #[inline]
    fn wide_zero() -> [f64; 3] {
        [0.0; 3]
    }
}

/// A scalar: ambient occlusion (a visible fraction, non-negative).
impl CacheValue for f32 {
    const CHANNELS: usize = 1;
    const TAG: u32 = 2;
    const NON_NEGATIVE: bool = true;
    type Wide = [f64; 1];

    #[inline]
    fn channels(&self) -> &[f32] {
        std::slice::from_ref(self)
    }
    #[inline]
    fn from_fn(mut f: impl FnMut(usize) -> f32) -> Self {
        f(0)
    }
    #[inline]
    fn wide_zero() -> [f64; 1] {
        [0.0]
    }
}

/// A vector of N signed coefficients (e.g. spherical-harmonic coefficients of incoming radiance,
/// for radiance caching): no clamping, negative channels allowed.
impl<const N: usize> CacheValue for [f32; N] {
    const CHANNELS: usize = N;
    const TAG: u32 = 3;
    const NON_NEGATIVE: bool = false;
    type Wide = [f64; N];

    #[inline]
    fn channels(&self) -> &[f32] {
        self
    }
    #[inline]
    fn from_fn(f: impl FnMut(usize) -> f32) -> Self {
        std::array::from_fn(f)
    }
    #[inline]
    fn wide_zero() -> [f64; N] {
        [0.0; N]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vector_space_operations() {
        let a = Rgb::new(1.0, 2.0, 3.0);
        let b = Rgb::new(0.5, -1.0, 4.0);
        assert_eq!(a.add(b), Rgb::new(1.5, 1.0, 7.0));
        assert_eq!(a.scale(2.0), Rgb::new(2.0, 4.0, 6.0));
        assert_eq!(Rgb::zero(), Rgb::splat(0.0));
        assert_eq!(2.0f32.add(3.0).scale(0.5), 2.5);
        assert_eq!([1.0f32, -2.0].add([1.0, 1.0]), [2.0, -1.0]);
        assert_eq!(<[f32; 4]>::zero(), [0.0; 4]);
    }

    #[test]
    fn channels_match_the_declared_count() {
        assert_eq!(Rgb::splat(1.0).channels().len(), Rgb::CHANNELS);
        assert_eq!(1.0f32.channels().len(), f32::CHANNELS);
        assert_eq!([0.0f32; 9].channels().len(), <[f32; 9]>::CHANNELS);
        assert_eq!(Rgb::wide_zero().len(), Rgb::CHANNELS);
        assert_eq!(<[f32; 9]>::wide_zero().len(), 9);
    }

    #[test]
    fn rgb_converts_to_and_from_vec3() {
        let v = Vec3::new(0.25, 0.5, 0.75);
        assert_eq!(Vec3::from(Rgb::from(v)), v);
    }
}
