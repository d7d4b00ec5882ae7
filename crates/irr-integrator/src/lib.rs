//! irr's integrators: given a scene and a ray, estimate the radiance arriving along it.
//!
//! # What it owns
//! - [`Scene`]: geometry plus [`Material`]s (glTF's metallic-roughness model, Lambertian as its
//!   special case: base colour, metallic, roughness, specular weight, emission, sidedness, the
//!   base colour, emission and metallic-roughness optionally times a [`Texture`] read at the
//!   point's [`TexCoords`], the base colour times [`VertexColours`]), the [`PunctualLight`]s
//!   (glTF's point, spot and directional lights, in glTF's units read as irr's: no 683 lm/W
//!   factor), a constant background radiance, and the [`LightSampler`] over emitting triangles
//!   and punctual lights (by power, then uniformly by area on a triangle). Integrators read a
//!   point's albedo and emission through [`Scene::albedo`] and [`Scene::emitted`], its
//!   reflection through [`Bsdf::at`].
//! - [`Texture`]: linear RGB images with glTF's wrap modes and nearest or bilinear filtering.
//! - The [`Integrator`] interface (pbrt-v4's `RayIntegrator::Li`): radiance along one ray, with
//!   random numbers from an `irr_sampling::rng::Dimensions` cursor, whole (`li`), split by
//!   bounce count (`li_split`), or for a batch of camera rays (`li_many`, each answer `li`'s);
//!   and [`first_hit`], what a camera ray meets first (albedo, shading normal, distance) for a
//!   renderer's auxiliary images.
//! - [`PathTracer`]: the unbiased reference (NEE + BSDF sampling with MIS, Russian roulette). Its
//!   estimate splits into emitted, direct and indirect parts ([`Radiance`]); the module `path`
//!   documents exactly which light paths each carries, so the irradiance cache can replace the
//!   indirect part without counting anything twice. On a large scene it traces a batch's paths
//!   a bounce at a time as streams of rays (`PathTracer::reflected_many`).
//! - [`AmbientOcclusion`].
//! - The irradiance cache ([`ic`]): [`IrradianceCacheIntegrator`] (emission + NEE + the cached
//!   indirect part, split like the path tracer's), [`CachedAmbientOcclusion`], their
//!   [`IcSettings`], and [`CacheBuilder`], the interface a renderer drives deterministic parallel
//!   construction through (probe, select, complete, commit).
//!
//! # What it must not know
//! Images, tiles, threads, progress, file formats: those are irr-render's. Integrators see camera
//! rays one at a time, or as a batch whose answers are each ray's alone; of the camera, the
//! cache knows only where it is and how tall its image is at a distance ([`CacheView`]), to
//! size its lengths by what the image shows.
//!
//! # Example
//! ```
//! use glam::Vec3;
//! use irr_geometry::{Geometry, Ray, TriangleMesh};
//! use irr_integrator::{AmbientOcclusion, AoSettings, Integrator, Material, RayCounter, Scene};
//! use irr_sampling::{rng::Dimensions, SampleKey};
//!
//! // A 2 m square floor at y = 0, facing up.
//! let floor = TriangleMesh {
//!     positions: vec![
//!         Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, -1.0),
//!         Vec3::new(1.0, 0.0, 1.0), Vec3::new(-1.0, 0.0, 1.0),
//!     ],
//!     indices: vec![[0, 2, 1], [0, 3, 2]],
//!     normals: None,
//!     material_ids: vec![0, 0],
//! };
//! let geometry = Geometry::build(&[floor]).unwrap();
//! let scene = Scene::new(geometry, vec![Material::diffuse(Vec3::splat(0.5))]).unwrap();
//!
//! // Nothing above the floor occludes it: AO is exactly 1.
//! let ao = AmbientOcclusion::new(AoSettings { max_distance: f32::INFINITY, samples: 8 });
//! let ray = Ray::new(Vec3::new(0.1, 1.0, 0.2), Vec3::new(0.0, -1.0, 0.0));
//! let mut dims = Dimensions::new(SampleKey::new(1, 0, 0));
//! let mut rays = RayCounter::default();
//! assert_eq!(ao.li(&scene, &ray, &mut dims, &mut rays), Vec3::ONE);
//! assert_eq!(rays.shadow, 8);
//! ```

mod ao;
pub mod bsdf;
pub mod ic;
mod integrator;
mod light;
pub mod path;
mod scene;

pub use ao::{AmbientOcclusion, AoSettings};
pub use bsdf::{Bsdf, BsdfDraw};
pub use ic::{
    BounceMode, CacheBuilder, CacheView, CachedAmbientOcclusion, CachedLevel, Candidate,
    CommitStats, DisplayRecord, GradientMode, GuardRecord, IcMetric, IcSettings, IcSettingsError,
    IrradianceCacheIntegrator, LeakGuard, LightCacheCounts, LightDeposit, LightPathTracer,
    MetricKind, Probe, RadiusStatistic, surface_spacing,
};
pub use integrator::{Batching, FirstHit, Integrator, PIXEL_BATCH, RayCounter, first_hit};
pub use irr_bsdf::luminance;
pub use irr_scene::{
    AlphaMode, Filter, Incidence, Material, PunctualLight, Sampler, TexCoords, Texture,
    TextureError, TextureRef, TooManyAttributeTriangles, TooManyTexCoords, VertexAttribute,
    VertexColours, VertexTangents, Wrap,
};
pub use light::{LightSample, LightSampler};
pub use path::{PathSettings, PathTracer, Radiance};
pub use scene::{Scene, SceneError, coverage_sample, pass_sample};

#[cfg(test)]
mod light_tests;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod texture_tests;
