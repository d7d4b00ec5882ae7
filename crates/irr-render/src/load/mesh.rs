//! Triangle primitives: positions, indices by topology, normals, texture coordinates, vertex
//! colours.

use super::{Loader, MAX_COORDINATE, describe, plural};
use crate::accessor::{read_colours, read_indices, read_tex_coords, read_vec3};
use crate::error::RenderError;
use glam::{Mat3, Mat4, Vec2, Vec3};
use irr_geometry::TriangleMesh;

/// A primitive instance in world space, the texture coordinates of its triangles, and their
/// vertex colours (empty without `COLOR_0`).
type Primitive = (TriangleMesh, Vec<[Vec2; 3]>, Vec<[Vec3; 3]>);

impl Loader<'_> {
    /// One primitive instance in world space with material `material.0`, and the texture
    /// coordinates of its triangles for the sets `material.1` its material reads (see
    /// `SceneData::tex_coords`); `None` for a primitive irr does not render.
    pub(super) fn primitive(
        &mut self,
        node: &gltf::Node<'_>,
        mesh: &gltf::Mesh<'_>,
        primitive: &gltf::Primitive<'_>,
        world: Mat4,
        material: (u32, &[u32]),
        buffers: &[Vec<u8>],
    ) -> Result<Option<Primitive>, RenderError> {
        let (material_id, sets) = material;
        use gltf::mesh::Mode;
        let what = format!(
            "mesh {} primitive {} (node {})",
            describe(mesh.index(), mesh.name()),
            primitive.index(),
            describe(node.index(), node.name())
        );
        let mode = primitive.mode();
        if matches!(
            mode,
            Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip
        ) {
            self.warnings.add("non-triangle", 1, |n| {
                format!(
                    "{} of points or lines ignored (irr renders triangles)",
                    plural(n, "primitive", "primitives")
                )
            });
            return Ok(None);
        }
        let targets = primitive.morph_targets().len();
        if targets > 0 {
            self.warnings.add("morph-targets", 1, |n| {
                format!(
                    "{} morph targets: ignored (irr uses the base positions)",
                    plural(n, "primitive has", "primitives have")
                )
            });
        }
        let extra_colours = primitive
            .attributes()
            .filter(|(s, _)| matches!(s, gltf::Semantic::Colors(k) if *k > 0))
            .count();
        self.warnings.add("vertex-colours", extra_colours, |n| {
            format!(
                "{} COLOR_n with n ≥ 1 ignored (COLOR_0 multiplies the base colour; the others have no meaning in glTF's material)",
                plural(n, "vertex colour attribute", "vertex colour attributes")
            )
        });
        let positions_accessor = primitive
            .get(&gltf::Semantic::Positions)
            .ok_or_else(|| self.err(format!("{what} has no POSITION attribute")))?;
        let local = read_vec3(
            &format!("{what} POSITION accessor {}", positions_accessor.index()),
            &positions_accessor,
            buffers,
            &mut self.budget,
        )
        .map_err(|e| self.err(e))?;
        // Messages name the vertex, never its coordinates: they are bytes of a file.
        let mut positions = self
            .budget
            .vec::<Vec3>(&format!("{what} POSITION"), local.len())
            .map_err(|e| self.err(e))?;
        for (i, p) in local.iter().enumerate() {
            let p = Vec3::from_array(*p);
            if !p.is_finite() {
                return Err(self.err(format!("{what}: vertex {i} has a non-finite coordinate")));
            }
            let w = world.transform_point3(p);
            if !w.is_finite() || w.abs().max_element() > MAX_COORDINATE {
                return Err(self.err(format!(
                    "{what}: vertex {i} lies beyond ±{MAX_COORDINATE:e} m in the world (irr's limit for finite ray arithmetic)"
                )));
            }
            positions.push(w);
        }
        drop(local);
        let n = positions.len();
        let indices: Vec<u32> = match primitive.indices() {
            Some(acc) => {
                let idx = read_indices(
                    &format!("{what} indices accessor {}", acc.index()),
                    &acc,
                    buffers,
                    &mut self.budget,
                )
                .map_err(|e| self.err(e))?;
                // The message names the entry, not its value (bytes of a file).
                if let Some(k) = idx.iter().position(|&v| v as usize >= n) {
                    return Err(self.err(format!(
                        "{what}: index entry {k} is out of range: the primitive has {n} vertices"
                    )));
                }
                idx
            }
            None => {
                let n32 = u32::try_from(n).map_err(|_| {
                    self.err(format!(
                        "{what} has {n} vertices and no indices; irr's triangle indices are 32-bit"
                    ))
                })?;
                let mut idx = self
                    .budget
                    .vec::<u32>(&format!("{what} implicit indices"), n)
                    .map_err(|e| self.err(e))?;
                idx.extend(0..n32);
                idx
            }
        };
        let triangle_count = triangle_count(mode, indices.len());
        // Each triangle also gets a material id below.
        self.budget
            .charge::<([u32; 3], u32)>(&format!("{what} triangles"), triangle_count)
            .map_err(|e| self.err(e))?;
        let (mut triangles, leftover) = assemble(mode, &indices);
        drop(indices);
        if leftover > 0 {
            self.warnings.add("leftover-indices", leftover, |n| {
                format!(
                    "{} left over after the last whole triangle ignored",
                    plural(n, "index", "indices")
                )
            });
        }
        let linear = Mat3::from_mat4(world);
        // A transform with negative determinant mirrors the mesh, which turns counter-clockwise
        // windings clockwise; swapping two vertices keeps the front face where the file meant.
        if linear.determinant() < 0.0 {
            for t in &mut triangles {
                t.swap(1, 2);
            }
        }
        let normals = match primitive.get(&gltf::Semantic::Normals) {
            None => None,
            Some(acc) => {
                let local = read_vec3(
                    &format!("{what} NORMAL accessor {}", acc.index()),
                    &acc,
                    buffers,
                    &mut self.budget,
                )
                .map_err(|e| self.err(e))?;
                self.budget
                    .charge::<Vec3>(&format!("{what} NORMAL"), local.len())
                    .map_err(|e| self.err(e))?;
                if local.len() != n {
                    return Err(self.err(format!(
                        "{what}: NORMAL has {} elements but POSITION has {n}",
                        local.len()
                    )));
                }
                // Normals transform by the inverse transpose of the linear part.
                let normal_matrix = linear.inverse().transpose();
                let world_normals: Option<Vec<Vec3>> = local
                    .iter()
                    .map(|v| (normal_matrix * Vec3::from_array(*v)).try_normalize())
                    .collect();
                if world_normals.is_none() {
                    self.warnings.add("bad-normals", 1, |n| {
                        format!(
                            "{} zero-length or non-finite normals: ignored, the geometric normal is used",
                            plural(n, "primitive has", "primitives have")
                        )
                    });
                }
                world_normals
            }
        };
        let tex_coords = self.tex_coords(&what, primitive, sets, n, &triangles, buffers)?;
        let colours = self.colours(&what, primitive, n, &triangles, buffers)?;
        let count = triangles.len();
        Ok(Some((
            TriangleMesh {
                positions,
                indices: triangles,
                normals,
                material_ids: vec![material_id; count],
            },
            tex_coords,
            colours,
        )))
    }

    /// The `COLOR_0` colours at the vertices of each of `triangles` (vertex indices below `n`,
    /// the vertex count), or none without the attribute. Float colours outside [0, 1] are
    /// clamped with a warning (the base colour they multiply must stay in [0, 1]); a non-finite
    /// one is refused.
    fn colours(
        &mut self,
        what: &str,
        primitive: &gltf::Primitive<'_>,
        n: usize,
        triangles: &[[u32; 3]],
        buffers: &[Vec<u8>],
    ) -> Result<Vec<[Vec3; 3]>, RenderError> {
        let Some(acc) = primitive.get(&gltf::Semantic::Colors(0)) else {
            return Ok(Vec::new());
        };
        let label = format!("{what} COLOR_0 accessor {}", acc.index());
        let colours =
            read_colours(&label, &acc, buffers, &mut self.budget).map_err(|e| self.err(e))?;
        if colours.len() != n {
            return Err(self.err(format!(
                "{what}: COLOR_0 has {} elements but POSITION has {n}",
                colours.len()
            )));
        }
        // Messages name the element, never its value (bytes of a file).
        if let Some(k) = colours
            .iter()
            .position(|c| !c.iter().all(|v| v.is_finite()))
        {
            return Err(self.err(format!("{what}: COLOR_0 element {k} is not finite")));
        }
        let outside = colours
            .iter()
            .filter(|c| c.iter().any(|v| !(0.0..=1.0).contains(v)))
            .count();
        self.warnings.add("colour-clamped", outside, |n| {
            format!(
                "{} outside [0, 1]: clamped",
                plural(n, "vertex colour", "vertex colours")
            )
        });
        let mut out = self
            .budget
            .vec::<[Vec3; 3]>(&format!("{what} vertex colours"), triangles.len())
            .map_err(|e| self.err(e))?;
        // The indices were checked against the vertex count, which `colours` matches.
        out.extend(triangles.iter().map(|t| {
            t.map(|i| Vec3::from_array(colours[i as usize]).clamp(Vec3::ZERO, Vec3::ONE))
        }));
        Ok(out)
    }

    /// The texture coordinates of each of `triangles` (vertex indices below `n`, the vertex
    /// count) for each of `sets`, triangle after triangle. A set the primitive lacks reads as
    /// (0, 0) at every vertex, as OpenGL reads a missing vertex attribute, with a warning.
    fn tex_coords(
        &mut self,
        what: &str,
        primitive: &gltf::Primitive<'_>,
        sets: &[u32],
        n: usize,
        triangles: &[[u32; 3]],
        buffers: &[Vec<u8>],
    ) -> Result<Vec<[Vec2; 3]>, RenderError> {
        if sets.is_empty() {
            return Ok(Vec::new());
        }
        let mut per_set = Vec::with_capacity(sets.len());
        for &set in sets {
            let Some(acc) = primitive.get(&gltf::Semantic::TexCoords(set)) else {
                self.warnings.add("missing-texcoord", 1, |n| {
                    format!(
                        "{} no TEXCOORD_n for the texture their material reads: read at (0, 0)",
                        plural(n, "primitive has", "primitives have")
                    )
                });
                per_set.push(None);
                continue;
            };
            let label = format!("{what} TEXCOORD_{set} accessor {}", acc.index());
            let uv = read_tex_coords(&label, &acc, buffers, &mut self.budget)
                .map_err(|e| self.err(e))?;
            if uv.len() != n {
                return Err(self.err(format!(
                    "{what}: TEXCOORD_{set} has {} elements but POSITION has {n}",
                    uv.len()
                )));
            }
            // Messages name the element, never its value (bytes of a file).
            if let Some(k) = uv.iter().position(|c| !c.iter().all(|v| v.is_finite())) {
                return Err(self.err(format!("{what}: TEXCOORD_{set} element {k} is not finite")));
            }
            per_set.push(Some(uv));
        }
        let mut out = self
            .budget
            .vec::<[Vec2; 3]>(
                &format!("{what} texture coordinates"),
                triangles.len().saturating_mul(sets.len()),
            )
            .map_err(|e| self.err(e))?;
        for t in triangles {
            for uv in &per_set {
                out.push(match uv {
                    // The indices were checked against the vertex count, which `uv` matches.
                    Some(uv) => t.map(|i| Vec2::from_array(uv[i as usize])),
                    None => [Vec2::ZERO; 3],
                });
            }
        }
        Ok(out)
    }
}

/// The number of triangles [`assemble`] makes from `indices` indices.
fn triangle_count(mode: gltf::mesh::Mode, indices: usize) -> usize {
    use gltf::mesh::Mode;
    match mode {
        Mode::TriangleStrip | Mode::TriangleFan => indices.saturating_sub(2),
        _ => indices / 3,
    }
}

/// Triangles from a primitive's index list (glTF 2.0 §3.7.2.1 "Topology Types"), and the number
/// of indices left over after the last whole triangle.
fn assemble(mode: gltf::mesh::Mode, idx: &[u32]) -> (Vec<[u32; 3]>, usize) {
    use gltf::mesh::Mode;
    match mode {
        Mode::TriangleStrip => {
            // Triangle i is (i, i+1, i+2) for even i and (i+1, i, i+2) for odd i, which keeps
            // every triangle's winding the same as the first one's.
            let tris = (0..idx.len().saturating_sub(2))
                .map(|i| {
                    if i % 2 == 0 {
                        [idx[i], idx[i + 1], idx[i + 2]]
                    } else {
                        [idx[i + 1], idx[i], idx[i + 2]]
                    }
                })
                .collect();
            (tris, 0)
        }
        Mode::TriangleFan => {
            // Triangle i is (i+1, i+2, 0).
            let tris = (0..idx.len().saturating_sub(2))
                .map(|i| [idx[i + 1], idx[i + 2], idx[0]])
                .collect();
            (tris, 0)
        }
        _ => {
            let tris = idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            (tris, idx.len() % 3)
        }
    }
}
