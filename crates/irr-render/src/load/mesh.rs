//! Triangle primitives: positions, indices by topology, normals, texture coordinates, vertex
//! colours.

use super::{Loader, MAX_COORDINATE, describe, plural};
use crate::accessor::{read_colours, read_indices, read_tex_coords, read_vec3, read_vec4};
use crate::error::RenderError;
use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
use irr_geometry::TriangleMesh;

/// The `COLOR_0` colours of a primitive's triangles, and their alphas (see
/// [`Primitive::alphas`]).
type ColoursAndAlphas = (Vec<[Vec3; 3]>, Vec<[f32; 3]>);

/// A primitive instance in world space and the per-vertex data of its triangles.
pub(super) struct Primitive {
    /// The triangles, in world space.
    pub mesh: TriangleMesh,
    /// The texture coordinates of each triangle, one triple per set its material reads.
    pub tex_coords: Vec<[Vec2; 3]>,
    /// The `COLOR_0` colours of each triangle (empty without them).
    pub colours: Vec<[Vec3; 3]>,
    /// The `COLOR_0` alphas of each triangle (empty without them, or if all are 1).
    pub alphas: Vec<[f32; 3]>,
    /// The world-space tangents of each triangle (empty unless the material has a normal
    /// texture).
    pub tangents: Vec<[Vec4; 3]>,
}

impl Loader<'_> {
    /// One primitive instance in world space with material `material.0`, the texture
    /// coordinates of its triangles for the sets `material.1` its material reads (see
    /// `SceneData::tex_coords`), and their tangents if the material has a normal texture,
    /// which reads entry `material.2` of those sets; `None` for a primitive irr does not
    /// render.
    pub(super) fn primitive(
        &mut self,
        node: &gltf::Node<'_>,
        mesh: &gltf::Mesh<'_>,
        primitive: &gltf::Primitive<'_>,
        world: Mat4,
        material: (u32, &[u32], Option<usize>),
        buffers: &[Vec<u8>],
    ) -> Result<Option<Primitive>, RenderError> {
        let (material_id, sets, normal_set) = material;
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
        let (colours, alphas) = self.colours(&what, primitive, n, &triangles, buffers)?;
        let count = triangles.len();
        let mesh = TriangleMesh {
            positions,
            indices: triangles,
            normals,
            material_ids: vec![material_id; count],
        };
        let tangents = match normal_set {
            None => Vec::new(),
            Some(slot) => {
                let uv = |t: usize| {
                    tex_coords
                        .get(t * sets.len() + slot)
                        .copied()
                        .unwrap_or_default()
                };
                self.tangents(&what, primitive, &mesh, uv, linear, buffers)?
            }
        };
        Ok(Some(Primitive {
            mesh,
            tex_coords,
            colours,
            alphas,
            tangents,
        }))
    }

    /// The world-space tangents at the vertices of each triangle of `mesh` (already in world
    /// space, windings as the geometry will have them), whose texture coordinates for the
    /// normal texture are `uv(t)`: the file's `TANGENT` turned by `linear` (the node's linear
    /// part; its handedness flips with a mirroring transform), or, without it, MikkTSpace's
    /// (glTF 2.0 §3.7.2.1: "client implementations SHOULD calculate tangents using default
    /// MikkTSpace algorithms"), computed in world space. Triangles MikkTSpace gives no tangent
    /// (degenerate texture coordinates with no neighbour to borrow from) get any tangent
    /// perpendicular to their normal.
    fn tangents(
        &mut self,
        what: &str,
        primitive: &gltf::Primitive<'_>,
        mesh: &TriangleMesh,
        uv: impl Fn(usize) -> [Vec2; 3],
        linear: Mat3,
        buffers: &[Vec<u8>],
    ) -> Result<Vec<[Vec4; 3]>, RenderError> {
        let count = mesh.indices.len();
        let mut out = self
            .budget
            .vec::<[Vec4; 3]>(&format!("{what} tangents"), count)
            .map_err(|e| self.err(e))?;
        if let Some(acc) = primitive.get(&gltf::Semantic::Tangents) {
            let label = format!("{what} TANGENT accessor {}", acc.index());
            let local =
                read_vec4(&label, &acc, buffers, &mut self.budget).map_err(|e| self.err(e))?;
            let n = mesh.positions.len();
            if local.len() != n {
                return Err(self.err(format!(
                    "{what}: TANGENT has {} elements but POSITION has {n}",
                    local.len()
                )));
            }
            let mirror = if linear.determinant() < 0.0 {
                -1.0
            } else {
                1.0
            };
            let world: Option<Vec<Vec4>> = local
                .iter()
                .map(|t| {
                    let t = Vec4::from_array(*t);
                    let xyz = (linear * t.truncate()).try_normalize()?;
                    let sign = if t.w < 0.0 { -mirror } else { mirror };
                    t.w.is_finite().then_some(xyz.extend(sign))
                })
                .collect();
            if let Some(world) = world {
                // The indices were checked against the vertex count, which `world` matches.
                out.extend(mesh.indices.iter().map(|t| t.map(|i| world[i as usize])));
                return Ok(out);
            }
            self.warnings.add("bad-tangents", 1, |n| {
                format!(
                    "{} zero-length or non-finite tangents: MikkTSpace's are used instead",
                    plural(n, "primitive has", "primitives have")
                )
            });
        }
        let mut faces = MikkFaces {
            mesh,
            uv: &uv,
            out: vec![[None; 3]; count],
        };
        // The error type has no values: generation cannot fail.
        let _ = bevy_mikktspace::generate_tangents(&mut faces);
        for (t, corners) in faces.out.iter().enumerate() {
            let normal = faces.corner_normals(t);
            out.push(std::array::from_fn(|k| {
                corners[k].unwrap_or_else(|| {
                    let n = normal[k].try_normalize().unwrap_or(Vec3::Z);
                    n.any_orthonormal_vector().extend(1.0)
                })
            }));
        }
        Ok(out)
    }

    /// The `COLOR_0` colours at the vertices of each of `triangles` (vertex indices below `n`,
    /// the vertex count), and their alphas where one is below 1; none without the attribute.
    /// Float colours outside [0, 1] are clamped with a warning (the base colour they multiply
    /// must stay in [0, 1]); a non-finite one is refused.
    fn colours(
        &mut self,
        what: &str,
        primitive: &gltf::Primitive<'_>,
        n: usize,
        triangles: &[[u32; 3]],
        buffers: &[Vec<u8>],
    ) -> Result<ColoursAndAlphas, RenderError> {
        let Some(acc) = primitive.get(&gltf::Semantic::Colors(0)) else {
            return Ok((Vec::new(), Vec::new()));
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
            t.map(|i| {
                let [r, g, b, _] = colours[i as usize];
                Vec3::new(r, g, b).clamp(Vec3::ZERO, Vec3::ONE)
            })
        }));
        // The alphas scale the coverage: kept only if some is below 1.
        let mut alphas = Vec::new();
        if colours.iter().any(|c| c[3] < 1.0) {
            alphas = self
                .budget
                .vec::<[f32; 3]>(&format!("{what} vertex alphas"), triangles.len())
                .map_err(|e| self.err(e))?;
            alphas.extend(
                triangles
                    .iter()
                    .map(|t| t.map(|i| colours[i as usize][3].clamp(0.0, 1.0))),
            );
        }
        Ok((out, alphas))
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

/// A mesh's triangles as MikkTSpace reads them (its positions and normals, the normal
/// texture's coordinates), and the tangents it writes, per triangle and corner.
struct MikkFaces<'a, F: Fn(usize) -> [Vec2; 3]> {
    mesh: &'a TriangleMesh,
    uv: &'a F,
    out: Vec<[Option<Vec4>; 3]>,
}

impl<F: Fn(usize) -> [Vec2; 3]> MikkFaces<'_, F> {
    /// The corners of triangle `t`.
    fn corners(&self, t: usize) -> [Vec3; 3] {
        // The loader checked every index against the positions.
        self.mesh.indices[t].map(|i| {
            self.mesh
                .positions
                .get(i as usize)
                .copied()
                .unwrap_or_default()
        })
    }

    /// The normals at the corners of triangle `t`: the mesh's, or its winding normal at each
    /// (glTF's flat normals for a primitive without `NORMAL`).
    fn corner_normals(&self, t: usize) -> [Vec3; 3] {
        match &self.mesh.normals {
            Some(n) => self.mesh.indices[t].map(|i| n.get(i as usize).copied().unwrap_or_default()),
            None => {
                let [a, b, c] = self.corners(t);
                [(b - a).cross(c - a).normalize_or_zero(); 3]
            }
        }
    }
}

impl<F: Fn(usize) -> [Vec2; 3]> bevy_mikktspace::Geometry for MikkFaces<'_, F> {
    fn num_faces(&self) -> usize {
        self.mesh.indices.len()
    }

    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }

    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.corners(face)[vert].to_array()
    }

    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        self.corner_normals(face)[vert].to_array()
    }

    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        // MikkTSpace takes v up from the image's bottom row (Blender's convention, whose
        // tangents a file's TANGENT carries); glTF's v runs down from the top row. With 1 − v
        // the bitangent points up the image, the +Y of glTF's normal texels.
        let uv = (self.uv)(face)[vert];
        [uv.x, 1.0 - uv.y]
    }

    fn set_tangent(
        &mut self,
        tangent_space: Option<bevy_mikktspace::TangentSpace>,
        face: usize,
        vert: usize,
    ) {
        let t = tangent_space.and_then(|s| {
            let e = Vec4::from_array(s.tangent_encoded());
            e.truncate().try_normalize().map(|xyz| xyz.extend(e.w))
        });
        if let Some(slot) = self.out.get_mut(face).and_then(|f| f.get_mut(vert)) {
            *slot = t;
        }
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
