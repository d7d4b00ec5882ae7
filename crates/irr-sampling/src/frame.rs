//! An orthonormal basis around a unit vector.

use glam::Vec3;

/// A right-handed orthonormal basis (`s`, `t`, `n`) with `n` the given normal.
///
/// Built with the branch-free construction of Duff et al., "Building an Orthonormal Basis,
/// Revisited" (JCGT 6(1), 2017), listing 3: it is continuous everywhere except across the plane
/// n.z = 0 where `copysign` flips, and exact to a few ulps for every unit `n` (no division by a
/// quantity near zero, unlike Frisvad's version at n.z ≈ −1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// First tangent.
    pub s: Vec3,
    /// Second tangent, `n × s`.
    pub t: Vec3,
    /// The normal (local +z).
    pub n: Vec3,
}

impl Frame {
    /// The frame whose local +z is `n`. `n` must be unit length (to a few ulps).
    #[inline]
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Self { s, t, n }
    }

    /// Local coordinates (z along the normal) to world coordinates.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }

    /// World coordinates to local coordinates.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn unit() -> impl Strategy<Value = Vec3> {
        (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0)
            .prop_map(|(x, y, z)| Vec3::new(x, y, z))
            .prop_filter("non-degenerate", |v| v.length() > 1e-3)
            .prop_map(Vec3::normalize)
    }

    proptest! {
        /// Each dot product is a sum of three products of unit-size numbers, each with error
        /// ≤ a few ulps (2⁻²³ ≈ 1.2e-7); 1e-5 bounds the error with a wide margin.
        #[test]
        fn orthonormal_and_right_handed(n in unit()) {
            let f = Frame::from_normal(n);
            prop_assert!((f.s.length() - 1.0).abs() < 1e-5);
            prop_assert!((f.t.length() - 1.0).abs() < 1e-5);
            prop_assert!(f.s.dot(f.t).abs() < 1e-5);
            prop_assert!(f.s.dot(f.n).abs() < 1e-5);
            prop_assert!(f.t.dot(f.n).abs() < 1e-5);
            prop_assert!((f.s.cross(f.t) - f.n).length() < 1e-5);
        }

        #[test]
        fn local_world_round_trip(n in unit(), v in unit()) {
            let f = Frame::from_normal(n);
            prop_assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
            prop_assert!((f.to_local(n) - Vec3::Z).length() < 1e-5);
        }
    }

    #[test]
    fn poles_are_exact() {
        for n in [Vec3::Z, -Vec3::Z, Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y] {
            let f = Frame::from_normal(n);
            assert!((f.s.cross(f.t) - n).length() < 1e-6, "{n}");
        }
    }
}
