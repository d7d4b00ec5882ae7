//! The input ([`TriangleMesh`]) and its validation (typed errors for malformed meshes, bad
//! triangles dropped and counted in a [`BuildReport`]), and the per-triangle view that queries
//! hand back ([`Triangle`]).

use std::borrow::Cow;

use glam::{DVec3, Vec3};

use crate::GeometryError;

/// A triangle mesh in world space (or, as a prototype of
/// [`Geometry::build_instanced`](crate::Geometry::build_instanced), in its object space): the
/// input of [`Geometry::build`](crate::Geometry::build).
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
    /// Unique triangles kept: the world meshes' (ids `0..kept` without instances) and the
    /// prototypes' ([`Geometry::unique_triangle_count`](crate::Geometry::unique_triangle_count)).
    pub kept: usize,
    /// Triangles dropped because their area is exactly zero (collinear or repeated vertices).
    pub dropped_degenerate: usize,
    /// Triangles dropped because a vertex coordinate is NaN or infinite.
    pub dropped_non_finite: usize,
    /// Instances dropped because their transform is not finite or not invertible, or their
    /// prototype kept no triangle ([`Geometry::build_instanced`](crate::Geometry::build_instanced)).
    pub dropped_instances: usize,
}

/// Checks a mesh's indices and array lengths.
pub(crate) fn validate_mesh(m: usize, mesh: &TriangleMesh) -> Result<(), GeometryError> {
    if let Some(normals) = &mesh.normals
        && normals.len() != mesh.positions.len()
    {
        return Err(GeometryError::NormalCountMismatch {
            mesh: m,
            normals: normals.len(),
            positions: mesh.positions.len(),
        });
    }
    if mesh.material_ids.len() != mesh.indices.len() {
        return Err(GeometryError::MaterialCountMismatch {
            mesh: m,
            material_ids: mesh.material_ids.len(),
            triangles: mesh.indices.len(),
        });
    }
    for (t, idx) in mesh.indices.iter().enumerate() {
        if let Some(&bad) = idx.iter().find(|&&i| i as usize >= mesh.positions.len()) {
            return Err(GeometryError::IndexOutOfRange {
                mesh: m,
                triangle: t,
                index: bad,
                vertex_count: mesh.positions.len(),
            });
        }
    }
    Ok(())
}

/// Drops (and counts) the triangles with a non-finite coordinate or zero area, keeping the
/// others in order. A borrowed mesh is copied only if it loses a triangle.
pub(crate) fn drop_bad_triangles(mesh: &mut Cow<'_, TriangleMesh>, report: &mut BuildReport) {
    let n = mesh.indices.len();
    let mut kept = 0;
    for t in 0..n {
        let idx = mesh.indices[t];
        let p = idx.map(|i| mesh.positions[i as usize]);
        // `Triangle::is_kept` is the one rule: callers that keep per-triangle data beside the
        // meshes (texture coordinates) map ids with it.
        if !Triangle::is_kept(&p) {
            if p.iter().all(|v| v.is_finite()) {
                report.dropped_degenerate += 1;
            } else {
                report.dropped_non_finite += 1;
            }
            continue;
        }
        if kept != t {
            let m = mesh.to_mut();
            m.indices[kept] = idx;
            m.material_ids[kept] = m.material_ids[t];
        }
        kept += 1;
    }
    if kept != n {
        let m = mesh.to_mut();
        m.indices.truncate(kept);
        m.material_ids.truncate(kept);
        m.indices.shrink_to_fit();
        m.material_ids.shrink_to_fit();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_meshes::quad;
    use crate::{Geometry, GeometryError};

    #[test]
    fn empty_input_is_an_error_not_a_panic() {
        let err = Geometry::build(&[]).err();
        assert_eq!(
            err,
            Some(GeometryError::EmptyScene {
                dropped_degenerate: 0,
                dropped_non_finite: 0
            })
        );
        let err = Geometry::build(&[TriangleMesh::default()]).err();
        assert!(matches!(err, Some(GeometryError::EmptyScene { .. })));
    }

    #[test]
    fn degenerate_and_non_finite_triangles_are_dropped_and_counted() {
        let mut m = quad(0.0, 3);
        m.positions.extend([
            Vec3::new(f32::NAN, 0.0, 0.0),
            Vec3::new(0.0, f32::INFINITY, 0.0),
            Vec3::new(2.0, 2.0, 0.0), // collinear with vertices 0 and 2
        ]);
        m.indices.extend([
            [0, 1, 4], // NaN
            [5, 1, 2], // infinite
            [0, 2, 6], // collinear: zero area
            [1, 1, 2], // repeated vertex: zero area
            [4, 5, 4], // non-finite and degenerate: counted once, as non-finite
        ]);
        m.material_ids.extend([3; 5]);
        let g = Geometry::build(&[m]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            *g.report(),
            BuildReport {
                kept: 2,
                dropped_degenerate: 2,
                dropped_non_finite: 3,
                dropped_instances: 0
            }
        );
        assert_eq!(g.bounds(), (Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0)));
        // Ids number the kept triangles in input order.
        assert_eq!(
            g.triangle(1).p,
            [Vec3::ZERO, Vec3::ONE.with_z(0.0), Vec3::Y]
        );
        assert!(g.get_triangle(2).is_none());
    }

    #[test]
    fn all_dropped_is_an_error_with_the_counts() {
        let m = TriangleMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(2.0, 0.0, 0.0), Vec3::NAN],
            indices: vec![[0, 1, 2], [0, 1, 3]],
            normals: None,
            material_ids: vec![0, 0],
        };
        let err = Geometry::build(&[m]).err();
        assert_eq!(
            err,
            Some(GeometryError::EmptyScene {
                dropped_degenerate: 1,
                dropped_non_finite: 1
            })
        );
        assert_eq!(
            err.map(|e| e.to_string()).unwrap_or_default(),
            "no triangles left after dropping 1 degenerate and 1 non-finite"
        );
    }

    #[test]
    fn malformed_meshes_are_typed_errors_naming_mesh_and_triangle() {
        let mut bad_index = quad(0.0, 0);
        bad_index.indices[1] = [0, 2, 4];
        let err = Geometry::build(&[quad(1.0, 0), bad_index]).err();
        assert_eq!(
            err,
            Some(GeometryError::IndexOutOfRange {
                mesh: 1,
                triangle: 1,
                index: 4,
                vertex_count: 4
            })
        );
        assert!(
            err.map(|e| e.to_string())
                .unwrap_or_default()
                .starts_with("mesh 1, triangle 1: vertex index 4 is out of range")
        );

        let mut bad_normals = quad(0.0, 0);
        bad_normals.normals = Some(vec![Vec3::Z; 3]);
        assert_eq!(
            Geometry::build(&[bad_normals]).err(),
            Some(GeometryError::NormalCountMismatch {
                mesh: 0,
                normals: 3,
                positions: 4
            })
        );

        let mut bad_materials = quad(0.0, 0);
        bad_materials.material_ids.push(1);
        assert_eq!(
            Geometry::build(&[bad_materials]).err(),
            Some(GeometryError::MaterialCountMismatch {
                mesh: 0,
                material_ids: 3,
                triangles: 2
            })
        );
    }
}
