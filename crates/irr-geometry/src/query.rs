//! The queries on a built [`Geometry`]: the closest hit ([`Hit`]) and occlusion, for one ray,
//! a coherent batch or a stream of incoherent rays, each also with a caller's [`HitFilter`];
//! the surface point at a hit ([`SurfacePoint`]); their brute-force references; and the
//! traversal stacks they run with.
//!
//! A filter reaches the traversals as a type parameter ([`RayFilter`]): the unfiltered queries
//! pass [`AcceptAll`], whose `ALL` compiles every filter branch out, so they run the code they
//! ran before filters existed.

use glam::Vec3;
use obvhs::bvh2::node::Bvh2Node;

use crate::instances::Instances;
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

/// A caller's test of each candidate hit, asked during traversal: a candidate it rejects is
/// treated as if its triangle had not been hit, and the traversal goes on. For alpha cut-outs
/// (glTF's `MASK` and, as stochastic transparency, `BLEND`): the caller looks up the
/// triangle's material and texture at the hit's barycentrics, which this crate knows nothing
/// of.
///
/// It gets the ray as the caller gave it (to hash its bits with the triangle id, say, for a
/// deterministic random number) and the candidate: its distance, triangle id and barycentrics,
/// with `t` in `(0, ray.t_max)` and within the margins of [`Geometry::intersect`]. Candidates
/// come in no particular order, and one may be asked about more than once (or not at all, once
/// the answer is known): the filter must be a pure function of its arguments. It is shared by
/// reference, so a batch traced on many threads needs it to be `Sync`.
///
/// Closures `Fn(&Ray, &Hit) -> bool` are filters (their argument types must then be written
/// out: `|_: &Ray, h: &Hit| h.triangle != 3`), and so is `dyn HitFilter`.
pub trait HitFilter {
    /// Whether the candidate `hit` of `ray` counts as a hit.
    fn accept(&self, ray: &Ray, hit: &Hit) -> bool;
}

impl<F: Fn(&Ray, &Hit) -> bool + ?Sized> HitFilter for F {
    #[inline(always)]
    fn accept(&self, ray: &Ray, hit: &Hit) -> bool {
        self(ray, hit)
    }
}

/// A filter as a batch's traversals take it: [`AcceptAll`] or a caller's [`HitFilter`], which
/// [`Filter::on`] binds to each ray in turn.
pub(crate) trait Filter: Copy {
    /// The filter bound to one ray.
    type On<'r>: RayFilter
    where
        Self: 'r;
    fn on<'r>(self, ray: &'r Ray) -> Self::On<'r>
    where
        Self: 'r;
}

/// A filter bound to the ray it tests the candidates of, as the traversals call it.
pub(crate) trait RayFilter: Copy {
    /// Whether it accepts every candidate: the traversals then never call it, and compile out
    /// what they would do for a rejection.
    const ALL: bool;
    fn accept(self, hit: &Hit) -> bool;
}

/// The unfiltered queries' filter: every candidate is a hit.
#[derive(Debug, Clone, Copy)]
pub(crate) struct AcceptAll;

impl Filter for AcceptAll {
    type On<'r> = AcceptAll;

    #[inline(always)]
    fn on<'r>(self, _: &'r Ray) -> AcceptAll
    where
        Self: 'r,
    {
        AcceptAll
    }
}

impl RayFilter for AcceptAll {
    const ALL: bool = true;

    #[inline(always)]
    fn accept(self, _: &Hit) -> bool {
        true
    }
}

impl<H: HitFilter + ?Sized> Filter for &H {
    type On<'r>
        = OnRay<'r, H>
    where
        Self: 'r;

    #[inline(always)]
    fn on<'r>(self, ray: &'r Ray) -> OnRay<'r, H>
    where
        Self: 'r,
    {
        OnRay(self, ray)
    }
}

/// A caller's filter and the ray it is asked about.
pub(crate) struct OnRay<'a, H: ?Sized>(&'a H, &'a Ray);

impl<H: ?Sized> Clone for OnRay<'_, H> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<H: ?Sized> Copy for OnRay<'_, H> {}

impl<H: HitFilter + ?Sized> RayFilter for OnRay<'_, H> {
    const ALL: bool = false;

    #[inline(always)]
    fn accept(self, hit: &Hit) -> bool {
        self.0.accept(self.1, hit)
    }
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
        self.closest(ray, AcceptAll)
    }

    /// The closest hit that `filter` accepts (with `t` in `(0, ray.t_max)`, as
    /// [`Geometry::intersect`]), or `None`: the closest candidate is asked first, and a
    /// rejected one is passed through, as if its triangle were not there. For alpha cut-outs
    /// (see [`HitFilter`]). With a filter that accepts everything, exactly `intersect`'s hit.
    #[must_use]
    pub fn intersect_filtered<F: HitFilter + ?Sized>(&self, ray: &Ray, filter: &F) -> Option<Hit> {
        self.closest(ray, filter.on(ray))
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
        self.many(rays, hits, false, AcceptAll);
    }

    /// [`Geometry::intersect_many`] with a hit filter: `hits[i]` is exactly what
    /// [`Geometry::intersect_filtered`] returns for `rays[i]`.
    ///
    /// # Panics
    /// If `rays` and `hits` differ in length.
    pub fn intersect_many_filtered<F: HitFilter + ?Sized>(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        filter: &F,
    ) {
        assert_eq!(rays.len(), hits.len(), "one hit slot per ray");
        self.many(rays, hits, false, filter);
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
        self.many(rays, hits, true, AcceptAll);
    }

    /// [`Geometry::intersect_stream`] with a hit filter: `hits[i]` is exactly what
    /// [`Geometry::intersect_filtered`] returns for `rays[i]`.
    ///
    /// # Panics
    /// If `rays` and `hits` differ in length.
    pub fn intersect_stream_filtered<F: HitFilter + ?Sized>(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        filter: &F,
    ) {
        assert_eq!(rays.len(), hits.len(), "one hit slot per ray");
        self.many(rays, hits, true, filter);
    }

    /// Whether each of many incoherent rays is occluded: `occluded[i]` is exactly what
    /// [`Geometry::occluded`] returns for `rays[i]`, traced as
    /// [`Geometry::intersect_stream`] traces its rays.
    ///
    /// # Panics
    /// If `rays` and `occluded` differ in length.
    pub fn occluded_stream(&self, rays: &[Ray], occluded: &mut [bool]) {
        assert_eq!(rays.len(), occluded.len(), "one answer slot per ray");
        self.many(rays, occluded, true, AcceptAll);
    }

    /// [`Geometry::occluded_stream`] with a hit filter: `occluded[i]` is exactly what
    /// [`Geometry::occluded_filtered`] returns for `rays[i]`.
    ///
    /// # Panics
    /// If `rays` and `occluded` differ in length.
    pub fn occluded_stream_filtered<F: HitFilter + ?Sized>(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        filter: &F,
    ) {
        assert_eq!(rays.len(), occluded.len(), "one answer slot per ray");
        self.many(rays, occluded, true, filter);
    }

    /// Whether anything is hit with `t` in `(0, ray.t_max)` (with the same error margins as
    /// [`Geometry::intersect`]). For shadow rays built with [`Ray::spawn_to`]. On a tree larger
    /// than the caches, the ray is traced as two walks that take steps in turn, so that one's
    /// wait for memory overlaps the other's work.
    #[must_use]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.any(ray, AcceptAll)
    }

    /// Whether anything that `filter` accepts is hit with `t` in `(0, ray.t_max)` (as
    /// [`Geometry::occluded`]): a shadow ray through alpha cut-outs (see [`HitFilter`]). The
    /// traversal stops at the first accepted candidate, in no particular order. With a filter
    /// that accepts everything, exactly `occluded`'s answer.
    #[must_use]
    pub fn occluded_filtered<F: HitFilter + ?Sized>(&self, ray: &Ray, filter: &F) -> bool {
        self.any(ray, filter.on(ray))
    }

    /// [`Geometry::intersect`] with filter `filter` bound to `ray`.
    #[inline(always)]
    fn closest<B: RayFilter>(&self, ray: &Ray, filter: B) -> Option<Hit> {
        if self.instances.is_none() {
            return self.world_closest(ray, filter);
        }
        self.closest_placed(ray, filter)
    }

    /// [`Geometry::occluded`] with filter `filter` bound to `ray`.
    #[inline(always)]
    fn any<B: RayFilter>(&self, ray: &Ray, filter: B) -> bool {
        if self.instances.is_none() {
            return self.world_any(ray, filter);
        }
        self.any_placed(ray, filter)
    }

    /// `closest` with placements: out of line, so that a geometry without them runs the
    /// code it ran before they existed.
    #[inline(never)]
    fn closest_placed<B: RayFilter>(&self, ray: &Ray, filter: B) -> Option<Hit> {
        let world = if self.world_count() > 0 {
            self.world_closest(ray, filter)
        } else {
            None
        };
        match &self.instances {
            Some(i) => i.closest(ray, world, filter, false),
            None => world,
        }
    }

    /// `any` with placements, out of line as `closest_placed`.
    #[inline(never)]
    fn any_placed<B: RayFilter>(&self, ray: &Ray, filter: B) -> bool {
        (self.world_count() > 0 && self.world_any(ray, filter))
            || self
                .instances
                .as_ref()
                .is_some_and(|i| i.any(ray, filter, false))
    }

    /// The closest hit in the world meshes' tree (all of it without instances).
    #[inline(always)]
    pub(crate) fn world_closest<B: RayFilter>(&self, ray: &Ray, filter: B) -> Option<Hit> {
        if !PreparedRay::traceable(ray) {
            return None;
        }
        let mut r = PreparedRay::prepare(ray, self.coordinate_bound);
        self.trace(Closest(&mut r, filter))
    }

    /// Whether the world meshes' tree is hit.
    #[inline(always)]
    pub(crate) fn world_any<B: RayFilter>(&self, ray: &Ray, filter: B) -> bool {
        if !PreparedRay::traceable(ray) {
            return false;
        }
        let mut r = PreparedRay::prepare(ray, self.coordinate_bound);
        self.trace(Any(&mut r, filter))
    }

    /// The answers of a batch (`Many`'s), then the placements' for each ray.
    fn many<A: Answer, F: Filter>(&self, rays: &[Ray], out: &mut [A], stream: bool, filter: F) {
        let Some(i) = &self.instances else {
            return self.trace(Many(rays, out, stream, filter));
        };
        if self.world_count() > 0 {
            self.trace(Many(rays, &mut *out, stream, filter));
        } else {
            out.fill(A::MISS);
        }
        for (ray, a) in rays.iter().zip(out.iter_mut()) {
            *a = A::placed(i, ray, *a, filter.on(ray));
        }
    }

    /// The surface point of a hit returned by [`Geometry::intersect`]. The ray is not needed
    /// for anything (the geometric normal is deliberately not flipped toward it); it is taken so
    /// that a future differential or error term can use it without an API change.
    ///
    /// # Panics
    /// If `hit.triangle` is not a valid id (hits from this geometry always are).
    #[must_use]
    pub fn surface(&self, _ray: &Ray, hit: &Hit) -> SurfacePoint {
        let (tri, ng, normals) = match &self.instances {
            Some(i) if hit.triangle >= i.world => {
                let (tri, k, local) = i.triangle(hit.triangle);
                let ng = TriSoa::new(tri.p).normal();
                (tri, ng, i.vertex_normals(k, local))
            }
            _ => {
                let stored = self.stored(hit.triangle);
                let tri = Triangle {
                    p: stored.vertices(),
                    material_id: self.material_ids[hit.triangle as usize],
                };
                (tri, stored.normal(), self.vertex_normals(hit.triangle))
            }
        };
        let shading_normal = normals
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
        self.closest_brute_force(ray, AcceptAll)
    }

    /// [`Geometry::intersect_filtered`] without the BVH (O(n) reference): every triangle in id
    /// order, each hit closer than the closest accepted so far asked to `filter`.
    #[must_use]
    pub fn intersect_brute_force_filtered<F: HitFilter + ?Sized>(
        &self,
        ray: &Ray,
        filter: &F,
    ) -> Option<Hit> {
        self.closest_brute_force(ray, filter.on(ray))
    }

    /// [`Geometry::occluded`] without the BVH (O(n) reference).
    #[must_use]
    pub fn occluded_brute_force(&self, ray: &Ray) -> bool {
        self.any_brute_force(ray, AcceptAll)
    }

    /// [`Geometry::occluded_filtered`] without the BVH (O(n) reference).
    #[must_use]
    pub fn occluded_brute_force_filtered<F: HitFilter + ?Sized>(
        &self,
        ray: &Ray,
        filter: &F,
    ) -> bool {
        self.any_brute_force(ray, filter.on(ray))
    }

    /// The brute-force closest hit, with filter `filter` bound to `ray`.
    fn closest_brute_force<B: RayFilter>(&self, ray: &Ray, filter: B) -> Option<Hit> {
        let world = self.world_closest_brute_force(ray, filter);
        match &self.instances {
            Some(i) => i.closest(ray, world, filter, true),
            None => world,
        }
    }

    /// The brute-force any hit, with filter `filter` bound to `ray`.
    fn any_brute_force<B: RayFilter>(&self, ray: &Ray, filter: B) -> bool {
        self.world_any_brute_force(ray, filter)
            || self
                .instances
                .as_ref()
                .is_some_and(|i| i.any(ray, filter, true))
    }

    /// The brute-force closest hit among the world meshes' triangles.
    pub(crate) fn world_closest_brute_force<B: RayFilter>(
        &self,
        ray: &Ray,
        filter: B,
    ) -> Option<Hit> {
        let r = PreparedRay::new(ray)?;
        let mut t_best = r.t_max;
        let mut best = None;
        for (id, tri) in self.world_triangles().enumerate() {
            let soa = TriSoa::new(tri.p);
            let h = match r.kz() {
                0 => intersect_triangle::<0>(&soa, &r, t_best),
                1 => intersect_triangle::<1>(&soa, &r, t_best),
                _ => intersect_triangle::<2>(&soa, &r, t_best),
            };
            if let Some(h) = h {
                let hit = Hit {
                    t: h.t,
                    triangle: id as u32,
                    b1: h.b1,
                    b2: h.b2,
                };
                if filter.accept(&hit) {
                    t_best = h.t;
                    best = Some(hit);
                }
            }
        }
        best
    }

    /// The brute-force any hit among the world meshes' triangles.
    pub(crate) fn world_any_brute_force<B: RayFilter>(&self, ray: &Ray, filter: B) -> bool {
        let Some(r) = PreparedRay::new(ray) else {
            return false;
        };
        self.world_triangles().enumerate().any(|(id, tri)| {
            let soa = TriSoa::new(tri.p);
            match r.kz() {
                0 => intersect_triangle::<0>(&soa, &r, r.t_max),
                1 => intersect_triangle::<1>(&soa, &r, r.t_max),
                _ => intersect_triangle::<2>(&soa, &r, r.t_max),
            }
            .is_some_and(|h| {
                filter.accept(&Hit {
                    t: h.t,
                    triangle: id as u32,
                    b1: h.b1,
                    b2: h.b2,
                })
            })
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

/// One ray's closest hit, with its filter.
struct Closest<'a, B>(&'a mut PreparedRay, B);

impl<B: RayFilter> Job for Closest<'_, B> {
    type Output = Option<Hit>;

    #[inline(always)]
    fn wide<const G: usize, N: NodeTest<G>>(
        self,
        w: &WideBvh<G>,
        g: &Geometry,
        test: N,
    ) -> Option<Hit> {
        on_stack!(g.stack_len, Entry, false, |s| Option::<Hit>::trace(
            w, self.0, s, test, self.1
        ))
    }

    /// Out of line (the BVH2 layout is the test oracle, not the default): inlined, its stack
    /// array made every `intersect` call set up a 1.2-KB frame and save five registers.
    #[inline(never)]
    fn bvh2(self, g: &Geometry, nodes: &[Bvh2Node]) -> Option<Hit> {
        self.0.finish();
        // `move`: the filter by value, not a reference to it (to nothing, unfiltered) kept in
        // the closure, which made the unfiltered code differ.
        let (r, f) = (&*self.0, self.1);
        let found = match r.kz() {
            0 => g.with_stack(move |s| g.bvh2_closest::<0, B>(nodes, r, s, f)),
            1 => g.with_stack(move |s| g.bvh2_closest::<1, B>(nodes, r, s, f)),
            _ => g.with_stack(move |s| g.bvh2_closest::<2, B>(nodes, r, s, f)),
        };
        found.map(|(i, h)| Hit {
            t: h.t,
            triangle: g.bvh_ids[i],
            b1: h.b1,
            b2: h.b2,
        })
    }
}

/// Whether one ray hits anything, with its filter.
struct Any<'a, B>(&'a mut PreparedRay, B);

impl<B: RayFilter> Job for Any<'_, B> {
    type Output = bool;

    #[inline(always)]
    fn wide<const G: usize, N: NodeTest<G>>(self, w: &WideBvh<G>, g: &Geometry, test: N) -> bool {
        let walks = WideBvh::<G>::walks::<bool, N>();
        on_stack!(g.stack_len * walks, Entry, walks == 2, |s| bool::trace(
            w, self.0, s, test, self.1
        ))
    }

    /// Out of line, as `Closest::bvh2`.
    #[inline(never)]
    fn bvh2(self, g: &Geometry, nodes: &[Bvh2Node]) -> bool {
        self.0.finish();
        let (r, f) = (&*self.0, self.1);
        match r.kz() {
            0 => g.with_stack(move |s| g.bvh2_any::<0, B>(nodes, r, s, f)),
            1 => g.with_stack(move |s| g.bvh2_any::<1, B>(nodes, r, s, f)),
            _ => g.with_stack(move |s| g.bvh2_any::<2, B>(nodes, r, s, f)),
        }
    }
}

/// The answers for many rays, written in place (`hits[i]` for `rays[i]`), within one run-time
/// dispatch whose setup is then paid once: a ray at a time, in order, or where the third field
/// asks for a stream and the tree is large, as a stream ([`wide_stream`]); the fourth is the
/// filter, bound to each ray in turn.
struct Many<'a, A, F>(&'a [Ray], &'a mut [A], bool, F);

impl<A: Answer, F: Filter> Job for Many<'_, A, F> {
    type Output = ();

    #[inline(always)]
    fn wide<const G: usize, N: NodeTest<G>>(self, w: &WideBvh<G>, g: &Geometry, test: N) {
        if N::LARGE && self.2 {
            return wide_stream::<G, N, STREAM, A, F>(w, g, self.0, self.1, test, self.3);
        }
        let walks = WideBvh::<G>::walks::<A, N>();
        let len = g.stack_len * walks;
        for (ray, hit) in self.0.iter().zip(self.1.iter_mut()) {
            // No closure here: it would be compiled outside the dispatched instruction set.
            *hit = if PreparedRay::traceable(ray) {
                let mut r = PreparedRay::prepare(ray, g.coordinate_bound);
                let f = self.3.on(ray);
                on_stack!(len, Entry, walks == 2, |s| A::trace(w, &mut r, s, test, f))
            } else {
                A::MISS
            };
        }
    }

    fn bvh2(self, g: &Geometry, _: &[Bvh2Node]) {
        for (ray, hit) in self.0.iter().zip(self.1.iter_mut()) {
            *hit = A::bvh2(g, ray, self.3.on(ray));
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
    /// The answer with the placements', given the world tree's.
    fn placed<B: RayFilter>(i: &Instances, ray: &Ray, world: Self, filter: B) -> Self;
    /// One ray's answer on a wide BVH, with a stack of `WideBvh::walks` times its
    /// `stack_len` entries, counting only the hits `filter` accepts.
    #[inline(always)]
    fn trace<const G: usize, N: NodeTest<G>, B: RayFilter>(
        w: &WideBvh<G>,
        r: &mut PreparedRay,
        stack: &mut [Entry],
        test: N,
        filter: B,
    ) -> Self {
        let (nodes, packets, ids) = w.arrays();
        if WideBvh::<G>::walks::<Self, N>() == 2 {
            let best =
                WideBvh::two_walks::<Self, N, B>(nodes, packets, ids, r, stack, test, filter);
            return Self::from_best(w, best);
        }
        let mut walk = Walk::new(r);
        while !WideBvh::step::<Self, N, B>(nodes, packets, ids, r, stack, &mut walk, test, filter) {
        }
        Self::from_best(w, walk.best)
    }
    /// One ray's answer on the BVH2 layout, with filter `filter` bound to it.
    fn bvh2<B: RayFilter>(g: &Geometry, ray: &Ray, filter: B) -> Self;
}

impl Query for Option<Hit> {
    const ANY: bool = false;
}

impl Answer for Option<Hit> {
    const MISS: Self = None;

    fn placed<B: RayFilter>(i: &Instances, ray: &Ray, world: Self, filter: B) -> Self {
        i.closest(ray, world, filter, false)
    }

    #[inline(always)]
    fn from_best<const G: usize>(w: &WideBvh<G>, best: Option<(u32, usize, TriHit)>) -> Self {
        best.map(|(p, lane, h)| Hit {
            t: h.t,
            triangle: w.id(p, lane),
            b1: h.b1,
            b2: h.b2,
        })
    }

    fn bvh2<B: RayFilter>(g: &Geometry, ray: &Ray, filter: B) -> Self {
        // Unfiltered, through the public call, which the batch then calls rather than inlines
        // (as before filters: inlined, the dispatch made the batch's loop too large to inline).
        if B::ALL {
            g.intersect(ray)
        } else {
            g.closest(ray, filter)
        }
    }
}

impl Query for bool {
    const ANY: bool = true;
}

impl Answer for bool {
    const MISS: Self = false;

    fn placed<B: RayFilter>(i: &Instances, ray: &Ray, world: Self, filter: B) -> Self {
        world || i.any(ray, filter, false)
    }

    #[inline(always)]
    fn from_best<const G: usize>(_: &WideBvh<G>, best: Option<(u32, usize, TriHit)>) -> Self {
        best.is_some()
    }

    fn bvh2<B: RayFilter>(g: &Geometry, ray: &Ray, filter: B) -> Self {
        // As for the closest hit.
        if B::ALL {
            g.occluded(ray)
        } else {
            g.any(ray, filter)
        }
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
fn wide_stream<const G: usize, N: NodeTest<G>, const K: usize, A: Answer, F: Filter>(
    w: &WideBvh<G>,
    g: &Geometry,
    rays: &[Ray],
    out: &mut [A],
    test: N,
    filter: F,
) {
    let (nodes, packets, ids) = w.arrays();
    let len = g.stack_len;
    let mut stacks = vec![Entry::default(); K * len];
    let mut next = 0;
    let mut lanes: [Option<Lane<'_, F>>; K] = [None; K];
    for lane in &mut lanes {
        *lane = refill(g, rays, out, &mut next, filter);
    }
    let mut active = lanes.iter().filter(|l| l.is_some()).count();
    while active > 0 {
        for (lane, stack) in lanes.iter_mut().zip(stacks.chunks_exact_mut(len)) {
            let Some(((i, r, walk), f)) = lane else {
                continue;
            };
            if WideBvh::step::<A, N, _>(nodes, packets, ids, r, stack, walk, test, *f) {
                out[*i] = A::from_best(w, walk.best);
                *lane = refill(g, rays, out, &mut next, filter);
                active -= usize::from(lane.is_none());
            }
        }
    }
}

/// A ray in flight in a stream: its index, the ray prepared, its walk, and the filter bound to
/// it (beside the rest, not among its fields: an unfiltered stream's lanes keep the layout
/// they had without filters).
type Lane<'r, F> = ((usize, PreparedRay, Walk), <F as Filter>::On<'r>);

/// The next traceable ray of `rays` from `*next` on, prepared, with its index, a walk at the
/// root and `filter` bound to it; the answers of those skipped (untraceable) are set to a
/// miss.
#[inline(always)]
fn refill<'r, A: Answer, F: Filter + 'r>(
    g: &Geometry,
    rays: &'r [Ray],
    out: &mut [A],
    next: &mut usize,
    filter: F,
) -> Option<Lane<'r, F>> {
    while *next < rays.len() {
        let i = *next;
        *next += 1;
        let ray = &rays[i];
        if PreparedRay::traceable(ray) {
            let r = PreparedRay::prepare(ray, g.coordinate_bound);
            let walk = Walk::new(&r);
            return Some(((i, r, walk), filter.on(ray)));
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
    use crate::test_meshes::{grid, quad, stacked_grids, thin_slab, xorshift};

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
    /// Each layout built from `mesh`, as each of its traversals runs it: the small and the
    /// large tree's (for a wide layout: prefetching, two walks for any hit, and streams), each
    /// through the detected dispatch and the baseline's. Named for messages.
    fn every_traversal(mesh: &TriangleMesh) -> Vec<(String, Geometry)> {
        let mut out = Vec::new();
        for layout in [BvhLayout::Bvh2, BvhLayout::Wide4, BvhLayout::Wide8] {
            let g = Geometry::build_with_layout(std::slice::from_ref(mesh), layout)
                .unwrap_or_else(|e| panic!("{e}"));
            let baseline = Geometry {
                arch: pulp::Arch::Scalar,
                #[cfg(target_arch = "x86_64")]
                v3: None,
                ..g.clone()
            };
            if layout != BvhLayout::Bvh2 {
                out.push((format!("{layout:?} large"), forced_large(&g)));
                out.push((
                    format!("{layout:?} large baseline"),
                    forced_large(&baseline),
                ));
                out.push((format!("{layout:?} baseline"), baseline));
            }
            out.push((format!("{layout:?}"), g));
        }
        out
    }

    /// Random rays through the stacked grids' box, from inside it as well as outside (so some
    /// triangles are behind their origin), a third of them segments; among them rays that
    /// cannot hit anything.
    fn rays_through_layers(seed: u32, n: usize) -> Vec<Ray> {
        let mut next = xorshift(seed);
        (0..n)
            .map(|i| {
                let o = Vec3::new(next(), next(), next()) * Vec3::new(1.5, 1.0, 1.5);
                let target = Vec3::new(next(), next() * 0.5, next());
                let mut ray = Ray::new(o, target - o);
                match i % 13 {
                    1 | 4 | 7 => ray.t_max = 1.5 * next().abs(),
                    5 => ray.direction = Vec3::ZERO,
                    11 => ray.t_max = 0.0,
                    _ => {}
                }
                ray
            })
            .collect()
    }

    /// A filter is only asked about candidates in front of the origin and before `t_max`.
    fn in_range(ray: &Ray, hit: &Hit) {
        assert!(
            hit.t > 0.0 && hit.t < ray.t_max,
            "asked about {hit:?} of {ray:?}"
        );
    }

    /// Every filtered query of `g` (one ray, a batch, a stream; closest and any hit) against
    /// the filtered brute-force oracle, ray by ray.
    fn filtered_like_the_oracle<F: HitFilter + ?Sized>(
        name: &str,
        g: &Geometry,
        rays: &[Ray],
        filter: &F,
    ) -> Result<(), proptest::test_runner::TestCaseError> {
        let mut many = vec![None; rays.len()];
        g.intersect_many_filtered(rays, &mut many, filter);
        let mut stream = vec![None; rays.len()];
        g.intersect_stream_filtered(rays, &mut stream, filter);
        let mut occluded = vec![true; rays.len()];
        g.occluded_stream_filtered(rays, &mut occluded, filter);
        for (k, ray) in rays.iter().enumerate() {
            let closest = g.intersect_brute_force_filtered(ray, filter);
            let any = g.occluded_brute_force_filtered(ray, filter);
            proptest::prop_assert_eq!(any, closest.is_some(), "{} oracle {:?}", name, ray);
            let one = g.intersect_filtered(ray, filter);
            proptest::prop_assert_eq!(one, closest, "{} intersect {:?}", name, ray);
            proptest::prop_assert_eq!(many[k], closest, "{} many {:?}", name, ray);
            proptest::prop_assert_eq!(stream[k], closest, "{} stream {:?}", name, ray);
            let blocked = g.occluded_filtered(ray, filter);
            proptest::prop_assert_eq!(blocked, any, "{} occluded {:?}", name, ray);
            proptest::prop_assert_eq!(occluded[k], any, "{} occluded stream {:?}", name, ray);
        }
        Ok(())
    }

    /// A filter that accepts every hit answers every query exactly as the unfiltered query,
    /// on every layout and traversal, for single rays, batches and streams, and the filtered
    /// oracles answer as the unfiltered ones.
    #[test]
    fn a_filter_that_accepts_everything_changes_no_answer() {
        let mesh = stacked_grids(3);
        let rays = rays_through_layers(0xACCE_0A11, 400);
        // Every test filter is a `dyn HitFilter`: each distinct filter type instantiates every
        // traversal again, at opt-level 3 (the unit tests' build time).
        let all: &dyn HitFilter = &|ray: &Ray, hit: &Hit| {
            in_range(ray, hit);
            true
        };
        for (name, g) in every_traversal(&mesh) {
            let (mut many, mut stream) = (vec![None; rays.len()], vec![None; rays.len()]);
            g.intersect_many(&rays, &mut many);
            g.intersect_stream(&rays, &mut stream);
            let (mut many_f, mut stream_f) = (vec![None; rays.len()], vec![None; rays.len()]);
            g.intersect_many_filtered(&rays, &mut many_f, all);
            g.intersect_stream_filtered(&rays, &mut stream_f, all);
            let (mut occluded, mut occluded_f) = (vec![false; rays.len()], vec![false; rays.len()]);
            g.occluded_stream(&rays, &mut occluded);
            g.occluded_stream_filtered(&rays, &mut occluded_f, all);
            assert_eq!(many, many_f, "{name}");
            assert_eq!(stream, stream_f, "{name}");
            assert_eq!(occluded, occluded_f, "{name}");
            let mut hits = 0;
            for ray in &rays {
                let hit = g.intersect(ray);
                assert_eq!(g.intersect_filtered(ray, all), hit, "{name} {ray:?}");
                assert_eq!(
                    g.occluded_filtered(ray, all),
                    g.occluded(ray),
                    "{name} {ray:?}"
                );
                let brute = g.intersect_brute_force(ray);
                assert_eq!(g.intersect_brute_force_filtered(ray, all), brute);
                assert_eq!(
                    g.occluded_brute_force_filtered(ray, all),
                    g.occluded_brute_force(ray)
                );
                hits += usize::from(hit.is_some());
            }
            assert!(hits > 200, "{name}: {hits} hits");
        }
    }

    /// The filters of `filtered_queries_answer_as_the_filtered_oracle` do change answers: in
    /// the stacked grids, rejected hits reveal farther layers, and rays that only cut-outs
    /// stood in the way of get through.
    #[test]
    fn rejected_hits_reveal_farther_layers() {
        let g = Geometry::build(&[stacked_grids(3)]).unwrap_or_else(|e| panic!("{e}"));
        let rays = rays_through_layers(0x1A7E_5EED, 400);
        let by_id = |_: &Ray, hit: &Hit| hit.triangle.wrapping_mul(0x9e37_79b9) >> 31 == 0;
        let cut_out = |_: &Ray, hit: &Hit| hit.b1 <= 0.5;
        for (name, filter) in [("by id", &by_id as &dyn HitFilter), ("cut-out", &cut_out)] {
            let (mut farther, mut through) = (0, 0);
            for ray in &rays {
                let (hit, filtered) = (g.intersect(ray), g.intersect_filtered(ray, filter));
                match (hit, filtered) {
                    (Some(h), Some(f)) if f.t > h.t => farther += 1,
                    (Some(_), None) => through += 1,
                    (h, f) => assert_eq!(h, f, "{name} {ray:?}"),
                }
                assert_eq!(g.occluded_filtered(ray, filter), filtered.is_some());
            }
            assert!(
                farther > 30 && through > 10,
                "{name}: {farther} farther, {through} through"
            );
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(24))]

        /// Filtered queries equal the filtered brute-force oracle on every layout and
        /// traversal, for random rays through stacked grids, with filters that reject: a
        /// pseudo-random half of the triangles by id; a pseudo-random half of the candidates by
        /// ray and triangle (stochastic transparency, which streams must ask about with each
        /// lane's own ray); part of each triangle (`b1 > 0.5`, a cut-out); and everything.
        #[test]
        fn filtered_queries_answer_as_the_filtered_oracle(seed in 1u32.., which in 0usize..4) {
            let mesh = stacked_grids(3);
            let rays = rays_through_layers(seed, 48);
            let hash = |x: u32| (x ^ (x >> 16)).wrapping_mul(0x7feb_352d) >> 31 == 0;
            let by_id = |ray: &Ray, hit: &Hit| {
                in_range(ray, hit);
                hash(hit.triangle.wrapping_mul(0x9e37_79b9) ^ seed)
            };
            let stochastic = |ray: &Ray, hit: &Hit| {
                in_range(ray, hit);
                let bits = ray.origin.to_array().map(f32::to_bits);
                hash(bits[0] ^ bits[1].rotate_left(11) ^ bits[2].rotate_left(22) ^ hit.triangle)
            };
            let cut_out = |ray: &Ray, hit: &Hit| {
                in_range(ray, hit);
                hit.b1 <= 0.5
            };
            let none: &dyn HitFilter = &|ray: &Ray, hit: &Hit| {
                in_range(ray, hit);
                false
            };
            let filters: [&dyn HitFilter; 4] = [&by_id, &stochastic, &cut_out, none];
            for (name, g) in every_traversal(&mesh) {
                filtered_like_the_oracle(&name, &g, &rays, filters[which])?;
            }
            if which == 3 {
                for (name, g) in every_traversal(&mesh) {
                    for ray in &rays {
                        proptest::prop_assert_eq!(g.intersect_filtered(ray, none), None, "{}", name);
                        proptest::prop_assert!(!g.occluded_filtered(ray, none), "{}", name);
                    }
                }
            }
        }
    }

    /// Two quads, one above the other: rejecting the near one makes the far one the closest
    /// hit, and occludes the ray only if the far one is before `t_max`; rejecting both lets
    /// the ray through. On every layout and traversal, one ray and a stream.
    #[test]
    fn a_rejected_near_quad_reveals_the_far_one() {
        let meshes = [quad(0.0, 0), quad(1.0, 1)];
        let mut both = meshes[0].clone();
        both.positions.extend(meshes[1].positions.iter().copied());
        both.indices.extend([[4, 5, 6], [4, 6, 7]]);
        both.material_ids.extend([1, 1]);
        let down = Ray::new(Vec3::new(0.7, 0.2, 2.0), Vec3::NEG_Z);
        for (name, g) in every_traversal(&both) {
            let near = g
                .intersect(&down)
                .unwrap_or_else(|| panic!("{name}: missed"));
            assert_eq!(g.material_id(near.triangle), 1, "{name}");
            let not_near: &dyn HitFilter = &|ray: &Ray, hit: &Hit| {
                in_range(ray, hit);
                assert_eq!(ray.origin, down.origin, "the ray as given");
                g.material_id(hit.triangle) != 1
            };
            let neither: &dyn HitFilter = &|ray: &Ray, hit: &Hit| {
                in_range(ray, hit);
                false
            };
            let far = g
                .intersect_filtered(&down, not_near)
                .unwrap_or_else(|| panic!("{name}: the far quad is behind the near one"));
            assert_eq!(g.material_id(far.triangle), 0, "{name}");
            // t = 2 exactly in exact arithmetic (see `closest_of_two_quads_and_its_surface`).
            assert!((far.t - 2.0).abs() < 1e-6, "{name}: {}", far.t);
            assert_eq!(g.intersect_filtered(&down, neither), None, "{name}");
            // Segments ending beyond the far quad, between the two, and before the near one.
            for (t_max, blocked) in [(3.0, true), (1.5, false), (0.5, false)] {
                let ray = Ray { t_max, ..down };
                assert_eq!(
                    g.occluded_filtered(&ray, not_near),
                    blocked,
                    "{name} {t_max}"
                );
                assert_eq!(g.occluded(&ray), t_max > 1.0, "{name} {t_max}");
                assert!(!g.occluded_filtered(&ray, neither), "{name} {t_max}");
                let want = blocked.then_some(far);
                assert_eq!(g.intersect_filtered(&ray, not_near), want, "{name} {t_max}");
            }
            let rays = [down, Ray { t_max: 1.5, ..down }, down];
            let mut hits = [None; 3];
            g.intersect_stream_filtered(&rays, &mut hits, not_near);
            assert_eq!(hits, [Some(far), None, Some(far)], "{name}");
            let mut occluded = [false; 3];
            g.occluded_stream_filtered(&rays, &mut occluded, not_near);
            assert_eq!(occluded, [true, false, true], "{name}");
        }
    }

    /// In a stack of 32 quads (1/100 apart, so that leaves and packets hold triangles of
    /// several), accepting the hits of one layer only finds that layer, however deep in its
    /// packet: the closest lanes are rejected one after the other, and any hit asks every lane.
    #[test]
    fn a_stack_of_cut_outs_is_seen_through_to_the_accepted_layer() {
        let mut stack = TriangleMesh::default();
        for layer in 0..32u32 {
            let q = quad(0.01 * layer as f32, layer);
            stack
                .indices
                .extend(q.indices.iter().map(|t| t.map(|v| v + 4 * layer)));
            stack.positions.extend(q.positions);
            stack.material_ids.extend(q.material_ids);
        }
        let mut next = xorshift(0x57AC_4ED0);
        let rays: Vec<Ray> = (0..8)
            .map(|_| {
                let o = Vec3::new(0.5 + 0.4 * next(), 0.5 + 0.4 * next(), 1.0);
                Ray::new(o, Vec3::new(0.05 * next(), 0.05 * next(), -1.0))
            })
            .collect();
        for (name, g) in every_traversal(&stack) {
            for layer in 0..32u32 {
                let only: &dyn HitFilter = &|ray: &Ray, hit: &Hit| {
                    in_range(ray, hit);
                    g.material_id(hit.triangle) == layer
                };
                // Layer `layer` and, behind it, the bottom one: the closest is `layer`.
                let and_bottom: &dyn HitFilter = &|ray: &Ray, hit: &Hit| {
                    only.accept(ray, hit) || g.material_id(hit.triangle) == 0
                };
                for ray in &rays {
                    let hit = g
                        .intersect_filtered(ray, only)
                        .unwrap_or_else(|| panic!("{name}: layer {layer} not found"));
                    assert_eq!(g.material_id(hit.triangle), layer, "{name}");
                    assert_eq!(
                        Some(hit),
                        g.intersect_brute_force_filtered(ray, only),
                        "{name}"
                    );
                    assert_eq!(g.intersect_filtered(ray, and_bottom), Some(hit), "{name}");
                    assert!(g.occluded_filtered(ray, only), "{name} {layer}");
                    // A segment ending between the layer and the one above it (whose hits,
                    // like all above, are rejected).
                    let short = Ray {
                        t_max: hit.t - 0.005,
                        ..*ray
                    };
                    assert!(!g.occluded_filtered(&short, only), "{name} {layer}");
                    assert_eq!(g.intersect_filtered(&short, only), None, "{name} {layer}");
                }
                let mut occluded = vec![false; rays.len()];
                g.occluded_stream_filtered(&rays, &mut occluded, only);
                assert!(occluded.iter().all(|&o| o), "{name} {layer}");
            }
        }
    }

    /// A ray starting between the quads is not asked about the quad behind it, whichever way
    /// it points, nor about one beyond its `t_max`.
    #[test]
    fn a_filter_is_never_asked_about_what_is_behind_or_beyond() {
        let mut both = quad(0.0, 0);
        let top = quad(1.0, 1);
        both.positions.extend(top.positions);
        both.indices.extend([[4, 5, 6], [4, 6, 7]]);
        both.material_ids.extend([1, 1]);
        for (name, g) in every_traversal(&both) {
            for (d, ahead) in [(Vec3::NEG_Z, 0), (Vec3::Z, 1)] {
                let ray = Ray::new(Vec3::new(0.3, 0.6, 0.5), d);
                let asked = std::sync::Mutex::new(Vec::new());
                let record: &dyn HitFilter = &|r: &Ray, hit: &Hit| {
                    in_range(r, hit);
                    asked
                        .lock()
                        .unwrap_or_else(|e| e.into_inner())
                        .push(hit.triangle);
                    true
                };
                let hit = g.intersect_filtered(&ray, record);
                assert!(g.occluded_filtered(&ray, record), "{name}");
                assert!(
                    !g.occluded_filtered(&Ray { t_max: 0.25, ..ray }, record),
                    "{name}"
                );
                assert_eq!(
                    hit.map(|h| g.material_id(h.triangle)),
                    Some(ahead),
                    "{name}"
                );
                let asked = asked.into_inner().unwrap_or_else(|e| e.into_inner());
                assert!(!asked.is_empty(), "{name}");
                for t in asked {
                    assert_eq!(g.material_id(t), ahead, "{name}: asked about triangle {t}");
                }
            }
        }
    }
}
