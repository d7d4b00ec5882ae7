//! The input ([`TriangleMesh`]), the per-triangle view that queries hand back ([`Triangle`]), and
//! the count of what the build dropped ([`BuildReport`]).

use glam::{DVec3, Vec3};

/// A triangle mesh in world space: the input of [`Geometry::build`](crate::Geometry::build).
///
/// Several meshes can be built into one [`Geometry`](crate::Geometry); triangle ids then run over
/// all kept triangles, mesh after mesh, in input order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriangleMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// One entry per triangle: three indices into `positions`. The winding
    /// `(p1 − p0) × (p2 − p0)` gives the geometric normal.
    pub indices: Vec<[u32; 3]>,
    /// Optional per-vertex shading normals, one per position. They need not be unit length;
    /// a normal that interpolates to zero or to a non-finite vector falls back to the geometric
    /// normal.
    pub normals: Option<Vec<Vec3>>,
    /// One material id per triangle.
    pub material_ids: Vec<u32>,
}

/// One kept triangle, as [`Geometry::triangle`](crate::Geometry::triangle) returns it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Triangle {
    /// The vertices, in input order (the winding defines the geometric normal).
    pub p: [Vec3; 3],
    /// The material id given for this triangle.
    pub material_id: u32,
}

impl Triangle {
    /// Whether [`Geometry::build`](crate::Geometry::build) keeps a triangle with these
    /// vertices: every coordinate finite and a non-zero area. A caller that keeps its own
    /// per-triangle data (texture coordinates, say) walks its input with this to learn each
    /// kept triangle's id: ids run over the kept triangles, mesh after mesh, in input order.
    #[must_use]
    pub fn is_kept(p: &[Vec3; 3]) -> bool {
        p.iter().all(|v| v.is_finite()) && cross_f64(*p) != DVec3::ZERO
    }

    /// The point with barycentric coordinates `(1 − b1 − b2, b1, b2)`, evaluated as
    /// `p0 + b1·(p1 − p0) + b2·(p2 − p0)` in `f64` and rounded once to `f32`.
    ///
    /// Error: every component is within `2⁻²⁴·|p_i| + 2⁻⁴⁹·max_k |p_k|` of the exact point of the
    /// triangle's plane at those barycentrics (half an ulp from the final rounding, plus four
    /// `f64` roundings of terms no larger than the largest vertex coordinate). Because the exact
    /// point lies *on the plane* for any `(b1, b2)`, errors in the barycentrics themselves only
    /// slide the point along the surface; this is what lets
    /// [`offset_ray_origin`](crate::offset_ray_origin) use an offset of a few ulps of `p`.
    #[must_use]
    pub fn point(&self, b1: f32, b2: f32) -> Vec3 {
        let p0 = self.p[0].as_dvec3();
        let e1 = self.p[1].as_dvec3() - p0;
        let e2 = self.p[2].as_dvec3() - p0;
        (p0 + e1 * f64::from(b1) + e2 * f64::from(b2)).as_vec3()
    }

    /// The unit geometric normal, normalised `(p1 − p0) × (p2 − p0)`, computed in `f64` so that it
    /// is accurate for triangles of any size (an `f32` cross product of edges of 1e-20 would
    /// underflow). Zero for a triangle of zero area (which `Geometry` never keeps).
    #[must_use]
    pub fn normal(&self) -> Vec3 {
        cross_f64(self.p).normalize_or_zero().as_vec3()
    }

    /// The area, computed in `f64`.
    #[must_use]
    pub fn area(&self) -> f32 {
        (0.5 * cross_f64(self.p).length()) as f32
    }
}

/// `(p1 − p0) × (p2 − p0)` in `f64`. The differences of `f32` values are exact in `f64` when the
/// exponents differ by at most 29, and the products of two such differences (≤ 50 significant
/// bits) are exact, so the cross product is exactly zero exactly when the vertices are collinear
/// (up to one final rounding per component, which cannot turn a non-zero value into zero).
pub(crate) fn cross_f64(p: [Vec3; 3]) -> DVec3 {
    let p0 = p[0].as_dvec3();
    (p[1].as_dvec3() - p0).cross(p[2].as_dvec3() - p0)
}

/// What [`Geometry::build`](crate::Geometry::build) kept and dropped, so a caller can warn.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BuildReport {
    /// Triangles kept (ids `0..kept`).
    pub kept: usize,
    /// Triangles dropped because their area is exactly zero (collinear or repeated vertices).
    pub dropped_degenerate: usize,
    /// Triangles dropped because a vertex coordinate is NaN or infinite.
    pub dropped_non_finite: usize,
}
