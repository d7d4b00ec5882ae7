//! Exact answers where the estimators' model is exact: an emitter that fills whole cells.
//!
//! The emitter is a patch of a sphere of radius R centred on the gather point, bounded by the
//! cell walls θ = θ_ja, θ_jb and φ = φ_ka, φ_kb. Every cell is then wholly covered or wholly
//! empty and every hit is at distance R, so the gather is the same for every jitter (no noise),
//! the radiance really is constant per cell, and the walls on the patch's outline really lie at
//! distance R: the piecewise-constant model of `gradient.rs` holds exactly. What remains between
//! an estimate and the truth is only
//! - for the rotation gradient: nothing (each cell's weight is its exact integral) but f32
//!   rounding;
//! - for the translation gradient: the variant's approximate wall weights — Ward & Heckbert's
//!   2π/N for the θ-walls' ∫ u dφ = 2 sin(π/N), and Křivánek & Gautron's φ-wall weight — whose
//!   signed effect is computed exactly below and added to the truth; the tolerance is rounding.
//!
//! The truth is the derivative of the patch's irradiance, by central differences of a
//! Gauss–Legendre quadrature of E(x, n) = L ∫ cos θₓ cos θ_y / d² dA over the patch (f64).

use crate::analytic::gauss_legendre;
use crate::{GatherSamples, TranslationGradient};
use glam::DVec3;
use irr_sampling::HemisphereStrata;
use std::f64::consts::{PI, TAU};

/// A spherical patch: radius R about the origin, θ ∈ [θa, θb], φ ∈ [φa, φb], radiance L.
struct Patch {
    r: f64,
    theta: (f64, f64),
    phi: (f64, f64),
    l: f64,
}

impl Patch {
    /// E at x with normal n (only the patch's part above the tangent plane counts; here the
    /// patch stays well above it).
    fn irradiance(&self, x: DVec3, n: DVec3) -> f64 {
        // 16 nodes on each of 8 panels: the smooth integrands here are exact to ~1e-15.
        let gl = gauss_legendre(16);
        let panels = 8;
        let mut sum = 0.0;
        let (ta, tb) = self.theta;
        let (pa, pb) = self.phi;
        let (dt, dp) = ((tb - ta) / panels as f64, (pb - pa) / panels as f64);
        for it in 0..panels {
            for ip in 0..panels {
                for &(xt, wt) in &gl {
                    let t = ta + dt * (it as f64 + 0.5 * (xt + 1.0));
                    let (st, ct) = t.sin_cos();
                    for &(xp, wp) in &gl {
                        let p = pa + dp * (ip as f64 + 0.5 * (xp + 1.0));
                        let (sp, cp) = p.sin_cos();
                        let w = DVec3::new(st * cp, st * sp, ct);
                        let y = w * self.r;
                        let v = y - x;
                        let d2 = v.length_squared();
                        let cos_x = n.dot(v).max(0.0);
                        // The patch faces the origin (normal −w); two-sided.
                        let cos_y = w.dot(v).abs();
                        let da = self.r * self.r * st * (0.5 * dt) * (0.5 * dp);
                        sum += wt * wp * cos_x * cos_y / (d2 * d2) * da;
                    }
                }
            }
        }
        self.l * sum
    }
}

fn rotate(v: DVec3, axis: DVec3, angle: f64) -> DVec3 {
    let (s, c) = angle.sin_cos();
    v * c + axis.cross(v) * s + axis * axis.dot(v) * (1.0 - c)
}

/// One configuration: the patch over rows [ja, jb) and columns [ka, kb) of an M×N strata.
fn check(m: u32, n: u32, rows: (u32, u32), cols: (u32, u32), r: f64) {
    let strata = HemisphereStrata::new(m, n).unwrap_or_else(|e| panic!("{e}"));
    let (ja, jb) = rows;
    let (ka, kb) = cols;
    let l = 2.0;
    let patch = Patch {
        r,
        theta: (
            f64::from(strata.theta_bound(ja)),
            f64::from(strata.theta_bound(jb)),
        ),
        phi: (
            TAU * f64::from(ka) / f64::from(n),
            TAU * f64::from(kb) / f64::from(n),
        ),
        l,
    };
    // θ bounds in f64 from the exact sin² θ = j/M (theta_bound is f32).
    let th = |j: u32| {
        let u = f64::from(j) / f64::from(m);
        u.sqrt().atan2((1.0 - u).sqrt())
    };
    let patch = Patch {
        theta: (th(ja), th(jb)),
        ..patch
    };
    let inside = |j: u32, k: u32| (ja..jb).contains(&j) && (ka..kb).contains(&k);
    let gather = GatherSamples::from_fn(strata, |c| {
        if inside(c.j, c.k) {
            (l as f32, r as f32)
        } else {
            (0.0f32, f32::INFINITY)
        }
    })
    .unwrap_or_else(|e| panic!("{e}"));

    // Central differences: h = 1e-4·R (truncation (h/R)²/6 ≈ 2e-9 relative, rounding of the
    // ~1e-15-accurate quadrature 1e-15/1e-4 = 1e-11); rotation step 1e-6 rad (truncation
    // ~1e-12, rounding 1e-9 relative).
    let (x, nrm) = (DVec3::ZERO, DVec3::Z);
    let h = 1e-4 * r;
    let axes = [DVec3::X, DVec3::Y, DVec3::Z];
    let t_exact = axes
        .map(|a| (patch.irradiance(x + a * h, nrm) - patch.irradiance(x - a * h, nrm)) / (2.0 * h));
    let ha = 1e-6;
    let r_exact = [DVec3::X, DVec3::Y].map(|a| {
        (patch.irradiance(x, rotate(nrm, a, ha)) - patch.irradiance(x, rotate(nrm, a, -ha)))
            / (2.0 * ha)
    });
    let e_exact = patch.irradiance(x, nrm);

    // The irradiance: the cells' projected solid angle is exact, so only rounding remains
    // (≤ (M + N + 2)ε relative, see samples.rs); the quadrature agrees to ~1e-15.
    let e = f64::from(gather.irradiance());
    let tol_e = f64::from(m + n + 2) * f64::from(f32::EPSILON) * e_exact;
    assert!((e - e_exact).abs() <= tol_e, "E {e} vs {e_exact}");

    // Rotation: exact up to f32 rounding. Each of the ≤ MN products and M + N sums rounds by
    // ≤ ε/2 relative to the sum of the magnitudes Σ|terms| ≤ L·Σ_cells |W| ≤ L·π (|W| ≤ the
    // cell's solid angle, the hemisphere's is 2π); the weights themselves are f64 rounded to f32.
    let rot = gather.rotation_gradient().map(f64::from);
    let tol_r = 4.0 * f64::from(m + n + 2) * f64::from(f32::EPSILON) * l * 2.0 * PI + 1e-9;
    for a in 0..2 {
        assert!(
            (rot[a] - r_exact[a]).abs() <= tol_r,
            "rotation {a}: {} vs {} (tol {tol_r:e}), {m}×{n} rows {rows:?} cols {cols:?}",
            rot[a],
            r_exact[a]
        );
    }
    assert_eq!(rot[2], 0.0);

    // Translation: each variant's estimate is the truth plus the exact, signed effect of its
    // approximate weights on the patch's outline walls (a wall's term is ΔL·c/R):
    // - θ-walls at ja (ΔL = +L, unless at the pole) and jb (ΔL = −L, unless at the horizon), one
    //   per column k, along u(φ꜀): both papers write 2π/N for ∫ u dφ = 2 sin(π/N);
    // - φ-walls at ka (ΔL = +L) and kb (ΔL = −L), one per row j, along eφ: Křivánek & Gautron's
    //   weight cos θ꜀ (cos θⱼ − cos θⱼ₊₁)/sin θ꜀ against the exact sin θⱼ₊₁ − sin θⱼ.
    let x_pi = PI / f64::from(n);
    let sb = |j: u32| (f64::from(j) / f64::from(m)).sqrt();
    let cb = |j: u32| (1.0 - f64::from(j) / f64::from(m)).sqrt();
    let theta_dev = |j: u32| {
        if j == 0 || j == m {
            0.0
        } else {
            2.0 * (x_pi - x_pi.sin()) * sb(j) * cb(j) * cb(j)
        }
    };
    let mut wh_dev = DVec3::ZERO;
    for k in ka..kb {
        let (sp, cp) = ((f64::from(k) + 0.5) * 2.0 * x_pi).sin_cos();
        wh_dev += DVec3::new(cp, sp, 0.0) * (l / r) * (theta_dev(ja) - theta_dev(jb));
    }
    let mut kg_dev = wh_dev;
    for j in ja..jb {
        let s2 = (f64::from(j) + 0.5) / f64::from(m);
        let kg = (1.0 - s2).sqrt() * (cb(j) - cb(j + 1)) / s2.sqrt();
        let d = (kg - (sb(j + 1) - sb(j))) * l / r;
        let e_phi = |k: u32| {
            let (sp, cp) = (f64::from(k) * 2.0 * x_pi).sin_cos();
            DVec3::new(-sp, cp, 0.0)
        };
        kg_dev += (e_phi(ka) - e_phi(kb)) * d;
    }
    // Rounding: as for the rotation, relative to Σ|terms| ≤ L/R·(total wall weight, at most
    // 2π/N·N for the θ-walls plus 2·Σⱼ(sin θⱼ₊₁ − sin θⱼ) ≤ 2 for the φ-walls).
    let round = 4.0 * f64::from(m + n + 2) * f64::from(f32::EPSILON) * l / r * (2.0 * PI + 2.0);
    let fd = 1e-8 * (e_exact / r + 1.0);
    let exact = DVec3::from_array(t_exact);
    for (variant, dev) in [
        (TranslationGradient::WardHeckbert, wh_dev),
        (TranslationGradient::KrivanekGautron, kg_dev),
    ] {
        let t = DVec3::from_array(gather.translation_gradient(variant).map(f64::from));
        let err = (t - (exact + dev)).length();
        let tol = round + fd;
        assert!(
            err <= tol,
            "{variant:?} {m}×{n} rows {rows:?} cols {cols:?}: ‖∇ₜE − (exact + weight error)‖ = \
             {err:.3e} > {tol:.3e} (est {t}, exact {exact}, weight error {dev})"
        );
    }
}

/// Patches overhead, off to one side, touching the pole, reaching the last row before the
/// horizon, at small and large radii, on coarse and fine strata.
#[test]
fn cell_aligned_patches_match_the_exact_derivatives() {
    check(8, 25, (2, 5), (3, 9), 1.0);
    check(8, 25, (0, 3), (20, 24), 3.0);
    check(16, 50, (5, 15), (10, 17), 0.5);
    check(16, 50, (1, 2), (0, 1), 1.0);
    check(32, 100, (10, 31), (40, 75), 1e-3);
    check(32, 100, (0, 12), (0, 50), 1e4);
}
