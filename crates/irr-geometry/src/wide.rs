//! The wide BVH: nodes of `4·G` children (`G` groups of four, tested with one 4-wide slab test
//! per group) whose leaves are packets of up to four triangles ([`Tri4`], tested at once), and
//! its traversals: ordered (nearest child first) for the closest hit, any order with early exit
//! for occlusion.
//!
//! The tree is obvhs's BVH2 (PLOC + reinsertion, leaves collapsed to at most four triangles)
//! with levels pulled up: a wide node takes its BVH2 node's two children and repeatedly
//! replaces the inner child of largest surface area by its two children, until it has `4·G`
//! children or only leaves (the usual BVH2 → BVH4/BVH8 collapse, as in Embree). Every child box
//! is the exact `f32` box of its BVH2 node, so Ize's relative correction keeps the box test
//! conservative.

use glam::Vec4;
use obvhs::{aabb::Aabb, bvh2::Bvh2};

use crate::intersect::{PreparedRay, Tri4, TriHit, TriSoa, intersect_tri4};

/// A child reference with this bit set is a leaf: the rest is the index of its [`Tri4`].
const LEAF: u32 = 1 << 31;
/// An empty child slot (its box is the empty box, which no ray enters).
const EMPTY: u32 = u32::MAX;

/// A node of `4·G` children: per group of four, the child boxes' min x, y, z and max x, y, z
/// planes (lane = child) and the child references (a node index, `LEAF | packet`, or
/// `EMPTY`).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
pub(crate) struct WideNode<const G: usize> {
    planes: [[Vec4; 6]; G],
    children: [[u32; 4]; G],
}

/// A wide BVH with `4·G` children per node (`G` = 1: BVH4, `G` = 2: BVH8).
#[derive(Debug, Clone)]
pub(crate) struct WideBvh<const G: usize> {
    nodes: Vec<WideNode<G>>,
    packets: Vec<Tri4>,
    /// The triangle id of each packet lane.
    ids: Vec<[u32; 4]>,
    /// Traversal stack entries the deepest path can need.
    stack_len: usize,
}

/// A traversal stack entry: a child reference and the ray's entry distance into its box.
pub(crate) type Entry = (u32, f32);

impl<const G: usize> WideBvh<G> {
    /// Converts `bvh` (leaves of at most four primitives; `triangles[i]` is primitive `i`).
    pub(crate) fn new(bvh: &Bvh2, triangles: &[TriSoa]) -> WideBvh<G> {
        let width = 4 * G;
        let mut out = WideBvh {
            nodes: Vec::with_capacity(bvh.nodes.len() / (width - 1) + 1),
            packets: Vec::with_capacity(bvh.primitive_indices.len() / 2 + 1),
            ids: Vec::with_capacity(bvh.primitive_indices.len() / 2 + 1),
            stack_len: 0,
        };
        let root = &bvh.nodes[0];
        // (BVH2 node whose children fill the wide node, wide node index, depth).
        let mut todo: Vec<(usize, usize, usize)> = Vec::new();
        let mut deepest = 1;
        out.nodes.push(WideNode {
            planes: [[Vec4::ZERO; 6]; G],
            children: [[EMPTY; 4]; G],
        });
        if root.is_leaf() {
            // A single leaf: a root node with one leaf child.
            let child = out.leaf(bvh, 0, triangles);
            out.set_children(0, &[(child, *root.aabb())]);
        } else {
            todo.push((0, 0, 1));
        }
        let mut kids: Vec<usize> = Vec::with_capacity(width);
        let mut slots: Vec<(u32, Aabb)> = Vec::with_capacity(width);
        while let Some((b, w, depth)) = todo.pop() {
            deepest = deepest.max(depth + 1);
            // Open the inner child of largest area until the node is full.
            let first = bvh.nodes[b].first_index as usize;
            kids.clear();
            kids.extend([first, first + 1]);
            while kids.len() < width {
                let open = kids
                    .iter()
                    .enumerate()
                    .filter(|&(_, &k)| !bvh.nodes[k].is_leaf())
                    .max_by(|a, b| {
                        let area = |k: usize| bvh.nodes[k].aabb().half_area();
                        area(*a.1).total_cmp(&area(*b.1))
                    })
                    .map(|(i, _)| i);
                let Some(i) = open else { break };
                let c = bvh.nodes[kids[i]].first_index as usize;
                kids[i] = c;
                kids.push(c + 1);
            }
            slots.clear();
            for &k in &kids {
                let node = &bvh.nodes[k];
                let child = if node.is_leaf() {
                    out.leaf(bvh, k, triangles)
                } else {
                    let index = out.nodes.len();
                    out.nodes.push(WideNode {
                        planes: [[Vec4::ZERO; 6]; G],
                        children: [[EMPTY; 4]; G],
                    });
                    todo.push((k, index, depth + 1));
                    index as u32
                };
                slots.push((child, *node.aabb()));
            }
            out.set_children(w, &slots);
        }
        // Each visited node pops one entry and pushes at most `4·G`.
        out.stack_len = (width - 1) * deepest + 1;
        out
    }

    /// Makes the packet of BVH2 leaf `k` and returns its child reference.
    fn leaf(&mut self, bvh: &Bvh2, k: usize, triangles: &[TriSoa]) -> u32 {
        let node = &bvh.nodes[k];
        let first = node.first_index as usize;
        let prims = &bvh.primitive_indices[first..first + node.prim_count as usize];
        let tris: Vec<TriSoa> = prims.iter().map(|&p| triangles[p as usize]).collect();
        let mut ids = [0; 4];
        for (lane, id) in ids.iter_mut().enumerate() {
            *id = prims[lane.min(prims.len() - 1)];
        }
        let index = self.packets.len() as u32;
        self.packets.push(Tri4::new(&tris));
        self.ids.push(ids);
        LEAF | index
    }

    /// Fills wide node `w`'s slots with `children` (reference, box); the rest stay empty.
    fn set_children(&mut self, w: usize, children: &[(u32, Aabb)]) {
        let node = &mut self.nodes[w];
        for g in 0..G {
            for axis in 0..3 {
                node.planes[g][axis] = Vec4::splat(f32::INFINITY);
                node.planes[g][3 + axis] = Vec4::splat(f32::NEG_INFINITY);
            }
        }
        for (slot, (child, b)) in children.iter().enumerate() {
            let (g, lane) = (slot / 4, slot % 4);
            node.children[g][lane] = *child;
            for axis in 0..3 {
                node.planes[g][axis][lane] = b.min[axis];
                node.planes[g][3 + axis][lane] = b.max[axis];
            }
        }
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

    /// Closest hit: (packet, lane, hit). Children are visited nearest first: the hit children
    /// of a node are pushed farthest first, and an entry farther than the best hit so far is
    /// dropped when popped.
    #[inline(always)]
    pub(crate) fn closest<const KZ: usize>(
        &self,
        r: &PreparedRay,
        stack: &mut [Entry],
    ) -> Option<(u32, usize, TriHit)> {
        let mut t_best = r.t_max;
        let mut best = None;
        let mut sp = 0;
        let mut current = 0u32;
        loop {
            if current & LEAF != 0 {
                let p = current & !LEAF;
                let hits = intersect_tri4::<KZ>(&self.packets[p as usize], r, t_best);
                if let Some((lane, h)) = hits.closest() {
                    t_best = h.t;
                    best = Some((p, lane, h));
                }
            } else {
                let node = &self.nodes[current as usize];
                let first = sp;
                for g in 0..G {
                    let (t_near, mut hit) = r.hits4(&node.planes[g], t_best);
                    while hit != 0 {
                        let lane = hit.trailing_zeros() as usize;
                        hit &= hit - 1;
                        // Insertion sort, farthest at the bottom: the nearest is popped first.
                        let entry = (node.children[g][lane], t_near[lane]);
                        let mut i = sp;
                        while i > first && stack[i - 1].1 < entry.1 {
                            stack[i] = stack[i - 1];
                            i -= 1;
                        }
                        stack[i] = entry;
                        sp += 1;
                    }
                }
            }
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                let (c, t) = stack[sp];
                if t <= t_best {
                    current = c;
                    break;
                }
            }
        }
    }

    /// Any hit (for occlusion): children in any order, stopping at the first hit.
    #[inline(always)]
    pub(crate) fn any<const KZ: usize>(&self, r: &PreparedRay, stack: &mut [Entry]) -> bool {
        let mut sp = 0;
        let mut current = 0u32;
        loop {
            if current & LEAF != 0 {
                let p = (current & !LEAF) as usize;
                if intersect_tri4::<KZ>(&self.packets[p], r, r.t_max).mask != 0 {
                    return true;
                }
            } else {
                let node = &self.nodes[current as usize];
                for g in 0..G {
                    let (_, mut hit) = r.hits4(&node.planes[g], r.t_max);
                    while hit != 0 {
                        let lane = hit.trailing_zeros() as usize;
                        hit &= hit - 1;
                        stack[sp].0 = node.children[g][lane];
                        sp += 1;
                    }
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            current = stack[sp].0;
        }
    }
}
