//! Rays, and the robust offsets that let a ray leave a surface without hitting it again and
//! without tunnelling through thin geometry, at every scale.
//!
//! # The method
//! Wächter & Binder ("A Fast and Robust Method for Avoiding Self-Intersection", Ray Tracing Gems,
//! ch. 6, 2019) offset the origin by an amount that scales with the magnitude of the hit point,
//! never a fixed epsilon. We keep that principle in the form of pbrt-v4's `OffsetRayOrigin`
//! (Pharr, Jakob & Humphreys, *Physically Based Rendering*, 4th ed., §6.8.6): with a
//! per-component bound `err` on how far a point may be from the true surface, move it along the
//! normal by at least `d = |n|·err` (the largest distance that error can put it from the plane).
//! pbrt then rounds every moved component one more float away so that the rounding of `p +
//! offset` cannot pull it back; irr instead adds that rounding's bound (half an ulp of each
//! moved component, at most `2⁻²³·|p_i|` plus the smallest normal float) to `err` before moving,
//! which gives the same guarantee without a branch per component on the offset's sign (a coin
//! toss per ray).
//!
//! The bound `err` is [`position_error`]: `2⁻²²·|p_i|` per component. The points this crate
//! produces ([`SurfacePoint::position`](crate::SurfacePoint), [`Triangle::point`](crate::Triangle))
//! are within `2⁻²⁴·|p_i|` (half an ulp) of the true plane, so the offset has a factor-4 margin,
//! which also covers points a caller computes with a couple of `f32` roundings of their own.
//! Scale invariance follows: the offset is a fixed number of ulps of `p`, whether the scene is
//! 1e-4 or 1e3 across or translated to 1e5.
//!
//! # The floor
//! `err` has a floor, [`POSITION_ERROR_FLOOR`] = 2⁻¹⁰⁰ (about 7.9e-31), for coordinates at or
//! near zero: a point on a plane through the origin of coordinates (a floor at y = 0, the
//! commonest plane a scene has) is exact in that coordinate, and with the smallest normal
//! float as the floor, a ray left it 2.4e-38 above the plane. The triangle test then
//! multiplied that coordinate's difference from the plane's vertices by the shear factors
//! (`|Sx|, |Sy| ≤ 1`), and the products fell below the smallest normal float: on x86, an
//! instruction whose result is subnormal takes a microcode assist, on the order of a hundred
//! cycles. With the floor at 2⁻¹⁰⁰ no packet test takes one, the hits are the same, and rays
//! leaving such a plane trace much faster (see docs/performance.md, ray offsets' floor and lazy
//! preparation).
//!
//! Why 2⁻¹⁰⁰: the difference from a plane's vertex is then at least 2⁻¹⁰⁰, its product with a
//! shear factor stays normal for any factor of at least 2⁻²⁶ (roughly, a direction more than
//! 1.5e-8 rad out of a coordinate plane; an exact zero factor gives an exact zero), and its
//! products with the test's error factors (`γ₇ < 2⁻²⁰`) stay normal too. And it moves no
//! coordinate more than before unless the coordinate is below 2⁻⁷⁸ (3.3e-24), where
//! `2⁻²²·|p_i|` is smaller than the floor: exact zeros above all (2⁻¹⁰⁰ instead of 2⁻¹²⁵).
//!
//! The other half of the robustness lives in the triangle test: a hit is only reported when its
//! distance is provably positive and provably below `t_max` (see `intersect.rs`), so an origin
//! that is merely on the right side of its own plane — by however little — cannot re-hit it.

use glam::{Vec3, Vec3A};

/// A ray `origin + t·direction` for `t` in `(0, t_max)`.
///
/// `direction` need not be unit length: `t` is measured in units of `direction`'s length (so a
/// shadow ray from [`Ray::spawn_to`] has `t_max = 1` and reaches its target at `t = 1`). A ray
/// with a non-finite origin or direction, a zero direction, or a NaN `t_max` hits nothing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Where the ray starts.
    pub origin: Vec3,
    /// Where it goes: any non-zero finite vector.
    pub direction: Vec3,
    /// Hits are reported only for `t < t_max` (exclusive).
    pub t_max: f32,
}

/// The floor of [`position_error`]: 2⁻¹⁰⁰, so that a point on a plane through the origin of
/// coordinates moves off it far enough for the triangle test's arithmetic on the ray to stay in
/// normal floats (see the module docs).
pub const POSITION_ERROR_FLOOR: f32 = 7.888_609e-31; // 2^-100

/// The relative bound on the error of a surface point that [`offset_ray_origin`] assumes:
/// `2⁻²²`, four times the half-ulp (`2⁻²⁴`) accuracy of the points this crate computes.
pub const POSITION_RELATIVE_ERROR: f32 = 1.0 / 4_194_304.0; // 2^-22

impl Ray {
    /// A ray with an unbounded `t_max`.
    #[must_use]
    pub fn new(origin: Vec3, direction: Vec3) -> Ray {
        Ray {
            origin,
            direction,
            t_max: f32::INFINITY,
        }
    }

    /// The point `origin + t·direction`.
    #[must_use]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.direction
    }

    /// A ray leaving the surface point `p` (geometric normal `ng`, either orientation) along
    /// `direction`: the origin is offset robustly to the side of the surface that `direction`
    /// goes to, so the ray cannot hit the surface it leaves. `t_max` is unbounded.
    ///
    /// `p` should come from [`SurfacePoint::position`](crate::SurfacePoint) or
    /// [`Triangle::point`](crate::Triangle::point) (or be as accurate, see
    /// [`POSITION_RELATIVE_ERROR`]).
    #[must_use]
    pub fn spawn(p: Vec3, ng: Vec3, direction: Vec3) -> Ray {
        let n = if ng.dot(direction) >= 0.0 { ng } else { -ng };
        Ray::new(offset_ray_origin(p, n), direction)
    }

    /// A shadow ray from the surface point `p` (geometric normal `ng`) to the point `target` on
    /// another surface (geometric normal `target_ng`); normals of either orientation.
    ///
    /// Both ends are offset off their surfaces, each to the side facing the other end, and the
    /// ray is `origin + t·(end − origin)` with `t_max = 1`: the target is visible from `p`
    /// exactly when `!geometry.occluded(&ray)`. Neither end's own surface can occlude the ray.
    ///
    /// The target's offset also covers the rounding of `end − origin` (at most half an ulp of
    /// each component of the difference), so the segment's end stays on the near side of the
    /// target's plane.
    #[must_use]
    pub fn spawn_to(p: Vec3, ng: Vec3, target: Vec3, target_ng: Vec3) -> Ray {
        let n_from = if ng.dot(target - p) >= 0.0 { ng } else { -ng };
        let origin = offset_ray_origin(p, n_from);
        let n_to = if target_ng.dot(origin - target) >= 0.0 {
            target_ng
        } else {
            -target_ng
        };
        Self::to_offset_target(origin, target, n_to)
    }

    /// A shadow ray from the front of `p`'s surface to the front of `target`'s: each end offset
    /// along its own normal as given (`front`, `target_front`: the sides the two points are
    /// seen from), whatever the other end's side; otherwise as [`Ray::spawn_to`]. A target
    /// behind `p`'s surface is then occluded by that surface where it extends between them: the
    /// ray crosses it as it leaves (a point on a floor's top does not see a point under it). A
    /// crossing of the target's own surface lies within rounding of the segment's end and may
    /// go unseen, so a caller that needs it starts from the end the other lies behind.
    #[must_use]
    pub fn spawn_between_fronts(p: Vec3, front: Vec3, target: Vec3, target_front: Vec3) -> Ray {
        Self::to_offset_target(offset_ray_origin(p, front), target, target_front)
    }

    /// The segment from `origin` to `target` offset along `n_to`.
    fn to_offset_target(origin: Vec3, target: Vec3, n_to: Vec3) -> Ray {
        // |end_i − origin_i| ≤ |target_i| + |origin_i| (plus the offset, far below this), and its
        // rounding is at most half an ulp, 2⁻²⁴ of that: 2⁻²³ leaves a factor 2.
        let direction_rounding = (target.abs() + origin.abs()) * (1.0 / 8_388_608.0);
        let end =
            offset_ray_origin_with_error(target, n_to, position_error(target) + direction_rounding);
        Ray {
            origin,
            direction: end - origin,
            t_max: 1.0,
        }
    }
}

/// The per-component error bound that [`offset_ray_origin`] assumes for a surface point `p`:
/// `2⁻²²·|p_i|`, plus [`POSITION_ERROR_FLOOR`] so that an exact zero still moves off its plane,
/// and far enough that the triangle test's products stay normal floats (see the module docs).
#[must_use]
pub fn position_error(p: Vec3) -> Vec3 {
    p.abs() * POSITION_RELATIVE_ERROR + Vec3::splat(POSITION_ERROR_FLOOR)
}

/// Offsets the surface point `p` along the normal `n` (toward the side `n` points to; need not
/// be unit length), by an amount that scales with the magnitude of `p`, so that a ray starting
/// there cannot hit the surface `p` lies on.
///
/// This is Wächter & Binder's idea (Ray Tracing Gems ch. 6: the offset scales with `|p|`, not a
/// fixed epsilon) in pbrt-v4's formulation, with the error bound [`position_error`]`(p)`: see
/// [`offset_ray_origin_with_error`].
#[must_use]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    offset_ray_origin_with_error(p, n, position_error(p))
}

/// Offsets `p` along `n` past a per-component error bound `err` (all components ≥ 0): the
/// result lies strictly on `n`'s side of the plane through the true point, farther from it
/// than `d = Σ|n̂_i|·err_i`, the furthest that error can put `p` from its plane along the unit
/// normal `n̂`. A zero or non-finite `n` returns `p` unchanged.
///
/// The move is `n̂·d'·(1 + 2⁻¹⁸)` with `d' = Σ|n̂_i|·(err_i + 2⁻²³·|p_i| + MIN)` (MIN the
/// smallest normal float), computed as `n·(|n|·err')/|n|²` (no square root for a normal of
/// length between ½ and 2; others are normalised first, so that this cannot underflow). Why it
/// is enough:
/// - the expression has about a dozen roundings, so the computed move along `n̂` is at least
///   `d'·(1 + 2⁻¹⁸)(1 − γ₁₂) ≥ d'·(1 + 51·2⁻²⁴)`;
/// - rounding `p_i + offset_i` loses at most half an ulp of the result, `2⁻²⁴·|p_i + offset_i|`
///   (or `2⁻¹⁵⁰` for a subnormal one), so the point loses at most
///   `2⁻²⁴·(Σ|n̂_i||p_i| + d'(1 + 2⁻¹⁸)) + 3·2⁻¹⁵⁰` of that along `n̂`;
/// - what is left exceeds `d` by at least `Σ|n̂_i|·(2⁻²⁴·|p_i| + MIN) − 3·2⁻¹⁵⁰ > 0`, for any
///   `err ≥ 0` (however large against `p`, as the end of a long shadow ray's is).
///
/// pbrt-v4 instead rounds each moved component one float further; that needs a branch per
/// component on the offset's sign, a coin toss per ray.
#[must_use]
#[inline]
pub fn offset_ray_origin_with_error(p: Vec3, n: Vec3, err: Vec3) -> Vec3 {
    const ROUNDING: f32 = 1.0 / 8_388_608.0; // 2⁻²³
    const MARGIN: f32 = 1.0 + 1.0 / 262_144.0; // 1 + 2⁻¹⁸
    let mut len2 = n.length_squared();
    if !(len2 > 0.0 && len2.is_finite()) {
        return p;
    }
    // Far from unit length, normalise first, so that `|n|·err'/|n|²` cannot underflow (the
    // normals irr passes are unit: this branch is never taken there).
    let mut n = n;
    if !(0.25..=4.0).contains(&len2) {
        n /= len2.sqrt();
        len2 = n.length_squared();
    }
    // In 4-lane vectors: the same operations on each component, in fewer instructions.
    let (p, n) = (Vec3A::from(p), Vec3A::from(n));
    let err = Vec3A::from(err) + p.abs() * ROUNDING + Vec3A::splat(f32::MIN_POSITIVE);
    (p + n * (n.abs().dot(err) / len2 * MARGIN)).into()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_moves_strictly_to_the_normal_side_at_every_scale() {
        for scale in [1e-30f32, 1e-4, 1.0, 1e3, 1e5, 1e30] {
            let p = Vec3::new(0.3, -0.7, 0.2) * scale;
            let n = Vec3::new(1.0, 2.0, -0.5).normalize();
            let po = offset_ray_origin(p, n);
            // In f64 (exact for these differences), the move along n must exceed the assumed
            // error d = |n|·err, which is ≥ 2⁻²²·|n|·|p| > 0.
            let moved = (po.as_dvec3() - p.as_dvec3()).dot(n.as_dvec3());
            let d = f64::from(n.abs().dot(position_error(p)));
            assert!(
                moved >= d * (1.0 - 1e-6),
                "scale {scale}: moved {moved}, need {d}"
            );
            // And it is a few ulps, not a fixed epsilon: at most 2·d + one ulp per component
            // (at 1e-30, d is the floor's: 2⁻¹⁰⁰ against 2⁻²²·|p| ≈ 2⁻¹²⁰).
            assert!(moved <= 2.0 * d + 3.0 * f64::from(p.abs().max_element()) * 2f64.powi(-23));
        }
    }

    proptest::proptest! {
        /// The guarantee of `offset_ray_origin_with_error`, checked in f64 (exact for these
        /// differences and products, up to a relative 2⁻⁵⁰): the point moves along n̂ by more
        /// than Σ|n̂_i|·err_i, for points from 1e-30 to 1e30, normals of any length and
        /// direction, and error bounds from none to far larger than the point.
        #[test]
        fn the_offset_clears_any_error_bound(
            p in proptest::array::uniform3(-1.0f32..1.0),
            n in proptest::array::uniform3(-1.0f32..1.0),
            e in proptest::array::uniform3(0.0f32..1.0),
            scale in -30i32..=30,
            n_scale in -10i32..=10,
            e_scale in -40i32..=10,
        ) {
            let p = Vec3::from(p) * 10f32.powi(scale);
            let n = Vec3::from(n) * 10f32.powi(n_scale);
            let err = Vec3::from(e) * 10f32.powi(scale + e_scale);
            proptest::prop_assume!(n.length_squared() > 0.0 && n.length_squared().is_finite());
            // An error bound near f32::MAX moves the point to infinity: not a bound of a
            // representable point's error.
            proptest::prop_assume!((p + err * 4.0).is_finite());
            let po = offset_ray_origin_with_error(p, n, err);
            let nh = n.as_dvec3().normalize();
            let moved = (po.as_dvec3() - p.as_dvec3()).dot(nh);
            let d = nh.abs().dot(err.as_dvec3());
            proptest::prop_assert!(moved > d * (1.0 + 1e-12), "moved {moved:e}, need {d:e}");
        }
    }

    /// A ray leaving a plane through the origin of coordinates (a floor at y = 0) starts at
    /// least `POSITION_ERROR_FLOOR` above it, so the triangle test's products of that
    /// coordinate's differences stay normal floats (no microcode assist per instruction, see
    /// the module docs): with any shear factor of at least 2⁻²⁶ and with its error factors
    /// (`γ₇`, about 4.2e-7). With the smallest normal float as the floor, the origin was
    /// 2.4e-38 above the plane and both products were subnormal.
    #[test]
    fn a_ray_leaving_a_plane_through_zero_keeps_the_triangle_test_in_normal_floats() {
        let smallest_shear = 1.0 / 67_108_864.0; // 2⁻²⁶
        let gamma7 = crate::intersect::gamma(7);
        for p in [
            Vec3::new(0.3, 0.0, 0.7),
            Vec3::ZERO,
            Vec3::new(-5e4, 0.0, 1e-3),
        ] {
            for ray in [
                Ray::spawn(p, Vec3::Y, Vec3::new(0.2, 1.0, -0.4)),
                Ray::spawn_to(p, Vec3::Y, Vec3::new(0.1, 2.0, 0.3), Vec3::NEG_Y),
            ] {
                // The triangle test's difference from a vertex on the plane.
                let below = 0.0 - ray.origin.y;
                assert!(
                    ray.origin.y >= POSITION_ERROR_FLOOR,
                    "{p}: {}",
                    ray.origin.y
                );
                for product in [below * smallest_shear, below * gamma7] {
                    assert!(product.is_normal(), "{p}: {product:e} is subnormal");
                }
            }
        }
    }

    #[test]
    fn offset_of_exact_zero_still_moves() {
        let po = offset_ray_origin(Vec3::ZERO, Vec3::Y);
        assert!(po.y > 0.0 && po.x == 0.0 && po.z == 0.0, "{po}");
    }

    #[test]
    fn degenerate_normal_leaves_point_unchanged() {
        let p = Vec3::new(1.0, 2.0, 3.0);
        assert_eq!(offset_ray_origin(p, Vec3::ZERO), p);
        assert_eq!(offset_ray_origin(p, Vec3::NAN), p);
    }

    #[test]
    fn spawn_picks_the_side_of_the_direction() {
        let p = Vec3::new(0.5, 0.0, 0.5);
        let up = Ray::spawn(p, Vec3::Y, Vec3::new(0.1, 1.0, 0.0));
        let down = Ray::spawn(p, Vec3::Y, Vec3::new(0.1, -1.0, 0.0));
        assert!(up.origin.y > 0.0 && down.origin.y < 0.0);
        assert_eq!(up.t_max, f32::INFINITY);
    }

    #[test]
    fn spawn_to_ends_on_the_near_side_of_both_surfaces() {
        let p = Vec3::new(0.5, 0.0, 0.5);
        let target = Vec3::new(0.25, 1.0, 0.75);
        let ray = Ray::spawn_to(p, Vec3::Y, target, Vec3::Y);
        assert!(ray.origin.y > 0.0);
        let end = ray.at(1.0);
        assert!(end.y < 1.0, "{end}");
        assert_eq!(ray.t_max, 1.0);
    }
}
