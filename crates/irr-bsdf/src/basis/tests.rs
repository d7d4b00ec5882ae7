//! The measurement sweeps that fill the module docs' tables are `#[ignore]`d (run them in
//! release with `--ignored --nocapture`); the asserted tests use small tables and grids.

use super::*;
use crate::testing::{spec_albedo, to_f32};

/// The relative L2 distance ‖a − b‖ / ‖b‖ of two coefficient vectors.
fn relative(a: &[f64], b: &[f64]) -> f64 {
    let d: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    let n: f64 = b.iter().map(|y| y * y).sum();
    (d / n).sqrt()
}

/// The Fresnel split is exact: f0·(Dν) + (f90 − f0)·(Dν w) equals `eval_lobes`' glossy part for
/// dielectrics, metals, mixtures and a specular weight. Both are f32 evaluations of the same
/// products of ≲ 20 operations from f64 values: relative difference ≲ 20 · 2⁻²⁴ ≈ 1.2e-6,
/// asserted at 1e-5 to cover f32's own D, ν formulas (rounded differently).
#[test]
fn fresnel_split_matches_eval_lobes() {
    let materials = [
        MetallicRoughness::new(Vec3::new(0.8, 0.5, 0.2), 0.0, 0.4),
        MetallicRoughness::new(Vec3::new(0.9, 0.6, 0.3), 1.0, 0.3),
        MetallicRoughness::new(Vec3::new(0.2, 0.7, 0.4), 0.5, 0.7),
        MetallicRoughness::with_specular(Vec3::new(0.5, 0.5, 0.5), 0.2, 0.6, 0.5),
    ];
    for m in materials {
        let alpha = f64::from(m.alpha());
        for cos_o in [0.2, 0.6, 0.95] {
            let wo = view(cos_o);
            for wi in [
                DVec3::new(-0.5, 0.1, 0.8),
                DVec3::new(-0.9, -0.2, 0.3),
                DVec3::new(0.3, 0.4, 0.85),
            ] {
                let wi = wi.normalize();
                let h = (wo + wi).normalize();
                let g = d_nu(alpha, wo, wi, h);
                let w = (1.0 - wo.dot(h)).powi(5);
                let f0 = m.specular_f0().as_dvec3();
                let df = m.specular_f90().as_dvec3() - f0;
                let split = f0 * g + df * (g * w);
                let want = m.eval_lobes(to_f32(wo), to_f32(wi)).glossy.as_dvec3();
                let err = (split - want).abs().max_element() / want.max_element();
                assert!(err < 1e-5, "{m:?} {cos_o} {wi}: {split} vs {want}");
            }
        }
    }
}

/// Uniform incoming radiance L: HSH's constant function is H_0^0 = 1/√(2π), so L's only
/// coefficient is c_0 = L √(2π) and the outgoing radiance c_0 b_0 must be L times the glossy
/// directional albedo, computed independently by testing.rs's `spec_albedo` (the
/// specification's f64 transcription, its own grid). Both quadratures' errors are estimated by
/// halving their grids (48² vs 24²); the table's entry is f32 (relative 6e-8), and the lookup at
/// a node interpolates nothing. The tolerance is the sum of both halving differences + 1e-6.
#[test]
fn uniform_light_gives_the_albedo() {
    let basis = Basis::hsh(2).unwrap_or_else(|e| panic!("{e}"));
    let table = GlossyTable::new(basis, 6, 6, 48).unwrap_or_else(|e| panic!("{e}"));
    let mut incoming = vec![Vec3::ZERO; basis.coefficient_count()];
    incoming[0] = Vec3::splat(TAU.sqrt() as f32);
    for (base, metallic) in [(Vec3::new(0.9, 0.6, 0.3), 1.0), (Vec3::splat(0.5), 0.0)] {
        for i in [2, 3, 5] {
            let roughness = i as f32 / 5.0;
            let m = MetallicRoughness::new(base, metallic, roughness);
            for j in [1, 3, 5] {
                // A node of the table's θo axis, so the lookup interpolates nothing.
                let cos_o = node_cos(f64::from(j) / 5.0) as f32;
                let got = table
                    .radiance(&m, cos_o, &incoming)
                    .unwrap_or_else(|e| panic!("{e}"))
                    .as_dvec3();
                let wo = view(f64::from(cos_o));
                let alpha = f64::from(m.alpha());
                let fine = spec_albedo(base.as_dvec3(), f64::from(metallic), alpha, wo, 48).1;
                let coarse = spec_albedo(base.as_dvec3(), f64::from(metallic), alpha, wo, 24).1;
                let (a_fine, _) = glossy_coefficients(basis, alpha, f64::from(cos_o), 48)
                    .unwrap_or_else(|e| panic!("{e}"));
                let (a_coarse, _) = glossy_coefficients(basis, alpha, f64::from(cos_o), 24)
                    .unwrap_or_else(|e| panic!("{e}"));
                let own = (a_fine[0] - a_coarse[0]).abs() / a_fine[0];
                let tol = (fine - coarse).abs().max_element() / fine.max_element() + own + 1e-6;
                let err = (got - fine).abs().max_element() / fine.max_element();
                assert!(
                    err <= tol,
                    "r {roughness} cos {cos_o}: {got} vs {fine} ({err} > {tol})"
                );
            }
        }
    }
}

/// Bad input is a typed error, never a panic.
#[test]
fn bad_input_is_an_error() {
    let basis = Basis::hsh(2).unwrap_or_else(|e| panic!("{e}"));
    assert!(matches!(
        GlossyTable::new(basis, 1, 4, 8),
        Err(BasisTableError::Resolution { .. })
    ));
    assert!(matches!(
        GlossyTable::new(basis, 4, 4, 0),
        Err(BasisTableError::Quadrature(0))
    ));
    assert!(matches!(
        GlossyTable::hsh(0),
        Err(BasisTableError::Basis(_))
    ));
    let table = GlossyTable::new(basis, 2, 2, 4).unwrap_or_else(|e| panic!("{e}"));
    let m = MetallicRoughness::new(Vec3::ONE, 1.0, 0.5);
    assert!(table.radiance(&m, 0.5, &[Vec3::ZERO; 3]).is_err());
}

/// At a node, the lookup returns the node's coefficients (bilinear weights 1, 0, 0, 0): equal to
/// direct quadrature up to the f32 rounding of the stored values (relative 2⁻²⁴ per entry) and
/// of the lookup's θo position (f32 acos: a few 2⁻²⁴ of the axis, times a relative change of the
/// coefficients across a cell ≤ 1): bound 1e-6.
#[test]
fn lookup_at_nodes_is_the_quadrature() {
    let basis = Basis::hsh(3).unwrap_or_else(|e| panic!("{e}"));
    let table = GlossyTable::new(basis, 3, 3, 16).unwrap_or_else(|e| panic!("{e}"));
    let (mut a, mut b) = (vec![0.0; 9], vec![0.0; 9]);
    table
        .lookup(0.5, node_cos(0.5) as f32, &mut a, &mut b)
        .unwrap_or_else(|e| panic!("{e}"));
    let (da, db) =
        glossy_coefficients(basis, 0.25, node_cos(0.5), 16).unwrap_or_else(|e| panic!("{e}"));
    let a: Vec<f64> = a.iter().map(|&x| f64::from(x)).collect();
    let b: Vec<f64> = b.iter().map(|&x| f64::from(x)).collect();
    assert!(relative(&a, &da) < 1e-6);
    assert!(relative(&b, &db) < 1e-6);
}

/// The interpolation error must shrink as the table is refined (bilinear: O(h²) for a smooth
/// lobe, so doubling the resolution should at least halve it; asserted as a strict halving,
/// which fails if interpolation were wrong, e.g. an off-by-one cell).
#[test]
fn interpolation_error_shrinks_with_resolution() {
    let basis = Basis::hsh(2).unwrap_or_else(|e| panic!("{e}"));
    let coarse = GlossyTable::new(basis, 5, 5, 24).unwrap_or_else(|e| panic!("{e}"));
    let fine = GlossyTable::new(basis, 9, 9, 24).unwrap_or_else(|e| panic!("{e}"));
    let e_coarse = interpolation_error(&coarse, 0.4, 0.2, 24).unwrap_or_else(|e| panic!("{e}"));
    let e_fine = interpolation_error(&fine, 0.4, 0.2, 24).unwrap_or_else(|e| panic!("{e}"));
    assert!(e_fine < 0.5 * e_coarse, "{e_fine} vs {e_coarse}");
}

/// Reconstruction of a lobe: raising the order must lower the error, since HSH of order n is a
/// subspace of order n + 2 and the coefficients are the orthogonal projection onto it. The
/// quadrature makes this only approximate (its discrete inner product leaves the basis
/// orthonormal within the quadrature error, ≲ 1e-2 at 32² nodes), while the decrease from order
/// to order at roughness 0.6 is several percent or more (module docs' table), so a strict
/// decrease is asserted.
#[test]
fn reconstruction_error_decreases_with_order() {
    let mut last = f64::INFINITY;
    for n in [2, 4, 6] {
        let basis = Basis::hsh(n).unwrap_or_else(|e| panic!("{e}"));
        let e = reconstruction_error(basis, 0.6, 0.7, 32).unwrap_or_else(|e| panic!("{e}"));
        assert!(e < last, "order {n}: {e} > {last}");
        last = e;
    }
}

/// Measurement: quadrature convergence (64² vs 128² nodes), HSH order 6.
#[test]
#[ignore = "measurement; run in release with --ignored --nocapture"]
fn quadrature_converges() {
    let basis = Basis::hsh(6).unwrap_or_else(|e| panic!("{e}"));
    for r in [0.1, 0.2, 0.4, 0.6, 0.8, 1.0] {
        let mut worst = [0.0f64; 2];
        for c in [0.05, 0.3, 0.6, 1.0] {
            let a32 = glossy_coefficients(basis, r * r, c, 32)
                .unwrap_or_else(|e| panic!("{e}"))
                .0;
            let a64 = glossy_coefficients(basis, r * r, c, 64)
                .unwrap_or_else(|e| panic!("{e}"))
                .0;
            let a128 = glossy_coefficients(basis, r * r, c, 128)
                .unwrap_or_else(|e| panic!("{e}"))
                .0;
            worst[0] = worst[0].max(relative(&a32, &a128));
            worst[1] = worst[1].max(relative(&a64, &a128));
        }
        println!("roughness {r}: 32² {:.1e}, 64² {:.1e}", worst[0], worst[1]);
    }
}

/// Measurement: table interpolation error against direct quadrature at cell midpoints.
#[test]
#[ignore = "measurement; run in release with --ignored --nocapture"]
fn interpolation_error_table() {
    let basis = Basis::hsh(6).unwrap_or_else(|e| panic!("{e}"));
    for res in [8, 16, 32, 64] {
        let table = GlossyTable::new(basis, res, res, 64).unwrap_or_else(|e| panic!("{e}"));
        let mut row = format!("{res}:");
        for min_r in [0.2, 0.4] {
            for min_cos in [0.0, 0.17, 0.5] {
                let e = interpolation_error(&table, min_r, min_cos, 64)
                    .unwrap_or_else(|e| panic!("{e}"));
                row += &format!(" r≥{min_r},cos≥{min_cos}: {e:.1e}");
            }
        }
        println!("{row}");
    }
}

/// Measurement: reconstruction error vs roughness and order (worst over view angles).
#[test]
#[ignore = "measurement; run in release with --ignored --nocapture"]
fn reconstruction_error_table() {
    for r in [0.2, 0.4, 0.6, 0.8, 1.0] {
        let mut row = format!("roughness {r}:");
        for n in [4, 6, 8, 10] {
            let basis = Basis::hsh(n).unwrap_or_else(|e| panic!("{e}"));
            let mut worst = 0.0f64;
            let mut cells = String::new();
            for c in [0.2, 0.5, 0.8, 1.0] {
                let e = reconstruction_error(basis, r, c, 64).unwrap_or_else(|e| panic!("{e}"));
                worst = worst.max(e);
                cells += &format!("{e:.3} ");
            }
            row += &format!(" | n={n}: {cells}");
        }
        println!("{row}");
    }
}

/// [`rotate_about_z`] against evaluation: the rotated coefficients reconstructed at a direction
/// with azimuth φ' must equal the original ones reconstructed at φ' + β. Both are sums of
/// n² = 16 f32 products of values ≲ 1: absolute difference ≲ 16 · 4 · 2⁻²⁴ ≈ 4e-6, asserted at
/// 1e-5. Checked for SH and HSH.
#[test]
fn rotation_about_z_matches_evaluation() {
    for basis in [Basis::sh(4), Basis::hsh(4)] {
        let basis = basis.unwrap_or_else(|e| panic!("{e}"));
        let original: Vec<f32> = (0..16).map(|k| ((k * 7 % 11) as f32 - 5.0) / 7.0).collect();
        let mut turned = original.clone();
        let beta = 0.7;
        rotate_about_z(basis, &mut turned, beta).unwrap_or_else(|e| panic!("{e}"));
        for (theta, phi) in [(0.3f64, 0.2f64), (1.1, 2.5), (0.8, -1.9)] {
            let at = |p: f64| DVec3::new(theta.sin() * p.cos(), theta.sin() * p.sin(), theta.cos());
            let new = basis
                .reconstruct(&turned, at(phi))
                .unwrap_or_else(|e| panic!("{e}"));
            let old = basis
                .reconstruct(&original, at(phi + beta))
                .unwrap_or_else(|e| panic!("{e}"));
            assert!(
                (new - old).abs() < 1e-5,
                "{basis:?} {theta} {phi}: {new} vs {old}"
            );
        }
    }
}

/// The SH version of the uniform-light answer: a constant L has the single SH coefficient
/// c_00 = L √(4π) (Y_0^0 = 1/√(4π)), and the lobe's SH coefficients (zero below the horizon)
/// give c_00 b_00 = L ∫ f cos θi dωi. Same grid for both sides, so they agree up to f32 rounding
/// of the table (2⁻²⁴ relative) and of the products (a few 2⁻²⁴): asserted at 1e-6 relative
/// against the HSH value, whose H_0^0 = 1/√(2π) gives the same integral.
#[test]
fn uniform_light_sh_matches_hsh() {
    let sh = Basis::sh(2).unwrap_or_else(|e| panic!("{e}"));
    let hsh = Basis::hsh(2).unwrap_or_else(|e| panic!("{e}"));
    let (a_sh, _) = glossy_coefficients(sh, 0.3, 0.6, 24).unwrap_or_else(|e| panic!("{e}"));
    let (a_hsh, _) = glossy_coefficients(hsh, 0.3, 0.6, 24).unwrap_or_else(|e| panic!("{e}"));
    let via_sh = a_sh[0] * (2.0 * TAU).sqrt();
    let via_hsh = a_hsh[0] * TAU.sqrt();
    assert!(
        (via_sh - via_hsh).abs() <= 1e-6 * via_hsh,
        "{via_sh} vs {via_hsh}"
    );
}

/// The residual's coefficients pair exactly with a band-limited function: for h of SH order n
/// on the sphere, Σ c_k r_k = ∫_{S²} h·r_n = ∫_{S²} h·r, since r_n is the projection of r (the
/// residual continued below the horizon by its mirror image) and h lies in the projected space;
/// folding the lower hemisphere onto the upper, that is ∫_{H²} (h(wi) + h(w̄i)) (f − ρ_d/π) dωi
/// with w̄i = (x, y, −z). So the table's answer must match a direct quadrature of the right
/// side (f from `eval_lobes`, ρ_d from `diffuse_albedo`) to the two quadratures' errors, each estimated by halving its grid, plus
/// f32 rounding (sums of 16 products: 1e-5 of the scale). The table's microfacet grid (384²
/// nodes) converges to first order only, and irregularly, since without the cosine the lobe
/// jumps to zero at the horizon, which cuts its cells (measured at roughness 0.8, cos θo 0.31:
/// 24, 48, 96, 192, 384 nodes give 0.934, 0.929, 0.920, 0.918, 0.920 against the direct
/// 0.920): its error is estimated as the larger difference to the grids of 192² and 96² nodes
/// (e_N ∝ 1/N makes either difference at least the finest grid's error, on average). The
/// direct rule is the midpoint rule in (cos θi, φi), 256 × 512 vs 128 × 256. At nodes of the
/// table, so its interpolation adds nothing.
#[test]
fn residual_pairs_with_band_limited_light() {
    let order = 4;
    let fine =
        ResidualTable::new(order, (6, 6), 384, &[(0.0, 1.0)]).unwrap_or_else(|e| panic!("{e}"));
    let coarse = [192, 96].map(|q| {
        ResidualTable::new(order, (6, 6), q, &[(0.0, 1.0)]).unwrap_or_else(|e| panic!("{e}"))
    });
    let basis = fine.basis();
    let count = basis.coefficient_count();
    let h: Vec<f64> = (0..count)
        .map(|k| {
            if k == 0 {
                2.0
            } else {
                ((k * 5 % 7) as f64 - 3.0) / 5.0
            }
        })
        .collect();
    let incoming: Vec<Vec3> = h.iter().map(|&x| Vec3::splat(x as f32)).collect();
    let mut scratch = vec![Vec3::ZERO; count];
    let direct = |m: &MetallicRoughness, wo: DVec3, rows: usize| {
        let columns = 2 * rows;
        let weight = TAU / (rows * columns) as f64;
        let stand_in = m.diffuse_albedo(to_f32(wo)).as_dvec3() / PI;
        let mut sum = DVec3::ZERO;
        let mut values = vec![0.0; count];
        for i in 0..rows {
            let z = (i as f64 + 0.5) / rows as f64;
            let s = (1.0 - z * z).sqrt();
            for k in 0..columns {
                let p = TAU * (k as f64 + 0.5) / columns as f64;
                let wi = DVec3::new(s * p.cos(), s * p.sin(), z);
                let mut hv = 0.0;
                for w in [wi, DVec3::new(wi.x, wi.y, -wi.z)] {
                    basis
                        .eval_f64(w, &mut values)
                        .unwrap_or_else(|e| panic!("{e}"));
                    hv += values.iter().zip(&h).map(|(a, b)| a * b).sum::<f64>();
                }
                let f = m.eval(to_f32(wo), to_f32(wi)).as_dvec3();
                sum += (f - stand_in) * (hv * weight);
            }
        }
        sum
    };
    for m in [
        MetallicRoughness::new(Vec3::new(0.8, 0.5, 0.2), 0.0, 0.6),
        MetallicRoughness::new(Vec3::new(0.9, 0.6, 0.3), 1.0, 0.8),
        MetallicRoughness::with_specular(Vec3::splat(0.5), 0.3, 1.0, 0.5),
    ] {
        for j in [1, 3, 4] {
            let cos_o = node_cos(f64::from(j) / 5.0);
            let wo = view(cos_o);
            let got = fine
                .radiance(&m, cos_o as f32, &incoming, &mut scratch)
                .unwrap_or_else(|e| panic!("{e}"))
                .as_dvec3();
            let own = coarse
                .iter()
                .map(|t| {
                    let v = t
                        .radiance(&m, cos_o as f32, &incoming, &mut scratch)
                        .unwrap_or_else(|e| panic!("{e}"))
                        .as_dvec3();
                    (got - v).abs().max_element()
                })
                .fold(0.0, f64::max);
            let want = direct(&m, wo, 256);
            let half = direct(&m, wo, 128);
            let scale = want.abs().max_element().max(1e-3);
            let tol = own + (want - half).abs().max_element() + 1e-5 * scale;
            let err = (got - want).abs().max_element();
            assert!(
                err <= tol,
                "{m:?} cos {cos_o}: {got} vs {want} ({err} > {tol})"
            );
        }
    }
}

/// The residual's coefficients are its mirror continuation's: those with l + m odd are zero
/// (exactly: multiplied by 0), so the reconstruction takes the same value at wi and at its
/// mirror image (x, y, −z); up to f32 rounding of sums of n² products, asserted at 1e-5 of the
/// coefficients' largest magnitude times n².
#[test]
fn residual_is_continued_by_its_mirror_image() {
    let order = 5;
    let table =
        ResidualTable::new(order, (6, 6), 48, &[(0.0, 1.0)]).unwrap_or_else(|e| panic!("{e}"));
    let basis = table.basis();
    let count = basis.coefficient_count();
    let m = MetallicRoughness::with_specular(Vec3::new(0.7, 0.5, 0.3), 0.4, 0.6, 0.8);
    let mut r = vec![Vec3::ZERO; count];
    table
        .coefficients(&m, 0.35, &mut r)
        .unwrap_or_else(|e| panic!("{e}"));
    for l in 0..order {
        for mm in -(l as isize)..=(l as isize) {
            if (l as isize + mm).rem_euclid(2) == 1 {
                assert_eq!(r[irr_sh::index(l, mm)], Vec3::ZERO, "({l}, {mm})");
            }
        }
    }
    let scale = r
        .iter()
        .map(|c| c.abs().max_element())
        .fold(0.0f32, f32::max);
    let mut values = vec![0.0f32; count];
    for wi in [Vec3::new(0.3, -0.2, 0.93), Vec3::new(-0.7, 0.6, 0.39)] {
        let wi = wi.normalize();
        let at = |w: Vec3, values: &mut [f32]| {
            basis.eval(w, values).unwrap_or_else(|e| panic!("{e}"));
            r.iter()
                .zip(values.iter())
                .map(|(c, y)| *c * *y)
                .sum::<Vec3>()
        };
        let up = at(wi, &mut values);
        let down = at(Vec3::new(wi.x, wi.y, -wi.z), &mut values);
        let tol = 1e-5 * scale * count as f32;
        assert!((up - down).abs().max_element() <= tol, "{up} vs {down}");
    }
}

/// The table's Parseval error √(1 − ‖b‖²/‖g‖²) against the direct reconstruction error
/// ‖g − Σ b_k B_k‖/‖g‖ on the same quadrature: expanding the direct one gives ‖g‖² − 2‖b‖² +
/// bᵀGb with G the quadrature's Gram matrix of the basis, so the two squared errors differ by
/// bᵀ(G − I)b/‖g‖², at most ‖G − I‖_F ‖b‖²/‖g‖². The test computes that bound from the
/// quadrature itself.
#[test]
fn parseval_error_matches_the_direct_reconstruction() {
    let basis = Basis::hsh(4).unwrap_or_else(|e| panic!("{e}"));
    let nodes = 24;
    let table = GlossyTable::new(basis, 5, 5, nodes).unwrap_or_else(|e| panic!("{e}"));
    let count = basis.coefficient_count();
    for i in [2usize, 3, 4] {
        let r = i as f64 / 4.0;
        let alpha = (r * r).max(f64::from(MIN_ALPHA));
        for j in [1usize, 2, 4] {
            let cos_o = node_cos(j as f64 / 4.0);
            let (b, _, _) = lobe_coefficients(basis, alpha, cos_o, nodes, Weighting::Cosine)
                .unwrap_or_else(|e| panic!("{e}"));
            let mut norm = 0.0;
            let wo = view(cos_o);
            for_each_node(alpha, cos_o, nodes, |wi, w, h| {
                norm += w * (d_nu(alpha, wo, wi, h) * wi.z).powi(2);
            });
            let mut gram = vec![0.0; count * count];
            let mut values = vec![0.0; count];
            for_each_node(alpha, cos_o, nodes, |wi, w, _| {
                basis
                    .eval_f64(wi, &mut values)
                    .unwrap_or_else(|e| panic!("{e}"));
                for (p, vp) in values.iter().enumerate() {
                    for (q, vq) in values.iter().enumerate() {
                        gram[p * count + q] += w * vp * vq;
                    }
                }
            });
            let frobenius: f64 = (0..count * count)
                .map(|e| {
                    let id = if e / count == e % count { 1.0 } else { 0.0 };
                    (gram[e] - id).powi(2)
                })
                .sum::<f64>()
                .sqrt();
            let kept: f64 = b.iter().map(|x| x * x).sum();
            let bound = frobenius * kept / norm + 1e-6;
            let parseval = f64::from(table.reconstruction_error(r as f32, cos_o as f32));
            let direct =
                reconstruction_error(basis, r, cos_o, nodes).unwrap_or_else(|e| panic!("{e}"));
            assert!(
                (parseval.powi(2) - direct.powi(2)).abs() <= bound,
                "r {r} cos {cos_o}: {parseval} vs {direct} (bound {bound})"
            );
        }
    }
}

/// The criterion radiance caching uses: [`ResidualTable::reconstruction_error`] (the
/// cosine-weighted lobe's Parseval error in real SH) for orders 4 to 10, roughness 0.2 to 1 and
/// cos θo = 0.2 / 0.5 / 0.8 / 1.0 (residual.rs's module docs).
#[test]
#[ignore = "measurement; run in release with --ignored --nocapture"]
fn sh_reconstruction_error_table() {
    let cosines = [0.2f32, 0.5, 0.8, 1.0];
    let orders = [4usize, 6, 8, 10];
    let tables: Vec<ResidualTable> = orders
        .iter()
        .map(|&n| ResidualTable::sh(n).unwrap_or_else(|e| panic!("{e}")))
        .collect();
    println!("| roughness | n = 4 | n = 6 | n = 8 | n = 10 |");
    println!("|---|---|---|---|---|");
    for r in [0.2f32, 0.4, 0.6, 0.8, 1.0] {
        let cells: Vec<String> = tables
            .iter()
            .map(|t| {
                cosines
                    .iter()
                    .map(|&c| format!("{:.2}", t.reconstruction_error(r, c)))
                    .collect::<Vec<_>>()
                    .join(" / ")
            })
            .collect();
        println!("| {r} | {} |", cells.join(" | "));
    }
}

/// A table built for some roughness ranges holds, in the rows it computes, the full table's
/// bits (the same quadratures), so lookups anywhere within the ranges are the full table's; a
/// lookup outside them is an error and its reconstruction error +∞, never a silent zero lobe.
/// Rows at 1/4 spacing (5 nodes): ranges {0.3} and [0.55, 0.6] need rows 1–2 and 2–3.
#[test]
fn a_table_within_ranges_is_the_full_table_there() {
    let basis = Basis::sh(3).unwrap_or_else(|e| panic!("{e}"));
    let build = |ranges: &[(f32, f32)]| {
        GlossyTable::within(basis, (5, 4), 8, Weighting::Plain, ranges)
            .unwrap_or_else(|e| panic!("{e}"))
    };
    let full = build(&[(0.0, 1.0)]);
    let part = build(&[(0.3, 0.3), (0.6, 0.55)]);
    let count = basis.coefficient_count();
    let lookup = |t: &GlossyTable, r: f32| {
        let (mut a, mut b) = (vec![0.0; count], vec![0.0; count]);
        t.lookup(r, 0.7, &mut a, &mut b).map(|()| (a, b))
    };
    for r in [0.25, 0.3, 0.42, 0.5, 0.55, 0.6] {
        assert!(part.tabulates(r), "{r}");
        assert_eq!(lookup(&part, r), lookup(&full, r), "{r}");
        assert_eq!(
            part.reconstruction_error(r, 0.7).to_bits(),
            full.reconstruction_error(r, 0.7).to_bits()
        );
    }
    for r in [0.0, 0.2, 0.75, 0.8, 1.0] {
        assert!(!part.tabulates(r), "{r}");
        assert_eq!(lookup(&part, r), Err(BasisTableError::Untabulated(r)));
        assert_eq!(part.reconstruction_error(r, 0.7), f32::INFINITY);
        let m = MetallicRoughness::new(Vec3::ONE, 1.0, r);
        let mut out = vec![Vec3::ZERO; count];
        assert!(part.coefficients(&m, 0.7, &mut out).is_err());
    }
}
