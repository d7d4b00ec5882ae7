//! Known answers for the triangle fan (`hessian` module): the edge integrals against quadrature,
//! one emitting triangle against central differences of Lambert's formula, the fan's own
//! triangles held fixed while the viewpoint moves, a step's closed-form curvature converging as
//! the strata grow, exact scaling, and the eigen-decomposition.

use crate::analytic::{Scene, fixed_config, gauss_legendre};
use crate::hessian::{accumulate, fan_triangles, with_horizon};
use crate::hessian::{edge_integrals, edge_terms};
use crate::{Curvature, GatherSamples};
use glam::{DMat3, DVec3};
use irr_sampling::{HemisphereStrata, SampleKey};
use proptest::prelude::*;
use std::f64::consts::PI;

/// ∫₀¹ f by 16-point Gauss–Legendre on `panels` equal panels.
fn quadrature<T: std::ops::Add<Output = T> + std::ops::Mul<f64, Output = T>>(
    panels: usize,
    zero: T,
    f: impl Fn(f64) -> T,
) -> T {
    // The rule on [−1, 1] carried to [0, 1].
    let rule: Vec<(f64, f64)> = gauss_legendre(16)
        .into_iter()
        .map(|(x, w)| (0.5 * (1.0 - x), 0.5 * w))
        .collect();
    let h = 1.0 / panels as f64;
    let mut sum = zero;
    for p in 0..panels {
        for &(x, w) in &rule {
            sum = sum + f((p as f64 + x) * h) * (w * h);
        }
    }
    sum
}

/// (Ω, ∇Ω, ∇∇Ω) of an edge by quadrature of the integrands of the module docs.
fn edge_terms_by_quadrature(a: DVec3, b: DVec3) -> (f64, DVec3, DMat3) {
    let e = b - a;
    let c = a.cross(b);
    let n_x_e = DVec3::new(-e.y, e.x, 0.0);
    let panels = 256;
    let i1 = quadrature(panels, 0.0, |t| 1.0 / (a + e * t).length_squared());
    let i2 = quadrature(panels, 0.0, |t| (a + e * t).length_squared().powi(-2));
    let g = quadrature(panels, DVec3::ZERO, |t| {
        let r = a + e * t;
        r / r.length_squared().powi(2)
    });
    let m = quadrature(panels, DMat3::ZERO, |t| {
        let r = a + e * t;
        DMat3::from_cols(r * r.x, r * r.y, r * r.z) * r.length_squared().powi(-3)
    });
    let ng = DMat3::from_cols(n_x_e * g.x, n_x_e * g.y, n_x_e * g.z);
    (
        0.5 * c.z * i1,
        0.5 * (n_x_e * i1 + 2.0 * c.z * g),
        ng + ng.transpose() + (m * 4.0 - DMat3::IDENTITY * i2) * c.z,
    )
}

fn max_abs(m: &DMat3) -> f64 {
    m.to_cols_array()
        .iter()
        .fold(0.0f64, |acc, v| acc.max(v.abs()))
}

fn strata(m: u32, n: u32) -> HemisphereStrata {
    HemisphereStrata::new(m, n).unwrap_or_else(|e| panic!("{e}"))
}

/// A point in the upper half-space at distance in [0.3, 3].
fn above() -> impl Strategy<Value = DVec3> {
    (0.0f64..1.0, 0.0f64..1.0, 0.3f64..3.0).prop_map(|(u, v, r)| {
        let z = 0.05 + 0.95 * u;
        let s = (1.0 - z * z).sqrt();
        let phi = 2.0 * PI * v;
        DVec3::new(s * phi.cos(), s * phi.sin(), z) * r
    })
}

proptest! {
    #![proptest_config(fixed_config(64, 0x4e55))]

    /// The closed forms of I₁ … K₃ against 256 panels of 16-point Gauss–Legendre.
    ///
    /// Quadrature error: each integrand is analytic with its nearest complex singularity at the
    /// segment's distance h ≥ 0.3·sin θ-ish from the origin; with edges of length ≤ 6 and the
    /// cases below (sin² θ ≥ 10⁻²: h/|e| ≥ 0.01), a panel is 1/256 of the edge, ≤ 0.4 h, where a
    /// 16-point rule errs by ~(0.2)³² ≈ 10⁻²², far below rounding. Closed-form rounding: the
    /// reduction divides by Δ = 4|c|² twice; relative to the integrals' size the error is
    /// ≲ ε·(AC/Δ)²·C/A ≲ 2·10⁻¹⁶·(25)²·100 ≈ 1.4·10⁻¹¹ (the K₃ step divides by A = |e|²; C/A ≤
    /// 100 here). Bound: 10⁻¹⁰ of each integral.
    #[test]
    fn edge_integrals_match_quadrature(a in above(), b in above()) {
        let c2 = a.cross(b).length_squared();
        prop_assume!(c2 >= 1e-2 * a.length_squared() * b.length_squared());
        prop_assume!(a.length_squared() <= 100.0 * (b - a).length_squared());
        let e = b - a;
        let q = |t: f64| (a + e * t).length_squared();
        let by_quadrature = [
            quadrature(256, 0.0, |t| 1.0 / q(t)),
            quadrature(256, 0.0, |t| q(t).powi(-2)),
            quadrature(256, 0.0, |t| t * q(t).powi(-2)),
            quadrature(256, 0.0, |t| q(t).powi(-3)),
            quadrature(256, 0.0, |t| t * q(t).powi(-3)),
            quadrature(256, 0.0, |t| t * t * q(t).powi(-3)),
        ];
        let closed = edge_integrals(a, b);
        for (got, want) in closed.iter().zip(by_quadrature) {
            prop_assert!((got - want).abs() <= 1e-10 * want.abs(), "{closed:?} vs {by_quadrature:?}");
        }
    }

    /// `edge_terms` against quadrature of its integrands, on either side of the near-collinear
    /// switch. Well-conditioned edges: 10⁻⁹ of the largest term (the integrals' 10⁻¹⁰ above,
    /// times the handful of terms summed). Near-collinear edges (b on a's line, pushed off it by
    /// sin θ ∈ [10⁻⁶, 10⁻²)): moving b onto the line changes |r| by ≤ |b| sin θ, so each
    /// integrand by ≤ 6 sin θ relative (|r|⁻⁶), the directions by ≤ sin θ: 10·sin θ.
    #[test]
    fn edge_terms_match_quadrature(a in above(), b in above(), t in 0.2f64..5.0, off in -6.0f64..-2.0) {
        let (omega, grad, hess) = edge_terms(a, b);
        let (qo, qg, qh) = edge_terms_by_quadrature(a, b);
        let c2 = a.cross(b).length_squared() / (a.length_squared() * b.length_squared());
        prop_assume!(c2 >= 1e-2 && a.length_squared() <= 100.0 * (b - a).length_squared());
        let scale = max_abs(&qh).max(qg.abs().max_element()).max(qo.abs());
        prop_assert!((omega - qo).abs() <= 1e-9 * scale);
        prop_assert!((grad - qg).abs().max_element() <= 1e-9 * scale);
        prop_assert!(max_abs(&(hess - qh)) <= 1e-9 * scale, "{hess:?} vs {qh:?}");

        // Near-collinear: b' along a, at t·|a|, pushed sideways by 10^off.
        let side = a.any_orthonormal_vector();
        let sin = 10f64.powf(off);
        let b2 = (a + side * (a.length() * sin)).normalize() * (t * a.length());
        prop_assume!((b2 - a).length() > 0.05 * a.length());
        let (omega, grad, hess) = edge_terms(a, b2);
        let (qo, qg, qh) = edge_terms_by_quadrature(a, b2);
        let scale = max_abs(&qh).max(qg.abs().max_element()).max(qo.abs());
        let bound = 10.0 * sin * scale + 1e-9 * scale;
        prop_assert!((omega - qo).abs() <= bound);
        prop_assert!((grad - qg).abs().max_element() <= bound);
        prop_assert!(max_abs(&(hess - qh)) <= bound, "{hess:?} vs {qh:?} at sin {sin}");
    }
}

/// The sum of `edge_terms` around one emitting triangle is the derivative of Lambert's formula:
/// Ω against the closed form, ∇Ω and ∇∇Ω against central differences of it. The Hessian is
/// symmetric and reversing the triangle negates everything.
///
/// Central differences with step h = 10⁻³·d (d the nearest corner's distance): truncation
/// h²/6·|f'''| ≈ 10⁻⁶/6·f/d³·d² relative for the gradient, h²/12·|f''''| for the second
/// differences, ~10⁻⁷ of the scale; rounding ε·f/h² ≈ 2·10⁻¹⁶·10⁶ = 2·10⁻¹⁰. Bound: 10⁻⁵ of the
/// largest entry (the fourth derivatives of 1/r-type terms carry factors up to ~5! = 120).
#[test]
fn one_triangle_against_lambert() {
    let triangles = [
        [
            DVec3::new(0.2, -0.3, 1.0),
            DVec3::new(1.1, 0.1, 0.8),
            DVec3::new(-0.4, 0.9, 1.4),
        ],
        [
            DVec3::new(2.0, -1.0, 0.3),
            DVec3::new(2.5, 1.5, 0.6),
            DVec3::new(1.5, 0.5, 2.0),
        ],
        [
            DVec3::new(-0.1, -0.1, 0.2),
            DVec3::new(0.1, -0.1, 0.25),
            DVec3::new(0.0, 0.2, 0.3),
        ],
    ];
    for tri in triangles {
        let scene = Scene {
            emitter: tri.to_vec(),
            radiance: 1.0,
            ceiling: None,
        };
        let sum = |corners: [DVec3; 3]| {
            (0..3).fold((0.0, DVec3::ZERO, DMat3::ZERO), |acc, i| {
                let (o, g, h) = edge_terms(corners[i], corners[(i + 1) % 3]);
                (acc.0 + o, acc.1 + g, acc.2 + h)
            })
        };
        let (omega, grad, hess) = sum(tri);
        let sign = omega.signum();
        let f = |x: DVec3| scene.irradiance(x, DVec3::Z);
        assert!((sign * omega - f(DVec3::ZERO)).abs() <= 1e-12 * f(DVec3::ZERO));

        let d = tri.iter().map(|p| p.length()).fold(f64::INFINITY, f64::min);
        let h = 1e-3 * d;
        let axes = [DVec3::X, DVec3::Y, DVec3::Z];
        let mut fd_grad = DVec3::ZERO;
        let mut fd_hess = DMat3::ZERO;
        for i in 0..3 {
            // The viewpoint moves by +h: the corners move by −h relative to it.
            fd_grad[i] = (f(axes[i] * h) - f(-axes[i] * h)) / (2.0 * h);
            for j in 0..3 {
                let (ei, ej) = (axes[i] * h, axes[j] * h);
                let v = (f(ei + ej) - f(ei - ej) - f(-ei + ej) + f(-ei - ej)) / (4.0 * h * h);
                fd_hess.col_mut(j)[i] = v;
            }
        }
        let scale = max_abs(&fd_hess).max(fd_grad.abs().max_element());
        assert!(
            (sign * grad - fd_grad).abs().max_element() <= 1e-5 * scale,
            "{grad} vs {fd_grad}"
        );
        assert!(
            max_abs(&(hess * sign - fd_hess)) <= 1e-5 * scale,
            "{hess:?} vs {fd_hess:?}"
        );
        // Symmetric: (n×e)gᵀ + g(n×e)ᵀ and ∫rrᵀ are symmetric term by term.
        assert!(max_abs(&(hess - hess.transpose())) <= 1e-14 * max_abs(&hess));
        // Reversed winding: every edge reversed.
        let (o2, g2, h2) = sum([tri[0], tri[2], tri[1]]);
        assert!((o2 + omega).abs() <= 1e-12 * omega.abs());
        assert!((g2 + grad).abs().max_element() <= 1e-12 * scale);
        assert!(max_abs(&(h2 + hess)) <= 1e-10 * scale);
    }
}

/// A gather of the analytic scene at the origin (normal +z) as the fan's points: the hit
/// points, misses at 10³ times the farthest hit (as `GatherSamples::fan` puts them), and the
/// horizon ring; with each point's value (the ring's from the row above).
fn gather_points(scene: &Scene, s: HemisphereStrata, seed: u64) -> (Vec<DVec3>, Vec<f64>) {
    let key = SampleKey::new(seed, 5, 0);
    let mut dirs = Vec::new();
    let mut values = Vec::new();
    for cell in s.cells() {
        let w = s
            .sample(cell, key.uniform_2d(cell.index(&s)))
            .as_dvec3()
            .normalize();
        let (l, r) = scene.trace(DVec3::ZERO, w);
        dirs.push((w, r));
        values.push(l);
    }
    let far = 1e3
        * dirs
            .iter()
            .map(|d| d.1)
            .filter(|r| r.is_finite())
            .fold(0.0, f64::max);
    let points = dirs
        .iter()
        .map(|&(w, r)| w * if r.is_finite() { r } else { far })
        .collect();
    let n = s.n() as usize;
    let last = values.len() - n;
    values.extend_from_within(last..);
    (with_horizon(points, n), values)
}

/// The fan's triangles held fixed in space while the viewpoint moves: with the values chosen
/// once at the origin, the fan's irradiance is a smooth function of the viewpoint, and the
/// fan's gradient and Hessian (with the values as weights, /π) are its derivatives. This checks
/// the edge bookkeeping (signs, shared edges, the pole's fan) apart from the triangulation's
/// value rule, for grids with and without quads (M = 1: the pole's fan alone).
#[test]
fn fan_held_fixed_matches_its_differences() {
    let scene = Scene {
        emitter: vec![
            DVec3::new(-0.2, -0.3, 0.6),
            DVec3::new(0.8, -0.3, 0.6),
            DVec3::new(0.8, 0.7, 0.9),
            DVec3::new(-0.2, 0.7, 0.9),
        ],
        radiance: 1.0,
        ceiling: Some((DVec3::new(0.0, 0.0, 1.3), DVec3::Z)),
    };
    for (m, n) in [(1, 5), (3, 8), (6, 20)] {
        let s = strata(m, n);
        let (points, values) = gather_points(&scene, s, 7);
        // Background cells of value 0.25 so that the ceiling's edges count too.
        let values: Vec<f64> = values.iter().map(|&l| l + 0.25).collect();
        let rows = m as usize + 1;
        let triangles = fan_triangles(rows, n as usize);
        let chosen: Vec<f64> = triangles
            .iter()
            .map(|t| values[t.farthest(&points)])
            .collect();
        let fan_at = |x: DVec3| {
            let moved: Vec<DVec3> = points.iter().map(|&p| p - x).collect();
            accumulate(
                rows,
                n as usize,
                &moved,
                &triangles,
                chosen.iter().map(|&v| (v, v as f32)),
            )
        };
        let here = fan_at(DVec3::ZERO);
        let d = points
            .iter()
            .map(|p| p.length())
            .fold(f64::INFINITY, f64::min);
        let h = 1e-3 * d;
        let axes = [DVec3::X, DVec3::Y, DVec3::Z];
        // The gradient is the fan's ∇E (the values as weights); the Hessian with the same
        // weights is ∇∇E/π: central differences of the gradient give it.
        let mut fd_hess = DMat3::ZERO;
        for (j, axis) in axes.into_iter().enumerate() {
            let gp = fan_at(axis * h).gradient;
            let gm = fan_at(-axis * h).gradient;
            for i in 0..3 {
                fd_hess.col_mut(j)[i] = f64::from(gp[i] - gm[i]) / (2.0 * h) / PI;
            }
        }
        let scale = max_abs(&here.hessian);
        // The gradients are f32 (value type): their difference over 2h carries rounding
        // 2^-24·|∇|/h ≈ 6·10⁻⁸·|∇|/(10⁻³ d) relative to |H| ~ |∇|/d: ≈ 6·10⁻⁵; bound 10⁻³.
        assert!(
            max_abs(&(here.hessian - fd_hess)) <= 1e-3 * scale,
            "{m}×{n}: {:?} vs {fd_hess:?}",
            here.hessian
        );
        // And the irradiance: the fan's E against the stratified estimate, short by the band.
        let e_fan = f64::from(here.irradiance);
        assert!(e_fan > 0.0, "{m}×{n}: the fan's winding gives E = {e_fan}");
    }
}

/// Scaling every hit point by 2ᵏ scales the Hessian by 2⁻²ᵏ and the gradient by 2⁻ᵏ exactly:
/// every operation in `edge_terms` is a product or quotient of lengths, and the near-collinear
/// switch compares ratios; powers of two are exact in binary floating point.
#[test]
fn scaling_is_exact() {
    let scene = Scene {
        emitter: vec![
            DVec3::new(-0.5, -0.3, 0.6),
            DVec3::new(0.8, -0.3, 0.6),
            DVec3::new(0.8, 0.7, 0.9),
        ],
        radiance: 2.0,
        ceiling: Some((DVec3::new(0.0, 0.0, 1.1), DVec3::Z)),
    };
    let s = strata(5, 16);
    let (points, values) = gather_points(&scene, s, 3);
    let triangles = fan_triangles(6, 16);
    let weights = |pts: &[DVec3]| -> Vec<(f64, f32)> {
        triangles
            .iter()
            .map(|t| {
                let v = values[t.farthest(pts)];
                (v, v as f32)
            })
            .collect()
    };
    let base = accumulate(6, 16, &points, &triangles, weights(&points).into_iter());
    for k in [-10i32, 10] {
        let f = 2f64.powi(k);
        let scaled: Vec<DVec3> = points.iter().map(|&p| p * f).collect();
        let fan = accumulate(6, 16, &scaled, &triangles, weights(&scaled).into_iter());
        assert_eq!(fan.hessian, base.hessian * (f * f).recip());
        for a in 0..3 {
            assert_eq!(fan.gradient[a], base.gradient[a] * (1.0 / f) as f32);
        }
    }
}

/// A step: a long wall strip of height H at perpendicular distance d, radiance L, darkness
/// elsewhere (every other ray misses). E = (πL/2)(1 − d/√(d² + H²)), so
/// ∂²E/∂y² = (3πL/2)·d·H²/(d² + H²)^{5/2} towards the wall and ∂²E/∂x² = 0 along it. The fan's
/// Hessian with the wall's values as weights (×π) converges to it as the strata grow: the
/// error falls at each ×4 of the cells. The table is printed (`--nocapture`); measured:
///
/// | strata | H_yy | rel. error | |H_xx|/H_yy exact |
/// |---|---|---|---|
/// | 8×32 | 0.7509 | 0.349 | 0.060 |
/// | 16×64 | 0.6524 | 0.172 | 0.040 |
/// | 32×128 | 0.6040 | 0.085 | 0.028 |
/// | exact | 0.5568 | | 0 |
///
/// Without the horizon ring the fan stops at the last row and the errors are 0.248, 0.105,
/// 0.015 for H_yy (a band of the wall missing, partly cancelling the staircase) and 0.147,
/// 0.103, 0.089 for H_xx (the band's slanted edge: no convergence to 0).
#[test]
fn step_curvature_converges() {
    let (d, height, half) = (1.0f64, 1.5f64, 1e3f64);
    let scene = Scene {
        emitter: vec![
            DVec3::new(-half, d, 0.0),
            DVec3::new(half, d, 0.0),
            DVec3::new(half, d, height),
            DVec3::new(-half, d, height),
        ],
        radiance: 1.0,
        ceiling: None,
    };
    let q = d * d + height * height;
    let exact_yy = 1.5 * PI * d * height * height / q.powf(2.5);
    let mut errors = Vec::new();
    for (m, n) in [(8u32, 32u32), (16, 64), (32, 128)] {
        let s = strata(m, n);
        let (points, values) = gather_points(&scene, s, 1);
        let triangles = fan_triangles(m as usize + 1, n as usize);
        let w: Vec<(f64, f32)> = triangles
            .iter()
            .map(|t| {
                let v = values[t.farthest(&points)];
                (v, v as f32)
            })
            .collect();
        let fan = accumulate(
            m as usize + 1,
            n as usize,
            &points,
            &triangles,
            w.into_iter(),
        );
        let yy = fan.hessian.y_axis.y * PI;
        let xx = fan.hessian.x_axis.x * PI;
        let err = (yy - exact_yy).abs() / exact_yy;
        println!("{m}×{n}: H_yy {yy:.5} (exact {exact_yy:.5}, rel. error {err:.4}), H_xx {xx:.5}");
        errors.push((err, xx.abs() / exact_yy, yy));
    }
    // The fan's error is first order in the cell size (the staircase of piecewise-constant
    // triangles along the wall's top edge), so each doubling of M and N should halve it: require
    // at least 1.5×. Richardson's extrapolation 2·H(h/2) − H(h) of the last two grids removes
    // the first-order term; what remains is second order, about the change between the two
    // extrapolations (measured 0.3 %): require 1 %.
    let (h1, h2) = (errors[1].2, errors[2].2);
    assert!(
        errors[0].0 > 1.5 * errors[1].0 && errors[1].0 > 1.5 * errors[2].0,
        "{errors:?}"
    );
    let richardson = 2.0 * h2 - h1;
    assert!(
        (richardson - exact_yy).abs() < 0.01 * exact_yy,
        "{richardson} vs {exact_yy}"
    );
    // Along the wall the exact curvature is 0; the fan's comes from the same staircase and
    // falls with the cells.
    assert!(
        errors[0].1 > errors[1].1 && errors[1].1 > errors[2].1,
        "{errors:?}"
    );
}

/// An open sky (no hit at all) has zero gradient and Hessian; an all-black gather gives the
/// purely geometric Hessian (finite, symmetric).
#[test]
fn sky_and_black_gathers() {
    let s = strata(4, 12);
    let sky =
        GatherSamples::from_fn(s, |_| (1.0f32, f32::INFINITY)).unwrap_or_else(|e| panic!("{e}"));
    let fan = sky.fan();
    assert_eq!(fan.hessian, DMat3::ZERO);
    assert_eq!(fan.gradient, [0.0; 3]);
    let black =
        GatherSamples::from_fn(s, |c| (0.0f32, 1.0 + c.j as f32)).unwrap_or_else(|e| panic!("{e}"));
    let fan = black.fan();
    assert!(fan.hessian.is_finite() && max_abs(&fan.hessian) > 0.0);
    assert!(max_abs(&(fan.hessian - fan.hessian.transpose())) <= 1e-12 * max_abs(&fan.hessian));
}

/// The 2×2 eigen-decomposition: known matrices, a negative eigenvalue, a double root, and the
/// reconstruction λ₁uuᵀ + λ₂vvᵀ for random symmetric blocks.
#[test]
fn curvature_of_known_blocks() {
    let block = |a: f64, b: f64, d: f64| {
        DMat3::from_cols(DVec3::new(a, b, 0.0), DVec3::new(b, d, 0.0), DVec3::ZERO)
    };
    let c = Curvature::of(&block(1.0, 0.0, 4.0));
    assert_eq!((c.major, c.minor), (4.0, 1.0));
    assert!((c.axis.abs() - DVec3::Y).length() < 1e-15);
    // Eigenvalues 3 and −5 along (1, 1)/√2 and (1, −1)/√2: |−5| is the major.
    let c = Curvature::of(&block(-1.0, 4.0, -1.0));
    assert!((c.major - 5.0).abs() < 1e-14 && (c.minor - 3.0).abs() < 1e-14);
    assert!((c.axis.x.abs() - c.axis.y.abs()).abs() < 1e-14 && c.axis.x * c.axis.y < 0.0);
    // A double root: any axis, equal radii.
    let c = Curvature::of(&block(2.0, 0.0, 2.0));
    assert_eq!(c.major, c.minor);
    for (a, b, d) in [(0.3, -1.2, 2.2), (-4.0, 0.5, 1.0), (1e-9, 3e-10, -2e-9)] {
        let c = Curvature::of(&block(a, b, d));
        let u = c.axis;
        let v = DVec3::new(-u.y, u.x, 0.0);
        let h = block(a, b, d);
        // u and v are eigenvectors: (Hu)·v = 0, and |u·Hu| = major, |v·Hv| = minor.
        let scale = a.abs().max(b.abs()).max(d.abs());
        assert!((h * u).dot(v).abs() <= 1e-14 * scale);
        assert!(((h * u).dot(u).abs() - c.major).abs() <= 1e-14 * scale);
        assert!(((h * v).dot(v).abs() - c.minor).abs() <= 1e-14 * scale);
    }
}

/// The fan's gradient (through `GatherSamples::with_directions` and
/// `TranslationGradient::OcclusionFan`) against central differences of Lambert's formula for the
/// known-answer placements, as the strata grow; printed (`--nocapture`). Relative error of the
/// vector, measured:
///
/// | placement | 8×32 | 16×64 | 32×128 |
/// |---|---|---|---|
/// | overhead | 0.351 | 0.194 | 0.095 |
/// | grazing | 0.546 | 0.163 | 0.175 |
/// | clipped | 0.693 | 0.189 | 0.090 |
/// | contact | 0.223 | 0.137 | 0.060 |
///
/// First order in the cell size and short of the closed form (a triangle shows its farthest
/// corner, so the emitter's outline is drawn inside it); the wall model's estimators are more
/// accurate on these one-emitter scenes (`known_answers`). What the fan adds is the Hessian, and
/// a gradient that sees occluders (module docs). The test asks for the error at 32×128 to be
/// at most half that at 8×32 (the grazing placement's third step stalls on one cell row).
#[test]
fn fan_gradient_converges_on_the_placements() {
    use crate::TranslationGradient;
    use crate::known_answers::{placements, reference};
    use irr_sampling::Frame;
    for p in placements() {
        let (want, _, _) = reference(&p);
        let norm = want.iter().map(|v| v * v).sum::<f64>().sqrt();
        let mut errors = Vec::new();
        for (m, n) in [(8u32, 32u32), (16, 64), (32, 128)] {
            let s = strata(m, n);
            let frame = Frame::from_normal(glam::Vec3::Z);
            let key = SampleKey::new(11, 5, 0);
            let dirs: Vec<glam::Vec3> = s
                .cells()
                .map(|cell| {
                    frame
                        .to_world(s.sample(cell, key.uniform_2d(cell.index(&s))))
                        .normalize()
                })
                .collect();
            let g = p
                .scene
                .gather(DVec3::ZERO, &frame, s, key)
                .with_directions(dirs)
                .unwrap_or_else(|e| panic!("{e}"));
            let got = g.translation_gradient(TranslationGradient::OcclusionFan);
            let err = (0..3)
                .map(|a| (f64::from(got[a]) - want[a]).powi(2))
                .sum::<f64>()
                .sqrt()
                / norm;
            println!("{} {m}×{n}: {got:?} vs {want:?}: {err:.4}", p.name);
            errors.push(err);
        }
        assert!(errors[2] <= 0.5 * errors[0], "{}: {errors:?}", p.name);
    }
}
