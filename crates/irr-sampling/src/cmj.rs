//! Correlated multi-jittered sampling (Kensler 2013, "Correlated Multi-Jittered Sampling", Pixar
//! technical memo 13-01): `count` points of the unit square that are stratified in a √count-ish
//! grid of cells *and* in each coordinate alone (n-rooks), for any `count`, with sample `index`
//! computed on its own (no table), so a pixel's samples stay counter-based.
//!
//! The permutation is Kensler's hash-based one (a bijection of [0, 2ᵏ) walked until it lands in
//! [0, count)), seeded by the pattern; the jitter inside each cell comes from the caller's `u`,
//! as every sampling routine of this crate takes its randomness.

use glam::Vec2;

/// A permutation of [0, `len`) chosen by `pattern`, applied to `i` (< `len`): Kensler's
/// cycle-walking hash. Each round is a bijection of [0, 2ᵏ) (2ᵏ the smallest power of two ≥ len),
/// so walking from i < len returns to [0, len) after at most 2ᵏ − len + 1 < len + 1 steps (on
/// average fewer than 2).
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

/// Point `index` (< `count`) of the correlated multi-jittered pattern `pattern`, in [0, 1)²,
/// jittered inside its cell by `u` ∈ [0, 1)². For a square `count` = m², the points fill an m×m
/// grid one per cell, and each coordinate alone hits every one of the `count` strata of [0, 1)
/// once. An `index` ≥ `count` is taken modulo `count`; `count` 0 is taken as 1.
pub fn correlated_multi_jitter(index: u32, count: u32, pattern: u32, u: Vec2) -> Vec2 {
    let n_total = count.max(1);
    let m = (f64::from(n_total).sqrt().ceil() as u32).max(1);
    let n = n_total.div_ceil(m);
    let s = permute(index % n_total, n_total, pattern.wrapping_mul(0x5163_3e2d));
    let sx = permute(s % m, m, pattern.wrapping_mul(0x68bc_21eb));
    let sy = permute(s / m, n, pattern.wrapping_mul(0x02e5_be93));
    let x = (sx as f32 + (sy as f32 + u.x) / n as f32) / m as f32;
    let y = (s as f32 + u.y) / n_total as f32;
    // Rounding can reach 1.0 from just below: keep the point inside the square.
    Vec2::new(x.min(1.0f32.next_down_f32()), y.min(1.0f32.next_down_f32()))
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
                let j = permute(i, len, pattern);
                prop_assert!(j < len);
                prop_assert!(!seen[j as usize]);
                seen[j as usize] = true;
            }
        }

        /// Each coordinate alone puts exactly one point in each of the `count` strata of
        /// [0, 1) (y always; x too when count = m² — with m·n > count the x strata are m·n), and
        /// for a square count each of the m×m cells holds exactly one point.
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
}
