//! Irradiance-cache records from hemisphere gathers: the join between irr-gradients, which
//! computes E and its gradients from one gather, and irr-cache, which stores and interpolates
//! records. Neither of the two knows the other; a renderer that uses both needs this crate and
//! nothing more.
//!
//! # What it owns
//! - [`GatheredValue`]: a cache value ([`CacheValue`]) paired with the gather value
//!   ([`GatherValue`]) it is computed from, and the conversions both ways. Implemented for
//!   [`Rgb`] irradiance (gathered as `glam::Vec3`) and `f32` (ambient occlusion, or any scalar).
//! - [`record`]: a [`Record`] holding a gather's world-space [`Gradients`], each channel copied
//!   as is (no arithmetic, so a record carries exactly the numbers irr-gradients computed).
//!
//! # What it must not know
//! Rays, scenes and how a radius is chosen: the caller traces the gather, turns its gradients to
//! world space ([`Gradients::in_world`]) and sizes the record (irr-cache's `plan_radius` and
//! `insert_with_radius`, fed by the gather's distance statistics).
//!
//! # Example
//! ```
//! use glam::Vec3;
//! use irr_cache::{IrradianceCache, Rgb, TabellionLamorlette};
//! use irr_gradients::{GatherSamples, TranslationGradient};
//! use irr_sampling::{Frame, HemisphereStrata};
//!
//! // A gather under a uniform sky of radiance 1 (every ray misses): E = π, no gradient.
//! let strata = HemisphereStrata::new(8, 24)?;
//! let sky = GatherSamples::from_fn(strata, |_| (Vec3::ONE, f32::INFINITY))?;
//! let (position, normal) = (Vec3::ZERO, Vec3::Y);
//! let world = sky
//!     .gradients(TranslationGradient::WardHeckbert)
//!     .in_world(&Frame::from_normal(normal));
//!
//! // The record, sized by hand here (radius 2), then filed and read back.
//! let mut cache = IrradianceCache::<Rgb, _>::new(TabellionLamorlette::new(1.0)?);
//! cache.insert(irr_gather_record::record(position, normal, 2.0, &world))?;
//! let read = cache.interpolate(Vec3::new(0.5, 0.0, 0.0), normal).ok_or("miss")?;
//! assert!((Vec3::from(read.value) - Vec3::splat(std::f32::consts::PI)).abs().max_element() < 1e-5);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use glam::Vec3;
use irr_cache::{CacheValue, Record, Rgb};
use irr_gradients::{GatherValue, Gradients};

/// A value a cache stores ([`CacheValue`]) that a gather computes in another type
/// ([`GatherValue`]): irradiance is gathered as `Vec3` and stored as [`Rgb`]; a scalar is `f32`
/// in both. The two conversions are exact inverses, channel for channel.
pub trait GatheredValue: CacheValue {
    /// The gather's per-cell value type. `Send + Sync` as the cache's values are: gathers run
    /// in parallel while the cache is read.
    type Gathered: GatherValue + Send + Sync;
    /// The cached value of a gathered one.
    fn from_gathered(g: Self::Gathered) -> Self;
    /// The gathered value of a cached one.
    fn to_gathered(self) -> Self::Gathered;
}

impl GatheredValue for Rgb {
    type Gathered = Vec3;
    #[inline]
    fn from_gathered(g: Vec3) -> Self {
        Rgb::from(g)
    }
    #[inline]
    fn to_gathered(self) -> Vec3 {
        Vec3::from_array(self.0)
    }
}

impl GatheredValue for f32 {
    type Gathered = f32;
    #[inline]
    fn from_gathered(g: f32) -> Self {
        g
    }
    #[inline]
    fn to_gathered(self) -> f32 {
        self
    }
}

/// The record at `position` (normal `normal`, radius `radius`) holding `world`: E and both
/// gradients, which must already be in world coordinates ([`Gradients::in_world`]) since a
/// [`Record`] keeps its gradients per world axis.
///
/// The conventions agree: irr-gradients' rotation gradient gives the change a·∇ᵣE for a turn of
/// the normal about a, and irr-cache extrapolates by (nᵢ × n)·∇ᵣE, so a record with one
/// neighbourless query reads what [`Gradients::extrapolate`] predicts (this crate's tests check
/// it). The record is isotropic; `Record::with_ellipse` and `Record::with_curvature` add an
/// anisotropic record's shape.
#[inline]
pub fn record<V: GatheredValue>(
    position: Vec3,
    normal: Vec3,
    radius: f32,
    world: &Gradients<V::Gathered>,
) -> Record<V> {
    Record::new(position, normal, radius, V::from_gathered(world.irradiance)).with_gradients(
        world.translation.map(V::from_gathered),
        world.rotation.map(V::from_gathered),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use irr_cache::{IrradianceCache, TabellionLamorlette};

    #[test]
    fn conversions_are_exact_inverses() {
        let v = Vec3::new(0.1, 2.5e-8, 3.0e7);
        assert_eq!(Rgb::from_gathered(v).to_gathered(), v);
        assert_eq!(Rgb::from_gathered(v), Rgb::new(0.1, 2.5e-8, 3.0e7));
        assert_eq!(f32::from_gathered(0.3).to_gathered(), 0.3);
    }

    /// Distinct numbers in every slot, so a swapped axis or a swapped gradient shows.
    fn gradients() -> Gradients<Vec3> {
        Gradients {
            irradiance: Vec3::new(2.0, 3.0, 4.0),
            rotation: [
                Vec3::new(0.11, 0.12, 0.13),
                Vec3::new(0.21, 0.22, 0.23),
                Vec3::new(0.31, 0.32, 0.33),
            ],
            translation: [
                Vec3::new(-0.41, 0.42, 0.43),
                Vec3::new(0.51, -0.52, 0.53),
                Vec3::new(0.61, 0.62, -0.63),
            ],
        }
    }

    #[test]
    fn the_record_holds_each_number_in_its_place() {
        let g = gradients();
        let r: Record<Rgb> = record(Vec3::new(1.0, 2.0, 3.0), Vec3::Z, 0.5, &g);
        assert_eq!(r.position, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!((r.normal, r.radius, r.aspect), (Vec3::Z, 0.5, 1.0));
        assert_eq!(r.value, Rgb::new(2.0, 3.0, 4.0));
        for k in 0..3 {
            assert_eq!(r.translation_gradient[k], Rgb::from(g.translation[k]));
            assert_eq!(r.rotation_gradient[k], Rgb::from(g.rotation[k]));
        }
        // A scalar record takes the scalar gather's numbers.
        let s: Record<f32> = record(
            Vec3::ZERO,
            Vec3::Y,
            1.0,
            &Gradients {
                irradiance: 0.75,
                rotation: [0.1, 0.2, 0.3],
                translation: [0.4, 0.5, 0.6],
            },
        );
        assert_eq!(s.value, 0.75);
        assert_eq!(s.translation_gradient, [0.4, 0.5, 0.6]);
        assert_eq!(s.rotation_gradient, [0.1, 0.2, 0.3]);
    }

    /// One record alone, read at a moved point with a turned normal: the cache's gradient
    /// correction equals irr-gradients' own first-order extrapolation (one record, so the
    /// weights cancel). Both sides compute a·b sums of f32 values near 1 (the cache in f64):
    /// 1e-5 covers their roundings by two orders of magnitude.
    #[test]
    fn the_cache_extrapolates_as_irr_gradients_does() -> Result<(), Box<dyn std::error::Error>> {
        let g = gradients();
        let (position, normal) = (Vec3::new(0.2, -0.1, 0.4), Vec3::Z);
        let mut cache = IrradianceCache::<Rgb, _>::new(TabellionLamorlette::new(1.0)?);
        cache.insert(record(position, normal, 4.0, &g))?;
        let offset = Vec3::new(0.3, -0.2, 0.0);
        let turned = Vec3::new(0.05, 0.08, 1.0).normalize();
        let read = cache
            .interpolate(position + offset, turned)
            .ok_or("the record does not cover the query")?;
        let expected = g.extrapolate(offset, normal.cross(turned));
        let got = Vec3::from(read.value);
        assert!(
            (got - expected).abs().max_element() < 1e-5,
            "cache {got}, irr-gradients {expected}"
        );
        // The correction is not negligible, so the comparison tests the gradients' placement.
        assert!((got - g.irradiance).abs().max_element() > 0.05);
        Ok(())
    }
}
