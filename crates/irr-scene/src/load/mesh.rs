//! Triangle primitives: positions, indices by topology, normals, texture coordinates, vertex
//! colours.

use super::{Loader, MAX_COORDINATE, describe, plural};
use crate::accessor::{Quantized, read_attribute, read_colours, read_indices};
use crate::error::LoadError;
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
    /// Whether the file uses `KHR_mesh_quantization`, whose integer attribute types irr then
    /// reads too.
    fn quantization(&self) -> bool {
        self.document
            .extensions_used()
            .any(|e| e == "KHR_mesh_quantization")
    }

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
    ) -> Result<Option<Primitive>, LoadError> {
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
        let local = read_attribute::<3>(
            &format!("{what} POSITION accessor {}", positions_accessor.index()),
            &positions_accessor,
            (Quantized::Position, self.quantization()),
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
        // The file's copy is freed: the tally counts what the loader holds.
        self.budget.refund::<[f32; 3]>(local.len());
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
        self.budget.refund::<u32>(indices.len());
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
                let local = read_attribute::<3>(
                    &format!("{what} NORMAL accessor {}", acc.index()),
                    &acc,
                    (Quantized::Normal, self.quantization()),
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
                self.budget.refund::<[f32; 3]>(local.len());
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
    /// part; its handedness flips with a mirroring transform), or, without it (or without
    /// `NORMAL`, as glTF requires), MikkTSpace's (glTF 2.0 §3.7.2.1: "client implementations
    /// SHOULD calculate tangents using default MikkTSpace algorithms"), computed in world space.
    /// A corner MikkTSpace gives no tangent (degenerate texture coordinates with no neighbour
    /// to borrow from), and every corner of a primitive with a vertex shared by more than
    /// [`MAX_MIKKTSPACE_FAN`] triangles, gets its triangle's own tangent. Triangles whose
    /// vertex normals face against their winding get their frame turned with the normal.
    fn tangents(
        &mut self,
        what: &str,
        primitive: &gltf::Primitive<'_>,
        mesh: &TriangleMesh,
        uv: impl Fn(usize) -> [Vec2; 3],
        linear: Mat3,
        buffers: &[Vec<u8>],
    ) -> Result<Vec<[Vec4; 3]>, LoadError> {
        let count = mesh.indices.len();
        let mut out = self
            .budget
            .vec::<[Vec4; 3]>(&format!("{what} tangents"), count)
            .map_err(|e| self.err(e))?;
        // glTF 2.0 §3.7.2.1: without NORMAL, a primitive's TANGENT must be ignored.
        let file_tangents = primitive
            .get(&gltf::Semantic::Tangents)
            .filter(|_| mesh.normals.is_some());
        if mesh.normals.is_none() && primitive.get(&gltf::Semantic::Tangents).is_some() {
            self.warnings.add("tangents-without-normals", 1, |n| {
                format!(
                    "{} TANGENT without NORMAL: ignored, as glTF requires (MikkTSpace's are used)",
                    plural(n, "primitive has", "primitives have")
                )
            });
        }
        if let Some(acc) = file_tangents {
            let label = format!("{what} TANGENT accessor {}", acc.index());
            let local = read_attribute::<4>(
                &label,
                &acc,
                (Quantized::Tangent, self.quantization()),
                buffers,
                &mut self.budget,
            )
            .map_err(|e| self.err(e))?;
            let n = mesh.positions.len();
            if local.len() != n {
                return Err(self.err(format!(
                    "{what}: TANGENT has {} elements but POSITION has {n}",
                    local.len()
                )));
            }
            self.budget
                .charge::<Vec4>(&format!("{what} TANGENT in world space"), n)
                .map_err(|e| self.err(e))?;
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
                return Ok(self.against_flipped_normals(mesh, out));
            }
            self.warnings.add("bad-tangents", 1, |n| {
                format!(
                    "{} zero-length or non-finite tangents: MikkTSpace's are used instead",
                    plural(n, "primitive has", "primitives have")
                )
            });
        }
        let faces = MikkFaces {
            mesh,
            uv: &uv,
            out: Vec::new(),
        };
        self.budget
            .charge::<[u32; 3]>(&format!("{what} shared corners"), count.saturating_mul(3))
            .map_err(|e| self.err(e))?;
        let widest = faces.widest_fan();
        if widest > MAX_MIKKTSPACE_FAN {
            // MikkTSpace groups a vertex's triangles by recursion, as deep as the fan: a file
            // could make it overflow the stack. Each triangle's own tangent instead.
            self.warnings.add("tangent-fan", 1, |n| {
                format!(
                    "{} a vertex shared by more than {MAX_MIKKTSPACE_FAN} triangles: per-triangle tangents instead of MikkTSpace's",
                    plural(n, "primitive has", "primitives have")
                )
            });
            out.extend((0..count).map(|t| faces.triangle_tangents(t)));
            return Ok(self.against_flipped_normals(mesh, out));
        }
        // MikkTSpace's own arrays, a few hundred bytes per corner, and its answers.
        self.budget
            .charge::<u8>(
                &format!("{what} MikkTSpace"),
                count.saturating_mul(3 * MIKKTSPACE_BYTES_PER_CORNER),
            )
            .map_err(|e| self.err(e))?;
        let mut faces = MikkFaces {
            out: vec![[None; 3]; count],
            ..faces
        };
        // The error type has no values: generation cannot fail.
        let _ = bevy_mikktspace::generate_tangents(&mut faces);
        for (t, corners) in faces.out.iter().enumerate() {
            let fallback = faces.triangle_tangents(t);
            out.push(std::array::from_fn(|k| corners[k].unwrap_or(fallback[k])));
        }
        Ok(self.against_flipped_normals(mesh, out))
    }

    /// `tangents` with those of triangles whose vertex normals face against their winding
    /// negated (xyz and w): irr-geometry turns such a normal to the winding's side, and the
    /// frame (t, w·(n × t), n) must turn with it as a whole, which negating t and w does.
    fn against_flipped_normals(
        &self,
        mesh: &TriangleMesh,
        mut tangents: Vec<[Vec4; 3]>,
    ) -> Vec<[Vec4; 3]> {
        let Some(normals) = &mesh.normals else {
            return tangents;
        };
        for (t, corners) in mesh.indices.iter().zip(tangents.iter_mut()) {
            let p = t.map(|i| mesh.positions.get(i as usize).copied().unwrap_or_default());
            let n = t.map(|i| normals.get(i as usize).copied().unwrap_or_default());
            let winding = (p[1] - p[0]).cross(p[2] - p[0]);
            if (n[0] + n[1] + n[2]).dot(winding) < 0.0 {
                for c in corners.iter_mut() {
                    *c = -*c;
                }
            }
        }
        tangents
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
    ) -> Result<ColoursAndAlphas, LoadError> {
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
    ) -> Result<Vec<[Vec2; 3]>, LoadError> {
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
            let quantization = self.quantization();
            let uv = read_attribute::<2>(
                &label,
                &acc,
                (Quantized::TexCoord, quantization),
                buffers,
                &mut self.budget,
            )
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

/// The most triangles around one vertex that MikkTSpace is given (its grouping recurses once
/// per triangle of a fan; 4096 levels take well under a thread's 2 MiB stack).
const MAX_MIKKTSPACE_FAN: usize = 4096;

/// What MikkTSpace allocates per triangle corner, rounded up (its welded vertex list, face
/// infos, groups and tangent spaces: about 200 bytes in bevy_mikktspace 1.0).
const MIKKTSPACE_BYTES_PER_CORNER: usize = 256;

impl<F: Fn(usize) -> [Vec2; 3]> MikkFaces<'_, F> {
    /// The most corners that share one position (an upper bound on the triangles around any
    /// vertex MikkTSpace welds).
    fn widest_fan(&self) -> usize {
        let mut keys: Vec<[u32; 3]> = (0..self.mesh.indices.len())
            .flat_map(|t| self.corners(t))
            // + 0.0 makes −0.0 +0.0, which MikkTSpace's welding takes for the same value.
            .map(|p| p.to_array().map(|c| (c + 0.0).to_bits()))
            .collect();
        keys.sort_unstable();
        keys.chunk_by(|a, b| a == b)
            .map(<[_]>::len)
            .max()
            .unwrap_or(0)
    }

    /// Triangle `t`'s own tangent at each corner: ∂p/∂u with the handedness of ∂p/∂v′ (v′ =
    /// 1 − v, as MikkTSpace is given), made orthogonal to each corner's normal; any tangent
    /// perpendicular to the normal where the texture coordinates are degenerate.
    fn triangle_tangents(&self, t: usize) -> [Vec4; 3] {
        let [p0, p1, p2] = self.corners(t);
        let [a, b, c] = (self.uv)(t).map(|uv| Vec2::new(uv.x, 1.0 - uv.y));
        let (e1, e2, d1, d2) = (p1 - p0, p2 - p0, b - a, c - a);
        let r = d1.x * d2.y - d2.x * d1.y;
        let dpdu = (e1 * d2.y - e2 * d1.y) / r;
        let dpdv = (e2 * d1.x - e1 * d2.x) / r;
        self.corner_normals(t).map(|n| {
            let n = n.try_normalize().unwrap_or(Vec3::Z);
            match (dpdu - n * n.dot(dpdu)).try_normalize() {
                Some(tangent) => {
                    let w = if n.cross(tangent).dot(dpdv) < 0.0 {
                        -1.0
                    } else {
                        1.0
                    };
                    tangent.extend(w)
                }
                None => n.any_orthonormal_vector().extend(1.0),
            }
        })
    }

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
