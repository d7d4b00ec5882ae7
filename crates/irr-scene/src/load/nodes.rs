//! The node hierarchy, its transforms, `EXT_mesh_gpu_instancing`'s instances, and cameras.

use super::{Loader, describe};
use crate::accessor::{Buffers, read_vec3, read_vec4};
use crate::camera::Camera;
use crate::error::LoadError;
use glam::{Mat4, Quat, Vec3};

impl<'a> Loader<'a> {
    /// The nodes of the default scene that hold a mesh, a camera or a light, in depth-first
    /// order, each with its world transform.
    pub(super) fn walk_nodes(&mut self) -> Result<Vec<(gltf::Node<'a>, Mat4)>, LoadError> {
        let d: &'a gltf::Document = self.document;
        let roots: Vec<gltf::Node<'a>> = match d.default_scene().or_else(|| d.scenes().next()) {
            Some(scene) => scene.nodes().collect(),
            // No scene at all: every node that is nobody's child is a root.
            None => {
                let mut is_child = vec![false; d.nodes().len()];
                for n in d.nodes() {
                    for c in n.children() {
                        is_child[c.index()] = true;
                    }
                }
                d.nodes().filter(|n| !is_child[n.index()]).collect()
            }
        };
        let mut visited = vec![false; d.nodes().len()];
        // Only nodes with a mesh, a camera or a light are kept: the others matter only through
        // the transforms they pass on.
        let holds = |n: &gltf::Node<'_>| {
            n.mesh().is_some() || n.camera().is_some() || super::lights::light_index(d, n).is_some()
        };
        let kept = d.nodes().filter(|n| holds(n)).count();
        let mut out = self
            .budget
            .vec::<(gltf::Node<'a>, Mat4)>("the node hierarchy", kept)
            .map_err(|e| self.err(e))?;
        let mut stack: Vec<(gltf::Node<'a>, Mat4)> = roots
            .into_iter()
            .rev()
            .map(|n| (n, Mat4::IDENTITY))
            .collect();
        while let Some((node, parent)) = stack.pop() {
            let i = node.index();
            if std::mem::replace(&mut visited[i], true) {
                return Err(self.err(format!(
                    "node {} is reached twice: glTF's node hierarchy must be a set of disjoint trees (a node has at most one parent and no cycles)",
                    describe(i, node.name())
                )));
            }
            let world = parent * self.local_transform(&node)?;
            // Children in reverse, so the first child is visited first; the stack holds at most
            // one entry per node, as `visited` guarantees.
            let first = stack.len();
            stack.extend(node.children().map(|child| (child, world)));
            stack[first..].reverse();
            if holds(&node) {
                out.push((node, world));
            }
        }
        Ok(out)
    }

    /// The world transforms `node`'s mesh is drawn with: `world` alone, or with
    /// `EXT_mesh_gpu_instancing` one per instance, `world` × the instance's T·R·S (the
    /// extension applies the instance's transform first, then the node's).
    pub(super) fn instances(
        &mut self,
        node: &gltf::Node<'_>,
        world: Mat4,
        buffers: &Buffers,
    ) -> Result<Vec<Mat4>, LoadError> {
        let Some(ext) = node.extension_value("EXT_mesh_gpu_instancing") else {
            return Ok(vec![world]);
        };
        let what = format!(
            "node {}: EXT_mesh_gpu_instancing",
            describe(node.index(), node.name())
        );
        let accessor = |name: &str| -> Result<Option<gltf::Accessor<'a>>, LoadError> {
            let Some(index) = ext.get("attributes").and_then(|a| a.get(name)) else {
                return Ok(None);
            };
            index
                .as_u64()
                .and_then(|i| self.document.accessors().nth(usize::try_from(i).ok()?))
                .map(Some)
                .ok_or_else(|| self.err(format!("{what}: {name} {index} is no accessor")))
        };
        let (t, r, s) = (
            accessor("TRANSLATION")?,
            accessor("ROTATION")?,
            accessor("SCALE")?,
        );
        let count = [&t, &r, &s]
            .iter()
            .flat_map(|a| a.as_ref())
            .map(|a| a.count())
            .max();
        let Some(count) = count else {
            return Err(self.err(format!(
                "{what}: no TRANSLATION, ROTATION or SCALE attribute"
            )));
        };
        let vec3 = |loader: &mut Self, a: &Option<gltf::Accessor<'_>>, name: &str, default| match a
        {
            None => Ok(vec![default; count]),
            Some(a) => read_vec3(&format!("{what}: {name}"), a, buffers, &mut loader.budget)
                .map_err(|e| loader.err(e)),
        };
        let translations = vec3(self, &t, "TRANSLATION", [0.0; 3])?;
        let scales = vec3(self, &s, "SCALE", [1.0; 3])?;
        let rotations = match &r {
            None => vec![[0.0, 0.0, 0.0, 1.0]; count],
            Some(a) => read_vec4(&format!("{what}: ROTATION"), a, buffers, &mut self.budget)
                .map_err(|e| self.err(e))?,
        };
        if translations.len() != count || rotations.len() != count || scales.len() != count {
            return Err(self.err(format!(
                "{what}: its attributes' counts differ (they must all be {count})"
            )));
        }
        // The placements (each a transform here, then a record and its top-level nodes in the
        // geometry) must fit what is left of the memory limit: refused here, before any is
        // made. A mirroring instance is copied instead, and charged as it is loaded.
        let bytes = (count as u64).saturating_mul(
            (size_of::<Mat4>() + size_of::<irr_geometry::Instance>()) as u64
                + irr_geometry::BUILT_BYTES_PER_INSTANCE,
        );
        let limit = self.budget.limit();
        if bytes > limit.bytes.saturating_sub(self.budget.spent()) {
            return Err(self.err(format!(
                "{what}: {count} instances take {}, past the scene's memory limit of {limit}",
                crate::files::gib(bytes)
            )));
        }
        self.budget
            .charge::<Mat4>(&what, count)
            .map_err(|e| self.err(e))?;
        let mut out = Vec::with_capacity(count);
        for ((t, r), s) in translations.iter().zip(&rotations).zip(&scales) {
            let q = Quat::from_array(*r);
            let q = if q.length_squared() > 0.0 {
                q.normalize()
            } else {
                Quat::NAN
            };
            let m = world
                * Mat4::from_scale_rotation_translation(
                    Vec3::from_array(*s),
                    q,
                    Vec3::from_array(*t),
                );
            if !m.is_finite() {
                return Err(self.err(format!(
                    "{what}: an instance's transform is not finite (or its rotation is zero)"
                )));
            }
            out.push(m);
        }
        Ok(out)
    }

    pub(super) fn local_transform(&self, node: &gltf::Node<'_>) -> Result<Mat4, LoadError> {
        let m = match node.transform() {
            gltf::scene::Transform::Matrix { matrix } => Mat4::from_cols_array_2d(&matrix),
            gltf::scene::Transform::Decomposed {
                translation,
                rotation,
                scale,
            } => {
                let q = Quat::from_array(rotation);
                // glTF requires a unit quaternion; normalise small deviations, refuse zero.
                let q = if q.length_squared() > 0.0 {
                    q.normalize()
                } else {
                    Quat::NAN
                };
                Mat4::from_scale_rotation_translation(
                    Vec3::from_array(scale),
                    q,
                    Vec3::from_array(translation),
                )
            }
        };
        if !m.is_finite() {
            return Err(self.err(format!(
                "node {}: its transform is not finite (or its rotation quaternion is zero)",
                describe(node.index(), node.name())
            )));
        }
        Ok(m)
    }

    pub(super) fn camera(
        &self,
        node: &gltf::Node<'_>,
        world: Mat4,
        p: &gltf::camera::Perspective<'_>,
    ) -> Result<Camera, LoadError> {
        let yfov = p.yfov();
        let name = describe(node.index(), node.name());
        if !(yfov > 0.0 && yfov < std::f32::consts::PI) {
            return Err(self.err(format!(
                "camera of node {name}: yfov {yfov} rad is not in (0, π)"
            )));
        }
        let mut camera = Camera::from_node(world, yfov).ok_or_else(|| {
            self.err(format!(
                "camera of node {name}: its transform collapses the view direction"
            ))
        })?;
        camera.znear = p.znear().max(0.0);
        camera.zfar = p.zfar().filter(|&f| f > camera.znear && f.is_finite());
        camera.aspect_ratio_in_file = p.aspect_ratio();
        Ok(camera)
    }
}
