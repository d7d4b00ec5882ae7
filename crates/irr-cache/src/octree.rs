//! The octree of influence spheres.
//!
//! As in Ward et al. 1988 (§"Octree"), a record is filed at the level whose cell size matches its
//! influence radius r: the deepest level whose cells have side s ≥ [`FIT`]·r. Rather than one node
//! with "loose" bounds, the record's entry is copied into **every** cell of that level that its
//! sphere's bounding box overlaps (at most 2 per axis, so at most 8, because the box's side 2r is at
//! most s). A query then follows a single path from the root, one cell per level (the cell that
//! contains p), and tests the entries it meets: no branching, no backtracking.
//!
//! **Exactness.** A query visits every record whose sphere contains p: the insertion descends into
//! a child when the box overlaps it (lo < mid for the lower half, hi ≥ mid for the upper), the query
//! into the child that holds p (p < mid lower, p ≥ mid upper), with the same `f64` split planes; so
//! if lo ≤ p ≤ hi on every axis the query's child is always one the record went into. The box is
//! padded so that it contains every p that [`contains`] accepts despite rounding (see
//! [`padded_radius`]). Conversely the query visits nothing it should not: the caller filters the
//! entries with [`contains`], the same test a brute-force scan uses.
//!
//! **Growth.** The root is created around the first record, and doubled (the old root becoming one
//! of the new root's eight children) until it holds a new record's box; cell sizes stay powers of
//! two times the first root's, so doubling never moves an existing entry.
//!
//! Positions are `f32` and the split planes `f64`: a cell at depth ≤ [`MAX_DEPTH`] below any root a
//! `f32` scene needs is still far above `f64` resolution, and in any case the insertion and the
//! query compute the planes with the same operations, which is all exactness needs.

use glam::{DVec3, Vec3};

/// A record's cell side is at least `FIT` times its influence radius: 2 (the sphere's diameter is
/// at most a cell) bounds its copies by 8 and keeps cells small, so a query tests few entries.
const FIT: f64 = 2.0;

/// The deepest level below the root. Deeper cells are never needed (cells of side 2⁻⁴⁰ of the scene
/// are below `f32` resolution), and the bound keeps descent loops short.
pub(crate) const MAX_DEPTH: u32 = 40;

const NONE: u32 = u32::MAX;

/// A record's sphere as the octree stores it: its centre, influence radius and index.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Entry {
    pub center: Vec3,
    pub radius: f32,
    pub index: u32,
}

#[derive(Clone, Debug)]
struct Node {
    children: [u32; 8],
    entries: Vec<Entry>,
}

impl Node {
    fn new() -> Self {
        Self {
            children: [NONE; 8],
            entries: Vec::new(),
        }
    }
}

/// Whether p lies strictly inside the sphere of influence (centre `center`, radius `radius`).
///
/// Computed in `f64`: the differences of `f32` coordinates are exact there (up to exponents 29
/// apart), and squaring them can neither overflow nor underflow (the square of `f32::MAX` and of
/// the smallest subnormal are both normal `f64`s). The octree and any brute-force scan must use
/// this one function so they agree to the last bit.
#[inline]
pub fn contains(center: Vec3, radius: f32, p: DVec3) -> bool {
    let r = f64::from(radius);
    (p - center.as_dvec3()).length_squared() < r * r
}

/// The half-side of a box around a sphere of influence radius `radius` that holds every p that
/// [`contains`] accepts.
///
/// If `contains` accepts p, the computed squared distance is < the computed r²; each of the two
/// carries a relative rounding error below 4·2⁻⁵³, so the exact distance is below r·(1 + 4·2⁻⁵³),
/// and so is each coordinate difference. A pad of 2⁻⁴⁰·r covers that with room to spare. (The box
/// corners c ± r' are then rounded, but monotonically: c − r' ≤ p exactly implies fl(c − r') ≤ p
/// for p a float.)
#[inline]
fn padded_radius(radius: f32) -> f64 {
    f64::from(radius) * (1.0 + 2f64.powi(-40))
}

/// The octree: nodes in one array, children by index.
#[derive(Clone, Debug, Default)]
pub(crate) struct Octree {
    nodes: Vec<Node>,
    root: u32,
    root_min: DVec3,
    root_size: f64,
}

impl Octree {
    /// Files `entry` (whose radius is finite and ≥ 0).
    pub fn insert(&mut self, entry: Entry) {
        let c = entry.center.as_dvec3();
        let r = padded_radius(entry.radius);
        let (lo, hi) = (c - DVec3::splat(r), c + DVec3::splat(r));
        let cell = f64::max(FIT * f64::from(entry.radius), 0.0);
        if self.nodes.is_empty() {
            self.create_root(lo, hi, cell);
        }
        self.grow_to(lo, hi);

        // The deepest level whose cell side is ≥ FIT·r.
        let mut depth = 0;
        let mut side = self.root_size;
        while depth < MAX_DEPTH && 0.5 * side >= cell {
            side *= 0.5;
            depth += 1;
        }
        self.insert_at(
            self.root,
            self.root_min,
            self.root_size,
            depth,
            lo,
            hi,
            entry,
        );
    }

    /// A root around the first box: a power-of-two side ≥ the box's and ≥ the record's cell,
    /// aligned to a multiple of that side.
    fn create_root(&mut self, lo: DVec3, hi: DVec3, cell: f64) {
        let extent = (hi - lo).max_element().max(cell);
        let mut size = if extent > 0.0 {
            2f64.powi(extent.log2().ceil() as i32)
        } else {
            // A zero radius: any size will do; take the centre's magnitude (or 1) rounded to a
            // power of two so the root is of the scene's scale.
            let m = lo.abs().max_element();
            if m > 0.0 {
                2f64.powi(m.log2().floor() as i32)
            } else {
                1.0
            }
        };
        if !(size > 0.0 && size.is_finite()) {
            size = 1.0;
        }
        self.root_min = (lo / size).floor() * size;
        self.root_size = size;
        self.root = 0;
        self.nodes.push(Node::new());
    }

    /// Doubles the root until it holds [lo, hi].
    fn grow_to(&mut self, lo: DVec3, hi: DVec3) {
        loop {
            let max = self.root_min + DVec3::splat(self.root_size);
            if lo.cmpge(self.root_min).all() && hi.cmple(max).all() {
                return;
            }
            // The old root becomes the upper child on an axis where the box sticks out below, the
            // lower child otherwise (the new root extends upwards there).
            let below = lo.cmplt(self.root_min);
            let mut octant = 0;
            let mut new_min = self.root_min;
            for axis in 0..3 {
                if below.test(axis) {
                    octant |= 1 << axis;
                    new_min[axis] -= self.root_size;
                }
            }
            let mut node = Node::new();
            node.children[octant] = self.root;
            self.root = self.nodes.len() as u32;
            self.nodes.push(node);
            self.root_min = new_min;
            self.root_size *= 2.0;
        }
    }

    #[expect(
        clippy::too_many_arguments,
        reason = "a recursive descent carrying its cell"
    )]
    fn insert_at(
        &mut self,
        node: u32,
        min: DVec3,
        size: f64,
        depth: u32,
        lo: DVec3,
        hi: DVec3,
        entry: Entry,
    ) {
        if depth == 0 {
            self.nodes[node as usize].entries.push(entry);
            return;
        }
        let half = 0.5 * size;
        let mid = min + DVec3::splat(half);
        for octant in 0..8u32 {
            let mut child_min = min;
            let mut overlaps = true;
            for axis in 0..3 {
                if octant & (1 << axis) == 0 {
                    overlaps &= lo[axis] < mid[axis];
                } else {
                    overlaps &= hi[axis] >= mid[axis];
                    child_min[axis] = mid[axis];
                }
            }
            if !overlaps {
                continue;
            }
            let mut child = self.nodes[node as usize].children[octant as usize];
            if child == NONE {
                child = self.nodes.len() as u32;
                self.nodes.push(Node::new());
                self.nodes[node as usize].children[octant as usize] = child;
            }
            self.insert_at(child, child_min, half, depth - 1, lo, hi, entry);
        }
    }

    /// Calls `f` with every entry on p's path: a superset of the entries whose sphere contains p
    /// (filter with [`contains`]).
    #[inline]
    pub fn for_each_on_path(&self, p: DVec3, mut f: impl FnMut(&Entry)) {
        if self.nodes.is_empty() {
            return;
        }
        let mut node = &self.nodes[self.root as usize];
        let mut min = self.root_min;
        let mut half = 0.5 * self.root_size;
        loop {
            node.entries.iter().for_each(&mut f);
            let mid = min + DVec3::splat(half);
            let upper = p.cmpge(mid);
            let octant = upper.bitmask() as usize;
            let child = node.children[octant];
            if child == NONE {
                return;
            }
            min = DVec3::select(upper, mid, min);
            half *= 0.5;
            node = &self.nodes[child as usize];
        }
    }

    /// Calls `f` with every entry filed in a cell that overlaps the box [lo, hi] (entries of a
    /// record filed in several cells come several times).
    pub fn for_each_in_box(&self, lo: DVec3, hi: DVec3, f: &mut impl FnMut(&Entry)) {
        if self.nodes.is_empty() {
            return;
        }
        self.box_at(self.root, self.root_min, self.root_size, lo, hi, f);
    }

    fn box_at(
        &self,
        node: u32,
        min: DVec3,
        size: f64,
        lo: DVec3,
        hi: DVec3,
        f: &mut impl FnMut(&Entry),
    ) {
        let n = &self.nodes[node as usize];
        n.entries.iter().for_each(&mut *f);
        let half = 0.5 * size;
        let mid = min + DVec3::splat(half);
        for (octant, &child) in n.children.iter().enumerate() {
            if child == NONE {
                continue;
            }
            let mut child_min = min;
            let mut overlaps = true;
            for axis in 0..3 {
                if octant & (1 << axis) == 0 {
                    overlaps &= lo[axis] < mid[axis];
                } else {
                    overlaps &= hi[axis] >= mid[axis];
                    child_min[axis] = mid[axis];
                }
            }
            if overlaps {
                self.box_at(child, child_min, half, lo, hi, f);
            }
        }
    }

    /// Removes the entries of record `index`, whose sphere had influence radius `radius` around
    /// `center` (so they lie in cells overlapping its box).
    pub fn remove(&mut self, center: Vec3, radius: f32, index: u32) {
        if self.nodes.is_empty() {
            return;
        }
        let c = center.as_dvec3();
        let r = padded_radius(radius);
        let (lo, hi) = (c - DVec3::splat(r), c + DVec3::splat(r));
        self.remove_at(self.root, self.root_min, self.root_size, lo, hi, index);
    }

    fn remove_at(&mut self, node: u32, min: DVec3, size: f64, lo: DVec3, hi: DVec3, index: u32) {
        self.nodes[node as usize]
            .entries
            .retain(|e| e.index != index);
        let half = 0.5 * size;
        let mid = min + DVec3::splat(half);
        for octant in 0..8 {
            let child = self.nodes[node as usize].children[octant];
            if child == NONE {
                continue;
            }
            let mut child_min = min;
            let mut overlaps = true;
            for axis in 0..3 {
                if octant & (1 << axis) == 0 {
                    overlaps &= lo[axis] < mid[axis];
                } else {
                    overlaps &= hi[axis] >= mid[axis];
                    child_min[axis] = mid[axis];
                }
            }
            if overlaps {
                self.remove_at(child, child_min, half, lo, hi, index);
            }
        }
    }

    /// Bytes held by the nodes and their entry lists.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * size_of::<Node>()
            + self
                .nodes
                .iter()
                .map(|n| n.entries.capacity() * size_of::<Entry>())
                .sum::<usize>()
    }

    /// Number of nodes and of entries (copies of records), for statistics and tests.
    pub fn counts(&self) -> (usize, usize) {
        (
            self.nodes.len(),
            self.nodes.iter().map(|n| n.entries.len()).sum(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn root_grows_in_every_direction_and_keeps_entries() {
        let mut t = Octree::default();
        let e = |x: f32, y: f32, z: f32, r: f32, i: u32| Entry {
            center: Vec3::new(x, y, z),
            radius: r,
            index: i,
        };
        t.insert(e(0.0, 0.0, 0.0, 0.1, 0));
        t.insert(e(-1000.0, 5.0, 3.0, 0.1, 1));
        t.insert(e(1000.0, -7.0, 1e4, 2.0, 2));
        for (p, i) in [
            (DVec3::ZERO, 0),
            (DVec3::new(-1000.0, 5.0, 3.05), 1),
            (DVec3::new(1001.0, -7.0, 1e4), 2),
        ] {
            let mut found = Vec::new();
            t.for_each_on_path(p, |en| {
                if contains(en.center, en.radius, p) {
                    found.push(en.index);
                }
            });
            assert_eq!(found, vec![i], "query at {p}");
        }
    }

    #[test]
    fn an_entry_is_copied_into_at_most_eight_cells() {
        let mut t = Octree::default();
        for i in 0..1000u32 {
            let f = i as f32;
            t.insert(Entry {
                center: Vec3::new(f.sin() * 10.0, f.cos() * 10.0, (f * 0.37).sin()),
                radius: 0.01 + 0.1 * (f * 0.13).cos().abs(),
                index: i,
            });
        }
        let (_, entries) = t.counts();
        assert!(entries <= 8 * 1000, "{entries} entries");
    }

    #[test]
    fn removal_removes_every_copy() {
        let mut t = Octree::default();
        let a = Entry {
            center: Vec3::splat(0.5),
            radius: 0.3,
            index: 0,
        };
        let b = Entry {
            center: Vec3::splat(0.6),
            radius: 0.3,
            index: 1,
        };
        t.insert(a);
        t.insert(b);
        t.remove(a.center, a.radius, 0);
        let mut left = Vec::new();
        t.for_each_in_box(DVec3::splat(-10.0), DVec3::splat(10.0), &mut |e| {
            left.push(e.index)
        });
        assert!(left.iter().all(|&i| i == 1) && !left.is_empty());
    }
}
