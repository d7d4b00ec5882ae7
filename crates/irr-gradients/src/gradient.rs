//! Rotation and translation gradients of the irradiance from one stratified gather.
//!
//! # The model
//! Every estimator here treats the incoming radiance as constant over each cell of the M×N
//! stratification (Ward & Heckbert 1992; Křivánek & Gautron 2009, ch. 2): E = Σⱼₖ Aⱼₖ Lⱼₖ
//! with Aⱼₖ = ∫_cell cos θ dω = π/(MN). In the local frame (normal n = +z), with
//! eθ = (cos θ cos φ, cos θ sin φ, −sin θ) and eφ = (−sin φ, cos φ, 0):
//!
//! **Rotation.** Turning the normal about the axis a by a small angle δ changes the cosine of
//! every direction by δ·a·(n × ω), and adds no boundary term (cos θ = 0 on the horizon), so
//! ∇ᵣE = ∫ L(ω) (n × ω) dω, and n × ω = sin θ eφ (Ward & Heckbert 1992, the rotation
//! gradient). They estimate it as (π/(MN)) Σₖ vₖ Σⱼ tan θⱼ Lⱼₖ, the cosine-weighted estimate of the
//! integral with vₖ = eφ(φₖ) (Radiance takes θⱼ, φₖ at the cell's centre). We keep their model
//! (L constant over a cell) but give each cell its exact weight
//! ∫_cell sin θ eφ dω = ∫ sin² θ dθ · ∫ eφ dφ = [(θ − sin θ cos θ)/2]_{θⱼ}^{θⱼ₊₁} · 2 sin(π/N) eφ(φ꜀)
//! (φ꜀ the column's middle azimuth). It equals (π/(MN)) tan θ꜀ vₖ to first order in the cell
//! size, but stays right in the row at the horizon, where tan θ꜀ at the cell centre falls short of
//! the cell's integral by a factor tending to 1/√2 as M grows, and tan θ at the sample itself is
//! unbounded (its variance over the last row is infinite).
//!
//! **Translation.** Moving the point by dx moves every cell *wall* that is an edge of something
//! seen (an occluder's silhouette, or where the radiance jumps) by the motion of a fixed point at
//! the wall's distance R: dθ = −(eθ·dx)/R, sin θ dφ = −(eφ·dx)/R. The projected solid angle swept
//! changes from the radiance of one neighbour to that of the other, so
//!
//! - a wall at θⱼ between cells (j−1, k) and (j, k), over φ ∈ [φₖ, φₖ₊₁), adds
//!   (Lⱼₖ − Lⱼ₋₁,ₖ) · sin θⱼ cos θⱼ / R · ∫ eθ dφ, whose tangent part is
//!   (Lⱼₖ − Lⱼ₋₁,ₖ) · (2π/N) sin θⱼ cos² θⱼ / R · uₖ with uₖ = (cos φ, sin φ, 0) at the cell's
//!   middle azimuth (Ward & Heckbert 1992, the translation gradient's first sum);
//! - a wall at φₖ between cells (j, k−1) and (j, k), over θ ∈ [θⱼ, θⱼ₊₁), adds
//!   (Lⱼₖ − Lⱼ,ₖ₋₁) / R · eφ(φₖ) · ∫ cos θ dθ = (Lⱼₖ − Lⱼ,ₖ₋₁)(sin θⱼ₊₁ − sin θⱼ)/R · eφ(φₖ)
//!   (Ward & Heckbert 1992, the translation gradient's second sum).
//!
//! R is unknown on the wall itself; both papers take the nearer of the two cells' hits,
//! R = min(rⱼₖ, r_neighbour): at an occlusion edge the nearer object is the occluder, whose edge is
//! the wall. A wall between two misses (r = ∞) never moves: a distant sky does not change with
//! position. The wall at the horizon (j = M) has cos θ = 0 and adds nothing.
//!
//! **The normal component.** The papers give the gradient in the tangent plane, where cached
//! points lie. The same walls move along the normal too: the θ-walls' eθ has the normal part
//! −sin θ, adding (Lⱼₖ − Lⱼ₋₁,ₖ)·(−(2π/N) sin² θⱼ cos θⱼ / R) to the z component; eφ has none.
//! We return it (it is tested against finite differences like the rest), so the translation
//! gradient is a full 3D vector and transforms as one.

use crate::samples::GatherSamples;
use crate::value::GatherValue;
use glam::Vec3;
use irr_sampling::{Frame, HemisphereStrata};
use std::f64::consts::TAU;

/// Which translation-gradient estimator to use. The first two share the cell-wall model above and the
/// nearer-hit distance per wall; they differ in the weight of the walls between azimuthal
/// neighbours (the φ-walls). The θ-walls and the normal component are the same in both.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum TranslationGradient {
    /// Ward & Heckbert 1992 (as Radiance's `ambcomp.c` computes it): the φ-wall of row j weighs
    /// (sin θⱼ₊₁ − sin θⱼ)/R, the exact integral of cos θ along the wall (exact for the
    /// piecewise-constant model when R is constant along the wall). The θ-walls use 2π/N where
    /// the exact ∫ u dφ is 2 sin(π/N) (0.16 % more at N = 32). The default.
    #[default]
    WardHeckbert,
    /// Křivánek et al. 2005 ("Improved radiance gradient computation") in the form of Křivánek &
    /// Gautron 2009, ch. 2 (as Mitsuba 0.6's `irrcache.cpp` computes it): the φ-wall weighs
    /// cos θ꜀ (cos θⱼ − cos θⱼ₊₁) / (sin θ꜀ R), the change of the cell's *solid angle* times the
    /// cosine at the cell's centre θ꜀ (sin² θ꜀ = (j + ½)/M). Written for any per-cell weight
    /// (radiance caching's spherical harmonics, not only the cosine), it agrees with Ward &
    /// Heckbert to first order in the cell size, but in the row at the pole it is short by a
    /// factor tending to 1/√2 and in the row at the horizon long by √2, where the cosine is
    /// far from constant over the cell.
    KrivanekGautron,
    /// The occlusion-aware gradient of the triangle fan over the gather's hit points
    /// (Schwarzhaupt, Jensen & Jarosz 2012; Radiance ≥ 4.2): the derivative of Lambert's formula
    /// for the triangles, each showing its farthest corner's value, held fixed in space (see
    /// [`GatherSamples::fan`], which also gives the Hessian). Uses the sample directions given
    /// with [`GatherSamples::with_directions`] (the cells' middles otherwise).
    OcclusionFan,
}

/// The irradiance of one gather and its gradients, all in the gather's local frame (normal = +z)
/// until [`Gradients::in_world`] turns them.
///
/// `rotation[a]` and `translation[a]` are the a-th (x, y, z) components, one value each: for RGB
/// the gradient of each channel. The first-order extrapolation to a nearby point p with normal n
/// from this record at (pᵢ, nᵢ) is E + (p − pᵢ)·∇ₜE + (nᵢ × n)·∇ᵣE ([`Gradients::extrapolate`];
/// Ward & Heckbert 1992; Křivánek & Gautron 2009, ch. 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gradients<V> {
    /// The irradiance estimate E.
    pub irradiance: V,
    /// ∇ᵣE: dE/dδ = a·∇ᵣE when the normal turns by a small angle δ about the unit axis a.
    /// Perpendicular to the normal.
    pub rotation: [V; 3],
    /// ∇ₜE: dE = dx·∇ₜE when the point moves by dx.
    pub translation: [V; 3],
}

/// The gradient-based bound on a record's radius (Ward & Heckbert 1992; Křivánek et al.
/// 2006, "Making radiance and irradiance caching practical"): R ≤ E/‖∇ₜE‖ per channel, so that the first-order extrapolation never changes the
/// value by more than the value itself. Only the part of ∇ₜE in the tangent plane of `normal`
/// counts (cached neighbours lie on the surface). `f32::INFINITY` when the gradient is zero.
fn radius_limit_of<V: GatherValue>(e: V, t: &[V; 3], normal: Vec3) -> f32 {
    let nrm = normal.as_dvec3().normalize_or_zero();
    let mut limit = f64::INFINITY;
    for c in 0..V::CHANNELS {
        let g = glam::DVec3::new(
            f64::from(t[0].channel(c)),
            f64::from(t[1].channel(c)),
            f64::from(t[2].channel(c)),
        );
        let tangent = g - nrm * g.dot(nrm);
        let len = tangent.length();
        if len > 0.0 {
            limit = limit.min(f64::from(e.channel(c)).max(0.0) / len);
        }
    }
    limit as f32
}

/// `Σₐ w[a]·g[a]`: the change of a value along `w` given its gradient `g`.
#[inline]
pub fn directional<V: GatherValue>(g: &[V; 3], w: Vec3) -> V {
    g[0] * w.x + g[1] * w.y + g[2] * w.z
}

/// Turns a local-frame gradient (x, y, z along `frame.s`, `frame.t`, `frame.n`) into world
/// coordinates, as [`Frame::to_world`] does for a direction.
#[inline]
pub fn rotate_to_world<V: GatherValue>(g: &[V; 3], frame: &Frame) -> [V; 3] {
    let axis = |i: usize| g[0] * frame.s[i] + g[1] * frame.t[i] + g[2] * frame.n[i];
    [axis(0), axis(1), axis(2)]
}

impl<V: GatherValue> Gradients<V> {
    /// The same gradients with their vectors in world coordinates (the irradiance is unchanged).
    pub fn in_world(&self, frame: &Frame) -> Self {
        Self {
            irradiance: self.irradiance,
            rotation: rotate_to_world(&self.rotation, frame),
            translation: rotate_to_world(&self.translation, frame),
        }
    }

    /// The first-order extrapolation E + offset·∇ₜE + normal_rotation·∇ᵣE, where `offset` is
    /// p − pᵢ and `normal_rotation` is nᵢ × n, both in the frame the gradients are in.
    #[inline]
    pub fn extrapolate(&self, offset: Vec3, normal_rotation: Vec3) -> V {
        self.irradiance
            + directional(&self.translation, offset)
            + directional(&self.rotation, normal_rotation)
    }

    /// The gradient-based radius limit min over channels of E/‖∇ₜE‖, with ∇ₜE taken in the
    /// tangent plane of `normal` (`Vec3::Z` for local-frame gradients, the record's normal for
    /// world-frame ones). See Křivánek et al. 2006. `f32::INFINITY` for a zero gradient.
    pub fn radius_limit(&self, normal: Vec3) -> f32 {
        radius_limit_of(self.irradiance, &self.translation, normal)
    }
}

/// Per-strata constants of the estimators (O(M + N) trigonometry, computed in f64).
#[derive(Clone, Debug)]
struct Tables {
    /// Rotation weight of row j: ∫_{θⱼ}^{θⱼ₊₁} sin² θ dθ = [(θ − sin θ cos θ)/2].
    rotation_row: Vec<f32>,
    /// Rotation weight of column k: ∫_{φₖ}^{φₖ₊₁} eφ dφ = 2 sin(Δφ/2)·eφ(φ꜀), (x, y).
    rotation_col: Vec<[f32; 2]>,
    /// Tangent weight of the θ-wall j (index j, 1 ≤ j < M): (2π/N) sin θⱼ cos² θⱼ.
    theta_wall_tangent: Vec<f32>,
    /// Normal weight of the θ-wall j: −(2π/N) sin² θⱼ cos θⱼ.
    theta_wall_normal: Vec<f32>,
    /// uₖ = (cos φ꜀, sin φ꜀) at the middle azimuth of column k.
    u_mid: Vec<[f32; 2]>,
    /// Weight of the φ-walls of row j (depends on the variant).
    phi_wall: Vec<f32>,
    /// eφ(φₖ) = (−sin φₖ, cos φₖ) on the wall at the start of column k.
    v_wall: Vec<[f32; 2]>,
}

impl Tables {
    fn new(strata: &HemisphereStrata, variant: TranslationGradient) -> Self {
        let (m, n) = (strata.m() as usize, strata.n() as usize);
        let (mf, nf) = (m as f64, n as f64);
        // sin² θⱼ = j/M exactly (the warp's first coordinate); θ from atan2 keeps precision at
        // both ends.
        let sin_b: Vec<f64> = (0..=m).map(|j| (j as f64 / mf).sqrt()).collect();
        let cos_b: Vec<f64> = (0..=m).map(|j| (1.0 - j as f64 / mf).sqrt()).collect();
        let theta_b: Vec<f64> = (0..=m).map(|j| sin_b[j].atan2(cos_b[j])).collect();
        // (θ − sin θ cos θ)/2 = (θ − sin 2θ / 2)/2: in f64 its cancellation near the pole costs
        // at most ~1e-16/θ³ relative, below f32 precision for every θ₁ = asin √(1/M) ≥ 1e-3.
        let g = |j: usize| 0.5 * (theta_b[j] - sin_b[j] * cos_b[j]);
        let rotation_row = (0..m).map(|j| (g(j + 1) - g(j)) as f32).collect();

        let dphi = TAU / nf;
        let chord = 2.0 * (0.5 * dphi).sin();
        let mut rotation_col = Vec::with_capacity(n);
        let mut u_mid = Vec::with_capacity(n);
        let mut v_wall = Vec::with_capacity(n);
        for k in 0..n {
            let (s_mid, c_mid) = ((k as f64 + 0.5) * dphi).sin_cos();
            let (s_wall, c_wall) = (k as f64 * dphi).sin_cos();
            rotation_col.push([(-chord * s_mid) as f32, (chord * c_mid) as f32]);
            u_mid.push([c_mid as f32, s_mid as f32]);
            v_wall.push([-s_wall as f32, c_wall as f32]);
        }

        let mut theta_wall_tangent = vec![0.0; m];
        let mut theta_wall_normal = vec![0.0; m];
        for j in 1..m {
            let (s, c) = (sin_b[j], cos_b[j]);
            theta_wall_tangent[j] = (dphi * s * c * c) as f32;
            theta_wall_normal[j] = (-dphi * s * s * c) as f32;
        }

        let phi_wall = (0..m)
            .map(|j| match variant {
                // The fan does not use the wall tables.
                TranslationGradient::WardHeckbert | TranslationGradient::OcclusionFan => {
                    (sin_b[j + 1] - sin_b[j]) as f32
                }
                TranslationGradient::KrivanekGautron => {
                    let s2 = (j as f64 + 0.5) / mf;
                    let (s_c, c_c) = (s2.sqrt(), (1.0 - s2).sqrt());
                    (c_c * (cos_b[j] - cos_b[j + 1]) / s_c) as f32
                }
            })
            .collect();

        Self {
            rotation_row,
            rotation_col,
            theta_wall_tangent,
            theta_wall_normal,
            u_mid,
            phi_wall,
            v_wall,
        }
    }
}

impl<V: GatherValue> GatherSamples<V> {
    /// ∇ᵣE in the local frame (z = 0): Σⱼₖ Lⱼₖ ∫_cell sin θ eφ dω (Ward & Heckbert 1992,
    /// with each cell's exact weight; see the module docs).
    pub fn rotation_gradient(&self) -> [V; 3] {
        // The variant does not enter the rotation tables.
        let t = Tables::new(self.strata(), TranslationGradient::WardHeckbert);
        self.rotation_with(&t)
    }

    fn rotation_with(&self, t: &Tables) -> [V; 3] {
        let n = self.strata().n() as usize;
        let (mut x, mut y) = (V::default(), V::default());
        for (j, row) in self.radiance().chunks_exact(n).enumerate() {
            // Sum the row first (each column's weight is a fixed vector), then weigh the row by
            // its θ integral: one multiplication per cell and channel, and M + N rounding steps.
            let (mut rx, mut ry) = (V::default(), V::default());
            for (&l, w) in row.iter().zip(&t.rotation_col) {
                rx = rx + l * w[0];
                ry = ry + l * w[1];
            }
            x = x + rx * t.rotation_row[j];
            y = y + ry * t.rotation_row[j];
        }
        [x, y, V::default()]
    }

    /// ∇ₜE in the local frame, by the chosen estimator (see the module docs and
    /// [`TranslationGradient`]); x, y in the tangent plane, z along the normal.
    pub fn translation_gradient(&self, variant: TranslationGradient) -> [V; 3] {
        if variant == TranslationGradient::OcclusionFan {
            return self.fan().gradient;
        }
        let t = Tables::new(self.strata(), variant);
        self.translation_with(&t)
    }

    /// The translation gradient, by the walls of `variant` (Ward–Heckbert or
    /// Křivánek–Gautron; the occlusion fan's variant takes Ward–Heckbert's walls), of another
    /// quantity gathered by the same rays: `values` has one entry per cell, in the gather's
    /// cell order, and moves with the walls as the radiance does (the walls' distances are this
    /// gather's). For example the coefficients of the radiance in a basis, each cell's value
    /// the radiance times the basis function (Křivánek et al. 2005's gradients of a radiance
    /// record). `None` unless there is one value per cell.
    pub fn translation_gradient_of<W: GatherValue>(
        &self,
        variant: TranslationGradient,
        values: &[W],
    ) -> Option<[W; 3]> {
        if values.len() != self.radiance().len() {
            return None;
        }
        let variant = match variant {
            TranslationGradient::OcclusionFan => TranslationGradient::WardHeckbert,
            v => v,
        };
        let t = Tables::new(self.strata(), variant);
        Some(walls(self.strata(), self.distance(), values, &t))
    }

    /// [`GatherSamples::translation_gradient_of`] for `count` quantities at once: `values`
    /// holds `count` values per cell, `[cell][quantity]`, and `out` receives each quantity's
    /// gradient, `[quantity]`; the walls' weights are computed once for all of them. Each
    /// gradient has the bits `translation_gradient_of` gives that quantity alone (the same
    /// operations in the same order). `None` (and `out` untouched) unless `values` has `count`
    /// values per cell and `out` has `count` entries.
    pub fn translation_gradients_of<W: GatherValue>(
        &self,
        variant: TranslationGradient,
        values: &[W],
        count: usize,
        out: &mut [[W; 3]],
    ) -> Option<()> {
        if values.len() != self.radiance().len() * count || out.len() != count {
            return None;
        }
        let variant = match variant {
            TranslationGradient::OcclusionFan => TranslationGradient::WardHeckbert,
            v => v,
        };
        let t = Tables::new(self.strata(), variant);
        walls_many(self.strata(), self.distance(), values, count, &t, out);
        Some(())
    }

    fn translation_with(&self, t: &Tables) -> [V; 3] {
        walls(self.strata(), self.distance(), self.radiance(), t)
    }
}

/// [`walls`] for `count` quantities per cell (`l` is `[cell][quantity]`), into `out`
/// (`[quantity]`): per quantity, the same operations in the same order as `walls`. Kept apart
/// from `walls`, the irradiance's own hot path: `walls` as this with one quantity measured about
/// 2 % slower in the cache's final pass (its fallback gathers).
fn walls_many<W: GatherValue>(
    strata: &HemisphereStrata,
    distance: &[f32],
    l: &[W],
    count: usize,
    t: &Tables,
    out: &mut [[W; 3]],
) {
    let n = strata.n() as usize;
    let inv_r: Vec<f32> = distance.iter().map(|&r| 1.0 / r).collect();
    let at = |cell: usize| &l[cell * count..(cell + 1) * count];
    out.fill([W::default(); 3]);
    let mut row_sums = vec![[W::default(); 3]; count];
    for j in 0..strata.m() as usize {
        row_sums.fill([W::default(); 3]);
        let row = j * n;
        for k in 0..n {
            let i = row + k;
            let prev = row + if k == 0 { n - 1 } else { k - 1 };
            let w = inv_r[i].max(inv_r[prev]);
            if w > 0.0 {
                for ((r, a), b) in row_sums.iter_mut().zip(at(i)).zip(at(prev)) {
                    let d = (*a - *b) * t.phi_wall[j] * w;
                    r[0] = r[0] + d * t.v_wall[k][0];
                    r[1] = r[1] + d * t.v_wall[k][1];
                }
            }
            if j > 0 {
                let below = i - n;
                let w = inv_r[i].max(inv_r[below]);
                if w > 0.0 {
                    for ((r, a), b) in row_sums.iter_mut().zip(at(i)).zip(at(below)) {
                        let d = (*a - *b) * w;
                        let tangent = d * t.theta_wall_tangent[j];
                        r[0] = r[0] + tangent * t.u_mid[k][0];
                        r[1] = r[1] + tangent * t.u_mid[k][1];
                        r[2] = r[2] + d * t.theta_wall_normal[j];
                    }
                }
            }
        }
        for (o, r) in out.iter_mut().zip(&row_sums) {
            o[0] = o[0] + r[0];
            o[1] = o[1] + r[1];
            o[2] = o[2] + r[2];
        }
    }
}

/// The translation gradient of the per-cell values `l` whose cells' hits lie at `distance`, by
/// the walls of `t` (module docs, "Translation").
fn walls<V: GatherValue>(
    strata: &HemisphereStrata,
    distance: &[f32],
    l: &[V],
    t: &Tables,
) -> [V; 3] {
    {
        let n = strata.n() as usize;
        // 1/R per cell; a miss gives 0, so a wall between two misses adds nothing. Distances are
        // ≥ f32::MIN_POSITIVE (checked on construction), so 1/r is finite.
        let inv_r: Vec<f32> = distance.iter().map(|&r| 1.0 / r).collect();
        let (mut x, mut y, mut z) = (V::default(), V::default(), V::default());
        for j in 0..strata.m() as usize {
            let (mut rx, mut ry, mut rz) = (V::default(), V::default(), V::default());
            let row = j * n;
            for k in 0..n {
                let i = row + k;
                // The φ-wall at φₖ between (j, k−1) and (j, k); column k − 1 wraps to N − 1.
                let prev = row + if k == 0 { n - 1 } else { k - 1 };
                let w = inv_r[i].max(inv_r[prev]);
                if w > 0.0 {
                    // Weigh the difference before dividing by R: a zero difference stays zero.
                    let d = (l[i] - l[prev]) * t.phi_wall[j] * w;
                    rx = rx + d * t.v_wall[k][0];
                    ry = ry + d * t.v_wall[k][1];
                }
                // The θ-wall at θⱼ between (j−1, k) and (j, k); none at the pole (j = 0).
                if j > 0 {
                    let below = i - n;
                    let w = inv_r[i].max(inv_r[below]);
                    if w > 0.0 {
                        let d = (l[i] - l[below]) * w;
                        let tangent = d * t.theta_wall_tangent[j];
                        rx = rx + tangent * t.u_mid[k][0];
                        ry = ry + tangent * t.u_mid[k][1];
                        rz = rz + d * t.theta_wall_normal[j];
                    }
                }
            }
            x = x + rx;
            y = y + ry;
            z = z + rz;
        }
        [x, y, z]
    }
}

impl<V: GatherValue> GatherSamples<V> {
    /// The irradiance and both gradients, in the local frame.
    pub fn gradients(&self, variant: TranslationGradient) -> Gradients<V> {
        let t = Tables::new(self.strata(), variant);
        let translation = if variant == TranslationGradient::OcclusionFan {
            self.fan().gradient
        } else {
            self.translation_with(&t)
        };
        Gradients {
            irradiance: self.irradiance(),
            rotation: self.rotation_with(&t),
            translation,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analytic::fixed_config;
    use glam::Vec3A;
    use proptest::collection::vec;
    use proptest::prelude::*;

    /// A gather of M×N cells (M < 10, N < 32) with radiance in [0, 10) and distances in
    /// [0.01, 100) or misses.
    fn gathers() -> impl Strategy<Value = GatherSamples<f32>> {
        (1u32..10, 1u32..32)
            .prop_flat_map(|(m, n)| {
                let len = (m * n) as usize;
                let r = prop_oneof![Just(f32::INFINITY), 1e-2f32..1e2];
                (Just((m, n)), vec(0.0f32..10.0, len), vec(r, len))
            })
            .prop_map(|((m, n), l, r)| {
                let s = HemisphereStrata::new(m, n).unwrap_or_else(|e| panic!("{e}"));
                GatherSamples::new(s, l, r).unwrap_or_else(|e| panic!("{e}"))
            })
    }

    /// Rounding tolerances for results of `g`. Every estimate is a sum of products of three
    /// factors (a radiance or a difference of two, a weight rounded from f64, and 1/R), each
    /// rounding by ≤ ε/2, accumulated over ≤ M + N + 2 sequential additions (row sums, then
    /// rows), so its error is ≤ (M + N + 6)·ε·Σ|terms|. Σ|terms| is bounded by
    /// - translation: 2·max L·max 1/r·(Σ θ-wall weights + Σ φ-wall weights)
    ///   ≤ 2·max L·max 1/r·(π(M − 1) + N) (each of the M − 1 rows of θ-walls weighs
    ///   2π sin θ cos θ ≤ π in all; each row of φ-walls ≤ N·(sin θⱼ₊₁ − sin θⱼ), summing to N);
    /// - rotation: max L·Σ_cells |W| ≤ max L·2π (each |W| is at most the cell's solid angle).
    ///
    /// We allow twice that.
    fn tolerances(g: &GatherSamples<f32>) -> (f32, f32) {
        let (m, n) = (g.strata().m() as f32, g.strata().n() as f32);
        let l_max = g.radiance().iter().copied().fold(0.0, f32::max);
        let inv_r_max = g.distance().iter().map(|&r| 1.0 / r).fold(0.0, f32::max);
        let count = (m + n + 6.0) * f32::EPSILON * 2.0;
        let trans = count * 2.0 * l_max * inv_r_max * (std::f32::consts::PI * (m - 1.0) + n);
        let rot = count * l_max * std::f32::consts::TAU;
        (trans, rot)
    }

    /// The same gather with each cell's (L, r) taken from the cell `map(j, k)`.
    fn remapped(
        g: &GatherSamples<f32>,
        map: impl Fn(u32, u32) -> (u32, u32),
        scale: f32,
    ) -> GatherSamples<f32> {
        let s = *g.strata();
        GatherSamples::from_fn(s, |c| {
            let (j, k) = map(c.j, c.k);
            let i = (j * s.n() + k) as usize;
            (g.radiance()[i], g.distance()[i] * scale)
        })
        .unwrap_or_else(|e| panic!("{e}"))
    }

    fn close(a: [f32; 3], b: [f32; 3], tol: f32) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() <= tol)
    }

    proptest! {
        #![proptest_config(fixed_config(256, 0x6a7d))]

        /// The gradient of another per-cell quantity by the same walls: the radiance itself
        /// gives the radiance's gradient, bit for bit (the same sums in the same order); the
        /// radiance as one channel of an RGB value gives it in that channel; the fan's
        /// variant takes Ward–Heckbert's walls; a wrong count is refused.
        #[test]
        fn gradient_of_another_quantity_uses_the_same_walls(g in gathers()) {
            for variant in [TranslationGradient::WardHeckbert, TranslationGradient::KrivanekGautron] {
                let own = g.translation_gradient(variant);
                prop_assert_eq!(g.translation_gradient_of(variant, g.radiance()), Some(own));
                let rgb: Vec<Vec3> = g.radiance().iter().map(|&l| Vec3::new(0.0, l, 0.0)).collect();
                let of = g.translation_gradient_of(variant, &rgb).unwrap_or_default();
                prop_assert_eq!(of.map(|v| v.y), own);
                prop_assert_eq!(of.map(|v| v.x), [0.0; 3]);
            }
            prop_assert_eq!(
                g.translation_gradient_of(TranslationGradient::OcclusionFan, g.radiance()),
                Some(g.translation_gradient(TranslationGradient::WardHeckbert))
            );
            let one_more = vec![1.0f32; g.radiance().len() + 1];
            prop_assert_eq!(g.translation_gradient_of(TranslationGradient::WardHeckbert, &one_more), None);
        }

        /// Many quantities at once give each one's gradient alone, bit for bit: three per cell
        /// here (the radiance, its square and a cell-index pattern), against
        /// `translation_gradient_of` on each; wrong lengths are refused.
        #[test]
        fn gradients_of_many_quantities_are_each_ones(g in gathers()) {
            let l = g.radiance();
            let fields: [Vec<Vec3>; 3] = [
                l.iter().map(|&x| Vec3::splat(x)).collect(),
                l.iter().map(|&x| Vec3::new(x * x, -x, 1.0)).collect(),
                (0..l.len()).map(|i| Vec3::new((i % 7) as f32, (i % 3) as f32 - 1.0, 0.5)).collect(),
            ];
            let values: Vec<Vec3> = (0..l.len()).flat_map(|i| fields.iter().map(move |f| f[i])).collect();
            for variant in [TranslationGradient::WardHeckbert, TranslationGradient::KrivanekGautron, TranslationGradient::OcclusionFan] {
                let mut out = [[Vec3::NAN; 3]; 3];
                prop_assert_eq!(g.translation_gradients_of(variant, &values, 3, &mut out), Some(()));
                for (o, f) in out.iter().zip(&fields) {
                    prop_assert_eq!(Some(*o), g.translation_gradient_of(variant, f));
                }
                prop_assert_eq!(g.translation_gradients_of(variant, &values, 2, &mut out[..2]), None);
                prop_assert_eq!(g.translation_gradients_of(variant, &values, 3, &mut out[..2]), None);
            }
        }

        /// A constant radiance field has no rotation gradient: the column weights sum to zero
        /// (Σₖ 2 sin(π/N) eφ(φ꜀) = 0), up to rounding. (That it has no translation gradient
        /// either holds by construction, every wall's difference being zero; the linearity test
        /// below checks the translation estimator instead.)
        #[test]
        fn constant_radiance_has_no_rotation_gradient(g in gathers(), l in 0.0f32..1e3) {
            let s = *g.strata();
            let c = GatherSamples::from_fn(s, |cell| {
                (l, g.distance()[cell.index(&s) as usize])
            }).unwrap_or_else(|e| panic!("{e}"));
            let (_, tol) = tolerances(&c);
            let r = c.rotation_gradient();
            prop_assert!(r[0].abs() <= tol && r[1].abs() <= tol, "{r:?} (tol {tol:e})");
        }

        /// Both gradients are linear in the radiance for fixed distances: the gradients of
        /// a·L₁ + b·L₂ are a·∇(L₁) + b·∇(L₂). A non-linear step (a max, a clamp, a weight that
        /// read the radiance) would break it. Tolerance: the rounding bound of `tolerances` for
        /// each of the three gathers (the combined one's radiance bound is |a|·max L₁ + |b|·max
        /// L₂, which `tolerances` of it covers), plus one rounding of each product a·L.
        #[test]
        fn gradients_are_linear_in_the_radiance(g in gathers(), seed: u64, a in -3.0f32..3.0, b in -3.0f32..3.0) {
            let s = *g.strata();
            let key = irr_sampling::SampleKey::new(seed, 0, 0);
            let l2: Vec<f32> = (0..s.len() as u32).map(|i| 10.0 * key.uniform_2d(i).x).collect();
            let second = GatherSamples::new(s, l2.clone(), g.distance().to_vec()).unwrap_or_else(|e| panic!("{e}"));
            let mixed: Vec<f32> = g.radiance().iter().zip(&l2).map(|(&x, &y)| a * x + b * y).collect();
            let both = GatherSamples::new(s, mixed, g.distance().to_vec()).unwrap_or_else(|e| panic!("{e}"));
            let (t1, r1) = tolerances(&g);
            let (t2, r2) = tolerances(&second);
            let (t3, r3) = tolerances(&both.clone());
            for variant in [TranslationGradient::WardHeckbert, TranslationGradient::KrivanekGautron] {
                let (x, y, z) = (g.gradients(variant), second.gradients(variant), both.gradients(variant));
                let lin = |p: [f32; 3], q: [f32; 3]| [0, 1, 2].map(|i| a * p[i] + b * q[i]);
                let tt = a.abs() * t1 + b.abs() * t2 + t3;
                let tr = a.abs() * r1 + b.abs() * r2 + r3;
                prop_assert!(close(z.translation, lin(x.translation, y.translation), 2.0 * tt), "{:?} vs {:?}", z.translation, lin(x.translation, y.translation));
                prop_assert!(close(z.rotation, lin(x.rotation, y.rotation), 2.0 * tr), "{:?} vs {:?}", z.rotation, lin(x.rotation, y.rotation));
            }
        }

        /// The rotation gradient is perpendicular to the normal: zero along local z, and along
        /// the normal after turning to world space (up to the frame's rounding, a few ε).
        #[test]
        fn rotation_gradient_is_perpendicular_to_the_normal(
            g in gathers(),
            nx in -1.0f32..1.0, ny in -1.0f32..1.0, nz in -1.0f32..1.0,
        ) {
            let normal = Vec3::new(nx, ny, nz);
            prop_assume!(normal.length() > 1e-2);
            let normal = normal.normalize();
            let grads = g.gradients(TranslationGradient::WardHeckbert);
            let world = grads.in_world(&Frame::from_normal(normal));
            let along = directional(&world.rotation, normal);
            let size = grads.rotation[0].abs() + grads.rotation[1].abs();
            prop_assert!(along.abs() <= 8.0 * f32::EPSILON * size, "{along} vs {size}");
        }

        /// Turning the whole configuration about the normal by s columns (2πs/N) moves each
        /// cell's sample to the cell s columns on, and turns both gradients by 2πs/N about z:
        /// the estimators treat every column alike, the wrap-around included.
        #[test]
        fn turning_about_the_normal_turns_the_gradients(g in gathers(), shift in 0u32..32) {
            let n = g.strata().n();
            let shift = shift % n;
            let turned = remapped(&g, |j, k| (j, (k + n - shift) % n), 1.0);
            let (sa, ca) = (std::f32::consts::TAU * shift as f32 / n as f32).sin_cos();
            let turn = |v: [f32; 3]| [ca * v[0] - sa * v[1], sa * v[0] + ca * v[1], v[2]];
            let (tt, tr) = tolerances(&g);
            for variant in [TranslationGradient::WardHeckbert, TranslationGradient::KrivanekGautron] {
                let a = g.gradients(variant);
                let b = turned.gradients(variant);
                // Turning the result adds ≤ 2 roundings per component: within the tolerance.
                prop_assert!(close(b.translation, turn(a.translation), tt), "{:?} vs {:?}", b.translation, turn(a.translation));
                prop_assert!(close(b.rotation, turn(a.rotation), tr), "{:?} vs {:?}", b.rotation, turn(a.rotation));
            }
        }

        /// Mirroring the configuration in the xz-plane (φ → −φ, column k → N − 1 − k) mirrors
        /// the translation gradient, (x, y, z) → (x, −y, z), and the rotation gradient, a
        /// pseudo-vector, (x, y) → (−x, y).
        #[test]
        fn mirroring_mirrors_the_gradients(g in gathers()) {
            let n = g.strata().n();
            let mirrored = remapped(&g, |j, k| (j, n - 1 - k), 1.0);
            let (tt, tr) = tolerances(&g);
            for variant in [TranslationGradient::WardHeckbert, TranslationGradient::KrivanekGautron] {
                let a = g.gradients(variant);
                let b = mirrored.gradients(variant);
                let t = a.translation;
                let r = a.rotation;
                prop_assert!(close(b.translation, [t[0], -t[1], t[2]], tt), "{:?} vs {:?}", b.translation, t);
                prop_assert!(close(b.rotation, [-r[0], r[1], r[2]], tr), "{:?} vs {:?}", b.rotation, r);
            }
        }

        /// Scaling every distance by s scales the translation gradient by 1/s and leaves the
        /// rotation gradient (which never reads a distance) and the irradiance unchanged.
        /// Tolerance: the rounding bound of `tolerances`, divided by s, plus the two roundings
        /// of r·s and 1/(r·s) per term (within the factor 2 of `tolerances`).
        #[test]
        fn scaling_distances_scales_the_translation_gradient(g in gathers(), log_s in -3.0f32..3.0) {
            let s = 10f32.powf(log_s);
            let scaled = remapped(&g, |j, k| (j, k), s);
            let (tt, _) = tolerances(&g);
            for variant in [TranslationGradient::WardHeckbert, TranslationGradient::KrivanekGautron] {
                let a = g.gradients(variant);
                let b = scaled.gradients(variant);
                prop_assert_eq!(b.rotation, a.rotation);
                prop_assert_eq!(b.irradiance, a.irradiance);
                let expected = a.translation.map(|v| v / s);
                prop_assert!(close(b.translation, expected, 2.0 * tt / s), "{:?} vs {expected:?}", b.translation);
            }
        }

        /// RGB is three scalars: each channel of a Vec3 (and Vec3A) gather gives exactly what
        /// the f32 gather of that channel gives (the same operations in the same order).
        #[test]
        fn channels_are_independent(a in gathers(), seed: u64) {
            let s = *a.strata();
            let key = irr_sampling::SampleKey::new(seed, 0, 0);
            let rgb = GatherSamples::from_fn(s, |c| {
                let i = c.index(&s) as usize;
                let u = key.uniform_2d(c.index(&s));
                (Vec3::new(a.radiance()[i], 10.0 * u.x, 10.0 * u.y), a.distance()[i])
            }).unwrap_or_else(|e| panic!("{e}"));
            let rgb_a = GatherSamples::from_fn(s, |c| {
                let i = c.index(&s) as usize;
                (Vec3A::from(rgb.radiance()[i]), rgb.distance()[i])
            }).unwrap_or_else(|e| panic!("{e}"));
            for ch in 0..3 {
                let mono = GatherSamples::from_fn(s, |c| {
                    let i = c.index(&s) as usize;
                    (rgb.radiance()[i][ch], rgb.distance()[i])
                }).unwrap_or_else(|e| panic!("{e}"));
                for variant in [TranslationGradient::WardHeckbert, TranslationGradient::KrivanekGautron] {
                    let g1 = mono.gradients(variant);
                    let g3 = rgb.gradients(variant);
                    let g3a = rgb_a.gradients(variant);
                    prop_assert_eq!(g3.irradiance[ch], g1.irradiance);
                    prop_assert_eq!(g3a.irradiance[ch], g1.irradiance);
                    for ax in 0..3 {
                        prop_assert_eq!(g3.translation[ax][ch], g1.translation[ax]);
                        prop_assert_eq!(g3.rotation[ax][ch], g1.rotation[ax]);
                        prop_assert_eq!(g3a.translation[ax][ch], g1.translation[ax]);
                    }
                }
            }
        }
    }

    /// The rotation weights are the cells' exact integrals: for L = 1 on the half φ ∈ [0, π)
    /// only (cell-aligned for even N), ∇ᵣE = ∫_half sin θ eφ dω = ∫₀^{π/2} sin² θ dθ ·
    /// ∫₀^π (−sin φ, cos φ) dφ = (π/4)·(−2, 0), for any M.
    #[test]
    fn rotation_of_a_half_sky_is_exact() {
        for (m, n) in [(1, 2), (3, 8), (17, 54), (64, 200)] {
            let s = HemisphereStrata::new(m, n).unwrap_or_else(|e| panic!("{e}"));
            let g = GatherSamples::from_fn(s, |c| {
                (if c.k < n / 2 { 1.0f32 } else { 0.0 }, f32::INFINITY)
            })
            .unwrap_or_else(|e| panic!("{e}"));
            let r = g.rotation_gradient();
            let expected = -std::f32::consts::FRAC_PI_2;
            // Rounding: ≤ (M + N + 6)ε relative to Σ|terms| ≤ 2π (see `tolerances`).
            let tol = (m + n + 6) as f32 * f32::EPSILON * std::f32::consts::TAU * 2.0;
            assert!(
                (r[0] - expected).abs() <= tol && r[1].abs() <= tol,
                "{m}×{n}: {r:?}"
            );
        }
    }

    /// Turning to world space: a gather whose normal is +y, with its local x along the frame's
    /// s, gives world gradients along s; extrapolation adds the two first-order terms.
    #[test]
    fn world_frame_and_extrapolation() {
        let frame = Frame::from_normal(Vec3::Y);
        let g = Gradients {
            irradiance: 2.0f32,
            rotation: [0.5, -0.25, 0.0],
            translation: [1.0, 0.0, 3.0],
        };
        let w = g.in_world(&frame);
        let t = Vec3::new(w.translation[0], w.translation[1], w.translation[2]);
        let expected = frame.s * 1.0 + frame.n * 3.0;
        assert!((t - expected).length() < 1e-6, "{t} vs {expected}");
        let r = Vec3::new(w.rotation[0], w.rotation[1], w.rotation[2]);
        assert!(r.dot(Vec3::Y).abs() < 1e-6);
        // E + offset·∇ₜE + (nᵢ × n)·∇ᵣE, in the local frame.
        let e = g.extrapolate(Vec3::new(0.1, 0.0, 0.0), Vec3::new(0.0, 0.2, 0.0));
        assert!((e - (2.0 + 0.1 * 1.0 - 0.2 * 0.25)).abs() < 1e-6, "{e}");
        // The same extrapolation in world space (offsets turned by the frame).
        let ew = w.extrapolate(
            frame.to_world(Vec3::new(0.1, 0.0, 0.0)),
            frame.to_world(Vec3::new(0.0, 0.2, 0.0)),
        );
        assert!((ew - e).abs() < 1e-6);
    }

    /// R ≤ E/‖∇ₜE‖ over the tangent plane, per channel, the smallest channel's bound winning;
    /// no gradient, no limit; the component along the normal does not count.
    #[test]
    fn radius_limit_follows_krivanek() {
        let g = Gradients {
            irradiance: Vec3::new(1.0, 2.0, 4.0),
            rotation: [Vec3::ZERO; 3],
            translation: [
                Vec3::new(3.0, 1.0, 0.0),
                Vec3::new(4.0, 0.0, 0.0),
                Vec3::new(100.0, 100.0, 100.0),
            ],
        };
        // Channel 0: 1/5; channel 1: 2/1; channel 2: no tangent gradient.
        assert!((g.radius_limit(Vec3::Z) - 0.2).abs() < 1e-7);
        let flat = Gradients {
            irradiance: 1.0f32,
            rotation: [0.0; 3],
            translation: [0.0, 0.0, 5.0],
        };
        assert_eq!(flat.radius_limit(Vec3::Z), f32::INFINITY);
        // In world space with the normal given, the same bound.
        let frame = Frame::from_normal(Vec3::new(1.0, 2.0, 2.0).normalize());
        let w = g.in_world(&frame);
        assert!((w.radius_limit(frame.n) - 0.2).abs() < 1e-6);
        // A zero irradiance with a gradient allows no radius at all.
        let dark = Gradients {
            irradiance: 0.0f32,
            rotation: [0.0; 3],
            translation: [1.0, 0.0, 0.0],
        };
        assert_eq!(dark.radius_limit(Vec3::Z), 0.0);
    }

    /// The horizon row: Ward & Heckbert's cell-centre weight (π/(MN))·tan θ꜀ falls short of the
    /// cell's exact integral ∫ sin² θ dθ·2 sin(π/N) by a factor tending to 1/√2 (module docs),
    /// and the crate uses the exact integral. A gather with L = 1 in one horizon cell only: the
    /// crate's |∇ᵣE| must equal the exact weight (to f32 rounding), and the centre weight divided
    /// by it must approach 1/√2 as M grows, within O(1/M) (the next term of the expansion; at
    /// M = 40 the gap is 1.5e-3, at 400 1.5e-4, at 4000 1.5e-5: below the 1e-4 asserted; the
    /// f32 rounding of the crate's weight adds ~1e-7).
    #[test]
    fn horizon_row_claim_holds() {
        let n = 8u32;
        let mut previous_gap = f64::INFINITY;
        for m in [40u32, 400, 4000] {
            let s = HemisphereStrata::new(m, n).unwrap_or_else(|e| panic!("{e}"));
            let last = (m - 1) * n;
            let g = GatherSamples::from_fn(s, |c| {
                (
                    if c.index(&s) == last { 1.0f32 } else { 0.0 },
                    f32::INFINITY,
                )
            })
            .unwrap_or_else(|e| panic!("{e}"));
            let r = g.rotation_gradient();
            let crate_weight = f64::from(r[0]).hypot(f64::from(r[1]));
            let (mf, nf) = (f64::from(m), f64::from(n));
            let t0 = ((mf - 1.0) / mf).sqrt().asin();
            let gi = |t: f64| 0.5 * (t - t.sin() * t.cos());
            let exact = (gi(std::f64::consts::FRAC_PI_2) - gi(t0))
                * 2.0
                * (std::f64::consts::PI / nf).sin();
            // f32 weights (two roundings) and their product: 4 ulps.
            assert!(
                (crate_weight / exact - 1.0).abs() < 4.0 * f64::from(f32::EPSILON),
                "M = {m}"
            );
            let u_c = 1.0 - 0.5 / mf;
            let centre = std::f64::consts::PI / (mf * nf) * (u_c / (1.0 - u_c)).sqrt();
            // The centre rule's φ factor is 2π/N where the exact one is 2 sin(π/N): compare θ
            // parts only.
            let phi_ratio =
                (2.0 * std::f64::consts::PI / nf) / (2.0 * (std::f64::consts::PI / nf).sin());
            let gap = (centre / crate_weight / phi_ratio - std::f64::consts::FRAC_1_SQRT_2).abs();
            assert!(gap < previous_gap, "M = {m}: gap {gap} did not shrink");
            previous_gap = gap;
        }
        assert!(previous_gap < 1e-4, "{previous_gap}");
    }
}
