//! Primitives drawn more than once, kept once: which draws share a primitive's data
//! ([`PrimitiveKey`]), and their prototype meshes and placements ([`Prototypes`]).

use super::{Loader, MAX_COORDINATE, describe};
use crate::Material;
use crate::error::LoadError;
use glam::{DAffine3, Mat3, Mat4, Vec3};
use irr_geometry::{Instance, TriangleMesh};
use std::collections::HashMap;

/// What a primitive's triangles and per-vertex data are read from: two draws with the same key
/// (of one mesh by several nodes or instances, or of meshes that share their accessors) load the
/// same object-space data, so one prototype serves both. The texture sets and the normal
/// texture's set come from the draw's material, which decides which attributes are read.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub(super) struct PrimitiveKey {
    mode: u32,
    positions: usize,
    indices: Option<usize>,
    normals: Option<usize>,
    colours: Option<usize>,
    tangents: Option<usize>,
    /// Per texture set the material reads: the set and its accessor.
    tex_coords: Vec<(u32, Option<usize>)>,
    normal_set: Option<usize>,
}

impl PrimitiveKey {
    /// The key of a primitive drawn with a material reading texture sets `sets` (its normal
    /// texture set `normal_set`); `None` for one never kept as a prototype: one with morph
    /// targets (its weights are its mesh's) or without positions.
    pub(super) fn of(
        primitive: &gltf::Primitive<'_>,
        sets: &[u32],
        normal_set: Option<usize>,
    ) -> Option<PrimitiveKey> {
        if primitive.morph_targets().len() > 0 {
            return None;
        }
        let accessor = |s: gltf::Semantic| primitive.get(&s).map(|a| a.index());
        Some(PrimitiveKey {
            mode: primitive.mode().as_gl_enum(),
            positions: accessor(gltf::Semantic::Positions)?,
            indices: primitive.indices().map(|a| a.index()),
            normals: accessor(gltf::Semantic::Normals),
            colours: accessor(gltf::Semantic::Colors(0)),
            tangents: normal_set.and(accessor(gltf::Semantic::Tangents)),
            tex_coords: sets
                .iter()
                .map(|&s| (s, accessor(gltf::Semantic::TexCoords(s))))
                .collect(),
            normal_set,
        })
    }
}

/// Whether a draw's transform mirrors (a negative determinant): such a draw is copied into
/// world space, where the winding and the tangents' handedness are turned as for any mirrored
/// mesh, rather than placed.
pub(super) fn mirrors(world: &Mat4) -> bool {
    Mat3::from_mat4(*world).determinant() < 0.0
}

/// A primitive's material id (glTF's default material where it has none), the texture sets
/// that material reads, and which of them its normal texture reads.
pub(super) fn material_of(
    primitive: &gltf::Primitive<'_>,
    materials: &[Material],
    default_material: u32,
) -> (u32, Vec<u32>, Option<usize>) {
    let material_id = primitive
        .material()
        .index()
        .map_or(default_material, |i| i as u32);
    let material = materials.get(material_id as usize);
    let sets: Vec<u32> = material
        .map(|m| m.tex_coord_sets().collect())
        .unwrap_or_default();
    let normal_set = material
        .and_then(|m| m.normal_texture)
        .and_then(|t| sets.iter().position(|&s| s == t.tex_coord));
    (material_id, sets, normal_set)
}

/// The prototypes loaded so far, their per-triangle arrays (as `SceneData`'s), and the
/// placements.
#[derive(Default)]
pub(super) struct Prototypes {
    /// The prototype of each key, or `None` for a primitive irr does not render.
    of: HashMap<PrimitiveKey, Option<u32>>,
    pub meshes: Vec<TriangleMesh>,
    /// Each prototype's box in object space.
    bounds: Vec<(Vec3, Vec3)>,
    pub instances: Vec<Instance>,
    pub tex_coords: Vec<Vec<[glam::Vec2; 3]>>,
    pub colours: Vec<Vec<[Vec3; 3]>>,
    pub alphas: Vec<Vec<[f32; 3]>>,
    pub tangents: Vec<Vec<[glam::Vec4; 3]>>,
}

/// The box around a mesh's positions (an empty mesh's is inverted).
pub(super) fn bounds_of(mesh: &TriangleMesh) -> (Vec3, Vec3) {
    mesh.positions
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        })
}

/// The eight corners of a box.
pub(super) fn corners(lo: Vec3, hi: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|c| {
        Vec3::new(
            if c & 1 == 0 { lo.x } else { hi.x },
            if c & 2 == 0 { lo.y } else { hi.y },
            if c & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

impl Loader<'_> {
    /// Places the primitive of `key` (`draw`: its node, mesh and primitive) by `world` with
    /// material `material.0`, loading its prototype on its first draw (in object space, with
    /// the per-vertex data `material`'s sets ask for). Whether it was placed: `false` for a
    /// primitive irr does not render.
    pub(super) fn place(
        &mut self,
        prototypes: &mut Prototypes,
        key: PrimitiveKey,
        draw: (&gltf::Node<'_>, &gltf::Mesh<'_>, &gltf::Primitive<'_>),
        world: Mat4,
        material: (u32, &[u32], Option<usize>),
        buffers: &[Vec<u8>],
    ) -> Result<bool, LoadError> {
        let (node, mesh, primitive) = draw;
        let prototype = match prototypes.of.get(&key) {
            Some(&p) => p,
            None => {
                let loaded =
                    self.primitive(node, mesh, primitive, Mat4::IDENTITY, material, buffers)?;
                let p = loaded.map(|p| {
                    prototypes.bounds.push(bounds_of(&p.mesh));
                    prototypes.meshes.push(p.mesh);
                    prototypes.tex_coords.push(p.tex_coords);
                    prototypes.colours.push(p.colours);
                    prototypes.alphas.push(p.alphas);
                    prototypes.tangents.push(p.tangents);
                    (prototypes.meshes.len() - 1) as u32
                });
                prototypes.of.insert(key, p);
                p
            }
        };
        let Some(prototype) = prototype else {
            return Ok(false);
        };
        // The placed box's corners bound every placed vertex: the limit the copies would have
        // been held to, vertex by vertex.
        let (lo, hi) = prototypes.bounds[prototype as usize];
        let beyond = corners(lo, hi).iter().any(|&c| {
            let w = world.transform_point3(c);
            !w.is_finite() || w.abs().max_element() > MAX_COORDINATE
        });
        if beyond {
            return Err(self.err(format!(
                "mesh {} primitive {} (node {}): a vertex lies beyond ±{MAX_COORDINATE:e} m in the world (irr's limit for finite ray arithmetic)",
                describe(mesh.index(), mesh.name()),
                primitive.index(),
                describe(node.index(), node.name())
            )));
        }
        self.budget
            .charge::<Instance>("the placements of repeated meshes", 1)
            .map_err(|e| self.err(e))?;
        prototypes.instances.push(Instance {
            prototype,
            to_world: DAffine3::from_mat4(world.as_dmat4()),
            material_id: Some(material.0),
        });
        Ok(true)
    }
}
