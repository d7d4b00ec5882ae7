//! The per-ray hot path: a ray prepared once for all its box and triangle tests, the
//! conservative ray–box test, and the watertight ray–triangle test with its error bound.
//!
//! # Triangle test
//! Woop, Benthin & Wald, "Watertight Ray/Triangle Intersection" (JCGT 2(1), 2013), in the form
//! of pbrt-v4 (§6.5.3, `IntersectTriangle`): translate the vertices to the ray origin, permute
//! so the ray's largest direction component is z, shear so the ray becomes the +z axis, and
//! evaluate the three 2D edge functions. An edge shared by two triangles gives the same edge
//! function value (up to sign) in both, bit for bit, so a ray cannot slip between them; an edge
//! function that rounds to exactly zero is recomputed in `f64` (pbrt-v4 does the same).
//!
//! The triangle is stored as three `Vec3A` of x, y and z coordinates (one lane per vertex), so
//! translation, shear and the three edge functions are a handful of 4-wide operations. The
//! permutation depends only on the ray, so it is a const generic (`KZ`, the axis that becomes z)
//! resolved once per ray, not per triangle. Multiplications and subtractions are written out
//! (glam's `cross` fuses with FMA when the target has it, which would break the bitwise
//! antisymmetry that watertightness needs).
//!
//! # Error bound on t
//! pbrt-v4's bound `δt` on the rounding error of the computed `t` (derived in pbrt-v3 §3.9.6
//! and kept in pbrt-v4 §6.8.4): a hit is reported only when `t > δt` (it is certainly in front
//! of the origin) and `t + δt < t_max` (it is certainly before the end). The first makes a ray
//! whose origin lies on the right side of its own surface, by however little, unable to re-hit
//! it; the second does the same for the far end of a shadow ray.
//!
//! # Box test
//! The slab test with Ize's correction ("Robust BVH Ray Traversal", JCGT 2(2), 2013): each slab
//! distance `(b − o)·(1/d)` carries at most three roundings, so the far distance is scaled by
//! `1 + 2γ₃` and a box that the exact ray touches is never rejected.

use glam::{Vec3, Vec3A, Vec3Swizzles};

use crate::Ray;

/// `γ_n = n·u / (1 − n·u)` with `u = 2⁻²⁴` (pbrt's bound on `n` successive roundings).
pub(crate) const fn gamma(n: i32) -> f32 {
    let nu = n as f32 * (f32::EPSILON * 0.5);
    nu / (1.0 - nu)
}

/// Ize's factor on the far slab distance: `1 + 2γ₃`.
const BOX_FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

/// A triangle as the hot path reads it: the x, y and z coordinates of its three vertices.
#[derive(Debug, Clone, Copy)]
pub(crate) struct TriSoa {
    pub(crate) xs: Vec3A,
    pub(crate) ys: Vec3A,
    pub(crate) zs: Vec3A,
}

impl TriSoa {
    pub(crate) fn new(p: [Vec3; 3]) -> TriSoa {
        TriSoa {
            xs: Vec3A::new(p[0].x, p[1].x, p[2].x),
            ys: Vec3A::new(p[0].y, p[1].y, p[2].y),
            zs: Vec3A::new(p[0].z, p[1].z, p[2].z),
        }
    }
}

/// A ray prepared once for all its tests: origin (also splatted per axis), the clamped inverse
/// direction for the box test, and the shear constants of the triangle test.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PreparedRay {
    pub(crate) origin: Vec3A,
    pub(crate) inv_dir: Vec3A,
    ox: Vec3A,
    oy: Vec3A,
    oz: Vec3A,
    sx: f32,
    sy: f32,
    sz: f32,
    /// The axis of the largest direction component, which the triangle test maps to z.
    pub(crate) kz: usize,
    /// The caller's `t_max`.
    pub(crate) t_max: f32,
}

impl PreparedRay {
    /// `None` for a ray that cannot hit anything: non-finite origin or direction, zero
    /// direction, or a `t_max` that is NaN or not positive.
    pub(crate) fn new(ray: &Ray) -> Option<PreparedRay> {
        let d = ray.direction;
        if !ray.origin.is_finite() || !d.is_finite() || d == Vec3::ZERO || ray.t_max.is_nan() {
            return None;
        }
        if ray.t_max <= 0.0 {
            return None;
        }
        let a = d.abs();
        let kz = if a.x > a.y && a.x > a.z {
            0
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let kx = (kz + 1) % 3;
        let ky = (kx + 1) % 3;
        // pbrt-v4: Sx = −d_x/d_z, Sy = −d_y/d_z, Sz = 1/d_z in the permuted frame.
        let sx = -d[kx] / d[kz];
        let sy = -d[ky] / d[kz];
        let sz = 1.0 / d[kz];
        // 1/d, clamped so that a zero component gives ±f32::MAX instead of ±∞ (∞·0 would be NaN
        // when the origin lies on a slab plane). This only matters for |d_i| < 2.9e-39.
        let inv_dir = (Vec3A::ONE / Vec3A::from(d)).clamp(Vec3A::splat(-f32::MAX), Vec3A::MAX);
        let o = Vec3A::from(ray.origin);
        Some(PreparedRay {
            origin: o,
            inv_dir,
            ox: Vec3A::splat(o.x),
            oy: Vec3A::splat(o.y),
            oz: Vec3A::splat(o.z),
            sx,
            sy,
            sz,
            kz,
            t_max: ray.t_max,
        })
    }
}

/// Entry distance of the ray into the box `[min, max]` if it enters it with an entry distance no
/// larger than `t_best` and an exit distance of at least 0; `f32::INFINITY` otherwise.
/// Conservative (Ize 2013): the far distance is scaled up by `1 + 2γ₃`.
#[inline(always)]
pub(crate) fn box_entry(min: Vec3A, max: Vec3A, ray: &PreparedRay, t_best: f32) -> f32 {
    let t0 = (min - ray.origin) * ray.inv_dir;
    let t1 = (max - ray.origin) * ray.inv_dir;
    let t_near = t0.min(t1).max_element();
    let t_far = t0.max(t1).min_element() * BOX_FAR_SCALE;
    if t_near <= t_far && t_far >= 0.0 && t_near <= t_best {
        t_near
    } else {
        f32::INFINITY
    }
}

/// A triangle hit: distance and the barycentrics of vertices 1 and 2.
#[derive(Debug, Clone, Copy)]
pub(crate) struct TriHit {
    pub(crate) t: f32,
    pub(crate) b1: f32,
    pub(crate) b2: f32,
}

/// The watertight test (see the module docs). Reports a hit only with `δt < t`, `t ≤ t_best`
/// and `t + δt < ray.t_max`, where `δt` bounds the rounding error of `t`.
#[inline(always)]
pub(crate) fn intersect_triangle<const KZ: usize>(
    tri: &TriSoa,
    ray: &PreparedRay,
    t_best: f32,
) -> Option<TriHit> {
    // Translate the vertices so the ray starts at the origin.
    let x = tri.xs - ray.ox;
    let y = tri.ys - ray.oy;
    let z = tri.zs - ray.oz;
    // Permute so that the ray's largest component is z (kx = kz + 1, ky = kz + 2, mod 3; a
    // cyclic permutation, so the winding keeps its sign).
    let (px, py, pz) = match KZ {
        0 => (y, z, x),
        1 => (z, x, y),
        _ => (x, y, z),
    };
    // Shear so the ray runs along +z: x' = x + Sx·z, y' = y + Sy·z.
    let xt = px + Vec3A::splat(ray.sx) * pz;
    let yt = py + Vec3A::splat(ray.sy) * pz;
    // Edge functions e_i = x_j·y_k − x_k·y_j for (i, j, k) cyclic: e0 weighs vertex 0.
    let mut e = xt.yzx() * yt.zxy() - xt.zxy() * yt.yzx();
    // An edge function of exactly zero is ambiguous in f32: redo all three in f64, where the
    // products are exact (Woop et al. 2013, §4; pbrt-v4 does the same).
    if e.cmpeq(Vec3A::ZERO).any() {
        e = edge_functions_f64(xt, yt);
    }
    // The ray passes the triangle only if all three edge functions have the same sign.
    if e.cmplt(Vec3A::ZERO).any() && e.cmpgt(Vec3A::ZERO).any() {
        return None;
    }
    let det = e.x + e.y + e.z;
    if det == 0.0 {
        return None;
    }
    // Scaled distance t·det, to test the range before dividing.
    let zt = pz * Vec3A::splat(ray.sz);
    let t_scaled = e.x * zt.x + e.y * zt.y + e.z * zt.z;
    if det < 0.0 && (t_scaled >= 0.0 || t_scaled < t_best * det) {
        return None;
    }
    if det > 0.0 && (t_scaled <= 0.0 || t_scaled > t_best * det) {
        return None;
    }
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;

    // pbrt-v4 §6.8.4 (pbrt-v3 §3.9.6): bound δt on the error of t, from the bounds on the
    // translated-sheared coordinates (δx, δy, δz), the edge functions (δe) and t itself.
    let max_zt = zt.abs().max_element();
    let max_xt = xt.abs().max_element();
    let max_yt = yt.abs().max_element();
    let delta_z = gamma(3) * max_zt;
    let delta_x = gamma(5) * (max_xt + max_zt);
    let delta_y = gamma(5) * (max_yt + max_zt);
    let delta_e = 2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    let max_e = e.abs().max_element();
    let delta_t =
        3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * inv_det.abs();
    // Written so that a NaN (from an overflowing product) rejects the hit.
    if t > delta_t && t + delta_t < ray.t_max {
        Some(TriHit {
            t,
            b1: e.y * inv_det,
            b2: e.z * inv_det,
        })
    } else {
        None
    }
}

/// The three edge functions in `f64`: the products of two `f32` values are exact there, so each
/// result is the correctly rounded difference, with the same antisymmetry as the `f32` form.
#[cold]
#[inline(never)]
fn edge_functions_f64(xt: Vec3A, yt: Vec3A) -> Vec3A {
    let x = xt.as_dvec3();
    let y = yt.as_dvec3();
    Vec3A::new(
        (x.y * y.z - x.z * y.y) as f32,
        (x.z * y.x - x.x * y.z) as f32,
        (x.x * y.y - x.y * y.x) as f32,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hit(tri: [Vec3; 3], ray: &Ray) -> Option<TriHit> {
        let r = PreparedRay::new(ray)?;
        let t = TriSoa::new(tri);
        match r.kz {
            0 => intersect_triangle::<0>(&t, &r, r.t_max),
            1 => intersect_triangle::<1>(&t, &r, r.t_max),
            _ => intersect_triangle::<2>(&t, &r, r.t_max),
        }
    }

    const TRI: [Vec3; 3] = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];

    #[test]
    fn hits_with_barycentrics_from_every_axis() {
        // The same point (0.25, 0.5, 0) reached along a direction dominated by each axis in turn.
        let target = Vec3::new(0.25, 0.5, 0.0);
        for d in [
            Vec3::new(2.0, 0.3, -1.0),
            Vec3::new(0.3, 2.0, -1.0),
            Vec3::new(0.3, 0.2, -2.0),
            Vec3::new(-0.3, -0.2, 2.0),
        ] {
            let ray = Ray::new(target - 3.0 * d, d);
            let h = hit(TRI, &ray).unwrap_or_else(|| panic!("missed along {d}"));
            // t = 3 exactly in exact arithmetic; a few roundings of values ≤ 10 in magnitude:
            // 1e-5 is ~100 ulps of 3, far above γ₁₀ ≈ 6e-7 relative.
            assert!((h.t - 3.0).abs() < 1e-5, "{}", h.t);
            assert!((h.b1 - 0.25).abs() < 1e-5 && (h.b2 - 0.5).abs() < 1e-5);
        }
    }

    #[test]
    fn misses_outside_behind_and_beyond_t_max() {
        let outside = Ray::new(Vec3::new(0.8, 0.8, 1.0), Vec3::NEG_Z);
        assert!(hit(TRI, &outside).is_none());
        let behind = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::Z);
        assert!(hit(TRI, &behind).is_none());
        let short = Ray {
            t_max: 0.5,
            ..Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z)
        };
        assert!(hit(TRI, &short).is_none());
        let edge_on = Ray::new(Vec3::new(-1.0, 0.2, 0.0), Vec3::X);
        assert!(hit(TRI, &edge_on).is_none());
    }

    #[test]
    fn invalid_rays_hit_nothing() {
        for ray in [
            Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::ZERO),
            Ray::new(Vec3::new(0.2, 0.2, f32::NAN), Vec3::NEG_Z),
            Ray::new(
                Vec3::new(0.2, 0.2, 1.0),
                Vec3::new(0.0, f32::INFINITY, -1.0),
            ),
            Ray {
                t_max: f32::NAN,
                ..Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z)
            },
        ] {
            assert!(hit(TRI, &ray).is_none(), "{ray:?}");
        }
    }

    #[test]
    fn shared_edge_is_watertight() {
        // Two triangles sharing the diagonal of the unit square; rays aimed exactly at points of
        // the diagonal must hit at least one of them, from both sides and along every axis.
        let a = [
            Vec3::ZERO,
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
        ];
        let b = [
            Vec3::ZERO,
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        for i in 1..1000 {
            let s = i as f32 / 1000.0;
            let p = Vec3::new(s, s, 0.0);
            for d in [
                Vec3::new(0.1, 0.37, -1.0),
                Vec3::new(-0.7, 0.3, 0.2),
                Vec3::new(0.3, 0.9, 0.35),
            ] {
                for d in [d, -d] {
                    let ray = Ray::new(p - d, d);
                    assert!(
                        hit(a, &ray).is_some() || hit(b, &ray).is_some(),
                        "slipped through at {p} along {d}"
                    );
                }
            }
        }
    }

    #[test]
    fn box_test_is_conservative_for_grazing_and_axis_rays() {
        let min = Vec3A::new(0.0, 0.0, 0.0);
        let max = Vec3A::new(1.0, 0.0, 1.0); // flat box, as for a floor triangle
        let r = PreparedRay::new(&Ray::new(Vec3::new(0.5, 1.0, 0.5), Vec3::NEG_Y))
            .unwrap_or_else(|| panic!("valid ray"));
        assert_eq!(box_entry(min, max, &r, f32::INFINITY), 1.0);
        // A ray hitting the flat box exactly on its boundary edge z = 0, with two zero
        // direction components (their inverse is clamped, never ∞·0 = NaN).
        let r = PreparedRay::new(&Ray::new(Vec3::new(0.5, 1.0, 0.0), Vec3::NEG_Y))
            .unwrap_or_else(|| panic!("valid ray"));
        assert_eq!(box_entry(min, max, &r, f32::INFINITY), 1.0);
        // Missing above.
        let r = PreparedRay::new(&Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X))
            .unwrap_or_else(|| panic!("valid ray"));
        assert_eq!(box_entry(min, max, &r, f32::INFINITY), f32::INFINITY);
    }
}
