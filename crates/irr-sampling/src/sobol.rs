//! A low-discrepancy sequence for the first dimensions of a pixel's samples: the first two
//! dimensions of Sobol's sequence, Owen-scrambled and shuffled per pixel and per dimension
//! (Burley, "Practical Hash-based Owen Scrambling", JCGT 9(4), 2020; pbrt-v4's
//! `PaddedSobolSampler` does the same with another hash).
//!
//! # What it gives
//! Sample `i` of a pixel's dimension `d` is the point `sobol(shuffle(i))` of the 2D Sobol
//! sequence (van der Corput in x, Sobol's second dimension in y), each coordinate scrambled by a
//! nested uniform (Owen) scramble, with `shuffle` itself an Owen scramble of the index's bits.
//! The shuffle and both scrambles are seeded by a hash of (seed, pixel, dimension):
//! - Owen scrambling keeps the Sobol points' stratification (every aligned power-of-two
//!   prefix is a (0, m, 2)-net: one point in each of the 2ᵐ elementary intervals of every
//!   shape) and makes each point uniformly distributed, so estimates stay unbiased;
//! - the shuffle maps each aligned block of 2ᵏ indices onto another aligned block, so the first
//!   `spp` samples of a pixel are still a net for any power-of-two `spp` (and well spread for
//!   others), and, being different for every dimension, it decorrelates the dimensions: sample
//!   `i` of the light-choice dimension is not tied to sample `i` of the BSDF dimension.
//!
//! Nothing is stored: a value depends only on (seed, pixel, index, dimension), like
//! [`crate::SampleKey`]'s, so images stay the same bit for bit for any thread count.

use glam::Vec2;

/// Burley's hash-based Laine–Karras permutation of the bits of `x`, seeded by `seed`: applied to
/// bit-reversed values it is a nested uniform scramble (each bit flipped by a hash of the bits
/// above it).
#[inline]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// The nested uniform (Owen) scramble of the 32-bit fixed-point value `x` ∈ [0, 2³²).
#[inline]
pub fn owen_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

/// Sobol's first dimension (the base-2 van der Corput sequence) at `index`, as 32-bit fixed
/// point. (`sobol_2d` and `sobol_1d` fold it into the scramble; the tests check the identity.)
#[cfg(test)]
#[inline]
fn sobol_0(index: u32) -> u32 {
    index.reverse_bits()
}

/// The direction numbers of Sobol's second dimension: v₀ = 2³¹ and vₖ = vₖ₋₁ ⊕ (vₖ₋₁ ≫ 1)
/// (primitive polynomial x + 1, m₁ = 1: the columns of Pascal's triangle mod 2).
const fn direction_numbers() -> [u32; 32] {
    let mut v = [0u32; 32];
    v[0] = 1 << 31;
    let mut k = 1;
    while k < 32 {
        v[k] = v[k - 1] ^ (v[k - 1] >> 1);
        k += 1;
    }
    v
}

/// For each byte of an index (4) and each value of that byte (256), the XOR of the direction
/// numbers of its set bits, bit-reversed: one lookup per byte instead of one step per bit (a
/// shuffled index has all 32 bits in play). Reversed because the Owen scramble reads the value
/// reversed (a reversal is linear over XOR, so it can be applied to each entry instead of to
/// their sum): one bit reversal per point fewer.
const REVERSED_TABLES: [[u32; 256]; 4] = {
    let v = direction_numbers();
    let mut t = [[0u32; 256]; 4];
    let mut byte = 0;
    while byte < 4 {
        let mut value = 0;
        while value < 256 {
            let mut out = 0u32;
            let mut bit = 0;
            while bit < 8 {
                if value & (1 << bit) != 0 {
                    out ^= v[8 * byte + bit];
                }
                bit += 1;
            }
            t[byte][value] = out.reverse_bits();
            value += 1;
        }
        byte += 1;
    }
    t
};

/// Sobol's second dimension at `index`, as 32-bit fixed point, bit-reversed: the XOR of the
/// (reversed) direction numbers vₖ for the set bits k of `index`.
#[inline]
fn sobol_1_reversed(index: u32) -> u32 {
    let [b0, b1, b2, b3] = index.to_le_bytes();
    REVERSED_TABLES[0][usize::from(b0)]
        ^ REVERSED_TABLES[1][usize::from(b1)]
        ^ REVERSED_TABLES[2][usize::from(b2)]
        ^ REVERSED_TABLES[3][usize::from(b3)]
}

/// Maps 32-bit fixed point to a float in [0, 1) (the top 24 bits, so never 1.0).
#[inline]
fn to_unit(x: u32) -> f32 {
    crate::rng::bits_to_unit_f32(x)
}

/// Sample `index` of the shuffled, Owen-scrambled 2D Sobol sequence seeded by `seed` (64 bits:
/// the shuffle's and the two scrambles' 32-bit seeds are cut from it and its rehash).
#[inline]
pub fn sobol_2d(index: u32, seed: u64) -> Vec2 {
    sobol_2d_reversed(index.reverse_bits(), seed)
}

/// [`sobol_2d`] of the index whose bits reversed are `reversed_index`: for a caller that draws
/// many dimensions of one sample ([`crate::SampleKey`]), which reverses the index once.
///
/// Three bit reversals per point (x86-64 has no instruction for one: 17 instructions each),
/// against seven in the definition, with the same bits (the tests check it against the
/// definition):
/// - the shuffle, `owen_scramble(index) = reverse(LK(reverse(index)))`, starts from the
///   reversed index it is given;
/// - x: `owen_scramble(sobol_0(j)) = reverse(LK(reverse(reverse(j)))) = reverse(LK(j))`;
/// - y: `owen_scramble(sobol_1(j)) = reverse(LK(reverse(sobol_1(j))))`, and the tables give
///   `reverse(sobol_1(j))` directly ([`REVERSED_TABLES`]).
#[inline]
pub(crate) fn sobol_2d_reversed(reversed_index: u32, seed: u64) -> Vec2 {
    let (x, shuffled, s) = first_coordinate(reversed_index, seed);
    Vec2::new(
        x,
        to_unit(laine_karras(sobol_1_reversed(shuffled), (s >> 32) as u32).reverse_bits()),
    )
}

/// What [`sobol_2d_reversed`] and [`sobol_1d_reversed`] share: the point's first coordinate,
/// and the shuffled index and the scrambles' seed that the second coordinate needs.
#[inline(always)]
fn first_coordinate(reversed_index: u32, seed: u64) -> (f32, u32, u64) {
    let s = crate::rng::mix64(seed);
    let shuffled = laine_karras(reversed_index, seed as u32).reverse_bits();
    (
        to_unit(laine_karras(shuffled, s as u32).reverse_bits()),
        shuffled,
        s,
    )
}

/// Sample `index` of the shuffled, Owen-scrambled van der Corput sequence seeded by `seed`.
#[inline]
pub fn sobol_1d(index: u32, seed: u64) -> f32 {
    sobol_1d_reversed(index.reverse_bits(), seed)
}

/// [`sobol_1d`] of the index whose bits reversed are `reversed_index` (see
/// [`sobol_2d_reversed`]).
#[inline]
pub(crate) fn sobol_1d_reversed(reversed_index: u32, seed: u64) -> f32 {
    first_coordinate(reversed_index, seed).0
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Sobol's second dimension from its definition: the XOR of the direction numbers of the
    /// index's set bits.
    fn sobol_1(index: u32) -> u32 {
        let v = direction_numbers();
        (0..32)
            .filter(|k| index & (1 << k) != 0)
            .fold(0, |acc, k| acc ^ v[k])
    }

    /// The point as the module docs define it: both coordinates of the shuffled index's Sobol
    /// point, Owen-scrambled.
    fn defined_2d(index: u32, seed: u64) -> Vec2 {
        let s = crate::rng::mix64(seed);
        let shuffled = owen_scramble(index, seed as u32);
        Vec2::new(
            to_unit(owen_scramble(sobol_0(shuffled), s as u32)),
            to_unit(owen_scramble(sobol_1(shuffled), (s >> 32) as u32)),
        )
    }

    /// Sobol's second dimension, from its definition: the first points in natural (not Gray-code)
    /// index order are 0, 1/2, 3/4, 1/4, 5/8, 1/8, 3/8, 7/8 (the XOR of v₁ = .1, v₂ = .11,
    /// v₃ = .101 in binary); paired with van der Corput's 0, 1/2, 1/4, 3/4, 1/8, 5/8, 3/8, 7/8
    /// they are the first eight points of Joe & Kuo's table, reordered.
    #[test]
    fn the_second_dimension_matches_the_published_points() {
        let expected = [0.0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875];
        for (i, e) in expected.iter().enumerate() {
            assert_eq!(
                f64::from(sobol_1(i as u32)) / 2f64.powi(32),
                *e,
                "index {i}"
            );
        }
    }

    /// The (0, m, 2)-net property of the scrambled, shuffled sequence: for m ≤ 8, every
    /// aligned block of 2ᵐ indices puts exactly one point in each elementary interval
    /// [a/2ʲ, (a+1)/2ʲ) × [b/2ᵐ⁻ʲ, (b+1)/2ᵐ⁻ʲ), for every j. Exact: no tolerance.
    #[test]
    fn every_power_of_two_prefix_is_a_net() {
        for seed in [0u64, 1, 0xdead_beef, u64::MAX] {
            for m in 0..=8u32 {
                let n = 1u32 << m;
                for block in 0..3u32 {
                    let points: Vec<Vec2> = (block * n..(block + 1) * n)
                        .map(|i| sobol_2d(i, seed))
                        .collect();
                    for j in 0..=m {
                        let (nx, ny) = (1u32 << j, 1u32 << (m - j));
                        let mut seen = vec![false; n as usize];
                        for p in &points {
                            let cell = (p.x * nx as f32) as u32 * ny + (p.y * ny as f32) as u32;
                            assert!(
                                !std::mem::replace(&mut seen[cell as usize], true),
                                "seed {seed}, m {m}, j {j}: two points in one interval"
                            );
                        }
                    }
                }
            }
        }
    }

    proptest! {
        /// The shortcuts of `sobol_2d` and `sobol_1d` (fewer bit reversals, reversed tables)
        /// give the defined point bit for bit.
        #[test]
        fn the_shortcuts_are_exact(index: u32, seed: u64) {
            let p = defined_2d(index, seed);
            prop_assert_eq!(sobol_2d(index, seed).to_array().map(f32::to_bits), p.to_array().map(f32::to_bits));
            prop_assert_eq!(sobol_1d(index, seed).to_bits(), p.x.to_bits());
        }

        /// The reversed byte tables give the reversed XOR of the direction numbers of the
        /// index's set bits.
        #[test]
        fn tables_match_the_bitwise_definition(index: u32) {
            prop_assert_eq!(sobol_1_reversed(index), sobol_1(index).reverse_bits());
        }

        /// Values lie in [0, 1) and depend only on (index, seed).
        #[test]
        fn values_are_in_the_unit_square(index: u32, seed: u64) {
            let p = sobol_2d(index, seed);
            prop_assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y));
            prop_assert_eq!(p, sobol_2d(index, seed));
            let q = sobol_1d(index, seed);
            prop_assert!((0.0..1.0).contains(&q));
        }
    }

    /// Unbiased: over many seeds, the mean of one sample is 1/2 in each coordinate. With 4096
    /// seeds the mean of a uniform variable has standard deviation √(1/12/4096) = 0.0045; the
    /// bound is 5 of those.
    #[test]
    fn each_point_is_uniform_over_seeds() {
        for index in [0u32, 1, 7, 1000] {
            let n = 4096;
            let (mut sx, mut sy) = (0.0f64, 0.0f64);
            for s in 0..n {
                let p = sobol_2d(index, crate::rng::hash_keys(&[s]));
                sx += f64::from(p.x);
                sy += f64::from(p.y);
            }
            let bound = 5.0 * (1.0 / 12.0 / n as f64).sqrt();
            assert!((sx / n as f64 - 0.5).abs() < bound, "x of index {index}");
            assert!((sy / n as f64 - 0.5).abs() < bound, "y of index {index}");
        }
    }
}
