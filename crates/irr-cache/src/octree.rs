//! The octree of influence spheres, stored as a linear (hashed) octree.
//!
//! **Cells.** An octree cell is addressed by its level e and integer coordinates (i, j, k): it is
//! the cube [i·2ᵉ, (i + 1)·2ᵉ) × [j·2ᵉ, …) × [k·2ᵉ, …). Halving e splits a cell into its eight
//! children exactly as a pointer octree does, so this is an octree; but instead of parent→child
//! pointers the non-empty cells live in one hash table keyed by (e, i, j, k) (a "linear octree",
//! Gargantini 1982). There is no root and no bound: the tree covers any extent from the start,
//! which is what a root that doubles whenever a record falls outside it achieves, without ever
//! re-rooting; and a query does not pay for the empty levels above the records.
//!
//! **Filing (as in Ward et al. 1988).** A record is filed at the level whose cells match its
//! influence radius r: the smallest e with 2ᵉ ≥ [`FIT`]·r. Its entry is copied into **every** cell of
//! that level that its sphere's bounding box overlaps (at most 2 per axis, 8 in all, because the
//! box is no wider than a cell). A query at p then looks, on each occupied level, at the one cell
//! that contains p, and tests the entries there with [`contains`].
//!
//! **Exactness.** The coordinate of x at level e is ⌊x·2⁻ᵉ⌋: the product is exact in `f64` (a power
//! of two times an `f32`) and ⌊·⌋ is monotone, so if lo ≤ p ≤ hi on an axis then p's coordinate lies
//! between lo's and hi's, and the cell holding p is one the record was copied into. The box is
//! padded so that it holds every p that [`contains`] accepts despite rounding (see
//! [`padded_radius`]). The query tests entries with [`contains`], the same function a brute-force
//! scan uses, so the two agree to the last bit. Coordinates are stored as `i32`, saturating
//! (`as` conversion); saturation is monotone too, so it only merges far-away cells (beyond 2³¹
//! cells from the origin: a record smaller than 10⁻⁵ at 10⁵ m, below `f32` resolution there)
//! and never loses a record.

use glam::{DVec3, Vec3};
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hash, Hasher};

/// A record's cell side is at least `FIT` times its influence radius. 2 (the sphere's diameter is
/// at most a cell) bounds its copies by 8 (docs/performance.md, "The octree's cell size").
const FIT: f64 = 2.0;

/// A record's sphere as the octree stores it: its centre, influence radius and index.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Entry {
    pub center: Vec3,
    pub radius: f32,
    pub index: u32,
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

/// [`contains`], also returning p − c and its squared length (for the caller's weight).
#[inline]
pub fn contains_offset(center: Vec3, radius: f32, p: DVec3) -> Option<(DVec3, f64)> {
    let r = f64::from(radius);
    let offset = p - center.as_dvec3();
    let d2 = offset.length_squared();
    (d2 < r * r).then_some((offset, d2))
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

/// An octree cell: level (log₂ of its side) and integer coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Cell {
    level: i16,
    x: i32,
    y: i32,
    z: i32,
}

impl Hash for Cell {
    #[inline]
    fn hash<H: Hasher>(&self, state: &mut H) {
        state.write_u64((u64::from(self.level as u16) << 32) | u64::from(self.x as u32));
        state.write_u64((u64::from(self.y as u32) << 32) | u64::from(self.z as u32));
    }
}

/// A fast hasher for [`Cell`] keys (the keys are not adversarial): multiply–rotate per word and
/// the SplitMix64 finaliser (Steele, Lea & Flood 2014) so every bit of the key reaches the low
/// bits (bucket index) and the high bits (the table's tag).
#[derive(Default)]
struct CellHasher(u64);

impl Hasher for CellHasher {
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(u64::from(b));
        }
    }
    #[inline]
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(26) ^ v).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    }
    #[inline]
    fn finish(&self) -> u64 {
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
}

/// An occupied level: its exponent, 2⁻ᵉ, how many cells it has, and the largest reach any entry
/// filed there was given (an upper bound: removals do not lower it).
#[derive(Clone, Copy, Debug)]
struct Level {
    exponent: i16,
    inverse_side: f64,
    cells: usize,
    max_reach: f32,
}

/// The cell coordinate of `x` on a level of cell side 1/`inverse_side`: ⌊x·2⁻ᵉ⌋, saturating (see
/// the module docs).
///
/// Written without `f64::floor`, which is a library call on baseline x86-64: the conversion
/// truncates towards zero (saturating), and one less is the floor where that rounded up (negative
/// non-integers). Monotone in `x`, as the exactness argument needs: truncation is, and the
/// correction only applies strictly between two integers.
#[inline]
fn coordinate(x: f64, inverse_side: f64) -> i32 {
    let t = x * inverse_side;
    let i = t as i32;
    if f64::from(i) > t {
        i.saturating_sub(1)
    } else {
        i
    }
}

/// The level for an entry of influence radius `radius`: the smallest e with 2ᵉ ≥ FIT·r', r' the
/// padded radius; `None` for a zero radius (such an entry contains no point).
fn level_for(radius: f32) -> Option<i16> {
    if radius <= 0.0 {
        return None;
    }
    let need = FIT * padded_radius(radius);
    let mut e = need.log2().ceil() as i32;
    // log2 may be off by an ulp at exact powers of two: settle on the exact smallest e.
    while 2f64.powi(e) < need {
        e += 1;
    }
    while 2f64.powi(e - 1) >= need {
        e -= 1;
    }
    Some(e as i16)
}

/// The octree: non-empty cells in a hash table, and the list of occupied levels.
#[derive(Clone, Debug, Default)]
pub(crate) struct Octree {
    cells: HashMap<Cell, Vec<Entry>, BuildHasherDefault<CellHasher>>,
    /// Occupied levels, sorted by exponent.
    levels: Vec<Level>,
    entries: usize,
}

impl Octree {
    /// The index in `levels` of exponent `e`, creating it if needed.
    fn level_index(&mut self, e: i16) -> usize {
        match self.levels.binary_search_by_key(&e, |l| l.exponent) {
            Ok(i) => i,
            Err(i) => {
                self.levels.insert(
                    i,
                    Level {
                        exponent: e,
                        inverse_side: 2f64.powi(-i32::from(e)),
                        cells: 0,
                        max_reach: 0.0,
                    },
                );
                i
            }
        }
    }

    /// The cell ranges (per axis, inclusive) at `level` of the box around a sphere.
    fn cell_range(level: &Level, center: Vec3, radius: f32) -> ([i32; 3], [i32; 3]) {
        let c = center.as_dvec3();
        let r = padded_radius(radius);
        let (lo, hi) = (c - DVec3::splat(r), c + DVec3::splat(r));
        let s = level.inverse_side;
        (
            [0, 1, 2].map(|a| coordinate(lo[a], s)),
            [0, 1, 2].map(|a| coordinate(hi[a], s)),
        )
    }

    /// Files `entry` (whose radius is finite and ≥ 0). `reach` is a length the caller attaches to
    /// the entry (the cache: the record's unclamped radius), for [`Octree::for_each_within_reach`].
    ///
    /// Each cell keeps its entries sorted by index, whatever order they were filed in: a record
    /// refiled after neighbour clamping goes back to its place, so the order in which a query
    /// visits records (and so the order of interpolation's sums) depends only on the set of
    /// records, not on the history of the cache.
    pub fn insert(&mut self, entry: Entry, reach: f32) {
        let Some(e) = level_for(entry.radius) else {
            return;
        };
        let li = self.level_index(e);
        let level = &mut self.levels[li];
        level.max_reach = level.max_reach.max(reach);
        let (lo, hi) = Self::cell_range(level, entry.center, entry.radius);
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    let list = self.cells.entry(Cell { level: e, x, y, z }).or_default();
                    if list.is_empty() {
                        self.levels[li].cells += 1;
                    }
                    // Appending is the common case (indices grow); a refiled entry is inserted.
                    let at = list.partition_point(|other| other.index < entry.index);
                    list.insert(at, entry);
                    self.entries += 1;
                }
            }
        }
    }

    /// Calls `f` with the entries of every cell that contains p (one per occupied level): a
    /// superset of the entries whose sphere contains p (filter with [`contains`]), each record at
    /// most once.
    ///
    /// The cells of up to 8 levels are looked up before any is scanned: the lookups do not depend
    /// on each other, so their cache misses overlap instead of queueing behind each scan.
    #[inline]
    pub fn for_each_on_path(&self, p: DVec3, mut f: impl FnMut(&Entry)) {
        const BATCH: usize = 8;
        for levels in self.levels.chunks(BATCH) {
            let mut lists: [&[Entry]; BATCH] = [&[]; BATCH];
            for (list, level) in lists.iter_mut().zip(levels) {
                let s = level.inverse_side;
                let cell = Cell {
                    level: level.exponent,
                    x: coordinate(p.x, s),
                    y: coordinate(p.y, s),
                    z: coordinate(p.z, s),
                };
                if let Some(found) = self.cells.get(&cell) {
                    *list = found;
                }
            }
            for list in &lists[..levels.len()] {
                list.iter().for_each(&mut f);
            }
        }
    }

    /// Calls `f` with every entry filed in a cell that overlaps the box [lo, hi] (a record filed in
    /// several such cells comes several times).
    pub fn for_each_in_box(&self, lo: DVec3, hi: DVec3, f: &mut impl FnMut(&Entry)) {
        for level in &self.levels {
            self.for_each_in_box_at(level, lo, hi, f);
        }
    }

    /// Calls `f` with every entry whose centre may lie within `reach − threshold` of `p`, where
    /// `reach` is what [`Octree::insert`] was given for it: on each level, the cells overlapping the
    /// box of half-side (the level's largest reach − `threshold`) around p. A superset (filter
    /// with the exact test); levels whose largest reach is ≤ `threshold` are skipped.
    ///
    /// This is the search neighbour clamping's second half needs: the records j with
    /// Rⱼ > r + ‖p − pⱼ‖ have ‖p − pⱼ‖ < Rⱼ − r, however far their spheres of influence (which
    /// decide their level) reach.
    pub fn for_each_within_reach(&self, p: DVec3, threshold: f64, f: &mut impl FnMut(&Entry)) {
        for level in &self.levels {
            let half = f64::from(level.max_reach) - threshold;
            if half > 0.0 {
                let half = half * (1.0 + 2f64.powi(-40));
                let (lo, hi) = (p - DVec3::splat(half), p + DVec3::splat(half));
                self.for_each_in_box_at(level, lo, hi, f);
            }
        }
    }

    fn for_each_in_box_at(&self, level: &Level, lo: DVec3, hi: DVec3, f: &mut impl FnMut(&Entry)) {
        {
            let s = level.inverse_side;
            let a = [0, 1, 2].map(|k| coordinate(lo[k], s));
            let b = [0, 1, 2].map(|k| coordinate(hi[k], s));
            let span = |k: usize| (i64::from(b[k]) - i64::from(a[k]) + 1).max(0) as u128;
            let count = span(0) * span(1) * span(2);
            if count <= level.cells as u128 {
                for x in a[0]..=b[0] {
                    for y in a[1]..=b[1] {
                        for z in a[2]..=b[2] {
                            let cell = Cell {
                                level: level.exponent,
                                x,
                                y,
                                z,
                            };
                            if let Some(list) = self.cells.get(&cell) {
                                list.iter().for_each(&mut *f);
                            }
                        }
                    }
                }
            } else {
                // The box spans more cells than the level has: scan the level's cells instead.
                for (cell, list) in &self.cells {
                    let inside = cell.level == level.exponent
                        && (a[0]..=b[0]).contains(&cell.x)
                        && (a[1]..=b[1]).contains(&cell.y)
                        && (a[2]..=b[2]).contains(&cell.z);
                    if inside {
                        list.iter().for_each(&mut *f);
                    }
                }
            }
        }
    }

    /// Removes the entries of record `index`, filed with influence radius `radius` around `center`.
    /// Its level keeps its largest reach (an upper bound stays an upper bound).
    pub fn remove(&mut self, center: Vec3, radius: f32, index: u32) {
        let Some(e) = level_for(radius) else {
            return;
        };
        let Ok(li) = self.levels.binary_search_by_key(&e, |l| l.exponent) else {
            return;
        };
        let (lo, hi) = Self::cell_range(&self.levels[li], center, radius);
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    let cell = Cell { level: e, x, y, z };
                    let Some(list) = self.cells.get_mut(&cell) else {
                        continue;
                    };
                    // The list is sorted by index: find the entry rather than scan.
                    let at = list.partition_point(|en| en.index < index);
                    if list.get(at).is_some_and(|en| en.index == index) {
                        list.remove(at);
                        self.entries -= 1;
                    }
                    if list.is_empty() {
                        self.cells.remove(&cell);
                        self.levels[li].cells -= 1;
                    }
                }
            }
        }
        if self.levels[li].cells == 0 {
            self.levels.remove(li);
        }
    }

    /// Bytes held by the hash table and the entry lists.
    pub fn memory_bytes(&self) -> usize {
        // hashbrown stores each slot (key and value) plus one control byte, at a load of at most
        // 7/8 of its capacity.
        let slot = size_of::<(Cell, Vec<Entry>)>() + 1;
        self.cells.capacity() * slot * 8 / 7
            + self
                .cells
                .values()
                .map(|l| l.capacity() * size_of::<Entry>())
                .sum::<usize>()
            + self.levels.capacity() * size_of::<Level>()
    }

    /// Number of non-empty cells and of entries (copies of records).
    pub fn counts(&self) -> (usize, usize) {
        (self.cells.len(), self.entries)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(x: f32, y: f32, z: f32, r: f32, index: u32) -> Entry {
        Entry {
            center: Vec3::new(x, y, z),
            radius: r,
            index,
        }
    }

    fn found(t: &Octree, p: DVec3) -> Vec<u32> {
        let mut v = Vec::new();
        t.for_each_on_path(p, |e| {
            if contains(e.center, e.radius, p) {
                v.push(e.index);
            }
        });
        v
    }

    #[test]
    fn levels_match_the_radius() {
        // 2ᵉ ≥ 2·r' with r' a hair above r: r = 0.5 needs 2⁰·(1 + 2⁻⁴⁰) → e = 1.
        assert_eq!(level_for(0.5), Some(1));
        assert_eq!(level_for(0.4), Some(0));
        assert_eq!(level_for(1e-4), Some(-12));
        assert_eq!(level_for(0.0), None);
        assert_eq!(level_for(f32::MAX), Some(129));
        assert_eq!(level_for(1e-45), Some(-147));
    }

    #[test]
    fn any_extent_without_bounds() {
        let mut t = Octree::default();
        t.insert(entry(0.0, 0.0, 0.0, 0.1, 0), 0.0);
        t.insert(entry(-1000.0, 5.0, 3.0, 0.1, 1), 0.0);
        t.insert(entry(1000.0, -7.0, 1e4, 2.0, 2), 0.0);
        t.insert(entry(-3e38, 3e38, 0.0, 1e30, 3), 0.0);
        for (p, i) in [
            (DVec3::ZERO, 0),
            (DVec3::new(-1000.0, 5.0, 3.05), 1),
            (DVec3::new(1001.0, -7.0, 1e4), 2),
            (DVec3::new(-3e38, 3e38, 1e29), 3),
        ] {
            assert_eq!(found(&t, p), vec![i], "query at {p}");
        }
    }

    #[test]
    fn an_entry_is_copied_into_at_most_eight_cells() {
        let mut t = Octree::default();
        for i in 0..1000u32 {
            let f = i as f32;
            t.insert(
                entry(
                    f.sin() * 10.0,
                    f.cos() * 10.0,
                    (f * 0.37).sin(),
                    0.01 + 0.1 * (f * 0.13).cos().abs(),
                    i,
                ),
                0.0,
            );
            let (_, entries) = t.counts();
            assert!(entries <= 8 * (i as usize + 1));
        }
    }

    #[test]
    fn removal_removes_every_copy_and_empty_cells() {
        let mut t = Octree::default();
        let (a, b) = (entry(0.5, 0.5, 0.5, 0.3, 0), entry(3.6, 0.6, 0.6, 0.01, 1));
        t.insert(a, 0.0);
        t.insert(b, 0.0);
        t.remove(a.center, a.radius, 0);
        let mut left = Vec::new();
        t.for_each_in_box(DVec3::splat(-10.0), DVec3::splat(10.0), &mut |e| {
            left.push(e.index)
        });
        assert!(left.iter().all(|&i| i == 1) && !left.is_empty());
        t.remove(b.center, b.radius, 1);
        assert_eq!(t.counts(), (0, 0));
        assert!(t.levels.is_empty());
    }

    #[test]
    fn a_box_much_larger_than_the_cells_scans_instead() {
        let mut t = Octree::default();
        t.insert(entry(0.25, 0.0, 0.0, 1e-6, 0), 0.0);
        t.insert(entry(7.0, 0.0, 0.0, 1e-6, 1), 0.0);
        let mut seen = Vec::new();
        t.for_each_in_box(DVec3::splat(-1.0), DVec3::splat(1.0), &mut |e| {
            seen.push(e.index)
        });
        seen.dedup();
        assert_eq!(seen, vec![0]);
    }
}
