//! A gather's own noise: the variance of its irradiance estimate E, estimated from the gather
//! itself, with no ray more, so that a cache can say how noisy each record is (its summary, its
//! debug view) and spend more rays where a record is noisy.
//!
//! # The estimator
//! E = W Σᵢ yᵢ over the C = M·N cells, W = π/(MN), one sample yᵢ per cell and the cells'
//! samples independent, so Var E = W² Σᵢ σᵢ², σᵢ² the variance of cell i's sample (the spread of
//! the radiance over the cell's directions plus whatever noise each value carries, such as a
//! path-traced continuation's). One sample cannot give its own cell's σᵢ², so neighbouring cells
//! are paired, the "collapsed strata" estimator of survey sampling (Cochran, *Sampling
//! Techniques*, §5A.12). Along φ each row is a cycle of N cells whose N successive differences
//! count every cell twice:
//!
//! V̂ = W² Σⱼ ½ Σₖ (y_{j,k+1} − y_{j,k})²     (k + 1 taken mod N)
//!
//! For independent cells E[(y_a − y_b)²] = σ_a² + σ_b² + (μ_a − μ_b)², so
//! E[V̂] = W² [Σᵢ σᵢ² + ½ Σⱼₖ (μ_{j,k+1} − μ_{j,k})²]: exact where the cells' means agree along φ,
//! too high by half the squared steps of the mean where they do not (a bright object's outline).
//! It never reads low in expectation, so a rule that stops sampling when V̂ is small stops late,
//! never early. With N = 1 (one cell per row) the cells are paired along θ instead, a path of M
//! cells whose M − 1 differences count the inner cells twice and the two ends once; the factor
//! M/(2(M − 1)) makes the count right on average.

use crate::samples::GatherSamples;
use crate::value::GatherValue;

impl<V: GatherValue> GatherSamples<V> {
    /// The estimated variance of channel `channel` of [`GatherSamples::irradiance`] (see the
    /// module docs); 0 for a single cell, which has nothing to be compared with. A cell with k
    /// samples ([`GatherSamples::from_cells`]) adds its own sample variance over k; a cell with
    /// one sample adds its share of the differences with its neighbours (a quarter of the two
    /// squared differences along φ: over a row of one-sample cells, the cyclic sum above).
    pub fn irradiance_variance(&self, channel: usize) -> f64 {
        let strata = self.strata();
        let (m, n) = (strata.m() as usize, strata.n() as usize);
        let w = f64::from(strata.cell_weight());
        let y = |i: usize| f64::from(self.radiance()[i].channel(channel));
        let mut sum = 0.0f64;
        if n >= 2 {
            for j in 0..m {
                let row = j * n;
                for k in 0..n {
                    let i = row + k;
                    match &self.cells {
                        Some(c) if c.counts[i] >= 2 => {
                            sum +=
                                f64::from(c.variance[i].channel(channel)) / f64::from(c.counts[i]);
                        }
                        _ => {
                            let before = y(i) - y(row + (k + n - 1) % n);
                            let after = y(row + (k + 1) % n) - y(i);
                            sum += 0.25 * (before * before + after * after);
                        }
                    }
                }
            }
        } else if m >= 2 {
            let pairs: f64 = (1..m).map(|j| (y(j) - y(j - 1)).powi(2)).sum();
            sum = pairs * m as f64 / (2.0 * (m - 1) as f64);
        }
        w * w * sum
    }

    /// The estimated relative standard error of E in its noisiest channel:
    /// max over channels of √V̂_c / E_c, among the channels with E_c > 0 (0 if none: a black
    /// gather, whose every sample was 0, has no noise).
    pub fn relative_error(&self) -> f32 {
        let e = self.irradiance();
        (0..V::CHANNELS)
            .filter(|&c| e.channel(c) > 0.0)
            .map(|c| (self.irradiance_variance(c).sqrt() / f64::from(e.channel(c))) as f32)
            .fold(0.0, f32::max)
    }
}

#[cfg(test)]
mod tests {
    use crate::samples::GatherSamples;
    use glam::Vec3;
    use irr_sampling::{HemisphereStrata, SampleKey};
    use proptest::prelude::*;

    fn strata(m: u32, n: u32) -> HemisphereStrata {
        HemisphereStrata::new(m, n).unwrap_or_else(|e| panic!("{e}"))
    }

    /// A sky of one radiance has no noise at all; a black one neither, and its relative error
    /// is 0 rather than 0/0.
    #[test]
    fn uniform_gathers_have_no_noise() {
        for (m, n) in [(1, 1), (1, 7), (6, 1), (12, 48)] {
            let sky = GatherSamples::from_fn(strata(m, n), |_| (Vec3::new(1.0, 2.0, 0.0), 1.0))
                .unwrap_or_else(|e| panic!("{e}"));
            for c in 0..3 {
                assert_eq!(sky.irradiance_variance(c), 0.0, "{m}×{n}");
            }
            assert_eq!(sky.relative_error(), 0.0);
        }
    }

    /// Known answer in expectation: cells whose samples are independent, of one mean μ and
    /// variance σ², give E[V̂] = W²·C·σ² exactly (module docs: the mean's steps are 0). Samples
    /// uniform in [0, 2μ] (σ² = μ²/3, kurtosis β₂ = μ₄/σ⁴ = 1.8), K = 4000 gathers of 6×24.
    /// The spread of V̂: a row's N cyclic squared differences d² have Var d² = 2μ₄ + 2σ⁴ and
    /// neighbours share a cell, Cov = μ₄ − σ⁴, so Var Σd² = 4Nμ₄ against E Σd² = 2Nσ², and over
    /// M independent rows Var V̂ / (E V̂)² = β₂/C = 0.0125. The mean of V̂ over K gathers is then
    /// within 6·√(0.0125/4000) = 1.1 % of W²Cσ² (probability 1 − 2e-9). The spread of E itself,
    /// the variance V̂ claims to estimate, is W²Cσ² too: its sample variance over K nearly
    /// normal values (a sum of 144 cells) has relative standard error √(2/(K − 1)), so within
    /// 6·√(2/3999) = 13.5 %.
    #[test]
    fn the_expectation_is_the_variance_of_e_where_the_means_agree() {
        let (m, n, mu) = (6u32, 24u32, 0.5f64);
        let s = strata(m, n);
        let w = f64::from(s.cell_weight());
        let truth = w * w * f64::from(m * n) * mu * mu / 3.0;
        let k = 4000u64;
        let (mut v_sum, mut e_sum, mut e2_sum) = (0.0f64, 0.0f64, 0.0f64);
        for g in 0..k {
            let gather = GatherSamples::from_fn(s, |cell| {
                let u = SampleKey::new(7, g, u64::from(cell.index(&s))).uniform(0);
                (2.0 * mu as f32 * u, 1.0)
            })
            .unwrap_or_else(|e| panic!("{e}"));
            v_sum += gather.irradiance_variance(0);
            let e = f64::from(gather.irradiance());
            e_sum += e;
            e2_sum += e * e;
        }
        let kf = k as f64;
        let mean_v = v_sum / kf;
        assert!((mean_v / truth - 1.0).abs() < 0.011, "{mean_v} vs {truth}");
        let spread = (e2_sum - e_sum * e_sum / kf) / (kf - 1.0);
        assert!((spread / truth - 1.0).abs() < 0.135, "{spread} vs {truth}");
    }

    /// Where the means differ between neighbours the estimate is higher than the noise by half
    /// the squared steps (module docs): a noiseless gather of alternating 0 and 1 along φ reads
    /// W²·M·N/2 exactly (N differences of 1 per row, each halved).
    #[test]
    fn structure_reads_as_noise_and_never_lowers_the_estimate() {
        let s = strata(3, 8);
        let g = GatherSamples::from_fn(s, |cell| ((cell.k % 2) as f32, 1.0))
            .unwrap_or_else(|e| panic!("{e}"));
        let w = f64::from(s.cell_weight());
        let expected = w * w * 3.0 * 8.0 * 0.5;
        assert!((g.irradiance_variance(0) - expected).abs() <= 1e-12 * expected);
    }

    proptest! {
        #![proptest_config(crate::analytic::fixed_config(64, 0x4e01))]

        /// V̂ ≥ 0; scaling every value by a scales V̂ by a² (to f64 rounding of the squares'
        /// sums: 1e-9 relative is thousands of times their rounding); turning every row by the
        /// same number of cells leaves it unchanged up to the order of the additions.
        #[test]
        fn scaling_and_rotation(
            m in 1u32..6, n in 1u32..12, a in 0.01f32..100.0, turn in 0u32..12,
            values in proptest::collection::vec(0.0f32..10.0, 72),
        ) {
            let s = strata(m, n);
            let at = |j: u32, k: u32| values[((j * n + k) as usize) % values.len()];
            let g = GatherSamples::from_fn(s, |c| (at(c.j, c.k), 1.0)).unwrap_or_else(|e| panic!("{e}"));
            let scaled = GatherSamples::from_fn(s, |c| (a * at(c.j, c.k), 1.0)).unwrap_or_else(|e| panic!("{e}"));
            let turned = GatherSamples::from_fn(s, |c| (at(c.j, (c.k + turn) % n), 1.0)).unwrap_or_else(|e| panic!("{e}"));
            let v = g.irradiance_variance(0);
            prop_assert!(v >= 0.0);
            let a2 = f64::from(a) * f64::from(a);
            // The scaled values are rounded to f32 once each: 2⁻²³ relative per value, so
            // their squared differences within 4·2⁻²³ ≈ 5e-7 relative of a²·V̂'s terms.
            prop_assert!((scaled.irradiance_variance(0) - a2 * v).abs() <= 1e-6 * a2 * v + 1e-30);
            prop_assert!((turned.irradiance_variance(0) - v).abs() <= 1e-9 * v + 1e-30);
        }
    }
}
