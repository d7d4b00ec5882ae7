//! A counter-based random source: every value is a hash of its keys.
//!
//! A value depends only on `(seed, stream, index, dimension)`: `stream` names what is being
//! sampled (a pixel, or a cache record), `index` the sample number within it, and `dimension` which
//! number of that sample. Nothing is stored between calls, so the same keys give the same number in
//! any thread and any order. The mixing function is SplitMix64's finaliser (Steele, Lea & Flood,
//! "Fast splittable pseudorandom number generators", OOPSLA 2014), applied to the keys one after
//! another so that nearby keys give unrelated outputs.

use glam::Vec2;

/// SplitMix64's output function: a bijection on `u64` with full avalanche.
#[inline]
pub(crate) fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The golden-ratio increment of SplitMix64, added before each key is mixed in.
const GAMMA: u64 = 0x9e37_79b9_7f4a_7c15;

/// Hashes a sequence of keys into one well-mixed `u64`.
#[inline]
pub fn hash_keys(keys: &[u64]) -> u64 {
    let mut h: u64 = 0x243f_6a88_85a3_08d3; // digits of π: an arbitrary non-zero start
    for &k in keys {
        h = mix64(h.wrapping_add(GAMMA) ^ k);
    }
    h
}

/// Maps 32 random bits to a float uniformly distributed in [0, 1).
///
/// The top 24 bits become the mantissa, so every value is a multiple of 2⁻²⁴ and the largest is
/// 1 − 2⁻²⁴ < 1: the result is never 1.0.
#[inline]
pub fn bits_to_unit_f32(bits: u32) -> f32 {
    (bits >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// The keys of one sample: which seed, which stream (pixel or record), which sample index.
///
/// The key is hashed once at construction; each dimension costs one more mix. A pixel's key
/// ([`SampleKey::pixel`]) also draws its [`uniform`](Self::uniform) and
/// [`uniform_2d`](Self::uniform_2d) values from dimension 1 on from a low-discrepancy sequence
/// (see [`crate::sobol`]): the pixel's samples then stratify every dimension pair together.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SampleKey {
    hashed: u64,
    /// For a pixel's key: the hash of (seed, pixel) that seeds its sequence, and the sample index
    /// with its bits reversed (as the sequence's shuffle reads it: reversed once here rather
    /// than at every draw).
    sequence: Option<(u64, u32)>,
}

/// The keys of one pixel's samples, hashed once ([`SampleKey::pixel_keys`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelKeys {
    /// The hash state after (seed, stream): `hash_keys` of those two keys.
    prefix: u64,
    /// The seed of the pixel's sequence.
    sequence_seed: u64,
}

impl PixelKeys {
    /// Sample `index`'s key: [`SampleKey::pixel`]`(seed, x, y, index)`.
    #[inline]
    pub fn sample(&self, index: u64) -> SampleKey {
        SampleKey {
            // hash_keys(&[seed, stream, index]): one more key into the prefix's state.
            hashed: mix64(self.prefix.wrapping_add(GAMMA) ^ index),
            sequence: Some((self.sequence_seed, (index as u32).reverse_bits())),
        }
    }
}

/// Mixed into a pixel's key to seed its low-discrepancy sequence, so the sequence's seeds are
/// unrelated to the independent values' hashes.
const SEQUENCE_TAG: u64 = 0x50b0_1000_0000_0001;

/// Mixed into a key's hash for its sub-samples ([`SampleKey::subsample`]).
const SUBSAMPLE_TAG: u64 = 0x5b5a_3b1e_0000_0001;

impl SampleKey {
    /// The key of sample `index` of `stream` under `seed`: independent uniform values per
    /// dimension.
    #[inline]
    pub fn new(seed: u64, stream: u64, index: u64) -> Self {
        Self {
            hashed: hash_keys(&[seed, stream, index]),
            sequence: None,
        }
    }

    /// The key of a pixel's sample: the stream is the pixel's position packed into 64 bits.
    /// Dimension 0 is left independent (irr-render stratifies the position in the pixel itself);
    /// dimensions 1 and up come from the pixel's shuffled, Owen-scrambled Sobol sequence
    /// ([`crate::sobol`]), sample `index` of it (indices past 2³² − 1 wrap). Every value is still a
    /// function of (seed, pixel, index, dimension) alone.
    ///
    /// Every dimension, not only the first bounce's: stopping the sequence earlier gained time
    /// within the seeds' spread, for noisier images at equal samples (see docs/performance.md,
    /// Sobol sampler).
    #[inline]
    pub fn pixel(seed: u64, x: u32, y: u32, index: u64) -> Self {
        let stream = (u64::from(y) << 32) | u64::from(x);
        Self {
            sequence: Some((
                hash_keys(&[seed, stream, SEQUENCE_TAG]),
                (index as u32).reverse_bits(),
            )),
            ..Self::new(seed, stream, index)
        }
    }

    /// What every sample of pixel (x, y) under `seed` shares, so that each sample's key
    /// ([`PixelKeys::sample`]) costs one mix rather than a hash of all its keys: the same keys
    /// as [`SampleKey::pixel`], bit for bit.
    #[inline]
    pub fn pixel_keys(seed: u64, x: u32, y: u32) -> PixelKeys {
        let stream = (u64::from(y) << 32) | u64::from(x);
        PixelKeys {
            prefix: hash_keys(&[seed, stream]),
            sequence_seed: hash_keys(&[seed, stream, SEQUENCE_TAG]),
        }
    }

    /// The same key with independent values in every dimension (the sequence dropped): for
    /// comparisons with the low-discrepancy sequence.
    #[inline]
    pub fn independent(self) -> Self {
        Self {
            sequence: None,
            ..self
        }
    }

    /// Sub-sample `j` of `2^bits` that split this sample (`j < 2^bits`, `bits` ≤ 16), such as
    /// the K BSDF samples a camera hit spends on one glossy lobe. In a pixel's sequence it is
    /// sample `index·2^bits + j`: the sub-samples of one sample are one aligned block of the
    /// sequence, which the shuffle keeps aligned, so together they are a (0, bits, 2)-net in
    /// each dimension (stratified against each other, not K independent points), and those of
    /// the pixel's first 2ᵐ samples a (0, m + bits, 2)-net. Independent values are rehashed
    /// with `j`. Sub-sample 0 of 1 (`bits` 0) is the sample itself.
    #[inline]
    pub fn subsample(self, j: u32, bits: u32) -> Self {
        debug_assert!(
            bits <= 16 && u64::from(j) < 1u64 << bits,
            "sub-sample {j} of 2^{bits}"
        );
        if bits == 0 {
            return self;
        }
        Self {
            hashed: mix64(self.hashed.wrapping_add(GAMMA) ^ SUBSAMPLE_TAG ^ u64::from(j)),
            // reverse(index·2^bits + j) = reverse(index) ≫ bits | reverse(j): j < 2^bits
            // fills the top `bits` bits once reversed (indices past 2³² − 1 wrap).
            sequence: self
                .sequence
                .map(|(seed, reversed)| (seed, (reversed >> bits) | j.reverse_bits())),
        }
    }

    /// 64 random bits for `dimension`.
    #[inline]
    pub fn bits(self, dimension: u32) -> u64 {
        mix64(self.hashed.wrapping_add(GAMMA) ^ u64::from(dimension))
    }

    /// A number uniform in [0, 1) for `dimension`.
    #[inline]
    pub fn uniform(self, dimension: u32) -> f32 {
        match self.sequence {
            Some((seed, reversed_index)) if dimension > 0 => {
                crate::sobol::sobol_1d_reversed(reversed_index, mix64(seed ^ u64::from(dimension)))
            }
            _ => bits_to_unit_f32((self.bits(dimension) >> 32) as u32),
        }
    }

    /// A point uniform in [0, 1)² for dimension `dimension`: both coordinates come from one hash
    /// (its high and low 32 bits), or one point of the pixel's sequence, so a 2D sample uses one
    /// dimension number.
    #[inline]
    pub fn uniform_2d(self, dimension: u32) -> Vec2 {
        match self.sequence {
            Some((seed, reversed_index)) if dimension > 0 => {
                crate::sobol::sobol_2d_reversed(reversed_index, mix64(seed ^ u64::from(dimension)))
            }
            _ => {
                let b = self.bits(dimension);
                Vec2::new(
                    bits_to_unit_f32((b >> 32) as u32),
                    bits_to_unit_f32(b as u32),
                )
            }
        }
    }
}

/// A cursor over the dimensions of one [`SampleKey`], for code that draws numbers in sequence.
///
/// The values still depend only on the key and the dimension number; the cursor only counts.
#[derive(Clone, Copy, Debug)]
pub struct Dimensions {
    key: SampleKey,
    next: u32,
}

impl Dimensions {
    /// Starts at dimension 0 of `key`.
    pub fn new(key: SampleKey) -> Self {
        Self { key, next: 0 }
    }

    /// Starts at dimension `first` of `key`.
    pub fn starting_at(key: SampleKey, first: u32) -> Self {
        Self { key, next: first }
    }

    /// The next number in [0, 1).
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        let v = self.key.uniform(self.next);
        self.next += 1;
        v
    }

    /// The next point in [0, 1)².
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let v = self.key.uniform_2d(self.next);
        self.next += 1;
        v
    }

    /// The key the cursor draws from.
    #[inline]
    pub fn key(&self) -> SampleKey {
        self.key
    }

    /// The dimension number the next draw will use.
    pub fn position(&self) -> u32 {
        self.next
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// A pixel's keys hashed once give every sample's key bit for bit.
        #[test]
        fn pixel_keys_give_the_pixels_sample_keys(seed: u64, x: u32, y: u32, index: u64) {
            prop_assert_eq!(SampleKey::pixel_keys(seed, x, y).sample(index), SampleKey::pixel(seed, x, y, index));
        }
    }

    #[test]
    fn unit_float_range_is_half_open() {
        assert_eq!(bits_to_unit_f32(0), 0.0);
        assert!(bits_to_unit_f32(u32::MAX) < 1.0);
        assert_eq!(bits_to_unit_f32(u32::MAX), 1.0 - (2.0f32).powi(-24));
    }

    #[test]
    fn order_of_calls_does_not_matter() {
        let key = SampleKey::new(1, 2, 3);
        let forward: Vec<f32> = (0..64).map(|d| key.uniform(d)).collect();
        let backward: Vec<f32> = (0..64).rev().map(|d| key.uniform(d)).collect();
        let mut backward = backward;
        backward.reverse();
        assert_eq!(forward, backward);
        // And from other threads.
        let from_threads: Vec<f32> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..64).map(|d| s.spawn(move || key.uniform(d))).collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or(f32::NAN))
                .collect()
        });
        assert_eq!(forward, from_threads);
    }

    /// The K = 2^k sub-samples of one camera sample are a (0, k, 2)-net in a pixel dimension
    /// (one point in each elementary interval of every shape), and those of the first 2ᵐ
    /// samples together a (0, m + k, 2)-net. Exact: no tolerance.
    #[test]
    fn subsamples_of_a_sample_are_a_net() {
        let cells = |points: &[Vec2], m: u32| {
            (0..=m).all(|j| {
                let (nx, ny) = (1u32 << j, 1u32 << (m - j));
                let mut seen = vec![false; 1 << m];
                points.iter().all(|p| {
                    let cell = (p.x * nx as f32) as u32 * ny + (p.y * ny as f32) as u32;
                    !std::mem::replace(&mut seen[cell as usize], true)
                })
            })
        };
        for (seed, dim) in [(1u64, 1u32), (7, 5), (u64::MAX, 40)] {
            for k in 0..=5u32 {
                for m in 0..=3u32 {
                    let mut all = Vec::new();
                    for i in 0..1u64 << m {
                        let key = SampleKey::pixel(seed, 3, 4, i);
                        let own: Vec<Vec2> = (0..1 << k)
                            .map(|j| key.subsample(j, k).uniform_2d(dim))
                            .collect();
                        assert!(cells(&own, k), "seed {seed}, k {k}, sample {i}");
                        all.extend(own);
                    }
                    assert!(cells(&all, m + k), "seed {seed}, k {k}, m {m}");
                }
            }
        }
    }

    #[test]
    fn cursor_matches_direct_indexing() {
        let key = SampleKey::pixel(9, 10, 11, 12);
        let mut dims = Dimensions::new(key);
        assert_eq!(dims.next_1d(), key.uniform(0));
        assert_eq!(dims.next_2d(), key.uniform_2d(1));
        assert_eq!(dims.position(), 2);
    }

    /// The mean of n uniform numbers has standard deviation 1/√(12n); with n = 2¹⁶ that is
    /// 0.00113, and a 6σ band (false-failure odds ≈ 2·10⁻⁹ for a fixed, deterministic draw) is
    /// ±0.0068. The same for the lag-1 correlation, whose standard deviation is 1/√n = 0.0039.
    #[test]
    fn moments_of_a_stream_are_uniform() {
        let n = 1u32 << 16;
        let xs: Vec<f64> = (0..n)
            .map(|i| f64::from(SampleKey::new(5, u64::from(i), 0).uniform(0)))
            .collect();
        let mean = xs.iter().sum::<f64>() / f64::from(n);
        assert!(
            (mean - 0.5).abs() < 6.0 / (12.0 * f64::from(n)).sqrt(),
            "mean {mean}"
        );
        let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / f64::from(n);
        let corr = xs
            .windows(2)
            .map(|w| (w[0] - mean) * (w[1] - mean))
            .sum::<f64>()
            / (f64::from(n - 1) * var);
        assert!(
            corr.abs() < 6.0 / f64::from(n).sqrt(),
            "lag-1 correlation {corr}"
        );
    }

    proptest! {
        #[test]
        fn same_keys_same_numbers(seed: u64, stream: u64, index: u64, dim in 0u32..1024) {
            let a = SampleKey::new(seed, stream, index).uniform_2d(dim);
            let b = SampleKey::new(seed, stream, index).uniform_2d(dim);
            prop_assert_eq!(a, b);
            prop_assert!(a.x >= 0.0 && a.x < 1.0 && a.y >= 0.0 && a.y < 1.0);
        }

        #[test]
        fn pixel_keys_are_distinct_streams(seed: u64, x: u32, y: u32) {
            prop_assume!(x != y);
            prop_assert_ne!(SampleKey::pixel(seed, x, y, 0), SampleKey::pixel(seed, y, x, 0));
        }

        /// Sub-sample j of 2^bits of a pixel's sample i is the sequence's sample i·2^bits + j
        /// in every dimension from 1 on; sub-sample 0 of 1 is the sample itself.
        #[test]
        fn subsamples_are_the_sequences_finer_samples(seed: u64, x: u32, y: u32, index in 0u32..1 << 20, bits in 0u32..=8, j: u32, dim in 1u32..64) {
            let j = j & ((1 << bits) - 1);
            let sub = SampleKey::pixel(seed, x, y, u64::from(index)).subsample(j, bits);
            let finer = SampleKey::pixel(seed, x, y, u64::from((index << bits) | j));
            prop_assert_eq!(sub.uniform_2d(dim), finer.uniform_2d(dim));
            prop_assert_eq!(sub.uniform(dim), finer.uniform(dim));
            let key = SampleKey::pixel(seed, x, y, u64::from(index));
            prop_assert_eq!(key.subsample(0, 0), key);
        }

        /// Sub-samples draw unrelated independent values (dimension 0, and keys without a
        /// sequence): distinct 64-bit hashes for distinct j.
        #[test]
        fn subsamples_rehash_the_independent_values(seed: u64, stream: u64, index: u64, a in 0u32..256, b in 0u32..256) {
            prop_assume!(a != b);
            let key = SampleKey::new(seed, stream, index);
            prop_assert_ne!(key.subsample(a, 8).bits(0), key.subsample(b, 8).bits(0));
        }

        /// A pixel's dimensions from 1 on are points of its sequence: sample `index` of
        /// `sobol_2d` / `sobol_1d` seeded by the pixel's sequence hash and the dimension (the
        /// key keeps the index bit-reversed, which must not change a value).
        #[test]
        fn pixel_dimensions_are_the_sequence(seed: u64, x: u32, y: u32, index: u32, dim in 1u32..64) {
            let key = SampleKey::pixel(seed, x, y, u64::from(index));
            let stream = (u64::from(y) << 32) | u64::from(x);
            let sequence_seed = mix64(hash_keys(&[seed, stream, SEQUENCE_TAG]) ^ u64::from(dim));
            prop_assert_eq!(key.uniform_2d(dim), crate::sobol::sobol_2d(index, sequence_seed));
            prop_assert_eq!(key.uniform(dim), crate::sobol::sobol_1d(index, sequence_seed));
        }
    }
}
