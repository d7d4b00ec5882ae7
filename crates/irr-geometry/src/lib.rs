//! Scene geometry for irr: triangle meshes, a BVH over them built with obvhs, closest-hit and
//! occlusion queries, and ray offsets that stay robust at every scene scale.
//!
//! # What it owns
//! - [`TriangleMesh`] (input) and [`Geometry::build`] / [`Geometry::build_owned`]: validation
//!   (typed [`GeometryError`]s naming the mesh and triangle), dropping and counting of zero-area
//!   and non-finite triangles ([`BuildReport`]), and the BVH: obvhs PLOC + reinsertion for
//!   small scenes, a lean top-down SAH build with leaves of four above, then by default an
//!   8-wide tree with four-triangle SIMD leaves with exact float child boxes, its nodes tested
//!   8 lanes at once where the CPU has AVX2 (detected at run time; any x86-64 CPU runs the
//!   4-lane path); a subtree of two packets is one pair leaf, and trees above 1 MiB prefetch
//!   the children they push ([`BvhLayout`] lists the layouts; docs/performance.md has their
//!   measured cost). The leaves hold each triangle's vertices, once: about 80 bytes per
//!   triangle in all ([`Geometry::heap_bytes`]).
//! - [`Geometry::intersect`] (closest hit: distance, triangle id, barycentrics) and
//!   [`Geometry::occluded`] (any hit), with a watertight triangle test (Woop et al. 2013) that
//!   reports a hit only when its distance is provably inside `(0, t_max)`; and for batches:
//!   a coherent one in one dispatch ([`Geometry::intersect_many`]), and incoherent ones
//!   ([`Geometry::intersect_stream`], [`Geometry::occluded_stream`]), which on a tree larger
//!   than the caches keep several rays in flight so that their waits for memory overlap (as
//!   [`Geometry::occluded`] does there with two walks of its one ray).
//! - [`Geometry::surface`]: the hit point computed from the barycentrics, the geometric normal
//!   (from the winding, never flipped) and the shading normal.
//! - [`Ray::spawn`], [`Ray::spawn_to`] and [`offset_ray_origin`]: origins offset by a few ulps of
//!   the point's magnitude (Wächter & Binder, Ray Tracing Gems ch. 6), so secondary rays neither
//!   re-hit their own surface nor tunnel through thin geometry, in tiny, huge or far-translated
//!   scenes alike; and at least [`POSITION_ERROR_FLOOR`] (2⁻¹⁰⁰) off a plane through zero, so
//!   that the triangle test's arithmetic on such a ray stays in normal floats (a subnormal
//!   result costs a microcode assist on x86).
//!
//! # Robustness, and its limits
//! - Watertight: a ray through a shared edge or vertex hits at least one of the triangles
//!   (Woop et al. 2013; edge functions within rounding of zero are redone in `f64`).
//! - A hit is reported only if its distance is provably in `(0, t_max)`, and spawned origins
//!   are provably on the right side of their surface, so no ray re-hits the surface it leaves,
//!   at any scale or translation (tested at scales 1e-4, 1, 1e3 and translated by 1e5).
//! - The offset is 2–6 ulps of the point, so geometry thinner than that cannot be resolved: at
//!   a translation of 1e5 (ulp 2⁻⁷) a slab must be about 8 ulps (0.06) thick.
//! - A point within an ulp or two of an edge can end up on the other side of the adjacent
//!   face (its rounding or its offset crosses that face's plane); a ray from there may then
//!   leave through the corner. This is the usual concave-corner limit of offset methods, and
//!   only matters where the float spacing is comparable to the geometry (far translations).
//! - Coordinates must stay below about 1e18 in magnitude (products of two coordinates must
//!   not overflow `f32`); NaN and infinite coordinates are dropped at build time.
//!
//! # What it must not know
//! Materials, lights, cameras, sampling and radiance. A material id is an opaque `u32` carried
//! through; the glTF loader lives elsewhere and hands this crate plain world-space meshes.
//!
//! # Example
//! ```
//! use glam::Vec3;
//! use irr_geometry::{Geometry, Ray, TriangleMesh};
//!
//! // A unit floor quad (facing +y) and a ceiling quad above it.
//! let quad = |y: f32, material: u32| TriangleMesh {
//!     positions: vec![
//!         Vec3::new(0.0, y, 0.0),
//!         Vec3::new(0.0, y, 1.0),
//!         Vec3::new(1.0, y, 1.0),
//!         Vec3::new(1.0, y, 0.0),
//!     ],
//!     indices: vec![[0, 1, 2], [0, 2, 3]],
//!     normals: None,
//!     material_ids: vec![material; 2],
//! };
//! let geometry = Geometry::build(&[quad(0.0, 0), quad(1.0, 1)])?;
//! assert_eq!(geometry.report().kept, 4);
//!
//! // A camera ray hits the floor...
//! let ray = Ray::new(Vec3::new(0.5, 0.5, 0.5), Vec3::new(0.1, -1.0, 0.2));
//! let hit = geometry.intersect(&ray).ok_or("the floor is below")?;
//! let floor = geometry.surface(&ray, &hit);
//! assert_eq!(floor.material_id, 0);
//! assert_eq!(floor.geometric_normal, Vec3::Y);
//!
//! // ...a bounce leaves it without re-hitting it and finds the ceiling...
//! let bounce = Ray::spawn(floor.position, floor.geometric_normal, Vec3::new(-0.1, 1.0, 0.05));
//! let up = geometry.intersect(&bounce).ok_or("the ceiling is above")?;
//! assert_eq!(geometry.triangle(up.triangle).material_id, 1);
//!
//! // ...and a shadow ray to a point on the ceiling is not blocked by either end's surface.
//! let light = Vec3::new(0.25, 1.0, 0.75);
//! let shadow = Ray::spawn_to(floor.position, floor.geometric_normal, light, -Vec3::Y);
//! assert!(!geometry.occluded(&shadow));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod build;
mod error;
mod geometry;
mod intersect;
mod layout;
mod mesh;
mod pages;
mod query;
mod ray;
#[cfg(test)]
mod test_meshes;
mod wide;

pub use error::GeometryError;
pub use geometry::{Geometry, MAX_TRIANGLES};
pub use layout::BvhLayout;
pub use mesh::{BuildReport, Triangle, TriangleMesh};
pub use query::{Hit, SurfacePoint};
pub use ray::{
    POSITION_ERROR_FLOOR, POSITION_RELATIVE_ERROR, Ray, offset_ray_origin,
    offset_ray_origin_with_error, position_error,
};
