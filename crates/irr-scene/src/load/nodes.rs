//! The node hierarchy, its transforms, and cameras.

use super::{Loader, describe};
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
