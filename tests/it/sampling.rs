//! irr-sampling used as a renderer uses it: stratified directions around arbitrary normals.

use glam::Vec3;
use irr_sampling::{Frame, HemisphereStrata, SampleKey};
use proptest::prelude::*;

proptest! {
    /// A gather around any normal stays in that normal's hemisphere, and the estimate of a
    /// constant radiance L is exactly L·π (each of the MN cells carries weight π/(MN)), up to the
    /// rounding of MN additions of π/(MN)·L: relative error ≤ MN·2⁻²⁴ ≈ 6e-5 for MN = 1024.
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
            e += strata.cell_weight() * l;
        }
        let rel = (e - std::f32::consts::PI * l).abs() / (std::f32::consts::PI * l);
        prop_assert!(rel < strata.len() as f32 * f32::EPSILON, "{rel}");
    }
}
