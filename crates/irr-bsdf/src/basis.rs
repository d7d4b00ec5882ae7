//! The glossy lobe in a (hemi)spherical-harmonic basis, for radiance caching (Křivánek,
//! Gautron, Pattanaik & Bouatouch 2005, "Radiance Caching for Efficient Global Illumination
//! Computation", TVCG 11(5): the BRDF's coefficients are precomputed per view angle
//! and tabulated, and a shading point's outgoing radiance is their dot product with the incoming
//! radiance's coefficients).
//!
//! # What is computed
//! For a view direction wo in the x-z plane (φo = 0) with cos θo = `cos_o`, the coefficients
//!
//! b_k(θo) = ∫_{H²} f_glossy(wo, wi) cos θi B_k(wi) dωi
//!
//! of the cosine-weighted glossy lobe in an irr-sh [`Basis`] (HSH, or SH with the lobe zero
//! below the horizon). With c_k the incoming radiance's coefficients **in the frame whose x axis
//! is wo's azimuth** (normal +z), the glossy outgoing radiance is Σ_k c_k b_k
//! ([`GlossyTable::radiance`]). A caller whose wo has azimuth φo ≠ 0 first rotates its
//! coefficients into the frame whose x axis is at azimuth φo: [`rotate_about_z`] (exact for both
//! SH and HSH, since a rotation about the normal keeps the hemisphere; it mixes only (l, m) with
//! (l, −m), by the angle |m|φo).
//!
//! # The Fresnel split (exact)
//! irr-bsdf's glossy lobe is F·D·ν with Schlick's F = f0 + (f90 − f0)·w, w = (1 − |wo·h|)⁵, and
//! f0 = mix(0.04 s, base, metallic), f90 = mix(s, 1, metallic) per channel (crate docs). F is
//! affine in (f0, f90), so
//!
//! b = f0 · b_A + (f90 − f0) · b_B, b_A = ∫ D ν cos θi B dωi, b_B = ∫ D ν w cos θi B dωi,
//!
//! exactly, where b_A and b_B depend only on (α, cos θo): two tables serve every base colour,
//! metallic and specular weight (a test checks f0·A + (f90 − f0)·B against `eval_lobes`).
//!
//! # Quadrature
//! Over the microfacet normal h instead of wi (dωi = 4 |wo·h| dωh, Walter et al. 2007, eq. 14),
//! with wi = reflect(wo, h) and the terms with wi below the horizon dropped: D depends on h
//! alone, so its width α sets the grid whatever the view. The grid is the midpoint rule in
//! (v, φh), θh = atan(α v / (1 − v)), which spreads the nodes over the lobe's scale α; the
//! default is [`QUADRATURE_NODES`]² nodes. Its error, measured as the relative L2 difference of
//! b_A's coefficient vector against 128² nodes (test `quadrature_converges`, HSH order 6, worst
//! over cos θo ∈ {0.05, 0.3, 0.6, 1}):
//!
//! | roughness | 0.1 | 0.2 | 0.4 | 0.6 | 0.8 | 1.0 |
//! |---|---|---|---|---|---|---|
//! | 32² nodes | 2.0e-3 | 7.7e-3 | 1.1e-2 | 1.2e-2 | 2.0e-2 | 8.1e-3 |
//! | 64² nodes | 1.1e-3 | 3.3e-3 | 6.2e-3 | 4.0e-3 | 2.2e-3 | 2.0e-3 |
//!
//! The midpoint rule converges only to first order here: the horizon (wi.z = 0) cuts the grid
//! in h along a curve, a jump the rule does not resolve. The default's ≲ 6e-3 is well below the
//! reconstruction error of any order below at the same roughness.
//!
//! # Tables
//! [`GlossyTable`] holds b_A and b_B on a grid uniform in roughness ∈ [0, 1] (α =
//! max(roughness², [`MIN_ALPHA`])) and in θo ∈ [0, π/2], and interpolates bilinearly. The θo
//! axis is uniform in the angle, not its cosine: the coefficients of odd m vary like sin θo,
//! whose slope in cos θo is infinite at normal incidence (a grid uniform in cos θo measured a
//! relative error of 8 % in its last cell at 9 × 9 nodes, order 2, roughness 0.69).
//!
//! **Resolution from the measured error** ([`interpolation_error`], test
//! `interpolation_error_table`): the largest relative L2 error of b_A's coefficient vector (for
//! HSH, equal to the L2 error of the reconstructed lobe) at the cells' midpoints against direct
//! quadrature with 64² nodes, HSH order 6, N × N nodes:
//!
//! | N | r ≥ 0.2, all θo | r ≥ 0.2, θo ≤ 80° | r ≥ 0.4, all θo | r ≥ 0.4, θo ≤ 80° |
//! |---|---|---|---|---|
//! | 8 | 3.1e-1 | 2.3e-1 | 1.3e-1 | 4.9e-2 |
//! | 16 | 8.5e-2 | 5.4e-2 | 8.4e-2 | 1.1e-2 |
//! | 32 | 5.1e-2 | 1.8e-2 | 5.1e-2 | 3.1e-3 |
//! | 64 | 3.7e-2 | 4.1e-3 | 3.7e-2 | 2.7e-3 |
//!
//! From 32 to 64 nodes the error for θo ≤ 80° and r ≥ 0.4 stops falling: 3e-3 is the
//! quadrature's own noise (table above), so finer tables buy nothing there. The default,
//! [`DEFAULT_RESOLUTION`] = 32 (32 × 32 nodes, two tables of 32²·n² f32), is where it reaches
//! that floor. Two regions converge more slowly: roughness near 0.2 (a lobe narrower than a
//! roughness cell) and the grazing cells θo > 80°, where the error is 5e-2 at 32 and 3.7e-2 at 64
//! nodes (not O(h²): the lobe's coefficients are not smooth in θo at the horizon). Compared with
//! the reconstruction error (next table), the table's error is negligible at roughness ≤ 0.6;
//! at roughness near 1 and grazing views it is not.
//!
//! # Reconstruction error of the lobe
//! How well order n represents the lobe itself ([`reconstruction_error`], test
//! `reconstruction_error_table`): the relative L2 error over the hemisphere of Σ b_k H_k(wi)
//! against D ν cos θi (Fresnel-free; HSH; 64² nodes, whose own error floor is ≈ 2e-3), for
//! cos θo = 0.2 / 0.5 / 0.8 / 1.0:
//!
//! | roughness | n = 4 | n = 6 | n = 8 | n = 10 |
//! |---|---|---|---|---|
//! | 0.2 | 0.99 / 0.97 / 0.95 / 0.95 | 0.98 / 0.93 / 0.89 / 0.88 | 0.96 / 0.89 / 0.83 / 0.79 | 0.95 / 0.85 / 0.75 / 0.71 |
//! | 0.4 | 0.87 / 0.70 / 0.54 / 0.46 | 0.80 / 0.54 / 0.32 / 0.25 | 0.73 / 0.42 / 0.19 / 0.13 | 0.68 / 0.32 / 0.11 / 0.06 |
//! | 0.6 | 0.50 / 0.31 / 0.13 / 0.07 | 0.38 / 0.17 / 0.03 / 0.01 | 0.30 / 0.10 / 0.01 / 0.002 | 0.24 / 0.06 / 0.003 / 0.002 |
//! | 0.8 | 0.14 / 0.06 / 0.01 / 0.002 | 0.08 / 0.03 / 0.003 / 0.002 | 0.06 / 0.01 / 0.001 / 0.002 | 0.04 / 0.008 / 0.001 / 0.002 |
//! | 1.0 | 0.02 / 0.008 / 0.003 / 0.003 | 0.004 / 0.001 / < 0.0005 / 0.002 | 0.001 / 0.001 / 0.001 / 0.002 | 0.001 / 0.001 / 0.001 / 0.003 |
//!
//! The lobe narrows and moves towards the horizon at grazing views, so the error grows as
//! cos θo falls. This table is what a renderer's threshold on roughness for order n must come
//! from; e.g. at n = 8 and cos θo = 0.5 the error is 10 % at roughness 0.6 and 42 % at 0.4.
//!
//! [`MIN_ALPHA`]: crate::MIN_ALPHA

use crate::MetallicRoughness;
use crate::material::MIN_ALPHA;
use glam::{DVec3, Vec3};
use irr_sh::{Basis, ShError};
use std::f64::consts::{PI, TAU};
use std::fmt;

/// The default number of quadrature nodes per axis (v, φh) of the microfacet-normal grid.
pub const QUADRATURE_NODES: usize = 64;

/// The default table resolution (roughness × cos θo nodes), chosen from the measured
/// interpolation error (module docs).
pub const DEFAULT_RESOLUTION: usize = 32;

/// Why a [`GlossyTable`] could not be built.
#[derive(Clone, Debug, PartialEq)]
pub enum BasisTableError {
    /// The basis' order is not supported by irr-sh.
    Basis(ShError),
    /// A table needs at least 2 nodes on each axis.
    Resolution {
        /// The roughness nodes asked for.
        roughness: usize,
        /// The cos θo nodes asked for.
        cos_theta: usize,
    },
    /// The quadrature needs at least 1 node per axis.
    Quadrature(usize),
    /// A lookup at a roughness whose table rows were not computed (a table built for some
    /// roughness ranges only: [`GlossyTable::within`]).
    Untabulated(f32),
}

impl fmt::Display for BasisTableError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Basis(e) => write!(f, "basis: {e}"),
            Self::Resolution {
                roughness,
                cos_theta,
            } => write!(
                f,
                "table resolution {roughness} × {cos_theta}: at least 2 nodes per axis"
            ),
            Self::Quadrature(n) => write!(f, "quadrature of {n} nodes per axis: at least 1"),
            Self::Untabulated(r) => write!(f, "roughness {r} lies outside the table's ranges"),
        }
    }
}

impl std::error::Error for BasisTableError {}

impl From<ShError> for BasisTableError {
    fn from(e: ShError) -> Self {
        Self::Basis(e)
    }
}

/// D(h) ν(wo, wi) in f64, the glossy lobe without its Fresnel factor (crate docs' formulas).
fn d_nu(alpha: f64, wo: DVec3, wi: DVec3, h: DVec3) -> f64 {
    let a2 = alpha * alpha;
    let t = h.z * h.z * (a2 - 1.0) + 1.0;
    let d = a2 / (PI * t * t);
    let nu = 0.5
        / (wo.z * (a2 + (1.0 - a2) * wi.z * wi.z).sqrt()
            + wi.z * (a2 + (1.0 - a2) * wo.z * wo.z).sqrt());
    d * nu
}

/// The cell of a table axis of `nodes` nodes over [0, 1] that holds `x` (clamped into [0, 1],
/// NaN read as 0), and the position within it.
fn cell(x: f32, nodes: usize) -> (usize, f32) {
    let x = if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
    let t = x * (nodes - 1) as f32;
    let i = (t.floor() as usize).min(nodes - 2);
    (i, t - i as f32)
}

/// The position on the table's θo axis of cos θo = `cos_o` (clamped into [0, 1], NaN read as 0).
/// The axis is uniform in θo: the coefficients of odd m vary like sin θo, whose slope in
/// cos θo is infinite at normal incidence, but which is smooth in θo.
fn theta_axis(cos_o: f32) -> f32 {
    let cos_o = if cos_o.is_nan() {
        0.0
    } else {
        cos_o.clamp(0.0, 1.0)
    };
    1.0 - cos_o.acos() / std::f32::consts::FRAC_PI_2
}

/// cos θo at position t ∈ [0, 1] of the table's θo axis: θo = (1 − t) π/2, so t = 1 is normal
/// incidence and nodes are uniform in θo.
fn node_cos(t: f64) -> f64 {
    ((1.0 - t) * std::f64::consts::FRAC_PI_2).cos()
}

/// The view direction with cos θo = `cos_o` (clamped into [0, 1]) in the x-z plane.
fn view(cos_o: f64) -> DVec3 {
    let c = cos_o.clamp(0.0, 1.0);
    DVec3::new((1.0 - c * c).max(0.0).sqrt(), 0.0, c)
}

/// Calls `f(wi, weight, h)` for each node of the microfacet-normal quadrature (module docs) whose
/// reflected wi lies above the horizon; `weight` includes dωi = 4 |wo·h| dωh.
fn for_each_node(alpha: f64, cos_o: f64, nodes: usize, mut f: impl FnMut(DVec3, f64, DVec3)) {
    let wo = view(cos_o);
    let dv = 1.0 / nodes as f64;
    let dphi = TAU / nodes as f64;
    for i in 0..nodes {
        let v = (i as f64 + 0.5) * dv;
        let theta = (alpha * v / (1.0 - v)).atan();
        let jacobian = alpha / ((1.0 - v).powi(2) + (alpha * v).powi(2));
        let (sin_t, cos_t) = theta.sin_cos();
        let w_row = sin_t * jacobian * dv * dphi;
        for j in 0..nodes {
            let (sin_p, cos_p) = ((j as f64 + 0.5) * dphi).sin_cos();
            let h = DVec3::new(sin_t * cos_p, sin_t * sin_p, cos_t);
            let d = wo.dot(h);
            let wi = 2.0 * d * h - wo;
            if d <= 0.0 || wi.z <= 0.0 {
                continue;
            }
            f(wi, w_row * 4.0 * d, h);
        }
    }
}

/// Which function of wi a table projects: the lobe times cos θi (its product with the incoming
/// *radiance*'s coefficients is the reflected radiance), or the lobe alone (its product with the
/// coefficients of the *cosine-weighted* radiance L cos θi is).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Weighting {
    /// D ν cos θi: pairs with the coefficients of L.
    Cosine,
    /// D ν: pairs with the coefficients of L cos θi.
    Plain,
}

/// The coefficients (b_A, b_B) of the Fresnel-free and Schlick-weighted cosine-weighted glossy
/// lobe (module docs) for GGX width `alpha` and cos θo = `cos_o`, by the quadrature with
/// `nodes`² nodes. Each vector has `basis.coefficient_count()` entries.
pub fn glossy_coefficients(
    basis: Basis,
    alpha: f64,
    cos_o: f64,
    nodes: usize,
) -> Result<(Vec<f64>, Vec<f64>), BasisTableError> {
    let (a, b, _) = lobe_coefficients(basis, alpha, cos_o, nodes, Weighting::Cosine)?;
    Ok((a, b))
}

/// [`glossy_coefficients`] with either [`Weighting`], and the relative L2 error of the
/// Fresnel-free **cosine-weighted** lobe D ν cos θi reconstructed in the basis, by Parseval's
/// identity (`parseval_error`): the lobe as the light it multiplies weighs it. (Without the
/// cosine the lobe jumps to zero at the horizon, a jump no SH order holds, though it matters
/// little once multiplied by L cos θi, which vanishes there.)
fn lobe_coefficients(
    basis: Basis,
    alpha: f64,
    cos_o: f64,
    nodes: usize,
    weighting: Weighting,
) -> Result<(Vec<f64>, Vec<f64>, f64), BasisTableError> {
    if nodes == 0 {
        return Err(BasisTableError::Quadrature(nodes));
    }
    let alpha = alpha.max(f64::from(MIN_ALPHA));
    let count = basis.coefficient_count();
    let (mut a, mut b) = (vec![0.0; count], vec![0.0; count]);
    // The cosine-weighted lobe's coefficients and squared norm, for the error.
    let (mut cosine, mut norm) = (vec![0.0; count], 0.0);
    let mut values = vec![0.0; count];
    let wo = view(cos_o);
    let mut result = Ok(());
    for_each_node(alpha, cos_o, nodes, |wi, weight, h| {
        if let Err(e) = basis.eval_f64(wi, &mut values) {
            result = Err(e);
            return;
        }
        let lobe = d_nu(alpha, wo, wi, h);
        let weighted = lobe * wi.z;
        norm += weighted * weighted * weight;
        let g = match weighting {
            Weighting::Cosine => weighted,
            Weighting::Plain => lobe,
        } * weight;
        let w = (1.0 - wo.dot(h).abs()).clamp(0.0, 1.0).powi(5);
        for (((ak, bk), ck), bv) in a.iter_mut().zip(&mut b).zip(&mut cosine).zip(&values) {
            *ak += g * bv;
            *bk += g * w * bv;
            *ck += weighted * weight * bv;
        }
    });
    result?;
    let error = parseval_error(&cosine, norm);
    Ok((a, b, error))
}

/// The relative L2 error √(1 − ‖b‖²/‖g‖²) of a function g of norm² `norm` reconstructed from its
/// coefficients `b` in an orthonormal basis (Parseval's identity: the part of g outside the
/// basis has norm² ‖g‖² − ‖b‖²); clamped at 0 where the quadrature's rounding makes ‖b‖ exceed
/// ‖g‖.
fn parseval_error(b: &[f64], norm: f64) -> f64 {
    if norm <= 0.0 {
        return 0.0;
    }
    let kept: f64 = b.iter().map(|x| x * x).sum();
    (1.0 - kept / norm).max(0.0).sqrt()
}

/// The coefficients b_A, b_B of the cosine-weighted glossy lobe (module docs), tabulated over
/// roughness × cos θo and interpolated bilinearly.
#[derive(Clone, Debug)]
pub struct GlossyTable {
    basis: Basis,
    weighting: Weighting,
    roughness_nodes: usize,
    cos_nodes: usize,
    /// Which roughness rows hold coefficients ([`GlossyTable::within`]).
    rows: Vec<bool>,
    /// [roughness][cos θo][k] for b_A, then the same for b_B.
    a: Vec<f32>,
    b: Vec<f32>,
    /// [roughness][cos θo]: the relative L2 error of the Fresnel-free cosine-weighted lobe in
    /// the basis (Parseval's identity, [`GlossyTable::reconstruction_error`]).
    error: Vec<f32>,
}

impl GlossyTable {
    /// The table for HSH of `order` at [`DEFAULT_RESOLUTION`]² nodes with [`QUADRATURE_NODES`]²
    /// quadrature nodes each.
    pub fn hsh(order: usize) -> Result<Self, BasisTableError> {
        Self::new(
            Basis::hsh(order)?,
            DEFAULT_RESOLUTION,
            DEFAULT_RESOLUTION,
            QUADRATURE_NODES,
        )
    }

    /// The table for `basis` at `roughness_nodes` × `cos_nodes` nodes (roughness i/(R − 1),
    /// θo = (1 − j/(C − 1)) π/2, uniform in θo), each computed with `quadrature_nodes`² nodes. Errors: fewer than 2
    /// nodes on an axis, no quadrature node.
    pub fn new(
        basis: Basis,
        roughness_nodes: usize,
        cos_nodes: usize,
        quadrature_nodes: usize,
    ) -> Result<Self, BasisTableError> {
        Self::with_weighting(
            basis,
            (roughness_nodes, cos_nodes),
            quadrature_nodes,
            Weighting::Cosine,
        )
    }

    /// [`GlossyTable::new`] for either [`Weighting`], at `(roughness, cos θo)` nodes.
    pub fn with_weighting(
        basis: Basis,
        nodes: (usize, usize),
        quadrature_nodes: usize,
        weighting: Weighting,
    ) -> Result<Self, BasisTableError> {
        Self::within(basis, nodes, quadrature_nodes, weighting, &[(0.0, 1.0)])
    }

    /// [`GlossyTable::with_weighting`] computing only the roughness rows that a lookup at a
    /// roughness within one of the closed `ranges` reads (the two rows around each such
    /// roughness): a renderer whose materials reach a few roughness values builds a few rows of
    /// the table (each row costs `cos_nodes` quadratures). Elsewhere the table holds nothing:
    /// lookups there are errors ([`BasisTableError::Untabulated`]) and
    /// [`GlossyTable::reconstruction_error`] is +∞. The rows it computes are the bits a full
    /// table has.
    pub fn within(
        basis: Basis,
        (roughness_nodes, cos_nodes): (usize, usize),
        quadrature_nodes: usize,
        weighting: Weighting,
        ranges: &[(f32, f32)],
    ) -> Result<Self, BasisTableError> {
        if roughness_nodes < 2 || cos_nodes < 2 {
            return Err(BasisTableError::Resolution {
                roughness: roughness_nodes,
                cos_theta: cos_nodes,
            });
        }
        let mut rows = vec![false; roughness_nodes];
        for &(lo, hi) in ranges {
            let (first, _) = cell(lo.min(hi), roughness_nodes);
            let (last, _) = cell(hi.max(lo), roughness_nodes);
            rows[first..=last + 1].fill(true);
        }
        let count = basis.coefficient_count();
        let size = roughness_nodes * cos_nodes * count;
        let (mut a, mut b) = (Vec::with_capacity(size), Vec::with_capacity(size));
        let mut error = Vec::with_capacity(roughness_nodes * cos_nodes);
        for (i, &computed) in rows.iter().enumerate() {
            let r = i as f64 / (roughness_nodes - 1) as f64;
            for j in 0..cos_nodes {
                if !computed {
                    a.resize(a.len() + count, 0.0);
                    b.resize(b.len() + count, 0.0);
                    error.push(f32::INFINITY);
                    continue;
                }
                let c = node_cos(j as f64 / (cos_nodes - 1) as f64);
                let (ca, cb, e) = lobe_coefficients(basis, r * r, c, quadrature_nodes, weighting)?;
                a.extend(ca.iter().map(|&x| x as f32));
                b.extend(cb.iter().map(|&x| x as f32));
                error.push(e as f32);
            }
        }
        Ok(Self {
            basis,
            weighting,
            roughness_nodes,
            cos_nodes,
            rows,
            a,
            b,
            error,
        })
    }

    /// Whether a lookup at `roughness` reads computed rows only ([`GlossyTable::within`]).
    pub fn tabulates(&self, roughness: f32) -> bool {
        let (i, _) = cell(roughness, self.roughness_nodes);
        self.rows[i] && self.rows[i + 1]
    }

    /// What the table projects (the lobe with or without cos θi).
    pub fn weighting(&self) -> Weighting {
        self.weighting
    }

    /// The relative L2 error over the hemisphere of the Fresnel-free cosine-weighted lobe
    /// g = D ν cos θi reconstructed from its coefficients in the table's basis,
    /// √(1 − ‖b‖²/‖g‖²) by Parseval's identity, computed at the nodes and interpolated
    /// bilinearly at (roughness, cos θo): how well the basis' order holds the lobe as the light
    /// it multiplies weighs it (module docs' "Reconstruction error" table, for HSH), whatever
    /// the table's [`Weighting`].
    pub fn reconstruction_error(&self, roughness: f32, cos_o: f32) -> f32 {
        if !self.tabulates(roughness) {
            return f32::INFINITY;
        }
        let (i, u) = cell(roughness, self.roughness_nodes);
        let (j, v) = cell(theta_axis(cos_o), self.cos_nodes);
        let at = |ii: usize, jj: usize| self.error[ii * self.cos_nodes + jj];
        (1.0 - u) * ((1.0 - v) * at(i, j) + v * at(i, j + 1))
            + u * ((1.0 - v) * at(i + 1, j) + v * at(i + 1, j + 1))
    }

    /// The basis of the coefficients.
    pub fn basis(&self) -> Basis {
        self.basis
    }

    /// The resolution (roughness nodes, cos θo nodes).
    pub fn resolution(&self) -> (usize, usize) {
        (self.roughness_nodes, self.cos_nodes)
    }

    /// Writes b_A and b_B interpolated bilinearly at (roughness, cos θo), both clamped into
    /// [0, 1] (NaN read as 0), into `a` and `b`, each `basis().coefficient_count()` long.
    pub fn lookup(
        &self,
        roughness: f32,
        cos_o: f32,
        a: &mut [f32],
        b: &mut [f32],
    ) -> Result<(), BasisTableError> {
        let count = self.basis.coefficient_count();
        for len in [a.len(), b.len()] {
            if len != count {
                return Err(ShError::LengthMismatch {
                    expected: count,
                    actual: len,
                }
                .into());
            }
        }
        let corners = self.corners(roughness, cos_o)?;
        for (table, out) in [(&self.a, &mut *a), (&self.b, &mut *b)] {
            out.fill(0.0);
            for &(start, w) in &corners {
                for (o, t) in out.iter_mut().zip(&table[start..start + count]) {
                    *o += w * t;
                }
            }
        }
        Ok(())
    }

    /// The start of each of the four table entries around (roughness, cos θo) and its bilinear
    /// weight; an error where those rows were not computed.
    fn corners(&self, roughness: f32, cos_o: f32) -> Result<[(usize, f32); 4], BasisTableError> {
        if !self.tabulates(roughness) {
            return Err(BasisTableError::Untabulated(roughness));
        }
        let count = self.basis.coefficient_count();
        let (i, u) = cell(roughness, self.roughness_nodes);
        let (j, v) = cell(theta_axis(cos_o), self.cos_nodes);
        let at = |ii: usize, jj: usize| (ii * self.cos_nodes + jj) * count;
        Ok([
            (at(i, j), (1.0 - u) * (1.0 - v)),
            (at(i, j + 1), (1.0 - u) * v),
            (at(i + 1, j), u * (1.0 - v)),
            (at(i + 1, j + 1), u * v),
        ])
    }

    /// The glossy lobe's coefficients for `material` and cos θo = `cos_o`, per channel:
    /// f0 · b_A + (f90 − f0) · b_B (module docs), interpolated as [`GlossyTable::lookup`] does,
    /// written into `out`.
    pub fn coefficients(
        &self,
        material: &MetallicRoughness,
        cos_o: f32,
        out: &mut [Vec3],
    ) -> Result<(), BasisTableError> {
        let count = self.basis.coefficient_count();
        if out.len() != count {
            return Err(ShError::LengthMismatch {
                expected: count,
                actual: out.len(),
            }
            .into());
        }
        let f0 = material.specular_f0();
        let df = material.specular_f90() - f0;
        out.fill(Vec3::ZERO);
        for (start, w) in self.corners(material.roughness(), cos_o)? {
            let (a, b) = (&self.a[start..start + count], &self.b[start..start + count]);
            let (wa, wb) = (f0 * w, df * w);
            for ((o, ak), bk) in out.iter_mut().zip(a).zip(b) {
                *o += wa * *ak + wb * *bk;
            }
        }
        Ok(())
    }

    /// The glossy lobe's outgoing radiance Σ_k c_k b_k for incoming radiance coefficients
    /// `incoming` (RGB, in the frame whose x axis is wo's azimuth, normal +z) and cos θo =
    /// `cos_o`.
    pub fn radiance(
        &self,
        material: &MetallicRoughness,
        cos_o: f32,
        incoming: &[Vec3],
    ) -> Result<Vec3, BasisTableError> {
        let mut b = vec![Vec3::ZERO; self.basis.coefficient_count()];
        self.coefficients(material, cos_o, &mut b)?;
        if incoming.len() != b.len() {
            return Err(ShError::LengthMismatch {
                expected: b.len(),
                actual: incoming.len(),
            }
            .into());
        }
        Ok(incoming.iter().zip(&b).map(|(c, k)| *c * *k).sum())
    }
}

/// Re-expresses `coefficients` (of `basis`, real SH or HSH as irr-sh defines them) in the frame
/// turned by `azimuth` about z, whose x axis points at azimuth `azimuth` of the old frame: a
/// function's value at a direction of azimuth φ' in the new frame is its value at φ' + azimuth in
/// the old one. With f = a cos mφ + b sin mφ (a at index (l, m), b at (l, −m)), the new pair is
/// (a cos mβ + b sin mβ, b cos mβ − a sin mβ) for β = `azimuth`.
pub fn rotate_about_z<V>(basis: Basis, coefficients: &mut [V], azimuth: f64) -> Result<(), ShError>
where
    V: Copy
        + std::ops::Mul<f32, Output = V>
        + std::ops::Add<Output = V>
        + std::ops::Sub<Output = V>,
{
    let count = basis.coefficient_count();
    if coefficients.len() != count {
        return Err(ShError::LengthMismatch {
            expected: count,
            actual: coefficients.len(),
        });
    }
    // cos mβ and sin mβ by the angle-addition recurrence from one sin_cos, in f64 (each step
    // is a rotation of the unit circle: the error grows by ~2⁻⁵³ per step, far below f32).
    let (s1, c1) = azimuth.sin_cos();
    let mut turns = [(0.0f32, 1.0f32); irr_sh::MAX_ORDER];
    let (mut c, mut s) = (1.0f64, 0.0f64);
    for t in turns.iter_mut().take(basis.order()) {
        *t = (s as f32, c as f32);
        (c, s) = (c * c1 - s * s1, s * c1 + c * s1);
    }
    for l in 0..basis.order() {
        for (m, &(sin, cos)) in turns.iter().enumerate().take(l + 1).skip(1) {
            let (ip, im) = (l * l + l + m, l * l + l - m);
            let (a, b) = (coefficients[ip], coefficients[im]);
            coefficients[ip] = a * cos + b * sin;
            coefficients[im] = b * cos - a * sin;
        }
    }
    Ok(())
}

/// The largest relative L2 error ‖b_table − b_direct‖ / ‖b_direct‖ of `table`'s b_A against
/// direct quadrature (`quadrature_nodes`²) at the midpoints of its cells with roughness ≥
/// `min_roughness` and cos θo ≥ `min_cos`. For an orthonormal basis (HSH) this is also the relative L2 error of the
/// reconstructed lobe's interpolation over the hemisphere.
pub fn interpolation_error(
    table: &GlossyTable,
    min_roughness: f64,
    min_cos: f64,
    quadrature_nodes: usize,
) -> Result<f64, BasisTableError> {
    let (rn, cn) = table.resolution();
    let count = table.basis.coefficient_count();
    let (mut a, mut b) = (vec![0.0; count], vec![0.0; count]);
    let mut worst = 0.0f64;
    for i in 0..rn - 1 {
        let r = (i as f64 + 0.5) / (rn - 1) as f64;
        if r < min_roughness {
            continue;
        }
        for j in 0..cn - 1 {
            let c = node_cos((j as f64 + 0.5) / (cn - 1) as f64);
            if c < min_cos {
                continue;
            }
            table.lookup(r as f32, c as f32, &mut a, &mut b)?;
            let (direct, _) = glossy_coefficients(table.basis, r * r, c, quadrature_nodes)?;
            let diff: f64 = a
                .iter()
                .zip(&direct)
                .map(|(x, y)| (f64::from(*x) - y).powi(2))
                .sum();
            let norm: f64 = direct.iter().map(|y| y * y).sum();
            if norm > 0.0 {
                worst = worst.max((diff / norm).sqrt());
            }
        }
    }
    Ok(worst)
}

/// The relative L2 error over the hemisphere of the cosine-weighted Fresnel-free lobe
/// D ν cos θi reconstructed from its coefficients in `basis` (Σ b_k B_k(wi)), for roughness and
/// cos θo, both integrals by the quadrature with `nodes`² nodes (its reflected directions cover
/// the whole hemisphere, densest in the lobe).
pub fn reconstruction_error(
    basis: Basis,
    roughness: f64,
    cos_o: f64,
    nodes: usize,
) -> Result<f64, BasisTableError> {
    let alpha = (roughness * roughness).max(f64::from(MIN_ALPHA));
    let (coefficients, _) = glossy_coefficients(basis, alpha, cos_o, nodes)?;
    let wo = view(cos_o);
    let mut values = vec![0.0; basis.coefficient_count()];
    let (mut err, mut norm) = (0.0, 0.0);
    let mut result = Ok(());
    for_each_node(alpha, cos_o, nodes, |wi, weight, h| {
        if let Err(e) = basis.eval_f64(wi, &mut values) {
            result = Err(e);
            return;
        }
        let g = d_nu(alpha, wo, wi, h) * wi.z;
        let r: f64 = values.iter().zip(&coefficients).map(|(x, y)| x * y).sum();
        err += weight * (r - g).powi(2);
        norm += weight * g * g;
    });
    result?;
    Ok((err / norm).sqrt())
}

mod residual;
pub use residual::ResidualTable;

#[cfg(test)]
mod tests;
