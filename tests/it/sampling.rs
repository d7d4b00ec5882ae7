//! irr-sampling used as a renderer uses it: stratified directions around arbitrary normals.

use glam::Vec3;
use irr_sampling::{Frame, HemisphereStrata, SampleKey};
use proptest::prelude::*;

proptest! {
    /// A gather around any normal stays in that normal's hemisphere, each sampled direction lies
    /// in the cell it was drawn for, and the estimate of a sky of radiance L above the surface
    /// (L where the sampled direction is above it, 0 below) is exactly L·π (each of the MN cells
    /// carries weight π/(MN)), up to the rounding of MN additions of π/(MN)·L: relative error
    /// ≤ MN·2⁻²⁴ ≈ 6e-5 for MN = 1024. A direction that left its hemisphere or its cell fails.
    #[test]
    fn gather_of_constant_radiance_is_pi_l(
        nx in -1.0f32..1.0, ny in -1.0f32..1.0, nz in -1.0f32..1.0, seed: u64, l in 0.01f32..100.0,
    ) {
        let n = Vec3::new(nx, ny, nz);
        prop_assume!(n.length() > 1e-2);
        let n = n.normalize();
        let frame = Frame::from_normal(n);
        let strata = HemisphereStrata::with_sample_count(1024).unwrap_or_else(|e| panic!("{e}"));
        let key = SampleKey::new(seed, 1, 0);
        let mut e = 0.0f32;
        for cell in strata.cells() {
            let wi = frame.to_world(strata.sample(cell, key.uniform_2d(cell.index(&strata))));
            prop_assert!(wi.dot(n) >= -1e-5, "direction below the surface: {wi} for {n}");
            // Back in the local frame, the direction's cell (one f32 rotation each way moves it
            // by a few ulps; a cell is far wider unless the sample sits on its wall, which
            // `cell_point` keeps it off by at least one ulp of the unit square). Near the pole
            // the azimuth is ill-conditioned: a move of δ ≈ 4·2⁻²⁴ turns it by δ/sin θ, which
            // spans that many cells of 2π/n of the ring, plus one for a wall.
            let local = frame.to_local(wi);
            let back = strata.cell_of(local.with_z(local.z.max(0.0)));
            let n_k = strata.n();
            let sin = local.x.hypot(local.y).max(f32::MIN_POSITIVE);
            let turn = 4.0 * f32::EPSILON / sin / (std::f32::consts::TAU / n_k as f32);
            let slack = turn.min(n_k as f32).ceil() as u32 + 1;
            let dk = back.k.abs_diff(cell.k);
            prop_assert!(back.j.abs_diff(cell.j) <= 1 && dk.min(n_k - dk) <= slack, "{cell:?} came back as {back:?}");
            let sky = if wi.dot(n) >= 0.0 { l } else { 0.0 };
            e += strata.cell_weight() * sky;
        }
        let rel = (e - std::f32::consts::PI * l).abs() / (std::f32::consts::PI * l);
        prop_assert!(rel < strata.len() as f32 * f32::EPSILON, "{rel}");
    }
}
