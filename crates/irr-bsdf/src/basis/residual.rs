//! What an irradiance cache leaves out of the BRDF, in real SH, for radiance caching.
//!
//! A cache that multiplies irradiance by the diffuse stand-in ρ_d(wo)/π (crate docs) leaves out
//! the residual f − ρ_d/π: the glossy lobe, and the diffuse lobe's departure from its
//! stand-in. [`ResidualTable`] holds that residual's coefficients **without the cosine**, so
//! that with the coefficients c of the cosine-weighted incoming radiance L cos θi (zero below
//! the horizon), in the frame whose x axis is wo's azimuth,
//!
//! Σ_k c_k r_k = ∫_{H²} (f − ρ_d/π) L cos θi dωi
//!
//! up to the basis' truncation (exact when either function is band-limited to the order). Real
//! SH rather than HSH: records rotate into a query's frame with irr-sh's exact SH rotation, and
//! L cos θi, which vanishes on the horizon, continues by zero below it without a jump.
//!
//! # The residual's mirror image below the horizon
//! Since the light is zero below the horizon, the residual may be continued there by anything
//! without changing the integral; the table continues it by its mirror image, r(x, y, −z) =
//! r(x, y, z), rather than by zero. Real SH have parity (−1)^(l+m) under z → −z, so the
//! mirror continuation's coefficients are the upper hemisphere's doubled where l + m is even and
//! zero where it is odd. Continued by zero, the residual jumps at the horizon wherever it is
//! not zero there (the diffuse departure everywhere, the glossy lobe at grazing views), and
//! its truncation rings; mirrored, it is continuous, and the diffuse departure's hemisphere
//! indicator becomes the constant 1, exact at any order. On a rough metal floor (order 10) the
//! glossy light's bias per band of rows went from −0.71 / −2.62 / −1.34 % to −0.70 / −0.93 /
//! −1.44 % (docs/performance.md, "Radiance caching").
//!
//! The parts, per channel, with kd = (1 − metallic) base/π and specular weight s:
//! - glossy: f0 · a + (f90 − f0) · b ([`GlossyTable`] with [`Weighting::Plain`]);
//! - the diffuse lobe kd (1 − s F_d(|wo·h|)) with F_d = 0.04 + 0.96 w: kd ((1 − 0.04 s) u −
//!   0.96 s w_k), where u holds the coefficients of the upper hemisphere's indicator and w_k
//!   those of Schlick's weight w(|wo·h|) (a function of θo alone, tabulated on the glossy
//!   table's θo axis);
//! - minus the stand-in: − ρ_d(wo)/π · u.
//!
//! u and w_k are smooth over the hemisphere: a uniform midpoint rule in (cos θi, φi) computes
//! them, with `quadrature_nodes` × 2·`quadrature_nodes` nodes.

use super::{
    BasisTableError, GlossyTable, QUADRATURE_NODES, Weighting, cell, node_cos, theta_axis, view,
};
use crate::MetallicRoughness;
use crate::fresnel::DIELECTRIC_F0;
use glam::{DVec3, Vec3};
use irr_sh::{Basis, ShError};
use std::f32::consts::FRAC_1_PI;
use std::f64::consts::TAU;

/// The residual f − ρ_d/π of the BRDF in real SH of one order, tabulated over roughness and
/// cos θo (module docs).
#[derive(Clone, Debug)]
pub struct ResidualTable {
    glossy: GlossyTable,
    /// The coefficients of the upper hemisphere's indicator.
    upper: Vec<f32>,
    /// [cos θo node][k]: the coefficients of w(|wo·h|) over the upper hemisphere.
    fresnel: Vec<f32>,
    /// Per coefficient (l, m): 2 where l + m is even, 0 where odd: what turns a function's
    /// upper-hemisphere coefficients into its mirror continuation's (module docs).
    mirror: Vec<f32>,
}

impl ResidualTable {
    /// The table for SH of `order` at [`super::DEFAULT_RESOLUTION`]² nodes, each from
    /// [`QUADRATURE_NODES`]² quadrature nodes.
    pub fn sh(order: usize) -> Result<Self, BasisTableError> {
        Self::sh_within(order, &[(0.0, 1.0)])
    }

    /// [`ResidualTable::sh`] for lookups at roughness within the closed `ranges` only (the
    /// glossy part as [`GlossyTable::within`] builds it): what a renderer needs for the
    /// roughness its materials reach, at a fraction of the cost.
    pub fn sh_within(order: usize, ranges: &[(f32, f32)]) -> Result<Self, BasisTableError> {
        Self::new(
            order,
            (super::DEFAULT_RESOLUTION, super::DEFAULT_RESOLUTION),
            QUADRATURE_NODES,
            ranges,
        )
    }

    /// The table for SH of `order` at `(roughness, cos θo)` nodes, as [`GlossyTable::new`]
    /// places them, each from `quadrature_nodes`² nodes, for roughness within `ranges`
    /// ([`GlossyTable::within`]).
    pub fn new(
        order: usize,
        nodes: (usize, usize),
        quadrature_nodes: usize,
        ranges: &[(f32, f32)],
    ) -> Result<Self, BasisTableError> {
        let basis = Basis::sh(order)?;
        let glossy = GlossyTable::within(basis, nodes, quadrature_nodes, Weighting::Plain, ranges)?;
        let count = basis.coefficient_count();
        let cos_nodes = nodes.1;
        let views: Vec<DVec3> = (0..cos_nodes)
            .map(|j| view(node_cos(j as f64 / (cos_nodes - 1) as f64)))
            .collect();
        let mut upper = vec![0.0f64; count];
        let mut fresnel = vec![0.0f64; cos_nodes * count];
        let mut values = vec![0.0f64; count];
        let (rows, columns) = (quadrature_nodes, 2 * quadrature_nodes);
        let weight = TAU / (rows * columns) as f64;
        for i in 0..rows {
            let z = (i as f64 + 0.5) / rows as f64;
            let s = (1.0 - z * z).max(0.0).sqrt();
            for k in 0..columns {
                let (sin_p, cos_p) = (TAU * (k as f64 + 0.5) / columns as f64).sin_cos();
                let wi = DVec3::new(s * cos_p, s * sin_p, z);
                basis.eval_f64(wi, &mut values)?;
                for (u, v) in upper.iter_mut().zip(&values) {
                    *u += weight * v;
                }
                for (wo, row) in views.iter().zip(fresnel.chunks_exact_mut(count)) {
                    let w = schlick_weight_f64(((*wo + wi) * 0.5).length());
                    for (f, v) in row.iter_mut().zip(&values) {
                        *f += weight * w * v;
                    }
                }
            }
        }
        let mirror = (0..order)
            .flat_map(|l| (0..=2 * l).map(move |j| if j % 2 == 0 { 2.0 } else { 0.0 }))
            .collect();
        Ok(Self {
            glossy,
            upper: upper.iter().map(|&x| x as f32).collect(),
            fresnel: fresnel.iter().map(|&x| x as f32).collect(),
            mirror,
        })
    }

    /// The basis (real SH).
    pub fn basis(&self) -> Basis {
        self.glossy.basis()
    }

    /// The glossy lobe's relative reconstruction error at (roughness, cos θo)
    /// ([`GlossyTable::reconstruction_error`], without the cosine): how well this order holds
    /// the lobe, the criterion for using it at a shading point.
    pub fn reconstruction_error(&self, roughness: f32, cos_o: f32) -> f32 {
        self.glossy.reconstruction_error(roughness, cos_o)
    }

    /// The coefficients of the residual's mirror continuation (module docs) for `material` and
    /// cos θo = `cos_o`, per channel, written into `out` (`basis().coefficient_count()` long).
    pub fn coefficients(
        &self,
        material: &MetallicRoughness,
        cos_o: f32,
        out: &mut [Vec3],
    ) -> Result<(), BasisTableError> {
        self.glossy.coefficients(material, cos_o, out)?;
        let count = self.upper.len();
        let cos_nodes = self.glossy.resolution().1;
        let (j, t) = cell(theta_axis(cos_o), cos_nodes);
        let (lo, hi) = (
            &self.fresnel[j * count..(j + 1) * count],
            &self.fresnel[(j + 1) * count..(j + 2) * count],
        );
        let s = material.specular();
        let kd = material.base_color() * ((1.0 - material.metallic()) * FRAC_1_PI);
        let cos_o = if cos_o.is_nan() {
            0.0
        } else {
            cos_o.clamp(0.0, 1.0)
        };
        let wo = Vec3::new((1.0 - cos_o * cos_o).max(0.0).sqrt(), 0.0, cos_o);
        let stand_in = material.diffuse_albedo(wo) * FRAC_1_PI;
        let flat = kd * (1.0 - DIELECTRIC_F0 * s) - stand_in;
        let schlick = kd * ((1.0 - DIELECTRIC_F0) * s);
        let parts = self.upper.iter().zip(lo).zip(hi).zip(&self.mirror);
        for (o, (((&u, &a), &b), &mirror)) in out.iter_mut().zip(parts) {
            let w = a + t * (b - a);
            *o = (*o + flat * u - schlick * w) * mirror;
        }
        Ok(())
    }

    /// The reflected radiance Σ_k c_k r_k for the coefficients `incoming` of the cosine-weighted
    /// incoming radiance (RGB, in the frame whose x axis is wo's azimuth, normal +z), with
    /// `scratch` (`basis().coefficient_count()` long) for the residual's coefficients.
    pub fn radiance(
        &self,
        material: &MetallicRoughness,
        cos_o: f32,
        incoming: &[Vec3],
        scratch: &mut [Vec3],
    ) -> Result<Vec3, BasisTableError> {
        if incoming.len() != scratch.len() {
            return Err(ShError::LengthMismatch {
                expected: scratch.len(),
                actual: incoming.len(),
            }
            .into());
        }
        self.coefficients(material, cos_o, scratch)?;
        Ok(incoming
            .iter()
            .zip(scratch.iter())
            .map(|(c, r)| *c * *r)
            .sum())
    }
}

/// Schlick's weight (1 − x)⁵ for x = |wo·h| in f64, clamped into [0, 1].
fn schlick_weight_f64(x: f64) -> f64 {
    (1.0 - x).clamp(0.0, 1.0).powi(5)
}
