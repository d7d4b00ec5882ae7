//! Building the BVH2 that every layout starts from (leaves of at most [`LEAF_SIZE`] = 4
//! triangles, one four-triangle packet of the wide layouts): obvhs's PLOC + reinsertion for
//! scenes of at most [`PLOC_LIMIT`] triangles, a lean top-down binned-SAH build above.
//!
//! # Which builder, and why
//! PLOC's scratch alone is about 320 bytes per triangle (its 2n-node output, its builder's
//! buffers, the boxes, then a collapsed copy), more than a whole 10⁶-triangle render may peak
//! at. The lean build needs the prims (32 B/triangle), about half a 48-byte node per triangle
//! and the final leaf order (4 B/triangle), and its trees trace faster on every scene measured
//! but the Cornell box. So: PLOC + reinsertion up to [`PLOC_LIMIT`] = 1024 triangles (where it
//! traced a room faster, and its scratch is a few hundred kilobytes), the lean build above,
//! with reinsertion over every node up to [`REINSERT_LIMIT`] = 2¹⁸ triangles, none beyond,
//! where the build's time and memory matter most. The figures are in docs/performance.md, BVH
//! build.
//!
//! # Why PLOC stalls on shared centroids
//! PLOC (Meister & Bittner 2018) sorts the primitives by the Morton code of their centroid and
//! merges each node with its best neighbour within a window of the sorted order, when the two
//! agree. Primitives with one Morton code are in an arbitrary order (obvhs's sort is unstable),
//! and for nested boxes (coincident instances, stacked decals, the same triangle at growing
//! scales) the merge cost `area(a ∪ b)` is the area of the larger box, so most nodes tie between
//! all their smaller neighbours and few pairs agree: each pass merges only a handful of a
//! cluster's nodes, and the passes repeat until the cluster is one node (with obvhs 0.4, 10⁵
//! nested triangles take over a minute). PLOC now only sees scenes of at most [`PLOC_LIMIT`] =
//! [`CLUSTER_LIMIT`] triangles, where that costs nothing noticeable.
//!
//! # The lean build
//! Top down over one array of [`Prim`]s (box and index, 32 bytes), partitioned in place:
//! - a range of more than [`SWEEP_LIMIT`] primitives is split by binned SAH (16 bins on each
//!   of the three axes over the centroids' box), a smaller one by a full sweep over its
//!   centroids sorted on each axis;
//! - the cost of a side is its box's area times its number of *packets*, `⌈count / 4⌉` (as
//!   Embree's builders count blocks), so splits fall at multiples of four and leaves come out
//!   nearly full: 3.9 triangles per packet on a heightfield;
//! - a range of at most four is a leaf, unless splitting it in two lowers the summed box area
//!   below [`LEAF_SPLIT`] of its own (four wall triangles of a room, not four neighbours of a
//!   surface);
//! - where no split separates the centroids (they coincide, or fall in one bin), the median of
//!   the centroids on the longest axis, or of box size if they coincide, at a multiple of four:
//!   nested boxes end up in a balanced tree ordered by size.
//!
//! Each level costs `O(n)` in all. SAH alone could peel a few primitives per level off a long
//! range (exponentially spaced centroids do that), which would make the build quadratic, so
//! deeper than [`SAH_DEPTH_LIMIT`] (64; ordinary scenes stop before 30) ranges are split at
//! medians instead: at most 64 SAH levels, then `⌈log₂ n⌉` median levels down to
//! [`SWEEP_LIMIT`] primitives, then at most 32 sweep levels on ranges of at most 32: the build
//! is `O(n log n)` whatever the input. It is single-threaded, so the tree does not depend on
//! the thread count. Up to [`REINSERT_LIMIT`] triangles it is
//! followed by obvhs's reinsertion over every node (skipped where many centroids share a cell:
//! its search for a better place of each node descends every overlapping subtree, and a
//! cluster of nested boxes overlaps everywhere).
//!
//! Memory: the prims (32 B/triangle), the nodes (48 B per node, about half a node per
//! triangle) and the final `primitive_indices` (4 B/triangle). The whole build's peak comes
//! later, in `Geometry::build_from`, while the wide BVH's packets are filled from the meshes
//! (see docs/performance.md, memory per triangle).

use glam::Vec3A;
use obvhs::{
    aabb::Aabb,
    bvh2::{Bvh2, leaf_collapser::collapse, node::Bvh2Node, reinsertion::ReinsertionOptimizer},
    ploc::{PlocBuilder, PlocSearchDistance, SortPrecision},
};

/// The largest number of primitives sharing a centroid cell for which reinsertion is run (see
/// the module docs).
pub(crate) const CLUSTER_LIMIT: usize = 1024;

/// Scenes of at most this many triangles are built with PLOC + reinsertion (see the module
/// docs): where it traced faster, and its scratch is a few hundred kilobytes at most.
pub(crate) const PLOC_LIMIT: usize = CLUSTER_LIMIT;

/// The lean build is followed by a reinsertion pass over every node up to this many triangles
/// (see docs/performance.md, BVH build, for what it gains and costs).
pub(crate) const REINSERT_LIMIT: usize = 1 << 18;

/// A range of at most [`LEAF_SIZE`] primitives is split rather than made a leaf when its two
/// halves' box areas sum to less than this fraction of its own.
const LEAF_SPLIT: f32 = 0.7;

/// Which builder [`build_bvh2`] used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Builder {
    /// obvhs's PLOC + reinsertion, leaves collapsed to at most four primitives.
    Ploc,
    /// The lean top-down build.
    TopDown,
}

/// The BVH2 over `prims` (leaves of at most [`LEAF_SIZE`] primitives, `primitive_indices`
/// holding the prims' indices) and the builder that made it.
pub(crate) fn build_bvh2(prims: Vec<Prim>) -> (Bvh2, Builder) {
    let n = prims.len();
    if n <= PLOC_LIMIT {
        // obvhs's `medium_build` recipe: PLOC with a search radius of 14, then reinsertion
        // (Meister & Bittner 2017); then leaves collapsed by SAH to at most four primitives and
        // a second, short reinsertion pass.
        let aabbs: Vec<Aabb> = prims.iter().map(Prim::aabb).collect();
        let mut bvh = PlocBuilder::with_capacity(n).build(
            PlocSearchDistance::Medium,
            &aabbs,
            prims.iter().map(|p| p.index).collect(),
            SortPrecision::U64,
            3,
        );
        ReinsertionOptimizer::default().run(&mut bvh, 0.05, None);
        collapse(&mut bvh, LEAF_SIZE as u32, 3.0);
        ReinsertionOptimizer::default().run(&mut bvh, 0.1, None);
        return (bvh, Builder::Ploc);
    }
    let reinsert = n <= REINSERT_LIMIT && largest_cluster(&prims) <= CLUSTER_LIMIT;
    let mut bvh = top_down(prims);
    if reinsert {
        ReinsertionOptimizer::default().run(&mut bvh, 1.0, None);
    }
    (bvh, Builder::TopDown)
}

/// The most primitives whose centroids share one cell of the 2²¹-per-axis grid over the
/// centroids' bounds (the cells of PLOC's 64-bit Morton codes).
fn largest_cluster(prims: &[Prim]) -> usize {
    if prims.len() <= CLUSTER_LIMIT {
        return prims.len();
    }
    let mut lo = Vec3A::INFINITY;
    let mut hi = Vec3A::NEG_INFINITY;
    for p in prims {
        lo = lo.min(p.center());
        hi = hi.max(p.center());
    }
    const CELLS: f32 = (1 << 21) as f32;
    let extent = hi - lo;
    let scale = Vec3A::select(
        extent.cmpgt(Vec3A::ZERO),
        Vec3A::splat(CELLS) / extent,
        Vec3A::ZERO,
    );
    let mut keys: Vec<u64> = prims
        .iter()
        .map(|p| {
            let q = ((p.center() - lo) * scale).min(Vec3A::splat(CELLS - 1.0));
            u64::from(q.x as u32) | u64::from(q.y as u32) << 21 | u64::from(q.z as u32) << 42
        })
        .collect();
    keys.sort_unstable();
    keys.chunk_by(|a, b| a == b)
        .map(<[u64]>::len)
        .max()
        .unwrap_or(0)
}

/// Primitives per leaf of the lean build: one four-triangle packet of the wide layouts.
pub(crate) const LEAF_SIZE: usize = 4;

/// Number of SAH bins per axis of the lean build.
const SAH_BINS: usize = 16;

/// A primitive of the lean build: its box and its index, in 32 bytes, so that the build
/// partitions one array in place and reads it in order.
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(16))]
pub(crate) struct Prim {
    min: [f32; 3],
    index: u32,
    max: [f32; 3],
    _pad: u32,
}

impl Prim {
    pub(crate) fn new(min: glam::Vec3, max: glam::Vec3, index: u32) -> Prim {
        Prim {
            min: min.to_array(),
            index,
            max: max.to_array(),
            _pad: 0,
        }
    }

    #[inline(always)]
    pub(crate) fn aabb(&self) -> Aabb {
        Aabb::new(Vec3A::from_array(self.min), Vec3A::from_array(self.max))
    }

    #[inline(always)]
    fn center(&self) -> Vec3A {
        (Vec3A::from_array(self.min) + Vec3A::from_array(self.max)) * 0.5
    }
}

/// A bin: the union of its primitives' boxes and their count.
#[derive(Clone, Copy)]
struct Bin {
    bounds: Aabb,
    count: u32,
}

const EMPTY_BIN: Bin = Bin {
    bounds: Aabb {
        min: Vec3A::splat(f32::MAX),
        max: Vec3A::splat(f32::MIN),
    },
    count: 0,
};

/// The cost of `count` primitives in leaves of [`LEAF_SIZE`]: the number of packets.
fn blocks(count: u32) -> f32 {
    count.div_ceil(LEAF_SIZE as u32) as f32
}

/// A node still to build: it covers `prims[first..end]`, whose boxes' union is `bounds` and
/// whose centroids' box is `centroids`.
struct Pending {
    node: usize,
    first: usize,
    end: usize,
    bounds: Aabb,
    centroids: Aabb,
    depth: usize,
}

/// The lean top-down build (see the module docs).
fn top_down(mut prims: Vec<Prim>) -> Bvh2 {
    let n = prims.len();
    let mut bounds = Aabb::empty();
    let mut centroids = Aabb::empty();
    for p in &prims {
        bounds = bounds.union(&p.aabb());
        centroids.extend(p.center());
    }
    // About two nodes per leaf of four; an eighth more for leaves that are not full (the
    // vector grows if that is not enough, and is trimmed at the end).
    let mut nodes = Vec::with_capacity(2 * n.div_ceil(LEAF_SIZE) * 9 / 8);
    nodes.push(Bvh2Node::default());
    let mut deepest = 1;
    let mut todo = vec![Pending {
        node: 0,
        first: 0,
        end: n,
        bounds,
        centroids,
        depth: 1,
    }];
    let mut scratch = Vec::with_capacity(SWEEP_LIMIT);
    while let Some(p) = todo.pop() {
        deepest = deepest.max(p.depth);
        let len = p.end - p.first;
        let range = &mut prims[p.first..p.end];
        let (mid, left, right) = if len <= SWEEP_LIMIT {
            let (cost, mid) = sweep(range, &mut scratch);
            // (A NaN cost, from boxes too large for f32 areas, makes a leaf.)
            let worth_splitting = cost < LEAF_SPLIT * p.bounds.half_area();
            if len <= LEAF_SIZE && !worth_splitting {
                nodes[p.node] = Bvh2Node::new(p.bounds, len as u32, p.first as u32);
                continue;
            }
            (mid, sides(&range[..mid]), sides(&range[mid..]))
        } else if p.depth > SAH_DEPTH_LIMIT {
            split_median(range, &p.centroids)
        } else {
            split_binned(range, &p.centroids)
        };
        let child = nodes.len();
        nodes.push(Bvh2Node::default());
        nodes.push(Bvh2Node::default());
        nodes[p.node] = Bvh2Node::new(p.bounds, 0, child as u32);
        todo.push(Pending {
            node: child + 1,
            first: p.first + mid,
            end: p.end,
            bounds: right.0,
            centroids: right.1,
            depth: p.depth + 1,
        });
        todo.push(Pending {
            node: child,
            first: p.first,
            end: p.first + mid,
            bounds: left.0,
            centroids: left.1,
            depth: p.depth + 1,
        });
    }
    nodes.shrink_to_fit();
    let primitive_indices = prims.iter().map(|p| p.index).collect();
    drop(prims);
    Bvh2 {
        nodes,
        primitive_indices,
        children_are_ordered_after_parents: true,
        max_depth: deepest.max(obvhs::bvh2::DEFAULT_MAX_STACK_DEPTH),
        ..Bvh2::default()
    }
}

/// The union of `part`'s boxes and the box of its centroids.
fn sides(part: &[Prim]) -> (Aabb, Aabb) {
    part.iter()
        .fold((Aabb::empty(), Aabb::empty()), |(b, mut c), p| {
            c.extend(p.center());
            (b.union(&p.aabb()), c)
        })
}

/// Below this depth, ranges are split by SAH; deeper (a tree that SAH keeps peeling a few
/// primitives off, as it can for exponentially spaced centroids), by medians, so that the
/// build stays `O(n log n)`. Far deeper than SAH goes on ordinary scenes (depth 21 on the
/// 10⁶-triangle heightfield, 26 on the benchmark's 10⁶-triangle scene, 23 on 10⁶ nested
/// triangles).
pub(crate) const SAH_DEPTH_LIMIT: usize = 64;

/// Ranges of at most this many primitives are split by a full sweep rather than by bins.
pub(crate) const SWEEP_LIMIT: usize = 32;

/// The cheapest split of `range` (2 to [`SWEEP_LIMIT`] primitives) over every position of its
/// centroids sorted on each axis (ties by position); reorders `range` to it (through `scratch`)
/// and returns its cost and the size of the first part.
fn sweep(range: &mut [Prim], scratch: &mut Vec<Prim>) -> (f32, usize) {
    let len = range.len();
    let mut centers = [Vec3A::ZERO; SWEEP_LIMIT];
    for (c, p) in centers.iter_mut().zip(range.iter()) {
        *c = p.center();
    }
    let mut orders = [[0u8; SWEEP_LIMIT]; 3];
    let mut best = (f32::INFINITY, 0, 1);
    for (axis, order) in orders.iter_mut().enumerate() {
        // Sort by centroid (ties by position): each key is the centroid's bits made to order
        // as integers, above the position.
        let mut keys = [0u64; SWEEP_LIMIT];
        for (k, key) in keys[..len].iter_mut().enumerate() {
            let bits = centers[k][axis].to_bits();
            let ordered = if bits >> 31 == 1 {
                !bits
            } else {
                bits | 1 << 31
            };
            *key = u64::from(ordered) << 8 | k as u64;
        }
        keys[..len].sort_unstable();
        let order = &mut order[..len];
        for (o, key) in order.iter_mut().zip(&keys) {
            *o = *key as u8;
        }
        let mut right = [0.0f32; SWEEP_LIMIT];
        let mut acc = Aabb::empty();
        for k in (1..len).rev() {
            acc = acc.union(&range[usize::from(order[k])].aabb());
            right[k] = acc.half_area() * blocks((len - k) as u32);
        }
        let mut acc = Aabb::empty();
        for k in 1..len {
            acc = acc.union(&range[usize::from(order[k - 1])].aabb());
            let cost = acc.half_area() * blocks(k as u32) + right[k];
            if cost < best.0 {
                best = (cost, axis, k);
            }
        }
    }
    scratch.clear();
    scratch.extend(orders[best.1][..len].iter().map(|&k| range[usize::from(k)]));
    range.copy_from_slice(scratch);
    (best.0, best.2)
}

/// Splits `range` (more than [`SWEEP_LIMIT`] primitives, centroids within `centroids`) in two
/// non-empty parts by binned SAH; returns the size of the first and each part's (bounds,
/// centroid bounds).
fn split_binned(range: &mut [Prim], centroids: &Aabb) -> (usize, (Aabb, Aabb), (Aabb, Aabb)) {
    let len = range.len();
    let lo = centroids.min;
    let extent = centroids.max - centroids.min;
    let scale = Vec3A::select(
        extent.cmpgt(Vec3A::ZERO),
        Vec3A::splat(SAH_BINS as f32) / extent,
        Vec3A::ZERO,
    );
    // The bin of a centroid on each axis: its position scaled to 0..=15 and rounded to the
    // nearest integer by adding 2²³ (whose float spacing is 1), which leaves the integer in
    // the low bits: cheaper than a float-to-integer conversion per axis, and monotonic.
    let last = Vec3A::splat((SAH_BINS - 1) as f32);
    let magic = Vec3A::splat(8_388_608.0);
    let bin_of = |c: Vec3A| {
        let b = ((c - lo) * scale).min(last) + magic;
        [b.x, b.y, b.z].map(|v| ((v.to_bits() & 0x7f_ffff) as usize).min(SAH_BINS - 1))
    };
    let mut bins = [[EMPTY_BIN; SAH_BINS]; 3];
    for p in range.iter() {
        let a = p.aabb();
        let k = bin_of(p.center());
        for axis in 0..3 {
            let bin = &mut bins[axis][k[axis]];
            bin.bounds = bin.bounds.union(&a);
            bin.count += 1;
        }
    }
    // The cheapest split over the three axes: for each, sweep from the right for the cost of
    // every right part, then from the left.
    let mut best: Option<(f32, usize, usize)> = None;
    for axis in 0..3 {
        if scale[axis] <= 0.0 {
            continue;
        }
        let bins = &bins[axis];
        let mut right_cost = [0.0f32; SAH_BINS];
        let (mut acc, mut count) = (Aabb::empty(), 0);
        for b in (1..SAH_BINS).rev() {
            acc = acc.union(&bins[b].bounds);
            count += bins[b].count;
            right_cost[b] = if count > 0 {
                acc.half_area() * blocks(count)
            } else {
                0.0
            };
        }
        let (mut acc, mut count) = (Aabb::empty(), 0);
        for b in 0..SAH_BINS - 1 {
            acc = acc.union(&bins[b].bounds);
            count += bins[b].count;
            if count == 0 || count as usize == len {
                continue;
            }
            let cost = acc.half_area() * blocks(count) + right_cost[b + 1];
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, b));
            }
        }
    }
    if let Some((_, axis, b)) = best {
        let mut left = 0;
        let (mut cl, mut cr) = (Aabb::empty(), Aabb::empty());
        for k in 0..len {
            let c = range[k].center();
            if bin_of(c)[axis] <= b {
                cl.extend(c);
                range.swap(k, left);
                left += 1;
            } else {
                cr.extend(c);
            }
        }
        let union = |bins: &[Bin]| {
            bins.iter()
                .fold(Aabb::empty(), |u, bin| u.union(&bin.bounds))
        };
        return (
            left,
            (union(&bins[axis][..=b]), cl),
            (union(&bins[axis][b + 1..]), cr),
        );
    }
    // No split separates the centroids (they coincide, or all fall in one bin).
    split_median(range, centroids)
}

/// Splits `range` (more than [`LEAF_SIZE`] primitives) at the median of the centroids on their
/// longest axis, or where they coincide, of box size, at a multiple of the leaf size (ties by
/// index); returns the size of the first part and each part's (bounds, centroid bounds).
fn split_median(range: &mut [Prim], centroids: &Aabb) -> (usize, (Aabb, Aabb), (Aabb, Aabb)) {
    let len = range.len();
    let extent = centroids.max - centroids.min;
    let mid = (len / 2).next_multiple_of(LEAF_SIZE).min(len - 1);
    let axis = extent.max_position();
    if extent[axis] > 0.0 {
        range.select_nth_unstable_by(mid, |a, b| {
            a.center()[axis]
                .total_cmp(&b.center()[axis])
                .then(a.index.cmp(&b.index))
        });
    } else {
        range.select_nth_unstable_by(mid, |a, b| {
            a.aabb()
                .half_area()
                .total_cmp(&b.aabb().half_area())
                .then(a.index.cmp(&b.index))
        });
    }
    (mid, sides(&range[..mid]), sides(&range[mid..]))
}
