//! Scene geometry for irr: triangle meshes, a BVH over them built with obvhs, closest-hit and
//! occlusion queries, and ray offsets that stay robust at every scene scale.
//!
//! # What it owns
//! - [`TriangleMesh`] (input) and [`Geometry::build`] / [`Geometry::build_owned`] (`geometry.rs`):
//!   validation (typed [`GeometryError`]s naming the mesh and triangle), dropping and counting of
//!   zero-area and non-finite triangles ([`BuildReport`], `mesh.rs`), and the BVH: obvhs PLOC +
//!   reinsertion up to 1024 triangles, above a lean top-down binned-SAH build with leaves of four
//!   that splits coincident centroids by box size (`build.rs`), then the chosen [`BvhLayout`]
//!   (`layout.rs`). The leaves hold each triangle's vertices, once, bit for bit as given: about
//!   80 bytes per triangle in all ([`Geometry::heap_bytes`]); `build_owned` frees the meshes as
//!   it goes.
//! - Instances ([`Geometry::build_instanced`], `instances.rs`): prototype meshes stored once
//!   in object space, each with its own BVH, placed by [`Instance`] transforms under a
//!   top-level BVH (pbrt-v4's, Mitsuba 3's and Cycles' two levels). Rays are mapped into object
//!   space with pbrt-v4's error bounds; hits carry one id space
//!   ([`Geometry::instance_of`], [`Geometry::attribute_id`] for per-vertex data kept once).
//! - [`Geometry::intersect`] (closest hit: distance, triangle id, barycentrics) and
//!   [`Geometry::occluded`] (any hit), with a watertight triangle test (Woop et al. 2013) that
//!   reports a hit only when its distance is provably inside `(0, t_max)`; and for batches:
//!   a coherent one in one dispatch ([`Geometry::intersect_many`]), and incoherent ones
//!   ([`Geometry::intersect_stream`], [`Geometry::occluded_stream`]); [`Geometry::streams`]
//!   tells a caller whether batching pays (`query.rs`).
//! - Hit filters: each of those queries, and the brute-force references, also as
//!   `*_filtered`, taking a caller's [`HitFilter`] that is asked about each candidate hit
//!   during traversal and may reject it; the traversal then goes on as if that triangle were
//!   not hit. For alpha cut-outs (glTF `MASK`, and `BLEND` as stochastic transparency): the
//!   caller tests its texture, so the crate still knows no materials. The filter is a type
//!   parameter of the traversal, and the unfiltered queries pass one that accepts everything
//!   at compile time, so they run the same code as without filters.
//! - [`Geometry::surface`]: the hit point computed from the barycentrics in `f64`, the geometric
//!   normal (from the winding, never flipped), the shading normal, and the barycentrics, with
//!   which callers interpolate their own per-vertex data ([`Triangle::is_kept`] tells which
//!   input triangles get ids).
//! - [`Ray::spawn`], [`Ray::spawn_to`] and [`offset_ray_origin`] (`ray.rs`): origins offset by a
//!   few ulps of the point's magnitude (Wächter & Binder, Ray Tracing Gems ch. 6, in pbrt-v4's
//!   form with the final rounding's bound added to the error: no branch on the offset's sign), so
//!   secondary rays neither re-hit their own surface nor tunnel through thin geometry, in tiny,
//!   huge or far-translated scenes alike; and at least [`POSITION_ERROR_FLOOR`] (2⁻¹⁰⁰) off a
//!   plane through zero, so that the triangle test's arithmetic on such a ray stays in normal
//!   floats (a subnormal result costs a microcode assist on x86).
//!
//! # How a query runs
//! - The default layout, [`BvhLayout::Wide8`], is an 8-wide tree of exact `f32` child boxes whose
//!   leaves are packets of four triangles tested at once (`wide.rs`; the triangle and box tests
//!   and their error bounds are in `intersect.rs`). `Wide4` is the 4-wide variant, `Bvh2` the
//!   scalar traversal, kept as the oracle the wide ones are tested against.
//! - The wide traversals run compiled for the CPU found at run time (pulp: AVX2 or the x86-64
//!   baseline, no `unsafe` in irr), with the same bits either way; with AVX2 an 8-wide node's
//!   children are tested in one 8-lane slab test. They share one traversal, generic over the
//!   width, the node test and the query, written as one step at a time (`WideBvh::step`).
//! - A ray is prepared once, before the dispatch; the triangle test's part of it (largest axis,
//!   shear, and a screen that skips most of the work for packets the ray certainly misses)
//!   waits for the ray's first packet.
//! - A subtree of two packets is a *pair* leaf of its parent rather than a node of its own. A
//!   small tree's nodes hold their children largest box first, so that any hit, which visits
//!   the last one first, tries the smallest boxes (in a room, not the walls a shadow ray leaves).
//! - On trees larger than 1 MiB the 8-lane traversal prefetches each child it pushes (pulp's
//!   safe `_mm_prefetch`), and a hit packet's triangle ids, which the answer reads; on Linux,
//!   node, packet and id arrays of 2 MiB and more live on transparent huge pages (`pages.rs`:
//!   memmap2's safe `MADV_HUGEPAGE`, read through bytemuck).
//! - On such a tree the streams keep eight rays in flight, each taking one traversal step in
//!   turn, so that one ray's wait for memory overlaps the others' work; one ray's any-hit query
//!   runs as two walks of its own that take steps in turn (`WideBvh::two_walks`). Every batched
//!   answer is exactly the one-ray query's.
//!
//! Why each of these was chosen, with its measured cost, is in docs/performance.md.
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
//! through; the glTF loader lives elsewhere and hands this crate plain meshes (world-space, or
//! prototypes in object space with their placements' transforms).
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
mod instances;
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
pub use geometry::{
    BUILT_BYTES_PER_INSTANCE, BUILT_BYTES_PER_TRIANGLE, Geometry, MAX_OUTLIERS, MAX_TRIANGLES,
    OUTLIER_SPAN,
};
pub use instances::{Instance, Placement};
pub use layout::BvhLayout;
pub use mesh::{BuildReport, Triangle, TriangleMesh};
pub use query::{Hit, HitFilter, SurfacePoint};
pub use ray::{
    POSITION_ERROR_FLOOR, POSITION_RELATIVE_ERROR, Ray, offset_ray_origin,
    offset_ray_origin_with_error, position_error,
};
