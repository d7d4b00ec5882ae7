//! Radiance caching for glossy lobes (Křivánek, Gautron, Pattanaik & Bouatouch 2005): each
//! first-level record also keeps its gather's incoming light as coefficients, and a glossy
//! shading point reflects their interpolation through its BRDF's coefficients instead of
//! path-tracing its lobe.
//!
//! # What a record stores
//! The coefficients, in real SH of order n ([`IcSettings::radiance_order`]) in the record's
//! frame (`Frame::from_normal` of its normal, the frame its gather used), of the
//! **cosine-weighted** incoming radiance L cos θ over the upper hemisphere, zero below:
//!
//! c_k = (π/MN) Σ_cells mean over the cell's rays of L·Y_k(ω),
//!
//! the same estimator as the record's irradiance (E = √(4π)·c₀ exactly), with its bounded
//! weights (irr-sh's crate docs measure the alternative, radiance with 1/cos θ weights, 10×
//! noisier). What each ray brings back is what the record's irradiance counts: the light its
//! hit reflects and the background, never an emitter's own light (that is the direct light's,
//! by next-event estimation).
//!
//! # A glossy shading point
//! Its BRDF minus the diffuse stand-in the irradiance cache already covers, f − ρ_d/π, is
//! irr-bsdf's [`ResidualTable`] (cosine-free, so that its product with L cos θ is the reflected
//! light). The point takes every record the irradiance cache would weigh there (same weights,
//! same leak guard), rotates each one's coefficients into its own frame (irr-sh's exact SH
//! rotation; none where the normals are equal), averages them by weight, turns the result
//! about the normal to wo's azimuth and takes the dot product with the residual's
//! coefficients: the lobe's indirect light, with no ray traced. Its direct light is then next-
//! event estimation alone (no BSDF sample to weigh it against).
//!
//! **When.** Only where the lobe's relative reconstruction error at the point's roughness and
//! view angle is at most [`IcSettings::radiance_error`] (the table's Parseval error, measured
//! per node); elsewhere (sharp lobes, grazing views), and where no record with coefficients
//! covers the point, the lobe is path-traced as without radiance caching. The choice depends
//! only on the point, so it is deterministic.
//!
//! **Left out.** Per-coefficient translation gradients: records interpolate their coefficients
//! by weight alone (Ward et al. 1988's form), which is consistent (the records' spacing, and so
//! the error, shrinks with the error parameter).
//!
//! [`IcSettings::radiance_order`]: super::IcSettings::radiance_order
//! [`IcSettings::radiance_error`]: super::IcSettings::radiance_error

use crate::bsdf::Bsdf;
use glam::{Mat3, Vec3};
use irr_bsdf::basis::{BasisTableError, ResidualTable, rotate_about_z};
use irr_sampling::{Frame, HemisphereStrata};
use irr_sh::{Basis, ShRotation};
use std::f32::consts::PI;

/// One ray of a gather as the projection reads it: its cell's index, its direction in the
/// gather's frame and what it brought back.
pub(super) type LoggedRay = (u32, Vec3, Vec3);

/// The basis, the BRDF's table and the threshold (module docs).
#[derive(Clone, Debug)]
pub(super) struct RadianceCaching {
    table: ResidualTable,
    basis: Basis,
    max_error: f32,
}

impl RadianceCaching {
    /// The table for SH of `order`, used where the lobe's reconstruction error is at most
    /// `max_error`.
    pub(super) fn new(order: usize, max_error: f32) -> Result<Self, BasisTableError> {
        let table = ResidualTable::sh(order)?;
        Ok(Self {
            basis: table.basis(),
            table,
            max_error,
        })
    }

    /// The basis' order n.
    pub(super) fn order(&self) -> usize {
        self.basis.order()
    }

    /// Coefficients per colour channel, n².
    pub(super) fn count(&self) -> usize {
        self.basis.coefficient_count()
    }

    /// Whether `bsdf`'s lobe is reflected from the records (module docs, "When").
    pub(super) fn covers(&self, bsdf: &Bsdf) -> bool {
        match bsdf {
            Bsdf::Lambertian { .. } => false,
            Bsdf::Glossy { material, wo, .. } => {
                self.table.reconstruction_error(material.roughness(), wo.z) <= self.max_error
            }
        }
    }

    /// The coefficients of a gather's cosine-weighted radiance from its rays `log` (every ray,
    /// including those of super-sampled cells and those below the geometric surface, which
    /// brought back nothing), in the gather's frame.
    pub(super) fn project(&self, strata: HemisphereStrata, log: &[LoggedRay]) -> Vec<Vec3> {
        let mut per_cell = vec![0u32; strata.len()];
        for &(cell, _, _) in log {
            if let Some(c) = per_cell.get_mut(cell as usize) {
                *c += 1;
            }
        }
        let cell_weight = PI / strata.len() as f32;
        let mut out = vec![Vec3::ZERO; self.count()];
        let mut values = vec![0.0f32; self.count()];
        for &(cell, w, value) in log {
            let samples = per_cell.get(cell as usize).copied().unwrap_or(0);
            if samples == 0 || value == Vec3::ZERO || self.basis.eval(w, &mut values).is_err() {
                continue;
            }
            let weighted = value * (cell_weight / samples as f32);
            for (o, y) in out.iter_mut().zip(&values) {
                *o += weighted * *y;
            }
        }
        out
    }

    /// Adds `weight` times the record's coefficients `stored` (in the frame of `record_normal`)
    /// turned into `frame` to `sum`; `turned` is scratch of `count()` entries.
    pub(super) fn accumulate(
        &self,
        (stored, record_normal): (&[Vec3], Vec3),
        frame: &Frame,
        weight: f32,
        sum: &mut [Vec3],
        turned: &mut [Vec3],
    ) {
        // Normals within 2⁻²⁰ of each other (a flat surface's interpolated normals, equal up
        // to rounding) share the frame to that order: no rotation.
        if (record_normal - frame.n).length_squared() < 1e-12 {
            for (s, c) in sum.iter_mut().zip(stored) {
                *s += *c * weight;
            }
            return;
        }
        // R = F_qᵀ F_r: the record frame's axes in the query's frame (irr-sh's convention).
        let record = Frame::from_normal(record_normal);
        let rotation = Mat3::from_cols(
            frame.to_local(record.s),
            frame.to_local(record.t),
            frame.to_local(record.n),
        );
        let order = self.basis.order();
        let Ok(r) = ShRotation::new(order, rotation) else {
            return;
        };
        if r.apply(stored, turned).is_err() {
            return;
        }
        for (s, c) in sum.iter_mut().zip(turned.iter()) {
            *s += *c * weight;
        }
    }

    /// The light `bsdf` reflects through its residual f − ρ_d/π from the averaged coefficients
    /// `incoming` (in the shading frame; turned in place to wo's azimuth), with `scratch` of
    /// `count()` entries. Zero for a Lambertian BSDF.
    pub(super) fn reflect(&self, bsdf: &Bsdf, incoming: &mut [Vec3], scratch: &mut [Vec3]) -> Vec3 {
        let Bsdf::Glossy { material, wo, .. } = bsdf else {
            return Vec3::ZERO;
        };
        let azimuth = f64::from(wo.y.atan2(wo.x));
        if rotate_about_z(self.basis, incoming, azimuth).is_err() {
            return Vec3::ZERO;
        }
        self.table
            .radiance(material, wo.z, incoming, scratch)
            .unwrap_or(Vec3::ZERO)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use irr_bsdf::MetallicRoughness;
    use irr_sampling::SampleKey;
    use std::f32::consts::TAU;

    fn caching(order: usize) -> RadianceCaching {
        RadianceCaching::new(order, 0.5).unwrap_or_else(|e| panic!("{e}"))
    }

    /// A uniform sky of radiance 1 seen by a cosine-stratified gather: c₀ = (π/MN)·Σ Y₀ =
    /// π·Y₀ = π/√(4π), exactly (every ray brings 1, Y₀ is constant), so √(4π)·c₀ = E = π, up to
    /// f32 rounding of MN sums (MN·2⁻²⁴ relative).
    #[test]
    fn projection_of_a_uniform_sky_gives_its_irradiance() {
        let rc = caching(3);
        let strata = HemisphereStrata::new(4, 16).unwrap_or_else(|e| panic!("{e}"));
        let log: Vec<LoggedRay> = strata
            .cells()
            .map(|cell| {
                let key = SampleKey::new(7, u64::from(cell.index(&strata)), 0);
                (
                    cell.index(&strata),
                    strata.sample(cell, key.uniform_2d(0)),
                    Vec3::ONE,
                )
            })
            .collect();
        let c = rc.project(strata, &log);
        let e = c[0] * (4.0 * PI).sqrt();
        assert!((e - Vec3::splat(PI)).abs().max_element() < 64.0 * 6e-8 * PI);
    }

    /// Turning a record into a frame that differs only by the tangent's choice (same normal,
    /// frames from different normals' conventions) and back is the identity; and a record
    /// whose frame is the query's is added unchanged. The rotation is exact up to f32 rounding
    /// of order-n sums (n² terms: 16·2⁻²⁴ per entry, asserted at 1e-5 for entries ≲ 1).
    #[test]
    fn accumulate_rotates_between_frames() {
        let rc = caching(4);
        let count = rc.count();
        let stored: Vec<Vec3> = (0..count)
            .map(|k| Vec3::splat(((k * 3 % 7) as f32 - 3.0) / 4.0))
            .collect();
        let n = Vec3::new(0.3, 0.2, 0.9).normalize();
        let frame = Frame::from_normal(n);
        let (mut sum, mut turned) = (vec![Vec3::ZERO; count], vec![Vec3::ZERO; count]);
        rc.accumulate((&stored, n), &frame, 2.0, &mut sum, &mut turned);
        for (s, c) in sum.iter().zip(&stored) {
            assert_eq!(*s, *c * 2.0);
        }
        // A record on a tilted normal: its coefficients evaluated along a direction d equal
        // the turned ones evaluated along d in the query's frame.
        let m = Vec3::new(0.1, 0.3, 0.95).normalize();
        let record = Frame::from_normal(m);
        sum.fill(Vec3::ZERO);
        rc.accumulate((&stored, m), &frame, 1.0, &mut sum, &mut turned);
        for d in [Vec3::new(0.2, 0.1, 0.97), Vec3::new(-0.5, 0.4, 0.77)] {
            let d = d.normalize();
            let a = rc
                .basis
                .reconstruct(&stored, record.to_local(d))
                .unwrap_or_else(|e| panic!("{e}"));
            let b = rc
                .basis
                .reconstruct(&sum, frame.to_local(d))
                .unwrap_or_else(|e| panic!("{e}"));
            assert!((a - b).abs().max_element() < 1e-4, "{a} vs {b}");
        }
    }

    /// A uniform sky's coefficients reflect the residual's integral against L cos θ = cos θ:
    /// the glossy albedo plus the diffuse lobe's departure, which integrates to zero under
    /// uniform light. Checked against irr-bsdf's own glossy albedo by direct evaluation: the
    /// midpoint rule in (cos θi, φ) on 256 × 512 cells, whose error is estimated by halving
    /// the grid; the SH truncation of cos θ·χ (a kink at the horizon) is the other term, bounded
    /// by the product of both functions' truncation norms, measured here as the difference to
    /// order 8; the third is the table's own bilinear interpolation, at most 3.1e-3 relative
    /// for roughness ≥ 0.4 and θo ≤ 80° (irr-bsdf's basis module docs, measured against direct
    /// quadrature).
    #[test]
    fn uniform_sky_reflects_the_glossy_albedo() {
        let m = MetallicRoughness::new(Vec3::new(0.8, 0.6, 0.4), 0.5, 0.9);
        let wo = Vec3::new(0.5, 0.2, 0.84).normalize();
        let frame = Frame::from_normal(Vec3::Z);
        let bsdf = Bsdf::Glossy {
            material: m,
            frame,
            wo,
        };
        let reflected = |order: usize| {
            let rc = caching(order);
            // The exact coefficients of cos θ·χ(θ < π/2), by a fine midpoint rule.
            let (rows, columns) = (512, 64);
            let mut c = vec![Vec3::ZERO; rc.count()];
            let mut values = vec![0.0f32; rc.count()];
            for i in 0..rows {
                let z = (i as f32 + 0.5) / rows as f32;
                let s = (1.0 - z * z).sqrt();
                for k in 0..columns {
                    let p = TAU * (k as f32 + 0.5) / columns as f32;
                    let w = Vec3::new(s * p.cos(), s * p.sin(), z);
                    rc.basis
                        .eval(w, &mut values)
                        .unwrap_or_else(|e| panic!("{e}"));
                    let weight = z * TAU / (rows * columns) as f32;
                    for (o, y) in c.iter_mut().zip(&values) {
                        *o += Vec3::splat(weight * y);
                    }
                }
            }
            let mut scratch = vec![Vec3::ZERO; rc.count()];
            rc.reflect(&bsdf, &mut c, &mut scratch)
        };
        let albedo = |rows: usize| {
            let columns = 2 * rows;
            let mut sum = Vec3::ZERO;
            for i in 0..rows {
                let z = (i as f32 + 0.5) / rows as f32;
                let s = (1.0 - z * z).sqrt();
                for k in 0..columns {
                    let p = TAU * (k as f32 + 0.5) / columns as f32;
                    let wi = Vec3::new(s * p.cos(), s * p.sin(), z);
                    sum += m.eval_lobes(wo, wi).glossy * z;
                }
            }
            sum * (TAU / (rows * columns) as f32)
        };
        let (want, half) = (albedo(256), albedo(128));
        let (got, finer) = (reflected(6), reflected(8));
        let tol = (want - half).abs().max_element()
            + (got - finer).abs().max_element()
            + 3.1e-3 * want.max_element()
            + 1e-4;
        let err = (got - want).abs().max_element();
        assert!(err <= tol, "{got} vs {want} ({err} > {tol})");
    }
}
