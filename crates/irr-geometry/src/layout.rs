//! [`BvhLayout`]: the BVH layouts a [`Geometry`] is built with, the nodes each keeps, and how a
//! query reaches its layout's traversal: the run-time dispatch to the wide traversal compiled
//! for the CPU (`wide.rs`), through the [`Job`] each query is, and the BVH2 layout's scalar
//! traversal, the oracle the wide ones are tested against.

use glam::UVec2;
use obvhs::bvh2::node::Bvh2Node;

use crate::Geometry;
use crate::intersect::{PreparedRay, TriHit, box_entry, intersect_triangle};
use crate::query::{Hit, RayFilter};
#[cfg(target_arch = "x86_64")]
use crate::wide::Lanes8;
use crate::wide::{Lanes4, NodeTest, WideBvh};

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
pub(crate) enum Nodes {
    Bvh2(Vec<Bvh2Node>),
    Wide4(WideBvh<1>),
    Wide8(WideBvh<2>),
}

/// What [`Geometry::trace`] computes, on each layout. The one-ray jobs take the ray prepared
/// outside the dispatched function: prepared in there, its fields compete for registers with
/// the traversal's, and LLVM spills them (see docs/performance.md, node test and ray
/// preparation).
pub(crate) trait Job {
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

impl Geometry {
    /// Runs `job` on this BVH: the scalar traversal for the BVH2 layout; on the wide layouts,
    /// the traversal compiled for the CPU found at build time, with the 8-lane node test where
    /// there is AVX2.
    #[inline(always)]
    pub(crate) fn trace<J: Job>(&self, job: J) -> J::Output {
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

    /// BVH2 closest hit that `filter` accepts: returns the index into `bvh_triangles` and the
    /// hit.
    #[inline(always)]
    pub(crate) fn bvh2_closest<const KZ: usize, B: RayFilter>(
        &self,
        nodes: &[Bvh2Node],
        r: &PreparedRay,
        stack: &mut [UVec2],
        filter: B,
    ) -> Option<(usize, TriHit)> {
        let mut best: Option<(usize, TriHit)> = None;
        let mut t_best = r.t_max;
        // The filter is an argument rather than a capture: captured, it would be a reference
        // (to nothing, unfiltered) kept in the closure, and the unfiltered code would differ.
        let mut leaf = |node: &Bvh2Node, t_best: &mut f32, filter: B| {
            let first = node.first_index as usize;
            for i in first..first + node.prim_count as usize {
                if let Some(h) = intersect_triangle::<KZ>(&self.bvh_triangles[i], r, *t_best)
                    && (B::ALL || filter.accept(&self.bvh2_candidate(i, h)))
                {
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
            leaf(root, &mut t_best, filter);
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
                    leaf(a, &mut t_best, filter);
                } else {
                    next = Some(a.first_index as usize);
                }
            }
            // Re-check the farther child against a closer hit just found in the nearer leaf
            // (a miss is ∞, which must not pass when t_best is still an infinite t_max).
            if tb != f32::INFINITY && tb <= t_best {
                if b.is_leaf() {
                    leaf(b, &mut t_best, filter);
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

    /// The [`Hit`] a filter is asked about: `bvh_triangles[i]`, hit as `h`.
    #[inline(always)]
    fn bvh2_candidate(&self, i: usize, h: TriHit) -> Hit {
        Hit {
            t: h.t,
            triangle: self.bvh_ids[i],
            b1: h.b1,
            b2: h.b2,
        }
    }

    /// BVH2 any hit that `filter` accepts.
    #[inline(always)]
    pub(crate) fn bvh2_any<const KZ: usize, B: RayFilter>(
        &self,
        nodes: &[Bvh2Node],
        r: &PreparedRay,
        stack: &mut [UVec2],
        filter: B,
    ) -> bool {
        // The filter an argument, as in `bvh2_closest`, and moved into the inner closure for
        // the same reason.
        let leaf = |node: &Bvh2Node, filter: B| {
            let first = node.first_index as usize;
            (first..first + node.prim_count as usize).any(move |i| {
                matches!(
                    intersect_triangle::<KZ>(&self.bvh_triangles[i], r, r.t_max),
                    Some(h) if B::ALL || filter.accept(&self.bvh2_candidate(i, h))
                )
            })
        };
        let root = &nodes[0];
        if box_entry(root.aabb().min, root.aabb().max, r, r.t_max) == f32::INFINITY {
            return false;
        }
        if root.is_leaf() {
            return leaf(root, filter);
        }
        let mut sp = 0;
        let mut pair = root.first_index as usize;
        loop {
            let a = &nodes[pair];
            let b = &nodes[pair + 1];
            let mut next = None;
            if box_entry(a.aabb().min, a.aabb().max, r, r.t_max) != f32::INFINITY {
                if a.is_leaf() {
                    if leaf(a, filter) {
                        return true;
                    }
                } else {
                    next = Some(a.first_index as usize);
                }
            }
            if box_entry(b.aabb().min, b.aabb().max, r, r.t_max) != f32::INFINITY {
                if b.is_leaf() {
                    if leaf(b, filter) {
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

/// The depth of the deepest BVH2 leaf (the root alone has depth 1).
pub(crate) fn bvh2_depth(nodes: &[Bvh2Node]) -> usize {
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

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::Ray;
    use crate::test_meshes::{grid, nested, quad, thin_slab, xorshift};

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
}
