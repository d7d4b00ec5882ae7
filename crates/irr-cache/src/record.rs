//! Cache records and the checks a record passes before it enters a cache.

use crate::value::CacheValue;
use glam::{DVec3, Vec3};
use thiserror::Error;

/// One cached value: where it was computed, how far it may be reused, and its gradients.
///
/// Stored as plain `f32` data (`Vec3` is three `f32`, no padding): an RGB record,
/// `Record<Rgb>`, takes 4 · (3 + 3 + 1 + 2 + 1 + 3 + 3 + 9 + 9 + 2) = **144 bytes**, a scalar
/// record `Record<f32>` 4 · (3 + 3 + 1 + 2 + 1 + 3 + 1 + 3 + 3 + 2) = 88 bytes.
///
/// A record may be **anisotropic** (Schwarzhaupt et al. 2012; Radiance ≥ 4.2): an ellipse on its
/// tangent plane with the major radius R along `normal × tangent` and the minor radius
/// `aspect`·R along `tangent`. R stays the radius every metric, the octree and neighbour
/// clamping use (so the sphere the octree files contains the ellipse), and an isotropic record
/// is the special case `aspect` = 1 (what [`Record::new`] makes; `tangent` is then unused and
/// may be zero). Only a metric that reads the ellipse ([`crate::Hessian`]) treats the record as
/// one.
///
/// Besides the radius R it uses, a record keeps what neighbour clamping needs to change R later
/// (Křivánek et al. 2006; Mitsuba 0.6 keeps the same per record): the **unclamped radius**, the
/// geometric radius before any pixel or world-space minimum or maximum was applied (the gather's
/// distance, gradient-limited, neighbour-clamped), which is what neighbour clamping propagates;
/// and the **minimum radius**, below which clamping must not push R. [`Record::new`] sets the
/// first to R and the second to 0, which makes neighbour clamping act on R directly.
///
/// Gradients are stored per axis: `translation_gradient[k]` is ∂E/∂p along world axis k, and
/// `rotation_gradient[k]` is the k-th component of the rotation gradient ∇ᵣE (Ward & Heckbert
/// 1992), so that the first-order change of E when the normal turns from nᵢ to n is
/// (nᵢ × n)·∇ᵣE = Σₖ (nᵢ × n)ₖ · `rotation_gradient[k]`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Record<V> {
    /// pᵢ, where the value was computed.
    pub position: Vec3,
    /// nᵢ, the unit surface normal there.
    pub normal: Vec3,
    /// Rᵢ, the validity radius (e.g. the harmonic mean or the minimum of the gather's hit
    /// distances, clamped by the caller). The metric turns it into an influence radius.
    pub radius: f32,
    /// The geometric radius before the minimum and maximum limits (see the type's docs); finite
    /// and > 0.
    pub unclamped_radius: f32,
    /// The smallest R neighbour clamping may leave (the pixel or world-space minimum); finite
    /// and ≥ 0.
    pub min_radius: f32,
    /// The minor radius as a fraction of R, in (0, 1]; 1 for an isotropic record.
    pub aspect: f32,
    /// The unit direction of the minor axis, perpendicular to the normal (zero allowed where
    /// `aspect` = 1).
    pub tangent: Vec3,
    /// Eᵢ, the value.
    pub value: V,
    /// ∂E/∂p, one value per world axis.
    pub translation_gradient: [V; 3],
    /// ∇ᵣE, one value per world axis (see the type's docs for the convention).
    pub rotation_gradient: [V; 3],
    /// The value's relative second derivatives (1/length²) along the minor axis `tangent` and
    /// along nᵢ × `tangent`: the eigenvalues of the tangent block of H/E, the irradiance
    /// Hessian relative to the value (Hessian records). A metric whose
    /// [`crate::ErrorMetric::second_order_limit`] is positive extrapolates by them; zero, or a
    /// record without a minor axis, extrapolates to first order.
    pub curvature: [f32; 2],
}

impl<V: CacheValue> Record<V> {
    /// A record with zero gradients.
    pub fn new(position: Vec3, normal: Vec3, radius: f32, value: V) -> Self {
        Self {
            position,
            normal,
            radius,
            unclamped_radius: radius,
            min_radius: 0.0,
            aspect: 1.0,
            tangent: Vec3::ZERO,
            value,
            translation_gradient: [V::zero(); 3],
            rotation_gradient: [V::zero(); 3],
            curvature: [0.0; 2],
        }
    }

    /// The same record with an unclamped radius and a minimum radius of its own (see the type's
    /// docs); R is unchanged.
    pub fn with_clamping_history(self, unclamped_radius: f32, min_radius: f32) -> Self {
        Self {
            unclamped_radius,
            min_radius,
            ..self
        }
    }

    /// The same record as an ellipse: the minor radius `aspect`·R along `tangent` (see the
    /// type's docs); R is unchanged.
    pub fn with_ellipse(self, aspect: f32, tangent: Vec3) -> Self {
        Self {
            aspect,
            tangent,
            ..self
        }
    }

    /// The same record with the given curvature (see [`Record::curvature`]).
    pub fn with_curvature(self, curvature: [f32; 2]) -> Self {
        Self { curvature, ..self }
    }

    /// The same record with the given gradients (translation, rotation), each per world axis.
    pub fn with_gradients(self, translation: [V; 3], rotation: [V; 3]) -> Self {
        Self {
            translation_gradient: translation,
            rotation_gradient: rotation,
            ..self
        }
    }

    /// The record as the cache stores it, or why it cannot be stored: the position must be
    /// finite; the normal finite and non-zero (it is normalised unless it is already unit to
    /// float precision); the radius a finite normal `f32` > 0; the value and gradients finite,
    /// and the value non-negative for a [`CacheValue::NON_NEGATIVE`] type.
    pub fn validated(self) -> Result<Self, InsertError> {
        if !self.position.is_finite() {
            return Err(InsertError::Position);
        }
        if !(self.radius.is_finite() && self.radius >= f32::MIN_POSITIVE) {
            return Err(InsertError::Radius(self.radius));
        }
        if !(self.unclamped_radius.is_finite() && self.unclamped_radius >= f32::MIN_POSITIVE) {
            return Err(InsertError::UnclampedRadius(self.unclamped_radius));
        }
        if !(self.min_radius.is_finite() && self.min_radius >= 0.0) {
            return Err(InsertError::MinRadius(self.min_radius));
        }
        let normal = unit_normal(self.normal).ok_or(InsertError::Normal)?;
        if !(self.aspect > 0.0 && self.aspect <= 1.0) {
            return Err(InsertError::Aspect(self.aspect));
        }
        // The minor axis made perpendicular to the normal and unit (Gram–Schmidt in f64); an
        // isotropic record keeps whatever it has, an ellipse needs a usable axis. An axis
        // already unit and perpendicular to float precision (as this step leaves it: each
        // component rounded to f32 moves t·n by at most ~3·2⁻²⁴) is kept as it is, so validating
        // twice gives the same bits, as for the normal.
        let (t, n) = (self.tangent.as_dvec3(), normal.as_dvec3());
        let tangent = if self.aspect == 1.0 && self.tangent == Vec3::ZERO {
            Vec3::ZERO
        } else if (t.length() - 1.0).abs() <= UNIT_TOLERANCE && t.dot(n).abs() <= UNIT_TOLERANCE {
            self.tangent
        } else {
            // Projected with n·n, not 1: the normal is unit only to f32 precision, and the
            // error (t·n)(1 − n·n) would be amplified by 1/|t| for an axis nearly along n.
            let t = t - n * (t.dot(n) / n.length_squared());
            let len = t.length();
            if !(len.is_finite() && len > 1e-6 * self.tangent.as_dvec3().length()) {
                return Err(InsertError::Tangent);
            }
            unit_normal((t / len).as_vec3()).ok_or(InsertError::Tangent)?
        };
        let finite = |v: &V| v.channels().iter().all(|c| c.is_finite());
        if !finite(&self.value) {
            return Err(InsertError::Value);
        }
        if V::NON_NEGATIVE && self.value.channels().iter().any(|&c| c < 0.0) {
            return Err(InsertError::NegativeValue);
        }
        if !(self.translation_gradient.iter().all(finite)
            && self.rotation_gradient.iter().all(finite))
        {
            return Err(InsertError::Gradient);
        }
        if !self.curvature.iter().all(|c| c.is_finite()) {
            return Err(InsertError::Curvature);
        }
        Ok(Self {
            normal,
            tangent,
            ..self
        })
    }
}

/// `n` made unit, or `None` when it is zero or not finite.
///
/// A vector already unit to float precision is returned unchanged, so validation is idempotent
/// (a cache read back from a file stores the same bits it wrote). The threshold: a unit vector
/// rounded to `f32` has each component off by at most 2⁻²⁴ relative, so its length is within
/// 2⁻²⁴ of 1, and the `f64` length computation adds far less; a length within 4·2⁻²⁴ of 1 is
/// therefore accepted as unit, and normalising it would only move its last bits.
pub(crate) fn unit_normal(n: Vec3) -> Option<Vec3> {
    if !n.is_finite() {
        return None;
    }
    let d = n.as_dvec3();
    let len = d.length();
    if len == 0.0 {
        return None;
    }
    if (len - 1.0).abs() <= UNIT_TOLERANCE {
        Some(n)
    } else {
        Some((d / len).as_vec3())
    }
}

/// A query normal made unit in `f64`, or `None` when it is zero or not finite. As for records, a
/// normal already unit to float precision is kept as it is, so a query with a record's own normal
/// sees nᵢ × n = 0 exactly.
#[inline]
pub(crate) fn unit_query_normal(n: Vec3) -> Option<DVec3> {
    if !n.is_finite() {
        return None;
    }
    let d = n.as_dvec3();
    let len = d.length();
    if len == 0.0 {
        None
    } else if (len - 1.0).abs() <= UNIT_TOLERANCE {
        Some(d)
    } else {
        Some(d / len)
    }
}

/// How far from 1 the length of a vector may be for it to count as unit: 4·2⁻²⁴ (see
/// [`unit_normal`]).
const UNIT_TOLERANCE: f64 = 4.0 * (f32::EPSILON as f64) * 0.5;

/// Why a record was refused.
#[derive(Clone, Copy, Debug, PartialEq, Error)]
pub enum InsertError {
    /// The position has a NaN or infinite coordinate.
    #[error("record position is not finite")]
    Position,
    /// The normal is zero or not finite.
    #[error("record normal is zero or not finite")]
    Normal,
    /// The radius is zero, negative, subnormal, NaN or infinite.
    #[error("record radius must be a finite normal float > 0, got {0}")]
    Radius(f32),
    /// The unclamped radius is zero, negative, subnormal, NaN or infinite.
    #[error("record unclamped radius must be a finite normal float > 0, got {0}")]
    UnclampedRadius(f32),
    /// The minimum radius is negative, NaN or infinite.
    #[error("record minimum radius must be finite and >= 0, got {0}")]
    MinRadius(f32),
    /// The radius limits given to the radius pipeline are not 0 ≤ min ≤ max < ∞.
    #[error("radius limits must satisfy 0 <= min <= max < inf, got [{0}, {1}]")]
    Limits(f32, f32),
    /// The distance given to the radius pipeline is NaN.
    #[error("the gather distance is {0}")]
    Distance(f32),
    /// The metric gives this record an influence radius that is not finite (a huge radius with a
    /// tiny accuracy).
    #[error("the metric gives an influence radius of {0}, which is not finite")]
    Influence(f32),
    /// The aspect (minor radius / radius) is not in (0, 1].
    #[error("record aspect (minor radius / radius) must lie in (0, 1], got {0}")]
    Aspect(f32),
    /// An anisotropic record's minor axis is not finite, zero or along the normal.
    #[error("record minor axis is not finite, zero or parallel to the normal")]
    Tangent,
    /// The value has a NaN or infinite channel.
    #[error("record value is not finite")]
    Value,
    /// The value has a negative channel, and the value type is non-negative.
    #[error("record value has a negative channel")]
    NegativeValue,
    /// A gradient has a NaN or infinite channel.
    #[error("record gradient is not finite")]
    Gradient,
    /// A curvature is NaN or infinite.
    #[error("record curvature is not finite")]
    Curvature,
    /// The cache holds `u32::MAX` records already.
    #[error("the cache is full (u32::MAX records)")]
    Full,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::value::Rgb;

    #[test]
    fn layout_is_compact() {
        assert_eq!(size_of::<Record<Rgb>>(), 144);
        assert_eq!(size_of::<Record<f32>>(), 88);
        assert_eq!(align_of::<Record<Rgb>>(), 4);
    }

    fn good() -> Record<Rgb> {
        Record::new(Vec3::ZERO, Vec3::Z, 1.0, Rgb::splat(1.0))
    }

    #[test]
    fn bad_records_are_refused_with_the_reason() {
        let r = |f: fn(&mut Record<Rgb>)| {
            let mut rec = good();
            f(&mut rec);
            rec.validated()
        };
        assert_eq!(r(|x| x.position.x = f32::NAN), Err(InsertError::Position));
        assert_eq!(
            r(|x| x.position.y = f32::INFINITY),
            Err(InsertError::Position)
        );
        assert_eq!(r(|x| x.normal = Vec3::ZERO), Err(InsertError::Normal));
        assert_eq!(r(|x| x.normal.z = f32::NAN), Err(InsertError::Normal));
        assert_eq!(r(|x| x.radius = 0.0), Err(InsertError::Radius(0.0)));
        assert_eq!(r(|x| x.radius = -1.0), Err(InsertError::Radius(-1.0)));
        assert_eq!(r(|x| x.radius = 1e-40), Err(InsertError::Radius(1e-40)));
        assert_eq!(
            r(|x| x.radius = f32::INFINITY),
            Err(InsertError::Radius(f32::INFINITY))
        );
        assert!(matches!(
            r(|x| x.radius = f32::NAN),
            Err(InsertError::Radius(_))
        ));
        assert_eq!(
            r(|x| x.unclamped_radius = f32::INFINITY),
            Err(InsertError::UnclampedRadius(f32::INFINITY))
        );
        assert_eq!(
            r(|x| x.unclamped_radius = 0.0),
            Err(InsertError::UnclampedRadius(0.0))
        );
        assert_eq!(
            r(|x| x.min_radius = -1.0),
            Err(InsertError::MinRadius(-1.0))
        );
        assert_eq!(r(|x| x.value.0[1] = f32::NAN), Err(InsertError::Value));
        assert_eq!(r(|x| x.value.0[2] = -0.5), Err(InsertError::NegativeValue));
        assert_eq!(
            r(|x| x.rotation_gradient[2].0[0] = f32::INFINITY),
            Err(InsertError::Gradient)
        );
        assert_eq!(
            r(|x| x.translation_gradient[0].0[0] = f32::NAN),
            Err(InsertError::Gradient)
        );
        // Negative zero is not negative; signed coefficient vectors may be negative.
        assert!(r(|x| x.value.0[0] = -0.0).is_ok());
        let sh = Record::new(Vec3::ZERO, Vec3::Z, 1.0, [-1.0f32, 2.0]);
        assert!(sh.validated().is_ok());
    }

    #[test]
    fn normals_are_normalised_once() {
        let rec = Record::new(Vec3::ZERO, Vec3::new(0.0, 3.0, 4.0), 1.0, 0.5f32);
        let v = rec.validated().unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(v.normal, Vec3::new(0.0, 0.6, 0.8));
        // Idempotent: a validated record validates to the same bits.
        let tiny = Record::new(Vec3::ZERO, Vec3::new(1e-30, 2e-30, -3e-30), 1.0, 0.5f32);
        let once = tiny.validated().unwrap_or_else(|e| panic!("{e}"));
        let twice = once.validated().unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(once, twice);
        assert!((once.normal.length() - 1.0).abs() <= f32::EPSILON);
    }
}
