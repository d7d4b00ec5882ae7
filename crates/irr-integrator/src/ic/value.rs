//! The values the integrator's caches hold: irr-gather-record's pairing of irr-gradients' and
//! irr-cache's value types, and what the integrator adds to it.

use irr_cache::{Record, Rgb};
use irr_gather_record::GatheredValue;

/// A value the integrator's caches hold: irradiance ([`Rgb`], gathered as `Vec3`) or ambient
/// occlusion (`f32`). Its conversions from and to the gather's value type are
/// irr-gather-record's [`GatheredValue`].
pub trait IcValue: GatheredValue {
    /// Whether a record is read only where a surface's diffuse reflectance multiplies it
    /// (irradiance: a point that reflects no diffuse light, a metal or a black surface, never
    /// reads one), rather than wherever the camera looks (ambient occlusion).
    const READ_THROUGH_REFLECTANCE: bool;
}

impl IcValue for Rgb {
    const READ_THROUGH_REFLECTANCE: bool = true;
}

impl IcValue for f32 {
    const READ_THROUGH_REFLECTANCE: bool = false;
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
