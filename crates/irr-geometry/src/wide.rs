//! The wide BVH: nodes of `4·G` children (`G` groups of four, tested with one 4-lane slab test
//! per group, or for `G = 2` with one 8-lane AVX test where the CPU has AVX2: [`NodeTest`])
//! whose leaves are packets of up to four triangles ([`Tri4`], tested at once), and
//! its traversals: ordered (nearest child first) for the closest hit, any order with early exit
//! for occlusion (on a large tree, as two walks of the one ray: [`WideBvh::two_walks`]).
//!
//! The tree is the BVH2 of `build.rs` (leaves of at most four triangles) with levels pulled
//! up: a wide node takes its BVH2 node's two children and repeatedly replaces the inner child
//! of largest surface area by its two children, until it has `4·G` children or only leaves
//! (the usual BVH2 → BVH4/BVH8 collapse, as in Embree). Every child box is the exact `f32` box
//! of its BVH2 node, so Ize's relative correction keeps the box test conservative.
//!
//! A BVH2 node whose two children are both leaves is not made a wide node of its own: it
//! becomes one *pair* leaf of its parent, two consecutive packets tested one after the other
//! (a leaf reference with [`PAIR`] set), rather than a node visit, with its four cache lines,
//! only to choose between two packets.
//!
//! On a tree larger than the caches (more than [`LARGE_BYTES`]), the 8-lane traversal
//! prefetches each child as it pushes it: the nearest child is visited next, and the others
//! are on their way by the time they are popped. A node is four cache lines, a packet three,
//! a pair six. On smaller trees it only costs instructions, so it is compiled out there
//! ([`NodeTest::LARGE`]). The packet test's screen shortcut goes the other way (it pays on
//! small trees, whose triangles are large against the scene), and switches at the same size.
//! See docs/performance.md, packet leaves and pair leaves, and prefetching.
//!
//! The conversion runs in two steps so that the BVH2's nodes are freed before the packets are
//! allocated: [`WideBvh::topology`] makes the nodes (counted first, so allocated at their exact
//! size) and lists the leaves, [`WideBvh::fill_packets`] makes the packets and their lanes'
//! triangle ids. The packets are also where [`Geometry`](crate::Geometry) keeps each
//! triangle's vertices (bit for bit as given), which it reads back through
//! [`WideBvh::triangle`].

use obvhs::{aabb::Aabb, bvh2::node::Bvh2Node};

use crate::intersect::{PreparedRay, Tri4, Tri4Hits, TriHit, TriSoa, intersect_tri4};
use crate::pages::{Pages, Plain};
use crate::query::{Hit, RayFilter};

/// A child reference with this bit set is a leaf: the rest is the index of its [`Tri4`] (and
/// [`PAIR`]).
const LEAF: u32 = 1 << 31;
/// A leaf reference with this bit set too is a *pair*: packets `p` and `p + 1` (see the module
/// docs). Packet indices stay below 2³⁰ ([`MAX_TRIANGLES`](crate::MAX_TRIANGLES) triangles
/// make at most as many packets), so the index fits below this bit.
const PAIR: u32 = 1 << 30;
/// The packet index of a leaf reference.
const PACKET_MASK: u32 = PAIR - 1;

/// Trees of more bytes (nodes and packets) than this are *large*: the 8-lane traversal
/// prefetches what it pushes (see the module docs), the packet test computes every filter
/// bound rather than first trying the screen's shortcut (`intersect_tri4`'s `shortcut`: the
/// smaller a scene's triangles against its size, the more edge functions fall within half the
/// screen), and the closest-hit traversal takes no shortcut for one or two children hit.
/// 1 MiB: where prefetching starts to pay, and the shortcuts to cost, on a CPU with 48 KiB of
/// L1 data cache and 2 MiB of L2 a core (see docs/performance.md, prefetching).
const LARGE_BYTES: usize = 1 << 20;

/// The two BVH2 leaves under inner node `b`, if both its children are leaves: such a subtree
/// becomes one pair leaf instead of a wide node of two children.
fn pair_under(nodes: &[Bvh2Node], b: usize) -> Option<[usize; 2]> {
    let first = nodes[b].first_index as usize;
    (nodes[first].is_leaf() && nodes[first + 1].is_leaf()).then_some([first, first + 1])
}

/// An empty child slot (its box is the empty box, which no ray enters).
const EMPTY: u32 = u32::MAX;

/// A node of `4·G` children: the child boxes' min x, y, z and max x, y, z planes, each as `G`
/// groups of four lanes (lane = child), so that one plane of all `4·G` children is contiguous
/// (one 8-lane load for the 8-lane test), and the child references (a node index,
/// `LEAF | packet`, or `EMPTY`).
#[derive(Debug, Clone, Copy, bytemuck::AnyBitPattern)]
#[repr(C, align(64))]
pub(crate) struct WideNode<const G: usize> {
    planes: [[[f32; 4]; G]; 6],
    children: [[u32; 4]; G],
}

impl<const G: usize> Plain for WideNode<G> {
    /// The planes and the children at their offsets (the padding after them is left as it is).
    fn write_to(&self, out: &mut [u8]) {
        let planes = bytemuck::bytes_of(&self.planes);
        out[..planes.len()].copy_from_slice(planes);
        let children = bytemuck::bytes_of(&self.children);
        let at = std::mem::offset_of!(WideNode<G>, children);
        out[at..at + children.len()].copy_from_slice(children);
    }
}

/// How a traversal tests a wide node's children: the entry distances of the `4·G` child boxes
/// (group, lane) and the mask of those entered within `[0, t_best]` (bit `4·group + lane`).
pub(crate) trait NodeTest<const G: usize>: Copy {
    /// Whether the tree is large ([`LARGE_BYTES`]): the traversal prefetches (where the test
    /// can), and takes neither the packet test's screen shortcut nor the closest-hit
    /// traversal's one- and two-child shortcut.
    const LARGE: bool;
    fn hits(self, node: &WideNode<G>, r: &PreparedRay, t_best: f32) -> ([[f32; 4]; G], u32);
    /// Asks for the cache line at `p` without waiting for it, where the test can and the tree
    /// is large; by default, nothing.
    #[inline(always)]
    fn prefetch_line(self, _p: *const u8) {}
    /// Asks for the cache lines of the `size` bytes (192 to 384) from `p` on
    /// ([`NodeTest::prefetch_line`]). Six prefetches whatever the size, without a branch: for
    /// a node (256 bytes) lines 0, 1, 2, 2, 2, 3; for a packet (192) lines 0, 1, 2, 1, 1, 2;
    /// for a pair (384) lines 0 to 5. (Four left a pair's middle lines out, and lost.)
    #[inline(always)]
    fn prefetch(self, p: *const u8, size: usize) {
        for offset in [0, 64, 128, size / 2, size - 128, size - 64] {
            self.prefetch_line(p.wrapping_add(offset));
        }
    }
}

/// The node test as `G` four-lane slab tests (`PreparedRay::hits4`), for any instruction set,
/// on a large tree (`LARGE`) or not.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Lanes4<const LARGE: bool>;

impl<const G: usize, const LARGE: bool> NodeTest<G> for Lanes4<LARGE> {
    const LARGE: bool = LARGE;

    #[inline(always)]
    fn hits(self, node: &WideNode<G>, r: &PreparedRay, t_best: f32) -> ([[f32; 4]; G], u32) {
        let mut t = [[0.0; 4]; G];
        let mut mask = 0;
        for (g, t) in t.iter_mut().enumerate() {
            let (t_near, hit) = r.hits4(&node.planes, g, t_best);
            *t = t_near.to_array();
            mask |= hit << (4 * g);
        }
        (t, mask)
    }
}

/// The 8-wide node test as one 8-lane (AVX) slab test: the same operations on each lane, in the
/// same order, as [`Lanes4`], so the same bits; half the instructions. On a large tree
/// (`LARGE`), the traversal also prefetches each child it pushes (`_mm_prefetch`, which pulp's
/// token offers as a safe call: a prefetch never faults, whatever the address); otherwise that
/// code is compiled out, since prefetching a tree that is in cache only costs instructions.
#[cfg(target_arch = "x86_64")]
#[derive(Debug, Clone, Copy)]
pub(crate) struct Lanes8<const LARGE: bool>(pub(crate) pulp::x86::V3);

#[cfg(target_arch = "x86_64")]
impl<const LARGE: bool> NodeTest<2> for Lanes8<LARGE> {
    const LARGE: bool = LARGE;

    #[inline(always)]
    fn hits(self, node: &WideNode<2>, r: &PreparedRay, t_best: f32) -> ([[f32; 4]; 2], u32) {
        use pulp::bytemuck::cast;
        use std::arch::x86_64::{__m256, _CMP_LE_OQ};
        let avx = self.0.avx;
        let plane = |k: usize| -> __m256 { cast(node.planes[k]) };
        let mut t_near = avx._mm256_setzero_ps();
        let mut t_far = avx._mm256_set1_ps(t_best);
        for a in 0..3 {
            let o = avx._mm256_set1_ps(r.origin[a]);
            let near = avx._mm256_sub_ps(plane(r.slabs.near[a] as usize), o);
            let far = avx._mm256_sub_ps(plane(r.slabs.far[a] as usize), o);
            t_near = avx._mm256_max_ps(
                t_near,
                avx._mm256_mul_ps(near, avx._mm256_set1_ps(r.inv_dir[a])),
            );
            t_far = avx._mm256_min_ps(
                t_far,
                avx._mm256_mul_ps(far, avx._mm256_set1_ps(r.inv_far[a])),
            );
        }
        let mask = avx._mm256_movemask_ps(avx._mm256_cmp_ps::<_CMP_LE_OQ>(t_near, t_far)) as u32;
        (cast(t_near), mask)
    }

    #[inline(always)]
    fn prefetch_line(self, p: *const u8) {
        if LARGE {
            self.0
                .sse
                ._mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p.cast());
        }
    }
}

/// A wide BVH with `4·G` children per node (`G` = 1: BVH4, `G` = 2: BVH8).
#[derive(Debug, Clone)]
pub(crate) struct WideBvh<const G: usize> {
    /// On huge pages where the array is large, like the packets (see `pages.rs`).
    nodes: Pages<WideNode<G>>,
    packets: Pages<Tri4>,
    /// The triangle id of each packet lane, read once per closest hit (for its answer). On
    /// huge pages where the array is large, and on a large tree prefetched when a packet is
    /// hit ([`NodeTest::prefetch_line`]), so that its line is on its way while the traversal
    /// goes on: otherwise a hit's id is one more miss, taken after its traversal, with nothing
    /// left to overlap it (see docs/performance.md, prefetching).
    ids: Pages<[u32; 4]>,
    /// Traversal stack entries the deepest path can need.
    stack_len: usize,
    /// Whether the tree is large (more than [`LARGE_BYTES`]).
    large: bool,
}

/// The children of a wide node made from BVH2 node `b` (inner), into `kids`: `b`'s two
/// children, then repeatedly the inner child of largest area replaced by its two children,
/// until there are `width` or only leaves.
fn open(nodes: &[Bvh2Node], b: usize, width: usize, kids: &mut Vec<usize>) {
    let first = nodes[b].first_index as usize;
    kids.clear();
    kids.extend([first, first + 1]);
    while kids.len() < width {
        let open = kids
            .iter()
            .enumerate()
            .filter(|&(_, &k)| !nodes[k].is_leaf())
            .max_by(|a, b| {
                let area = |k: usize| nodes[k].aabb().half_area();
                area(*a.1).total_cmp(&area(*b.1))
            })
            .map(|(i, _)| i);
        let Some(i) = open else { break };
        let c = nodes[kids[i]].first_index as usize;
        kids[i] = c;
        kids.push(c + 1);
    }
}

/// Fills `node`'s slots with `children` (reference, box) in their order; the rest stay empty.
///
/// On a small tree (not [`LARGE_BYTES`]) the children come ordered by decreasing box area, so
/// that any hit, which visits the last slot hit first ([`WideBvh::step`]), tries the smallest
/// boxes first: in a room those are what stands in it, and the largest are the walls and the
/// floor, which a shadow ray leaves or runs along but seldom meets. (Closest hits visit by
/// entry distance, whatever the slots' order.) A large tree keeps the collapse's order, which
/// was faster there (see docs/performance.md, node child order and traversal shortcuts).
fn set_children<const G: usize>(node: &mut WideNode<G>, children: &[(u32, Aabb)]) {
    for axis in 0..3 {
        node.planes[axis] = [[f32::INFINITY; 4]; G];
        node.planes[3 + axis] = [[f32::NEG_INFINITY; 4]; G];
    }
    for (slot, (child, b)) in children.iter().enumerate() {
        let (g, lane) = (slot / 4, slot % 4);
        node.children[g][lane] = *child;
        for axis in 0..3 {
            node.planes[axis][g][lane] = b.min[axis];
            node.planes[3 + axis][g][lane] = b.max[axis];
        }
    }
}

/// A traversal stack entry: a child reference and the ray's entry distance into its box.
pub(crate) type Entry = (u32, f32);

/// What a traversal ([`WideBvh::step`]) looks for: the closest hit, or with `ANY` any hit (it
/// stops at the first).
pub(crate) trait Query {
    const ANY: bool;
}

/// Where one ray's traversal is ([`WideBvh::step`]): the node or leaf to visit next, the
/// height of its stack, the distance within which hits count, and the closest hit so far (or
/// the first, for any hit).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Walk {
    current: u32,
    sp: usize,
    t_best: f32,
    pub(crate) best: Option<(u32, usize, TriHit)>,
}

impl Walk {
    /// At the root, nothing hit yet.
    #[inline(always)]
    pub(crate) fn new(r: &PreparedRay) -> Walk {
        Walk {
            current: 0,
            sp: 0,
            t_best: r.t_max,
            best: None,
        }
    }
}

impl<const G: usize> WideBvh<G> {
    /// Converts the BVH2 `nodes` (leaves of at most four primitives) into wide nodes, without
    /// packets yet: leaf children are numbered in the order this visits them, and the returned
    /// list gives, for each packet in that order, its BVH2 leaf's primitives packed as
    /// `first << 2 | (count − 1)` (`first` indexes the BVH2's `primitive_indices`; the caller
    /// keeps fewer than 2³⁰ primitives). [`WideBvh::fill_packets`] then makes the packets, so
    /// that the BVH2 nodes can be dropped before the packets are allocated.
    pub(crate) fn topology(nodes: &[Bvh2Node]) -> (WideBvh<G>, Vec<u32>) {
        let width = 4 * G;
        let root = &nodes[0];
        let mut kids: Vec<usize> = Vec::with_capacity(width);
        // A first pass counts the wide nodes and the leaves, so that both lists are allocated
        // at their exact size.
        let (mut node_count, mut leaf_count) = (1, usize::from(root.is_leaf()));
        let mut todo: Vec<usize> = Vec::new();
        if !root.is_leaf() {
            todo.push(0);
        }
        while let Some(b) = todo.pop() {
            open(nodes, b, width, &mut kids);
            for &k in &kids {
                if nodes[k].is_leaf() {
                    leaf_count += 1;
                } else if pair_under(nodes, k).is_some() {
                    leaf_count += 2;
                } else {
                    node_count += 1;
                    todo.push(k);
                }
            }
        }
        let bytes = node_count * size_of::<WideNode<G>>() + leaf_count * size_of::<Tri4>();
        let mut out = WideBvh {
            nodes: Pages::default(),
            packets: Pages::default(),
            ids: Pages::default(),
            stack_len: 0,
            large: bytes > LARGE_BYTES,
        };
        let mut leaves = Vec::with_capacity(leaf_count);
        let mut leaf = |list: &[usize]| {
            let index = leaves.len() as u32;
            for &b in list {
                let node = &nodes[b];
                leaves.push(node.first_index << 2 | (node.prim_count - 1));
            }
            LEAF | if list.len() == 2 { PAIR } else { 0 } | index
        };
        // (BVH2 node whose children fill the wide node, wide node index, depth).
        let mut todo: Vec<(usize, usize, usize)> = Vec::new();
        let mut deepest = 1;
        let mut wide = Vec::with_capacity(node_count);
        wide.push(WideNode {
            planes: [[[0.0; 4]; G]; 6],
            children: [[EMPTY; 4]; G],
        });
        if root.is_leaf() {
            // A single leaf: a root node with one leaf child.
            let child = leaf(&[0]);
            set_children(&mut wide[0], &[(child, *root.aabb())]);
        } else {
            todo.push((0, 0, 1));
        }
        let mut slots: Vec<(u32, Aabb)> = Vec::with_capacity(width);
        while let Some((b, w, depth)) = todo.pop() {
            deepest = deepest.max(depth + 1);
            open(nodes, b, width, &mut kids);
            slots.clear();
            for &k in &kids {
                let node = &nodes[k];
                let child = if node.is_leaf() {
                    leaf(&[k])
                } else if let Some(pair) = pair_under(nodes, k) {
                    leaf(&pair)
                } else {
                    let index = wide.len();
                    wide.push(WideNode {
                        planes: [[[0.0; 4]; G]; 6],
                        children: [[EMPTY; 4]; G],
                    });
                    todo.push((k, index, depth + 1));
                    index as u32
                };
                slots.push((child, *node.aabb()));
            }
            if !out.large {
                // Largest box first (see `set_children`).
                slots.sort_by(|a, b| b.1.half_area().total_cmp(&a.1.half_area()));
            }
            set_children(&mut wide[w], &slots);
        }
        // Each visited node pops one entry and pushes at most `4·G`; a pair pops one and
        // pushes one. One more slot for the write above the top at a leaf (see `closest`).
        out.stack_len = (width - 1) * deepest + 2;
        out.nodes = Pages::from_vec(wide);
        (out, leaves)
    }

    /// Makes the packets of `leaves` (from [`WideBvh::topology`]), whose primitives
    /// `primitive_indices` numbers, and their lanes' triangle ids (a packet of fewer than four
    /// repeats its last); `triangle(id)` gives triangle `id` as the scalar test reads it. Sets
    /// `slots[id]` to `4·packet + lane` of the first lane holding triangle `id`.
    pub(crate) fn fill_packets(
        &mut self,
        leaves: &[u32],
        primitive_indices: &[u32],
        triangle: impl Fn(u32) -> TriSoa,
        slots: &mut [u32],
    ) {
        // The nodes onto huge pages first: their heap copy is freed before the packets are
        // allocated, so this adds nothing to the build's peak memory. The ids then go straight
        // onto huge pages too (where the array is large), not through a heap copy.
        self.nodes = std::mem::take(&mut self.nodes).onto_huge_pages();
        // Packet `packet`'s primitives (one to four), from its `first << 2 | (count − 1)`.
        let prims = |packet: usize| {
            let leaf = leaves[packet] as usize;
            let first = leaf >> 2;
            &primitive_indices[first..=first + (leaf & 3)]
        };
        self.packets = Pages::from_fn(leaves.len(), |packet| {
            let prims = prims(packet);
            let mut tris = [TriSoa::default(); 4];
            for (lane, &id) in prims.iter().enumerate() {
                tris[lane] = triangle(id);
                slots[id as usize] = (packet * 4 + lane) as u32;
            }
            Tri4::new(&tris[..prims.len()])
        });
        self.ids = Pages::from_fn(leaves.len(), |packet| {
            let prims = prims(packet);
            std::array::from_fn(|lane| prims[lane.min(prims.len() - 1)])
        });
    }

    /// Triangle `slot >> 2`'s lane `slot & 3`, as the scalar test reads it: its vertices
    /// exactly as given to the build, and its unit normal.
    #[inline]
    pub(crate) fn triangle(&self, slot: u32) -> TriSoa {
        self.packets[(slot >> 2) as usize].lane((slot & 3) as usize)
    }

    /// Bytes of the nodes, the packets (on the heap or on huge pages) and the packets'
    /// triangle ids.
    pub(crate) fn heap_bytes(&self) -> [(&'static str, usize); 3] {
        [
            ("wide nodes", self.nodes.len() * size_of::<WideNode<G>>()),
            ("triangle packets", self.packets.len() * size_of::<Tri4>()),
            (
                "packet triangle ids",
                self.ids.len() * size_of::<[u32; 4]>(),
            ),
        ]
    }

    pub(crate) fn stack_len(&self) -> usize {
        self.stack_len
    }

    pub(crate) fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The triangle id of a packet lane.
    #[inline(always)]
    pub(crate) fn id(&self, packet: u32, lane: usize) -> u32 {
        self.ids[packet as usize][lane]
    }

    /// One step of a traversal from the root (`walk` from [`Walk::new`]; run until it returns
    /// `true`), for the closest hit or, with `Q::ANY`, for any hit: visits `walk.current` (a
    /// node, or a leaf's packet; on the first packet it finishes preparing `r`,
    /// [`PreparedRay::finish`]) and picks the next, from the stack unless a shortcut chose it.
    /// Returns whether the traversal is over, with the answer in `walk.best` as (packet, lane,
    /// hit): the stack ran out, or (`Q::ANY`) a packet was hit, which `walk.best` then holds with
    /// lane 0 and no meaningful hit. `query.rs` runs one ray's steps in a loop, or
    /// interleaves several rays' steps (its streams), or two walks' steps of one ray
    /// ([`WideBvh::two_walks`]).
    ///
    /// Closest hit: children are visited nearest first: the hit children of a node are pushed
    /// farthest first, and an entry farther than the best hit so far is dropped when popped.
    /// On a small tree, a node with one child hit goes straight to it, and one with two pushes
    /// the farther and goes to the nearer, in the order the general sort would give: those
    /// visits skip the stack, or the sort loop and its mispredicted exit. Not on a large tree,
    /// where the branches on the number of children hit mispredict more than the shortcut
    /// saves. Either way the nodes are visited in the same order.
    ///
    /// Any hit: children in any order, stopping at the first hit. The last child pushed is
    /// visited next straight from a register, not read back from the stack.
    ///
    /// The alternatives measured and rejected (branch-free variants of both, other visit
    /// orders) are in docs/performance.md, node child order and traversal shortcuts.
    ///
    /// Only hits that `filter` accepts count: a packet's hit lanes are asked closest first
    /// (closest hit) or in lane order (any hit) until one is accepted; rejected lanes leave
    /// `t_best` as it was. With [`RayFilter::ALL`] (the unfiltered queries) none of that is
    /// compiled.
    #[inline(always)]
    #[expect(
        clippy::too_many_arguments,
        reason = "the tree's arrays, the ray's state and the query's parts, all inlined"
    )]
    pub(crate) fn step<Q: Query, N: NodeTest<G>, B: RayFilter>(
        nodes: &[WideNode<G>],
        packets: &[Tri4],
        ids: &Pages<[u32; 4]>,
        r: &mut PreparedRay,
        stack: &mut [Entry],
        walk: &mut Walk,
        test: N,
        filter: B,
    ) -> bool {
        let Walk {
            current,
            sp,
            t_best,
            best,
        } = walk;
        if *current & LEAF != 0 {
            let p = *current & PACKET_MASK;
            // The triangle test's part of the preparation, on the ray's first packet.
            r.finish();
            let hits = intersect_tri4(&packets[p as usize], r, *t_best, !N::LARGE);
            if Q::ANY {
                if hits.mask != 0 && (B::ALL || Self::any_accepted(ids, p, &hits, filter)) {
                    *best = Some((p, 0, TriHit::default()));
                    return true;
                }
            } else {
                // On the mask, which is known before the closest lane is (the same test:
                // `closest` finds a lane exactly when one hit), and which spares a packet
                // without a hit the lane search.
                if hits.mask != 0 {
                    // The packet's triangle ids, which the answer will read, on their way
                    // while the traversal goes on (a large tree's only; see `ids`).
                    test.prefetch_line(ids.as_ptr().wrapping_add(p as usize).cast());
                    if B::ALL {
                        let (lane, h) = hits.closest();
                        *t_best = h.t;
                        *best = Some((p, lane, h));
                    } else if let Some((lane, h)) = Self::closest_accepted(ids, p, &hits, filter) {
                        *t_best = h.t;
                        *best = Some((p, lane, h));
                    }
                }
            }
            // A pair's second packet is popped next (without a branch: the slot above the
            // top is written either way, and counted only for a pair).
            stack[*sp] = (LEAF | (p + 1), 0.0);
            *sp += ((*current & PAIR) >> 30) as usize;
        } else {
            let node = &nodes[*current as usize];
            let first = *sp;
            let (t_near, mut hit) = test.hits(node, r, *t_best);
            // (A small tree's traversal does not prefetch, so neither shortcut does.)
            if !Q::ANY && !N::LARGE && hit.is_power_of_two() {
                // One child hit: visit it next, without the stack.
                let l = hit.trailing_zeros() as usize;
                *current = node.children[l / 4][l % 4];
                return false;
            }
            if !Q::ANY && !N::LARGE && hit.count_ones() == 2 {
                // Two: push the farther, visit the nearer (of equal distances the second,
                // as the insertion below orders them).
                let (a, b) = (
                    hit.trailing_zeros() as usize,
                    31 - hit.leading_zeros() as usize,
                );
                let ea = (node.children[a / 4][a % 4], t_near[a / 4][a % 4]);
                let eb = (node.children[b / 4][b % 4], t_near[b / 4][b % 4]);
                let (near, far) = if ea.1 < eb.1 { (ea, eb) } else { (eb, ea) };
                stack[*sp] = far;
                *sp += 1;
                *current = near.0;
                return false;
            }
            // (Any hit:) the last child pushed, popped next.
            let mut top = EMPTY;
            while hit != 0 {
                let l = hit.trailing_zeros() as usize;
                hit &= hit - 1;
                let child = node.children[l / 4][l % 4];
                Self::prefetch_child(test, nodes, packets, child);
                if Q::ANY {
                    // Any order: no distance, no sort.
                    stack[*sp].0 = child;
                    top = child;
                } else {
                    // Insertion sort, farthest at the bottom: the nearest is popped first.
                    let entry = (child, t_near[l / 4][l % 4]);
                    let mut i = *sp;
                    while i > first && stack[i - 1].1 < entry.1 {
                        stack[i] = stack[i - 1];
                        i -= 1;
                    }
                    stack[i] = entry;
                }
                *sp += 1;
            }
            if Q::ANY && *sp > first {
                // The last child pushed, popped next: from a register rather than read back
                // from the stack.
                *sp -= 1;
                *current = top;
                return false;
            }
        }
        loop {
            if *sp == 0 {
                return true;
            }
            *sp -= 1;
            let (c, t) = stack[*sp];
            // (Any hit has no order, and no entry beyond `t_max`: its node test saw to that.)
            if Q::ANY || t <= *t_best {
                *current = c;
                return false;
            }
        }
    }

    /// The closest of packet `p`'s hit lanes that `filter` accepts, as (lane, hit): the
    /// closest lane first, each rejected one dropped and the next closest asked.
    #[inline(always)]
    fn closest_accepted<B: RayFilter>(
        ids: &Pages<[u32; 4]>,
        p: u32,
        hits: &Tri4Hits,
        filter: B,
    ) -> Option<(usize, TriHit)> {
        let mut mask = hits.mask;
        while mask != 0 {
            let (lane, h) = hits.closest_in(mask);
            if filter.accept(&Self::candidate(ids, p, lane, h)) {
                return Some((lane, h));
            }
            mask &= !(1 << lane);
        }
        None
    }

    /// Whether `filter` accepts any of packet `p`'s hit lanes (asked in lane order, up to the
    /// first accepted).
    #[inline(always)]
    fn any_accepted<B: RayFilter>(
        ids: &Pages<[u32; 4]>,
        p: u32,
        hits: &Tri4Hits,
        filter: B,
    ) -> bool {
        let mut mask = hits.mask;
        while mask != 0 {
            let lane = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            if filter.accept(&Self::candidate(ids, p, lane, hits.lane(lane))) {
                return true;
            }
        }
        false
    }

    /// The [`Hit`] a filter is asked about: lane `lane` of packet `p`, hit as `h`.
    #[inline(always)]
    fn candidate(ids: &Pages<[u32; 4]>, p: u32, lane: usize, h: TriHit) -> Hit {
        Hit {
            t: h.t,
            triangle: ids[p as usize][lane],
            b1: h.b1,
            b2: h.b2,
        }
    }

    /// How many walks one ray's traversal runs as, for query `Q` with node test `N`: two
    /// for any hit on a large tree ([`WideBvh::two_walks`]), one otherwise. Its stack holds
    /// [`WideBvh::stack_len`] entries a walk.
    #[inline(always)]
    pub(crate) fn walks<Q: Query, N: NodeTest<G>>() -> usize {
        1 + usize::from(Q::ANY && N::LARGE)
    }

    /// Any hit on a large tree, as two walks, each with its own half of `stack` (at least
    /// [`WideBvh::stack_len`] entries), taking [`WideBvh::step`]s in turn, so that one walk's
    /// wait for a node or a packet overlaps the other's work: memory-level parallelism within
    /// one ray, as streams have it across rays. The second walk starts from the first's next
    /// entry (after the root, one of its hit children), and whenever a walk runs out of work it
    /// takes the other's next entry; each stays a depth-first walk from where it started, so
    /// each half of the stack holds what one traversal can need. Returns `Walk::best` of the
    /// walk that hit (`None` if neither did).
    ///
    /// More work, less time, on large trees. Closest hits are not traced so: the benchmark
    /// gained, but renders, whose coherent rays find their nodes in cache, lost to the second
    /// walk's detours (see docs/performance.md, streams and two walks).
    #[inline(always)]
    pub(crate) fn two_walks<Q: Query, N: NodeTest<G>, B: RayFilter>(
        nodes: &[WideNode<G>],
        packets: &[Tri4],
        ids: &Pages<[u32; 4]>,
        r: &mut PreparedRay,
        stack: &mut [Entry],
        test: N,
        filter: B,
    ) -> Option<(u32, usize, TriHit)> {
        debug_assert!(Q::ANY, "two walks trace any hit only");
        // The two walks' turns are written out: with the hand-over as a shared function the
        // loop's branches were laid out otherwise, and ran slower.
        let (sa, sb) = stack.split_at_mut(stack.len() / 2);
        let (mut a, mut b) = (Walk::new(r), Walk::new(r));
        let (mut a_on, mut b_on) = (true, false);
        loop {
            if a_on {
                a_on = !Self::step::<Q, N, B>(nodes, packets, ids, r, sa, &mut a, test, filter);
                if a.best.is_some() {
                    return a.best;
                }
            }
            if !b_on && a.sp > 0 {
                // (Any hit has no order: the entry's distance is not kept.)
                a.sp -= 1;
                (b.current, b.sp, b_on) = (sa[a.sp].0, 0, true);
            }
            if b_on {
                b_on = !Self::step::<Q, N, B>(nodes, packets, ids, r, sb, &mut b, test, filter);
                if b.best.is_some() {
                    return b.best;
                }
            }
            if !a_on && b.sp > 0 {
                b.sp -= 1;
                (a.current, a.sp, a_on) = (sb[b.sp].0, 0, true);
            }
            if !a_on && !b_on {
                return None;
            }
        }
    }

    /// The nodes and the packets, as slices, and the packets' triangle ids (for
    /// [`WideBvh::step`]; left as they are, since a step only reads them for a prefetch, on a
    /// large tree: a slice here costs every closest hit the storage check).
    #[inline(always)]
    pub(crate) fn arrays(&self) -> (&[WideNode<G>], &[Tri4], &Pages<[u32; 4]>) {
        (&self.nodes, &self.packets, &self.ids)
    }

    /// Whether the tree is large ([`LARGE_BYTES`]): traced with [`NodeTest::LARGE`].
    pub(crate) fn large(&self) -> bool {
        self.large
    }

    /// Forces the large tree's traversal on or off (for tests: it never changes an answer).
    #[cfg(test)]
    pub(crate) fn set_large(&mut self, on: bool) {
        self.large = on;
    }

    /// Whether the packets are on huge pages (for tests).
    #[cfg(test)]
    pub(crate) fn packets_on_huge_pages(&self) -> bool {
        self.packets.huge_pages()
    }

    /// The number of pair leaves (for tests).
    #[cfg(test)]
    pub(crate) fn pair_count(&self) -> usize {
        let children = self.nodes.iter().flat_map(|n| n.children.iter().flatten());
        children
            .filter(|&&c| c != EMPTY && c & (LEAF | PAIR) == LEAF | PAIR)
            .count()
    }

    /// Prefetches child reference `child` (a node, a packet or a pair) with `test`.
    #[inline(always)]
    fn prefetch_child<N: NodeTest<G>>(
        test: N,
        nodes: &[WideNode<G>],
        packets: &[Tri4],
        child: u32,
    ) {
        // Selected without a branch: leaf or node is a coin toss. A node's reference is its
        // index, below 2³⁰ like a packet's (a tree has fewer nodes than packets), so `PAIR`
        // is clear for nodes and single packets, and the mask gives either index.
        let leaf = (child >> 31) as usize;
        let base: [*const u8; 2] = [nodes.as_ptr().cast(), packets.as_ptr().cast()];
        let size = [size_of::<WideNode<G>>(), size_of::<Tri4>()][leaf];
        let index = (child & PACKET_MASK) as usize;
        let count = 1 + (child & PAIR != 0) as usize;
        test.prefetch(base[leaf].wrapping_add(index * size), size * count);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Wide nodes written onto huge pages (through `Plain::write_to`, field by field) read back
    /// as written: planes and children at their offsets, for both widths.
    #[test]
    fn nodes_on_huge_pages_read_back_as_written() {
        fn check<const G: usize>() {
            let node = |i: usize| {
                let mut n = WideNode::<G> {
                    planes: [[[0.0; 4]; G]; 6],
                    children: [[EMPTY; 4]; G],
                };
                for (k, plane) in n.planes.iter_mut().flatten().flatten().enumerate() {
                    *plane = (i * 100 + k) as f32 * 0.5;
                }
                for (k, child) in n.children.iter_mut().flatten().enumerate() {
                    *child = (i * 10 + k) as u32 | if k % 2 == 0 { LEAF } else { 0 };
                }
                n
            };
            let len = (2 << 20) / size_of::<WideNode<G>>() + 5;
            let on_pages = Pages::from_vec((0..len).map(node).collect()).onto_huge_pages();
            println!("G = {G}: huge pages {}", on_pages.huge_pages());
            for (i, got) in on_pages.iter().enumerate() {
                let want = node(i);
                assert_eq!(got.children, want.children, "node {i}");
                let bits = |n: &WideNode<G>| n.planes.map(|g| g.map(|l| l.map(f32::to_bits)));
                assert_eq!(bits(got), bits(&want), "node {i}");
            }
        }
        check::<1>();
        check::<2>();
    }
}
