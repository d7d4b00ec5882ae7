//! Known answers: the estimated gradients against central differences of the closed-form
//! irradiance from an emitting polygon, for several placements of the emitter.

use crate::analytic::Scene;
use crate::{GatherSamples, TranslationGradient};
use glam::{DVec3, Vec3};
use irr_sampling::{Frame, HemisphereStrata, SampleKey};

/// An emitter placement: the scene, seen from the origin with normal +z.
pub struct Placement {
    pub name: &'static str,
    pub scene: Scene,
    /// The distance from the origin to the nearest point of the emitter (sets the step).
    pub nearest: f64,
}

fn quad(c: [[f64; 3]; 4]) -> Vec<DVec3> {
    c.iter().map(|&p| DVec3::from_array(p)).collect()
}

fn ceiling(h: f64) -> Option<(DVec3, DVec3)> {
    Some((DVec3::new(0.0, 0.0, h), DVec3::Z))
}

/// The four placements of the issue, each with an emitter of size 1 and radiance 1, under a
/// non-emitting ceiling that gives the background a finite distance.
pub fn placements() -> Vec<Placement> {
    vec![
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

/// Statistics of one estimator over K independent gathers.
pub struct Stats {
    pub exact_t: [f64; 3],
    pub exact_r: [f64; 3],
    pub mean_t: [f64; 3],
    pub mean_r: [f64; 3],
    /// Standard deviation of one gather's estimate, per component.
    pub sd_t: [f64; 3],
    pub sd_r: [f64; 3],
    /// RMS over gathers of the relative error ‖ĝ − g‖/‖g‖.
    pub rms_rel_t: f64,
    pub rms_rel_r: f64,
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub fn evaluate(
    p: &Placement,
    variant: TranslationGradient,
    strata: HemisphereStrata,
    seeds: u64,
) -> Stats {
    let frame = Frame::from_normal(Vec3::Z);
    let (exact_t, exact_r) = p
        .scene
        .finite_differences(DVec3::ZERO, &frame, 1e-4 * p.nearest);
    let mut sum_t = [0.0; 3];
    let mut sum_r = [0.0; 3];
    let mut sq_t = [0.0; 3];
    let mut sq_r = [0.0; 3];
    let (mut rel_t, mut rel_r) = (0.0, 0.0);
    for seed in 0..seeds {
        let g: GatherSamples<f32> =
            p.scene
                .gather(DVec3::ZERO, &frame, strata, SampleKey::new(seed, 0, 0));
        let grads = g.gradients(variant);
        let t = grads.translation.map(f64::from);
        let r = grads.rotation.map(f64::from);
        for a in 0..3 {
            sum_t[a] += t[a];
            sum_r[a] += r[a];
            sq_t[a] += t[a] * t[a];
            sq_r[a] += r[a] * r[a];
        }
        rel_t += (norm(sub(t, exact_t)) / norm(exact_t)).powi(2);
        rel_r += (norm(sub(r, exact_r)) / norm(exact_r)).powi(2);
    }
    let k = seeds as f64;
    let mean_t = sum_t.map(|s| s / k);
    let mean_r = sum_r.map(|s| s / k);
    let sd = |sq: f64, m: f64| ((sq / k - m * m).max(0.0) * k / (k - 1.0)).sqrt();
    Stats {
        exact_t,
        exact_r,
        mean_t,
        mean_r,
        sd_t: [0, 1, 2].map(|a| sd(sq_t[a], mean_t[a])),
        sd_r: [0, 1, 2].map(|a| sd(sq_r[a], mean_r[a])),
        rms_rel_t: (rel_t / k).sqrt(),
        rms_rel_r: (rel_r / k).sqrt(),
    }
}

#[test]
#[ignore = "prints the table of relative errors; run with --ignored --nocapture"]
fn gradient_table() {
    let sizes = [(8, 25), (16, 50), (32, 100), (64, 200)];
    println!(
        "placement | variant | M×N | rot rms rel | rot bias rel | trans rms rel | trans bias rel | exact t | mean t | sd t"
    );
    for p in placements() {
        for variant in [
            TranslationGradient::WardHeckbert,
            TranslationGradient::KrivanekGautron,
        ] {
            for (m, n) in sizes {
                let strata = HemisphereStrata::new(m, n).unwrap_or_else(|e| panic!("{e}"));
                let s = evaluate(&p, variant, strata, 64);
                println!(
                    "{} | {:?} | {}×{} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4?} | {:.4?} | {:.4?} | r {:.4?} {:.4?} {:.4?}",
                    p.name,
                    variant,
                    m,
                    n,
                    s.rms_rel_r,
                    norm(sub(s.mean_r, s.exact_r)) / norm(s.exact_r),
                    s.rms_rel_t,
                    norm(sub(s.mean_t, s.exact_t)) / norm(s.exact_t),
                    s.exact_t,
                    s.mean_t,
                    s.sd_t,
                    s.exact_r,
                    s.mean_r,
                    s.sd_r
                );
            }
        }
    }
}
