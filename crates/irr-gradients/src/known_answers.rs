//! Known answers: the estimated gradients against central differences of the closed-form
//! irradiance from an emitting polygon (Lambert's formula, [`crate::analytic`]), for four
//! placements of the emitter, both translation variants and three stratifications.
//!
//! # Where the estimators can be wrong, and by how much
//! Radiance is constant (L or 0) except across the emitter's outline, so only the cells the
//! outline passes through (the *straddled* cells, found by walking the outline) carry any error:
//! a cell wholly inside or outside the emitter is exact in the piecewise-constant model.
//!
//! - **Rotation**: the mean of K = 32 gathers (fixed seeds) must lie within a rigorous bias bound
//!   (what a straddled cell can get wrong in expectation, [`rotation_bias_per_cell`]) plus 5σ/√K,
//!   σ bounded analytically (a straddled cell's sample is a Bernoulli trial).
//! - **Translation**: every one of the K gathers must lie within 5σ̂ of the closed form, σ̂ the
//!   spread of the K gathers, plus a bound on the bias that the variant's wall weights and the
//!   distances taken beside the outline can cause ([`translation_bias`]). The staircase part of
//!   the cell-wall model's bias has no separate bound: the test asserts that it stays within one
//!   gather's noise (the table reports the bias as the error of the mean of K).
//!
//! The finite differences themselves are exact to ~1e-8 relative (see [`reference`]).

use crate::analytic::{Scene, clip_above};
use crate::{GatherSamples, TranslationGradient};
use glam::{DVec3, Vec2, Vec3};
use irr_sampling::{Cell, Frame, HemisphereStrata, SampleKey};
use std::collections::BTreeMap;
use std::f64::consts::{PI, TAU};

/// An emitter placement, seen from the origin with normal +z.
pub struct Placement {
    pub name: &'static str,
    pub scene: Scene,
    /// The distance from the origin to the nearest point of the emitter (sets the FD step).
    pub nearest: f64,
}

fn quad(c: [[f64; 3]; 4]) -> Vec<DVec3> {
    c.iter().map(|&p| DVec3::from_array(p)).collect()
}

fn ceiling(h: f64) -> Option<(DVec3, DVec3)> {
    Some((DVec3::new(0.0, 0.0, h), DVec3::Z))
}

/// The four placements, each an emitter of size 1 and radiance 1 under a
/// non-emitting ceiling (which gives the background a finite distance, so that the choice of the
/// nearer hit per wall matters). None is symmetric about the normal, so no gradient is zero.
pub fn placements() -> Vec<Placement> {
    vec![
        // Horizontal, overhead and off-centre: its outline passes 8.5° from the pole.
        Placement {
            name: "overhead",
            scene: Scene {
                emitter: quad([
                    [-0.15, -0.3, 1.0],
                    [0.85, -0.3, 1.0],
                    [0.85, 0.7, 1.0],
                    [-0.15, 0.7, 1.0],
                ]),
                radiance: 1.0,
                ceiling: ceiling(1.5),
            },
            nearest: 1.0,
        },
        // Vertical, 2 away, seen between 2.9° and 29° of elevation.
        Placement {
            name: "grazing",
            scene: Scene {
                emitter: quad([
                    [2.0, -0.2, 0.1],
                    [2.0, 0.8, 0.1],
                    [2.0, 0.8, 1.1],
                    [2.0, -0.2, 1.1],
                ]),
                radiance: 1.0,
                ceiling: ceiling(3.0),
            },
            nearest: 2.0,
        },
        // Vertical, crossing the horizon: its lower half is clipped away.
        Placement {
            name: "clipped",
            scene: Scene {
                emitter: quad([
                    [1.0, -0.3, -0.5],
                    [1.0, 0.7, -0.5],
                    [1.0, 0.7, 0.5],
                    [1.0, -0.3, 0.5],
                ]),
                radiance: 1.0,
                ceiling: ceiling(3.0),
            },
            nearest: 1.0,
        },
        // Horizontal, 1e-3 above the plane and 1e-3 beside the point: near contact.
        Placement {
            name: "contact",
            scene: Scene {
                emitter: quad([
                    [1e-3, -0.3, 1e-3],
                    [1.001, -0.3, 1e-3],
                    [1.001, 0.7, 1e-3],
                    [1e-3, 0.7, 1e-3],
                ]),
                radiance: 1.0,
                ceiling: ceiling(3.0),
            },
            nearest: 2f64.sqrt() * 1e-3,
        },
    ]
}

/// The variants, for loops.
pub const VARIANTS: [TranslationGradient; 2] = [
    TranslationGradient::WardHeckbert,
    TranslationGradient::KrivanekGautron,
];

/// The stratifications the assertions use (N ≈ πM, Ward & Heckbert's shape).
pub const SIZES: [(u32, u32); 3] = [(16, 50), (32, 100), (64, 200)];

/// Number of gathers (fixed seeds 0..K) averaged per configuration.
pub const K: u64 = 32;

fn strata(m: u32, n: u32) -> HemisphereStrata {
    HemisphereStrata::new(m, n).unwrap_or_else(|e| panic!("{e}"))
}

fn frame() -> Frame {
    Frame::from_normal(Vec3::Z)
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// (∇ₜE, ∇ᵣE) of the closed form by central differences, and a bound on their error.
///
/// Translation step h = 1e-4·d (d the nearest distance to the emitter, which sets the scale of
/// every derivative: E⁽ᵏ⁾ ~ E/dᵏ): truncation h²/6·|E'''| ≈ 1.7e-9·E/d, rounding of the f64
/// closed form ε·E/h ≈ 1e-12·E/d. Rotation step 1e-6 rad against the smallest angular feature
/// (1.4e-3 rad, the contact emitter's elevation): truncation ≲ (1e-6/1.4e-3)²/6 ≈ 1e-7 relative,
/// rounding 1e-16/1e-6 = 1e-10. We allow 1e-6·(E/d + E) for both, far above these.
pub fn reference(p: &Placement) -> ([f64; 3], [f64; 3], f64) {
    let (t, r) = p
        .scene
        .finite_differences(DVec3::ZERO, &frame(), 1e-4 * p.nearest);
    let e = p.scene.irradiance(DVec3::ZERO, DVec3::Z);
    (t, r, 1e-6 * (e / p.nearest + e))
}

/// The cells the emitter's outline passes through (the clipped polygon's edges, except the one
/// the clipping itself made along the horizon, which bounds the hemisphere, not a cell), each
/// with the range of 1/r along the outline inside it.
///
/// Each edge is a great-circle arc seen from the origin; it is walked in steps of a tenth of the
/// smallest cell extent (sin θ₁·2π/N, the azimuthal width at the pole), and every point marks
/// its cell and the cells of four points 1e-5 rad away in θ and φ, so that a point on a wall
/// (where the inverse warp rounds either way) marks both sides.
pub fn outline_cells(scene: &Scene, s: &HemisphereStrata) -> BTreeMap<(u32, u32), (f64, f64)> {
    let poly = clip_above(&scene.emitter, DVec3::ZERO, DVec3::Z);
    let on_horizon = |p: DVec3| p.z.abs() <= 1e-12 * p.length();
    let min_extent = (1.0 / f64::from(s.m())).sqrt() * TAU / f64::from(s.n());
    let step = 0.1 * min_extent;
    let mut cells: BTreeMap<(u32, u32), (f64, f64)> = BTreeMap::new();
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        if on_horizon(a) && on_horizon(b) {
            continue;
        }
        let angle = a.normalize().angle_between(b.normalize());
        let steps = (angle / step).ceil().max(1.0) as usize;
        for q in 0..=steps {
            let point = a + (b - a) * (q as f64 / steps as f64);
            let inv_r = 1.0 / point.length();
            let w = point.normalize();
            let theta = w.z.clamp(-1.0, 1.0).acos();
            let phi = w.y.atan2(w.x);
            for (dt, dp) in [
                (0.0, 0.0),
                (1e-5, 0.0),
                (-1e-5, 0.0),
                (0.0, 1e-5),
                (0.0, -1e-5),
            ] {
                let t = (theta + dt).clamp(0.0, PI / 2.0);
                let (st, ct) = t.sin_cos();
                let (sp, cp) = (phi + dp).sin_cos();
                let d = Vec3::new((st * cp) as f32, (st * sp) as f32, ct as f32);
                let c = s.cell_of(d);
                let e = cells.entry((c.j, c.k)).or_insert((inv_r, inv_r));
                e.0 = e.0.min(inv_r);
                e.1 = e.1.max(inv_r);
            }
        }
    }
    cells
}

/// The straddled cells: those [`outline_cells`] marks.
pub fn straddled_cells(scene: &Scene, s: &HemisphereStrata) -> Vec<Cell> {
    outline_cells(scene, s)
        .into_keys()
        .map(|(j, k)| Cell { j, k })
        .collect()
}

/// The bounds of row j in θ and the width of a column in φ.
fn row_bounds(s: &HemisphereStrata, j: u32) -> (f64, f64) {
    let th = |j: u32| {
        let u = f64::from(j) / f64::from(s.m());
        u.sqrt().atan2((1.0 - u).max(0.0).sqrt())
    };
    (th(j), th(j + 1))
}

/// |W| of a cell of row j in the rotation estimator: ∫ sin²θ dθ · 2 sin(π/N).
fn rotation_weight(s: &HemisphereStrata, j: u32) -> f64 {
    let (a, b) = row_bounds(s, j);
    let g = |t: f64| 0.5 * (t - t.sin() * t.cos());
    (g(b) - g(a)) * 2.0 * (PI / f64::from(s.n())).sin()
}

/// Rotation bias bound of one straddled cell of row j, per unit radiance:
/// D = ∫_cell |sin θ eφ(φ) − W·cos θ/A| dω with W the cell's weight vector and A = π/(MN).
///
/// Why: if the emitter covers the part Ω of the cell, the estimate's expectation is
/// L·P(hit)·W = L·(∫_Ω cos θ dω / A)·W, and the truth is L·∫_Ω sin θ eφ dω; their difference is
/// L·∫_Ω (sin θ eφ − W cos θ/A) dω, whose norm is at most L·D whatever Ω is. (A cell wholly
/// covered has difference 0: W is the cell's integral of sin θ eφ.) D does not depend on the
/// column (rotational symmetry). Midpoint rule on 64×16 points: its relative error O(1/64²) is
/// far below the other terms.
fn rotation_bias_per_cell(s: &HemisphereStrata, j: u32) -> f64 {
    let (a, b) = row_bounds(s, j);
    let dphi = TAU / f64::from(s.n());
    let area = PI / (f64::from(s.m()) * f64::from(s.n()));
    let w = rotation_weight(s, j);
    // The cell's weight vector points along eφ at the middle azimuth (take column 0).
    let (swm, cwm) = (0.5 * dphi).sin_cos();
    let wvec = [-swm * w, cwm * w];
    let (qt, qp) = (64, 16);
    let (dt, dp) = ((b - a) / f64::from(qt), dphi / f64::from(qp));
    let mut d = 0.0;
    for it in 0..qt {
        let t = a + (f64::from(it) + 0.5) * dt;
        let (st, ct) = t.sin_cos();
        for ip in 0..qp {
            let p = (f64::from(ip) + 0.5) * dp;
            let (sp, cp) = p.sin_cos();
            let ex = -st * sp - wvec[0] * ct / area;
            let ey = st * cp - wvec[1] * ct / area;
            d += (ex * ex + ey * ey).sqrt() * st * dt * dp;
        }
    }
    d
}

/// The rotation tolerance: Σ_straddled L·D (bias) + 5σ/√K, with σ² ≤ (L²/4)·Σ_straddled |W|²
/// (each straddled cell's radiance is L with probability f and 0 otherwise, variance
/// L² f(1−f) ≤ L²/4, independent between cells; the gather's other cells are constant). With
/// hundreds of straddled cells the sum is near Gaussian, and 5σ is exceeded with probability
/// ~1e-6; the seeds are fixed, so the outcome is deterministic in any case.
pub fn rotation_tolerance(scene: &Scene, s: &HemisphereStrata, k: u64) -> f64 {
    let cells = straddled_cells(scene, s);
    let per_row: Vec<f64> = (0..s.m()).map(|j| rotation_bias_per_cell(s, j)).collect();
    let bias: f64 = cells.iter().map(|c| per_row[c.j as usize]).sum::<f64>() * scene.radiance;
    let var: f64 = cells
        .iter()
        .map(|c| rotation_weight(s, c.j).powi(2))
        .sum::<f64>()
        * scene.radiance.powi(2)
        / 4.0;
    bias + 5.0 * (var / k as f64).sqrt()
}

/// A bound on the translation estimators' bias from two of its three sources, summed over the
/// straddled cells (the only cells whose walls carry a radiance difference). A wall's term is
/// ΔL·c/R with |ΔL| ≤ L, c the wall's weight and R the nearer of the two cells' hits.
///
/// 1. **The variant's wall weights.** In the piecewise-constant model the exact weight of a
///    θ-wall's tangent part is sin θⱼ cos² θⱼ · ∫ u dφ = sin θⱼ cos² θⱼ · 2 sin(π/N) (a chord),
///    where both papers write 2π/N; the φ-walls' exact weight is ∫ cos θ dθ = sin θⱼ₊₁ − sin θⱼ,
///    which Ward & Heckbert use and Křivánek & Gautron replace by cos θ꜀ (cos θⱼ − cos θⱼ₊₁)/sin θ꜀
///    (29 % short at the pole, 41 % long at the horizon). Per wall of a straddled cell:
///    L·max(1/r)·|c − c_exact|, the maximum over the two cells beside the wall.
/// 2. **1/R from a hit beside the wall.** The outline at the wall is at some distance r_edge in
///    the cell; the estimator divides by the distance of a hit in the cell or its neighbour
///    across the wall. Per wall of a straddled cell: L·|c|·(max − min of 1/r) over the two
///    cells, the range taken over the outline in the cell and the emitter hits of a 9×9 grid of
///    directions over each cell. (|c| of a θ-wall, tangent and normal parts together:
///    (2π/N) sin θⱼ cos θⱼ.)
/// 3. **The staircase.** In expectation the estimator puts the outline on the walls around its
///    crossing, interpolating the wall weights linearly (in sin² θ for θ-walls, in φ for
///    φ-walls): an error of second order per cell that largely cancels along the outline. It is
///    not bounded here; the tests leave it to their noise margin.
///
/// A wall between two straddled cells is counted twice (conservative).
pub fn translation_bias(scene: &Scene, s: &HemisphereStrata, variant: TranslationGradient) -> f64 {
    let (m, n) = (s.m(), s.n());
    let frame = frame();
    let outline = outline_cells(scene, s);
    let emitter_inv_r = |c: Cell, u: Vec2| {
        let d = frame.to_world(s.sample(c, u)).as_dvec3().normalize();
        let (l, r) = scene.trace(DVec3::ZERO, d);
        (l > 0.0).then(|| 1.0 / r)
    };
    let sb = |j: u32| (f64::from(j) / f64::from(m)).sqrt();
    let cb = |j: u32| (1.0 - f64::from(j) / f64::from(m)).max(0.0).sqrt();
    let x = PI / f64::from(n);
    let dphi = 2.0 * x;
    // Inner θ-walls only: none at the pole (j = 0) nor at the horizon (j = M, cos θ = 0).
    let inner = |j: u32| j > 0 && j < m;
    let theta_weight = |j: u32| if inner(j) { dphi * sb(j) * cb(j) } else { 0.0 };
    let theta_error = |j: u32| {
        if inner(j) {
            2.0 * (x - x.sin()) * sb(j) * cb(j) * cb(j)
        } else {
            0.0
        }
    };
    let phi_exact = |j: u32| sb(j + 1) - sb(j);
    let phi_kg = |j: u32| {
        let s2 = (f64::from(j) + 0.5) / f64::from(m);
        (1.0 - s2).sqrt() * (cb(j) - cb(j + 1)) / s2.sqrt()
    };
    let kg = variant == TranslationGradient::KrivanekGautron;
    let phi_weight = |j: u32| if kg { phi_kg(j) } else { phi_exact(j) };
    let phi_error = |j: u32| {
        if kg {
            (phi_kg(j) - phi_exact(j)).abs()
        } else {
            0.0
        }
    };
    // The range of 1/r over the emitter hits a cell can have: a 9×9 grid of directions over
    // the cell (walls included), and the outline's own points in it.
    let range = |j: u32, k: u32| {
        let (mut lo, mut hi) = outline
            .get(&(j, k))
            .copied()
            .unwrap_or((f64::INFINITY, 0.0));
        for a in 0..=8 {
            for b in 0..=8 {
                let u = Vec2::new(a as f32 / 8.0, b as f32 / 8.0);
                if let Some(v) = emitter_inv_r(Cell { j, k }, u) {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
        }
        (lo, hi)
    };
    let mut total = 0.0;
    for &(j, k) in outline.keys() {
        let own = range(j, k);
        // Each wall of the cell: its weight, its weight's error, and the neighbour across it.
        let walls = [
            (theta_weight(j), theta_error(j), (j > 0).then(|| (j - 1, k))),
            (
                theta_weight(j + 1),
                theta_error(j + 1),
                (j + 1 < m).then(|| (j + 1, k)),
            ),
            (phi_weight(j), phi_error(j), Some((j, (k + n - 1) % n))),
            (phi_weight(j), phi_error(j), Some((j, (k + 1) % n))),
        ];
        for (weight, error, neighbour) in walls {
            let (mut lo, mut hi) = own;
            if let Some((jn, kn)) = neighbour {
                let (l2, h2) = range(jn, kn);
                lo = lo.min(l2);
                hi = hi.max(h2);
            }
            if hi > 0.0 {
                total += error * hi + weight * (hi - lo.min(hi));
            }
        }
    }
    total * scene.radiance
}

/// One configuration's estimates over K gathers.
pub struct Run {
    pub mean_t: [f64; 3],
    pub mean_r: [f64; 3],
    /// √(Σₐ σ̂ₐ²): the spread of one gather's translation estimate (all components).
    pub spread_t: f64,
    /// RMS over the gathers of ‖ĝ − g‖, translation and rotation.
    pub rms_t: f64,
    pub rms_r: f64,
    /// The largest ‖ĝ − g‖ of one gather, translation.
    pub max_t: f64,
}

pub fn run(
    p: &Placement,
    variant: TranslationGradient,
    s: HemisphereStrata,
    k: u64,
    exact: ([f64; 3], [f64; 3]),
) -> Run {
    let mut sum_t = [0.0; 3];
    let mut sum_r = [0.0; 3];
    let mut sq_t = [0.0; 3];
    let (mut err_t, mut err_r, mut max_t) = (0.0, 0.0, 0.0f64);
    for seed in 0..k {
        let g: GatherSamples<f32> =
            p.scene
                .gather(DVec3::ZERO, &frame(), s, SampleKey::new(seed, 0, 0));
        let grads = g.gradients(variant);
        let t = grads.translation.map(f64::from);
        let r = grads.rotation.map(f64::from);
        for a in 0..3 {
            sum_t[a] += t[a];
            sum_r[a] += r[a];
            sq_t[a] += t[a] * t[a];
        }
        max_t = max_t.max(norm(sub(t, exact.0)));
        err_t += norm(sub(t, exact.0)).powi(2);
        err_r += norm(sub(r, exact.1)).powi(2);
    }
    let kf = k as f64;
    let mean_t = sum_t.map(|v| v / kf);
    let var: f64 = (0..3)
        .map(|a| (sq_t[a] / kf - mean_t[a] * mean_t[a]).max(0.0) * kf / (kf - 1.0))
        .sum();
    Run {
        mean_t,
        mean_r: sum_r.map(|v| v / kf),
        spread_t: var.sqrt(),
        rms_t: (err_t / kf).sqrt(),
        rms_r: (err_r / kf).sqrt(),
        max_t,
    }
}

/// The rotation gradient of the mean of K gathers is within its derived tolerance of the
/// closed form's, for every placement and stratification; and the tolerance at 64×200 is
/// tight enough to catch a 25 % error in the gradient (under 1 % overhead and clipped, ~20 %
/// for the grazing and contact emitters, whose outlines straddle many near-horizon cells).
#[test]
fn rotation_gradient_matches_the_closed_form() {
    for p in placements() {
        let (t, r, fd) = reference(&p);
        for (m, n) in SIZES {
            let s = strata(m, n);
            let run = run(&p, TranslationGradient::WardHeckbert, s, K, (t, r));
            let err = norm(sub(run.mean_r, r));
            let tol = rotation_tolerance(&p.scene, &s, K) + fd;
            assert!(
                err <= tol,
                "{} {m}×{n}: ‖∇ᵣE − exact‖ = {err:.3e} > {tol:.3e} (exact {r:?}, mean {:?})",
                p.name,
                run.mean_r
            );
            if m == 64 {
                assert!(
                    tol < 0.25 * norm(r),
                    "{}: tolerance {tol:.3e} too loose",
                    p.name
                );
            }
        }
    }
}

/// Every one of K gathers' translation gradient is within its tolerance of the closed form's,
/// for every placement, variant and stratification: 5σ̂ + the bias bound of
/// [`translation_bias`] (wall weights and distances), σ̂ the spread of one gather's estimate (√ of the summed per-component
/// variances over the K gathers; with K = 32 its relative error is ~1/√(2K) ≈ 13 %, so 5σ̂ is
/// still ≥ 4σ). For a 3D Gaussian error P(‖e‖ > 4σ) ≈ 1e-3 per gather and P(‖e‖ > 5σ) ≈ 2e-5.
///
/// What this asserts beyond the noise: the third source of bias (the staircase of cell walls
/// standing in for the outline) is not bounded separately: the test claims it stays within the
/// noise of one gather. The table ([`gradient_table`]) reports that bias (the mean of K's error) beside it.
#[test]
fn translation_gradient_matches_the_closed_form() {
    for p in placements() {
        let (t, r, fd) = reference(&p);
        for variant in VARIANTS {
            for (m, n) in SIZES {
                let s = strata(m, n);
                let run = run(&p, variant, s, K, (t, r));
                let bias = translation_bias(&p.scene, &s, variant);
                let tol = 5.0 * run.spread_t + bias + fd;
                assert!(
                    run.max_t <= tol,
                    "{} {variant:?} {m}×{n}: max ‖∇ₜE − exact‖ = {:.3e} > {tol:.3e} \
                     (σ̂ {:.3e}, bias bound {bias:.3e}; exact {t:?}, mean {:?})",
                    p.name,
                    run.max_t,
                    run.spread_t,
                    run.mean_t
                );
                // Power: what error this tolerance can still see. The bounds add every straddled
                // wall's worst case without the cancellation along the outline, so they are 10–30
                // times the actual error (see the table). Measured ratios tol/‖∇ₜE‖ over the four
                // placements: Ward–Heckbert 0.64–1.08 at 16×50, 0.33–0.66 at 32×100, 0.14–0.42 at
                // 64×200; Křivánek–Gautron 0.82–3.05, 0.41–2.50, 0.18–0.95. So:
                // - both variants at 64×200 see a lost gradient (an error of ‖t‖), and the
                //   default variant there a factor of 2 (an error of ½‖t‖);
                // - the default variant sees a flipped sign (2‖t‖) at every size.
                // Křivánek–Gautron's bias bound is too loose at coarse strata to see anything;
                // `cell_aligned` checks both variants exactly there (8×25, 16×50, 32×100).
                let power = match (variant, m) {
                    (TranslationGradient::WardHeckbert, 64) => Some(0.5),
                    (_, 64) => Some(1.0),
                    (TranslationGradient::WardHeckbert, _) => Some(2.0),
                    _ => None,
                };
                if let Some(power) = power {
                    assert!(
                        tol < power * norm(t),
                        "{} {variant:?} {m}×{n}: tolerance {tol:.3e} ≥ {power}·‖∇ₜE‖ = {:.3e}: \
                         the test could not see that error",
                        p.name,
                        power * norm(t)
                    );
                }
            }
        }
    }
}

/// Prints the table of relative errors of the report (placement × variant × M×N).
#[test]
#[ignore = "prints the error table; run with --ignored --nocapture"]
fn gradient_table() {
    println!(
        "| placement | variant | M×N | ∇ᵣE rms rel. (1 gather) | ∇ᵣE rel. (mean of {K}) | ∇ᵣE tol. rel. | ∇ₜE rms rel. (1 gather) | ∇ₜE rel. (mean of {K}) | ∇ₜE max rel. (1 gather) | ∇ₜE tol. rel. |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for p in placements() {
        let (t, r, fd) = reference(&p);
        for variant in VARIANTS {
            for (m, n) in [(8, 25)].into_iter().chain(SIZES) {
                let s = strata(m, n);
                let run = run(&p, variant, s, K, (t, r));
                let rot_tol = rotation_tolerance(&p.scene, &s, K) + fd;
                let tr_tol = translation_bias(&p.scene, &s, variant) + 5.0 * run.spread_t + fd;
                let (nt, nr) = (norm(t), norm(r));
                println!(
                    "| {} | {variant:?} | {m}×{n} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} |",
                    p.name,
                    run.rms_r / nr,
                    norm(sub(run.mean_r, r)) / nr,
                    rot_tol / nr,
                    run.rms_t / nt,
                    norm(sub(run.mean_t, t)) / nt,
                    run.max_t / nt,
                    tr_tol / nt,
                );
            }
        }
    }
}
