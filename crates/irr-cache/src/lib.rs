//! The irradiance cache on its own (Ward et al. 1988; Ward & Heckbert 1992; Tabellion &
//! Lamorlette 2004; Křivánek et al. 2006; Křivánek & Gautron 2009): records of a value computed at
//! sparse surface points, the error metrics that say where each may be reused, an octree that
//! finds them, gradient-corrected interpolation, and a binary file to keep a cache between renders.
//!
//! # What it owns
//! - [`CacheValue`]: the stored value, a small vector space over `f32` channels; implemented for
//!   [`Rgb`] irradiance, `f32` (ambient occlusion) and `[f32; N]` (e.g. spherical-harmonic
//!   coefficients for radiance caching).
//! - [`Record`]: position, normal, validity radius R, value E, translation gradient ∂E/∂p and
//!   rotation gradient ∇ᵣE, each gradient as `[V; 3]` (per world axis), and
//!   the unclamped and minimum radii that neighbour clamping needs, and for an anisotropic
//!   record its ellipse (aspect and minor axis) and curvature. 144 bytes for `Rgb`.
//! - [`ErrorMetric`] with [`Ward`], [`TabellionLamorlette`] and [`Hessian`] (elliptical
//!   records), the shared [`Cuts`] (Ward &
//!   Heckbert's "in front" test with a tolerance relative to R, the normal-divergence cut with an
//!   [`Angle`] that cannot be read in the wrong unit) and the [`RadiusLimits`] a caller clamps a
//!   new radius to, from the pixel spacing.
//! - The octree of influence spheres (a linear octree: cells keyed by level and integer
//!   coordinates in a hash table, no bounds to set or grow; each record filed at the level that
//!   matches its influence radius, as in Ward et al. 1988). A query visits exactly the records whose
//!   sphere contains p, the same set as a brute-force scan, to the last bit.
//! - [`IrradianceCache`]: insertion (`insert`, all-or-nothing `extend`), the exact range query,
//!   [`IrradianceCache::interpolate`] (returning the value, the total weight and the record count,
//!   or `None` on a miss), neighbour clamping, and [`IrradianceCache::write_to`] /
//!   [`IrradianceCache::read_from`] (format in [`io`]); [`io::read_records`] and
//!   [`io::write_records`] for tools that join or filter caches' records without filing them.
//!
//! # What it must not know
//! **Rays, scenes, sampling.** It takes positions, normals, radii and values as plain numbers;
//! computing a record (the hemisphere gather and its gradients) and choosing R are the caller's.
//! No `irr-*` crate is needed to use it.
//!
//! # Concurrency
//! Insertion takes `&mut self`; queries take `&self` and the cache is `Sync`: query from many
//! threads between insertion phases (e.g. a rayon pass that collects new records, then
//! [`IrradianceCache::extend`]).
//!
//! # Example
//! ```
//! use irr_cache::{IrradianceCache, Record, Rgb, TabellionLamorlette};
//! use glam::Vec3;
//!
//! // κ = 1: a record of radius R is used within R/2 of its position and 10° of its normal.
//! let metric = TabellionLamorlette::new(1.0)?;
//! let mut cache = IrradianceCache::<Rgb, _>::new(metric);
//!
//! // A query on an empty cache misses: the caller computes a record there and inserts it.
//! let (p, n) = (Vec3::new(0.0, 0.0, 0.0), Vec3::Z);
//! assert!(cache.interpolate(p, n).is_none());
//! // Irradiance that brightens along +x: E = 1 + 0.5·x, so ∂E/∂x = 0.5.
//! let grad_x = Rgb::splat(0.5);
//! let record = Record::new(p, n, 2.0, Rgb::splat(1.0))
//!     .with_gradients([grad_x, Rgb::splat(0.0), Rgb::splat(0.0)], [Rgb::splat(0.0); 3]);
//! cache.insert(record)?;
//!
//! // Within R/2 = 1 of the record, the value is extrapolated by its gradient.
//! let hit = cache.interpolate(Vec3::new(0.5, 0.0, 0.0), Vec3::Z).ok_or("miss")?;
//! assert_eq!(hit.value, Rgb::splat(1.25));
//! assert_eq!(hit.count, 1);
//! // Beyond it, or on a wall at 90°, it is not used.
//! assert!(cache.interpolate(Vec3::new(1.5, 0.0, 0.0), Vec3::Z).is_none());
//! assert!(cache.interpolate(Vec3::new(0.5, 0.0, 0.0), Vec3::X).is_none());
//!
//! // Bad input is an error, not a panic.
//! assert!(cache.insert(Record::new(p, n, 0.0, Rgb::splat(1.0))).is_err());
//!
//! // Keep the cache for the next render of the same scene.
//! let mut file = Vec::new();
//! cache.write_to(&mut file)?;
//! let again = IrradianceCache::<Rgb, _>::read_from(file.as_slice(), metric)?;
//! assert_eq!(again.records(), cache.records());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod cache;
pub mod io;
mod metric;
mod octree;
mod record;
mod value;

pub use cache::{
    BatchError, Interpolation, IrradianceCache, MAX_SCALED_CHANNELS, NearbyRecord, Placement,
    RadiusInputs, RecordId, within_influence,
};
pub use io::CacheFileError;
pub use metric::{
    Angle, Candidate, Cuts, ErrorMetric, Hessian, MetricError, PixelRange, RadiusLimits,
    TabellionLamorlette, Ward,
};
pub use record::{InsertError, Record};
pub use value::{CacheValue, Rgb};

#[cfg(test)]
mod tests;
