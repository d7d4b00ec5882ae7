//! Gathers with several samples in some cells (adaptive super-sampling): each cell's samples
//! accumulated, the gather the estimators read, and the plan that says which cells get more.
//!
//! # What the estimators read
//! A cell with k samples enters every estimator through their mean L̄ (an unbiased estimate of
//! the cell's mean radiance, with 1/k of one sample's variance) and its **nearest** hit: E and
//! the rotation gradient are linear in the cells' radiance with weights that read no distance,
//! and the translation gradient's wall terms (L_b − L_a)·g/R take R from the nearer of the two
//! cells' hits because the nearer object is the occluder whose silhouette moves. At an
//! occlusion edge that falls inside a cell (an occluder over a fraction f of it, at R_o, the
//! background beyond), one sample gives (L_o − L_b)/R_o with probability f and 0 otherwise, so
//! f·(L_o − L_b)/R_o in expectation; k samples' mean with their nearest hit give
//! f̂·(L_o − L_b)/R_o whenever one of them met the occluder (and 0 when f̂ = 0): the same
//! expectation. The pilot's distance or a mean distance would pull R towards the background's.
//! Radiance (`ambcomp.c`) keeps the mean value and the nearest distance of a resampled cell too.
//!
//! # Which cells get more samples
//! [`plan_extra_samples`]: the cells' spreads are scored from the pilot (one sample each) by the
//! difference of each cell's two neighbours along φ and along θ, never by its own value. A cell
//! straddling the outline of something bright has one bright and one dark neighbour and scores
//! high; a quiet region scores low. Because a cell's own sample does not decide how many
//! samples it gets, its mean stays unbiased (Radiance scores a cell by its own value, so a
//! pilot that struck something bright by chance draws samples that dilute it: its source says
//! the step "introduces bias"). The extra samples follow Neyman's allocation, in proportion to
//! the scored spread σ̃ᵢ (which minimises W² Σ σᵢ²/kᵢ for a given total), with the total set so
//! that the predicted relative standard error of E meets the target, at most a cap.

use crate::samples::{CellSpread, GatherError, GatherSamples};
use crate::value::GatherValue;
use irr_sampling::HemisphereStrata;

/// One cell's samples, accumulated in the order they were taken (Welford's update): their
/// count, mean, sum of squared deviations and nearest hit. A cell of one sample holds that
/// sample's value exactly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CellSamples<V> {
    count: u32,
    mean: V,
    m2: V,
    min_distance: f32,
}

impl<V: GatherValue> CellSamples<V> {
    /// A cell with its first sample: the value and the hit distance (`f32::INFINITY` for a
    /// miss, as [`GatherSamples::new`] takes them).
    pub fn first(value: V, distance: f32) -> Self {
        Self {
            count: 1,
            mean: value,
            m2: V::default(),
            min_distance: distance,
        }
    }

    /// Adds a sample.
    pub fn push(&mut self, value: V, distance: f32) {
        self.count += 1;
        let before = value - self.mean;
        self.mean = self.mean + before * (1.0 / self.count as f32);
        self.m2 = self.m2 + before.hadamard(value - self.mean);
        self.min_distance = self.min_distance.min(distance);
    }

    /// How many samples it has.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// Their mean.
    pub fn mean(&self) -> V {
        self.mean
    }

    /// Their sample variance (0 for one sample).
    pub fn variance(&self) -> V {
        if self.count < 2 {
            V::default()
        } else {
            self.m2 * (1.0 / (self.count - 1) as f32)
        }
    }
}

impl<V: GatherValue> GatherSamples<V> {
    /// A gather from cells of any number of samples (by [`irr_sampling::Cell::index`]): each
    /// cell's mean radiance and nearest hit (module docs), its count and spread kept for the
    /// noise estimate ([`GatherSamples::irradiance_variance`]). With one sample in every cell
    /// it is [`GatherSamples::new`] of those samples, bit for bit, with the counts recorded.
    pub fn from_cells(
        strata: HemisphereStrata,
        cells: &[CellSamples<V>],
    ) -> Result<Self, GatherError> {
        let radiance = cells.iter().map(|c| c.mean).collect();
        let distance = cells.iter().map(|c| c.min_distance).collect();
        let mut g = Self::new(strata, radiance, distance)?;
        g.cells = Some(CellSpread {
            counts: cells.iter().map(|c| c.count).collect(),
            variance: cells.iter().map(CellSamples::variance).collect(),
        });
        Ok(g)
    }

    /// How many samples each cell has (1 each unless made by [`GatherSamples::from_cells`]).
    pub fn counts(&self) -> Vec<u32> {
        match &self.cells {
            Some(c) => c.counts.clone(),
            None => vec![1; self.radiance().len()],
        }
    }
}

/// How many samples to add to each cell of a one-sample-per-cell gather (`pilot`) so that the
/// predicted relative standard error of its E falls to `target` (in its noisiest channel),
/// with at most `cap` extra samples in all; `fixed[i]` marks cells whose value is known exactly
/// (below the surface: no ray, value 0), which get none. All zeros when the pilot already
/// meets the target (by [`GatherSamples::relative_error`]). See the module docs for the scores
/// and the allocation.
pub fn plan_extra_samples<V: GatherValue>(
    pilot: &GatherSamples<V>,
    fixed: &[bool],
    target: f32,
    cap: u32,
) -> Vec<u32> {
    let strata = pilot.strata();
    let (m, n) = (strata.m() as usize, strata.n() as usize);
    let cells = m * n;
    let mut extra = vec![0u32; cells];
    if cap == 0 || target.is_nan() || target <= 0.0 || pilot.relative_error() <= target {
        return extra;
    }
    let e = pilot.irradiance();
    let y = pilot.radiance();
    // The scored spread of each cell, relative to E per channel, summed over the channels
    // with E > 0: from the differences of its two neighbours along φ (a cycle) and along θ
    // (where both exist). Each difference of two independent cells has twice one cell's
    // variance; the mean of the available squared differences, halved, estimates σ².
    let spread = |i: usize| -> f64 {
        let (j, k) = (i / n, i % n);
        let mut pairs: Vec<(usize, usize)> = Vec::with_capacity(2);
        if n >= 3 {
            pairs.push((j * n + (k + 1) % n, j * n + (k + n - 1) % n));
        }
        if j >= 1 && j + 1 < m {
            pairs.push(((j + 1) * n + k, (j - 1) * n + k));
        }
        if pairs.is_empty() {
            return 0.0;
        }
        let mut sum = 0.0f64;
        for c in (0..V::CHANNELS).filter(|&c| e.channel(c) > 0.0) {
            let ec = f64::from(e.channel(c));
            for &(a, b) in &pairs {
                let d = f64::from(y[a].channel(c) - y[b].channel(c)) / ec;
                sum += d * d;
            }
        }
        sum / (2.0 * pairs.len() as f64)
    };
    let sigma: Vec<f64> = (0..cells)
        .map(|i| if fixed[i] { 0.0 } else { spread(i).sqrt() })
        .collect();
    // Relative variance of E with kᵢ = max(1, λσᵢ) samples: W² Σ σᵢ²/kᵢ; the smallest λ that
    // meets target², or whose samples reach the cap.
    let w = f64::from(strata.cell_weight());
    let goal = f64::from(target) * f64::from(target) / (w * w);
    let hi = neyman_scale(&sigma, goal, f64::from(cap));
    // Whole samples: the floor of each cell's share, then the largest remainders (ties to the
    // lower cell index), within the cap.
    let wanted: Vec<f64> = sigma
        .iter()
        .zip(fixed)
        .map(|(&s, &f)| {
            if f {
                0.0
            } else {
                ((hi * s).max(1.0) - 1.0).max(0.0)
            }
        })
        .collect();
    let total = wanted.iter().sum::<f64>().min(f64::from(cap)).round() as u32;
    let scale = if wanted.iter().sum::<f64>() > f64::from(total) {
        f64::from(total) / wanted.iter().sum::<f64>()
    } else {
        1.0
    };
    let mut given = 0u32;
    let mut remainders: Vec<(f64, usize)> = Vec::new();
    for (i, &want) in wanted.iter().enumerate() {
        let share = want * scale;
        extra[i] = share.floor() as u32;
        given += extra[i];
        remainders.push((share - share.floor(), i));
    }
    remainders.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    for &(r, i) in &remainders {
        if given >= total || r <= 0.0 {
            break;
        }
        extra[i] += 1;
        given += 1;
    }
    extra
}

/// The smallest λ ≥ 0 at which the spreads σᵢ (any order, ≥ 0), given kᵢ = max(1, λσᵢ) samples
/// each, have Σ σᵢ²/kᵢ ≤ `goal` or Σ (kᵢ − 1) ≥ `cap` (at most 10¹²). Both sums are monotone and
/// continuous in λ, and with the σ sorted so that the first K have λσᵢ ≥ 1 they read
/// P_K/λ + Q_K and λ·P_K − K (P_K the sum of those K spreads, Q_K the sum of the others'
/// squares): each stretch of λ between two breakpoints 1/σᵢ is solved in closed form, the
/// stretches in increasing λ, where a bisection would evaluate both sums over every cell at
/// each of its steps.
fn neyman_scale(sigma: &[f64], goal: f64, cap: f64) -> f64 {
    const MAX: f64 = 1e12;
    let mut s: Vec<f64> = sigma.iter().copied().filter(|&x| x > 0.0).collect();
    s.sort_by(|a, b| b.total_cmp(a));
    let mut q: f64 = s.iter().map(|x| x * x).sum();
    let mut p = 0.0f64;
    for k in 0..=s.len() {
        // The stretch where exactly the first k spreads have λσ ≥ 1.
        let lo = if k == 0 { 0.0 } else { 1.0 / s[k - 1] };
        let hi = s.get(k).map_or(f64::INFINITY, |x| 1.0 / x);
        let mut best = f64::INFINITY;
        if q <= goal && (p == 0.0 || goal > q) {
            let at = if p == 0.0 { lo } else { p / (goal - q) };
            best = best.min(at.max(lo));
        }
        if p > 0.0 {
            best = best.min(((cap + k as f64) / p).max(lo));
        } else if cap <= 0.0 {
            best = lo;
        }
        if best <= hi {
            return best.min(MAX);
        }
        if let Some(&x) = s.get(k) {
            p += x;
            q = (q - x * x).max(0.0);
        }
    }
    MAX
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::TranslationGradient;
    use glam::Vec3;
    use irr_sampling::SampleKey;
    use proptest::prelude::*;

    fn strata(m: u32, n: u32) -> HemisphereStrata {
        HemisphereStrata::new(m, n).unwrap_or_else(|e| panic!("{e}"))
    }

    /// Welford's mean and variance against a two-pass computation in f64: within a few f32
    /// roundings per sample of the values' scale (k ≤ 64 samples: 1e-5 relative).
    #[test]
    fn a_cells_mean_and_variance() {
        let values: Vec<f32> = (0..37).map(|i| ((i * 7919) % 101) as f32 * 0.37).collect();
        let mut cell = CellSamples::first(values[0], 3.0);
        for (i, &v) in values.iter().enumerate().skip(1) {
            cell.push(v, 3.0 - i as f32 * 0.01);
        }
        let n = values.len() as f64;
        let mean = values.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
        let var = values
            .iter()
            .map(|&v| (f64::from(v) - mean).powi(2))
            .sum::<f64>()
            / (n - 1.0);
        assert_eq!(cell.count(), 37);
        assert!((f64::from(cell.mean()) - mean).abs() <= 1e-5 * mean);
        assert!((f64::from(cell.variance()) - var).abs() <= 1e-5 * var);
        assert_eq!(cell.min_distance, 3.0 - 36.0 * 0.01);
        // One sample: the value exactly, no spread.
        let one = CellSamples::first(Vec3::new(1.0, 2.0, 3.0), 1.5);
        assert_eq!(
            (one.mean(), one.variance()),
            (Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO)
        );
    }

    proptest! {
        #![proptest_config(crate::analytic::fixed_config(48, 0xce11))]

        /// Cells whose samples are all equal (any counts) are the one-sample gather bit for
        /// bit: the mean of equal values is the value, their nearest hit the distance, so E and
        /// both gradients are the same numbers; the noise of the one-sample cells is unchanged.
        #[test]
        fn repeated_samples_change_nothing(
            m in 2u32..6, n in 3u32..12,
            values in proptest::collection::vec((0.0f32..10.0, 0.1f32..100.0), 72),
            counts in proptest::collection::vec(1u32..5, 72),
        ) {
            let s = strata(m, n);
            let at = |i: usize| values[i % values.len()];
            let plain = GatherSamples::from_fn(s, |c| {
                let (l, r) = at(c.index(&s) as usize);
                (Vec3::splat(l), r)
            }).unwrap_or_else(|e| panic!("{e}"));
            let cells: Vec<CellSamples<Vec3>> = (0..s.len())
                .map(|i| {
                    let (l, r) = at(i);
                    let mut c = CellSamples::first(Vec3::splat(l), r);
                    for _ in 1..counts[i % counts.len()] {
                        c.push(Vec3::splat(l), r);
                    }
                    c
                })
                .collect();
            let super_sampled = GatherSamples::from_cells(s, &cells).unwrap_or_else(|e| panic!("{e}"));
            prop_assert_eq!(super_sampled.radiance(), plain.radiance());
            prop_assert_eq!(super_sampled.distance(), plain.distance());
            for variant in [TranslationGradient::WardHeckbert, TranslationGradient::KrivanekGautron] {
                prop_assert_eq!(super_sampled.gradients(variant), plain.gradients(variant));
            }
            let ones: Vec<CellSamples<Vec3>> = (0..s.len())
                .map(|i| { let (l, r) = at(i); CellSamples::first(Vec3::splat(l), r) })
                .collect();
            let one = GatherSamples::from_cells(s, &ones).unwrap_or_else(|e| panic!("{e}"));
            prop_assert_eq!(one.irradiance_variance(0).to_bits(), plain.irradiance_variance(0).to_bits());
        }
    }

    /// A cell with k samples adds its sample variance over k: one cell of 4 samples 1, 3, 1, 3
    /// (sample variance 4/3) in an otherwise uniform 2×4 sky whose other cells read 2: the
    /// uniform cells' pair shares are 0 except the two beside the cell, which differ from its
    /// mean 2 by 0, so V̂ = W²·(4/3)/4, to the f32 rounding of Welford's four updates (a few
    /// ulps: 1e-6 relative).
    #[test]
    fn super_sampled_cells_add_their_own_spread() {
        let s = strata(2, 4);
        let mut cells: Vec<CellSamples<f32>> =
            (0..8).map(|_| CellSamples::first(2.0, 1.0)).collect();
        cells[5] = CellSamples::first(1.0, 1.0);
        for v in [3.0, 1.0, 3.0] {
            cells[5].push(v, 1.0);
        }
        let g = GatherSamples::from_cells(s, &cells).unwrap_or_else(|e| panic!("{e}"));
        let w = f64::from(s.cell_weight());
        let expected = w * w * (4.0 / 3.0) / 4.0;
        assert!((g.irradiance_variance(0) - expected).abs() <= 1e-6 * expected);
        assert_eq!(g.counts()[5], 4);
    }

    /// The plan: nothing for a gather that meets the target, nothing for fixed cells, never
    /// more than the cap, and a cell's share does not depend on its own value.
    #[test]
    fn the_plan_respects_the_target_the_cap_and_leaves_a_cells_own_value_out() {
        let s = strata(6, 24);
        // A bright patch (value 10) over the cells with j < 2 and 5 ≤ k < 11, dark (0.1)
        // elsewhere: its outline cells have one bright and one dark neighbour.
        let patch = |j: u32, k: u32| {
            if j < 2 && (5..11).contains(&k) {
                10.0f32
            } else {
                0.1
            }
        };
        let g =
            GatherSamples::from_fn(s, |c| (patch(c.j, c.k), 1.0)).unwrap_or_else(|e| panic!("{e}"));
        let fixed = vec![false; s.len()];
        assert!(
            plan_extra_samples(&g, &fixed, 10.0, 1000)
                .iter()
                .all(|&k| k == 0)
        );
        let plan = plan_extra_samples(&g, &fixed, 0.01, 500);
        let total: u32 = plan.iter().sum();
        assert!(total > 0 && total <= 500, "{total}");
        // The cells beside the outline (k = 4 and 11, whose φ-neighbours straddle it, and the
        // outline's own ends) get samples; the middle of the dark region (j = 4, k = 20) none.
        let at = |j: usize, k: usize| plan[j * 24 + k];
        assert!(at(0, 4) > 0 && at(0, 11) > 0 && at(4, 20) == 0, "{plan:?}");
        // Spending the cap in full when the target is out of reach.
        assert_eq!(
            plan_extra_samples(&g, &fixed, 1e-6, 300)
                .iter()
                .sum::<u32>(),
            300
        );
        // A cell's own value does not change its share: with every other cell but one fixed
        // (so the total goes to those two), changing cell 4's value alone leaves its share.
        let mut changed = g.radiance().to_vec();
        changed[4] = 55.0;
        let g2 =
            GatherSamples::new(s, changed, g.distance().to_vec()).unwrap_or_else(|e| panic!("{e}"));
        let mut two_free = vec![true; s.len()];
        two_free[4] = false;
        two_free[100] = false;
        let q1 = plan_extra_samples(&g, &two_free, 1e-6, 50);
        let q2 = plan_extra_samples(&g2, &two_free, 1e-6, 50);
        assert_eq!((q1[4], q1[100]), (q2[4], q2[100]));
        let mut no_rays = vec![false; s.len()];
        no_rays[5] = true;
        assert_eq!(plan_extra_samples(&g, &no_rays, 0.01, 500)[5], 0);
    }

    /// The closed form against a bisection of the same two conditions (60 halvings of a bracket
    /// at least 1 wide, so within 2⁻⁶⁰·max(1, λ) of the answer, and the sums in f64 over ≤ 64
    /// terms: a few 1e-16 relative): the two agree to 1e-9 relative plus the bisection's
    /// 2⁻⁵⁹·max(1, λ) whenever the answer is below the 10¹² ceiling.
    #[test]
    fn the_neyman_scale_solves_both_conditions() {
        let bisect = |sigma: &[f64], goal: f64, cap: f64| {
            let variance =
                |l: f64| -> f64 { sigma.iter().map(|&s| s * s / (l * s).max(1.0)).sum() };
            let samples = |l: f64| -> f64 { sigma.iter().map(|&s| (l * s).max(1.0) - 1.0).sum() };
            let mut hi = 1.0f64;
            while variance(hi) > goal && samples(hi) < cap && hi < 1e12 {
                hi *= 2.0;
            }
            let mut lo = 0.0f64;
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if variance(mid) > goal && samples(mid) < cap {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            hi
        };
        for case in 0..2000u64 {
            let key = SampleKey::new(case, 0, 0);
            let n = 1 + (key.uniform(0) * 64.0) as usize;
            let sigma: Vec<f64> = (0..n)
                .map(|i| {
                    let u = f64::from(SampleKey::new(case, i as u64 + 1, 0).uniform(0));
                    // Zeros (fixed cells), and spreads over six decades.
                    if u < 0.1 {
                        0.0
                    } else {
                        10f64.powf(6.0 * u - 4.0)
                    }
                })
                .collect();
            let total: f64 = sigma.iter().map(|s| s * s).sum();
            let goal = total * f64::from(key.uniform(1)).powi(3);
            let cap = (f64::from(key.uniform(2)) * 4.0 * n as f64).floor();
            let (a, b) = (neyman_scale(&sigma, goal, cap), bisect(&sigma, goal, cap));
            assert!(
                (a - b).abs() <= 1e-9 * b + 2f64.powi(-59) * b.max(1.0)
                    || (a >= 1e12 && b >= 1e12 * 0.999),
                "case {case}: {a} against {b} ({sigma:?}, goal {goal}, cap {cap})"
            );
        }
    }

    /// Unbiased: cells that are bright (value 1/p) with probability p and 0 otherwise (mean 1:
    /// E = π), the heavy tail of a gather whose rays seldom find a bright patch. Over K = 3000
    /// gathers of 4×12 with p = 0.1, planned to a 5 % target with at most 3 extra samples per
    /// cell on average, the mean of E lies within 5 standard errors (from the gathers' own
    /// spread) of π: a cell's count never depends on its own samples. A plan that read a cell's
    /// own pilot would pull the bright pilots down and read low.
    #[test]
    fn super_sampling_stays_unbiased() {
        let s = strata(4, 12);
        let p = 0.1f32;
        let k = 3000u64;
        let value = |g: u64, cell: usize, sample: u64| {
            let u = SampleKey::new(g, cell as u64, sample).uniform(0);
            if u < p { 1.0 / p } else { 0.0 }
        };
        let (mut sum, mut sum2, mut extra) = (0.0f64, 0.0f64, 0u64);
        for g in 0..k {
            let mut cells: Vec<CellSamples<f32>> = (0..s.len())
                .map(|i| CellSamples::first(value(g, i, 0), 1.0))
                .collect();
            let pilot = GatherSamples::from_cells(s, &cells).unwrap_or_else(|e| panic!("{e}"));
            let plan = plan_extra_samples(&pilot, &vec![false; s.len()], 0.05, 3 * s.len() as u32);
            for (i, &more) in plan.iter().enumerate() {
                for t in 1..=u64::from(more) {
                    cells[i].push(value(g, i, t), 1.0);
                }
                extra += u64::from(more);
            }
            let e = f64::from(
                GatherSamples::from_cells(s, &cells)
                    .unwrap_or_else(|e| panic!("{e}"))
                    .irradiance(),
            );
            sum += e;
            sum2 += e * e;
        }
        let kf = k as f64;
        let mean = sum / kf;
        let se = ((sum2 / kf - mean * mean) / kf).sqrt();
        assert!(extra > 0);
        assert!(
            (mean - std::f64::consts::PI).abs() < 5.0 * se,
            "{mean} ± {se}"
        );
    }
}
