//! The M×N stratification of the hemisphere used by the final gather and its gradients.
//!
//! Cell (j, k), with j ∈ [0, M) along θ and k ∈ [0, N) along φ, is the image under
//! [`sample_cosine_hemisphere`] of the rectangle [j/M, (j+1)/M) × [k/N, (k+1)/N) of the unit square.
//! Its bounds are therefore (Ward & Heckbert 1992, eq. 5; Křivánek & Gautron 2009, §2.2):
//!
//! - θⱼ = asin √(j/M), for j = 0..=M (θ₀ = 0 at the pole, θ_M = π/2 at the horizon),
//! - φₖ = 2πk/N, for k = 0..=N.
//!
//! Every cell has the same projected solid angle π/(MN), so one cosine-distributed direction per
//! cell gives the irradiance estimate E ≈ (π/(MN)) Σⱼₖ Lⱼₖ.

use crate::warp::sample_cosine_hemisphere;
use glam::{Vec2, Vec3};
use std::f32::consts::TAU;
use std::fmt;

/// An M×N stratification of the hemisphere in (θ, φ).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HemisphereStrata {
    m: u32,
    n: u32,
}

/// One cell of a [`HemisphereStrata`]: `j` along θ, `k` along φ.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Cell {
    /// Index along θ, in [0, M).
    pub j: u32,
    /// Index along φ, in [0, N).
    pub k: u32,
}

impl Cell {
    /// The cell's index in row-major order (j·N + k), in [0, MN).
    #[inline]
    pub fn index(self, strata: &HemisphereStrata) -> u32 {
        self.j * strata.n + self.k
    }
}

/// A stratification that cannot be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StrataError {
    /// M or N is zero.
    Empty,
    /// M·N does not fit the cell index (u32), or is beyond any sensible gather (over 2²⁰ cells).
    TooMany,
}

impl fmt::Display for StrataError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StrataError::Empty => write!(f, "a hemisphere stratification needs M ≥ 1 and N ≥ 1"),
            StrataError::TooMany => {
                write!(f, "a hemisphere stratification may have at most 2^20 cells")
            }
        }
    }
}

impl std::error::Error for StrataError {}

impl HemisphereStrata {
    /// The most cells a stratification may have (2²⁰): far beyond any final gather, and small
    /// enough that every cell index and dimension number fits a `u32`.
    pub const MAX_CELLS: u64 = 1 << 20;

    /// M divisions in θ and N in φ. Ward & Heckbert recommend N ≈ πM (square-ish cells).
    pub fn new(m: u32, n: u32) -> Result<Self, StrataError> {
        if m == 0 || n == 0 {
            return Err(StrataError::Empty);
        }
        if u64::from(m) * u64::from(n) > Self::MAX_CELLS {
            return Err(StrataError::TooMany);
        }
        Ok(Self { m, n })
    }

    /// The stratification with about `samples` cells and N ≈ πM (Ward & Heckbert 1992, §3):
    /// M = round(√(samples/π)), N = round(samples/M), each at least 1.
    pub fn with_sample_count(samples: u32) -> Result<Self, StrataError> {
        let m = ((f64::from(samples) / std::f64::consts::PI).sqrt().round() as u32).max(1);
        let n = ((f64::from(samples) / f64::from(m)).round() as u32).max(1);
        Self::new(m, n)
    }

    /// Divisions along θ.
    #[inline]
    pub fn m(&self) -> u32 {
        self.m
    }

    /// Divisions along φ.
    #[inline]
    pub fn n(&self) -> u32 {
        self.n
    }

    /// Number of cells, M·N.
    #[inline]
    pub fn len(&self) -> usize {
        self.m as usize * self.n as usize
    }

    /// Always false: a stratification has at least one cell.
    #[inline]
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The cells in row-major order (j outer, k inner), each exactly once.
    pub fn cells(&self) -> impl ExactSizeIterator<Item = Cell> + use<> {
        let n = self.n;
        (0..self.m * self.n).map(move |i| Cell { j: i / n, k: i % n })
    }

    /// θⱼ = asin √(j/M), the polar angle of the boundary between cells j−1 and j (j ∈ 0..=M).
    #[inline]
    pub fn theta_bound(&self, j: u32) -> f32 {
        (self.sin2_theta_bound(j)).sqrt().asin()
    }

    /// sin²θⱼ = j/M, exactly the boundary in the square's first coordinate.
    #[inline]
    pub fn sin2_theta_bound(&self, j: u32) -> f32 {
        j.min(self.m) as f32 / self.m as f32
    }

    /// φₖ = 2πk/N, the azimuth of the boundary between cells k−1 and k (k ∈ 0..=N).
    #[inline]
    pub fn phi_bound(&self, k: u32) -> f32 {
        TAU * (k.min(self.n) as f32 / self.n as f32)
    }

    /// The projected solid angle of every cell, π/(MN): the weight of one cell's radiance in the
    /// irradiance estimate.
    #[inline]
    pub fn cell_weight(&self) -> f32 {
        std::f32::consts::PI / (self.m as f32 * self.n as f32)
    }

    /// The point of the unit square that `u` (in [0, 1)²) becomes inside `cell`.
    #[inline]
    pub fn cell_point(&self, cell: Cell, u: Vec2) -> Vec2 {
        let p = Vec2::new(
            (cell.j as f32 + u.x) / self.m as f32,
            (cell.k as f32 + u.y) / self.n as f32,
        );
        // (j + u)/M can round up to the next cell's bound when u is just below 1: keep it inside.
        let hi = Vec2::new(
            ((cell.j + 1) as f32 / self.m as f32).next_down_f32(),
            ((cell.k + 1) as f32 / self.n as f32).next_down_f32(),
        );
        p.min(hi)
    }

    /// A cosine-distributed direction inside `cell` (local frame, +z the normal), placed by `u`.
    #[inline]
    pub fn sample(&self, cell: Cell, u: Vec2) -> Vec3 {
        sample_cosine_hemisphere(self.cell_point(cell, u))
    }

    /// The cell that contains the local direction `w` (w.z ≥ 0), by inverting the warp.
    pub fn cell_of(&self, w: Vec3) -> Cell {
        let u = crate::warp::invert_cosine_hemisphere(w);
        Cell {
            j: ((u.x * self.m as f32) as u32).min(self.m - 1),
            k: ((u.y * self.n as f32) as u32).min(self.n - 1),
        }
    }
}

/// `f32::next_down`, spelled out for the stable toolchain this crate pins.
trait NextDown {
    fn next_down_f32(self) -> f32;
}

impl NextDown for f32 {
    #[inline]
    fn next_down_f32(self) -> f32 {
        if self <= 0.0 || !self.is_finite() {
            return self;
        }
        f32::from_bits(self.to_bits() - 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SampleKey;
    use crate::warp::cosine_hemisphere_pdf;
    use proptest::prelude::*;
    use std::collections::HashSet;

    #[test]
    fn rejects_empty_and_huge() {
        assert_eq!(HemisphereStrata::new(0, 4), Err(StrataError::Empty));
        assert_eq!(HemisphereStrata::new(4, 0), Err(StrataError::Empty));
        assert_eq!(
            HemisphereStrata::new(1 << 11, 1 << 10),
            Err(StrataError::TooMany)
        );
        assert!(HemisphereStrata::new(1 << 10, 1 << 10).is_ok());
    }

    #[test]
    fn bounds_run_from_pole_to_horizon() {
        let s = HemisphereStrata::new(5, 16).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.theta_bound(0), 0.0);
        assert!((s.theta_bound(5) - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
        assert_eq!(s.phi_bound(0), 0.0);
        assert!((s.phi_bound(16) - TAU).abs() < 1e-6);
        for j in 0..5 {
            assert!(s.theta_bound(j) < s.theta_bound(j + 1));
        }
    }

    #[test]
    fn sample_count_follows_ward_heckbert() {
        let s = HemisphereStrata::with_sample_count(1024).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((s.m(), s.n()), (18, 57));
        let s = HemisphereStrata::with_sample_count(1).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((s.m(), s.n()), (1, 1));
    }

    proptest! {
        /// Every cell is visited exactly once, and each cell's sample lies inside that cell's
        /// θ and φ bounds (checked by inverting the warp, and against the stated bounds).
        #[test]
        fn stratification_covers_every_cell_once(m in 1u32..24, n in 1u32..48, seed: u64) {
            let s = HemisphereStrata::new(m, n).unwrap_or_else(|e| panic!("{e}"));
            let cells: Vec<Cell> = s.cells().collect();
            prop_assert_eq!(cells.len(), s.len());
            let distinct: HashSet<Cell> = cells.iter().copied().collect();
            prop_assert_eq!(distinct.len(), s.len());
            let key = SampleKey::new(seed, 0, 0);
            let mut visits = vec![0u32; s.len()];
            for cell in cells {
                let u = key.uniform_2d(cell.index(&s));
                // The exact point of the square lies inside the cell's stated bounds.
                let p = s.cell_point(cell, u);
                prop_assert!(p.x >= s.sin2_theta_bound(cell.j) && p.x < s.sin2_theta_bound(cell.j + 1));
                prop_assert!(p.y >= cell.k as f32 / n as f32 && p.y < (cell.k + 1) as f32 / n as f32);
                // The direction maps back into the same cell, unless the point is within the
                // inverse warp's rounding (≲ 5e-5 in φ, see warp.rs) of a cell boundary.
                let w = s.sample(cell, u);
                let near_boundary = [
                    p.x - s.sin2_theta_bound(cell.j), s.sin2_theta_bound(cell.j + 1) - p.x,
                    p.y - cell.k as f32 / n as f32, (cell.k + 1) as f32 / n as f32 - p.y,
                ].iter().any(|&d| d < 5e-5);
                if !near_boundary {
                    prop_assert_eq!(s.cell_of(w), cell);
                }
                visits[cell.index(&s) as usize] += 1;
            }
            prop_assert!(visits.iter().all(|&v| v == 1));
        }

        /// u just below 1 must not leak into the next cell.
        #[test]
        fn cell_point_stays_inside(m in 1u32..64, n in 1u32..64, j_frac in 0.0f64..1.0, k_frac in 0.0f64..1.0) {
            let s = HemisphereStrata::new(m, n).unwrap_or_else(|e| panic!("{e}"));
            let cell = Cell { j: ((j_frac * f64::from(m)) as u32).min(m - 1), k: ((k_frac * f64::from(n)) as u32).min(n - 1) };
            let p = s.cell_point(cell, Vec2::splat(1.0f32.next_down_f32()));
            prop_assert!(p.x < s.sin2_theta_bound(cell.j + 1));
            prop_assert!(p.y < (cell.k + 1) as f32 / n as f32);
        }
    }

    /// Pearson's χ² goodness-of-fit test of the cosine sampler against its pdf, binned in
    /// (cos θ, φ) on a 10 × 20 grid of equal-size bins (so that the test does not share the warp's
    /// own coordinates). The expected fraction of bin [c₀, c₁) × [φ₀, φ₁) is
    /// ∫∫ (cos θ/π) d(cos θ) dφ = (c₁² − c₀²)/2 · (φ₁ − φ₀)/π.
    ///
    /// 200 bins give 199 degrees of freedom; 10⁶ samples give at least 10⁶·(0.1²/2)·(2π/20)/π = 500
    /// expected counts in the smallest bin (≫ 5, so the χ² approximation holds). Significance
    /// level α = 10⁻⁴: the critical value from the Wilson–Hilferty approximation,
    /// k·(1 − 2/(9k) + z·√(2/(9k)))³ with z = 3.719 (the standard normal's 1 − 10⁻⁴ quantile), is
    /// 271.4 for k = 199. The draw is deterministic (fixed seed), so the test never flakes: it
    /// fails only if the sampler's distribution is wrong.
    #[test]
    fn cosine_sampler_chi_square() {
        const THETA_BINS: usize = 10;
        const PHI_BINS: usize = 20;
        const N: u32 = 1_000_000;
        let mut counts = vec![0u32; THETA_BINS * PHI_BINS];
        for i in 0..N {
            let w = sample_cosine_hemisphere(SampleKey::new(11, u64::from(i), 0).uniform_2d(0));
            let c = ((w.z * THETA_BINS as f32) as usize).min(THETA_BINS - 1);
            let phi = w.y.atan2(w.x).rem_euclid(TAU);
            let p = ((phi / TAU * PHI_BINS as f32) as usize).min(PHI_BINS - 1);
            counts[c * PHI_BINS + p] += 1;
        }
        let mut chi2 = 0.0f64;
        for c in 0..THETA_BINS {
            let c0 = c as f64 / THETA_BINS as f64;
            let c1 = (c + 1) as f64 / THETA_BINS as f64;
            let frac = (c1 * c1 - c0 * c0) / 2.0 * (std::f64::consts::TAU / PHI_BINS as f64)
                / std::f64::consts::PI;
            for p in 0..PHI_BINS {
                let expected = frac * f64::from(N);
                let d = f64::from(counts[c * PHI_BINS + p]) - expected;
                chi2 += d * d / expected;
            }
        }
        let k = (THETA_BINS * PHI_BINS - 1) as f64;
        let z = 3.719;
        let critical = k * (1.0 - 2.0 / (9.0 * k) + z * (2.0 / (9.0 * k)).sqrt()).powi(3);
        assert!(
            chi2 < critical,
            "χ² = {chi2:.1} ≥ critical {critical:.1} (k = {k})"
        );
        // The pdf agrees with the binned expectation at the bins' centres (sanity of the formula).
        assert!((cosine_hemisphere_pdf(0.5) - 0.5 / std::f32::consts::PI).abs() < 1e-7);
    }
}
