//! The input of every estimator: one hemisphere gather as plain data.
//!
//! Per cell of a [`HemisphereStrata`] (indexed by [`Cell::index`]): the incoming radiance Lⱼₖ
//! seen along the cell's sample direction, and the distance rⱼₖ to what the ray hit (`f32::INFINITY`
//! where it escaped to the sky). Nothing here knows rays or scenes: the caller traced the rays.
//!
//! Also here: the irradiance estimate and the distance statistics that set a record's radius
//! (Ward, Rubinstein & Clear 1988: the harmonic mean distance; Tabellion & Lamorlette 2004
//! and Křivánek et al. 2006: the minimum distance).

use crate::value::GatherValue;
use glam::Vec3;
use irr_sampling::{Cell, HemisphereStrata};

/// Why a gather cannot be used.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum GatherError {
    /// The radiance or distance list does not have one entry per cell.
    #[error("{what} has {got} entries, but the {m}×{n} stratification has {expected} cells")]
    Length {
        /// Which list: "radiance" or "distance".
        what: &'static str,
        /// Its length.
        got: usize,
        /// M·N.
        expected: usize,
        /// M.
        m: u32,
        /// N.
        n: u32,
    },
    /// A radiance value has a NaN or infinite channel.
    #[error("the radiance of cell (j = {j}, k = {k}) is not finite")]
    Radiance {
        /// The cell's index along θ.
        j: u32,
        /// The cell's index along φ.
        k: u32,
    },
    /// A distance is NaN, zero, negative or subnormal. Misses are `f32::INFINITY`; a hit closer
    /// than `f32::MIN_POSITIVE` must be clamped by the caller (its reciprocal would overflow).
    #[error(
        "the distance of cell (j = {j}, k = {k}) is {value}: it must be at least \
         f32::MIN_POSITIVE, or +inf for a miss"
    )]
    Distance {
        /// The cell's index along θ.
        j: u32,
        /// The cell's index along φ.
        k: u32,
        /// The value given.
        value: f32,
    },
    /// A sample direction is not finite, not unit or below the tangent plane.
    #[error(
        "the direction of cell (j = {j}, k = {k}) is not a unit vector above the tangent plane"
    )]
    Direction {
        /// The cell's index along θ.
        j: u32,
        /// The cell's index along φ.
        k: u32,
    },
    /// A sample's cos θ is NaN or outside [0, 1].
    #[error("the cos theta of cell (j = {j}, k = {k}) is {value}: it must lie in [0, 1]")]
    CosTheta {
        /// The cell's index along θ.
        j: u32,
        /// The cell's index along φ.
        k: u32,
        /// The value given.
        value: f32,
    },
}

/// One stratified hemisphere gather: radiance and hit distance per cell, in the cells' order
/// ([`Cell::index`], row-major: j along θ outer, k along φ inner).
///
/// The cells are those of `strata` in the local frame of the gather point (normal = +z), as
/// [`HemisphereStrata::sample`] places them. The estimators use only the cells' bounds, never the
/// sample directions, so the directions need not be stored.
#[derive(Clone, Debug, PartialEq)]
pub struct GatherSamples<V> {
    strata: HemisphereStrata,
    radiance: Vec<V>,
    distance: Vec<f32>,
    /// cos θ of each cell's actual sample direction, when the caller gave them
    /// ([`GatherSamples::with_cos_theta`]); the distance statistics that skip near-horizon hits
    /// use them.
    cos_theta: Option<Vec<f32>>,
    /// Each cell's unit sample direction in the local frame, when the caller gave them
    /// ([`GatherSamples::with_directions`]); the triangle fan places its hit points along them.
    directions: Option<Vec<Vec3>>,
    /// With several samples in some cells ([`GatherSamples::from_cells`]): each cell's sample
    /// count and the sample variance of its values (0 where it has one sample); `None` for one
    /// sample per cell.
    pub(crate) cells: Option<CellSpread<V>>,
}

/// How many samples each cell of a super-sampled gather has and how they spread.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct CellSpread<V> {
    pub(crate) counts: Vec<u32>,
    pub(crate) variance: Vec<V>,
}

impl<V: GatherValue> GatherSamples<V> {
    /// Checks and wraps one gather. `radiance[i]` and `distance[i]` belong to the cell whose
    /// [`Cell::index`] is `i`; a distance is `f32::INFINITY` for a ray that hit nothing.
    pub fn new(
        strata: HemisphereStrata,
        radiance: Vec<V>,
        distance: Vec<f32>,
    ) -> Result<Self, GatherError> {
        let expected = strata.len();
        for (what, got) in [("radiance", radiance.len()), ("distance", distance.len())] {
            if got != expected {
                return Err(GatherError::Length {
                    what,
                    got,
                    expected,
                    m: strata.m(),
                    n: strata.n(),
                });
            }
        }
        for cell in strata.cells() {
            let i = cell.index(&strata) as usize;
            if !radiance[i].is_finite() {
                return Err(GatherError::Radiance {
                    j: cell.j,
                    k: cell.k,
                });
            }
            let r = distance[i];
            // NaN fails both comparisons, so it is rejected too.
            if r.is_nan() || r < f32::MIN_POSITIVE {
                return Err(GatherError::Distance {
                    j: cell.j,
                    k: cell.k,
                    value: r,
                });
            }
        }
        Ok(Self {
            strata,
            radiance,
            distance,
            cos_theta: None,
            directions: None,
            cells: None,
        })
    }

    /// The same gather with cos θ of each cell's sample direction (local frame, by
    /// [`Cell::index`]), for the distance statistics that skip hits near the horizon. Each value
    /// must lie in [0, 1] (a NaN or a value outside is refused: [`GatherError::CosTheta`]).
    pub fn with_cos_theta(self, cos_theta: Vec<f32>) -> Result<Self, GatherError> {
        if cos_theta.len() != self.strata.len() {
            return Err(GatherError::Length {
                what: "cos theta",
                got: cos_theta.len(),
                expected: self.strata.len(),
                m: self.strata.m(),
                n: self.strata.n(),
            });
        }
        if let Some(i) = cos_theta.iter().position(|c| !(0.0..=1.0).contains(c)) {
            let n = self.strata.n() as usize;
            return Err(GatherError::CosTheta {
                j: (i / n) as u32,
                k: (i % n) as u32,
                value: cos_theta[i],
            });
        }
        Ok(Self {
            cos_theta: Some(cos_theta),
            ..self
        })
    }

    /// The same gather with each cell's unit sample direction in the local frame (normal +z, by
    /// [`Cell::index`]), for the triangle fan ([`GatherSamples::fan`]); their cos θ (z) serve the
    /// distance statistics as [`GatherSamples::with_cos_theta`]'s do. A direction must be finite,
    /// unit within 10⁻³ and not below the tangent plane by more than that
    /// ([`GatherError::Direction`]).
    pub fn with_directions(self, directions: Vec<Vec3>) -> Result<Self, GatherError> {
        if directions.len() != self.strata.len() {
            return Err(GatherError::Length {
                what: "directions",
                got: directions.len(),
                expected: self.strata.len(),
                m: self.strata.m(),
                n: self.strata.n(),
            });
        }
        let bad = |w: &Vec3| !(w.is_finite() && (w.length() - 1.0).abs() <= 1e-3 && w.z >= -1e-3);
        if let Some(i) = directions.iter().position(bad) {
            let n = self.strata.n() as usize;
            return Err(GatherError::Direction {
                j: (i / n) as u32,
                k: (i % n) as u32,
            });
        }
        let cos_theta = directions.iter().map(|w| w.z.clamp(0.0, 1.0)).collect();
        Ok(Self {
            cos_theta: Some(cos_theta),
            directions: Some(directions),
            ..self
        })
    }

    /// The sample directions given with [`GatherSamples::with_directions`].
    #[inline]
    pub fn directions(&self) -> Option<&[Vec3]> {
        self.directions.as_deref()
    }

    /// cos θ of the sample of cell `i`: the caller's value if given, else the cell's middle
    /// elevation (sin² θ = (j + ½)/M, the warp's centre).
    #[inline]
    fn sample_cos_theta(&self, i: usize) -> f32 {
        match &self.cos_theta {
            Some(c) => c[i],
            None => {
                let j = (i / self.strata.n() as usize) as f32;
                (1.0 - (j + 0.5) / self.strata.m() as f32).max(0.0).sqrt()
            }
        }
    }

    /// Builds a gather by asking `f` for (radiance, distance) of every cell, in index order.
    pub fn from_fn(
        strata: HemisphereStrata,
        mut f: impl FnMut(Cell) -> (V, f32),
    ) -> Result<Self, GatherError> {
        let (radiance, distance) = strata.cells().map(&mut f).unzip();
        Self::new(strata, radiance, distance)
    }

    /// The stratification.
    #[inline]
    pub fn strata(&self) -> &HemisphereStrata {
        &self.strata
    }

    /// Radiance per cell, by [`Cell::index`].
    #[inline]
    pub fn radiance(&self) -> &[V] {
        &self.radiance
    }

    /// Hit distance per cell, by [`Cell::index`] (`f32::INFINITY` for a miss).
    #[inline]
    pub fn distance(&self) -> &[f32] {
        &self.distance
    }

    /// The irradiance estimate E = (π/(MN)) Σⱼₖ Lⱼₖ (Ward & Heckbert 1992, with cells of
    /// equal projected solid angle; Křivánek & Gautron 2009, ch. 2).
    ///
    /// Summed row by row, so the rounding error grows with M + N rather than with M·N.
    pub fn irradiance(&self) -> V {
        let n = self.strata.n() as usize;
        let mut sum = V::default();
        for row in self.radiance.chunks_exact(n) {
            let row_sum = row.iter().fold(V::default(), |acc, &l| acc + l);
            sum = sum + row_sum;
        }
        sum * self.strata.cell_weight()
    }

    /// The harmonic mean distance to the hits, R = MN / Σⱼₖ 1/rⱼₖ (Ward, Rubinstein & Clear 1988,
    /// the "harmonic mean distance" Rᵢ of the record's split-sphere bound): a miss counts
    /// as infinitely far (1/r = 0). `f32::INFINITY` when every ray missed.
    pub fn harmonic_mean_distance(&self) -> f32 {
        // Accumulate in f64: up to 2²⁰ terms of very different sizes.
        let sum: f64 = self.distance.iter().map(|&r| 1.0 / f64::from(r)).sum();
        if sum > 0.0 {
            (self.distance.len() as f64 / sum) as f32
        } else {
            f32::INFINITY
        }
    }

    /// The smallest hit distance (`f32::INFINITY` when every ray missed): the bound that
    /// Tabellion & Lamorlette (2004) and Křivánek et al. (2006) use in place of the harmonic mean.
    pub fn min_distance(&self) -> f32 {
        self.distance.iter().copied().fold(f32::INFINITY, f32::min)
    }

    /// The smallest distance among the hits whose sample direction has cos θ > `min_cos_theta`
    /// (`f32::INFINITY` if none). Hits grazing the horizon are often the surface's own
    /// neighbourhood (a wall meeting the floor) and would shrink every radius near a corner;
    /// ignoring rays within ~10° of the horizon (`min_cos_theta` = cos 80° ≈ 0.174, Mitsuba 0.6's
    /// 0.173) is the usual remedy. The test is per sample direction ([`GatherSamples::with_cos_theta`];
    /// the cell's middle elevation when none were given), so it does not depend on M: a whole
    /// row's cells are not dropped because the row's lower edge dips under the cut.
    pub fn min_distance_above(&self, min_cos_theta: f32) -> f32 {
        let mut best = f32::INFINITY;
        for (i, &r) in self.distance.iter().enumerate() {
            if self.sample_cos_theta(i) > min_cos_theta {
                best = best.min(r);
            }
        }
        best
    }

    /// The harmonic mean distance over the samples whose direction has cos θ > `min_cos_theta`
    /// (as [`GatherSamples::min_distance_above`] selects them), misses counting as infinitely
    /// far: R = count / Σ 1/rⱼₖ over those samples. `f32::INFINITY` when none of them hit.
    /// Radiance's `ambcomp.c` and Mitsuba 0.6 skip the same near-horizon hits when they size a
    /// record.
    pub fn harmonic_mean_distance_above(&self, min_cos_theta: f32) -> f32 {
        let mut count = 0usize;
        let mut sum = 0.0f64;
        for (i, &r) in self.distance.iter().enumerate() {
            if self.sample_cos_theta(i) > min_cos_theta {
                count += 1;
                sum += 1.0 / f64::from(r);
            }
        }
        if sum > 0.0 {
            (count as f64 / sum) as f32
        } else {
            f32::INFINITY
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use proptest::prelude::*;

    fn strata(m: u32, n: u32) -> HemisphereStrata {
        HemisphereStrata::new(m, n).unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn rejects_bad_input_with_typed_errors() {
        let s = strata(2, 3);
        let ok_l = vec![1.0f32; 6];
        let ok_r = vec![1.0f32; 6];
        assert!(matches!(
            GatherSamples::new(s, vec![1.0f32; 5], ok_r.clone()),
            Err(GatherError::Length {
                what: "radiance",
                got: 5,
                expected: 6,
                ..
            })
        ));
        assert!(matches!(
            GatherSamples::new(s, ok_l.clone(), vec![1.0; 7]),
            Err(GatherError::Length {
                what: "distance",
                got: 7,
                ..
            })
        ));
        for bad in [0.0, -1.0, f32::NAN, 1e-40, f32::NEG_INFINITY] {
            let mut r = ok_r.clone();
            r[4] = bad;
            let e = GatherSamples::new(s, ok_l.clone(), r).err();
            assert!(
                matches!(e, Some(GatherError::Distance { j: 1, k: 1, .. })),
                "{bad}: {e:?}"
            );
        }
        let mut l = ok_l.clone();
        l[2] = f32::INFINITY;
        assert_eq!(
            GatherSamples::new(s, l, ok_r.clone()).err(),
            Some(GatherError::Radiance { j: 0, k: 2 })
        );
        let mut l = vec![Vec3::ONE; 6];
        l[3].y = f32::NAN;
        assert_eq!(
            GatherSamples::new(s, l, ok_r.clone()).err(),
            Some(GatherError::Radiance { j: 1, k: 0 })
        );
        // Misses are allowed, and the messages name the cell.
        let mut r = ok_r;
        r[0] = f32::INFINITY;
        assert!(GatherSamples::new(s, ok_l, r).is_ok());
        let msg = GatherError::Distance {
            j: 1,
            k: 2,
            value: 0.0,
        }
        .to_string();
        assert!(msg.contains("j = 1, k = 2"), "{msg}");
    }

    #[test]
    fn distances_harmonic_mean_and_minimum() {
        let s = strata(2, 2);
        // Rows: j = 0 near the pole, j = 1 at the horizon (cos θ from √½ down to 0).
        let g = GatherSamples::new(s, vec![0.0f32; 4], vec![1.0, 2.0, f32::INFINITY, 0.5])
            .unwrap_or_else(|e| panic!("{e}"));
        // 4 / (1 + ½ + 0 + 2) = 8/7: exact in binary to one rounding.
        assert!((g.harmonic_mean_distance() - 8.0 / 7.0).abs() <= f32::EPSILON);
        assert_eq!(g.min_distance(), 0.5);
        // Without sample directions, the cells' middle elevations: row 0 at cos θ = √¾ ≈ 0.866,
        // row 1 at √¼ = 0.5.
        assert_eq!(g.min_distance_above(0.7), 1.0);
        assert_eq!(g.min_distance_above(0.0), 0.5);
        assert_eq!(g.min_distance_above(0.9), f32::INFINITY);
        let sky = GatherSamples::new(s, vec![1.0f32; 4], vec![f32::INFINITY; 4])
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(sky.harmonic_mean_distance(), f32::INFINITY);
        assert_eq!(sky.min_distance(), f32::INFINITY);
    }

    /// The near-horizon cut is per sample direction, independent of M. At
    /// M = 8 the last row spans θ from 69.3° to 90° (cos 0.354 … 0): the old per-row test
    /// dropped the whole row, so it ignored hits up to 20.7° above the horizon; a hit at
    /// 15° above the horizon (cos θ = 0.259 > 0.174) must count, one at 5° must not, for every M.
    #[test]
    fn horizon_cut_is_per_sample_and_independent_of_m() {
        let cut = 80f32.to_radians().cos();
        for m in [2u32, 4, 8, 16, 64] {
            let s = strata(m, 4);
            let last = ((m - 1) * 4) as usize;
            for (elevation, counts) in [(15f32, true), (5f32, false)] {
                let cos = (90.0 - elevation).to_radians().cos();
                // Every sample at the pole, far; one sample of the last row low, near.
                let mut cos_theta = vec![1.0f32; s.len()];
                cos_theta[last] = cos;
                let mut distance = vec![100.0f32; s.len()];
                distance[last] = 0.5;
                let g = GatherSamples::new(s, vec![0.0f32; s.len()], distance)
                    .and_then(|g| g.with_cos_theta(cos_theta))
                    .unwrap_or_else(|e| panic!("{e}"));
                let expected = if counts { 0.5 } else { 100.0 };
                assert_eq!(g.min_distance_above(cut), expected, "M = {m}, {elevation}°");
                let h = g.harmonic_mean_distance_above(cut);
                assert_eq!(h < 100.0, counts, "M = {m}, {elevation}°: {h}");
            }
        }
        let s = strata(2, 2);
        let g =
            GatherSamples::new(s, vec![0.0f32; 4], vec![1.0; 4]).unwrap_or_else(|e| panic!("{e}"));
        assert!(matches!(
            g.clone().with_cos_theta(vec![0.5; 3]),
            Err(GatherError::Length { .. })
        ));
        assert!(matches!(
            g.with_cos_theta(vec![0.5, 1.5, 0.5, 0.5]),
            Err(GatherError::CosTheta { j: 0, k: 1, .. })
        ));
    }

    proptest! {
        #![proptest_config(crate::analytic::fixed_config(64, 0x5a3f))]

        /// A uniform sky of radiance L gives E = πL: the MN cells of weight π/(MN) sum to π.
        /// Each cell's weight π/(MN) and each of the ≤ M + N additions of the row-wise sum
        /// round by ≤ ε/2 relative, so |E − πL| ≤ (M + N + 2)·ε·πL.
        #[test]
        fn uniform_sky_irradiance_is_pi_l(m in 1u32..40, n in 1u32..120, l in 0.0f32..1e6) {
            let s = strata(m, n);
            let g = GatherSamples::from_fn(s, |_| (l, f32::INFINITY)).unwrap_or_else(|e| panic!("{e}"));
            let e = g.irradiance();
            let pi_l = std::f32::consts::PI * l;
            let tol = (m + n + 2) as f32 * f32::EPSILON * pi_l;
            prop_assert!((e - pi_l).abs() <= tol, "E = {e}, πL = {pi_l}");
        }

        /// The harmonic mean lies between the smallest and the largest distance (when all hit).
        #[test]
        fn harmonic_mean_is_bounded(r in proptest::collection::vec(1e-3f32..1e3, 6)) {
            let s = strata(2, 3);
            let g = GatherSamples::new(s, vec![0.0f32; 6], r.clone()).unwrap_or_else(|e| panic!("{e}"));
            let h = g.harmonic_mean_distance();
            let lo = r.iter().copied().fold(f32::INFINITY, f32::min);
            let hi = r.iter().copied().fold(0.0, f32::max);
            // One f64 → f32 rounding: half an ulp either side.
            prop_assert!(h >= lo * (1.0 - f32::EPSILON) && h <= hi * (1.0 + f32::EPSILON));
            prop_assert_eq!(g.min_distance(), lo);
        }
    }
}
