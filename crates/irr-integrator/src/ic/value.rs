//! The values the integrator's caches hold, and their conversions between irr-gradients' and
//! irr-cache's value types.

use glam::Vec3;
use irr_cache::{CacheValue, Record, Rgb};
use irr_gradients::GatherValue;

/// A value the integrator's caches hold: irradiance ([`Rgb`], gathered as `Vec3`) or ambient
/// occlusion (`f32`). Converts between irr-gradients' and irr-cache's value types.
pub trait IcValue: CacheValue {
    /// The gather's per-cell value type.
    type Gathered: GatherValue + Send + Sync;
    /// Whether a record is read only where a surface's diffuse reflectance multiplies it
    /// (irradiance: a point that reflects no diffuse light, a metal or a black surface, never
    /// reads one), rather than wherever the camera looks (ambient occlusion).
    const READ_THROUGH_REFLECTANCE: bool;
    /// The cached value of a gathered one.
    fn from_gathered(g: Self::Gathered) -> Self;
    /// The gathered value of a cached one.
    fn to_gathered(self) -> Self::Gathered;
}

impl IcValue for Rgb {
    type Gathered = Vec3;
    const READ_THROUGH_REFLECTANCE: bool = true;
    #[inline]
    fn from_gathered(g: Vec3) -> Self {
        Rgb::from(g)
    }
    #[inline]
    fn to_gathered(self) -> Vec3 {
        Vec3::from_array(self.0)
    }
}

impl IcValue for f32 {
    type Gathered = f32;
    const READ_THROUGH_REFLECTANCE: bool = false;
    #[inline]
    fn from_gathered(g: f32) -> Self {
        g
    }
    #[inline]
    fn to_gathered(self) -> f32 {
        self
    }
}

/// A record of `Rgb` (how candidates travel) as a record of `V` (the first channel for a scalar).
pub(super) fn convert_record<V: IcValue>(r: &Record<Rgb>) -> Record<V> {
    let conv = |v: &Rgb| V::from_fn(|i| v.0[i.min(2)]);
    Record {
        position: r.position,
        normal: r.normal,
        radius: r.radius,
        unclamped_radius: r.unclamped_radius,
        min_radius: r.min_radius,
        aspect: r.aspect,
        tangent: r.tangent,
        value: conv(&r.value),
        translation_gradient: r.translation_gradient.each_ref().map(conv),
        rotation_gradient: r.rotation_gradient.each_ref().map(conv),
        curvature: r.curvature,
    }
}

/// A record of `V` as the `Rgb` record a candidate carries (a scalar in every channel).
pub(super) fn to_rgb_record<V: IcValue>(r: &Record<V>) -> Record<Rgb> {
    let conv = |v: &V| {
        let c = v.channels();
        Rgb::new(c[0], c[1.min(c.len() - 1)], c[2.min(c.len() - 1)])
    };
    Record {
        position: r.position,
        normal: r.normal,
        radius: r.radius,
        unclamped_radius: r.unclamped_radius,
        min_radius: r.min_radius,
        aspect: r.aspect,
        tangent: r.tangent,
        value: conv(&r.value),
        translation_gradient: r.translation_gradient.each_ref().map(conv),
        rotation_gradient: r.rotation_gradient.each_ref().map(conv),
        curvature: r.curvature,
    }
}
