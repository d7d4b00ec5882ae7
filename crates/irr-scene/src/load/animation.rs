//! The file's animations, as far as they move cameras (module `animation` of the crate): the
//! channels that drive the translation, rotation or scale of a camera's node or of a node
//! above it. Every other channel (meshes, lights, morph weights) is ignored with a warning:
//! irr renders the rest pose of everything but the cameras.

use super::{Loader, describe, plural};
use crate::accessor::{Buffers, read_scalars, read_vec3, read_vec4};
use crate::animation::{CameraPath, Interpolation, Link, NodeMotion, Track, TrackError};
use crate::camera::NamedCamera;
use crate::error::LoadError;
use glam::{Quat, Vec3};
use gltf::animation::Property;

/// One animated node's tracks, as the channels give them.
#[derive(Default)]
struct Tracks {
    translation: Option<Track<Vec3>>,
    rotation: Option<Track<Quat>>,
    scale: Option<Track<Vec3>>,
}

impl Loader<'_> {
    /// Each camera's path (`None` where no channel moves it), by `cameras`' order, and the
    /// number of channels that move a mesh or a light (a node that places one, or a node above
    /// it, or a mesh's morph weights): irr renders those in their rest pose.
    pub(super) fn camera_paths(
        &mut self,
        buffers: &Buffers,
        cameras: &[NamedCamera],
    ) -> Result<(Vec<Option<CameraPath>>, usize), LoadError> {
        let d = self.document;
        let nodes = d.nodes().len();
        if d.animations().len() == 0 {
            return Ok((vec![None; cameras.len()], 0));
        }
        // Parents (the hierarchy was checked to be a forest when the nodes were walked).
        let mut parent = vec![None; nodes];
        for n in d.nodes() {
            for c in n.children() {
                parent[c.index()] = Some(n.index());
            }
        }
        let chain_of = |node: usize| {
            let mut chain = vec![node];
            let mut at = node;
            while let Some(p) = parent[at] {
                // A forest has no cycle, and a chain is at most the node count long.
                if chain.len() > nodes {
                    break;
                }
                chain.push(p);
                at = p;
            }
            chain.reverse();
            chain
        };
        let all: Vec<gltf::Node<'_>> = d.nodes().collect();
        let chains: Vec<Vec<usize>> = cameras.iter().map(|c| chain_of(c.node)).collect();
        let mut moves_camera = vec![false; nodes];
        for &n in chains.iter().flatten() {
            moves_camera[n] = true;
        }
        // Nodes that carry a mesh or a light, or sit above one.
        let mut carries = vec![false; nodes];
        for n in d.nodes() {
            if n.mesh().is_some() || super::lights::light_index(d, &n).is_some() {
                for m in chain_of(n.index()) {
                    carries[m] = true;
                }
            }
        }
        let mut tracks: Vec<Option<Tracks>> = (0..nodes).map(|_| None).collect();
        let (mut ignored, mut duplicate, mut moves_content, mut together) = (0, 0, 0, 0);
        for animation in d.animations() {
            for (ci, channel) in animation.channels().enumerate() {
                let node = channel.target().node().index();
                let property = channel.target().property();
                moves_content += usize::from(carries[node]);
                if !moves_camera[node] || property == Property::MorphTargetWeights {
                    ignored += 1;
                    continue;
                }
                together += usize::from(carries[node]);
                let what = format!(
                    "animation {} channel {ci} (node {})",
                    describe(animation.index(), animation.name()),
                    describe(node, all.get(node).and_then(|n| n.name()))
                );
                let sampler = channel.sampler();
                let interpolation = match sampler.interpolation() {
                    gltf::animation::Interpolation::Step => Interpolation::Step,
                    gltf::animation::Interpolation::Linear => Interpolation::Linear,
                    gltf::animation::Interpolation::CubicSpline => Interpolation::CubicSpline,
                };
                let times = read_scalars(
                    &format!("{what}: input"),
                    &sampler.input(),
                    buffers,
                    &mut self.budget,
                )
                .map_err(|e| self.err(e))?;
                let output = sampler.output();
                let out_what = format!("{what}: output");
                let path = self.path;
                let bad = |e: TrackError| LoadError::scene(path, format!("{what}: {e}"));
                let entry = tracks[node].get_or_insert_with(Tracks::default);
                let taken = match property {
                    Property::Translation | Property::Scale => {
                        let values = read_vec3(&out_what, &output, buffers, &mut self.budget)
                            .map_err(|e| LoadError::scene(self.path, e))?;
                        let track = Track::new(
                            times,
                            values.into_iter().map(Vec3::from_array).collect(),
                            interpolation,
                        )
                        .map_err(bad)?;
                        let slot = if property == Property::Translation {
                            &mut entry.translation
                        } else {
                            &mut entry.scale
                        };
                        slot.is_some() || {
                            *slot = Some(track);
                            false
                        }
                    }
                    Property::Rotation => {
                        let values = read_vec4(&out_what, &output, buffers, &mut self.budget)
                            .map_err(|e| LoadError::scene(self.path, e))?;
                        let track = Track::new(
                            times,
                            values.into_iter().map(Quat::from_array).collect(),
                            interpolation,
                        )
                        .map_err(bad)?;
                        entry.rotation.is_some() || {
                            entry.rotation = Some(track);
                            false
                        }
                    }
                    Property::MorphTargetWeights => false,
                };
                duplicate += usize::from(taken);
            }
        }
        self.warnings.add("animations", ignored, |n| {
            format!(
                "{} ignored: {} no camera (irr renders the rest pose of meshes and lights, and animates cameras only)",
                plural(n, "animation channel", "animation channels"),
                if n == 1 { "it moves" } else { "they move" }
            )
        });
        self.warnings.add("animation-content", together, |n| {
            format!(
                "{} a camera together with meshes or lights below the same node: the camera moves, the meshes and lights keep their rest pose",
                plural(n, "animation channel moves", "animation channels move")
            )
        });
        self.warnings.add("animation-duplicates", duplicate, |n| {
            format!(
                "{} a node property that an earlier channel already drives: the first channel in file order is used",
                plural(n, "animation channel drives", "animation channels drive")
            )
        });
        let mut paths = Vec::with_capacity(cameras.len());
        for (camera, chain) in cameras.iter().zip(&chains) {
            if !chain.iter().any(|&n| tracks[n].is_some()) {
                paths.push(None);
                continue;
            }
            let mut links = Vec::with_capacity(chain.len());
            for &n in chain {
                let Some(node) = all.get(n) else {
                    continue;
                };
                let link = match (tracks[n].take(), node.transform()) {
                    (None, _) => Link::Fixed(self.local_transform(node)?),
                    (Some(_), gltf::scene::Transform::Matrix { .. }) => {
                        return Err(self.err(format!(
                            "node {} is animated but has a matrix: glTF requires animated nodes to give translation, rotation and scale",
                            describe(n, node.name())
                        )));
                    }
                    (
                        Some(t),
                        gltf::scene::Transform::Decomposed {
                            translation,
                            rotation,
                            scale,
                        },
                    ) => {
                        let rest = Quat::from_array(rotation);
                        Link::Moving(NodeMotion {
                            rest: (
                                Vec3::from_array(translation),
                                if rest.length_squared() > 0.0 {
                                    rest.normalize()
                                } else {
                                    Quat::IDENTITY
                                },
                                Vec3::from_array(scale),
                            ),
                            translation: t.translation,
                            rotation: t.rotation,
                            scale: t.scale,
                        })
                    }
                };
                // Put the tracks back for another camera under the same node.
                if let Link::Moving(m) = &link {
                    tracks[n] = Some(Tracks {
                        translation: m.translation.clone(),
                        rotation: m.rotation.clone(),
                        scale: m.scale.clone(),
                    });
                }
                links.push(link);
            }
            let path = CameraPath {
                chain: links,
                rest: camera.camera,
            };
            // Every frame must place the camera: check the keys' times and the rest pose.
            let (start, end) = path.span();
            for t in [start, end] {
                if path.camera_at(t).is_none() {
                    return Err(self.err(format!(
                        "camera of node {}: its animation collapses the view direction at {t} s",
                        camera.describe()
                    )));
                }
            }
            paths.push(Some(path));
        }
        Ok((paths, moves_content))
    }
}
