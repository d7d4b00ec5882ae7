//! The per-ray hot path: a ray prepared once for all its box and triangle tests, the
//! conservative ray–box test, and the watertight ray–triangle test with its error bound.
//!
//! # Triangle test
//! Woop, Benthin & Wald, "Watertight Ray/Triangle Intersection" (JCGT 2(1), 2013), in the form
//! of pbrt-v4 (§6.5.3, `IntersectTriangle`): translate the vertices to the ray origin, permute
//! so the ray's largest direction component is z, shear so the ray becomes the +z axis, and
//! evaluate the three 2D edge functions. An edge shared by two triangles gives the same edge
//! function value (up to sign) in both, bit for bit, so a ray cannot slip between them.
//! Where an edge function is within its rounding-error bound of zero (the ray passes within
//! rounding distance of an edge, so the `f32` sign is uncertain), the test is redone in `f64`
//! from the original data — a filtered predicate, in the manner of Shewchuk's adaptive
//! predicates. pbrt-v4 only redoes edge functions that are exactly zero; the wider filter keeps
//! the inside/outside decision correct where it matters for robustness: a grazing ray leaving
//! a face just above its edge must be found to enter the adjacent face, not the face it leaves.
//!
//! The triangle is stored as three `Vec3A` of x, y and z coordinates (one lane per vertex), so
//! translation, shear and the three edge functions are a handful of 4-wide operations. The
//! permutation depends only on the ray: the scalar test takes it as a const generic (`KZ`, the
//! axis that becomes z); the 4-wide test indexes its packet's coordinate arrays with the ray's
//! `perm`, one body for every ray (three bodies chosen per ray cost a mispredicted branch per
//! ray, and three copies of the traversal in the instruction cache).
//!
//! The 4-wide test first screens its packet: a lane with one edge function below `−s` and
//! another above `s` certainly misses, where `s`, set once per ray from the scene's largest
//! coordinate, is twice any filter bound the test can compute (see `PreparedRay::set_screen`).
//! A packet whose four lanes all miss that way costs no filter, no division and no distance. Multiplications and subtractions are written out
//! (glam's `cross` fuses with FMA when the target has it, which would break the bitwise
//! antisymmetry that watertightness needs).
//!
//! # Distance and its error bound
//! The edge functions decide *whether* the ray passes the triangle (watertight); the distance
//! comes from the plane instead: `t = ((p0 − o)·n) / (d·n)` with the unit normal `n` computed in
//! `f64` at build time. Its rounding error is bounded by
//! `δt = (γ₅·Σ|a_i n_i| + γ₄·|t|·Σ|d_i n_i|) / |d·n| + γ₁·|t|` with `a = p0 − o` (the dot
//! products carry γ₃, the rounding of `a` and of `n` one `u` each; see `intersect_triangle`).
//! pbrt-v4's bound for the Woop distance (§6.8.4) goes through the barycentric weights, whose
//! error grows with the triangle's length over its area: for a 1e-4 × 1e-7 sliver (the side of
//! a thin slab) it is ~600× the distance to the side, and a ray starting next to the side would
//! pass through it. The plane distance's bound depends only on how far `p0` is from the origin.
//!
//! A hit is reported only when `t > δt` (it is certainly in front of the origin) and
//! `t + δt < t_max` (it is certainly before the end). The first makes a ray whose origin lies on
//! the right side of its own surface, by however little, unable to re-hit it; the second does the
//! same for the far end of a shadow ray.
//!
//! # Box test
//! The slab test with Ize's correction ("Robust BVH Ray Traversal", JCGT 2(2), 2013): each slab
//! distance `(b − o)·(1/d)` carries at most three roundings, so the far distance is scaled by
//! `1 + 2γ₃` and a box that the exact ray touches is never rejected.

use glam::{BVec4A, DVec3, Vec3, Vec3A, Vec3Swizzles, Vec4};

use crate::Ray;
use crate::mesh::cross_f64;

/// `γ_n = n·u / (1 − n·u)` with `u = 2⁻²⁴` (pbrt's bound on `n` successive roundings).
pub(crate) const fn gamma(n: i32) -> f32 {
    let nu = n as f32 * (f32::EPSILON * 0.5);
    nu / (1.0 - nu)
}

/// The clamp on `1/d` (2⁶⁴).
const INV_DIR_LIMIT: Vec3A = Vec3A::splat(18_446_744_073_709_551_616.0);

/// The constant of [`PreparedRay::set_screen`]:
/// `2(1 + 2⁻¹⁶)(1 + 2⁻¹²)·(8γ₃ + 16γ₅ + 8γ₅²)`.
const SCREEN_FACTOR: f32 = 2.0
    * (1.0 + 1.0 / 65_536.0)
    * (1.0 + 1.0 / 4096.0)
    * (8.0 * gamma(3) + 16.0 * gamma(5) + 8.0 * gamma(5) * gamma(5));

/// Ize's factor on the far slab distance: `1 + 2γ₃`.
const BOX_FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

/// A triangle as the hot path reads it: the x, y and z coordinates of its three vertices, and
/// its unit normal. 64 bytes, aligned to a cache line.
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(64))]
pub(crate) struct TriSoa {
    xs: Vec3A,
    ys: Vec3A,
    zs: Vec3A,
    n: Vec3A,
}

impl TriSoa {
    pub(crate) fn new(p: [Vec3; 3]) -> TriSoa {
        TriSoa {
            xs: Vec3A::new(p[0].x, p[1].x, p[2].x),
            ys: Vec3A::new(p[0].y, p[1].y, p[2].y),
            zs: Vec3A::new(p[0].z, p[1].z, p[2].z),
            n: cross_f64(p).normalize_or_zero().as_vec3a(),
        }
    }

    /// The vertices, bit for bit those given to [`TriSoa::new`].
    #[inline]
    pub(crate) fn vertices(&self) -> [Vec3; 3] {
        [0, 1, 2].map(|v| Vec3::new(self.xs[v], self.ys[v], self.zs[v]))
    }

    /// The unit normal (normalised `(p1 − p0) × (p2 − p0)`, computed in `f64`).
    #[inline]
    pub(crate) fn normal(&self) -> Vec3 {
        self.n.into()
    }
}

/// An axis, as an index the compiler knows to be below 3 (a `usize` field would be bounds-checked
/// at every use: a compare and a branch for each coordinate array a packet test reads).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub(crate) enum Axis {
    X,
    Y,
    Z,
}

/// A plane of a box, as an index into a wide node's planes (min x, min y, min z, max x, max y,
/// max z) that the compiler knows to be below 6 (as [`Axis`]: no bounds check per node test).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub(crate) enum Plane {
    MinX,
    MinY,
    MinZ,
    MaxX,
    MaxY,
    MaxZ,
}

/// The planes and axes a ray's tests read, chosen by the signs of its direction and its
/// largest axis: the near and far plane of a box per axis, and the permutation of the
/// triangle test. One 16-byte table entry ([`Slabs::TABLE`]), so that preparing a ray copies
/// it with one load and one store (three arrays of `usize` indices took more instructions).
/// The permutation is set later, with the rest of the triangle test's part
/// ([`PreparedRay::finish`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(C, align(16))]
pub(crate) struct Slabs {
    /// Per axis, the near plane of a box (the min plane where the direction is positive).
    pub(crate) near: [Plane; 3],
    /// Per axis, the far plane (the other one).
    pub(crate) far: [Plane; 3],
    /// The axes that become x, y and z in the triangle test: `[kz + 1, kz + 2, kz]` (mod 3),
    /// `kz` the axis of the largest direction component.
    /// The 4-wide test indexes the packet's coordinate arrays with them, so it has one body
    /// for every ray rather than one per axis (a per-ray branch among three bodies was a
    /// mispredicted branch per ray).
    pub(crate) perm: [Axis; 3],
}

impl Slabs {
    /// The triangle test's permutation for each `kz`: `[kz + 1, kz + 2, kz]` (mod 3).
    const PERMUTATION: [[Axis; 3]; 3] = {
        use Axis::{X, Y, Z};
        [[Y, Z, X], [Z, X, Y], [X, Y, Z]]
    };

    /// By the signs of the direction (bit `a` set: axis `a` negative), with the permutation of
    /// `kz` = z until [`PreparedRay::finish`] sets the ray's own.
    const TABLE: [Slabs; 8] = {
        use Plane::{MaxX, MaxY, MaxZ, MinX, MinY, MinZ};
        const NEAR: [[Plane; 3]; 8] = [
            [MinX, MinY, MinZ],
            [MaxX, MinY, MinZ],
            [MinX, MaxY, MinZ],
            [MaxX, MaxY, MinZ],
            [MinX, MinY, MaxZ],
            [MaxX, MinY, MaxZ],
            [MinX, MaxY, MaxZ],
            [MaxX, MaxY, MaxZ],
        ];
        let mut t = [Slabs {
            near: NEAR[0],
            far: NEAR[0],
            perm: Slabs::PERMUTATION[2],
        }; 8];
        let mut signs = 0;
        while signs < 8 {
            t[signs] = Slabs {
                near: NEAR[signs],
                far: NEAR[7 - signs],
                perm: Slabs::PERMUTATION[2],
            };
            signs += 1;
        }
        t
    };
}

/// A ray prepared once for all its tests: origin, the clamped inverse direction for the box
/// test, and the shear constants of the triangle test (those on the ray's first packet:
/// [`PreparedRay::finish`]).
///
/// Scalars only: the vector tests splat the origin and the inverse directions where they use
/// them. On x86-64-v3, where they run, a splat from memory is one `vbroadcastss`, as cheap as
/// the load of a splatted copy (twelve such copies made the prepared ray 300 bytes, whose
/// stores cost more than the splats).
#[derive(Debug, Clone, Copy)]
pub(crate) struct PreparedRay {
    pub(crate) origin: Vec3A,
    pub(crate) dir: Vec3A,
    pub(crate) inv_dir: Vec3A,
    /// The shear of the triangle test (0 until [`PreparedRay::finish`]).
    pub(crate) sx: f32,
    pub(crate) sy: f32,
    /// The caller's `t_max`.
    pub(crate) t_max: f32,
    /// The inverse direction scaled by Ize's `1 + 2γ₃`, for far slab distances (one more
    /// rounding of at most u, which the factor's margin of γ₃ − u covers).
    pub(crate) inv_far: Vec3A,
    /// Which planes and axes the tests read, by the direction's signs and (from
    /// [`PreparedRay::finish`] on) its largest axis.
    pub(crate) slabs: Slabs,
    /// The 4-wide test's screen: a lane whose edge functions include one below `−screen` and
    /// one above `screen` certainly misses (see [`PreparedRay::set_screen`]). Until
    /// [`PreparedRay::finish`], the scene's coordinate bound, from which it sets the screen.
    pub(crate) screen: f32,
    /// Whether [`PreparedRay::finish`] has computed the triangle test's part.
    pub(crate) finished: bool,
}

impl PreparedRay {
    /// `None` for a ray that cannot hit anything: non-finite origin or direction, zero
    /// direction, or a `t_max` that is NaN or not positive.
    #[inline(always)]
    pub(crate) fn new(ray: &Ray) -> Option<PreparedRay> {
        Self::traceable(ray).then(|| {
            let mut r = Self::prepare(ray, f32::INFINITY);
            r.finish();
            r
        })
    }

    /// The axis of the largest direction component, which the triangle test maps to z (once
    /// [`PreparedRay::finish`]ed).
    #[inline(always)]
    pub(crate) fn kz(&self) -> usize {
        debug_assert!(self.finished, "the triangle test's part is not computed");
        self.slabs.perm[2] as usize
    }

    /// Computes the triangle test's part of the preparation, if not done yet: the largest axis
    /// of the direction, the permutation, the shear and the screen. The wide traversals call
    /// it on a ray's first packet, which in a small scene most shadow rays never reach (most
    /// of the Cornell box's are done at the root): per such ray the largest axis's selection, a
    /// division and the screen's arithmetic fewer (see docs/performance.md, ray offsets' floor
    /// and lazy preparation).
    #[inline(always)]
    pub(crate) fn finish(&mut self) {
        if self.finished {
            return;
        }
        self.finished = true;
        let a = self.dir.abs();
        // kz is the largest component; kx = kz + 1, ky = kz + 2 (mod 3). pbrt-v4: Sx = −d_x/d_z,
        // Sy = −d_y/d_z in the permuted frame (Sz is not needed: the distance comes from the
        // plane, see the module docs).
        // Selected without branches: the largest axis of a random direction is a coin toss.
        let kz = if a.x > a.y && a.x > a.z {
            0
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
        let da = self.dir.to_array();
        (self.sx, self.sy) = (-da[kx] / da[kz], -da[ky] / da[kz]);
        self.slabs.perm = Slabs::PERMUTATION[kz];
        self.set_screen(self.screen);
    }

    /// Whether `ray` can hit anything (see [`PreparedRay::new`]).
    #[inline(always)]
    pub(crate) fn traceable(ray: &Ray) -> bool {
        let o = Vec3A::from(ray.origin);
        let d = Vec3A::from(ray.direction);
        // `&` rather than `&&` on the conditions and lane masks rather than one test per
        // vector: fewer instructions, and no branch.
        (o.is_finite_mask() & d.is_finite_mask()).all()
            & d.cmpne(Vec3A::ZERO).any()
            & (ray.t_max > 0.0)
    }

    /// The prepared ray, for a `ray` that is [`PreparedRay::traceable`], in a scene whose vertex
    /// coordinates are at most `coordinate_bound` in magnitude (its screen, see
    /// [`PreparedRay::set_screen`]; ∞ screens nothing out), without the triangle test's part
    /// ([`PreparedRay::finish`] computes it). Separate from the check so that the hot callers
    /// build it in place: returned in an `Option`, it was copied once more per ray. (Where it is
    /// called, before the run-time dispatch: see `Job`'s docs in `layout.rs`.)
    #[inline(always)]
    pub(crate) fn prepare(ray: &Ray, coordinate_bound: f32) -> PreparedRay {
        let o = Vec3A::from(ray.origin);
        let d = Vec3A::from(ray.direction);
        // 1/d, clamped to ±2⁶⁴ so that a zero component gives a large finite value instead of
        // ±∞ (∞·0 is NaN when the origin lies on a slab plane). The clamp
        // only changes components below 5.4e-20 (relative to the others: the ray is then
        // parallel to that axis to within 5e-20 rad).
        let inv_dir = (Vec3A::ONE / d).clamp(-INV_DIR_LIMIT, INV_DIR_LIMIT);
        let inv_far = inv_dir * BOX_FAR_SCALE;
        // The signs of `d` are those of `inv_dir` (1/±0 = ±∞, clamped to ±2⁶⁴), and do not wait
        // for the division: the table entry, and the node test's plane loads after it, do not
        // follow the division's latency (see docs/performance.md, node test and ray
        // preparation).
        let signs = (d.is_negative_bitmask() & 7) as usize;
        PreparedRay {
            origin: o,
            dir: d,
            inv_dir,
            sx: 0.0,
            sy: 0.0,
            t_max: ray.t_max,
            inv_far,
            // Looked up by the signs (`inv_dir` is never ±0 or NaN, so its sign bit is
            // `< 0`, and it is `d`'s): a table load rather than a select per axis.
            slabs: Slabs::TABLE[signs],
            // The bound, until `finish` turns it into the screen.
            screen: coordinate_bound,
            finished: false,
        }
    }

    /// Sets [`PreparedRay::screen`] for a scene whose vertex coordinates are all at most
    /// `coordinate_bound` in magnitude: twice a bound on every filter bound `δ` that
    /// [`intersect_tri4`] can compute for this ray, so that a lane it screens out is one the
    /// full test finds missed too (the same answer, sooner).
    ///
    /// The bound. With `C = (B + O)(1 + u)`, `B` the coordinate bound and `O` the origin's
    /// largest component, every translated coordinate has `r ≤ C`, and every sheared one
    /// `|x + Sx·z| ≤ 2r(1 + 3u)` (`|Sx|, |Sy| ≤ 1`). The computed
    /// `δ = 2γ₃·xm·ym + 2e(xm + ym) + 2e² + MIN` (`e = 2γ₅r`, each term with ≤ 5 roundings) is
    /// then at most `(1 + 12u)·C²·(8γ₃ + 16γ₅ + 8γ₅²) + (1 + 5u)·MIN`. Computed here in `f64`
    /// with a relative margin of 2⁻¹⁶ (it covers the `(1 + 12u)`) and 4·MIN, then doubled:
    /// `s = 2(1 + 2⁻¹⁶)·C²·(8γ₃ + 16γ₅ + 8γ₅²) + 8·MIN`. Evaluated in `f32` as
    /// `fl(B + O)²·SCREEN_FACTOR + 8·MIN`, whose constant carries a further `1 + 2⁻¹²` for the
    /// `(1 + u)²` of `C` and the half-dozen roundings of the evaluation and of the constant.
    ///
    /// Why twice δ: a lane with `e_i < −2δ` and `e_j > 2δ` has `|e_i|, |e_j| > δ`, so those two
    /// signs are exact; and if its third edge function sends it to the `f64` test, that test's
    /// exact values are `< −δ` and `> δ` (each `f32` value errs by at most `δ`), far beyond its
    /// own rounding (2⁻²⁹ of `δ`'s), so it finds the same mixed signs: a miss either way.
    ///
    /// A huge bound (an origin or a scene near `f32::MAX`) gives ∞: nothing is screened out.
    #[inline(always)]
    pub(crate) fn set_screen(&mut self, coordinate_bound: f32) {
        let c = coordinate_bound + self.origin.abs().max_element();
        self.screen = c * c * SCREEN_FACTOR + 8.0 * f32::MIN_POSITIVE;
    }

    /// Entry distances of the four boxes of group `g` of a wide node's planes (min x, min y,
    /// min z, max x, max y, max z; per group, lane = box), and the mask of those entered within
    /// `[0, t_best]`, conservatively (Ize's factor on the far distances; the planes must be
    /// exact box bounds).
    #[inline(always)]
    pub(crate) fn hits4<const G: usize>(
        &self,
        planes: &[[[f32; 4]; G]; 6],
        g: usize,
        t_best: f32,
    ) -> (Vec4, u32) {
        let mut t_near = Vec4::ZERO;
        let mut t_far = Vec4::splat(t_best);
        for a in 0..3 {
            let near = Vec4::from_array(planes[self.slabs.near[a] as usize][g]);
            let far = Vec4::from_array(planes[self.slabs.far[a] as usize][g]);
            let o = Vec4::splat(self.origin[a]);
            t_near = t_near.max((near - o) * Vec4::splat(self.inv_dir[a]));
            t_far = t_far.min((far - o) * Vec4::splat(self.inv_far[a]));
        }
        (t_near, t_near.cmple(t_far).bitmask())
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
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct TriHit {
    pub(crate) t: f32,
    pub(crate) b1: f32,
    pub(crate) b2: f32,
}

/// The watertight test (see the module docs). Reports a hit only with `δt < t`, `t ≤ t_best`
/// and `t + δt < ray.t_max`, where `δt` bounds the rounding error of `t`.
///
/// `t_best` (the closest hit so far) is checked with the exact `t ≤ t_best`: a tie between two
/// triangles at the same computed distance goes to the later one, which is harmless.
#[inline(always)]
pub(crate) fn intersect_triangle<const KZ: usize>(
    tri: &TriSoa,
    ray: &PreparedRay,
    t_best: f32,
) -> Option<TriHit> {
    debug_assert!(ray.finished, "the triangle test's part is not computed");
    // Translate the vertices so the ray starts at the origin.
    let x = tri.xs - Vec3A::splat(ray.origin.x);
    let y = tri.ys - Vec3A::splat(ray.origin.y);
    let z = tri.zs - Vec3A::splat(ray.origin.z);
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
    let e = xt.yzx() * yt.zxy() - xt.zxy() * yt.yzx();
    // Filter (as in exact geometric predicates): every |e_i| above the bound `edge_error` has
    // the sign of the exact edge function; otherwise redo the test in f64, whose error is 2⁻²⁹
    // times smaller.
    let delta_e = edge_error(x, y, z, xt, yt);
    let (b1, b2) = if e.abs().cmple(Vec3A::splat(delta_e)).any() {
        edge_test_f64::<KZ>(tri, ray.origin, ray.sx, ray.sy)?
    } else {
        // The ray passes the triangle only if all three edge functions have the same sign.
        if e.cmplt(Vec3A::ZERO).any() && e.cmpgt(Vec3A::ZERO).any() {
            return None;
        }
        let inv_det = 1.0 / (e.x + e.y + e.z);
        (e.y * inv_det, e.z * inv_det)
    };
    // Distance to the plane through p0 (see the module docs): a = p0 − o was computed above.
    let a = Vec3A::new(x.x, y.x, z.x);
    let den = dot3(ray.dir, tri.n);
    let t = dot3(a, tri.n) / den;
    // A zero `den` (the ray parallel to the plane) gives ±∞ or NaN, rejected here or below.
    if t.is_nan() || t > t_best {
        return None;
    }
    // Bound on |t − t_exact|: with N = a·n and D = d·n, the computed N is within
    // γ₃·Σ|a_i n_i| of its value for the computed a and n (a dot of three), the rounding of a
    // and of n (each one u) add γ₂·Σ|a_i n_i|: γ₅ in all; likewise D is within γ₄·Σ|d_i n_i|.
    // Then |N/D − N*/D*| ≤ (|N − N*| + |t|·|D − D*|)/|D|, and the division adds u·|t|. The
    // bound itself is computed with a few roundings: γ₇, γ₆ and γ₂ instead of γ₅, γ₄ and γ₁
    // cover them.
    let t_abs = t.abs();
    let delta_t = (gamma(7) * sum3((a * tri.n).abs())
        + gamma(6) * t_abs * sum3((ray.dir * tri.n).abs()))
        / den.abs()
        + gamma(2) * t_abs;
    if t > delta_t && t + delta_t < ray.t_max {
        Some(TriHit { t, b1, b2 })
    } else {
        None
    }
}

/// `a·b` summed as `(x + y) + z`, the order the 4-wide test ([`intersect_tri4`]) uses too, so
/// both give the same bits.
#[inline(always)]
fn dot3(a: Vec3A, b: Vec3A) -> f32 {
    sum3(a * b)
}

/// `v.x + v.y + v.z`, summed in that order (see [`dot3`]).
#[inline(always)]
fn sum3(v: Vec3A) -> f32 {
    (v.x + v.y) + v.z
}

/// A bound on the error of the `f32` edge functions, from the translated vertices `x, y, z`
/// (`v − o`) and the sheared ones `xt, yt`.
///
/// With `R` the largest `|v − o|` component and `|Sx|, |Sy| ≤ 1` (z is the largest direction
/// component), a sheared coordinate `x + Sx·z` carries an error of at most
/// `E = γ₃·2R(1 + u) ≤ 2γ₄R` (translation, product and sum; `u` for `R` itself being computed).
/// An edge function `x_j·y_k − x_k·y_j` then errs by at most `γ₂·(|x_j y_k| + |x_k y_j|)` (its
/// own two roundings) plus `2·(X·E + Y·E + E²)` (its inputs' errors), with `X`, `Y` the largest
/// `|xt|`, `|yt|`: in all `2γ₂·XY + 4γ₄R·(X + Y) + 8γ₄²R²`. It is evaluated with `γ₃` and `γ₅`
/// in place of `γ₂` and `γ₄`, which covers the few roundings of the evaluation, plus the
/// smallest normal float for products that underflow.
///
/// Unlike a bound in `R²` alone, this one stays small for a small triangle far from the
/// origin (its sheared coordinates `X`, `Y` are small where the ray passes near it), so the
/// `f64` path stays rare.
#[inline(always)]
fn edge_error(x: Vec3A, y: Vec3A, z: Vec3A, xt: Vec3A, yt: Vec3A) -> f32 {
    let r = x.abs().max(y.abs()).max(z.abs()).max_element();
    let xm = xt.abs().max_element();
    let ym = yt.abs().max_element();
    let e = 2.0 * gamma(5) * r;
    2.0 * gamma(3) * xm * ym + 2.0 * e * (xm + ym) + 2.0 * e * e + f32::MIN_POSITIVE
}

/// Four triangles as the 4-wide test reads them (lane = triangle): per axis, per vertex, the
/// coordinates (`v[axis][vertex]`), and the components of the unit normal. A packet of fewer
/// than four triangles repeats its last one in the spare lanes (a repeated triangle gives the
/// same hit, so it changes no answer). 192 bytes, three cache lines.
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(64))]
pub(crate) struct Tri4 {
    v: [[[f32; 4]; 3]; 3],
    n: [[f32; 4]; 3],
}

impl crate::pages::Plain for Tri4 {
    fn write_to(&self, out: &mut [u8]) {
        out.copy_from_slice(bytemuck::bytes_of(self));
    }
}

impl Tri4 {
    /// A packet of one to four triangles (the first four of `tris`; `tris` must not be empty).
    pub(crate) fn new(tris: &[TriSoa]) -> Tri4 {
        let mut v = [[[0.0f32; 4]; 3]; 3];
        let mut n = [[0.0f32; 4]; 3];
        for lane in 0..4 {
            let t = &tris[lane.min(tris.len() - 1)];
            for (axis, coordinates) in [t.xs, t.ys, t.zs].into_iter().enumerate() {
                for vertex in 0..3 {
                    v[axis][vertex][lane] = coordinates[vertex];
                }
            }
            for (axis, c) in t.n.to_array().into_iter().enumerate() {
                n[axis][lane] = c;
            }
        }
        Tri4 { v, n }
    }

    /// The triangle in `lane`, as the scalar test reads it (bit for bit the `TriSoa` it was
    /// made from). Twelve scalar loads: the packet is stored as plain arrays because indexing
    /// a `Vec4` by a variable lane compiles to a jump table (a mispredicted jump for a random
    /// lane) or to a spill of the whole vector.
    #[inline]
    pub(crate) fn lane(&self, lane: usize) -> TriSoa {
        let get = |v: &[[f32; 4]; 3]| Vec3A::new(v[0][lane], v[1][lane], v[2][lane]);
        TriSoa {
            xs: get(&self.v[0]),
            ys: get(&self.v[1]),
            zs: get(&self.v[2]),
            n: get(&self.n),
        }
    }
}

/// The hits of a ray on a [`Tri4`]: per lane the distance and barycentrics, and the mask of the
/// lanes that hit. A lane that missed has distance ∞, unless no lane hit (then the distances
/// mean nothing: a packet screened out returns zeros).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Tri4Hits {
    pub(crate) t: Vec4,
    pub(crate) b1: Vec4,
    pub(crate) b2: Vec4,
    pub(crate) mask: u32,
}

impl Tri4Hits {
    /// The closest of the hits, as (lane, hit); lane 4 (and a meaningless hit) if no lane hit.
    /// Of equal distances, the lowest lane. Without a branch: which lanes hit, and how many, is a
    /// coin toss (a loop over the hit lanes mispredicted).
    #[inline(always)]
    pub(crate) fn closest(&self) -> (usize, TriHit) {
        // Lanes that missed have distance ∞ and a hit's is finite, so the minimum is a hit's
        // unless there is none.
        let t = self.t.min_element();
        let lane = ((self.t.cmpeq(Vec4::splat(t)).bitmask() & self.mask) | 16).trailing_zeros();
        // Arrays, not `Vec4` indexing (see `Tri4::lane`).
        let (b1, b2) = (self.b1.to_array(), self.b2.to_array());
        let l = lane as usize & 3;
        (
            lane as usize,
            TriHit {
                t,
                b1: b1[l],
                b2: b2[l],
            },
        )
    }

    /// The closest of the hits in lanes `mask` (some of `self.mask`'s, at least one), as
    /// (lane, hit); of equal distances, the lowest lane. For the whole mask, the lane and hit
    /// [`Tri4Hits::closest`] gives. With a loop over the lanes: only hit filters ask for it,
    /// retrying without each lane their filter rejects.
    #[inline(always)]
    pub(crate) fn closest_in(&self, mask: u32) -> (usize, TriHit) {
        debug_assert!(
            mask != 0 && mask & !self.mask == 0,
            "{mask:#b} of {:#b}",
            self.mask
        );
        // A hit's distance is finite, so the first lane of `mask` beats the initial ∞.
        let t = self.t.to_array();
        let (mut lane, mut t_min) = (0, f32::INFINITY);
        for (l, &tl) in t.iter().enumerate() {
            if mask & (1 << l) != 0 && tl < t_min {
                (lane, t_min) = (l, tl);
            }
        }
        (lane, self.lane(lane))
    }

    /// Lane `lane`'s hit (meaningful only for a lane of `self.mask`).
    #[inline(always)]
    pub(crate) fn lane(&self, lane: usize) -> TriHit {
        // Arrays, not `Vec4` indexing (see `Tri4::lane`).
        TriHit {
            t: self.t.to_array()[lane],
            b1: self.b1.to_array()[lane],
            b2: self.b2.to_array()[lane],
        }
    }
}

/// A packet translated to the ray's origin and permuted (`p`: per axis x, y, z of the permuted
/// frame, per vertex), and sheared so that the ray runs along +z (`xt`, `yt`, per vertex), with
/// the same operations as the scalar test. The origin is splatted from memory (one
/// `vbroadcastss` where the tests run) and the arrays are indexed by [`Axis`] (no bounds check).
#[inline(always)]
fn sheared(tri: &Tri4, ray: &PreparedRay) -> ([[Vec4; 3]; 3], [Vec4; 3], [Vec4; 3]) {
    let o: &[f32; 3] = ray.origin.as_ref();
    let p = ray
        .slabs
        .perm
        .map(|k| tri.v[k as usize].map(|v| Vec4::from_array(v) - Vec4::splat(o[k as usize])));
    let [px, py, pz] = p;
    let sx = Vec4::splat(ray.sx);
    let sy = Vec4::splat(ray.sy);
    let xt = [0, 1, 2].map(|v| px[v] + sx * pz[v]);
    let yt = [0, 1, 2].map(|v| py[v] + sy * pz[v]);
    (p, xt, yt)
}

/// The lanes of [`intersect_tri4`] with an edge function `e` within the filter bound of
/// `edge_error` (computed per lane with the same operations; max is exact, so its order does
/// not matter): those the scalar `f64` test decides.
#[inline(always)]
fn near_lanes(tri: &Tri4, ray: &PreparedRay, e: [Vec4; 3]) -> u32 {
    let ([px, py, pz], xt, yt) = sheared(tri, ray);
    let r = px[0]
        .abs()
        .max(px[1].abs())
        .max(px[2].abs())
        .max(py[0].abs().max(py[1].abs()).max(py[2].abs()))
        .max(pz[0].abs().max(pz[1].abs()).max(pz[2].abs()));
    let xm = xt[0].abs().max(xt[1].abs()).max(xt[2].abs());
    let ym = yt[0].abs().max(yt[1].abs()).max(yt[2].abs());
    let err = Vec4::splat(2.0 * gamma(5)) * r;
    let delta_e = Vec4::splat(2.0 * gamma(3)) * xm * ym
        + Vec4::splat(2.0) * err * (xm + ym)
        + Vec4::splat(2.0) * err * err
        + Vec4::splat(f32::MIN_POSITIVE);
    (e[0].abs().cmple(delta_e) | e[1].abs().cmple(delta_e) | e[2].abs().cmple(delta_e)).bitmask()
}

/// [`intersect_triangle`] on four triangles at once (lane = triangle), with the same operations
/// in the same order on each lane, so each lane's answer is bit for bit the scalar test's. A
/// lane whose edge functions fail the filter is redone by the scalar `f64` test, as there.
///
/// Before the filter, the packet is screened with the ray's [`PreparedRay::screen`]: when every
/// lane has edge functions of certain opposite signs, the packet is a miss and nothing more is
/// computed (most packets a ray reaches, it passes by). The permutation is the ray's `perm`,
/// applied by indexing the packet's coordinate arrays, so one body serves every ray.
///
/// With `shortcut` (a constant where the test is inlined: the traversals pass it per tree
/// size, see `wide.rs`'s `LARGE_BYTES`), the filter bound is computed only when half the
/// screen does not already prove every lane clear of its edges. Either way the answer is the
/// same.
#[inline(always)]
pub(crate) fn intersect_tri4(
    tri: &Tri4,
    ray: &PreparedRay,
    t_best: f32,
    shortcut: bool,
) -> Tri4Hits {
    debug_assert!(ray.finished, "the triangle test's part is not computed");
    const MISS: Tri4Hits = Tri4Hits {
        t: Vec4::ZERO,
        b1: Vec4::ZERO,
        b2: Vec4::ZERO,
        mask: 0,
    };
    let (_, xt, yt) = sheared(tri, ray);
    // Edge functions e_i = x_j·y_k − x_k·y_j for (i, j, k) cyclic.
    let e0 = xt[1] * yt[2] - xt[2] * yt[1];
    let e1 = xt[2] * yt[0] - xt[0] * yt[2];
    let e2 = xt[0] * yt[1] - xt[1] * yt[0];
    // The screen (see above): lanes certainly missed.
    let screen = Vec4::splat(ray.screen);
    let below = e0.cmplt(-screen) | e1.cmplt(-screen) | e2.cmplt(-screen);
    let above = e0.cmpgt(screen) | e1.cmpgt(screen) | e2.cmpgt(screen);
    if (below & above).bitmask() == 0xf {
        return MISS;
    }
    // Lanes with an edge function within the filter bound `δ` of zero (`near`), which the
    // scalar `f64` test decides. The shortcut: half the screen is at least every lane's `δ`,
    // so when no edge function is within it, no lane is near and `δ` need not be computed
    // (the common case in a small scene: the ray passes 10⁻⁵ of the scene's size away from
    // every edge's line; not in a large one, whose triangles are small against the scene).
    // Halving is exact (the screen is at least 8·MIN, a normal number, or ∞).
    let e = [e0, e1, e2];
    let near = if !shortcut {
        near_lanes(tri, ray, e)
    } else {
        let half = Vec4::splat(0.5 * ray.screen);
        if (e0.abs().cmple(half) | e1.abs().cmple(half) | e2.abs().cmple(half)).bitmask() == 0 {
            0
        } else {
            // Through `black_box`, so that the sheared packet is recomputed here rather than
            // kept alive (spilled) on the common path.
            near_lanes(std::hint::black_box(tri), ray, e)
        }
    };
    // The ray passes a triangle only if its three edge functions have the same sign.
    let zero = Vec4::ZERO;
    let neg = e0.cmplt(zero) | e1.cmplt(zero) | e2.cmplt(zero);
    let pos = e0.cmpgt(zero) | e1.cmpgt(zero) | e2.cmpgt(zero);
    let mut inside = !(neg & pos).bitmask() & 0xf & !near;
    if inside | near == 0 {
        return MISS;
    }
    let inv_det = Vec4::ONE / (e0 + e1 + e2);
    let b1 = e1 * inv_det;
    let b2 = e2 * inv_det;
    // Lanes within rounding distance of an edge: the scalar f64 test decides. The lanes the
    // ray passes, as a vector mask too (for `Tri4Hits::t`).
    let (b1, b2, inside_v) = if near == 0 {
        (b1, b2, !(neg & pos))
    } else {
        let (mut b1, mut b2) = (b1.to_array(), b2.to_array());
        let mut m = near;
        while m != 0 {
            let l = m.trailing_zeros() as usize;
            m &= m - 1;
            let lane = tri.lane(l);
            let found = match ray.kz() {
                0 => edge_test_f64::<0>(&lane, ray.origin, ray.sx, ray.sy),
                1 => edge_test_f64::<1>(&lane, ray.origin, ray.sx, ray.sy),
                _ => edge_test_f64::<2>(&lane, ray.origin, ray.sx, ray.sy),
            };
            if let Some((c1, c2)) = found {
                inside |= 1 << l;
                b1[l] = c1;
                b2[l] = c2;
            }
        }
        let lane = |l: u32| inside & (1 << l) != 0;
        let inside_v = BVec4A::new(lane(0), lane(1), lane(2), lane(3));
        (Vec4::from_array(b1), Vec4::from_array(b2), inside_v)
    };
    // Distance to the plane through p0, and its error bound (see `intersect_triangle`), in
    // world axis order, as the scalar test sums.
    let a = [0, 1, 2].map(|axis| Vec4::from_array(tri.v[axis][0]) - Vec4::splat(ray.origin[axis]));
    let d = [0, 1, 2].map(|axis| Vec4::splat(ray.dir[axis]));
    let n = &tri.n.map(Vec4::from_array);
    let den = (d[0] * n[0] + d[1] * n[1]) + d[2] * n[2];
    let an = [a[0] * n[0], a[1] * n[1], a[2] * n[2]];
    let t = ((an[0] + an[1]) + an[2]) / den;
    let t_abs = t.abs();
    let dn = (d[0] * n[0]).abs() + (d[1] * n[1]).abs() + (d[2] * n[2]).abs();
    let delta_t = (Vec4::splat(gamma(7)) * ((an[0].abs() + an[1].abs()) + an[2].abs())
        + Vec4::splat(gamma(6)) * t_abs * dn)
        / den.abs()
        + Vec4::splat(gamma(2)) * t_abs;
    // NaN distances fail every comparison, as in the scalar test.
    let ok = t.cmple(Vec4::splat(t_best))
        & t.cmpgt(delta_t)
        & (t + delta_t).cmplt(Vec4::splat(ray.t_max));
    let hit = ok & inside_v;
    // A hit's distance is finite (`t + δt < t_max` fails for ∞); the other lanes get ∞.
    Tri4Hits {
        t: Vec4::select(hit, t, Vec4::INFINITY),
        b1,
        b2,
        mask: hit.bitmask(),
    }
}

/// The edge test in `f64` from the original data, for rays that pass within rounding distance
/// of an edge: translation and products of `f32` values are (nearly) exact in `f64`, the shear
/// uses the same `Sx`, `Sy` as the `f32` test (so both approximate the same exact problem), and
/// each edge function errs by ~2⁻⁵⁰·R², 2⁻²⁹ times less than in `f32`. A shared edge gives
/// bitwise opposite values in both triangles (same operands), so the test stays watertight.
/// Returns the barycentrics `(b1, b2)` if the ray passes the triangle.
#[cold]
#[inline(never)]
fn edge_test_f64<const KZ: usize>(
    tri: &TriSoa,
    origin: Vec3A,
    sx: f32,
    sy: f32,
) -> Option<(f32, f32)> {
    let x = tri.xs.as_dvec3() - DVec3::splat(f64::from(origin.x));
    let y = tri.ys.as_dvec3() - DVec3::splat(f64::from(origin.y));
    let z = tri.zs.as_dvec3() - DVec3::splat(f64::from(origin.z));
    let (px, py, pz) = match KZ {
        0 => (y, z, x),
        1 => (z, x, y),
        _ => (x, y, z),
    };
    let xt = px + f64::from(sx) * pz;
    let yt = py + f64::from(sy) * pz;
    let e = DVec3::new(
        xt.y * yt.z - xt.z * yt.y,
        xt.z * yt.x - xt.x * yt.z,
        xt.x * yt.y - xt.y * yt.x,
    );
    if e.cmplt(DVec3::ZERO).any() && e.cmpgt(DVec3::ZERO).any() {
        return None;
    }
    let det = e.x + e.y + e.z;
    if det == 0.0 {
        return None;
    }
    Some(((e.y / det) as f32, (e.z / det) as f32))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hit(tri: [Vec3; 3], ray: &Ray) -> Option<TriHit> {
        let r = PreparedRay::new(ray)?;
        let t = TriSoa::new(tri);
        match r.kz() {
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
        // Zero components of either sign: −0 has the inverse −2⁶⁴, so its slab's near plane
        // must be the max plane (the sign bit, not `< 0`, chooses it). The wide layouts' test
        // reads the planes through the table of the direction's signs: lane 0 the box, lanes 1
        // to 3 empty (min planes ∞, max planes −∞).
        let (lo, hi) = (min.to_array(), max.to_array());
        let planes: [[[f32; 4]; 1]; 6] = std::array::from_fn(|k| {
            let empty = if k < 3 {
                f32::INFINITY
            } else {
                f32::NEG_INFINITY
            };
            [[if k < 3 { lo[k] } else { hi[k - 3] }, empty, empty, empty]]
        });
        for d in [
            Vec3::new(-0.0, -1.0, -0.0),
            Vec3::new(0.0, -1.0, -0.0),
            Vec3::new(-0.0, -1.0, 0.0),
        ] {
            let r = PreparedRay::new(&Ray::new(Vec3::new(0.5, 1.0, 0.5), d))
                .unwrap_or_else(|| panic!("valid ray"));
            assert_eq!(box_entry(min, max, &r, f32::INFINITY), 1.0, "{d}");
            let (t, mask) = r.hits4(&planes, 0, f32::INFINITY);
            assert_eq!((t.x, mask), (1.0, 1), "{d}");
        }
        // Missing above.
        let r = PreparedRay::new(&Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X))
            .unwrap_or_else(|| panic!("valid ray"));
        assert_eq!(box_entry(min, max, &r, f32::INFINITY), f32::INFINITY);
    }

    proptest::proptest! {
        /// The screen only ever skips work: a packet tested with the ray's screen set gives
        /// the same bits as with no screen (∞), for rays through a random point, an edge or a
        /// vertex of the packet's triangles (where edge functions are within the filter), and
        /// at scales and translations up to 1e5.
        #[test]
        fn the_screen_never_changes_a_packet_answer(
            seed in proptest::num::u64::ANY,
            scale in proptest::sample::select(vec![1e-3f32, 1.0, 1e3]),
            shift in proptest::sample::select(vec![0.0f32, 1e3, 1e5]),
            aim in 0usize..3,
        ) {
            // SplitMix64 values in [−0.5, 0.5).
            let mut state = seed;
            let values: Vec<f32> = (0..48)
                .map(|_| {
                    state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
                    let mut z = state;
                    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
                    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
                    ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32 - 0.5
                })
                .collect();
            let point = |i: usize, k: f32| {
                Vec3::new(values[3 * i], values[3 * i + 1], values[3 * i + 2]) * k * scale
                    + Vec3::splat(shift)
            };
            let tris: Vec<[Vec3; 3]> =
                (0..4).map(|t| [point(3 * t, 1.0), point(3 * t + 1, 1.0), point(3 * t + 2, 1.0)]).collect();
            let bound = tris
                .iter()
                .flatten()
                .fold(0.0f32, |m, p| m.max(p.abs().max_element()));
            // Aim at a random point, an edge point or a vertex of the first triangle.
            let [a, b, c] = tris[0];
            let w = values[47] + 0.5;
            let target = match aim {
                0 => a * 0.25 + b * 0.25 + c * 0.5,
                1 => a * w + b * (1.0 - w),
                _ => b,
            };
            let origin = point(13, 3.0);
            let ray = Ray::new(origin, target - origin);
            let packet = Tri4::new(&tris.iter().map(|t| TriSoa::new(*t)).collect::<Vec<_>>());
            if let Some(mut r) = PreparedRay::new(&ray) {
                let open = intersect_tri4(&packet, &r, r.t_max, false);
                r.set_screen(bound);
                proptest::prop_assert!(r.screen.is_finite() && r.screen > 0.0);
                // The screen, with and without the shortcut it allows.
                for shortcut in [false, true] {
                    let screened = intersect_tri4(&packet, &r, r.t_max, shortcut);
                    proptest::prop_assert_eq!(open.mask, screened.mask);
                    for l in (0..4).filter(|l| open.mask & (1 << l) != 0) {
                        for (x, y) in [(open.t, screened.t), (open.b1, screened.b1), (open.b2, screened.b2)] {
                            proptest::prop_assert_eq!(x.to_array()[l].to_bits(), y.to_array()[l].to_bits());
                        }
                    }
                }
            }
        }
    }
}
