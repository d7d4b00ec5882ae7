//! The gather's hit points as a triangle fan: the occlusion-aware translation gradient and the
//! irradiance Hessian (Schwarzhaupt, Jensen & Jarosz 2012, "Practical Hessian-Based Error
//! Control for Irradiance Caching", in the form Radiance ≥ 4.2 computes it in `ambcomp.c`).
//!
//! # The fan
//! Each cell's sample direction ω and hit distance r give a hit point r·ω (in the local frame,
//! the gather point at the origin; a miss is put at [`FAR_FACTOR`] times the farthest hit). The
//! points of neighbouring cells are joined into triangles: each quad of rows j, j+1 and columns
//! k, k+1 (k wrapping around the pole) splits into (j,k)(j,k+1)(j+1,k) and
//! (j+1,k+1)(j+1,k)(j,k+1); the ring of row 0 is closed over the pole by a fan from (0,0). Each
//! triangle T carries the value L_T of its **farthest** vertex (Radiance's `back_ambval`: the
//! nearer surfaces are the occluders, so the farther value is what the triangle's interior shows).
//! Radiance's fan stops at the last row; irr's closes the band below it with a ring on the
//! horizon ([`with_horizon`]).
//!
//! # Irradiance from a triangle, and its derivatives
//! Lambert's formula (Arvo 1995) gives the projected solid angle of a polygon seen from x with
//! normal n as a sum over its edges a→b: Ω = Σₑ ½ (n·c) I₁, with c = (a − x) × (b − x) and
//! I₁ = ∫₀¹ |r(t)|⁻² dt = angle(a − x, b − x)/|c|, r(t) = (a − x) + t·e, e = b − a. Then
//! E = Σ_T L_T Ω_T. Differentiating under the integral with respect to x (∇(n·c) = n × e,
//! ∇|r|⁻² = 2r|r|⁻⁴, ∇(r|r|⁻⁴) = 4rrᵀ|r|⁻⁶ − |r|⁻⁴·𝟙):
//!
//! - ∇Ωₑ = ½ [(n × e) I₁ + 2 (n·c) g],  g = ∫ r|r|⁻⁴ dt = I₂ (a − x) + J₂ e;
//! - ∇∇Ωₑ = (n × e) gᵀ + g (n × e)ᵀ + (n·c) (4 ∫ rrᵀ|r|⁻⁶ dt − I₂ 𝟙),
//!   ∫ rrᵀ|r|⁻⁶ = I₃ (a−x)(a−x)ᵀ + J₃ ((a−x)eᵀ + e(a−x)ᵀ) + K₃ eeᵀ;
//!
//! with I₂, J₂ = ∫{1, t}|r|⁻⁴ and I₃, J₃, K₃ = ∫{1, t, t²}|r|⁻⁶ by the reduction formulas for
//! ∫ tᵏ/Qⁿ, Q = At² + Bt + C = |r|², whose discriminant is Δ = 4AC − B² = 4|c|²
//! ([`edge_integrals`]). Reversing an edge negates all three terms, so an edge shared by two
//! triangles counts once with the difference of their values: only edges between triangles of
//! different value, and the outer perimeter, contribute.
//!
//! The gradient is that of the fan's irradiance with the real values (per channel: an absolute
//! gradient like the other two estimators'). It is **occlusion-aware**: a triangle's value is
//! held while its corners are fixed points in space, so moving x changes which solid angle each
//! surface covers, the effect of occluders that the split-sphere and Ward–Heckbert's walls model
//! only through the nearer distance.
//!
//! The Hessian is **relative** (units 1/length²): the fan of Radiance's normalised scalar values
//! v' = 0.99·v·MN/Σv + 0.01, v the channel mean (mean v' = 1), divided by π, so a uniform
//! hemisphere of v' = 1 has E = 1. The 0.01 floor keeps a geometric term where the gather is
//! dark, and an all-black gather is taken as v' = 1 everywhere (the purely geometric Hessian).

use crate::samples::GatherSamples;
use crate::value::GatherValue;
use glam::{DMat3, DVec3, Vec3};
use std::f64::consts::PI;

/// A miss is put at this many times the farthest hit's distance (Radiance uses 10× the scene's
/// size + 1000, a length; a multiple of the gather's own distances keeps the result the same in
/// any unit). A triangle at distance D contributes O(1/D²) to the Hessian, so 10³ makes the sky's
/// own curvature 10⁻⁶ of the nearest geometry's.
pub(crate) const FAR_FACTOR: f64 = 1e3;

/// Below this sin² of the angle an edge subtends at x, its integrals are taken in the collinear
/// limit (see [`edge_terms`]): the reduction formulas divide by Δ = 4|c|² twice, so I₃ loses
/// about log₁₀(1/(4 sin²θ))² digits; at sin² = 10⁻⁴ that is 7.8 of f64's 16.
const NEAR_COLLINEAR: f64 = 1e-4;

/// The triangle fan's results, in the gather's local frame (normal +z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fan<V> {
    /// The fan's own irradiance estimate Σ_T L_T Ω_T (short of the stratified estimate by the
    /// uncovered band below the last row).
    pub irradiance: V,
    /// ∇E of the fan, per channel: the occlusion-aware translation gradient.
    pub gradient: [V; 3],
    /// The relative irradiance Hessian (1/length², symmetric; see the module docs).
    pub hessian: DMat3,
}

/// The tangent-plane curvature of a relative Hessian: its 2×2 block's eigenvalues by absolute
/// size and the direction of the larger, along which a record must be shortest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Curvature {
    /// The larger |λ| (1/length²).
    pub major: f64,
    /// The smaller |λ|.
    pub minor: f64,
    /// The unit tangent (z = 0) along which |λ| = `major`: the record's minor axis.
    pub axis: DVec3,
    /// The eigenvalues with their signs: along `axis`, then along z × `axis`.
    pub signed: [f64; 2],
}

impl Curvature {
    /// The eigen-decomposition of the tangent block [[h₀₀, h₀₁], [h₀₁, h₁₁]] of `h` by one Jacobi
    /// rotation: the angle ψ = ½ atan2(2h₀₁, h₀₀ − h₁₁) diagonalises it exactly, for every sign of
    /// the eigenvalues and at a double root (ψ is then any angle; atan2(0, 0) = 0 picks x).
    pub fn of(h: &DMat3) -> Self {
        let (a, b, d) = (h.x_axis.x, h.y_axis.x, h.y_axis.y);
        let psi = 0.5 * (2.0 * b).atan2(a - d);
        let (s, c) = psi.sin_cos();
        let l0 = a * c * c + 2.0 * b * s * c + d * s * s;
        let l1 = a * s * s - 2.0 * b * s * c + d * c * c;
        let (u0, u1) = (DVec3::new(c, s, 0.0), DVec3::new(-s, c, 0.0));
        if l0.abs() >= l1.abs() {
            Self {
                major: l0.abs(),
                minor: l1.abs(),
                axis: u0,
                signed: [l0, l1],
            }
        } else {
            Self {
                major: l1.abs(),
                minor: l0.abs(),
                axis: u1,
                signed: [l1, l0],
            }
        }
    }
}

/// ∫₀¹ {1, t}·|r|⁻⁴ and ∫₀¹ {1, t, t²}·|r|⁻⁶ along r(t) = a + t(b − a), and I₁ = ∫ |r|⁻²:
/// `[i1, i2, j2, i3, j3, k3]`, for an edge that does not pass through the origin (the
/// reduction formulas; no guard against Δ → 0, which [`edge_terms`] handles).
pub(crate) fn edge_integrals(a: DVec3, b: DVec3) -> [f64; 6] {
    let e = b - a;
    let (qa, qb, qc) = (e.length_squared(), 2.0 * a.dot(e), a.length_squared());
    let q1 = b.length_squared();
    let c = a.cross(b).length();
    let delta = 4.0 * c * c;
    let i1 = c.atan2(a.dot(b)) / c;
    // ∫dt/Q² = (2At+B)/(ΔQ) + (2A/Δ)∫dt/Q;  ∫t dt/Q² = −(Bt+2C)/(ΔQ) − (B/Δ)∫dt/Q.
    let i2 = ((2.0 * qa + qb) / q1 - qb / qc) / delta + 2.0 * qa / delta * i1;
    let j2 = (2.0 - (qb + 2.0 * qc) / q1) / delta - qb / delta * i1;
    // ∫dt/Q³ = (2At+B)/(2ΔQ²) + (3A/Δ)∫dt/Q²;  ∫t dt/Q³ = −(Bt+2C)/(2ΔQ²) − (3B/2Δ)∫dt/Q²;
    // t² = (Q − Bt − C)/A gives ∫t² dt/Q³ = (∫dt/Q² − B∫t dt/Q³ − C∫dt/Q³)/A.
    let i3 = ((2.0 * qa + qb) / (q1 * q1) - qb / (qc * qc)) / (2.0 * delta) + 3.0 * qa / delta * i2;
    let j3 = -((qb + 2.0 * qc) / (q1 * q1) - 2.0 / qc) / (2.0 * delta) - 1.5 * qb / delta * i2;
    let k3 = (i2 - qb * j3 - qc * i3) / qa;
    [i1, i2, j2, i3, j3, k3]
}

/// One edge a → b of Lambert's sum seen from the origin with normal +z: (Ωₑ, ∇Ωₑ, ∇∇Ωₑ) with
/// respect to the viewpoint (module docs). Zero for an edge of zero length.
///
/// Where a and b lie within sin² < `NEAR_COLLINEAR` of one line through the origin, the
/// integrals are those of the segment moved onto that line (r = â(α + t(γ − α)), α = |a|,
/// γ = |b|): I₁ = 1/(αγ), ∫r|r|⁻⁴ = â(α+γ)/(2α²γ²), I₂ = (α²+αγ+γ²)/(3α³γ³), ∫rrᵀ|r|⁻⁶ = ââᵀI₂,
/// each off by O(sin θ) relative, on an edge whose (n·c) factor is itself O(sin θ). An edge
/// along a line through the origin with a and b on opposite sides would pass through the
/// viewpoint; no fan of a hemisphere has one, and it is given no contribution.
pub(crate) fn edge_terms(a: DVec3, b: DVec3) -> (f64, DVec3, DMat3) {
    let e = b - a;
    let (aa, bb) = (a.length_squared(), b.length_squared());
    if e.length_squared() <= f64::EPSILON * aa.max(bb) {
        return (0.0, DVec3::ZERO, DMat3::ZERO);
    }
    let c = a.cross(b);
    let nc = c.z;
    let n_x_e = DVec3::new(-e.y, e.x, 0.0);
    let (i1, i2, g, m) = if c.length_squared() >= NEAR_COLLINEAR * aa * bb {
        let [i1, i2, j2, i3, j3, k3] = edge_integrals(a, b);
        let g = a * i2 + e * j2;
        let ae = outer(a, e);
        let m = outer(a, a) * i3 + (ae + ae.transpose()) * j3 + outer(e, e) * k3;
        (i1, i2, g, m)
    } else {
        if a.dot(b) <= 0.0 {
            return (0.0, DVec3::ZERO, DMat3::ZERO);
        }
        let (alpha, gamma) = (aa.sqrt(), bb.sqrt());
        let dir = a / alpha;
        let i1 = 1.0 / (alpha * gamma);
        let g = dir * ((alpha + gamma) / (2.0 * aa * bb));
        let i2 = (aa + alpha * gamma + bb) / (3.0 * aa * alpha * bb * gamma);
        (i1, i2, g, outer(dir, dir) * i2)
    };
    let omega = 0.5 * nc * i1;
    let gradient = 0.5 * (n_x_e * i1 + 2.0 * nc * g);
    let ng = outer(n_x_e, g);
    let hessian = ng + ng.transpose() + (m * 4.0 - DMat3::IDENTITY * i2) * nc;
    (omega, gradient, hessian)
}

/// u vᵀ.
#[inline]
fn outer(u: DVec3, v: DVec3) -> DMat3 {
    DMat3::from_cols(u * v.x, u * v.y, u * v.z)
}

/// The fan's edges, each once, in a canonical direction, with the signed sums of the values of
/// the triangles on either side (a triangle that runs along the edge's direction adds its value,
/// one that runs against it subtracts it). Layout over an M×N grid (vertex (j, k) = j·N + k):
/// - `ring(j, k)`: (j, k) → (j, k+1 mod N), M·N of them;
/// - `up(j, k)`: (j, k) → (j+1, k), for j < M − 1;
/// - `diagonal(j, k)`: (j, k+1 mod N) → (j+1, k), for j < M − 1;
/// - `cap(k)`: (0, 0) → (0, k), for 2 ≤ k ≤ N − 2 (the pole fan's inner edges).
struct Edges<V> {
    m: usize,
    n: usize,
    /// Per edge: (relative scalar weight, per-channel weight).
    weights: Vec<(f64, V)>,
}

impl<V: GatherValue> Edges<V> {
    fn new(m: usize, n: usize) -> Self {
        let count = m * n + 2 * (m - 1) * n + n.saturating_sub(3);
        Self {
            m,
            n,
            weights: vec![(0.0, V::default()); count],
        }
    }
    /// The canonical endpoints of edge `i` (vertex indices).
    fn endpoints(&self, i: usize) -> (usize, usize) {
        let (m, n) = (self.m, self.n);
        let v = |j: usize, k: usize| j * n + k;
        if i < m * n {
            let (j, k) = (i / n, i % n);
            (v(j, k), v(j, (k + 1) % n))
        } else if i < m * n + (m - 1) * n {
            let r = i - m * n;
            let (j, k) = (r / n, r % n);
            (v(j, k), v(j + 1, k))
        } else if i < m * n + 2 * (m - 1) * n {
            let r = i - m * n - (m - 1) * n;
            let (j, k) = (r / n, r % n);
            (v(j, (k + 1) % n), v(j + 1, k))
        } else {
            (0, i - m * n - 2 * (m - 1) * n + 2)
        }
    }
    fn add(&mut self, edge: usize, sign: f64, w: (f64, V)) {
        let slot = &mut self.weights[edge];
        slot.0 += sign * w.0;
        slot.1 = slot.1 + w.1 * sign as f32;
    }
}

impl<V: GatherValue> GatherSamples<V> {
    /// The triangle fan over this gather's hit points: its irradiance, the occlusion-aware
    /// translation gradient and the relative Hessian, in the local frame (module docs).
    ///
    /// The hit points use the directions given with [`GatherSamples::with_directions`], or each
    /// cell's middle direction when none were given. A gather with no hit at all (an open sky,
    /// infinitely far) has E independent of position: zero gradient and zero Hessian.
    pub fn fan(&self) -> Fan<V> {
        let Some(points) = self.hit_points() else {
            return Fan {
                irradiance: V::default(),
                gradient: [V::default(); 3],
                hessian: DMat3::ZERO,
            };
        };
        let values = self.radiance();
        let relative = relative_values(values);
        let strata = self.strata();
        let (m, n) = (strata.m() as usize, strata.n() as usize);
        // The horizon ring (row M) shows what the last row shows.
        let cell = |i: usize| if i < m * n { i } else { i - n };
        let triangles = fan_triangles(m + 1, n);
        let weights = triangles.iter().map(|t| {
            let far = cell(t.farthest(&points));
            (relative[far], values[far])
        });
        accumulate(m + 1, n, &points, &triangles, weights)
    }

    /// The hit points r·ω in the local frame, misses at [`FAR_FACTOR`] times the farthest hit,
    /// then the horizon ring ([`with_horizon`]); `None` when no ray hit anything.
    pub(crate) fn hit_points(&self) -> Option<Vec<DVec3>> {
        let distance = self.distance();
        let farthest = distance
            .iter()
            .filter(|r| r.is_finite())
            .fold(0.0f64, |acc, &r| acc.max(f64::from(r)));
        if farthest == 0.0 {
            return None;
        }
        let far = FAR_FACTOR * farthest;
        let points = (0..distance.len())
            .map(|i| {
                let r = f64::from(distance[i]);
                self.sample_direction(i).as_dvec3() * if r.is_finite() { r } else { far }
            })
            .collect();
        Some(with_horizon(points, self.strata().n() as usize))
    }
}

/// The hit points of an M×N gather followed by a ring of N points on the tangent plane, the
/// last row's points projected onto it (z = 0): row M of an (M+1)×N fan.
///
/// Without it the fan stops at the last row, θ ≈ asin √(1 − ½/M) short of the horizon (7° at
/// M = 32), and the uncovered band's edge curves the fan where the light is uniform (a floor
/// point beside a wall whose band is seen at a slant). Projecting continues each last-row
/// surface straight down to the tangent plane, which is exact for a wall standing on it. A
/// closed planar ring around x adds Σ ±θₑ/2 = π to Ω whatever x's position in the plane, so
/// it adds nothing to the tangent block of the Hessian: a uniform hemisphere then has exactly
/// zero tangent curvature.
pub(crate) fn with_horizon(mut points: Vec<DVec3>, n: usize) -> Vec<DVec3> {
    let last = points.len() - n;
    for k in 0..n {
        let p = points[last + k];
        points.push(DVec3::new(p.x, p.y, 0.0));
    }
    points
}

/// One triangle of the fan: its corners (vertex indices) in fan order and its three edges with
/// the sign of their traversal against the edge's canonical direction.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Triangle {
    pub(crate) corners: [usize; 3],
    sides: [(usize, f64); 3],
}

impl Triangle {
    /// The corner farthest from the gather point (the first of equals): whose value the
    /// triangle shows.
    pub(crate) fn farthest(&self, points: &[DVec3]) -> usize {
        let depth = |i: usize| points[i].length_squared();
        let [a, b, c] = self.corners;
        let ab = if depth(b) > depth(a) { b } else { a };
        if depth(c) > depth(ab) { c } else { ab }
    }
}

/// The fan's triangles over an M×N grid (module docs), with their edges in the layout of
/// [`Edges`].
pub(crate) fn fan_triangles(m: usize, n: usize) -> Vec<Triangle> {
    let v = |j: usize, k: usize| j * n + k;
    let mut out = Vec::with_capacity(2 * m * n);
    for j in 0..m.saturating_sub(1) {
        for k in 0..n {
            let k1 = (k + 1) % n;
            let diag = edges_diagonal(m, n, j, k);
            // (j,k) → (j,k+1) → (j+1,k) → (j,k).
            out.push(Triangle {
                corners: [v(j, k), v(j, k1), v(j + 1, k)],
                sides: [
                    (edges_ring(n, j, k), 1.0),
                    (diag, 1.0),
                    (edges_up(m, n, j, k), -1.0),
                ],
            });
            // (j+1,k+1) → (j+1,k) → (j,k+1) → (j+1,k+1).
            out.push(Triangle {
                corners: [v(j + 1, k1), v(j + 1, k), v(j, k1)],
                sides: [
                    (edges_ring(n, j + 1, k), -1.0),
                    (diag, -1.0),
                    (edges_up(m, n, j, k1), 1.0),
                ],
            });
        }
    }
    // The pole: (0,0) → (0,k+1) → (0,k) → (0,0), for 1 ≤ k ≤ N − 2, wound as the quads are.
    for k in 1..n.saturating_sub(1) {
        let first = if k + 1 == n - 1 {
            (edges_ring(n, 0, n - 1), -1.0)
        } else {
            (edges_cap(m, n, k + 1), 1.0)
        };
        let last = if k == 1 {
            (edges_ring(n, 0, 0), -1.0)
        } else {
            (edges_cap(m, n, k), -1.0)
        };
        out.push(Triangle {
            corners: [v(0, 0), v(0, k + 1), v(0, k)],
            sides: [first, (edges_ring(n, 0, k), -1.0), last],
        });
    }
    out
}

/// The fan's irradiance, gradient and relative Hessian from its triangles and each triangle's
/// (relative, per-channel) value: the triangles' values summed onto their edges, then each edge
/// with a non-zero sum evaluated once.
pub(crate) fn accumulate<V: GatherValue>(
    m: usize,
    n: usize,
    points: &[DVec3],
    triangles: &[Triangle],
    weights: impl Iterator<Item = (f64, V)>,
) -> Fan<V> {
    let mut edges = Edges::<V>::new(m, n);
    for (t, w) in triangles.iter().zip(weights) {
        for (edge, sign) in t.sides {
            edges.add(edge, sign, w);
        }
    }
    let mut fan = Fan {
        irradiance: V::default(),
        gradient: [V::default(); 3],
        hessian: DMat3::ZERO,
    };
    let mut hessian = DMat3::ZERO;
    for (i, &(w_rel, w)) in edges.weights.iter().enumerate() {
        let channels_zero = (0..V::CHANNELS).all(|c| w.channel(c) == 0.0);
        if w_rel == 0.0 && channels_zero {
            continue;
        }
        let (p, q) = edges.endpoints(i);
        let (omega, grad, hess) = edge_terms(points[p], points[q]);
        hessian += hess * (ORIENTATION * w_rel);
        if !channels_zero {
            fan.irradiance = fan.irradiance + w * (ORIENTATION * omega) as f32;
            for (a, g) in fan.gradient.iter_mut().enumerate() {
                *g = *g + w * (ORIENTATION * grad[a]) as f32;
            }
        }
    }
    fan.hessian = hessian * (1.0 / PI);
    fan
}

/// The fan's winding (quads (j,k)(j,k+1)(j+1,k+1)(j+1,k) run clockwise seen from above the
/// pole) makes Lambert's edge sum negative; this sign makes a bright triangle add irradiance.
const ORIENTATION: f64 = -1.0;

// Edge indices, in the layout of `Edges`' docs.
fn edges_ring(n: usize, j: usize, k: usize) -> usize {
    j * n + k
}
fn edges_up(m: usize, n: usize, j: usize, k: usize) -> usize {
    m * n + j * n + k
}
fn edges_diagonal(m: usize, n: usize, j: usize, k: usize) -> usize {
    m * n + (m - 1) * n + j * n + k
}
fn edges_cap(m: usize, n: usize, k: usize) -> usize {
    m * n + 2 * (m - 1) * n + (k - 2)
}

/// Radiance's normalised scalar values: v' = 0.99·v·count/Σv + 0.01 with v the channel mean,
/// or 1 everywhere for a black (or negative-sum) gather.
fn relative_values<V: GatherValue>(values: &[V]) -> Vec<f64> {
    let mean = |v: &V| {
        (0..V::CHANNELS)
            .map(|c| f64::from(v.channel(c)))
            .sum::<f64>()
            / V::CHANNELS as f64
    };
    let sum: f64 = values.iter().map(mean).sum();
    if sum <= 0.0 || !sum.is_finite() {
        return vec![1.0; values.len()];
    }
    let scale = 0.99 * values.len() as f64 / sum;
    values.iter().map(|v| mean(v) * scale + 0.01).collect()
}

impl<V: GatherValue> GatherSamples<V> {
    /// The unit direction of cell `i` in the local frame: the caller's, or the cell's middle.
    pub(crate) fn sample_direction(&self, i: usize) -> Vec3 {
        match self.directions() {
            Some(d) => d[i],
            None => {
                let strata = self.strata();
                let n = strata.n() as usize;
                let cell = irr_sampling::Cell {
                    j: (i / n) as u32,
                    k: (i % n) as u32,
                };
                strata.sample(cell, glam::Vec2::splat(0.5))
            }
        }
    }
}
