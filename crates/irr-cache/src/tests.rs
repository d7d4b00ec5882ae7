//! Property tests of the cache as a whole: its invariants, each with the rounding
//! bound it is checked against and that bound's derivation.
//!
//! Notation: u₃₂ = 2⁻²⁴ and u₆₄ = 2⁻⁵³ are the unit roundoffs of `f32` and `f64`.

use crate::io::{read_records, write_records};
use crate::record::unit_query_normal;
use crate::*;
use glam::Vec3;
use proptest::prelude::*;

const U32: f64 = 1.0 / (1u64 << 24) as f64;
const U64: f64 = 1.0 / (1u64 << 53) as f64;

fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases,
        ..ProptestConfig::default()
    }
}

fn v3(r: std::ops::Range<f32>) -> impl Strategy<Value = Vec3> {
    (r.clone(), r.clone(), r).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

/// A unit vector.
fn unit() -> impl Strategy<Value = Vec3> {
    v3(-1.0..1.0)
        .prop_filter("non-degenerate", |v| v.length() > 1e-2)
        .prop_map(Vec3::normalize)
}

/// A unit vector within about `max_degrees` of `axis`.
fn near(axis: Vec3, max_degrees: f32) -> impl Strategy<Value = Vec3> {
    let t = max_degrees.to_radians().tan();
    v3(-1.0..1.0).prop_map(move |d| (axis + (d - axis * d.dot(axis)) * t).normalize())
}

/// A value with channels in [0, 10).
fn rgb() -> impl Strategy<Value = Rgb> {
    (0.0f32..10.0, 0.0f32..10.0, 0.0f32..10.0).prop_map(|(r, g, b)| Rgb::new(r, g, b))
}

fn rgb_signed(m: f32) -> impl Strategy<Value = Rgb> {
    (-m..m, -m..m, -m..m).prop_map(|(r, g, b)| Rgb::new(r, g, b))
}

fn tl() -> TabellionLamorlette {
    TabellionLamorlette::new(1.0).unwrap_or_else(|e| panic!("{e}"))
}

fn ward(a: f32) -> Ward {
    Ward::new(a).unwrap_or_else(|e| panic!("{e}"))
}

fn cache_of<M: ErrorMetric>(metric: M, records: &[Record<Rgb>]) -> IrradianceCache<Rgb, M> {
    let mut c = IrradianceCache::new(metric);
    c.extend(records.iter().copied())
        .unwrap_or_else(|e| panic!("{e}"));
    c
}

/// The records with a positive weight at (p, n), found by scanning every record with the same
/// tests the cache applies (no octree).
fn brute_weighted<V: CacheValue, M: ErrorMetric>(
    cache: &IrradianceCache<V, M>,
    p: Vec3,
    n: Vec3,
) -> Vec<(u32, f64)> {
    let nd = unit_query_normal(n).unwrap_or_else(|| panic!("bad normal {n}"));
    let m = cache.metric();
    let mut out = Vec::new();
    for (i, r) in cache.records().iter().enumerate() {
        if !within_influence(r.position, m.influence_radius(r.radius), p) {
            continue;
        }
        let w = m.weight(&Candidate::new(
            p.as_dvec3(),
            nd,
            r.position,
            r.normal,
            r.radius,
        ));
        if w > 0.0 {
            out.push((i as u32, w));
        }
    }
    out
}

fn brute_in_range<V: CacheValue, M: ErrorMetric>(
    cache: &IrradianceCache<V, M>,
    p: Vec3,
) -> Vec<u32> {
    let m = cache.metric();
    (0..cache.len() as u32)
        .filter(|&i| {
            let r = &cache.records()[i as usize];
            within_influence(r.position, m.influence_radius(r.radius), p)
        })
        .collect()
}

fn tree_in_range<V: CacheValue, M: ErrorMetric>(
    cache: &IrradianceCache<V, M>,
    p: Vec3,
) -> Vec<u32> {
    let mut v = Vec::new();
    cache.for_each_in_range(p, |i, _| v.push(i));
    v.sort_unstable();
    v
}

fn tree_weighted<V: CacheValue, M: ErrorMetric>(
    cache: &IrradianceCache<V, M>,
    p: Vec3,
    n: Vec3,
) -> Vec<(u32, f64)> {
    let mut v = Vec::new();
    cache.for_each_weighted(p, n, |i, _, w| v.push((i, w)));
    v.sort_by_key(|&(i, _)| i);
    v
}

/// A bound on |Ẽᵢ| per channel for every record weighted at (p, n): |Eᵢ| + Σₖ |(nᵢ×n)ₖ|·|∇ᵣEᵢ|ₖ +
/// |(p − pᵢ)ₖ|·|∇ₜEᵢ|ₖ, computed in f64 and widened by 1 % so that its own rounding cannot make
/// it too small.
fn extrapolation_scale(cache: &IrradianceCache<Rgb, impl ErrorMetric>, p: Vec3, n: Vec3) -> f64 {
    let nd = unit_query_normal(n).unwrap_or_else(|| panic!("bad normal {n}"));
    let mut s: f64 = 0.0;
    cache.for_each_weighted(p, n, |_, r, _| {
        let turn = r.normal.as_dvec3().cross(nd);
        let step = p.as_dvec3() - r.position.as_dvec3();
        for c in 0..3 {
            let mut v = f64::from(r.value.0[c]).abs();
            for k in 0..3 {
                v += turn[k].abs() * f64::from(r.rotation_gradient[k].0[c]).abs()
                    + step[k].abs() * f64::from(r.translation_gradient[k].0[c]).abs();
            }
            s = s.max(v);
        }
    });
    s * 1.01
}

// ---------------------------------------------------------------------------------------------
// A record's own value.

proptest! {
    #![proptest_config(config(128))]

    /// At its own position and normal, a lone record gives exactly its value, whatever its
    /// gradients: p − pᵢ = 0 and nᵢ × n = 0 exactly (the query keeps a unit normal's bits), so
    /// Ẽ = E in f64; the mean is (w·E)/w with two f64 roundings, E·(1 + δ), |δ| ≤ 2u₆₄, which
    /// rounds back to the f32 E exactly (E's neighbours are ≥ u₃₂·|E| away, and 2u₆₄ ≪ u₃₂).
    #[test]
    fn own_position_returns_own_value(
        p in v3(-1e4..1e4),
        scale in -4.0f32..4.0,
        n in unit(),
        radius_exp in -4.0f32..4.0,
        e in rgb(),
        tg in prop::array::uniform3(rgb_signed(100.0)),
        rg in prop::array::uniform3(rgb_signed(100.0)),
    ) {
        let p = p * 10f32.powf(scale);
        let radius = 10f32.powf(radius_exp);
        let record = Record::new(p, n, radius, e).with_gradients(tg, rg);
        let stored = record.validated().unwrap_or_else(|e| panic!("{e}"));
        for hit in [
            cache_of(tl(), &[record]).interpolate(stored.position, stored.normal),
            cache_of(ward(0.2), &[record]).interpolate(stored.position, stored.normal),
        ] {
            let hit = hit.unwrap_or_else(|| panic!("own record not found"));
            prop_assert_eq!(hit.value, e);
            prop_assert_eq!(hit.count, 1);
        }
    }

    /// With zero gradients the result is a weighted mean, so it lies in each channel's
    /// [min, max] over the records used, exactly: the f64 mean is m·(1 + δ) with m in [lo, hi]
    /// and |δ| ≤ (k + 2)u₆₄ (k additions, a division, exact products of f32 × f64 … each one
    /// rounding), far below the half-ulp u₃₂ that would be needed to round past lo or hi.
    #[test]
    fn zero_gradient_result_is_a_weighted_mean(
        records in prop::collection::vec((v3(-1.0..1.0), near(Vec3::Z, 12.0), 0.5f32..4.0, rgb()), 1..40),
        q in v3(-0.5..0.5),
        qn in near(Vec3::Z, 5.0),
        use_ward in any::<bool>(),
    ) {
        // The first record sits at the query, so every case interpolates.
        let records: Vec<_> = records.into_iter()
            .enumerate()
            .map(|(i, (p, n, r, e))| {
                let (p, n) = if i == 0 { (q, qn) } else { (p * Vec3::new(1.0, 1.0, 0.05), n) };
                Record::new(p, n, r, e)
            })
            .collect();
        let check = |hit: Option<Interpolation<Rgb>>, used: Vec<(u32, f64)>| -> Result<(), TestCaseError> {
            let Some(hit) = hit else {
                return Err(TestCaseError::fail("the record at the query was not used"));
            };
            prop_assert_eq!(hit.count as usize, used.len());
            for c in 0..3 {
                let vals = used.iter().map(|&(i, _)| records[i as usize].value.0[c]);
                let lo = vals.clone().fold(f32::INFINITY, f32::min);
                let hi = vals.fold(f32::NEG_INFINITY, f32::max);
                prop_assert!(lo <= hit.value.0[c] && hit.value.0[c] <= hi,
                    "channel {c}: {} not in [{lo}, {hi}]", hit.value.0[c]);
            }
            Ok(())
        };
        if use_ward {
            let cache = cache_of(ward(0.3), &records);
            check(cache.interpolate(q, qn), brute_weighted(&cache, q, qn))?;
        } else {
            let cache = cache_of(tl(), &records);
            check(cache.interpolate(q, qn), brute_weighted(&cache, q, qn))?;
        }
    }

    /// A constant field is reproduced exactly, whatever the placement, radii and normals: every
    /// Ẽᵢ = c, so the f64 mean is c·(1 + δ), |δ| ≤ (k + 2)u₆₄, and rounds to the f32 c exactly
    /// (as above: (k + 2)u₆₄ < u₃₂ for k < 2²⁸). The bound is zero.
    #[test]
    fn constant_field_is_exact(
        records in prop::collection::vec((v3(-1.0..1.0), near(Vec3::Z, 30.0), -3.0f32..1.0), 1..60),
        q in v3(-1.0..1.0),
        qn in near(Vec3::Z, 20.0),
        c in rgb(),
        kappa in 0.25f32..2.0,
    ) {
        // Records anywhere around the query (most of them in use: radii up to 10 over a span
        // of 2), and one within a thousandth of its radius of it so that every case
        // interpolates.
        let mut records: Vec<_> = records.into_iter()
            .map(|(p, n, r, )| Record::new(p, n, 10f32.powf(r), c))
            .collect();
        records.push(Record::new(q + Vec3::new(1e-3, 0.0, 0.0), qn, 1.0, c));
        let metric = TabellionLamorlette::new(kappa).unwrap_or_else(|e| panic!("{e}"));
        let hit = cache_of(metric, &records).interpolate(q, qn);
        prop_assert_eq!(hit.map(|h| h.value), Some(c));
        let hit = cache_of(ward(0.5), &records).interpolate(q, qn);
        prop_assert_eq!(hit.map(|h| h.value), Some(c));
    }

    /// A field linear in p, E(p) = a + G·p per channel, is reproduced by records that carry its
    /// translation gradient G, with any normals (the rotation gradient is zero).
    ///
    /// Bound: record i stores Eᵢ = fl₃₂(E(pᵢ)), off by ≤ u₃₂|E(pᵢ)|; Ẽᵢ = Eᵢ + Σₖ(p − pᵢ)ₖGₖ in f64
    /// has the exact differences (p − pᵢ) and 6 roundings of ≤ u₆₄ each relative to at most S (the
    /// largest |Eᵢ| + Σ|(p − pᵢ)ₖ||Gₖ|); the mean adds (k + 2)u₆₄·S, the final rounding u₃₂|E(p)|.
    /// Since a weighted mean of errors is bounded by their maximum:
    /// |E − E(p)| ≤ u₃₂·(maxᵢ|E(pᵢ)| + |E(p)|) + (k + 8)u₆₄·S.
    #[test]
    fn linear_field_is_reproduced_by_its_gradient(
        records in prop::collection::vec((v3(-1.0..1.0), near(Vec3::Z, 40.0), 0.2f32..3.0), 1..40),
        q in v3(-1.0..1.0),
        qn in near(Vec3::Z, 30.0),
        g in prop::array::uniform3(rgb_signed(5.0)),
        scale_exp in -3i32..4,
    ) {
        // Scale the scene by a power of two so the test covers small and large scenes exactly.
        let s = 2f32.powi(scale_exp * 4);
        let inv = 1.0 / s;
        // a ≥ 1 + Σ|G|·|p|max keeps the field positive (no clamping) over the scaled region.
        let a: [f64; 3] = std::array::from_fn(|c| {
            1.0 + 2.0 * g.iter().map(|gk| f64::from(gk.0[c].abs())).sum::<f64>()
        });
        // The gradient of E(p) = a + G·(p/s) is G/s, exact for a power-of-two s.
        let grad = g.map(|gk| Rgb::from_fn(|c| gk.0[c] * inv));
        let field = |p: Vec3| -> [f64; 3] {
            std::array::from_fn(|c| a[c] + (0..3).map(|k| f64::from(grad[k].0[c]) * f64::from(p[k])).sum::<f64>())
        };
        let records: Vec<_> = records.into_iter()
            .map(|(p, n, r)| {
                let p = p * s;
                let e = field(p);
                Record::new(p, n, r * s, Rgb::from_fn(|c| e[c] as f32))
                    .with_gradients(grad, [Rgb::zero(); 3])
            })
            .collect();
        let q = q * s;
        // One more record near the query so that every case interpolates.
        let mut records = records;
        let near_q = q + Vec3::new(0.01, -0.02, 0.0) * s;
        let e = field(near_q);
        records.push(Record::new(near_q, qn, s, Rgb::from_fn(|c| e[c] as f32))
            .with_gradients(grad, [Rgb::zero(); 3]));
        let cache = cache_of(tl(), &records);
        let hit = cache.interpolate(q, qn);
        prop_assert!(hit.is_some());
        if let Some(hit) = hit {
            let exact = field(q);
            let scale = extrapolation_scale(&cache, q, qn);
            let k = f64::from(hit.count);
            for (c, &ex) in exact.iter().enumerate() {
                let max_ei = records.iter().map(|r| f64::from(r.value.0[c])).fold(0.0, f64::max)
                    * (1.0 + 2.0 * U32);
                let bound = U32 * (max_ei + ex.abs()) + (k + 8.0) * U64 * scale;
                let err = (f64::from(hit.value.0[c]) - ex).abs();
                prop_assert!(err <= bound, "channel {c}: error {err:e} > bound {bound:e}");
            }
        }
    }

    /// The result does not depend on insertion order. The two caches weigh the same records with
    /// the same weights (each weight is a function of one record and the query), so only the order
    /// of the f64 sums differs: each mean is the exact one up to (k + 2)u₆₄·S (S bounds |Ẽᵢ|), then
    /// rounded to f32 (half an ulp each). So |v₁ − v₂| ≤ 2(k + 2)u₆₄·S + ulp₃₂(max|vᵢ|); and the
    /// total weights differ by at most 2k·u₆₄·Σw.
    #[test]
    fn insertion_order_does_not_matter(
        records in prop::collection::vec(
            (v3(-1.0..1.0), near(Vec3::Z, 15.0), 0.5f32..3.0, rgb(),
             prop::array::uniform3(rgb_signed(3.0)), prop::array::uniform3(rgb_signed(3.0))),
            2..50),
        perm_seed in any::<u64>(),
        queries in prop::collection::vec((v3(-1.0..1.0), near(Vec3::Z, 10.0)), 1..8),
    ) {
        let records: Vec<_> = records.into_iter()
            .map(|(p, n, r, e, tg, rg)| Record::new(p, n, r, e).with_gradients(tg, rg))
            .collect();
        // Random queries, and one at each of the first records (hits for sure).
        let mut queries = queries;
        queries.extend(records.iter().take(4).map(|r| (r.position, r.normal)));
        // A deterministic permutation (Fisher–Yates driven by a SplitMix64 stream).
        let mut shuffled = records.clone();
        let mut state = perm_seed;
        for i in (1..shuffled.len()).rev() {
            state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^= z >> 31;
            shuffled.swap(i, (z % (i as u64 + 1)) as usize);
        }
        let a = cache_of(tl(), &records);
        let b = cache_of(tl(), &shuffled);
        for (q, qn) in queries {
            match (a.interpolate(q, qn), b.interpolate(q, qn)) {
                (None, None) => {}
                (Some(x), Some(y)) => {
                    prop_assert_eq!(x.count, y.count);
                    let k = f64::from(x.count);
                    let s = extrapolation_scale(&a, q, qn);
                    prop_assert!((x.total_weight - y.total_weight).abs() <= 2.0 * k * U64 * x.total_weight);
                    for c in 0..3 {
                        let (u, v) = (x.value.0[c], y.value.0[c]);
                        let ulp = f64::from(u.abs().max(v.abs())) * 2.0 * U32;
                        let bound = 2.0 * (k + 2.0) * U64 * s + ulp;
                        prop_assert!(f64::from((u - v).abs()) <= bound,
                            "channel {c}: {u} vs {v}, bound {bound:e}");
                    }
                }
                (x, y) => prop_assert!(false, "one order hits, the other misses: {x:?} {y:?}"),
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The octree against a brute-force scan.

/// In range by the octree, in range by brute force, weighted by the octree, weighted by brute
/// force.
type Sets = (Vec<u32>, Vec<u32>, Vec<(u32, f64)>, Vec<(u32, f64)>);

proptest! {
    #![proptest_config(config(64))]

    /// For random records with radii over six orders of magnitude (10⁻³ to 10³) and positions
    /// clustered at several scales, and queries near records and anywhere, the octree visits
    /// exactly the records whose sphere of influence contains the query (each once), and the
    /// weighted visit returns exactly the records of positive weight, with the same weights. No
    /// tolerance: both sides apply the same f64 tests to the same f32 data.
    #[test]
    fn octree_matches_brute_force(
        records in prop::collection::vec(
            (v3(-1.0..1.0), -3.0f32..3.0, unit(), -3.0f32..3.0), 1..300),
        near_queries in prop::collection::vec((0usize..300, v3(-1.0..1.0), unit()), 1..40),
        far_queries in prop::collection::vec((v3(-1.0..1.0), -3.0f32..4.0, unit()), 1..20),
        use_ward in any::<bool>(),
    ) {
        let records: Vec<_> = records.into_iter()
            .map(|(p, pos_exp, n, r_exp)| Record::new(p * 10f32.powf(pos_exp), n, 10f32.powf(r_exp), Rgb::splat(1.0)))
            .collect();
        // Queries within about one radius of a record, and anywhere over the span of positions.
        let mut queries: Vec<(Vec3, Vec3)> = near_queries.into_iter()
            .map(|(i, d, n)| {
                let r = &records[i % records.len()];
                (r.position + d * r.radius * 0.7, n)
            })
            .collect();
        queries.extend(far_queries.into_iter().map(|(p, e, n)| (p * 10f32.powf(e), n)));
        let check = |cache: &dyn Fn(Vec3, Vec3) -> Sets| -> Result<(), TestCaseError> {
            for &(q, n) in &queries {
                let (tree, brute, tw, bw) = cache(q, n);
                prop_assert_eq!(&tree, &brute, "in range at {}", q);
                prop_assert_eq!(&tw, &bw, "weighted at {}", q);
                prop_assert!(tw.iter().all(|&(_, w)| w > 0.0 && w.is_finite()));
            }
            Ok(())
        };
        if use_ward {
            let c = cache_of(ward(0.4), &records);
            let mut raw = Vec::new();
            check(&|q, n| {
                (tree_in_range(&c, q), brute_in_range(&c, q), tree_weighted(&c, q, n), brute_weighted(&c, q, n))
            })?;
            // Each record at most once per query.
            for &(q, _) in &queries {
                raw.clear();
                c.for_each_in_range(q, |i, _| raw.push(i));
                let mut dedup = raw.clone();
                dedup.sort_unstable();
                dedup.dedup();
                prop_assert_eq!(raw.len(), dedup.len());
            }
        } else {
            let c = cache_of(tl(), &records);
            check(&|q, n| {
                (tree_in_range(&c, q), brute_in_range(&c, q), tree_weighted(&c, q, n), brute_weighted(&c, q, n))
            })?;
        }
    }

    /// Neighbour clamping keeps the octree exact: after radii are lowered and records refiled,
    /// the range query still equals the brute-force scan. And each insertion obeys both halves
    /// of the clamp: the new radius r ≤ Rⱼ + dⱼ for every record j, and every record within r of
    /// the new one ends with Rⱼ ≤ r + dⱼ.
    #[test]
    fn neighbour_clamping_keeps_the_octree_exact(
        records in prop::collection::vec((v3(-1.0..1.0), unit(), -2.0f32..0.5), 1..120),
        queries in prop::collection::vec(v3(-1.2..1.2), 1..30),
    ) {
        let mut cache = IrradianceCache::<Rgb, _>::new(tl());
        for (p, n, r) in records {
            let r = cache.neighbour_clamped_radius(p, 10f32.powf(r));
            // Each clamp Rⱼ + d is computed in f64 and rounded to f32 once: u₃₂ relative.
            let slack = 1.0 + 2.0 * U32;
            for other in cache.records() {
                let d = (p.as_dvec3() - other.position.as_dvec3()).length();
                prop_assert!(f64::from(r) <= (f64::from(other.radius) + d) * slack);
            }
            cache.clamp_neighbours(p, r);
            // Every record, near or far (not only those within r).
            for other in cache.records() {
                let d = (p.as_dvec3() - other.position.as_dvec3()).length();
                prop_assert!(f64::from(other.radius) <= (f64::from(r) + d) * slack);
                prop_assert!(f64::from(other.unclamped_radius) <= (f64::from(r) + d) * slack);
            }
            cache.insert(Record::new(p, n, r, Rgb::splat(1.0))).unwrap_or_else(|e| panic!("{e}"));
        }
        for q in queries {
            prop_assert_eq!(tree_in_range(&cache, q), brute_in_range(&cache, q));
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Finite weights.

proptest! {
    #![proptest_config(config(256))]

    /// Weights are finite and ≥ 0 for coincident points, opposite normals, the smallest radius a
    /// record may have, and subnormal distances.
    #[test]
    fn weights_are_finite(
        p in v3(-1.0..1.0),
        exp in -160i32..30,
        tiny in v3(-1.0..1.0),
        n in unit(),
        m in unit(),
        flip in any::<bool>(),
        r_exp in -37.0f32..37.0,
        coincide in any::<bool>(),
    ) {
        // From zero (2⁻¹⁶⁰ underflows) through subnormal coordinates to 2³⁰.
        let p = p * 2f32.powi(exp);
        // A subnormal offset (|x| < 2⁻¹²⁶) or none at all.
        let q = if coincide { p } else { p + tiny * 1e-39 };
        let rn = if flip { -n } else { m };
        for radius in [f32::MIN_POSITIVE, 10f32.powf(r_exp), f32::MAX] {
            let c = Candidate::new(q.as_dvec3(), n.as_dvec3(), p, rn, radius);
            for w in [tl().weight(&c), ward(0.3).weight(&c), ward(1e30).weight(&c),
                      TabellionLamorlette::new(1e-30).unwrap_or_else(|e| panic!("{e}")).weight(&c)] {
                prop_assert!(w.is_finite() && w >= 0.0, "weight {w} for {c:?}");
            }
        }
    }

    /// The metrics' weights are positive only inside their influence radius, so the octree,
    /// filing records by that radius, cannot miss a usable record.
    #[test]
    fn positive_weight_implies_within_influence(
        d in v3(-1.0..1.0),
        scale in -3.0f32..1.0,
        n in near(Vec3::Z, 15.0),
        radius in 0.1f32..10.0,
        kappa in 0.1f32..3.0,
        a in 0.05f32..1.5,
    ) {
        let q = d * 10f32.powf(scale);
        let c = Candidate::new(q.as_dvec3(), n.as_dvec3(), Vec3::ZERO, Vec3::Z, radius);
        let t = TabellionLamorlette::new(kappa).unwrap_or_else(|e| panic!("{e}"));
        if t.weight(&c) > 0.0 {
            prop_assert!(within_influence(Vec3::ZERO, t.influence_radius(radius), q));
        }
        let w = ward(a);
        if w.weight(&c) > 0.0 {
            prop_assert!(within_influence(Vec3::ZERO, w.influence_radius(radius), q));
        }
    }
}

#[test]
fn zero_and_bad_radii_are_rejected_at_insertion() {
    let mut cache = IrradianceCache::<Rgb, _>::new(tl());
    for r in [0.0, -0.0, -1.0, f32::NAN, f32::INFINITY, 1e-45] {
        let e = cache.insert(Record::new(Vec3::ZERO, Vec3::Z, r, Rgb::splat(1.0)));
        assert!(
            matches!(e, Err(InsertError::Radius(_))),
            "radius {r}: {e:?}"
        );
    }
    assert!(cache.is_empty());
    // A finite radius whose influence is not finite (R/(2κ) overflows f32) is refused too.
    let loose = TabellionLamorlette::new(1e-3).unwrap_or_else(|e| panic!("{e}"));
    let mut cache = IrradianceCache::<Rgb, _>::new(loose);
    let e = cache.insert(Record::new(Vec3::ZERO, Vec3::Z, f32::MAX, Rgb::splat(1.0)));
    assert!(matches!(e, Err(InsertError::Influence(_))), "{e:?}");
}

#[test]
fn extend_is_all_or_nothing() {
    let mut cache = IrradianceCache::<Rgb, _>::new(tl());
    let good = Record::new(Vec3::ZERO, Vec3::Z, 1.0, Rgb::splat(1.0));
    let bad = Record::new(Vec3::ZERO, Vec3::Z, 1.0, Rgb::new(1.0, f32::NAN, 0.0));
    assert_eq!(
        cache.extend([good, good, bad, good]),
        Err(BatchError {
            index: 2,
            source: InsertError::Value
        })
    );
    assert!(cache.is_empty());
    assert!(cache.interpolate(Vec3::ZERO, Vec3::Z).is_none());
    assert_eq!(cache.extend([good, good]), Ok(0..2));
    assert_eq!(cache.extend([good]), Ok(2..3));
    assert_eq!(
        cache.interpolate(Vec3::ZERO, Vec3::Z).map(|h| h.count),
        Some(3)
    );
}

#[test]
fn bad_queries_miss_without_panicking() {
    let cache = cache_of(
        tl(),
        &[Record::new(Vec3::ZERO, Vec3::Z, 1.0, Rgb::splat(1.0))],
    );
    for (p, n) in [
        (Vec3::NAN, Vec3::Z),
        (Vec3::ZERO, Vec3::NAN),
        (Vec3::ZERO, Vec3::ZERO),
        (Vec3::INFINITY, Vec3::Z),
    ] {
        assert!(cache.interpolate(p, n).is_none(), "{p} {n}");
    }
    // A query normal that is not unit is normalised.
    assert!(
        cache
            .interpolate(Vec3::ZERO, Vec3::new(0.0, 0.0, 7.0))
            .is_some()
    );
}

// ---------------------------------------------------------------------------------------------
// The two known bugs of public implementations, and scale.

/// A record whose normal is `degrees` away from +z, at the query point.
fn tilted(degrees: f32) -> Record<Rgb> {
    let t = degrees.to_radians();
    Record::new(
        Vec3::ZERO,
        Vec3::new(t.sin(), 0.0, t.cos()),
        1.0,
        Rgb::splat(1.0),
    )
}

/// A 10° normal limit must act at 10°, not at 68° (pbrt-v2 computes `cosf(Degrees(maxang))`:
/// cos(572.96 rad) = cos 68.1°). 9.9° and 10.1° are 0.2° apart: the chord between them differs by
/// 2(sin 5.05° − sin 4.95°) ≈ 3.5·10⁻³, far above the ~10⁻⁷ rounding of the chord from f32
/// normals.
#[test]
fn ten_degree_limit_is_ten_degrees() {
    let cuts = Cuts::new(Angle::from_degrees(10.0), 0.05).unwrap_or_else(|e| panic!("{e}"));
    let ward_cut = ward(0.5).with_cuts(cuts);
    let tl_cut = TabellionLamorlette::new(0.5)
        .unwrap_or_else(|e| panic!("{e}"))
        .with_cuts(cuts);
    let used = |rec: Record<Rgb>| {
        [
            cache_of(ward_cut, &[rec])
                .interpolate(Vec3::ZERO, Vec3::Z)
                .is_some(),
            cache_of(tl_cut, &[rec])
                .interpolate(Vec3::ZERO, Vec3::Z)
                .is_some(),
            // κ = 1 and no separate cut: Tabellion & Lamorlette's normal term alone ends at 10°.
            cache_of(tl(), &[rec])
                .interpolate(Vec3::ZERO, Vec3::Z)
                .is_some(),
        ]
    };
    assert_eq!(used(tilted(9.9)), [true; 3]);
    assert_eq!(used(tilted(10.1)), [false; 3]);
    assert_eq!(used(tilted(30.0)), [false; 3]);
    assert!((Angle::from_degrees(10.0).radians() - 0.174_532_925).abs() < 1e-8);
}

/// The in-front test scales with the scene: a record at height h·R in front of the query's
/// tangent plane is skipped when h > τ and used when h < τ, for scenes scaled by 2⁻²⁰ … 2²⁰ (a
/// tolerance in world units, like Mitsuba's 0.05, would accept both at small scales and reject
/// both at large ones). Powers of two scale every coordinate exactly, so the decisions must be the
/// same at every scale.
#[test]
fn in_front_test_is_relative_to_the_radius() {
    let tau = Cuts::default().in_front_tolerance();
    for e in -20..=20 {
        let s = 2f32.powi(e);
        let (radius, q) = (s, Vec3::new(0.25 * s, 0.0, 0.0));
        let cache = |h: f32| {
            let rec = Record::new(Vec3::new(0.0, 0.0, h * s), Vec3::Z, radius, Rgb::splat(1.0));
            (
                cache_of(tl(), &[rec]).interpolate(q, Vec3::Z).is_some(),
                cache_of(ward(0.5), &[rec])
                    .interpolate(q, Vec3::Z)
                    .is_some(),
            )
        };
        // Heights of 0.03 R and 0.07 R around τ = 0.05; behind the plane (negative heights) the
        // record is always in use.
        assert_eq!(
            cache(0.03),
            (true, true),
            "scale 2^{e}, h = 0.03 (τ = {tau})"
        );
        assert_eq!(cache(0.07), (false, false), "scale 2^{e}, h = 0.07");
        assert_eq!(cache(-0.2), (true, true), "scale 2^{e}, h = −0.2");
    }
}

/// Records at 10⁻⁴ m and at 10⁴ m in one cache; the scene translated by 10⁵ gives the same
/// answers bit for bit. Positions are multiples of 2⁻⁷, so adding 10⁵ (where the f32 spacing is
/// 2⁻⁷) is exact, and so is every offset p − pᵢ: the weights, the values and the sets are equal.
#[test]
fn any_scale_and_translation() {
    let mut records = Vec::new();
    for i in 0..50u8 {
        let f = f32::from(i);
        // Small records on a 2⁻⁷ grid near the origin (R = 10⁻⁴ … 10⁻³ m would be below the
        // translated scene's resolution, so those are kept untranslated below), large ones
        // spread over 10⁴ m.
        records.push(Record::new(
            Vec3::new(f * 0.5, (f * 0.25).floor(), 0.0),
            Vec3::Z,
            1.0 + f * 0.125,
            Rgb::splat(f),
        ));
        records.push(Record::new(
            Vec3::new(f * 256.0 - 6000.0, 3000.0, 128.0 * f),
            Vec3::Y,
            1e4,
            Rgb::splat(100.0 + f),
        ));
    }
    let base = cache_of(tl(), &records);
    let shift = Vec3::splat(1e5);
    let moved: Vec<_> = records
        .iter()
        .map(|r| Record {
            position: r.position + shift,
            ..*r
        })
        .collect();
    let moved = cache_of(tl(), &moved);
    let mut hits = 0;
    for i in 0..200u16 {
        let f = f32::from(i);
        for (q, n) in [
            (
                Vec3::new(f * 0.125 - 3.0, (f * 0.0625).floor(), 0.0),
                Vec3::Z,
            ),
            (Vec3::new(f * 64.0 - 6000.0, 3000.0 + f, 128.0 * f), Vec3::Y),
        ] {
            // The same records with the same weights, bit for bit.
            let wa = tree_weighted(&base, q, n);
            assert_eq!(wa, tree_weighted(&moved, q + shift, n), "query {q}");
            // The two octrees have different roots, so they may visit the records in another
            // order: the values agree within the insertion-order bound (see
            // `insertion_order_does_not_matter`; the gradients are zero, so S = max Eᵢ).
            match (base.interpolate(q, n), moved.interpolate(q + shift, n)) {
                (None, None) => {}
                (Some(a), Some(b)) => {
                    hits += 1;
                    assert_eq!((a.count, a.total_weight), (b.count, b.total_weight));
                    let k = f64::from(a.count);
                    for c in 0..3 {
                        let (u, v) = (a.value.0[c], b.value.0[c]);
                        let s = f64::from(u.max(v)) * 1.01;
                        let bound = 2.0 * (k + 2.0) * U64 * s + 2.0 * U32 * s;
                        assert!(f64::from((u - v).abs()) <= bound, "{u} vs {v} at {q}");
                    }
                }
                (a, b) => panic!("query {q}: {a:?} vs {b:?}"),
            }
        }
    }
    assert!(hits > 100, "{hits} hits");
    assert!(
        base.interpolate(Vec3::new(1.0, 0.0, 0.0), Vec3::Z)
            .is_some()
    );

    // Tiny records (R = 10⁻⁴ m) next to huge ones (R = 10⁴ m) in one cache: each finds itself.
    let mut mixed = IrradianceCache::<Rgb, _>::new(tl());
    let small: Vec<_> = (0..100u8)
        .map(|i| {
            let f = f32::from(i);
            Record::new(Vec3::new(f * 3e-4, 0.0, 5.0), Vec3::Z, 1e-4, Rgb::splat(f))
        })
        .collect();
    mixed
        .extend(small.iter().copied())
        .unwrap_or_else(|e| panic!("{e}"));
    mixed
        .insert(Record::new(
            Vec3::new(-3e4, 2e4, 0.0),
            Vec3::Z,
            1e4,
            Rgb::splat(7.0),
        ))
        .unwrap_or_else(|e| panic!("{e}"));
    for r in &small {
        let hit = mixed
            .interpolate(r.position, Vec3::Z)
            .unwrap_or_else(|| panic!("miss at {}", r.position));
        // Small records are 3·10⁻⁴ apart with influence R/2 = 5·10⁻⁵: each is alone.
        assert_eq!((hit.value, hit.count), (r.value, 1));
    }
    let far = mixed.interpolate(Vec3::new(-3e4, 2e4, 1.0), Vec3::Z);
    assert_eq!(far.map(|h| h.value), Some(Rgb::splat(7.0)));
}

// ---------------------------------------------------------------------------------------------
// Threads.

#[test]
fn queries_from_many_threads_match_one_thread() {
    fn is_sync<T: Sync + Send>() {}
    is_sync::<IrradianceCache<Rgb, TabellionLamorlette>>();
    is_sync::<IrradianceCache<f32, Ward>>();

    let records: Vec<_> = (0..2000u32)
        .map(|i| {
            let f = i as f32;
            Record::new(
                Vec3::new((f * 0.618).fract() * 10.0, (f * 0.414).fract() * 10.0, 0.0),
                Vec3::Z,
                0.3,
                Rgb::splat(f),
            )
        })
        .collect();
    let cache = cache_of(tl(), &records);
    let queries: Vec<Vec3> = (0..4000u32)
        .map(|i| {
            let f = i as f32;
            Vec3::new(
                (f * 0.1234).fract() * 10.0,
                (f * 0.5678).fract() * 10.0,
                0.0,
            )
        })
        .collect();
    let serial: Vec<_> = queries
        .iter()
        .map(|&q| cache.interpolate(q, Vec3::Z))
        .collect();
    let parallel: Vec<_> = std::thread::scope(|s| {
        let handles: Vec<_> = queries
            .chunks(1000)
            .map(|chunk| {
                let cache = &cache;
                s.spawn(move || {
                    chunk
                        .iter()
                        .map(|&q| cache.interpolate(q, Vec3::Z))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_else(|_| panic!("query thread panicked")))
            .collect()
    });
    assert_eq!(serial, parallel);
    assert!(serial.iter().filter(|h| h.is_some()).count() > 1000);
}

// ---------------------------------------------------------------------------------------------
// Files.

fn record_strategy() -> impl Strategy<Value = Record<Rgb>> {
    (
        v3(-1e3..1e3),
        unit(),
        -3.0f32..3.0,
        rgb(),
        prop::array::uniform3(rgb_signed(50.0)),
        prop::array::uniform3(rgb_signed(50.0)),
    )
        .prop_map(|(p, n, r, e, tg, rg)| Record::new(p, n, 10f32.powf(r), e).with_gradients(tg, rg))
}

fn bytes_of<V: CacheValue, M: ErrorMetric>(cache: &IrradianceCache<V, M>) -> Vec<u8> {
    let mut out = Vec::new();
    cache.write_to(&mut out).unwrap_or_else(|e| panic!("{e}"));
    out
}

proptest! {
    #![proptest_config(config(64))]

    /// Write, read, write: the records and the bytes are identical, bit for bit, and the cache
    /// read back answers queries identically.
    #[test]
    fn files_round_trip_bit_for_bit(records in prop::collection::vec(record_strategy(), 0..80)) {
        let cache = cache_of(tl(), &records);
        let bytes = bytes_of(&cache);
        prop_assert_eq!(bytes.len(), 28 + 144 * records.len() + 8);
        let back = IrradianceCache::<Rgb, _>::read_from(bytes.as_slice(), tl())
            .unwrap_or_else(|e| panic!("{e}"));
        prop_assert_eq!(&bytes_of(&back), &bytes);
        prop_assert_eq!(back.records(), cache.records());
        for r in &records {
            prop_assert_eq!(back.interpolate(r.position, r.normal), cache.interpolate(r.position, r.normal));
        }
        // The record-level functions are the same format: the records come back in order,
        // and written again they are the cache's own bytes.
        let listed = read_records::<Rgb, _>(bytes.as_slice())
            .unwrap_or_else(|e| panic!("{e}"));
        prop_assert_eq!(listed.as_slice(), cache.records());
        let mut again = Vec::new();
        write_records(&listed, &mut again).unwrap_or_else(|e| panic!("{e}"));
        prop_assert_eq!(again, bytes);
    }

    /// Validation is idempotent for ellipses too: a record validated once comes back from a
    /// second validation, and from a file, with the same bits (a cache passed between
    /// processes as files is the cache one process holds).
    #[test]
    fn ellipses_validate_once_for_all(
        record in record_strategy(),
        aspect in 0.05f32..1.0,
        axis in v3(-1.0..1.0),
    ) {
        prop_assume!(axis.cross(record.normal).length() > 1e-3);
        let once = record.with_ellipse(aspect, axis).validated().unwrap_or_else(|e| panic!("{e}"));
        let twice = once.validated().unwrap_or_else(|e| panic!("{e}"));
        prop_assert_eq!(
            (once.tangent.to_array().map(f32::to_bits), once.normal.to_array().map(f32::to_bits)),
            (twice.tangent.to_array().map(f32::to_bits), twice.normal.to_array().map(f32::to_bits))
        );
        let cache = cache_of(tl(), &[once]);
        let back = IrradianceCache::<Rgb, _>::read_from(bytes_of(&cache).as_slice(), tl())
            .unwrap_or_else(|e| panic!("{e}"));
        prop_assert_eq!(back.records(), cache.records());
        prop_assert_eq!(bytes_of(&back), bytes_of(&cache));
    }

    /// Joining two caches' record lists and filing them gives the cache that inserted both
    /// lists in that order, bit for bit (what merging shards of a cache relies on).
    #[test]
    fn joined_record_lists_file_as_one_cache(
        a in prop::collection::vec(record_strategy(), 0..40),
        b in prop::collection::vec(record_strategy(), 0..40),
    ) {
        let mut joined = read_records::<Rgb, _>(bytes_of(&cache_of(tl(), &a)).as_slice())
            .unwrap_or_else(|e| panic!("{e}"));
        joined.extend(read_records::<Rgb, _>(bytes_of(&cache_of(tl(), &b)).as_slice())
            .unwrap_or_else(|e| panic!("{e}")));
        let mut bytes = Vec::new();
        write_records(&joined, &mut bytes).unwrap_or_else(|e| panic!("{e}"));
        let merged = IrradianceCache::<Rgb, _>::read_from(bytes.as_slice(), tl())
            .unwrap_or_else(|e| panic!("{e}"));
        let both: Vec<_> = a.iter().chain(&b).copied().collect();
        let direct = cache_of(tl(), &both);
        prop_assert_eq!(merged.records(), direct.records());
        for r in &both {
            prop_assert_eq!(merged.interpolate(r.position, r.normal), direct.interpolate(r.position, r.normal));
        }
    }

    /// Any single corrupted byte, anywhere in the file, is refused (the FNV-1a argument in the
    /// io module's docs), and so is every truncation.
    #[test]
    fn corrupt_files_are_rejected(
        records in prop::collection::vec(record_strategy(), 1..20),
        at in any::<prop::sample::Index>(),
        flip in 1u8..=255,
        cut in any::<prop::sample::Index>(),
    ) {
        let bytes = bytes_of(&cache_of(tl(), &records));
        let mut bad = bytes.clone();
        let i = at.index(bad.len());
        bad[i] ^= flip;
        prop_assert!(IrradianceCache::<Rgb, _>::read_from(bad.as_slice(), tl()).is_err(), "byte {} flipped", i);
        let n = cut.index(bytes.len());
        let short = IrradianceCache::<Rgb, _>::read_from(&bytes[..n], tl());
        prop_assert!(matches!(short, Err(CacheFileError::Truncated)), "cut at {}: {:?}", n, short.err());
    }
}

#[test]
fn foreign_and_wrong_version_files_are_rejected_with_the_reason() {
    let cache = cache_of(
        tl(),
        &[Record::new(Vec3::ZERO, Vec3::Z, 1.0, Rgb::splat(2.0))],
    );
    let bytes = bytes_of(&cache);
    let read = |b: &[u8]| IrradianceCache::<Rgb, _>::read_from(b, tl()).err();

    let png = b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR\0\0\0\x01\0\0\0\x01\x08\x02\0\0\0";
    assert!(matches!(read(png), Some(CacheFileError::NotACacheFile)));
    assert!(matches!(read(b""), Some(CacheFileError::Truncated)));

    // Files of the previous formats (version 1, without the radii neighbour clamping keeps;
    // version 2, without the ellipses; version 3, without the curvature) and of a future one
    // are refused by version, never misread.
    for version in [1u32, 2, 3, 5] {
        let mut other = bytes.clone();
        other[8..12].copy_from_slice(&version.to_le_bytes());
        let e = read(&other);
        assert!(
            matches!(e, Some(CacheFileError::Version { found, supported: 4 }) if found == version),
            "{e:?}"
        );
    }

    // An RGB file read as ambient occlusion, and as 3 signed coefficients.
    let as_ao = IrradianceCache::<f32, _>::read_from(bytes.as_slice(), tl()).err();
    assert!(matches!(
        as_ao,
        Some(CacheFileError::ValueType { found_tag: 1, .. })
    ));
    let as_sh = IrradianceCache::<[f32; 3], _>::read_from(bytes.as_slice(), tl()).err();
    assert!(matches!(
        as_sh,
        Some(CacheFileError::ValueType {
            expected_tag: 3,
            ..
        })
    ));

    // A payload change with a matching checksum still cannot smuggle in an invalid record.
    let mut zero_radius = bytes.clone();
    zero_radius[28 + 24..28 + 28].copy_from_slice(&0f32.to_le_bytes());
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in &zero_radius[..zero_radius.len() - 8] {
        h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
    }
    let end = zero_radius.len() - 8;
    zero_radius[end..].copy_from_slice(&h.to_le_bytes());
    assert!(matches!(
        read(&zero_radius),
        Some(CacheFileError::Record {
            index: 0,
            source: InsertError::Radius(_)
        })
    ));

    // Trailing bytes after the checksum are left unread.
    let mut longer = bytes.clone();
    longer.extend_from_slice(b"more");
    assert!(read(&longer).is_none());
}

#[test]
fn scalar_and_coefficient_caches_round_trip() {
    let mut ao = IrradianceCache::<f32, _>::new(ward(0.2));
    ao.insert(Record::new(Vec3::ONE, Vec3::X, 0.5, 0.75))
        .unwrap_or_else(|e| panic!("{e}"));
    let bytes = bytes_of(&ao);
    assert_eq!(bytes.len(), 28 + 88 + 8);
    let back = IrradianceCache::<f32, _>::read_from(bytes.as_slice(), ward(0.2))
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back.records(), ao.records());
    assert_eq!(
        back.interpolate(Vec3::ONE, Vec3::X).map(|h| h.value),
        Some(0.75)
    );

    let mut sh = IrradianceCache::<[f32; 9], _>::new(tl());
    let coeffs = std::array::from_fn(|i| i as f32 - 4.0);
    sh.insert(Record::new(Vec3::ZERO, Vec3::Y, 1.0, coeffs))
        .unwrap_or_else(|e| panic!("{e}"));
    let back = IrradianceCache::<[f32; 9], _>::read_from(bytes_of(&sh).as_slice(), tl())
        .unwrap_or_else(|e| panic!("{e}"));
    // Signed coefficients are not clamped.
    assert_eq!(
        back.interpolate(Vec3::ZERO, Vec3::Y).map(|h| h.value),
        Some(coeffs)
    );
}

// ---------------------------------------------------------------------------------------------
// Neighbour clamping and the radius pipeline.

/// A large record whose centre lies farther than the new record's radius, but whose
/// sphere reaches past it, must shrink. The new record (r = 0.1) at the origin; the neighbour at
/// d = 1 with R = 5 > r + d = 1.1. The old search (records within r of the new one) never saw
/// it: this test failed before the fix with R staying 5.
#[test]
fn a_large_neighbour_beyond_the_new_radius_shrinks() {
    let mut cache = IrradianceCache::<Rgb, _>::new(tl());
    let big = cache
        .insert(Record::new(Vec3::X, Vec3::Y, 5.0, Rgb::splat(1.0)))
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(cache.clamp_neighbours(Vec3::ZERO, 0.1), 1);
    let r = cache.records()[big as usize];
    // 0.1 + 1 in f64, rounded once to f32.
    assert_eq!(r.radius, (0.1f64 + 1.0) as f32);
    assert_eq!(r.unclamped_radius, r.radius);
    // The octree was refiled: the record no longer reaches x = 1.7 (influence R/2 = 0.55).
    assert!(
        cache
            .interpolate(Vec3::new(1.7, 0.0, 0.0), Vec3::Y)
            .is_none()
    );
    assert!(
        cache
            .interpolate(Vec3::new(1.5, 0.0, 0.0), Vec3::Y)
            .is_some()
    );
}

/// On a line of records at spacing 1, each inserted with the pipeline and the same
/// large distance, one small record propagates its limit: after it, record k steps away holds
/// g ≤ g_small + k (the triangle inequality in both directions).
#[test]
fn a_small_record_propagates_its_limit_along_a_line() {
    let mut cache = IrradianceCache::<Rgb, _>::new(tl());
    let inputs = |distance| RadiusInputs {
        distance,
        limits: RadiusLimits {
            min: 0.0,
            max: 1000.0,
        },
        neighbour_clamping: true,
    };
    for k in 0..10 {
        let rec = Record::new(Vec3::new(k as f32, 0.0, 0.0), Vec3::Y, 1.0, Rgb::splat(1.0));
        cache
            .insert_with_radius(rec, &inputs(100.0))
            .unwrap_or_else(|e| panic!("{e}"));
    }
    // Before the small one, the first-half clamp already chains: record k ≤ 100 + ... stays 100.
    assert!(cache.records().iter().all(|r| r.radius == 100.0));
    let small = Record::new(Vec3::new(4.0, 0.0, 0.0), Vec3::Y, 1.0, Rgb::splat(1.0));
    let (_, placed) = cache
        .insert_with_radius(
            small.with_gradients([Rgb::splat(0.0); 3], [Rgb::splat(0.0); 3]),
            &inputs(0.25),
        )
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(placed.radius, 0.25);
    for (k, r) in cache.records().iter().take(10).enumerate() {
        let expected = 0.25 + (k as f32 - 4.0).abs();
        assert_eq!(r.radius, expected, "record {k}");
    }
    // And a record inserted later, 2 beyond the line's end, is limited by the chain: the nearest
    // record (x = 9, g = 5.25) allows 5.25 + 2.
    let (_, late) = cache
        .insert_with_radius(
            Record::new(Vec3::new(11.0, 0.0, 0.0), Vec3::Y, 1.0, Rgb::splat(1.0)),
            &inputs(100.0),
        )
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(late.radius, 7.25);
}

/// Neighbour clamping propagates the unclamped radius plus d, not the pixel-clamped R,
/// and never pushes a record below its own minimum.
#[test]
fn clamping_propagates_the_geometric_radius_and_respects_minima() {
    let mut cache = IrradianceCache::<Rgb, _>::new(tl());
    // A record whose geometry allows 0.05 but whose pixel minimum raised R to 0.5.
    let inputs = RadiusInputs {
        distance: 0.05,
        limits: RadiusLimits {
            min: 0.5,
            max: 10.0,
        },
        neighbour_clamping: true,
    };
    let (_, a) = cache
        .insert_with_radius(
            Record::new(Vec3::ZERO, Vec3::Y, 1.0, Rgb::splat(1.0)),
            &inputs,
        )
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        (a.radius, a.unclamped_radius, a.min_radius),
        (0.5, 0.05, 0.5)
    );
    // A neighbour at d = 1 with a large distance and no minimum: limited by 0.05 + 1, not 0.5 + 1.
    let free = RadiusInputs {
        distance: 50.0,
        limits: RadiusLimits {
            min: 0.0,
            max: 10.0,
        },
        neighbour_clamping: true,
    };
    let (_, b) = cache
        .insert_with_radius(Record::new(Vec3::X, Vec3::Y, 1.0, Rgb::splat(1.0)), &free)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(b.radius, (0.05f64 + 1.0) as f32);
    // A new tiny record right next to the first lowers its g, but its R stays at its minimum.
    let tiny = RadiusInputs {
        distance: 0.001,
        limits: RadiusLimits {
            min: 0.0,
            max: 10.0,
        },
        neighbour_clamping: true,
    };
    cache
        .insert_with_radius(
            Record::new(Vec3::new(0.01, 0.0, 0.0), Vec3::Y, 1.0, Rgb::splat(1.0)),
            &tiny,
        )
        .unwrap_or_else(|e| panic!("{e}"));
    let first = cache.records()[0];
    assert_eq!(first.radius, 0.5);
    assert!(first.unclamped_radius <= 0.011 + 1e-6, "{first:?}");
}

/// A record forced to a large R by the minimum never extrapolates, anywhere within R, above
/// 2E or below 0: the pipeline scaled its gradient so ‖∇ₜE‖·R ≤ E. Without the cap (before the
/// fix) the gradient 10 over R = 1 extrapolates E = 1 to 11.
#[test]
fn the_gradient_cap_bounds_extrapolation_over_a_raised_radius() {
    // κ = 0.5: the influence R/(2κ) is R itself, the widest the test needs.
    let metric = TabellionLamorlette::new(0.5).unwrap_or_else(|e| panic!("{e}"));
    let mut cache = IrradianceCache::<Rgb, _>::new(metric);
    let e = Rgb::new(1.0, 2.0, 0.5);
    let grad = [
        Rgb::new(10.0, 0.0, -4.0),
        Rgb::new(0.0, 0.0, 0.0),
        Rgb::new(3.0, 1.0, 1.0),
    ];
    let rec = Record::new(Vec3::ZERO, Vec3::Y, 1.0, e).with_gradients(grad, [Rgb::splat(0.0); 3]);
    let inputs = RadiusInputs {
        distance: 0.01,
        limits: RadiusLimits { min: 1.0, max: 2.0 },
        neighbour_clamping: false,
    };
    let (_, placed) = cache
        .insert_with_radius(rec, &inputs)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(placed.radius, 1.0);
    // Tangent (x, z) gradients: red (10, 3), green (0, 1), blue (−4, 1): the limits
    // E/‖·‖ are 1/√109, 2 and 0.5/√17; the smallest wins (f32 rounding: 1e-7 relative).
    let expected = 1.0 / 109f64.sqrt();
    assert!((f64::from(placed.gradient_limit) / expected - 1.0).abs() < 1e-6);
    assert_eq!(placed.gradient_scale[1], 1.0);
    // Sample the disc of radius R on the plane, and a ring just inside it.
    for i in 0..64 {
        for &rho in &[0.25f32, 0.5, 0.999] {
            let phi = i as f32 / 64.0 * std::f32::consts::TAU;
            let p = Vec3::new(rho * phi.cos(), 0.0, rho * phi.sin());
            let v = cache
                .interpolate(p, Vec3::Y)
                .unwrap_or_else(|| panic!("miss at {p}"));
            for c in 0..3 {
                // One record: the value is E + d·∇ in f64, rounded to f32 once; the cap's scale
                // is rounded down, so the bound 2E holds up to that last rounding (u₃₂).
                let x = v.value.0[c];
                assert!(
                    x >= 0.0 && f64::from(x) <= 2.0 * f64::from(e.0[c]) * (1.0 + 2.0 * U32),
                    "{p}: channel {c} = {x}"
                );
            }
        }
    }
}

/// The pipeline's steps in order, and open sky: a gather that hit nothing gets the maximum,
/// never infinity; a NaN distance and bad limits are errors.
#[test]
fn radius_pipeline_order_and_open_sky() {
    let mut cache = IrradianceCache::<Rgb, _>::new(tl());
    let rec = |x: f32| Record::new(Vec3::new(x, 0.0, 0.0), Vec3::Y, 1.0, Rgb::splat(2.0));
    let limits = RadiusLimits { min: 0.1, max: 4.0 };
    let sky = RadiusInputs {
        distance: f32::INFINITY,
        limits,
        neighbour_clamping: true,
    };
    let (_, p) = cache
        .insert_with_radius(rec(0.0), &sky)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((p.radius, p.unclamped_radius), (4.0, 4.0));
    // The gradient limit comes before the clamps: E = 2, tangent gradient 4 → 0.5.
    let steep = rec(100.0).with_gradients(
        [Rgb::splat(4.0), Rgb::splat(0.0), Rgb::splat(0.0)],
        [Rgb::splat(0.0); 3],
    );
    let (_, p) = cache
        .insert_with_radius(
            steep,
            &RadiusInputs {
                distance: 3.0,
                ..sky
            },
        )
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((p.radius, p.unclamped_radius), (0.5, 0.5));
    assert_eq!(p.gradient_scale[0], 1.0);
    // A gradient along the normal does not limit the radius.
    let normal_only = rec(200.0).with_gradients(
        [Rgb::splat(0.0), Rgb::splat(50.0), Rgb::splat(0.0)],
        [Rgb::splat(0.0); 3],
    );
    let (_, p) = cache
        .insert_with_radius(
            normal_only,
            &RadiusInputs {
                distance: 3.0,
                ..sky
            },
        )
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(p.radius, 3.0);
    assert!(matches!(
        cache.insert_with_radius(
            rec(300.0),
            &RadiusInputs {
                distance: f32::NAN,
                ..sky
            }
        ),
        Err(InsertError::Distance(_))
    ));
    for (min, max) in [
        (0.0, f32::INFINITY),
        (2.0, 1.0),
        (-1.0, 1.0),
        (f32::NAN, 1.0),
    ] {
        let bad = RadiusInputs {
            limits: RadiusLimits { min, max },
            ..sky
        };
        assert!(matches!(
            cache.insert_with_radius(rec(300.0), &bad),
            Err(InsertError::Limits(..))
        ));
    }
    assert_eq!(cache.len(), 3);
}

/// `covers` says exactly whether `interpolate` finds a record.
#[test]
fn covers_agrees_with_interpolate() {
    let mut cache = IrradianceCache::<Rgb, _>::new(tl());
    for i in 0..50 {
        let f = i as f32;
        let p = Vec3::new((f * 0.7).sin() * 3.0, 0.0, (f * 1.3).cos() * 3.0);
        cache
            .insert(Record::new(
                p,
                Vec3::Y,
                0.3 + 0.2 * (f * 0.3).sin().abs(),
                Rgb::splat(1.0),
            ))
            .unwrap_or_else(|e| panic!("{e}"));
    }
    let mut hits = 0;
    for i in 0..2000 {
        let f = i as f32;
        let p = Vec3::new(
            (f * 0.37).sin() * 3.5,
            0.01 * (f * 0.1).sin(),
            (f * 0.53).cos() * 3.5,
        );
        let n = if i % 7 == 0 { Vec3::X } else { Vec3::Y };
        let hit = cache.interpolate(p, n).is_some();
        hits += usize::from(hit);
        assert_eq!(cache.covers(p, n), hit, "{p} {n}");
    }
    assert!(hits > 100 && hits < 1900, "{hits}");
    assert!(!cache.covers(Vec3::NAN, Vec3::Y) && !cache.covers(Vec3::ZERO, Vec3::ZERO));
}

proptest! {
    #![proptest_config(config(48))]

    /// A cache built with neighbour clamping, written and read back, interpolates to the
    /// same bits everywhere (cells stay in index order, so the sums run in the same order).
    /// Before the fix, refiled records went to the end of their cells and sums could reorder.
    #[test]
    fn round_trip_after_clamping_is_bit_for_bit(
        records in prop::collection::vec((v3(-1.0..1.0), near(Vec3::Y, 20.0), -2.0f32..0.3, rgb(), prop::array::uniform3(rgb_signed(5.0))), 1..80),
        queries in prop::collection::vec((v3(-1.2..1.2), near(Vec3::Y, 20.0)), 1..60),
    ) {
        let mut cache = IrradianceCache::<Rgb, _>::new(tl());
        for (p, n, r, e, g) in records {
            let inputs = RadiusInputs {
                distance: 10f32.powf(r),
                limits: RadiusLimits { min: 0.02, max: 1.0 },
                neighbour_clamping: true,
            };
            let rec = Record::new(p, n, 1.0, e).with_gradients(g, [Rgb::splat(0.0); 3]);
            cache.insert_with_radius(rec, &inputs).unwrap_or_else(|e| panic!("{e}"));
        }
        let bytes = bytes_of(&cache);
        let back = IrradianceCache::<Rgb, _>::read_from(bytes.as_slice(), tl()).unwrap_or_else(|e| panic!("{e}"));
        prop_assert_eq!(back.records(), cache.records());
        for (q, n) in queries {
            let (a, b) = (cache.interpolate(q, n), back.interpolate(q, n));
            prop_assert_eq!(a.map(|x| x.value.0.map(f32::to_bits)), b.map(|x| x.value.0.map(f32::to_bits)));
            prop_assert_eq!(a.map(|x| x.total_weight.to_bits()), b.map(|x| x.total_weight.to_bits()));
            prop_assert_eq!(tree_in_range(&cache, q), brute_in_range(&cache, q));
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Region queries.

proptest! {
    #![proptest_config(config(96))]

    /// One walk of the octree for a box, then a query per point of it: `interpolate_among` uses
    /// exactly the records `interpolate_filtered` uses (the same containment test and weights,
    /// so the same ids, weights and count), and its value differs only by the order of the f64
    /// sums. Each sum of k terms is within (k − 1)·u₆₄·Σ|terms| of the exact sum in either order,
    /// so the two means differ by at most 2(k + 1)·u₆₄ relative to Σ wᵢ|Ẽᵢ| / Σ wᵢ, before both
    /// are rounded to f32 (the same rounding unless the two f64 values straddle an f32 rounding
    /// boundary: a difference of one f32 ulp, u₃₂ relative, which the bound allows).
    #[test]
    fn a_box_query_sees_what_each_point_query_sees(
        records in prop::collection::vec(
            (v3(-1.0..1.0), near(Vec3::Z, 8.0), 0.05f32..0.8, rgb())
                .prop_map(|(p, n, r, e)| Record::new(p, n, r, e)),
            1..60,
        ),
        size in 0.0f32..0.3,
        points in prop::collection::vec((v3(0.0..1.0), near(Vec3::Z, 8.0)), 1..12),
    ) {
        let cache = cache_of(tl(), &records);
        // A box around the first record, so that its own position (a query it weighs 1) is in
        // every case's points.
        let lo = records[0].position - Vec3::splat(0.5 * size);
        let hi = lo + Vec3::splat(size);
        let own = (Vec3::splat(0.5), records[0].normal);
        let points = std::iter::once(own).chain(points);
        let mut nearby = Vec::new();
        cache.records_meeting_box(lo, hi, &mut nearby);
        prop_assert!(nearby.windows(2).all(|w| w[0].id < w[1].id), "index order, once each");
        for (i, (t, n)) in points.enumerate() {
            let p = if i == 0 { records[0].position } else { lo + t * (hi - lo) };
            let (mut a, mut b) = (Vec::new(), Vec::new());
            let whole = cache.interpolate_filtered(p, n, |id, _| { a.push(id); true });
            let among = cache.interpolate_among(&nearby, p, n, |id, _| { b.push(id); true });
            a.sort_unstable();
            prop_assert_eq!(&a, &b);
            // The bare enumeration: the same records, in the same order, with weights whose
            // sum (same terms, same order, f64) is interpolate_among's total to the bit.
            let (mut ids, mut total) = (Vec::new(), 0.0f64);
            cache.for_each_weighted_among(&nearby, p, n, |id, _, w| { ids.push(id); total += w; });
            prop_assert_eq!(&ids, &b);
            if let Some(y) = &among {
                prop_assert_eq!(total, y.total_weight);
            }
            match (whole, among) {
                (None, None) => {}
                (Some(x), Some(y)) => {
                    prop_assert_eq!(x.count, y.count);
                    let k = f64::from(x.count);
                    let w = (x.total_weight - y.total_weight).abs();
                    prop_assert!(w <= 2.0 * (k + 1.0) * U64 * x.total_weight, "weights {} {}", x.total_weight, y.total_weight);
                    for c in 0..3 {
                        let scale = records.iter().map(|r| f64::from(r.value.0[c])).fold(0.0, f64::max);
                        let d = (f64::from(x.value.0[c]) - f64::from(y.value.0[c])).abs();
                        prop_assert!(d <= (2.0 * (k + 1.0) * U64 + 2.0 * U32) * scale, "channel {}: {:?} {:?}", c, x.value, y.value);
                    }
                }
                (x, y) => prop_assert!(false, "{:?} vs {:?}", x, y),
            }
        }
    }
}

fn hessian(a: f32) -> Hessian {
    Hessian::new(a).unwrap_or_else(|e| panic!("{e}"))
}

/// A unit vector perpendicular to `n` at angle `angle` in its plane.
fn across(n: Vec3, angle: f32) -> Vec3 {
    let (s, t) = (
        n.any_orthonormal_vector(),
        n.cross(n.any_orthonormal_vector()),
    );
    (s * angle.cos() + t * angle.sin()).normalize()
}

proptest! {
    #![proptest_config(config(256))]

    /// An ellipse whose radii agree (aspect 1, with a minor axis) weighs exactly as the
    /// isotropic record: δₜ² = ((Δ·n)² + (Δ·u)² + (Δ·v)²)/R² = ‖Δ‖²/R² for an orthonormal
    /// (n, u, v). The stored n and u are `f32` unit vectors, orthonormal only to their rounding:
    /// |n·u| and |‖u‖ − 1| up to ~2·2⁻²⁴ each, so the frame's Gram matrix is off by ≲ 4·2⁻²⁴
    /// and δ² by as much relative; δ then by 2·2⁻²⁴ relative, and the weight 1 − δ/a (positive
    /// only for δ/a < 1) by at most 2·2⁻²⁴ absolute. Bound 4·2⁻²⁴ ≈ 2.4e-7.
    #[test]
    fn hessian_weight_with_equal_radii_is_isotropic(
        q in v3(-2.0..2.0), n in unit(), rn in unit(), angle in 0.0f32..6.3,
        radius in 0.1f32..4.0, a in 0.1f32..2.0,
    ) {
        let m = hessian(a);
        let iso = Candidate::new(q.as_dvec3(), n.as_dvec3(), Vec3::ZERO, rn, radius);
        let ell = iso.with_ellipse(1.0, across(rn, angle));
        let (wi, we) = (m.weight(&iso), m.weight(&ell));
        prop_assert!((wi - we).abs() <= 4.0 * f64::from(f32::EPSILON) * 0.5, "{wi} vs {we}");
    }

    /// Turning the minor axis by π (u → −u, so v → −v) leaves the weight bit for bit: every
    /// projection only changes sign, and only squares enter.
    #[test]
    fn hessian_weight_is_invariant_under_a_half_turn_of_the_axis(
        q in v3(-2.0..2.0), n in unit(), rn in unit(), angle in 0.0f32..6.3,
        radius in 0.1f32..4.0, aspect in 0.3f32..1.0, a in 0.1f32..2.0,
    ) {
        let m = hessian(a);
        let u = across(rn, angle);
        let base = Candidate::new(q.as_dvec3(), n.as_dvec3(), Vec3::ZERO, rn, radius);
        prop_assert_eq!(
            m.weight(&base.with_ellipse(aspect, u)),
            m.weight(&base.with_ellipse(aspect, -u))
        );
    }

    /// Inside the influence sphere only: a positive weight implies ‖Δ‖ < a·R (the octree files
    /// records by that sphere), and along the minor axis the weight vanishes at a·aspect·R.
    #[test]
    fn hessian_weight_stays_in_its_ellipse(
        q in v3(-2.0..2.0), rn in unit(), angle in 0.0f32..6.3,
        radius in 0.1f32..4.0, aspect in 0.3f32..1.0, a in 0.1f32..2.0, t in 0.0f32..1.5,
    ) {
        let m = hessian(a);
        let u = across(rn, angle);
        let c = Candidate::new(q.as_dvec3(), rn.as_dvec3(), Vec3::ZERO, rn, radius)
            .with_ellipse(aspect, u);
        if m.weight(&c) > 0.0 {
            prop_assert!(c.distance < f64::from(m.influence_radius(radius)));
        }
        // Along the minor axis at t times the scaled minor radius.
        let along = u.as_dvec3() * (f64::from(t) * f64::from(a) * f64::from(aspect) * f64::from(radius));
        let c = Candidate::new(along, rn.as_dvec3(), Vec3::ZERO, rn, radius).with_ellipse(aspect, u);
        // δₜ/a = t up to rounding (a few 2⁻⁵³): away from t = 1 the sign is certain.
        if t < 0.999 {
            prop_assert!(m.weight(&c) > 0.0);
        } else if t > 1.001 {
            prop_assert_eq!(m.weight(&c), 0.0);
        }
    }

    /// Interpolation among elliptical records stays a convex combination: without gradients
    /// each channel of E(p, n) lies within the records' own range (f64 sums rounded once to f32:
    /// one ulp of slack).
    #[test]
    fn hessian_interpolation_is_convex(
        records in prop::collection::vec(
            (v3(-1.0..1.0), 0.2f32..1.5, 0.5f32..1.0, 0.0f32..6.3, rgb()), 1..40),
        queries in prop::collection::vec(v3(-1.0..1.0), 1..20),
    ) {
        let records: Vec<Record<Rgb>> = records
            .iter()
            .map(|&(p, r, aspect, angle, v)| {
                Record::new(Vec3::new(p.x, p.y, 0.0), Vec3::Z, r, v)
                    .with_ellipse(aspect, across(Vec3::Z, angle))
            })
            .collect();
        let cache = cache_of(hessian(0.8), &records);
        let lo = records.iter().fold(Vec3::splat(f32::INFINITY), |m, r| m.min(Vec3::from_slice(r.value.channels())));
        let hi = records.iter().fold(Vec3::splat(f32::NEG_INFINITY), |m, r| m.max(Vec3::from_slice(r.value.channels())));
        for q in queries {
            if let Some(i) = cache.interpolate(Vec3::new(q.x, q.y, 0.0), Vec3::Z) {
                let v = Vec3::from_slice(i.value.channels());
                let slack = hi.abs() * f32::EPSILON;
                prop_assert!(v.cmpge(lo - slack).all() && v.cmple(hi + slack).all(), "{v} not in [{lo}, {hi}]");
            }
        }
    }
}

proptest! {
    #![proptest_config(config(256))]

    /// Second-order extrapolation: one record with curvature (cu, cv) along its minor axis u and
    /// along v = n × u, looked up at Δ = s·u + t·v on its plane, gives E·(1 + clamp(½(cu s² +
    /// cv t²), ±L)), the limit L the metric's. The query point q = u·s + v·t is rounded to f32
    /// (each component by ≤ 2⁻²⁴ of |s| + |t|) and the axes are f32 unit vectors (off by ~2⁻²⁴),
    /// so the projections are off by ≲ 3·2⁻²⁴·(|s| + |t|) and the correction ½(cu s² + cv t²)
    /// by ≲ (|cu s| + |cv t|)·3·2⁻²⁴·(|s| + |t|), times E; then one f32 rounding of the result
    /// (2⁻²⁴ relative). Asserted with each term doubled. With the limit 0 (the default)
    /// or without curvature, the value is the record's, bit for bit (first-order lookups
    /// unchanged).
    #[test]
    fn second_order_extrapolation_follows_the_curvature(
        angle in 0.0f32..6.3, cu in -20.0f32..20.0, cv in -20.0f32..20.0,
        s in -0.4f32..0.4, t in -0.4f32..0.4, limit in 0.05f32..1.0, e in 0.1f32..10.0,
    ) {
        let u = across(Vec3::Z, angle);
        let v = Vec3::Z.cross(u);
        let record = Record::new(Vec3::ZERO, Vec3::Z, 1.0, Rgb::new(e, 2.0 * e, 0.5 * e))
            .with_ellipse(1.0, u)
            .with_curvature([cu, cv]);
        let q = u * s + v * t;
        let second = hessian(1.0).with_second_order(limit).unwrap_or_else(|e| panic!("{e}"));
        let got = cache_of(second, std::slice::from_ref(&record)).interpolate(q, Vec3::Z).map(|i| i.value);
        let (ds, dt) = (f64::from(s), f64::from(t));
        let scale = 1.0 + (0.5 * (f64::from(cu) * ds * ds + f64::from(cv) * dt * dt))
            .clamp(-f64::from(limit), f64::from(limit));
        let want: Vec<f64> = record.value.channels().iter().map(|&c| f64::from(c) * scale).collect();
        let Some(got) = got else { return Err(TestCaseError::fail("no value")) };
        let eps = f64::from(f32::EPSILON) / 2.0;
        let moved = (f64::from(cu.abs()) * ds.abs() + f64::from(cv.abs()) * dt.abs()) * 3.0 * eps * (ds.abs() + dt.abs());
        for ((g, w), c) in got.channels().iter().zip(want).zip(record.value.channels()) {
            let tol = 2.0 * (moved * f64::from(*c) + eps * w.abs());
            prop_assert!((f64::from(*g) - w).abs() <= tol, "{g} vs {w} (tolerance {tol:e})");
        }
        let first = cache_of(hessian(1.0), std::slice::from_ref(&record)).interpolate(q, Vec3::Z);
        prop_assert_eq!(first.map(|i| i.value), Some(record.value));
        let flat = record.with_curvature([0.0; 2]);
        let plain = cache_of(second, std::slice::from_ref(&flat)).interpolate(q, Vec3::Z);
        prop_assert_eq!(plain.map(|i| i.value), Some(record.value));
    }
}

/// The second-order limit must lie in [0, 1]; a record's curvature must be finite.
#[test]
fn second_order_limits_and_curvatures_are_checked() {
    for bad in [-0.1, 1.5, f32::NAN] {
        assert!(matches!(
            hessian(1.0).with_second_order(bad),
            Err(MetricError::SecondOrder(_))
        ));
    }
    let record = Record::new(Vec3::ZERO, Vec3::Z, 1.0, Rgb::new(1.0, 1.0, 1.0))
        .with_curvature([f32::INFINITY, 0.0]);
    assert_eq!(record.validated().err(), Some(InsertError::Curvature));
}

/// An anisotropic record's minor axis is made perpendicular to its normal and unit; a missing or
/// normal-parallel axis on an ellipse, and an aspect outside (0, 1], are refused.
#[test]
fn ellipses_are_validated() {
    let r = Record::new(Vec3::ZERO, Vec3::Z, 1.0, Rgb::new(1.0, 1.0, 1.0));
    let v = r
        .with_ellipse(0.5, Vec3::new(2.0, 0.0, 1.0))
        .validated()
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(v.tangent, Vec3::X);
    assert_eq!(
        r.with_ellipse(0.5, Vec3::ZERO).validated(),
        Err(InsertError::Tangent)
    );
    assert_eq!(
        r.with_ellipse(0.5, Vec3::Z).validated(),
        Err(InsertError::Tangent)
    );
    for bad in [0.0, -0.5, 1.5, f32::NAN] {
        assert!(matches!(
            r.with_ellipse(bad, Vec3::X).validated(),
            Err(InsertError::Aspect(_))
        ));
    }
    // Isotropic records need no axis.
    assert!(r.validated().is_ok());
}

proptest! {
    #![proptest_config(config(128))]

    /// `interpolate_within(p, ρ)` weighs every record that some point q of the plane within ρ
    /// of p weighs: on a plane whose records share its normal, Tabellion–Lamorlette's weight is
    /// positive exactly where the distance is below the influence radius (the normals' term and
    /// the in-front offset are zero), and the shortened distance |p − pᵢ| − ρ is at most
    /// |q − pᵢ| by the triangle inequality. q is drawn at up to 0.999ρ from p so that its f32
    /// rounding (~1e-7 of the coordinates, far below 0.001ρ for ρ ≥ 1e-3) cannot carry it past ρ.
    /// With ρ = 0 the records are `interpolate_filtered`'s and the value differs only by the
    /// order of the f64 sums (the bound of `a_box_query_sees_what_each_point_query_sees`).
    #[test]
    fn reading_within_a_reach_weighs_what_the_points_within_it_weigh(
        records in prop::collection::vec(
            ((-1.0f32..1.0, -1.0f32..1.0), 0.05f32..0.8, rgb())
                .prop_map(|((x, y), r, e)| Record::new(Vec3::new(x, y, 0.0), Vec3::Z, r, e)),
            1..60,
        ),
        (px, py) in (-1.0f32..1.0, -1.0f32..1.0),
        reach in 1e-3f32..0.3,
        (t, turn) in (0.0f32..0.999, 0.0f32..std::f32::consts::TAU),
    ) {
        let cache = cache_of(tl(), &records);
        let p = Vec3::new(px, py, 0.0);
        let q = p + reach * t * Vec3::new(turn.cos(), turn.sin(), 0.0);
        let (mut at_q, mut within) = (Vec::new(), Vec::new());
        cache.interpolate_filtered(q, Vec3::Z, |id, _| { at_q.push(id); true });
        let read = cache.interpolate_within(p, Vec3::Z, reach, |id, _| { within.push(id); true });
        for id in &at_q {
            prop_assert!(within.contains(id), "record {} weighs at q but not within {} of p", id, reach);
        }
        prop_assert_eq!(read.is_some(), !within.is_empty());

        let (mut a, mut b) = (Vec::new(), Vec::new());
        let whole = cache.interpolate_filtered(p, Vec3::Z, |id, _| { a.push(id); true });
        let none_further = cache.interpolate_within(p, Vec3::Z, 0.0, |id, _| { b.push(id); true });
        a.sort_unstable();
        prop_assert_eq!(&a, &b);
        match (whole, none_further) {
            (None, None) => {}
            (Some(x), Some(y)) => {
                let k = f64::from(x.count);
                for c in 0..3 {
                    let scale = records.iter().map(|r| f64::from(r.value.0[c])).fold(0.0, f64::max);
                    let d = (f64::from(x.value.0[c]) - f64::from(y.value.0[c])).abs();
                    prop_assert!(d <= (2.0 * (k + 1.0) * U64 + 2.0 * U32) * scale, "channel {}: {:?} {:?}", c, x.value, y.value);
                }
            }
            (x, y) => prop_assert!(false, "{:?} vs {:?}", x, y),
        }
    }
}

/// A point beyond a record's sphere by less than the reach reads the record's value carried to
/// the point itself by its translation gradient, E + (p − pᵢ)·∇ₜE: one record, so the mean is
/// that value to rounding: the f64 sum of its seven terms (six roundings of partial sums, each
/// at most u₆₄ of the terms' magnitudes), the weight's product and quotient (2u₆₄ of the
/// value), 8u₆₄ of the terms in all, then one f32 rounding (u₃₂ relative). A reach short of
/// the gap reads nothing, as `interpolate_filtered` does.
#[test]
fn a_read_within_reach_extrapolates_to_the_point_itself() {
    let gradient = [
        Rgb::new(0.5, -0.25, 1.0),
        Rgb::new(2.0, 0.0, -0.5),
        Rgb::zero(),
    ];
    let record = Record::new(
        Vec3::new(0.2, -0.1, 0.0),
        Vec3::Z,
        0.4,
        Rgb::new(1.0, 2.0, 3.0),
    )
    .with_gradients(gradient, [Rgb::zero(); 3]);
    let cache = cache_of(tl(), &[record]);
    let influence = f64::from(tl().influence_radius(record.radius));
    let gap = 0.05;
    let p = record.position + Vec3::new(0.6, 0.8, 0.0) * (influence + gap) as f32;
    assert!(cache.interpolate(p, Vec3::Z).is_none());
    assert!(
        cache
            .interpolate_within(p, Vec3::Z, (0.5 * gap) as f32, |_, _| true)
            .is_none()
    );
    let read = cache
        .interpolate_within(p, Vec3::Z, (2.0 * gap) as f32, |_, _| true)
        .unwrap_or_else(|| panic!("a record {gap} beyond p's reach of {}", 2.0 * gap));
    let step = (p - record.position).as_dvec3();
    for c in 0..3 {
        let g = |k: usize| f64::from(gradient[k].0[c]);
        let expected = f64::from(record.value.0[c]) + step.x * g(0) + step.y * g(1) + step.z * g(2);
        let got = f64::from(read.value.0[c]);
        let terms = f64::from(record.value.0[c]).abs()
            + step
                .abs()
                .dot(glam::DVec3::new(g(0).abs(), g(1).abs(), g(2).abs()));
        assert!(
            (got - expected).abs() <= U32 * expected.abs() + 8.0 * U64 * terms,
            "channel {c}: {got} against {expected}"
        );
    }
}
