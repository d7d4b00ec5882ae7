//! Correlated multi-jittered sampling (Kensler 2013, "Correlated Multi-Jittered Sampling", Pixar
//! technical memo 13-01): `count` points of the unit square that are stratified in a √count-ish
//! grid of cells *and* in each coordinate alone (n-rooks), for any `count`, with sample `index`
//! computed on its own (no table), so a pixel's samples stay counter-based.
//!
//! The permutation is Kensler's hash-based one (a bijection of [0, 2ᵏ) walked until it lands in
//! [0, count)), seeded by the pattern; the jitter inside each cell comes from the caller's `u`,
//! as every sampling routine of this crate takes its randomness.

use glam::Vec2;

/// A permutation of [0, `len`) chosen by `pattern`: Kensler's cycle-walking hash. Each round is
/// a bijection of [0, 2ᵏ) (2ᵏ the smallest power of two ≥ len), so walking from i < len returns
/// to [0, len) after at most 2ᵏ − len + 1 < len + 1 steps (on average fewer than 2). What does
/// not depend on the point (the mask, the final offset) is computed once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Permutation {
    len: u32,
    /// 2ᵏ − 1.
    mask: u32,
    pattern: u32,
    /// `pattern` mod `len`: the final rotation (i + pattern) mod len, as i + offset, less len
    /// if it reaches len.
    offset: u32,
}

impl Permutation {
    fn new(len: u32, pattern: u32) -> Self {
        let mut w = len.max(1) - 1;
        w |= w >> 1;
        w |= w >> 2;
        w |= w >> 4;
        w |= w >> 8;
        w |= w >> 16;
        Self {
            len,
            mask: w,
            pattern,
            offset: if len > 1 { pattern % len } else { 0 },
        }
    }

    /// The image of `i` (< `len`).
    #[inline]
    fn apply(&self, mut i: u32) -> u32 {
        let (len, w, pattern) = (self.len, self.mask, self.pattern);
        if len <= 1 {
            return 0;
        }
        loop {
            i ^= pattern;
            i = i.wrapping_mul(0xe170_893d);
            i ^= pattern >> 16;
            i ^= (i & w) >> 4;
            i ^= pattern >> 8;
            i = i.wrapping_mul(0x0929_eb3f);
            i ^= pattern >> 23;
            i ^= (i & w) >> 1;
            i = i.wrapping_mul(1 | (pattern >> 27));
            i = i.wrapping_mul(0x6935_fa69);
            i ^= (i & w) >> 11;
            i = i.wrapping_mul(0x74dc_b303);
            i ^= (i & w) >> 2;
            i = i.wrapping_mul(0x9e50_1cc3);
            i ^= (i & w) >> 2;
            i = i.wrapping_mul(0xc860_a3df);
            i &= w;
            i ^= i >> 5;
            if i < len {
                break;
            }
        }
        // (i + pattern) mod len, with i < len and offset < len (in u64: the sum may pass 2³²).
        let j = u64::from(i) + u64::from(self.offset);
        (if j >= u64::from(len) {
            j - u64::from(len)
        } else {
            j
        }) as u32
    }
}

/// One correlated multi-jittered pattern of `count` points ([`correlated_multi_jitter`]), with
/// what its points share (the grid's shape and its three permutations) computed once: a pixel's
/// samples take their positions from one of these.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cmj {
    count: u32,
    m: u32,
    n: u32,
    order: Permutation,
    columns: Permutation,
    rows: Permutation,
}

impl Cmj {
    /// The pattern `pattern` of `count` points (`count` 0 is taken as 1).
    pub fn new(count: u32, pattern: u32) -> Self {
        let count = count.max(1);
        let m = (f64::from(count).sqrt().ceil() as u32).max(1);
        let n = count.div_ceil(m);
        Self {
            count,
            m,
            n,
            order: Permutation::new(count, pattern.wrapping_mul(0x5163_3e2d)),
            columns: Permutation::new(m, pattern.wrapping_mul(0x68bc_21eb)),
            rows: Permutation::new(n, pattern.wrapping_mul(0x02e5_be93)),
        }
    }

    /// Point `index` of the pattern, jittered inside its cell by `u` ∈ [0, 1)²: see
    /// [`correlated_multi_jitter`], which gives the same bits.
    #[inline]
    pub fn point(&self, index: u32, u: Vec2) -> Vec2 {
        let index = if index < self.count {
            index
        } else {
            index % self.count
        };
        let s = self.order.apply(index);
        let sx = self.columns.apply(s % self.m);
        let sy = self.rows.apply(s / self.m);
        let x = (sx as f32 + (sy as f32 + u.x) / self.n as f32) / self.m as f32;
        let y = (s as f32 + u.y) / self.count as f32;
        // Rounding can reach 1.0 from just below: keep the point inside the square.
        Vec2::new(x.min(1.0f32.next_down_f32()), y.min(1.0f32.next_down_f32()))
    }
}

/// Point `index` (< `count`) of the correlated multi-jittered pattern `pattern`, in [0, 1)²,
/// jittered inside its cell by `u` ∈ [0, 1)². For a square `count` = m², the points fill an m×m
/// grid one per cell, and each coordinate alone hits every one of the `count` strata of [0, 1)
/// once. An `index` ≥ `count` is taken modulo `count`; `count` 0 is taken as 1. (A caller with
/// many points of one pattern makes the [`Cmj`] once.)
pub fn correlated_multi_jitter(index: u32, count: u32, pattern: u32, u: Vec2) -> Vec2 {
    Cmj::new(count, pattern).point(index, u)
}

/// `f32::next_down`, spelled out (as in `strata.rs`).
trait NextDown {
    fn next_down_f32(self) -> f32;
}

impl NextDown for f32 {
    #[inline]
    fn next_down_f32(self) -> f32 {
        f32::from_bits(self.to_bits() - 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// For any count and pattern, `permute` is a permutation of [0, len).
        #[test]
        fn permute_is_a_bijection(len in 1u32..300, pattern: u32) {
            let mut seen = vec![false; len as usize];
            for i in 0..len {
                let j = Permutation::new(len, pattern).apply(i);
                prop_assert!(j < len);
                prop_assert!(!seen[j as usize]);
                seen[j as usize] = true;
            }
        }

        /// Each coordinate alone puts exactly one point in each of the `count` strata of
        /// [0, 1) (y always; x too when count = m² — with m·n > count the x strata are m·n), and
        /// for a square count each of the m×m cells holds exactly one point.
        /// The precomputed pattern gives exactly the points of Kensler's algorithm as first
        /// written here (each permutation's rotation by `(i + pattern) % len` in u64).
        #[test]
        fn cmj_gives_the_reference_points(count in 1u32..300, pattern: u32, index in 0u32..600, ux in 0.0f32..1.0, uy in 0.0f32..1.0) {
            let u = Vec2::new(ux, uy);
            let got = Cmj::new(count, pattern).point(index, u);
            let want = reference(index, count, pattern, u);
            prop_assert_eq!(got.to_array().map(f32::to_bits), want.to_array().map(f32::to_bits));
        }

        #[test]
        fn points_are_stratified(count in 1u32..200, pattern: u32, jitter in 0u32..1000) {
            let mut ys = vec![0u8; count as usize];
            let m = (f64::from(count).sqrt().ceil()) as u32;
            let n = count.div_ceil(m);
            let mut xs = vec![0u8; (m * n) as usize];
            let mut cells = vec![0u8; (m * m) as usize];
            for i in 0..count {
                // Jitter kept 1 % off the cell walls: a point on a wall may round, in f32, into
                // the neighbouring stratum, which says nothing about the pattern.
                let u = crate::SampleKey::new(u64::from(jitter), 0, u64::from(i)).uniform_2d(0)
                    * 0.98
                    + Vec2::splat(0.01);
                let p = correlated_multi_jitter(i, count, pattern, u);
                prop_assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y), "{p}");
                ys[(p.y * count as f32) as usize] += 1;
                xs[(p.x * (m * n) as f32) as usize] += 1;
                if m * m == count {
                    cells[((p.y * m as f32) as u32 * m + (p.x * m as f32) as u32) as usize] += 1;
                }
            }
            prop_assert!(ys.iter().all(|&c| c == 1));
            prop_assert!(xs.iter().all(|&c| c <= 1));
            if m * m == count {
                prop_assert!(cells.iter().all(|&c| c == 1));
            }
        }
    }

    /// The algorithm as it was first written: a permutation's mask and rotation computed at each
    /// call.
    fn reference(index: u32, count: u32, pattern: u32, u: Vec2) -> Vec2 {
        fn permute(mut i: u32, len: u32, pattern: u32) -> u32 {
            if len <= 1 {
                return 0;
            }
            let mut w = len - 1;
            w |= w >> 1;
            w |= w >> 2;
            w |= w >> 4;
            w |= w >> 8;
            w |= w >> 16;
            loop {
                i ^= pattern;
                i = i.wrapping_mul(0xe170_893d);
                i ^= pattern >> 16;
                i ^= (i & w) >> 4;
                i ^= pattern >> 8;
                i = i.wrapping_mul(0x0929_eb3f);
                i ^= pattern >> 23;
                i ^= (i & w) >> 1;
                i = i.wrapping_mul(1 | (pattern >> 27));
                i = i.wrapping_mul(0x6935_fa69);
                i ^= (i & w) >> 11;
                i = i.wrapping_mul(0x74dc_b303);
                i ^= (i & w) >> 2;
                i = i.wrapping_mul(0x9e50_1cc3);
                i ^= (i & w) >> 2;
                i = i.wrapping_mul(0xc860_a3df);
                i &= w;
                i ^= i >> 5;
                if i < len {
                    break;
                }
            }
            ((u64::from(i) + u64::from(pattern)) % u64::from(len)) as u32
        }
        let n_total = count.max(1);
        let m = (f64::from(n_total).sqrt().ceil() as u32).max(1);
        let n = n_total.div_ceil(m);
        let s = permute(index % n_total, n_total, pattern.wrapping_mul(0x5163_3e2d));
        let sx = permute(s % m, m, pattern.wrapping_mul(0x68bc_21eb));
        let sy = permute(s / m, n, pattern.wrapping_mul(0x02e5_be93));
        let x = (sx as f32 + (sy as f32 + u.x) / n as f32) / m as f32;
        let y = (s as f32 + u.y) / n_total as f32;
        Vec2::new(x.min(1.0f32.next_down_f32()), y.min(1.0f32.next_down_f32()))
    }
}
