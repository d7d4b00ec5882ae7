//! Building the BVH2 that every layout starts from: obvhs's PLOC + reinsertion for ordinary
//! scenes, and a top-down binned-SAH build for scenes with a large cluster of primitives whose
//! centroids fall in one Morton cell, where PLOC takes superlinear time.
//!
//! # Why PLOC stalls on shared centroids
//! PLOC (Meister & Bittner 2018) sorts the primitives by the Morton code of their centroid and
//! merges each node with its best neighbour within a window of the sorted order, when the two
//! agree. Primitives with one Morton code are in an arbitrary order (obvhs's sort is unstable),
//! and for nested boxes (coincident instances, stacked decals, the same triangle at growing
//! scales) the merge cost `area(a ∪ b)` is the area of the larger box, so most nodes tie between
//! all their smaller neighbours and few pairs agree: each pass merges only a handful of a
//! cluster's nodes, and the passes repeat until the cluster is one node. Measured with obvhs
//! 0.4 (`cargo bench -p irr-geometry -- same_centroid`): 10⁴ nested triangles ~0.3 s,
//! 2·10⁴ ~1 s, 4·10⁴ ~10 s, 10⁵ over a minute.
//!
//! # The fallback
//! A cluster of at most [`CLUSTER_LIMIT`] primitives costs PLOC nothing noticeable, so ordinary
//! scenes keep the PLOC build unchanged. Beyond it the whole scene is built top down: binned SAH
//! over centroids (16 bins on the axis of largest centroid extent), and for a range whose
//! centroids all coincide, a split at the median of box size, so nested boxes end up in a
//! balanced tree ordered by size. Each level is linear, and size-median splits halve, so the
//! build is `O(n log n)` whatever the input. Reinsertion is skipped for such scenes: its search
//! for a better place of each candidate node descends every overlapping subtree, and a cluster
//! of nested boxes overlaps everywhere.

use glam::Vec3A;
use obvhs::{
    aabb::Aabb,
    bvh2::{Bvh2, node::Bvh2Node},
    ploc::{PlocBuilder, PlocSearchDistance, SortPrecision},
};

/// The largest number of primitives sharing a centroid cell for which PLOC is used (see the
/// module docs).
pub(crate) const CLUSTER_LIMIT: usize = 1024;

/// Which builder [`build_bvh2`] used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Builder {
    /// obvhs's PLOC + reinsertion.
    Ploc,
    /// The top-down binned-SAH build, for a scene with a cluster beyond [`CLUSTER_LIMIT`].
    TopDown,
}

/// The BVH2 over `aabbs` (leaves of one primitive, `primitive_indices` numbering `aabbs`) and
/// the builder that made it.
pub(crate) fn build_bvh2(aabbs: &[Aabb]) -> (Bvh2, Builder) {
    let n = aabbs.len();
    if largest_cluster(aabbs) <= CLUSTER_LIMIT {
        // obvhs's `medium_build` recipe: PLOC with a search radius of 14, then reinsertion
        // (Meister & Bittner 2017).
        let mut bvh = PlocBuilder::with_capacity(n).build(
            PlocSearchDistance::Medium,
            aabbs,
            (0..n as u32).collect(),
            SortPrecision::U64,
            3,
        );
        obvhs::bvh2::reinsertion::ReinsertionOptimizer::default().run(&mut bvh, 0.05, None);
        (bvh, Builder::Ploc)
    } else {
        (top_down(aabbs), Builder::TopDown)
    }
}

/// The most primitives whose centroids share one cell of the 2²¹-per-axis grid over the
/// centroids' bounds (the cells of PLOC's 64-bit Morton codes).
fn largest_cluster(aabbs: &[Aabb]) -> usize {
    if aabbs.len() <= CLUSTER_LIMIT {
        return aabbs.len();
    }
    let mut lo = Vec3A::INFINITY;
    let mut hi = Vec3A::NEG_INFINITY;
    for a in aabbs {
        lo = lo.min(a.center());
        hi = hi.max(a.center());
    }
    const CELLS: f32 = (1 << 21) as f32;
    let extent = hi - lo;
    let scale = Vec3A::select(
        extent.cmpgt(Vec3A::ZERO),
        Vec3A::splat(CELLS) / extent,
        Vec3A::ZERO,
    );
    let mut keys: Vec<u64> = aabbs
        .iter()
        .map(|a| {
            let q = ((a.center() - lo) * scale).min(Vec3A::splat(CELLS - 1.0));
            u64::from(q.x as u32) | u64::from(q.y as u32) << 21 | u64::from(q.z as u32) << 42
        })
        .collect();
    keys.sort_unstable();
    keys.chunk_by(|a, b| a == b)
        .map(<[u64]>::len)
        .max()
        .unwrap_or(0)
}

/// Number of SAH bins.
const BINS: usize = 16;

/// The top-down build (see the module docs). Nodes follow obvhs's layout: the root at 0, each
/// pair of siblings at `(2k + 1, 2k + 2)`, children after their parents.
fn top_down(aabbs: &[Aabb]) -> Bvh2 {
    let n = aabbs.len();
    let mut indices: Vec<u32> = (0..n as u32).collect();
    let mut nodes = vec![Bvh2Node::default(); 2 * n - 1];
    let mut next = 1;
    let mut deepest = 1;
    // (node, first, end, depth): the node covering `indices[first..end]`.
    let mut todo = vec![(0usize, 0usize, n, 1usize)];
    while let Some((node, first, end, depth)) = todo.pop() {
        deepest = deepest.max(depth);
        let range = &mut indices[first..end];
        let bounds = range
            .iter()
            .fold(Aabb::empty(), |b, &i| b.union(&aabbs[i as usize]));
        if range.len() == 1 {
            nodes[node] = Bvh2Node::new(bounds, 1, first as u32);
            continue;
        }
        let mid = first + split(range, aabbs);
        nodes[node] = Bvh2Node::new(bounds, 0, next as u32);
        todo.push((next, first, mid, depth + 1));
        todo.push((next + 1, mid, end, depth + 1));
        next += 2;
    }
    Bvh2 {
        nodes,
        primitive_indices: indices,
        children_are_ordered_after_parents: true,
        max_depth: deepest.max(obvhs::bvh2::DEFAULT_MAX_STACK_DEPTH),
        ..Bvh2::default()
    }
}

/// Reorders `range` (at least two primitives) into two non-empty parts and returns the size of
/// the first: the best of the binned SAH splits on the axis of largest centroid extent, or,
/// where the centroids all coincide or no split separates them, the median of box size.
fn split(range: &mut [u32], aabbs: &[Aabb]) -> usize {
    let len = range.len();
    let mut lo = Vec3A::INFINITY;
    let mut hi = Vec3A::NEG_INFINITY;
    for &i in range.iter() {
        let c = aabbs[i as usize].center();
        lo = lo.min(c);
        hi = hi.max(c);
    }
    let extent = hi - lo;
    let axis = extent.max_position();
    if extent[axis] > 0.0 {
        let scale = BINS as f32 / extent[axis];
        let bin = |i: u32| {
            let c = aabbs[i as usize].center()[axis];
            (((c - lo[axis]) * scale) as usize).min(BINS - 1)
        };
        let mut counts = [0usize; BINS];
        let mut boxes = [Aabb::empty(); BINS];
        for &i in range.iter() {
            let b = bin(i);
            counts[b] += 1;
            boxes[b] = boxes[b].union(&aabbs[i as usize]);
        }
        // Sweep from the right to get the cost of every right part, then from the left.
        let mut right_cost = [0.0f32; BINS];
        let (mut acc, mut count) = (Aabb::empty(), 0);
        for b in (1..BINS).rev() {
            acc = acc.union(&boxes[b]);
            count += counts[b];
            right_cost[b] = acc.half_area() * count as f32;
        }
        let (mut acc, mut count) = (Aabb::empty(), 0);
        let mut best = (f32::INFINITY, 0);
        for b in 0..BINS - 1 {
            acc = acc.union(&boxes[b]);
            count += counts[b];
            let cost = acc.half_area() * count as f32 + right_cost[b + 1];
            if count > 0 && count < len && cost < best.0 {
                best = (cost, b);
            }
        }
        if best.0 < f32::INFINITY {
            let mut left = 0;
            for k in 0..len {
                if bin(range[k]) <= best.1 {
                    range.swap(k, left);
                    left += 1;
                }
            }
            return left;
        }
    }
    // Coincident centroids (or all in one bin): the smaller boxes to the left.
    let mid = len / 2;
    range.select_nth_unstable_by(mid, |&a, &b| {
        let area = |i: u32| aabbs[i as usize].half_area();
        area(a).total_cmp(&area(b))
    });
    mid
}
