//! The queries on a built [`Geometry`]: the closest hit ([`Hit`]) and occlusion, for one ray,
//! a coherent batch or a stream of incoherent rays; the surface point at a hit
//! ([`SurfacePoint`]); their brute-force references; and the traversal stacks they run with.

use glam::Vec3;
use obvhs::bvh2::node::Bvh2Node;

use crate::intersect::{PreparedRay, TriHit, TriSoa, intersect_triangle};
use crate::layout::Job;
use crate::wide::{Entry, NodeTest, Query, Walk, WideBvh};
use crate::{Geometry, Ray, Triangle};

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

impl Geometry {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::TriangleMesh;
    use crate::layout::{BvhLayout, Nodes};
    use crate::test_meshes::{grid, quad, thin_slab, xorshift};

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
