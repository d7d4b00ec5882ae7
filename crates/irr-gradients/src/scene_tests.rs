//! Whole-configuration tests through the ray caster of [`crate::analytic`]: invariance under
//! a rigid motion of everything, and what the gradients buy when irradiance is interpolated
//! between a few records (with them on and off).
//!
//! The interpolation here is a stand-in (two bracketing records, inverse-distance weights, the
//! first-order extrapolation of Ward & Heckbert 1992, written inline): irr-gradients may
//! not depend on irr-cache. The full cache test, with Ward's weights and the radius limit, comes
//! with the integrator.

use crate::analytic::{Scene, fixed_config, rotate};
use crate::known_answers::placements;
use crate::{Gradients, TranslationGradient};
use glam::{DVec3, Vec3};
use irr_sampling::{Frame, HemisphereStrata, SampleKey};
use proptest::prelude::*;

fn strata(m: u32, n: u32) -> HemisphereStrata {
    HemisphereStrata::new(m, n).unwrap_or_else(|e| panic!("{e}"))
}

fn to_vec(g: &[f32; 3]) -> Vec3 {
    Vec3::new(g[0], g[1], g[2])
}

proptest! {
    #![proptest_config(fixed_config(16, 0x71d))]

    /// Moving the whole configuration rigidly (emitter, ceiling, point, and the gather's frame
    /// turned with it) and turning the world-space gradients back gives the same gradients.
    ///
    /// The cells' rays are the same rays turned, so every cell sees the same radiance (checked)
    /// and a distance equal to ~1e-6 relative (f32 frames and f64 geometry rounded to f32).
    /// The gradients then agree to that relative precision of Σ|terms|, which is at most
    /// 2·L·max 1/r·(π(M − 1) + N) (see `gradient::tests::tolerances`); we allow 1e-5 of it.
    #[test]
    fn gradients_are_invariant_under_rigid_motions(
        ax in -1.0f64..1.0, ay in -1.0f64..1.0, az in -1.0f64..1.0,
        angle in -3.0f64..3.0,
        tx in -100.0f64..100.0, ty in -100.0f64..100.0, tz in -100.0f64..100.0,
    ) {
        let axis = DVec3::new(ax, ay, az);
        prop_assume!(axis.length() > 1e-2);
        let axis = axis.normalize();
        let t = DVec3::new(tx, ty, tz);
        let scene = &placements()[0].scene;
        let moved = scene.transformed(axis, angle, t, 1.0);
        let s = strata(16, 50);
        let key = SampleKey::new(9, 9, 9);
        let frame = Frame::from_normal(Vec3::Z);
        let turn = |v: Vec3| rotate(v.as_dvec3(), axis, angle).as_vec3();
        let frame2 = Frame { s: turn(frame.s), t: turn(frame.t), n: turn(frame.n) };
        let g1 = scene.gather(DVec3::ZERO, &frame, s, key);
        let g2 = moved.gather(t, &frame2, s, key);
        prop_assert_eq!(g1.radiance(), g2.radiance());
        for (a, b) in g1.distance().iter().zip(g2.distance()) {
            prop_assert!(a == b || (a - b).abs() <= 1e-5 * a, "{a} vs {b}");
        }
        let inv_r_max = g1.distance().iter().map(|&r| 1.0 / r).fold(0.0f32, f32::max);
        let sum_terms = 2.0 * inv_r_max * (std::f32::consts::PI * 15.0 + 50.0);
        for variant in [TranslationGradient::WardHeckbert, TranslationGradient::KrivanekGautron] {
            let w1 = g1.gradients(variant).in_world(&frame);
            let w2 = g2.gradients(variant).in_world(&frame2);
            let t1 = turn(to_vec(&w1.translation));
            let t2 = to_vec(&w2.translation);
            prop_assert!((t1 - t2).length() <= 1e-5 * sum_terms, "{t1} vs {t2}");
            let r1 = turn(to_vec(&w1.rotation));
            let r2 = to_vec(&w2.rotation);
            // The rotation gradient reads radiance only: equal up to the frames' rounding.
            prop_assert!((r1 - r2).length() <= 1e-5 * (1.0 + r1.length()), "{r1} vs {r2}");
        }
    }

    /// Scaling the whole configuration about the point by s scales every distance by s: the
    /// translation gradient scales by 1/s and the rotation gradient is unchanged (radiance and
    /// directions are the same). Tolerance as above, relative to the scaled Σ|terms|.
    #[test]
    fn scaling_the_scene_scales_the_translation_gradient(log_s in -4.0f64..4.0) {
        let sc = 10f64.powf(log_s);
        let scene = &placements()[0].scene;
        let scaled = scene.transformed(DVec3::Z, 0.0, DVec3::ZERO, sc);
        let s = strata(16, 50);
        let key = SampleKey::new(3, 1, 4);
        let frame = Frame::from_normal(Vec3::Z);
        let g1 = scene.gather(DVec3::ZERO, &frame, s, key);
        let g2 = scaled.gather(DVec3::ZERO, &frame, s, key);
        prop_assert_eq!(g1.radiance(), g2.radiance());
        let inv_r_max = g1.distance().iter().map(|&r| 1.0 / r).fold(0.0f32, f32::max);
        let sum_terms = 2.0 * inv_r_max * (std::f32::consts::PI * 15.0 + 50.0);
        let a = g1.gradients(TranslationGradient::WardHeckbert);
        let b = g2.gradients(TranslationGradient::WardHeckbert);
        prop_assert_eq!(a.rotation, b.rotation);
        let expected = to_vec(&a.translation) / sc as f32;
        let got = to_vec(&b.translation);
        prop_assert!((expected - got).length() <= 1e-5 * sum_terms / sc as f32, "{expected} vs {got}");
    }
}

/// A record: position, normal, harmonic mean distance and gradients in world space.
struct Record {
    p: DVec3,
    n: Vec3,
    r: f64,
    g: Gradients<f32>,
}

fn records(scene: &Scene, points: &[(DVec3, DVec3)]) -> Vec<Record> {
    let s = strata(64, 200);
    points
        .iter()
        .enumerate()
        .map(|(i, &(p, n))| {
            let frame = Frame::from_normal(n.as_vec3());
            let g = scene.gather(p, &frame, s, SampleKey::new(2024, i as u64, 0));
            Record {
                p,
                n: frame.n,
                r: f64::from(g.harmonic_mean_distance()),
                g: g.gradients(TranslationGradient::WardHeckbert)
                    .in_world(&frame),
            }
        })
        .collect()
}

/// RMS relative error against the closed form at `queries`, interpolating with gradients off
/// and on: Ward's weights wᵢ = 1/(‖p − pᵢ‖/Rᵢ + √(1 − n·nᵢ)) (Ward, Rubinstein & Clear 1988,
/// the weight of the split-sphere model) over the records with wᵢ > 1/a, a = 0.2, each record's value either Eᵢ or its
/// first-order extrapolation Eᵢ + (p − pᵢ)·∇ₜEᵢ + (nᵢ × n)·∇ᵣEᵢ.
fn interpolation_errors(
    scene: &Scene,
    records: &[Record],
    queries: &[(DVec3, DVec3)],
) -> (f64, f64) {
    // Ward's accuracy a: 0.1–0.2 in practice; with Rᵢ ≈ 2.1 here, a = 0.2 lets each record
    // serve points within ~0.42, just covering the gaps between records 0.4 apart.
    let a = 0.2;
    let (mut off, mut on, mut count) = (0.0, 0.0, 0.0);
    for &(p, n) in queries {
        let exact = scene.irradiance(p, n);
        let (mut w_sum, mut e_off, mut e_on) = (0.0, 0.0, 0.0);
        for r in records {
            let d = (p - r.p).length() / r.r + (1.0 - n.dot(r.n.as_dvec3())).max(0.0).sqrt();
            if d >= a {
                continue;
            }
            let w = 1.0 / d.max(1e-12);
            w_sum += w;
            e_off += w * f64::from(r.g.irradiance);
            e_on += w * f64::from(r.g.extrapolate((p - r.p).as_vec3(), r.n.cross(n.as_vec3())));
        }
        assert!(w_sum > 0.0, "no record covers {p}");
        off += ((e_off / w_sum - exact) / exact).powi(2);
        on += ((e_on / w_sum - exact) / exact).powi(2);
        count += 1.0;
    }
    ((off / count).sqrt(), (on / count).sqrt())
}

/// With the gradients on, interpolating between a few records reproduces the closed-form
/// irradiance with a smaller error than with them off: on a flat grid of records under the
/// overhead emitter, and on an arch (where the normals turn and the rotation gradient and the
/// normal component of the translation gradient take part). The ratios are printed (run with
/// --nocapture); see the crate's report for the figures.
///
/// Why a plain comparison suffices: each record's E is accurate to ~0.3 % (64×200 cells),
/// while between records 0.4 apart under a unit emitter at height 1, E changes by ~30 %; the
/// weights blend records unevenly (a record dominates near itself), so without gradients the
/// error is first order in the distance to the records and with them second order.
#[test]
fn gradients_reduce_the_interpolation_error() {
    let scene = &placements()[0].scene;
    // A 6×5 grid of records, 0.4 apart, under and around the overhead emitter; queries on a
    // finer grid that avoids the records themselves.
    let grid: Vec<(DVec3, DVec3)> = (0..6)
        .flat_map(|i| {
            (0..5).map(move |j| {
                (
                    DVec3::new(-0.6 + 0.4 * f64::from(i), -0.5 + 0.4 * f64::from(j), 0.0),
                    DVec3::Z,
                )
            })
        })
        .collect();
    let queries: Vec<(DVec3, DVec3)> = (0..9)
        .flat_map(|i| {
            (0..7).map(move |j| {
                (
                    DVec3::new(
                        -0.45 + 0.17 * f64::from(i),
                        -0.35 + 0.17 * f64::from(j),
                        0.0,
                    ),
                    DVec3::Z,
                )
            })
        })
        .collect();
    let (off, on) = interpolation_errors(scene, &records(scene, &grid), &queries);
    println!(
        "flat grid: RMS relative error {off:.4} without gradients, {on:.4} with; ratio {:.2}",
        off / on
    );
    assert!(on < off, "flat: {on} ≥ {off}");

    // An arch: a cylinder of radius 1.5 about an axis along y, its top at z = 0 below the
    // emitter's middle; records every 0.25 rad, queries at ¼, ½ and ¾ of each gap.
    let centre = DVec3::new(0.35, 0.1, -1.5);
    let arch = |a: f64| {
        let n = DVec3::new(a.sin(), 0.0, a.cos());
        (centre + n * 1.5, n)
    };
    let angles = [-0.75, -0.5, -0.25, 0.0, 0.25, 0.5, 0.75];
    let points: Vec<(DVec3, DVec3)> = angles.iter().map(|&a| arch(a)).collect();
    let queries: Vec<(DVec3, DVec3)> = angles
        .windows(2)
        .flat_map(|w| [0.25, 0.5, 0.75].map(|t| arch(w[0] + t * (w[1] - w[0]))))
        .collect();
    let (off, on) = interpolation_errors(scene, &records(scene, &points), &queries);
    println!(
        "arch: RMS relative error {off:.4} without gradients, {on:.4} with; ratio {:.2}",
        off / on
    );
    assert!(on < off, "arch: {on} ≥ {off}");
}
