//! [`Geometry`]: the kept triangles and the BVH over them (built in `build.rs`), and the two
//! queries every integrator needs: the closest hit and occlusion.

use std::borrow::Cow;

use glam::{UVec2, Vec3};
use obvhs::bvh2::node::Bvh2Node;

use crate::build;
use crate::intersect::{PreparedRay, TriHit, TriSoa, box_entry, intersect_triangle};
#[cfg(target_arch = "x86_64")]
use crate::wide::Lanes8;
use crate::wide::{Entry, Lanes4, NodeTest, Query, Walk, WideBvh};
use crate::{BuildReport, GeometryError, Ray, Triangle, TriangleMesh};

/// A closest hit: the distance along the ray, the triangle, and the barycentrics of its
/// vertices 1 and 2 (vertex 0 has `1 − b1 − b2`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance in units of the ray's direction length: the hit is near `origin + t·direction`
    /// (use [`Geometry::surface`] for an accurate point, never this product).
    pub t: f32,
    /// Triangle id, `0..triangle_count()`.
    pub triangle: u32,
    /// Barycentric coordinate of vertex 1.
    pub b1: f32,
    /// Barycentric coordinate of vertex 2.
    pub b2: f32,
}

/// What an integrator needs at a hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// The hit point, from the barycentrics (`p0 + b1·(p1 − p0) + b2·(p2 − p0)`, see
    /// [`Triangle::point`]): within half an ulp per component of the triangle's plane, which
    /// is what [`Ray::spawn`] and [`Ray::spawn_to`] rely on.
    pub position: Vec3,
    /// Unit normal from the winding, `(p1 − p0) × (p2 − p0)`; *not* flipped toward the ray.
    pub geometric_normal: Vec3,
    /// Unit shading normal: the interpolated vertex normals if the mesh has them (and they do
    /// not interpolate to zero), else the geometric normal; always on the geometric normal's
    /// side.
    pub shading_normal: Vec3,
    /// The triangle's material id.
    pub material_id: u32,
    /// The triangle id.
    pub triangle: u32,
    /// Barycentric coordinate of vertex 1 (the hit's [`Hit::b1`]): with `b2`, what a caller
    /// interpolates its own per-vertex data with (texture coordinates, say).
    pub b1: f32,
    /// Barycentric coordinate of vertex 2 (the hit's [`Hit::b2`]).
    pub b2: f32,
}

/// Which BVH layout [`Geometry`] builds and traverses. All come from the same BVH2 build
/// (`build.rs`) and give the same answers; they differ in speed (see docs/performance.md,
/// traversal layout).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum BvhLayout {
    /// Binary BVH, leaves of up to four triangles, 48-byte nodes with exact `f32` boxes, tested
    /// one box and one triangle at a time: the scalar traversal, kept as the oracle the wide
    /// layouts are tested against.
    Bvh2,
    /// 4-wide BVH (one 4-lane slab test per node, 128-byte nodes) whose leaves are packets of
    /// up to four triangles tested at once.
    Wide4,
    /// 8-wide BVH (one 8-lane slab test per node where the CPU has AVX2, else two 4-lane ones;
    /// 256-byte nodes) with the same four-triangle packets: the fastest on the benchmark
    /// scenes, so the default.
    #[default]
    Wide8,
}

/// The BVH nodes, in the chosen layout; the wide layouts hold their leaves' packets, the BVH2
/// layout's leaves index `Geometry::bvh_triangles`.
#[derive(Debug, Clone)]
enum Nodes {
    Bvh2(Vec<Bvh2Node>),
    Wide4(WideBvh<1>),
    Wide8(WideBvh<2>),
}

/// Traversal stack sizes kept on the call stack, zeroed for every ray (the smallest that fits
/// is used); a deeper BVH (only pathological inputs build one) traverses with a heap stack
/// instead. See docs/performance.md, traversal stack sizes.
const SMALL_STACK: usize = 32;
const LARGE_STACK: usize = 128;
/// Only for the two walks of any hit on a large tree (`WideBvh::two_walks`), so that one walk
/// is not given a stack this size to zero.
const HUGE_STACK: usize = 256;

/// Runs `$body` with `$s` bound to a zeroed traversal stack of at least `$len` entries of type
/// `$t`: an array on the call stack (the smallest of two sizes that fits, or of three for two
/// walks, `$two_walks`: compiled into the other traversals too, it made them spill), or a heap
/// vector for a pathologically deep tree. A macro rather than a closure, so that the body is
/// compiled inside its caller: a closure is one function whatever pulp's dispatch selected,
/// compiled for the baseline instruction set.
macro_rules! on_stack {
    ($len:expr, $t:ty, $two_walks:expr, |$s:ident| $body:expr) => {{
        let len: usize = $len;
        if len <= SMALL_STACK {
            let $s: &mut [$t] = &mut [<$t>::default(); SMALL_STACK];
            $body
        } else if len <= LARGE_STACK {
            let $s: &mut [$t] = &mut [<$t>::default(); LARGE_STACK];
            $body
        } else if $two_walks && len <= HUGE_STACK {
            let $s: &mut [$t] = &mut [<$t>::default(); HUGE_STACK];
            $body
        } else {
            let $s: &mut [$t] = &mut vec![<$t>::default(); len];
            $body
        }
    }};
}

/// The most triangles a [`Geometry`] holds: 2³⁰, so that a triangle's place in the wide
/// layouts' packets (`4·packet + lane`) fits in a `u32`. (At about 100 bytes per triangle that
/// is 100 GiB.)
pub const MAX_TRIANGLES: usize = 1 << 30;

/// The built BVH over all kept triangles. `Send + Sync`: trace from any number of threads.
///
/// Each triangle's vertices are stored once, in the BVH's leaves (the wide layouts' packets or
/// the BVH2 layout's `bvh_triangles`), exactly as given: [`Geometry::triangle`] reads them
/// back from there through `slots`.
#[derive(Debug, Clone)]
pub struct Geometry {
    /// Material id, by triangle id.
    material_ids: Vec<u32>,
    /// Where each triangle is stored, by id: `4·packet + lane` (its first lane) in the wide
    /// layouts, the index into `bvh_triangles` in the BVH2 layout.
    slots: Vec<u32>,
    /// The shading normals of the meshes that have them, in id order.
    shading: Vec<ShadingNormals>,
    /// BVH nodes (obvhs layouts).
    nodes: Nodes,
    /// How many traversal stack entries this BVH can need (from its depth).
    stack_len: usize,
    /// BVH2 layout only: the triangles in leaf order, as the hot path reads them.
    bvh_triangles: Vec<TriSoa>,
    /// BVH2 layout only: the id of each entry of `bvh_triangles`.
    bvh_ids: Vec<u32>,
    report: BuildReport,
    bounds: (Vec3, Vec3),
    /// The largest vertex coordinate in magnitude, for the wide layouts' triangle screen
    /// (`PreparedRay::set_screen`).
    coordinate_bound: f32,
    /// The instruction set the wide traversals are compiled for, detected at build time:
    /// x86-64-v3 (AVX2) where the CPU has it, else the baseline. Both run the same operations
    /// (no fused multiply-adds: Rust never contracts), so the answers are the same bits.
    arch: pulp::Arch,
    /// AVX2 where the CPU has it (and `arch` is not forced to the baseline): the 8-wide
    /// layout's nodes are then tested with one 8-lane slab test instead of two 4-lane ones.
    #[cfg(target_arch = "x86_64")]
    v3: Option<pulp::x86::V3>,
}

/// The shading normals of one mesh that has them: the mesh's per-vertex normals and the vertex
/// indices of its kept triangles, ids `first..first + indices.len()`. (As the mesh gives them,
/// shared vertices shared: 12 bytes per vertex and 12 per triangle, not 36 per triangle.)
#[derive(Debug, Clone)]
struct ShadingNormals {
    first: u32,
    normals: Vec<Vec3>,
    indices: Vec<[u32; 3]>,
}

impl Geometry {
    /// Validates the meshes, drops (and counts) triangles with zero area or a non-finite
    /// coordinate, and builds the BVH over the rest.
    ///
    /// The meshes are only borrowed, so they stay in memory beside the geometry (and a mesh
    /// that loses a triangle is copied); [`Geometry::build_owned`] builds the same geometry
    /// and frees each part of the meshes once it is used, which is what a large scene needs.
    ///
    /// # Errors
    /// [`GeometryError::IndexOutOfRange`], [`GeometryError::NormalCountMismatch`] and
    /// [`GeometryError::MaterialCountMismatch`] for malformed meshes (checked before anything is
    /// dropped), [`GeometryError::EmptyScene`] if no triangle is left, and
    /// [`GeometryError::TooManyTriangles`] beyond [`MAX_TRIANGLES`].
    pub fn build(meshes: &[TriangleMesh]) -> Result<Geometry, GeometryError> {
        Geometry::build_with_layout(meshes, BvhLayout::default())
    }

    /// [`Geometry::build`] with a chosen BVH layout (the default is the fastest on the CPU; the
    /// other is kept for comparison and benchmarks).
    ///
    /// # Errors
    /// As [`Geometry::build`].
    pub fn build_with_layout(
        meshes: &[TriangleMesh],
        layout: BvhLayout,
    ) -> Result<Geometry, GeometryError> {
        Geometry::build_from(meshes.iter().map(Cow::Borrowed).collect(), layout)
    }

    /// [`Geometry::build`], consuming the meshes: each mesh's material ids are freed once
    /// copied, its positions and indices once the BVH's leaves hold the triangles (its normals
    /// and indices are kept if it has shading normals). Same geometry, same ids, same answers.
    ///
    /// # Errors
    /// As [`Geometry::build`].
    pub fn build_owned(meshes: Vec<TriangleMesh>) -> Result<Geometry, GeometryError> {
        Geometry::build_owned_with_layout(meshes, BvhLayout::default())
    }

    /// [`Geometry::build_owned`] with a chosen BVH layout.
    ///
    /// # Errors
    /// As [`Geometry::build`].
    pub fn build_owned_with_layout(
        meshes: Vec<TriangleMesh>,
        layout: BvhLayout,
    ) -> Result<Geometry, GeometryError> {
        Geometry::build_from(meshes.into_iter().map(Cow::Owned).collect(), layout)
    }

    /// The build, on borrowed or owned meshes. Its steps free what they no longer need before
    /// the next allocates (see `build.rs` for the peak and where its bytes go).
    fn build_from(
        mut meshes: Vec<Cow<'_, TriangleMesh>>,
        layout: BvhLayout,
    ) -> Result<Geometry, GeometryError> {
        for (m, mesh) in meshes.iter().enumerate() {
            validate_mesh(m, mesh)?;
        }
        let mut report = BuildReport::default();
        for mesh in &mut meshes {
            drop_bad_triangles(mesh, &mut report);
        }
        let kept: usize = meshes.iter().map(|m| m.indices.len()).sum();
        report.kept = kept;
        if kept == 0 {
            return Err(GeometryError::EmptyScene {
                dropped_degenerate: report.dropped_degenerate,
                dropped_non_finite: report.dropped_non_finite,
            });
        }
        if kept > MAX_TRIANGLES {
            return Err(GeometryError::TooManyTriangles { count: kept });
        }

        // Material ids, by id; an owned mesh's own list is freed once copied. `starts[m]` is
        // the id of mesh m's first triangle.
        let mut material_ids = Vec::with_capacity(kept);
        let mut starts = Vec::with_capacity(meshes.len());
        for mesh in &mut meshes {
            starts.push(material_ids.len());
            material_ids.extend_from_slice(&mesh.material_ids);
            if let Cow::Owned(m) = mesh {
                m.material_ids = Vec::new();
            }
        }

        let mut min = Vec3::splat(f32::INFINITY);
        let mut max = Vec3::splat(f32::NEG_INFINITY);
        let mut prims = Vec::with_capacity(kept);
        for mesh in &meshes {
            for idx in &mesh.indices {
                let p = idx.map(|i| mesh.positions[i as usize]);
                let lo = p[0].min(p[1]).min(p[2]);
                let hi = p[0].max(p[1]).max(p[2]);
                min = min.min(lo);
                max = max.max(hi);
                prims.push(build::Prim::new(lo, hi, prims.len() as u32));
            }
        }
        // The build consumes the prims; the tree's nodes and leaf order are all that is kept.
        let mut bvh = build::build_bvh2(prims).0;
        let bvh_nodes = std::mem::take(&mut bvh.nodes);
        let primitive_indices = std::mem::take(&mut bvh.primitive_indices);
        drop(bvh);

        // Triangle `id` as the hot path reads it, from its mesh.
        let triangle = |id: u32| {
            let m = starts.partition_point(|&s| s <= id as usize) - 1;
            let mesh = &meshes[m];
            TriSoa::new(mesh.indices[id as usize - starts[m]].map(|i| mesh.positions[i as usize]))
        };
        let mut slots = vec![0u32; kept];
        // The BVH2 traversal pushes at most one entry per level below the root; the wide BVH
        // knows its own bound.
        let (nodes, stack_len, bvh_triangles, bvh_ids) = match layout {
            BvhLayout::Bvh2 => {
                let depth = bvh2_depth(&bvh_nodes);
                let mut tris = Vec::with_capacity(kept);
                for (k, &id) in primitive_indices.iter().enumerate() {
                    slots[id as usize] = k as u32;
                    tris.push(triangle(id));
                }
                (Nodes::Bvh2(bvh_nodes), depth, tris, primitive_indices)
            }
            BvhLayout::Wide4 => {
                let (mut w, leaves) = WideBvh::<1>::topology(&bvh_nodes);
                drop(bvh_nodes);
                w.fill_packets(&leaves, &primitive_indices, triangle, &mut slots);
                let depth = w.stack_len();
                (Nodes::Wide4(w), depth, Vec::new(), Vec::new())
            }
            BvhLayout::Wide8 => {
                let (mut w, leaves) = WideBvh::<2>::topology(&bvh_nodes);
                drop(bvh_nodes);
                w.fill_packets(&leaves, &primitive_indices, triangle, &mut slots);
                let depth = w.stack_len();
                (Nodes::Wide8(w), depth, Vec::new(), Vec::new())
            }
        };

        // The shading normals move out of the meshes that have them (a borrowed mesh's are
        // copied); the rest of each owned mesh is freed here.
        let mut shading = Vec::new();
        for (mesh, first) in meshes.into_iter().zip(starts) {
            if mesh.normals.is_none() || mesh.indices.is_empty() {
                continue;
            }
            let (normals, indices) = match mesh {
                Cow::Owned(m) => (m.normals.unwrap_or_default(), m.indices),
                Cow::Borrowed(m) => (m.normals.clone().unwrap_or_default(), m.indices.clone()),
            };
            shading.push(ShadingNormals {
                first: first as u32,
                normals,
                indices,
            });
        }

        Ok(Geometry {
            material_ids,
            slots,
            shading,
            nodes,
            stack_len,
            bvh_triangles,
            bvh_ids,
            report,
            bounds: (min, max),
            coordinate_bound: min.abs().max(max.abs()).max_element(),
            arch: pulp::Arch::new(),
            #[cfg(target_arch = "x86_64")]
            v3: pulp::x86::V3::try_new(),
        })
    }

    /// What the build kept and dropped.
    #[must_use]
    pub fn report(&self) -> &BuildReport {
        &self.report
    }

    /// The number of kept triangles; ids are `0..triangle_count()`, in input order (mesh after
    /// mesh) with dropped triangles skipped.
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.material_ids.len()
    }

    /// The kept triangle with this id: its vertices bit for bit as given to the build.
    ///
    /// # Panics
    /// If `id >= triangle_count()` (ids come from hits, so this is a caller bug); see
    /// [`Geometry::get_triangle`] for a checked lookup.
    #[must_use]
    pub fn triangle(&self, id: u32) -> Triangle {
        Triangle {
            p: self.stored(id).vertices(),
            material_id: self.material_ids[id as usize],
        }
    }

    /// The material id of triangle `id` (what `triangle(id).material_id` gives, without
    /// reading the vertices).
    ///
    /// # Panics
    /// If `id >= triangle_count()`.
    #[must_use]
    pub fn material_id(&self, id: u32) -> u32 {
        self.material_ids[id as usize]
    }

    /// The kept triangle with this id, or `None` if there is none.
    #[must_use]
    pub fn get_triangle(&self, id: u32) -> Option<Triangle> {
        ((id as usize) < self.triangle_count()).then(|| self.triangle(id))
    }

    /// All kept triangles, by id.
    pub fn triangles(&self) -> impl ExactSizeIterator<Item = Triangle> + '_ {
        (0..self.triangle_count() as u32).map(|id| self.triangle(id))
    }

    /// `(min, max)` corners of the box around all kept triangles.
    #[must_use]
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    /// The heap bytes this geometry holds, per structure (name, bytes): what a triangle costs
    /// once built (the build's transient peak is larger; see `build.rs`). Large node and packet
    /// arrays count here too where they live in a mapping on huge pages instead (`pages.rs`).
    #[must_use]
    pub fn heap_bytes(&self) -> Vec<(&'static str, usize)> {
        let mut out = vec![
            (
                "material ids",
                self.material_ids.capacity() * size_of::<u32>(),
            ),
            ("triangle slots", self.slots.capacity() * size_of::<u32>()),
            (
                "shading normals",
                self.shading
                    .iter()
                    .map(|s| {
                        s.normals.capacity() * size_of::<Vec3>()
                            + s.indices.capacity() * size_of::<[u32; 3]>()
                    })
                    .sum::<usize>()
                    + self.shading.capacity() * size_of::<ShadingNormals>(),
            ),
        ];
        match &self.nodes {
            Nodes::Bvh2(n) => out.extend([
                ("bvh2 nodes", n.capacity() * size_of::<Bvh2Node>()),
                (
                    "bvh2 triangles",
                    self.bvh_triangles.capacity() * size_of::<TriSoa>(),
                ),
                (
                    "bvh2 triangle ids",
                    self.bvh_ids.capacity() * size_of::<u32>(),
                ),
            ]),
            Nodes::Wide4(w) => out.extend(w.heap_bytes()),
            Nodes::Wide8(w) => out.extend(w.heap_bytes()),
        }
        out
    }

    /// Triangle `id` as stored in the BVH's leaves.
    #[inline]
    fn stored(&self, id: u32) -> TriSoa {
        let slot = self.slots[id as usize];
        match &self.nodes {
            Nodes::Bvh2(_) => self.bvh_triangles[slot as usize],
            Nodes::Wide4(w) => w.triangle(slot),
            Nodes::Wide8(w) => w.triangle(slot),
        }
    }

    /// The vertex shading normals of triangle `id`, if its mesh has them.
    #[inline]
    fn vertex_normals(&self, id: u32) -> Option<[Vec3; 3]> {
        if self.shading.is_empty() {
            return None;
        }
        let k = self.shading.partition_point(|s| s.first <= id);
        let s = &self.shading[k.checked_sub(1)?];
        let idx = s.indices.get((id - s.first) as usize)?;
        Some(idx.map(|i| s.normals[i as usize]))
    }

    /// The closest hit with `t` in `(0, ray.t_max)`, or `None`.
    ///
    /// Precisely: a hit is reported only when its `t` exceeds the bound `δt` on its own rounding
    /// error and `t + δt < t_max` (see [`Ray`] for why that makes offsets robust); `δt` is a
    /// few ulps of the distances involved. A ray that cannot hit anything (non-finite origin or
    /// direction, zero direction, NaN `t_max`) returns `None`.
    #[must_use]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !PreparedRay::traceable(ray) {
            return None;
        }
        let mut r = PreparedRay::prepare(ray, self.coordinate_bound);
        self.trace(Closest(&mut r))
    }

    /// The closest hits of many rays: `hits[i]` is exactly what [`Geometry::intersect`]
    /// returns for `rays[i]`.
    ///
    /// Made for a coherent batch, such as a gather's rays: they are traced one after the other,
    /// in the caller's order, within one run-time dispatch whose setup is then paid once (a
    /// stratified gather's consecutive rays are neighbours, so they visit mostly the same nodes
    /// while those are in cache). Ray packets and sorting the rays first lost to this (see
    /// docs/performance.md, streams and two walks). For independent rays that share no path
    /// through the tree, [`Geometry::intersect_stream`].
    ///
    /// # Panics
    /// If `rays` and `hits` differ in length.
    pub fn intersect_many(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), hits.len(), "one hit slot per ray");
        self.trace(Many(rays, hits, false));
    }

    /// The closest hits of many incoherent rays (one bounce of many paths, from all over the
    /// scene): `hits[i]` is exactly what [`Geometry::intersect`] returns for `rays[i]`.
    ///
    /// On a tree larger than the caches (the wide layouts' large trees, above 1 MiB), eight
    /// rays are kept in flight, each taking one traversal step in turn, so that one ray's wait
    /// for memory overlaps the others' work. On a tree that fits in cache that only adds work,
    /// so there the rays are traced one at a time, as `intersect_many` does (see
    /// docs/performance.md, streams and two walks).
    ///
    /// # Panics
    /// If `rays` and `hits` differ in length.
    pub fn intersect_stream(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), hits.len(), "one hit slot per ray");
        self.trace(Many(rays, hits, true));
    }

    /// Whether each of many incoherent rays is occluded: `occluded[i]` is exactly what
    /// [`Geometry::occluded`] returns for `rays[i]`, traced as
    /// [`Geometry::intersect_stream`] traces its rays.
    ///
    /// # Panics
    /// If `rays` and `occluded` differ in length.
    pub fn occluded_stream(&self, rays: &[Ray], occluded: &mut [bool]) {
        assert_eq!(rays.len(), occluded.len(), "one answer slot per ray");
        self.trace(Many(rays, occluded, true));
    }

    /// Whether anything is hit with `t` in `(0, ray.t_max)` (with the same error margins as
    /// [`Geometry::intersect`]). For shadow rays built with [`Ray::spawn_to`]. On a tree larger
    /// than the caches, the ray is traced as two walks that take steps in turn, so that one's
    /// wait for memory overlaps the other's work.
    #[must_use]
    pub fn occluded(&self, ray: &Ray) -> bool {
        if !PreparedRay::traceable(ray) {
            return false;
        }
        let mut r = PreparedRay::prepare(ray, self.coordinate_bound);
        self.trace(Any(&mut r))
    }

    /// The surface point of a hit returned by [`Geometry::intersect`]. The ray is not needed
    /// for anything (the geometric normal is deliberately not flipped toward it); it is taken so
    /// that a future differential or error term can use it without an API change.
    ///
    /// # Panics
    /// If `hit.triangle` is not a valid id (hits from this geometry always are).
    #[must_use]
    pub fn surface(&self, _ray: &Ray, hit: &Hit) -> SurfacePoint {
        let stored = self.stored(hit.triangle);
        let ng = stored.normal();
        let shading_normal = self
            .vertex_normals(hit.triangle)
            .map(|n| {
                let b0 = 1.0 - hit.b1 - hit.b2;
                let ns = (b0 * n[0] + hit.b1 * n[1] + hit.b2 * n[2]).normalize_or_zero();
                if ns == Vec3::ZERO {
                    ng
                } else if ns.dot(ng) < 0.0 {
                    -ns
                } else {
                    ns
                }
            })
            .unwrap_or(ng);
        let tri = Triangle {
            p: stored.vertices(),
            material_id: self.material_ids[hit.triangle as usize],
        };
        SurfacePoint {
            position: tri.point(hit.b1, hit.b2),
            geometric_normal: ng,
            shading_normal,
            material_id: tri.material_id,
            triangle: hit.triangle,
            b1: hit.b1,
            b2: hit.b2,
        }
    }

    /// [`Geometry::intersect`] without the BVH: the same triangle test on every triangle, in
    /// id order. O(n); the reference that the BVH is tested against.
    #[must_use]
    pub fn intersect_brute_force(&self, ray: &Ray) -> Option<Hit> {
        let r = PreparedRay::new(ray)?;
        let mut t_best = r.t_max;
        let mut best = None;
        for (id, tri) in self.triangles().enumerate() {
            let soa = TriSoa::new(tri.p);
            let h = match r.kz() {
                0 => intersect_triangle::<0>(&soa, &r, t_best),
                1 => intersect_triangle::<1>(&soa, &r, t_best),
                _ => intersect_triangle::<2>(&soa, &r, t_best),
            };
            if let Some(h) = h {
                t_best = h.t;
                best = Some(Hit {
                    t: h.t,
                    triangle: id as u32,
                    b1: h.b1,
                    b2: h.b2,
                });
            }
        }
        best
    }

    /// [`Geometry::occluded`] without the BVH (O(n) reference).
    #[must_use]
    pub fn occluded_brute_force(&self, ray: &Ray) -> bool {
        let Some(r) = PreparedRay::new(ray) else {
            return false;
        };
        self.triangles().any(|tri| {
            let soa = TriSoa::new(tri.p);
            match r.kz() {
                0 => intersect_triangle::<0>(&soa, &r, r.t_max),
                1 => intersect_triangle::<1>(&soa, &r, r.t_max),
                _ => intersect_triangle::<2>(&soa, &r, r.t_max),
            }
            .is_some()
        })
    }

    /// The number of BVH nodes (for statistics and benchmarks).
    #[must_use]
    pub fn node_count(&self) -> usize {
        match &self.nodes {
            Nodes::Bvh2(n) => n.len(),
            Nodes::Wide4(w) => w.node_count(),
            Nodes::Wide8(w) => w.node_count(),
        }
    }

    /// Whether [`Geometry::intersect_stream`] and [`Geometry::occluded_stream`] keep several
    /// rays in flight here (a wide layout's tree larger than the caches). Where they do not,
    /// they trace one ray at a time, and a caller that gathers rays into batches for them only
    /// pays for the bookkeeping (see docs/performance.md, streams and two walks).
    #[must_use]
    pub fn streams(&self) -> bool {
        match &self.nodes {
            Nodes::Bvh2(_) => false,
            Nodes::Wide4(w) => w.large(),
            Nodes::Wide8(w) => w.large(),
        }
    }

    /// The BVH layout this geometry was built with.
    #[must_use]
    pub fn layout(&self) -> BvhLayout {
        match &self.nodes {
            Nodes::Bvh2(_) => BvhLayout::Bvh2,
            Nodes::Wide4(_) => BvhLayout::Wide4,
            Nodes::Wide8(_) => BvhLayout::Wide8,
        }
    }

    /// Runs `job` on this BVH: the scalar traversal for the BVH2 layout; on the wide layouts,
    /// the traversal compiled for the CPU found at build time, with the 8-lane node test where
    /// there is AVX2.
    #[inline(always)]
    fn trace<J: Job>(&self, job: J) -> J::Output {
        match &self.nodes {
            Nodes::Bvh2(n) => job.bvh2(self, n),
            Nodes::Wide4(w) => self.lanes4(w, job),
            Nodes::Wide8(w) => {
                #[cfg(target_arch = "x86_64")]
                if let Some(v3) = self.v3 {
                    let g = self;
                    return if w.large() {
                        let test = Lanes8::<true>(v3);
                        pulp::Simd::vectorize(v3, WideOp { w, g, job, test })
                    } else {
                        let test = Lanes8::<false>(v3);
                        pulp::Simd::vectorize(v3, WideOp { w, g, job, test })
                    };
                }
                self.lanes4(w, job)
            }
        }
    }

    /// Runs `job` on wide BVH `w` with the four-lane node test, compiled for the instruction
    /// set pulp detected. Out of line: inlined, its two dispatches cost the 8-lane test's
    /// callers instructions on every ray.
    #[inline(never)]
    fn lanes4<const G: usize, J: Job>(&self, w: &WideBvh<G>, job: J) -> J::Output {
        let g = self;
        if w.large() {
            self.arch.dispatch(WideOp {
                w,
                g,
                job,
                test: Lanes4::<true>,
            })
        } else {
            self.arch.dispatch(WideOp {
                w,
                g,
                job,
                test: Lanes4::<false>,
            })
        }
    }

    /// Runs `f` with a traversal stack deep enough for this BVH: on the call stack normally
    /// (the smallest of two sizes that fits, since it is zeroed for every ray), on the heap for
    /// a pathologically deep tree.
    #[inline(always)]
    fn with_stack<T: Copy + Default, R>(&self, f: impl FnOnce(&mut [T]) -> R) -> R {
        if self.stack_len <= SMALL_STACK {
            f(&mut [T::default(); SMALL_STACK])
        } else if self.stack_len <= LARGE_STACK {
            f(&mut [T::default(); LARGE_STACK])
        } else {
            f(&mut vec![T::default(); self.stack_len])
        }
    }

    /// BVH2 closest hit: returns the index into `bvh_triangles` and the hit.
    #[inline(always)]
    fn bvh2_closest<const KZ: usize>(
        &self,
        nodes: &[Bvh2Node],
        r: &PreparedRay,
        stack: &mut [UVec2],
    ) -> Option<(usize, TriHit)> {
        let mut best: Option<(usize, TriHit)> = None;
        let mut t_best = r.t_max;
        let mut leaf = |node: &Bvh2Node, t_best: &mut f32| {
            let first = node.first_index as usize;
            for i in first..first + node.prim_count as usize {
                if let Some(h) = intersect_triangle::<KZ>(&self.bvh_triangles[i], r, *t_best) {
                    *t_best = h.t;
                    best = Some((i, h));
                }
            }
        };

        let root = &nodes[0];
        if box_entry(root.aabb().min, root.aabb().max, r, t_best) == f32::INFINITY {
            return None;
        }
        if root.is_leaf() {
            leaf(root, &mut t_best);
            return best;
        }
        let mut sp = 0;
        let mut pair = root.first_index as usize;
        loop {
            // Test both children; visit the nearer first.
            let mut a = &nodes[pair];
            let mut b = &nodes[pair + 1];
            let mut ta = box_entry(a.aabb().min, a.aabb().max, r, t_best);
            let mut tb = box_entry(b.aabb().min, b.aabb().max, r, t_best);
            if ta > tb {
                std::mem::swap(&mut a, &mut b);
                std::mem::swap(&mut ta, &mut tb);
            }
            let mut next = None;
            if ta != f32::INFINITY {
                if a.is_leaf() {
                    leaf(a, &mut t_best);
                } else {
                    next = Some(a.first_index as usize);
                }
            }
            // Re-check the farther child against a closer hit just found in the nearer leaf
            // (a miss is ∞, which must not pass when t_best is still an infinite t_max).
            if tb != f32::INFINITY && tb <= t_best {
                if b.is_leaf() {
                    leaf(b, &mut t_best);
                } else if next.is_some() {
                    stack[sp].x = b.first_index;
                    sp += 1;
                } else {
                    next = Some(b.first_index as usize);
                }
            }
            match next {
                Some(n) => pair = n,
                None => {
                    if sp == 0 {
                        return best;
                    }
                    sp -= 1;
                    pair = stack[sp].x as usize;
                }
            }
        }
    }

    /// BVH2 any hit.
    #[inline(always)]
    fn bvh2_any<const KZ: usize>(
        &self,
        nodes: &[Bvh2Node],
        r: &PreparedRay,
        stack: &mut [UVec2],
    ) -> bool {
        let leaf = |node: &Bvh2Node| {
            let first = node.first_index as usize;
            (first..first + node.prim_count as usize)
                .any(|i| intersect_triangle::<KZ>(&self.bvh_triangles[i], r, r.t_max).is_some())
        };
        let root = &nodes[0];
        if box_entry(root.aabb().min, root.aabb().max, r, r.t_max) == f32::INFINITY {
            return false;
        }
        if root.is_leaf() {
            return leaf(root);
        }
        let mut sp = 0;
        let mut pair = root.first_index as usize;
        loop {
            let a = &nodes[pair];
            let b = &nodes[pair + 1];
            let mut next = None;
            if box_entry(a.aabb().min, a.aabb().max, r, r.t_max) != f32::INFINITY {
                if a.is_leaf() {
                    if leaf(a) {
                        return true;
                    }
                } else {
                    next = Some(a.first_index as usize);
                }
            }
            if box_entry(b.aabb().min, b.aabb().max, r, r.t_max) != f32::INFINITY {
                if b.is_leaf() {
                    if leaf(b) {
                        return true;
                    }
                } else if next.is_some() {
                    stack[sp].x = b.first_index;
                    sp += 1;
                } else {
                    next = Some(b.first_index as usize);
                }
            }
            match next {
                Some(n) => pair = n,
                None => {
                    if sp == 0 {
                        return false;
                    }
                    sp -= 1;
                    pair = stack[sp].x as usize;
                }
            }
        }
    }
}

/// What [`Geometry::trace`] computes, on each layout. The one-ray jobs take the ray prepared
/// outside the dispatched function: prepared in there, its fields compete for registers with
/// the traversal's, and LLVM spills them (see docs/performance.md, node test and ray
/// preparation).
trait Job {
    type Output;
    /// On a wide BVH, with node test `test`.
    fn wide<const G: usize, N: NodeTest<G>>(
        self,
        w: &WideBvh<G>,
        g: &Geometry,
        test: N,
    ) -> Self::Output;
    /// On the BVH2 layout (the scalar oracle).
    fn bvh2(self, g: &Geometry, nodes: &[Bvh2Node]) -> Self::Output;
}

/// One ray's closest hit.
struct Closest<'a>(&'a mut PreparedRay);

impl Job for Closest<'_> {
    type Output = Option<Hit>;

    #[inline(always)]
    fn wide<const G: usize, N: NodeTest<G>>(
        self,
        w: &WideBvh<G>,
        g: &Geometry,
        test: N,
    ) -> Option<Hit> {
        on_stack!(g.stack_len, Entry, false, |s| Option::<Hit>::trace(
            w, self.0, s, test
        ))
    }

    /// Out of line (the BVH2 layout is the test oracle, not the default): inlined, its stack
    /// array made every `intersect` call set up a 1.2-KB frame and save five registers.
    #[inline(never)]
    fn bvh2(self, g: &Geometry, nodes: &[Bvh2Node]) -> Option<Hit> {
        self.0.finish();
        let r = &*self.0;
        let found = match r.kz() {
            0 => g.with_stack(|s| g.bvh2_closest::<0>(nodes, r, s)),
            1 => g.with_stack(|s| g.bvh2_closest::<1>(nodes, r, s)),
            _ => g.with_stack(|s| g.bvh2_closest::<2>(nodes, r, s)),
        };
        found.map(|(i, h)| Hit {
            t: h.t,
            triangle: g.bvh_ids[i],
            b1: h.b1,
            b2: h.b2,
        })
    }
}

/// Whether one ray hits anything.
struct Any<'a>(&'a mut PreparedRay);

impl Job for Any<'_> {
    type Output = bool;

    #[inline(always)]
    fn wide<const G: usize, N: NodeTest<G>>(self, w: &WideBvh<G>, g: &Geometry, test: N) -> bool {
        let walks = WideBvh::<G>::walks::<bool, N>();
        on_stack!(g.stack_len * walks, Entry, walks == 2, |s| bool::trace(
            w, self.0, s, test
        ))
    }

    /// Out of line, as `Closest::bvh2`.
    #[inline(never)]
    fn bvh2(self, g: &Geometry, nodes: &[Bvh2Node]) -> bool {
        self.0.finish();
        let r = &*self.0;
        match r.kz() {
            0 => g.with_stack(|s| g.bvh2_any::<0>(nodes, r, s)),
            1 => g.with_stack(|s| g.bvh2_any::<1>(nodes, r, s)),
            _ => g.with_stack(|s| g.bvh2_any::<2>(nodes, r, s)),
        }
    }
}

/// The answers for many rays, written in place (`hits[i]` for `rays[i]`), within one run-time
/// dispatch whose setup is then paid once: a ray at a time, in order, or where the third field
/// asks for a stream and the tree is large, as a stream ([`wide_stream`]).
struct Many<'a, A>(&'a [Ray], &'a mut [A], bool);

impl<A: Answer> Job for Many<'_, A> {
    type Output = ();

    #[inline(always)]
    fn wide<const G: usize, N: NodeTest<G>>(self, w: &WideBvh<G>, g: &Geometry, test: N) {
        if N::LARGE && self.2 {
            return wide_stream::<G, N, STREAM, A>(w, g, self.0, self.1, test);
        }
        let walks = WideBvh::<G>::walks::<A, N>();
        let len = g.stack_len * walks;
        for (ray, hit) in self.0.iter().zip(self.1.iter_mut()) {
            // No closure here: it would be compiled outside the dispatched instruction set.
            *hit = if PreparedRay::traceable(ray) {
                let mut r = PreparedRay::prepare(ray, g.coordinate_bound);
                on_stack!(len, Entry, walks == 2, |s| A::trace(w, &mut r, s, test))
            } else {
                A::MISS
            };
        }
    }

    fn bvh2(self, g: &Geometry, _: &[Bvh2Node]) {
        for (ray, hit) in self.0.iter().zip(self.1.iter_mut()) {
            *hit = A::bvh2(g, ray);
        }
    }
}

/// What a query answers for one ray, and how a wide traversal finds it: the closest hit
/// (`Option<Hit>`) or whether anything is hit (`bool`).
trait Answer: Query + Copy {
    /// The answer for a ray that hits nothing (or cannot hit anything).
    const MISS: Self;
    /// The answer from a finished traversal's `walk.best`.
    fn from_best<const G: usize>(w: &WideBvh<G>, best: Option<(u32, usize, TriHit)>) -> Self;
    /// One ray's answer on a wide BVH, with a stack of `WideBvh::walks` times its
    /// `stack_len` entries.
    #[inline(always)]
    fn trace<const G: usize, N: NodeTest<G>>(
        w: &WideBvh<G>,
        r: &mut PreparedRay,
        stack: &mut [Entry],
        test: N,
    ) -> Self {
        let (nodes, packets, ids) = w.arrays();
        if WideBvh::<G>::walks::<Self, N>() == 2 {
            let best = WideBvh::two_walks::<Self, N>(nodes, packets, ids, r, stack, test);
            return Self::from_best(w, best);
        }
        let mut walk = Walk::new(r);
        while !WideBvh::step::<Self, N>(nodes, packets, ids, r, stack, &mut walk, test) {}
        Self::from_best(w, walk.best)
    }
    /// One ray's answer on the BVH2 layout.
    fn bvh2(g: &Geometry, ray: &Ray) -> Self;
}

impl Query for Option<Hit> {
    const ANY: bool = false;
}

impl Answer for Option<Hit> {
    const MISS: Self = None;

    #[inline(always)]
    fn from_best<const G: usize>(w: &WideBvh<G>, best: Option<(u32, usize, TriHit)>) -> Self {
        best.map(|(p, lane, h)| Hit {
            t: h.t,
            triangle: w.id(p, lane),
            b1: h.b1,
            b2: h.b2,
        })
    }

    fn bvh2(g: &Geometry, ray: &Ray) -> Self {
        g.intersect(ray)
    }
}

impl Query for bool {
    const ANY: bool = true;
}

impl Answer for bool {
    const MISS: Self = false;

    #[inline(always)]
    fn from_best<const G: usize>(_: &WideBvh<G>, best: Option<(u32, usize, TriHit)>) -> Self {
        best.is_some()
    }

    fn bvh2(g: &Geometry, ray: &Ray) -> Self {
        g.occluded(ray)
    }
}

/// A [`Job`] on a wide BVH with node test `N`, as a pulp operation: `with_simd` is inlined
/// into pulp's function compiled for the detected instruction set, and the traversal (all
/// `#[inline(always)]`) into it. (A closure would be compiled once, for the baseline, and only
/// called from there.)
struct WideOp<'a, const G: usize, N, J> {
    w: &'a WideBvh<G>,
    g: &'a Geometry,
    job: J,
    test: N,
}

impl<const G: usize, N: NodeTest<G>, J: Job> pulp::WithSimd for WideOp<'_, G, N, J> {
    type Output = J::Output;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> J::Output {
        self.job.wide(self.w, self.g, self.test)
    }
}

/// Rays a stream keeps in flight (more than six gained nothing: see docs/performance.md,
/// streams and two walks).
const STREAM: usize = 8;

/// The answers for `rays` into `out`, `K` rays at a time: each ray in turn takes one step of
/// its own traversal ([`WideBvh::step`]), so that one ray's wait for a node or a packet
/// overlaps the others' work (memory-level parallelism). For large trees: on one in cache it
/// only adds work.
#[inline(always)]
fn wide_stream<const G: usize, N: NodeTest<G>, const K: usize, A: Answer>(
    w: &WideBvh<G>,
    g: &Geometry,
    rays: &[Ray],
    out: &mut [A],
    test: N,
) {
    let (nodes, packets, ids) = w.arrays();
    let len = g.stack_len;
    let mut stacks = vec![Entry::default(); K * len];
    let mut next = 0;
    let mut lanes: [Option<(usize, PreparedRay, Walk)>; K] = [None; K];
    for lane in &mut lanes {
        *lane = refill(g, rays, out, &mut next);
    }
    let mut active = lanes.iter().filter(|l| l.is_some()).count();
    while active > 0 {
        for (lane, stack) in lanes.iter_mut().zip(stacks.chunks_exact_mut(len)) {
            let Some((i, r, walk)) = lane else { continue };
            if WideBvh::step::<A, N>(nodes, packets, ids, r, stack, walk, test) {
                out[*i] = A::from_best(w, walk.best);
                *lane = refill(g, rays, out, &mut next);
                active -= usize::from(lane.is_none());
            }
        }
    }
}

/// The next traceable ray of `rays` from `*next` on, prepared, with its index and a walk at
/// the root; the answers of those skipped (untraceable) are set to a miss.
#[inline(always)]
fn refill<A: Answer>(
    g: &Geometry,
    rays: &[Ray],
    out: &mut [A],
    next: &mut usize,
) -> Option<(usize, PreparedRay, Walk)> {
    while *next < rays.len() {
        let i = *next;
        *next += 1;
        let ray = &rays[i];
        if PreparedRay::traceable(ray) {
            let r = PreparedRay::prepare(ray, g.coordinate_bound);
            let walk = Walk::new(&r);
            return Some((i, r, walk));
        }
        out[i] = A::MISS;
    }
    None
}

/// Checks a mesh's indices and array lengths.
fn validate_mesh(m: usize, mesh: &TriangleMesh) -> Result<(), GeometryError> {
    if let Some(normals) = &mesh.normals
        && normals.len() != mesh.positions.len()
    {
        return Err(GeometryError::NormalCountMismatch {
            mesh: m,
            normals: normals.len(),
            positions: mesh.positions.len(),
        });
    }
    if mesh.material_ids.len() != mesh.indices.len() {
        return Err(GeometryError::MaterialCountMismatch {
            mesh: m,
            material_ids: mesh.material_ids.len(),
            triangles: mesh.indices.len(),
        });
    }
    for (t, idx) in mesh.indices.iter().enumerate() {
        if let Some(&bad) = idx.iter().find(|&&i| i as usize >= mesh.positions.len()) {
            return Err(GeometryError::IndexOutOfRange {
                mesh: m,
                triangle: t,
                index: bad,
                vertex_count: mesh.positions.len(),
            });
        }
    }
    Ok(())
}

/// Drops (and counts) the triangles with a non-finite coordinate or zero area, keeping the
/// others in order. A borrowed mesh is copied only if it loses a triangle.
fn drop_bad_triangles(mesh: &mut Cow<'_, TriangleMesh>, report: &mut BuildReport) {
    let n = mesh.indices.len();
    let mut kept = 0;
    for t in 0..n {
        let idx = mesh.indices[t];
        let p = idx.map(|i| mesh.positions[i as usize]);
        // `Triangle::is_kept` is the one rule: callers that keep per-triangle data beside the
        // meshes (texture coordinates) map ids with it.
        if !Triangle::is_kept(&p) {
            if p.iter().all(|v| v.is_finite()) {
                report.dropped_degenerate += 1;
            } else {
                report.dropped_non_finite += 1;
            }
            continue;
        }
        if kept != t {
            let m = mesh.to_mut();
            m.indices[kept] = idx;
            m.material_ids[kept] = m.material_ids[t];
        }
        kept += 1;
    }
    if kept != n {
        let m = mesh.to_mut();
        m.indices.truncate(kept);
        m.material_ids.truncate(kept);
        m.indices.shrink_to_fit();
        m.material_ids.shrink_to_fit();
    }
}

/// The depth of the deepest BVH2 leaf (the root alone has depth 1).
fn bvh2_depth(nodes: &[Bvh2Node]) -> usize {
    let mut deepest = 0;
    let mut todo = vec![(0usize, 1usize)];
    while let Some((i, d)) = todo.pop() {
        deepest = deepest.max(d);
        let node = &nodes[i];
        if !node.is_leaf() {
            let c = node.first_index as usize;
            todo.push((c, d + 1));
            todo.push((c + 1, d + 1));
        }
    }
    deepest
}

/// Compile-time check that `Geometry` can be shared between threads.
const _: fn() = || {
    fn shareable<T: Send + Sync>() {}
    shareable::<Geometry>();
};

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit quad in the plane z = 0 facing +z, as two triangles.
    fn quad(z: f32, material: u32) -> TriangleMesh {
        TriangleMesh {
            positions: vec![
                Vec3::new(0.0, 0.0, z),
                Vec3::new(1.0, 0.0, z),
                Vec3::new(1.0, 1.0, z),
                Vec3::new(0.0, 1.0, z),
            ],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            normals: None,
            material_ids: vec![material, material],
        }
    }

    #[test]
    fn closest_of_two_quads_and_its_surface() {
        let g = Geometry::build(&[quad(0.0, 7), quad(1.0, 9)]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(g.triangle_count(), 4);
        assert_eq!(g.bounds(), (Vec3::ZERO, Vec3::ONE));
        let ray = Ray::new(Vec3::new(0.7, 0.2, 2.0), Vec3::NEG_Z);
        let hit = g.intersect(&ray).unwrap_or_else(|| panic!("missed"));
        // t = 1 exactly in exact arithmetic; the Woop test's few roundings of values ≤ 2 give a
        // relative error ≤ γ₇ ≈ 4.2e-7.
        assert!((hit.t - 1.0).abs() < 1e-6, "{}", hit.t);
        assert_eq!(g.triangle(hit.triangle).material_id, 9);
        let s = g.surface(&ray, &hit);
        assert_eq!(s.geometric_normal, Vec3::Z);
        assert_eq!(s.shading_normal, Vec3::Z);
        // The quad is axis-aligned, so the z of the barycentric point is exact; x and y carry
        // the barycentrics' few-ulp error: 1e-6 ≥ 8 ulps of 0.7.
        assert_eq!(s.position.z, 1.0);
        assert!((s.position.x - 0.7).abs() < 1e-6 && (s.position.y - 0.2).abs() < 1e-6);
        assert!(g.occluded(&ray));
        assert!(!g.occluded(&Ray { t_max: 0.5, ..ray }));
        assert!(
            g.intersect(&Ray::new(Vec3::new(2.0, 0.2, 2.0), Vec3::NEG_Z))
                .is_none()
        );
    }

    #[test]
    fn single_triangle_root_leaf() {
        let mut m = quad(0.0, 1);
        m.indices.truncate(1);
        m.material_ids.truncate(1);
        for layout in [BvhLayout::Bvh2, BvhLayout::Wide4, BvhLayout::Wide8] {
            let g = Geometry::build_with_layout(std::slice::from_ref(&m), layout)
                .unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(g.layout(), layout);
            let ray = Ray::new(Vec3::new(0.7, 0.2, -1.0), Vec3::Z);
            assert_eq!(g.intersect(&ray).map(|h| h.triangle), Some(0), "{layout:?}");
            assert!(g.occluded(&ray));
            let miss = Ray::new(Vec3::new(0.2, 0.7, -1.0), Vec3::Z);
            assert_eq!(g.intersect(&miss), None, "{layout:?}");
        }
    }

    /// A closed box of 1e-4 × 1e-7 × 1e-4 rotated about a tilted axis, faces numbered as
    /// material ids 0..6 (−x, +x, −y, +y, −z, +z).
    fn thin_slab() -> Geometry {
        let q = glam::Quat::from_axis_angle(Vec3::new(0.3, 0.2, 1.0).normalize(), 0.4);
        let h = Vec3::new(0.5e-4, 0.5e-7, 0.5e-4);
        let corner = |i: usize| {
            let s = |bit: usize| if i & bit == 0 { -1.0 } else { 1.0 };
            q * (Vec3::new(s(1), s(2), s(4)) * h)
        };
        let faces: [[u32; 4]; 6] = [
            [0, 4, 6, 2],
            [1, 3, 7, 5],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 2, 3, 1],
            [4, 5, 7, 6],
        ];
        let mut mesh = TriangleMesh {
            positions: (0..8).map(corner).collect(),
            ..TriangleMesh::default()
        };
        for (f, [a, b, c, d]) in faces.into_iter().enumerate() {
            mesh.indices.extend([[a, b, c], [a, c, d]]);
            mesh.material_ids.extend([f as u32; 2]);
        }
        Geometry::build(&[mesh]).unwrap_or_else(|e| panic!("{e}"))
    }

    /// Regression: a ray leaving the inside of a thin slab's bottom face at cos θ ≈ 7e-9 passes
    /// 3e-12 above the bottom edge of a side face, closer than the f32 edge functions can
    /// resolve (their error is ~u·R² with R ~ 1e-4). Without the f64 filter the side face was
    /// judged missed and the ray escaped.
    #[test]
    fn grazing_ray_along_a_thin_face_enters_the_adjacent_face() {
        let g = thin_slab();
        let p = Vec3::new(-5.537_509_4e-6, -4.625_895_3e-7, -1.314_264_8e-5);
        let d = Vec3::new(0.201_186_82, 0.207_230_27, -0.957_381_67);
        let ng = g.triangle(4).normal();
        let ray = Ray::spawn(p, ng, d);
        let hit = g
            .intersect(&ray)
            .unwrap_or_else(|| panic!("escaped: {ray:?}"));
        assert_eq!(g.triangle(hit.triangle).material_id, 4, "{hit:?}");
    }

    /// A reproducible stream of numbers in [−1, 1] (xorshift32 from `seed`).
    fn xorshift(mut seed: u32) -> impl FnMut() -> f32 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            seed as f32 / u32::MAX as f32 * 2.0 - 1.0
        }
    }

    /// An `n × n`-quad grid, vertex `(i, j)` at `vertex(i, j)`, two triangles per quad,
    /// material 0.
    fn grid(n: u32, mut vertex: impl FnMut(u32, u32) -> Vec3) -> TriangleMesh {
        let mut m = TriangleMesh::default();
        for j in 0..=n {
            for i in 0..=n {
                m.positions.push(vertex(i, j));
            }
        }
        for j in 0..n {
            for i in 0..n {
                let v = j * (n + 1) + i;
                m.indices
                    .extend([[v, v + n + 1, v + 1], [v + 1, v + n + 1, v + n + 2]]);
            }
        }
        m.material_ids = vec![0; m.indices.len()];
        m
    }

    /// `n` coplanar triangles nested about one centroid (also their boxes' centre), each
    /// 1.001 times the previous: the input that stalled PLOC.
    fn nested(n: u32) -> TriangleMesh {
        let shape = [
            Vec3::new(-1.0, -1.0, -1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let mut mesh = TriangleMesh::default();
        let mut scale = 1.0f32;
        for k in 0..n {
            mesh.positions.extend(shape.map(|p| p * scale));
            mesh.indices.push([3 * k, 3 * k + 1, 3 * k + 2]);
            scale *= 1.001;
        }
        mesh.material_ids = vec![0; n as usize];
        mesh
    }

    /// The build's primitives (box and index) of `mesh`'s triangles.
    fn prims_of(mesh: &TriangleMesh) -> Vec<build::Prim> {
        mesh.indices
            .iter()
            .enumerate()
            .map(|(k, t)| {
                let p = t.map(|i| mesh.positions[i as usize]);
                build::Prim::new(p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]), k as u32)
            })
            .collect()
    }

    #[test]
    fn nested_same_centroid_triangles_build_top_down_and_trace_like_brute_force() {
        let n = 3 * build::CLUSTER_LIMIT as u32;
        let mesh = nested(n);
        let prims = prims_of(&mesh);
        let (bvh, builder) = build::build_bvh2(prims.clone());
        assert_eq!(builder, build::Builder::TopDown);
        // Leaves of one to four primitives, every primitive in exactly one.
        let mut seen = vec![0u32; n as usize];
        let mut todo = vec![0usize];
        while let Some(i) = todo.pop() {
            let node = &bvh.nodes[i];
            if node.is_leaf() {
                assert!((1..=4).contains(&node.prim_count), "{node:?}");
                let f = node.first_index as usize;
                for &p in &bvh.primitive_indices[f..f + node.prim_count as usize] {
                    seen[p as usize] += 1;
                }
            } else {
                todo.extend([node.first_index as usize, node.first_index as usize + 1]);
            }
        }
        assert!(seen.iter().all(|&c| c == 1));
        // A small scene (two quads) is built with PLOC.
        assert_eq!(
            build::build_bvh2(prims[..4].to_vec()).1,
            build::Builder::Ploc
        );

        let mut next = xorshift(0x1234_5678_u32);
        for layout in [BvhLayout::Bvh2, BvhLayout::Wide4, BvhLayout::Wide8] {
            let g = Geometry::build_with_layout(std::slice::from_ref(&mesh), layout)
                .unwrap_or_else(|e| panic!("{e}"));
            for _ in 0..300 {
                let o = Vec3::new(next(), next(), next()) * 40.0;
                let d = (Vec3::new(next(), next(), next()) * 15.0 - o).normalize();
                let ray = Ray::new(o, d);
                let (a, b) = (g.intersect(&ray), g.intersect_brute_force(&ray));
                assert_eq!(
                    a.is_some(),
                    b.is_some(),
                    "{layout:?} {ray:?}: {a:?} vs {b:?}"
                );
                if let (Some(a), Some(b)) = (a, b) {
                    // The triangles are coplanar up to the rounding of their vertices
                    // (≤ u·37 ≈ 2.2e-6 off the plane at the largest scale, 1.001³⁰⁷² ≈ 22),
                    // so the closest hit is a tie between all those the ray passes, and
                    // each computed t is within its bound δt of the exact distance. With
                    // |d| = 1, |o| ≤ 70 and vertices within 37 of the origin, |p0 − o| ≤ 110
                    // and t ≤ 110: δt ≤ (γ₇ + γ₆)·110/|d·n| + γ₂·110 < 1e-4/|d·n|. Two
                    // answers differ by at most 2δt plus the vertices' 2 × 2.2e-6/|d·n|.
                    let cos = f64::from(d.dot(g.triangle(a.triangle).normal()).abs());
                    assert!(
                        f64::from((a.t - b.t).abs()) <= 4e-4 / cos,
                        "{layout:?} {ray:?}: {a:?} vs {b:?}"
                    );
                }
                assert_eq!(g.occluded(&ray), b.is_some(), "{layout:?} {ray:?}");
            }
        }
    }

    /// Nested triangles whose centroids drift apart as they grow (each 1.002 times the
    /// previous, its centroid 1.002 times farther out): SAH keeps peeling the largest few off,
    /// so the build switches to medians below `SAH_DEPTH_LIMIT` and the tree stays shallower
    /// (depth 94 against 117); it still traces like brute force.
    #[test]
    fn peeling_scenes_stay_shallow_and_trace_like_brute_force() {
        let n = 40000u32;
        let mut mesh = TriangleMesh::default();
        let mut scale = 1.0f32;
        for k in 0..n {
            let c = Vec3::new(1.0, 0.5, 0.25) * (scale * 1e-3);
            mesh.positions.extend([
                c + Vec3::new(-1.0, -1.0, 0.0) * scale,
                c + Vec3::new(1.0, -0.5, 0.2) * scale,
                c + Vec3::new(0.0, 1.0, -0.2) * scale,
            ]);
            mesh.indices.push([3 * k, 3 * k + 1, 3 * k + 2]);
            scale *= 1.002;
        }
        mesh.material_ids = vec![0; n as usize];
        let prims = prims_of(&mesh);
        let (bvh, builder) = build::build_bvh2(prims);
        assert_eq!(builder, build::Builder::TopDown);
        // At most SAH_DEPTH_LIMIT levels of SAH, then medians that halve the range down to
        // SWEEP_LIMIT primitives (⌈log₂ n⌉ levels at most), then sweeps that remove at least
        // one primitive per level (SWEEP_LIMIT levels at most). Without the limit: depth 117.
        let depth = bvh2_depth(&bvh.nodes);
        let bound =
            build::SAH_DEPTH_LIMIT + (f64::from(n)).log2().ceil() as usize + build::SWEEP_LIMIT;
        assert!(depth <= bound, "depth {depth} > {bound}");
        let g = Geometry::build(std::slice::from_ref(&mesh)).unwrap_or_else(|e| panic!("{e}"));
        let mut next = xorshift(0x0bad_cafe_u32);
        for _ in 0..100 {
            let o = Vec3::new(next(), next(), next()) * 30.0;
            let ray = Ray::new(o, Vec3::new(next(), next(), next()) * 10.0 - o);
            assert_eq!(
                g.intersect(&ray).map(|h| h.triangle),
                g.intersect_brute_force(&ray).map(|h| h.triangle),
                "{ray:?}"
            );
        }
    }

    /// A tree large enough for the large-tree traversal (prefetching, no shortcuts) and for its
    /// packets to go on huge pages (on Linux with transparent huge pages; 45 000 triangles,
    /// more than 2 MiB of packets) traces like brute force.
    #[test]
    fn a_large_tree_on_huge_pages_traces_like_brute_force() {
        let mesh = grid(150, |i, j| {
            let (x, z) = (i as f32 / 75.0 - 1.0, j as f32 / 75.0 - 1.0);
            Vec3::new(x, 0.2 * (7.0 * x).sin() * (5.0 * z).cos(), z)
        });
        let g = Geometry::build(std::slice::from_ref(&mesh)).unwrap_or_else(|e| panic!("{e}"));
        let Nodes::Wide8(w) = &g.nodes else {
            panic!("the default layout is Wide8")
        };
        assert!(w.large(), "not a large tree");
        assert!(g.streams());
        println!("packets on huge pages: {}", w.packets_on_huge_pages());
        let mut next = xorshift(0x5eed_1e55_u32);
        let mut hits = 0;
        let rays: Vec<Ray> = (0..300)
            .map(|_| {
                let o = Vec3::new(next(), next(), next()) * 3.0;
                Ray::new(o, Vec3::new(next(), next() * 0.2, next()) - o)
            })
            .collect();
        // The streams too (several rays in flight), which only a large tree gets.
        let mut many = vec![None; rays.len()];
        g.intersect_stream(&rays, &mut many);
        let mut occluded = vec![false; rays.len()];
        g.occluded_stream(&rays, &mut occluded);
        for ((ray, m), o) in rays.iter().zip(many).zip(occluded) {
            let (fast, brute) = (g.intersect(ray), g.intersect_brute_force(ray));
            assert_eq!(fast, brute, "{ray:?}");
            assert_eq!(m, brute, "intersect_stream: {ray:?}");
            assert_eq!(g.occluded(ray), brute.is_some(), "{ray:?}");
            assert_eq!(o, brute.is_some(), "occluded_stream: {ray:?}");
            hits += usize::from(brute.is_some());
        }
        assert!(hits > 100, "{hits} hits");
    }

    /// `g` with the large tree's traversal forced on (for a wide layout), and so its streams.
    fn forced_large(g: &Geometry) -> Geometry {
        let mut large = g.clone();
        match &mut large.nodes {
            Nodes::Wide4(w) => w.set_large(true),
            Nodes::Wide8(w) => w.set_large(true),
            Nodes::Bvh2(_) => {}
        }
        large
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(48))]

        /// The streams of `intersect_stream` and `occluded_stream` (several rays in flight,
        /// interleaved step by step, on a large tree) answer each ray exactly as tracing it
        /// alone does, on a large tree's traversal and on a small one's: for any number of rays
        /// (none, fewer than the stream holds, more), with rays that cannot hit anything among
        /// them (zero or NaN direction, zero `t_max`) and segments, on random triangle soups at
        /// the robustness tests' scales, through both dispatches (the detected instruction set
        /// and the baseline's 4-lane test).
        #[test]
        fn streams_answer_as_single_rays(
            seed in 1u32..,
            triangles in 1u32..160,
            len in 0usize..40,
            config in 0usize..4,
        ) {
            let (scale, shift) = [(1e-4, 0.0), (1.0, 0.0), (1e3, 0.0), (1.0, 1e5)][config];
            let mut next = xorshift(seed);
            let mut at = |spread: f32| {
                Vec3::new(next(), next(), next()) * spread * scale + Vec3::splat(shift)
            };
            let mut soup = TriangleMesh::default();
            for k in 0..triangles {
                let c = at(1.0);
                for _ in 0..3 {
                    soup.positions.push(c + (at(0.3) - Vec3::splat(shift)));
                }
                soup.indices.push([3 * k, 3 * k + 1, 3 * k + 2]);
                soup.material_ids.push(0);
            }
            let rays: Vec<Ray> = (0..len)
                .map(|i| {
                    let o = at(2.0);
                    let mut ray = Ray::new(o, at(0.5) - o);
                    match i % 7 {
                        1 => ray.t_max = 0.5,
                        3 => ray.direction = Vec3::ZERO,
                        4 => ray.direction = Vec3::NAN,
                        5 => ray.t_max = 0.0,
                        _ => {}
                    }
                    ray
                })
                .collect();
            for layout in [BvhLayout::Wide4, BvhLayout::Wide8] {
                let g = Geometry::build_with_layout(std::slice::from_ref(&soup), layout)
                    .map_err(|e| proptest::test_runner::TestCaseError::fail(e.to_string()))?;
                let baseline = Geometry {
                    arch: pulp::Arch::Scalar,
                    #[cfg(target_arch = "x86_64")]
                    v3: None,
                    ..g.clone()
                };
                for traced in [forced_large(&g), forced_large(&baseline), g.clone()] {
                    let mut many = vec![None; len];
                    traced.intersect_stream(&rays, &mut many);
                    let mut occluded = vec![true; len];
                    traced.occluded_stream(&rays, &mut occluded);
                    for ((ray, m), o) in rays.iter().zip(many).zip(occluded) {
                        let one = g.intersect(ray);
                        proptest::prop_assert_eq!(
                            m, one, "{:?} intersect_stream {:?}", layout, ray
                        );
                        proptest::prop_assert_eq!(traced.intersect(ray), one);
                        proptest::prop_assert_eq!(o, g.occluded(ray), "{:?} {:?}", layout, ray);
                        proptest::prop_assert_eq!(traced.occluded(ray), o);
                    }
                }
            }
        }
    }

    /// The wide traversals give the same bits whichever instruction set pulp dispatches to:
    /// the one detected here (x86-64-v3 on an AVX2 machine) and the baseline build, which
    /// runs on CPUs without it; and on a large tree's traversal or not (prefetching, which
    /// only the 8-lane test does, and the packet test without the screen's shortcut). (Rust
    /// never fuses a multiply and an add, so both evaluate the same IEEE operations in the
    /// same order.)
    #[test]
    fn dispatched_and_baseline_traversals_agree_bit_for_bit() {
        let mut mesh = nested(200);
        let slab = thin_slab();
        for (k, tri) in slab.triangles().enumerate() {
            let base = mesh.positions.len() as u32;
            mesh.positions.extend(tri.p.map(|p| p * 1e4));
            mesh.indices.push([base, base + 1, base + 2]);
            mesh.material_ids.push(k as u32);
        }
        // A wavy 32 × 32-quad grid through the middle (2048 triangles): a surface, whose BVH
        // has the pair leaves of the 8-wide layout.
        let wavy = grid(32, |i, j| {
            let (x, z) = (i as f32 / 16.0 - 1.0, j as f32 / 16.0 - 1.0);
            Vec3::new(x, 0.1 * (5.0 * x).sin() * (4.0 * z).cos(), z)
        });
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(wavy.positions);
        mesh.indices
            .extend(wavy.indices.iter().map(|t| t.map(|v| v + base)));
        mesh.material_ids.extend(wavy.material_ids);
        let mut next = xorshift(0x9E37_79B9_u32);
        for layout in [BvhLayout::Wide4, BvhLayout::Wide8] {
            let fast = Geometry::build_with_layout(std::slice::from_ref(&mesh), layout)
                .unwrap_or_else(|e| panic!("{e}"));
            let baseline = Geometry {
                arch: pulp::Arch::Scalar,
                #[cfg(target_arch = "x86_64")]
                v3: None,
                ..fast.clone()
            };
            let rays: Vec<Ray> = (0..2000)
                .map(|_| {
                    // From around the scene towards a point near its middle.
                    let o = Vec3::new(next(), next(), next()) * 3.0;
                    let target = Vec3::new(next(), next(), next()) * 0.5;
                    let mut ray = Ray::new(o, target - o);
                    if next() > 0.5 {
                        ray.t_max = 2.0 * next().abs();
                    }
                    ray
                })
                .collect();
            // The large tree's traversal, which this small tree would not get.
            let mut large = fast.clone();
            match &mut large.nodes {
                Nodes::Wide4(w) => w.set_large(true),
                Nodes::Wide8(w) => {
                    w.set_large(true);
                    // Pair leaves are on the path checked.
                    assert!(w.pair_count() > 0, "no pair leaves");
                }
                Nodes::Bvh2(_) => unreachable!("a wide layout was built"),
            }
            let mut many = vec![None; rays.len()];
            baseline.intersect_many(&rays, &mut many);
            // Enough hits for the comparison to mean something.
            let hits = many.iter().flatten().count();
            assert!(hits > 500, "{layout:?}: {hits} hits");
            for (ray, m) in rays.iter().zip(many) {
                let hit = fast.intersect(ray);
                assert_eq!(hit, baseline.intersect(ray), "{layout:?} {ray:?}");
                assert_eq!(hit, large.intersect(ray), "{layout:?} {ray:?}");
                assert_eq!(hit, m, "{layout:?} {ray:?}");
                let occluded = fast.occluded(ray);
                assert_eq!(occluded, baseline.occluded(ray), "{layout:?} {ray:?}");
                assert_eq!(occluded, large.occluded(ray), "{layout:?} {ray:?}");
            }
        }
    }

    #[test]
    fn the_default_layout_is_wide8() {
        let g = Geometry::build(&[quad(0.0, 0)]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(g.layout(), BvhLayout::Wide8);
        assert_eq!(BvhLayout::default(), BvhLayout::Wide8);
    }

    /// Meshes for the build-path tests: a soup with shading normals (one triangle
    /// degenerate, one non-finite), an empty mesh, a heightfield without normals, and a quad with
    /// normals; `soup` triangles in the soup.
    fn mixed_meshes(soup: u32) -> Vec<TriangleMesh> {
        let mut next = xorshift(0x2545_f491_u32);
        let mut a = TriangleMesh::default();
        for k in 0..soup {
            let c = Vec3::new(next(), next(), next()) * 3.0;
            for _ in 0..3 {
                a.positions
                    .push(c + Vec3::new(next(), next(), next()) * 0.2);
            }
            a.indices.push([3 * k, 3 * k + 1, 3 * k + 2]);
            a.material_ids.push(k % 5);
        }
        a.indices[3] = [0, 0, 1];
        a.positions[5] = Vec3::new(f32::NAN, 0.0, 0.0);
        a.normals = Some(
            (0..a.positions.len())
                .map(|_| Vec3::new(next(), next(), next()))
                .collect(),
        );
        let mut grid = grid(20, |i, j| {
            Vec3::new(i as f32 * 0.1, 0.05 * next() - 2.0, j as f32 * 0.1)
        });
        grid.material_ids.fill(7);
        let mut top = quad(4.0, 9);
        top.normals = Some(vec![Vec3::new(0.1, 0.2, 1.0); 4]);
        vec![a, TriangleMesh::default(), grid, top]
    }

    /// `build_owned` (which frees the meshes as it goes) builds the same geometry as `build`,
    /// on a scene built with PLOC and one built top down, in every layout: the same ids, the
    /// vertices bit for bit as given, the same hits and surface points.
    #[test]
    fn owned_and_borrowed_builds_agree_and_keep_the_input_bits() {
        for soup in [100, 3000] {
            let meshes = mixed_meshes(soup);
            // The kept triangles in id order: mesh after mesh, bad ones skipped.
            let kept: Vec<Triangle> = meshes
                .iter()
                .flat_map(|m| {
                    m.indices
                        .iter()
                        .zip(&m.material_ids)
                        .map(|(idx, &material_id)| Triangle {
                            p: idx.map(|i| m.positions[i as usize]),
                            material_id,
                        })
                })
                .filter(|t| t.p.iter().all(|v| v.is_finite()) && t.area() > 0.0)
                .collect();
            for layout in [BvhLayout::Bvh2, BvhLayout::Wide4, BvhLayout::Wide8] {
                let a =
                    Geometry::build_with_layout(&meshes, layout).unwrap_or_else(|e| panic!("{e}"));
                let b = Geometry::build_owned_with_layout(meshes.clone(), layout)
                    .unwrap_or_else(|e| panic!("{e}"));
                assert_eq!(a.report(), b.report());
                assert_eq!(
                    a.report().dropped_degenerate + a.report().dropped_non_finite,
                    2
                );
                assert_eq!(a.bounds(), b.bounds());
                assert_eq!(a.triangle_count(), kept.len());
                for (id, t) in kept.iter().enumerate() {
                    let id = id as u32;
                    assert_eq!(a.triangle(id), *t, "{layout:?} {id}");
                    assert_eq!(b.triangle(id), *t, "{layout:?} {id}");
                    assert_eq!(a.material_id(id), t.material_id);
                }
                assert!(a.triangles().eq(kept.iter().copied()));
                let mut next = xorshift(0x1357_9bdf_u32);
                let mut hits = 0;
                for _ in 0..2000 {
                    let o = Vec3::new(next(), next(), next()) * 6.0;
                    let ray = Ray::new(o, Vec3::new(next(), next(), next()) * 3.0 - o);
                    let (ha, hb) = (a.intersect(&ray), b.intersect(&ray));
                    assert_eq!(ha, hb, "{layout:?} {ray:?}");
                    if let Some(h) = ha {
                        hits += 1;
                        let s = a.surface(&ray, &h);
                        assert_eq!(s, b.surface(&ray, &h));
                        let tri = kept[h.triangle as usize];
                        assert_eq!(s.position, tri.point(h.b1, h.b2));
                        assert_eq!(s.geometric_normal, tri.normal());
                        assert_eq!(s.material_id, tri.material_id);
                    }
                }
                // Enough hits for the comparison to mean something.
                assert!(hits > 100, "{layout:?}: {hits} hits");
            }
        }
    }

    /// Shading normals come from the right mesh when several have them, around meshes that
    /// do not: each interpolates its own vertex normals (here constant per mesh).
    #[test]
    fn shading_normals_are_found_per_mesh() {
        let mut lower = quad(0.0, 0);
        lower.normals = Some(vec![Vec3::new(0.0, 0.6, 0.8); 4]);
        let plain = quad(1.0, 1);
        let mut upper = quad(2.0, 2);
        upper.normals = Some(vec![Vec3::new(0.6, 0.0, 0.8); 4]);
        let g = Geometry::build_owned(vec![lower, plain, upper]).unwrap_or_else(|e| panic!("{e}"));
        for (z, expected) in [
            (0.0, Vec3::new(0.0, 0.6, 0.8)),
            (1.0, Vec3::Z),
            (2.0, Vec3::new(0.6, 0.0, 0.8)),
        ] {
            let ray = Ray::new(Vec3::new(0.3, 0.6, z + 0.5), Vec3::NEG_Z);
            let hit = g.intersect(&ray).unwrap_or_else(|| panic!("missed {z}"));
            let s = g.surface(&ray, &hit);
            // Unit normals, interpolated with weights summing to 1 within a few ulps:
            // normalising leaves them within 1e-6.
            assert!((s.shading_normal - expected).length() < 1e-6, "{z}: {s:?}");
        }
    }

    /// What a built geometry holds per triangle, on a heightfield with shared vertices and no
    /// normals (the kind of mesh a large scene has): packets of four triangles (192 bytes)
    /// nearly full, their ids, 8-wide nodes, material ids and slots. The budget, 100 bytes per
    /// triangle, is the design target that keeps a 10⁶-triangle render under 150 bytes per
    /// triangle of peak memory (see docs/performance.md, memory per triangle).
    #[test]
    fn a_built_heightfield_holds_under_100_bytes_per_triangle() {
        let n = 64u32;
        let m = grid(n, |i, j| {
            let (x, z) = (i as f32 / n as f32, j as f32 / n as f32);
            Vec3::new(x, 0.05 * (7.0 * x).sin() * (5.0 * z).cos(), z)
        });
        let g = Geometry::build_owned(vec![m]).unwrap_or_else(|e| panic!("{e}"));
        let bytes = g.heap_bytes();
        let total: usize = bytes.iter().map(|(_, b)| b).sum();
        let per_triangle = total as f64 / g.triangle_count() as f64;
        assert!(
            per_triangle < 100.0,
            "{per_triangle} bytes per triangle: {bytes:?}"
        );
    }

    #[test]
    fn empty_input_is_an_error_not_a_panic() {
        let err = Geometry::build(&[]).err();
        assert_eq!(
            err,
            Some(GeometryError::EmptyScene {
                dropped_degenerate: 0,
                dropped_non_finite: 0
            })
        );
        let err = Geometry::build(&[TriangleMesh::default()]).err();
        assert!(matches!(err, Some(GeometryError::EmptyScene { .. })));
    }

    #[test]
    fn degenerate_and_non_finite_triangles_are_dropped_and_counted() {
        let mut m = quad(0.0, 3);
        m.positions.extend([
            Vec3::new(f32::NAN, 0.0, 0.0),
            Vec3::new(0.0, f32::INFINITY, 0.0),
            Vec3::new(2.0, 2.0, 0.0), // collinear with vertices 0 and 2
        ]);
        m.indices.extend([
            [0, 1, 4], // NaN
            [5, 1, 2], // infinite
            [0, 2, 6], // collinear: zero area
            [1, 1, 2], // repeated vertex: zero area
            [4, 5, 4], // non-finite and degenerate: counted once, as non-finite
        ]);
        m.material_ids.extend([3; 5]);
        let g = Geometry::build(&[m]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            *g.report(),
            BuildReport {
                kept: 2,
                dropped_degenerate: 2,
                dropped_non_finite: 3
            }
        );
        assert_eq!(g.bounds(), (Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0)));
        // Ids number the kept triangles in input order.
        assert_eq!(
            g.triangle(1).p,
            [Vec3::ZERO, Vec3::ONE.with_z(0.0), Vec3::Y]
        );
        assert!(g.get_triangle(2).is_none());
    }

    #[test]
    fn all_dropped_is_an_error_with_the_counts() {
        let m = TriangleMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(2.0, 0.0, 0.0), Vec3::NAN],
            indices: vec![[0, 1, 2], [0, 1, 3]],
            normals: None,
            material_ids: vec![0, 0],
        };
        let err = Geometry::build(&[m]).err();
        assert_eq!(
            err,
            Some(GeometryError::EmptyScene {
                dropped_degenerate: 1,
                dropped_non_finite: 1
            })
        );
        assert_eq!(
            err.map(|e| e.to_string()).unwrap_or_default(),
            "no triangles left after dropping 1 degenerate and 1 non-finite"
        );
    }

    #[test]
    fn malformed_meshes_are_typed_errors_naming_mesh_and_triangle() {
        let mut bad_index = quad(0.0, 0);
        bad_index.indices[1] = [0, 2, 4];
        let err = Geometry::build(&[quad(1.0, 0), bad_index]).err();
        assert_eq!(
            err,
            Some(GeometryError::IndexOutOfRange {
                mesh: 1,
                triangle: 1,
                index: 4,
                vertex_count: 4
            })
        );
        assert!(
            err.map(|e| e.to_string())
                .unwrap_or_default()
                .starts_with("mesh 1, triangle 1: vertex index 4 is out of range")
        );

        let mut bad_normals = quad(0.0, 0);
        bad_normals.normals = Some(vec![Vec3::Z; 3]);
        assert_eq!(
            Geometry::build(&[bad_normals]).err(),
            Some(GeometryError::NormalCountMismatch {
                mesh: 0,
                normals: 3,
                positions: 4
            })
        );

        let mut bad_materials = quad(0.0, 0);
        bad_materials.material_ids.push(1);
        assert_eq!(
            Geometry::build(&[bad_materials]).err(),
            Some(GeometryError::MaterialCountMismatch {
                mesh: 0,
                material_ids: 3,
                triangles: 2
            })
        );
    }

    #[test]
    fn shading_normals_interpolate_and_flip_to_the_geometric_side() {
        let mut m = quad(0.0, 0);
        // Vertex normals pointing to −z (the wrong side) and tilted: must be flipped.
        m.normals = Some(vec![Vec3::new(0.0, 0.0, -1.0); 4]);
        let g = Geometry::build(&[m]).unwrap_or_else(|e| panic!("{e}"));
        let ray = Ray::new(Vec3::new(0.3, 0.6, 1.0), Vec3::NEG_Z);
        let hit = g.intersect(&ray).unwrap_or_else(|| panic!("missed"));
        let s = g.surface(&ray, &hit);
        assert_eq!(s.shading_normal, Vec3::Z);
    }
}
