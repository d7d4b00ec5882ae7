//! [`Geometry`]: the kept triangles and the BVH over them, and its construction from meshes:
//! validation (`mesh.rs`), the BVH2 build (`build.rs`), the chosen layout's nodes and packets
//! (`layout.rs`, `wide.rs`), and what a built geometry tells about itself. The queries on it
//! are in `query.rs`.

use std::borrow::Cow;

use glam::Vec3;
use obvhs::bvh2::node::Bvh2Node;

use crate::build;
use crate::instances::{Instance, Instances, Placement};
use crate::intersect::TriSoa;
use crate::layout::{BvhLayout, Nodes, bvh2_depth};
use crate::mesh::{drop_bad_triangles, validate_mesh};
use crate::wide::WideBvh;
use crate::{BuildReport, GeometryError, Triangle, TriangleMesh};

/// The most heap bytes a built [`Geometry`] holds per triangle on a mesh of shared vertices
/// (`a_built_heightfield_holds_under_100_bytes_per_triangle` holds it to this): 70.6 measured
/// on a 10⁶-triangle heightfield (docs/performance.md, "Memory per triangle"). A renderer's
/// memory estimate adds it to the meshes' own bytes, which the build frees as it goes.
pub const BUILT_BYTES_PER_TRIANGLE: u64 = 100;

/// The most heap bytes a built [`Geometry`] holds per placement of
/// [`Geometry::build_instanced`] (its record, box, id base and top-level BVH nodes): 274
/// measured on 10⁴ placements, to which `the_bytes_per_placement_stay_under_their_bound`
/// holds it.
pub const BUILT_BYTES_PER_INSTANCE: u64 = 288;

/// The most triangles a [`Geometry`] holds: 2³⁰, so that a triangle's place in the wide
/// layouts' packets (`4·packet + lane`) fits in a `u32`. (At about 100 bytes per triangle that
/// is 100 GiB.)
pub const MAX_TRIANGLES: usize = 1 << 30;

/// [`Geometry::core_bounds`] leaves out a triangle wider than this many times the box of
/// everything narrower: a ground plane under a room, not a wall of it (a room's wall is at most
/// as wide as the room) nor a studio floor a few times a product's size.
pub const OUTLIER_SPAN: f32 = 4.0;

/// The most triangles [`Geometry::core_bounds`] leaves out.
pub const MAX_OUTLIERS: usize = 64;

/// The built BVH over all kept triangles. `Send + Sync`: trace from any number of threads.
///
/// Each triangle's vertices are stored once, in the BVH's leaves (the wide layouts' packets or
/// the BVH2 layout's `bvh_triangles`), exactly as given: [`Geometry::triangle`] reads them
/// back from there through `slots`.
#[derive(Debug, Clone)]
pub struct Geometry {
    /// Material id, by triangle id.
    pub(crate) material_ids: Vec<u32>,
    /// Where each triangle is stored, by id: `4·packet + lane` (its first lane) in the wide
    /// layouts, the index into `bvh_triangles` in the BVH2 layout.
    pub(crate) slots: Vec<u32>,
    /// The shading normals of the meshes that have them, in id order.
    pub(crate) shading: Vec<ShadingNormals>,
    /// BVH nodes (obvhs layouts).
    pub(crate) nodes: Nodes,
    /// How many traversal stack entries this BVH can need (from its depth).
    pub(crate) stack_len: usize,
    /// BVH2 layout only: the triangles in leaf order, as the hot path reads them.
    pub(crate) bvh_triangles: Vec<TriSoa>,
    /// BVH2 layout only: the id of each entry of `bvh_triangles`.
    pub(crate) bvh_ids: Vec<u32>,
    pub(crate) report: BuildReport,
    pub(crate) bounds: (Vec3, Vec3),
    /// The largest vertex coordinate in magnitude, for the wide layouts' triangle screen
    /// (`PreparedRay::set_screen`).
    pub(crate) coordinate_bound: f32,
    /// The instruction set the wide traversals are compiled for, detected at build time:
    /// x86-64-v3 (AVX2) where the CPU has it, else the baseline. Both run the same operations
    /// (no fused multiply-adds: Rust never contracts), so the answers are the same bits.
    pub(crate) arch: pulp::Arch,
    /// AVX2 where the CPU has it (and `arch` is not forced to the baseline): the 8-wide
    /// layout's nodes are then tested with one 8-lane slab test instead of two 4-lane ones.
    #[cfg(target_arch = "x86_64")]
    pub(crate) v3: Option<pulp::x86::V3>,
    /// The placements of a geometry built with [`Geometry::build_instanced`] (`instances.rs`);
    /// the fields above are then its world meshes' tree, which may be empty.
    pub(crate) instances: Option<Box<Instances>>,
    /// [`Geometry::core_bounds`], computed on its first call: the loader and the light sampler
    /// both read it.
    pub(crate) core: std::sync::OnceLock<(Vec3, Vec3)>,
}

/// The shading normals of one mesh that has them: the mesh's per-vertex normals and the vertex
/// indices of its kept triangles, ids `first..first + indices.len()`. (As the mesh gives them,
/// shared vertices shared: 12 bytes per vertex and 12 per triangle, not 36 per triangle.)
#[derive(Debug, Clone)]
pub(crate) struct ShadingNormals {
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
            instances: None,
            core: std::sync::OnceLock::new(),
        })
    }

    /// A geometry of world meshes (as [`Geometry::build_owned`]) and of prototype meshes placed
    /// by `instances`, each prototype stored once in its own object space with its own BVH,
    /// under a top-level BVH over the placements (see `instances.rs` for the ids and the
    /// object-space rays). A prototype that no instance places is still numbered in the
    /// attribute ids ([`Geometry::attribute_id`]) but not built.
    ///
    /// Without instances this is [`Geometry::build_owned`]: the same geometry, ids and answers.
    ///
    /// # Errors
    /// As [`Geometry::build`] for the world meshes (whose [`GeometryError::EmptyScene`] only
    /// counts when nothing is placed either), [`GeometryError::Prototype`] naming a malformed
    /// prototype, [`GeometryError::PrototypeOutOfRange`] for an instance naming no prototype,
    /// and [`GeometryError::TooManyIds`] if the placed triangles do not fit `u32` ids.
    pub fn build_instanced(
        meshes: Vec<TriangleMesh>,
        prototypes: Vec<TriangleMesh>,
        instances: &[Instance],
    ) -> Result<Geometry, GeometryError> {
        Geometry::build_instanced_with_layout(meshes, prototypes, instances, BvhLayout::default())
    }

    /// [`Geometry::build_instanced`] with a chosen BVH layout, for the world tree and every
    /// prototype's.
    ///
    /// # Errors
    /// As [`Geometry::build_instanced`].
    pub fn build_instanced_with_layout(
        meshes: Vec<TriangleMesh>,
        prototypes: Vec<TriangleMesh>,
        instances: &[Instance],
        layout: BvhLayout,
    ) -> Result<Geometry, GeometryError> {
        if instances.is_empty() && prototypes.is_empty() {
            return Geometry::build_owned_with_layout(meshes, layout);
        }
        let mut world = match Geometry::build_owned_with_layout(meshes, layout) {
            Ok(g) => g,
            Err(GeometryError::EmptyScene {
                dropped_degenerate,
                dropped_non_finite,
            }) => Geometry::empty(BuildReport {
                dropped_degenerate,
                dropped_non_finite,
                ..BuildReport::default()
            }),
            Err(e) => return Err(e),
        };
        let mut built = Vec::with_capacity(prototypes.len());
        let mut report = world.report;
        for (p, mesh) in prototypes.into_iter().enumerate() {
            let geometry = match Geometry::build_owned_with_layout(vec![mesh], layout) {
                Ok(g) => {
                    report.dropped_degenerate += g.report.dropped_degenerate;
                    report.dropped_non_finite += g.report.dropped_non_finite;
                    report.kept += g.report.kept;
                    Some(g)
                }
                Err(GeometryError::EmptyScene {
                    dropped_degenerate,
                    dropped_non_finite,
                }) => {
                    report.dropped_degenerate += dropped_degenerate;
                    report.dropped_non_finite += dropped_non_finite;
                    None
                }
                Err(e) => {
                    return Err(GeometryError::Prototype {
                        prototype: p,
                        source: Box::new(e),
                    });
                }
            };
            built.push(geometry);
        }
        let instances = Instances::new(
            built,
            instances,
            world.world_count() as u32,
            &mut report.dropped_instances,
        )?;
        if instances.total == 0 {
            return Err(GeometryError::EmptyScene {
                dropped_degenerate: report.dropped_degenerate,
                dropped_non_finite: report.dropped_non_finite,
            });
        }
        let (lo, hi) = instances.bounds;
        world.bounds = (world.bounds.0.min(lo), world.bounds.1.max(hi));
        world.report = report;
        world.instances = Some(Box::new(instances));
        Ok(world)
    }

    /// A world tree with no triangles, for a geometry whose triangles are all placed.
    fn empty(report: BuildReport) -> Geometry {
        Geometry {
            material_ids: Vec::new(),
            slots: Vec::new(),
            shading: Vec::new(),
            nodes: Nodes::Bvh2(Vec::new()),
            stack_len: 0,
            bvh_triangles: Vec::new(),
            bvh_ids: Vec::new(),
            report,
            bounds: (Vec3::INFINITY, Vec3::NEG_INFINITY),
            coordinate_bound: 0.0,
            arch: pulp::Arch::new(),
            #[cfg(target_arch = "x86_64")]
            v3: pulp::x86::V3::try_new(),
            instances: None,
            core: std::sync::OnceLock::new(),
        }
    }

    /// The world meshes' triangle count (all of them without instances).
    #[inline]
    pub(crate) fn world_count(&self) -> usize {
        self.material_ids.len()
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
        self.instances
            .as_ref()
            .map_or(self.world_count(), |i| i.total as usize)
    }

    /// The number of *unique* triangles: the world meshes' and the prototypes' kept triangles
    /// (the attribute ids' range, see [`Geometry::attribute_id`]); `triangle_count()` without
    /// instances.
    #[must_use]
    pub fn unique_triangle_count(&self) -> usize {
        self.instances
            .as_ref()
            .map_or(self.world_count(), |i| i.unique as usize)
    }

    /// The unique triangle whose per-vertex data triangle `id` shares: `id` itself for a world
    /// triangle; for a placed one, its prototype's triangle, numbered after the world's
    /// (`W + ` the kept triangles of the prototypes before it `+` its own kept index). A
    /// caller keeps its per-vertex data by this id.
    ///
    /// # Panics
    /// If `id >= triangle_count()`.
    #[must_use]
    #[inline]
    pub fn attribute_id(&self, id: u32) -> u32 {
        match &self.instances {
            Some(i) if id >= i.world => i.attribute_id(id),
            _ => id,
        }
    }

    /// The world meshes' triangles: ids `0..world_triangle_count()` (all of them without
    /// instances); the placements' ids follow.
    #[must_use]
    pub fn world_triangle_count(&self) -> usize {
        self.world_count()
    }

    /// The kept placements of a geometry built with [`Geometry::build_instanced`], in id order
    /// (none otherwise): what a caller walks instead of every placed id, to find the emitting
    /// ones, say.
    pub fn placements(&self) -> impl Iterator<Item = Placement> + '_ {
        self.instances.iter().flat_map(|i| i.placements())
    }

    /// The index (into the build's `instances`) of the instance triangle `id` lies on, or
    /// `None` for a world triangle.
    ///
    /// # Panics
    /// If `id >= triangle_count()`.
    #[must_use]
    pub fn instance_of(&self, id: u32) -> Option<u32> {
        match &self.instances {
            Some(i) if id >= i.world => Some(i.instance_of(id)),
            _ => None,
        }
    }

    /// A vector given in the object space of triangle `id`'s mesh (a tangent, say) in world
    /// space: mapped by its instance's linear part, unchanged for a world triangle. Not
    /// normalised.
    ///
    /// # Panics
    /// If `id >= triangle_count()`.
    #[must_use]
    pub fn vector_to_world(&self, id: u32, v: Vec3) -> Vec3 {
        match &self.instances {
            Some(i) if id >= i.world => i.vector_to_world(id, v),
            _ => v,
        }
    }

    /// The kept triangle with this id: its vertices bit for bit as given to the build.
    ///
    /// # Panics
    /// If `id >= triangle_count()` (ids come from hits, so this is a caller bug); see
    /// [`Geometry::get_triangle`] for a checked lookup.
    #[must_use]
    pub fn triangle(&self, id: u32) -> Triangle {
        if let Some(i) = &self.instances
            && id >= i.world
        {
            return i.triangle(id).0;
        }
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
        if let Some(i) = &self.instances
            && id >= i.world
        {
            return i.material_id(id);
        }
        self.material_ids[id as usize]
    }

    /// The kept triangle with this id, or `None` if there is none.
    #[must_use]
    pub fn get_triangle(&self, id: u32) -> Option<Triangle> {
        ((id as usize) < self.triangle_count()).then(|| self.triangle(id))
    }

    /// All triangles, by id (placed ones in world space).
    pub fn triangles(&self) -> impl ExactSizeIterator<Item = Triangle> + '_ {
        (0..self.triangle_count() as u32).map(|id| self.triangle(id))
    }

    /// The world meshes' triangles, by id.
    pub(crate) fn world_triangles(&self) -> impl ExactSizeIterator<Item = Triangle> + '_ {
        (0..self.world_count() as u32).map(|id| self.triangle(id))
    }

    /// `(min, max)` corners of the box around all kept triangles.
    #[must_use]
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    /// The box of what the scene is about: [`Geometry::bounds`] without the few triangles that
    /// alone stretch it, such as a ground plane kilometres wide under a room. What a default
    /// view frames and what a directional light's share of light sampling is measured over,
    /// where the whole box would make the room a dot or the sun's share almost 1.
    ///
    /// Pieces are the triangles, and the placements of an instanced geometry taken together
    /// (their joint box), ranked by the diagonal of their box. The k widest (k ≤
    /// [`MAX_OUTLIERS`], the smallest k that works) are left out when the narrowest of them is
    /// more than [`OUTLIER_SPAN`] times as wide as the box of all the others, which is then the
    /// answer. The same box as `bounds()` when no such k exists (a room of a few large quads, a
    /// terrain of many small triangles). Two passes over the triangles on the first call
    /// (memory bounded by `MAX_OUTLIERS`); later calls read the answer.
    #[must_use]
    pub fn core_bounds(&self) -> (Vec3, Vec3) {
        *self.core.get_or_init(|| self.outlier_free_bounds())
    }

    /// [`Geometry::core_bounds`]' two passes.
    fn outlier_free_bounds(&self) -> (Vec3, Vec3) {
        type Piece = (f32, u32, (Vec3, Vec3));
        let diagonal = |(lo, hi): (Vec3, Vec3)| (hi - lo).length();
        let world = self.world_count() as u32;
        // Piece `world` is the placements' joint box.
        let placed = self.instances.as_ref().map(|i| i.bounds);
        let piece = |id: u32| -> (Vec3, Vec3) {
            if id == world {
                return placed.unwrap_or((Vec3::INFINITY, Vec3::NEG_INFINITY));
            }
            let p = self.triangle(id).p;
            (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]))
        };
        let count = world + u32::from(placed.is_some());
        // Pass 1: the MAX_OUTLIERS widest pieces (a min-heap of them by diagonal, whose bits
        // order as its value: it is not negative; ties by id).
        let mut widest: std::collections::BinaryHeap<std::cmp::Reverse<(u32, u32)>> =
            std::collections::BinaryHeap::with_capacity(MAX_OUTLIERS + 1);
        for id in 0..count {
            widest.push(std::cmp::Reverse((diagonal(piece(id)).to_bits(), id)));
            if widest.len() > MAX_OUTLIERS {
                widest.pop();
            }
        }
        let mut widest: Vec<Piece> = widest
            .into_iter()
            .map(|std::cmp::Reverse((d, id))| (f32::from_bits(d), id, piece(id)))
            .collect();
        // Widest first.
        widest.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        // Pass 2: the box of every other piece.
        let union = |a: (Vec3, Vec3), b: (Vec3, Vec3)| (a.0.min(b.0), a.1.max(b.1));
        let mut left: Vec<u32> = widest.iter().map(|w| w.1).collect();
        left.sort_unstable();
        let mut rest = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for id in 0..count {
            if left.binary_search(&id).is_err() {
                rest = union(rest, piece(id));
            }
        }
        // below[i]: the box of every piece narrower than widest[i].
        let mut below = vec![rest; widest.len()];
        for i in (0..widest.len().saturating_sub(1)).rev() {
            below[i] = union(below[i + 1], widest[i + 1].2);
        }
        // The first cut whose narrowest left-out piece is OUTLIER_SPAN times as wide as all that
        // stays (a ground quad's two triangles go together); an empty or flat remainder is no cut.
        for (w, &under) in widest.iter().zip(&below) {
            let span = diagonal(under);
            if span.is_finite() && span > 0.0 && w.0 > OUTLIER_SPAN * span {
                return under;
            }
        }
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
        if let Some(i) = &self.instances {
            out.extend(i.heap_bytes());
        }
        out
    }

    /// The unit geometric normal of triangle `id` (as [`Geometry::surface`] gives it: normalised
    /// (p1 − p0) × (p2 − p0), computed in f64 at the build).
    #[inline]
    #[must_use]
    pub fn geometric_normal(&self, id: u32) -> Vec3 {
        if let Some(i) = &self.instances
            && id >= i.world
        {
            return i.geometric_normal(id);
        }
        self.stored(id).normal()
    }

    /// Triangle `id` as stored in the BVH's leaves.
    #[inline]
    pub(crate) fn stored(&self, id: u32) -> TriSoa {
        let slot = self.slots[id as usize];
        match &self.nodes {
            Nodes::Bvh2(_) => self.bvh_triangles[slot as usize],
            Nodes::Wide4(w) => w.triangle(slot),
            Nodes::Wide8(w) => w.triangle(slot),
        }
    }

    /// The vertex shading normals of triangle `id`, if its mesh has them.
    #[inline]
    pub(crate) fn vertex_normals(&self, id: u32) -> Option<[Vec3; 3]> {
        if self.shading.is_empty() {
            return None;
        }
        let k = self.shading.partition_point(|s| s.first <= id);
        let s = &self.shading[k.checked_sub(1)?];
        let idx = s.indices.get((id - s.first) as usize)?;
        Some(idx.map(|i| s.normals[i as usize]))
    }

    /// The number of BVH nodes (for statistics and benchmarks).
    #[must_use]
    pub fn node_count(&self) -> usize {
        let world = match &self.nodes {
            Nodes::Bvh2(n) => n.len(),
            Nodes::Wide4(w) => w.node_count(),
            Nodes::Wide8(w) => w.node_count(),
        };
        world + self.instances.as_ref().map_or(0, |i| i.node_count())
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
}

/// Compile-time check that `Geometry` can be shared between threads.
const _: fn() = || {
    fn shareable<T: Send + Sync>() {}
    shareable::<Geometry>();
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Ray;
    use crate::test_meshes::{grid, mixed_meshes, nested, prims_of, quad, xorshift};

    /// Triangles from corner triples, one mesh.
    fn triangles(corners: &[[Vec3; 3]]) -> TriangleMesh {
        TriangleMesh {
            positions: corners.iter().flatten().copied().collect(),
            indices: (0..corners.len() as u32)
                .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
                .collect(),
            normals: None,
            material_ids: vec![0; corners.len()],
        }
    }

    /// The six faces of the box [lo, hi], two triangles each.
    fn room(lo: Vec3, hi: Vec3) -> TriangleMesh {
        let mut corners = Vec::new();
        for axis in 0..3 {
            for side in [lo[axis], hi[axis]] {
                let at = |a: bool, b: bool| {
                    let mut c = Vec3::ZERO;
                    c[axis] = side;
                    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                    c[u] = if a { hi[u] } else { lo[u] };
                    c[v] = if b { hi[v] } else { lo[v] };
                    c
                };
                corners.push([at(false, false), at(true, false), at(true, true)]);
                corners.push([at(false, false), at(true, true), at(false, true)]);
            }
        }
        triangles(&corners)
    }

    fn core_of(meshes: &[TriangleMesh]) -> ((Vec3, Vec3), (Vec3, Vec3)) {
        let g = Geometry::build(meshes).unwrap_or_else(|e| panic!("{e}"));
        (g.bounds(), g.core_bounds())
    }

    /// A ground 10 km wide, 100 m below an 8 × 3 × 6 m room, is left out of the core bounds:
    /// they are the room's. Without it, and on a terrain of small triangles 10 km wide with
    /// the room on it, the core bounds are the whole box.
    #[test]
    fn a_far_ground_is_left_out_of_the_core_bounds() {
        let (lo, hi) = (Vec3::ZERO, Vec3::new(8.0, 3.0, 6.0));
        let ground = triangles(&[
            [
                Vec3::new(-5e3, -100.0, -5e3),
                Vec3::new(5e3, -100.0, 5e3),
                Vec3::new(5e3, -100.0, -5e3),
            ],
            [
                Vec3::new(-5e3, -100.0, -5e3),
                Vec3::new(-5e3, -100.0, 5e3),
                Vec3::new(5e3, -100.0, 5e3),
            ],
        ]);
        let (bounds, core) = core_of(&[room(lo, hi), ground]);
        assert_eq!(core, (lo, hi), "with the ground (whole box {bounds:?})");
        let (bounds, core) = core_of(&[room(lo, hi)]);
        assert_eq!(core, bounds, "the room alone");
        let terrain = grid(100, |i, j| {
            Vec3::new(i as f32 * 100.0 - 5e3, -1.0, j as f32 * 100.0 - 5e3)
        });
        let (bounds, core) = core_of(&[room(lo, hi), terrain]);
        assert_eq!(core, bounds, "a terrain of 100 m triangles");
    }

    proptest::proptest! {
        /// The core bounds lie within the bounds, and a triangle wider than OUTLIER_SPAN times
        /// the rest of the scene, wherever it lies, is left out: the core bounds are the rest's
        /// whole box.
        #[test]
        fn a_giant_triangle_is_left_out_of_the_core_bounds(
            seed in 1u32..u32::MAX,
            n in 1usize..40,
            at in proptest::array::uniform3(-1e4f32..1e4),
        ) {
            let mut next = xorshift(seed);
            let corners: Vec<[Vec3; 3]> = (0..n)
                .map(|_| {
                    let c = Vec3::new(next(), next(), next()) * 10.0;
                    let e = Vec3::new(next(), next(), next()) * (0.1 + next().abs() * 3.0);
                    [c, c + e, c + e.cross(Vec3::new(0.3, 1.0, 0.2))]
                })
                .collect();
            let scene = triangles(&corners);
            let (bounds, core) = core_of(std::slice::from_ref(&scene));
            proptest::prop_assert!(core.0.cmpge(bounds.0).all() && core.1.cmple(bounds.1).all());
            let span = (bounds.1 - bounds.0).length();
            let c = Vec3::from_array(at);
            let w = 2.0 * OUTLIER_SPAN * span;
            let giant = triangles(&[[c, c + Vec3::new(w, 0.0, 0.0), c + Vec3::new(0.0, 0.0, w)]]);
            let (_, with) = core_of(&[scene, giant]);
            proptest::prop_assert_eq!(with, bounds);
        }
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
            per_triangle < BUILT_BYTES_PER_TRIANGLE as f64,
            "{per_triangle} bytes per triangle: {bytes:?}"
        );
    }
}
