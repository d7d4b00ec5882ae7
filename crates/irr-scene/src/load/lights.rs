//! `KHR_lights_punctual`: point, spot and directional lights placed by nodes.
//!
//! A light's `intensity` × `color` is taken as irr-integrator's `PunctualLight` takes it (candela
//! for point and spot, lux for directional, read in the unit of irr's emitted radiance, with no
//! 683 lm/W factor). Its node's world transform gives the position (the transformed origin) and
//! the direction (the transformed −Z, normalised); scale changes neither the intensity nor the
//! cone. `range` is ignored with a warning: it is a culling hint that cuts the inverse-square
//! law, which a physically based renderer keeps.

use super::{Loader, describe, plural};
use crate::PunctualLight;
use crate::error::LoadError;
use glam::{Mat4, Vec3};
use gltf::json::extensions::scene::khr_lights_punctual::{Light, Type};
use gltf::json::validation::Checked;
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};

/// The index of the light that `node` places, if any.
pub(super) fn light_index(document: &gltf::Document, node: &gltf::Node<'_>) -> Option<usize> {
    let json = document.as_json().nodes.get(node.index())?;
    let ext = json.extensions.as_ref()?.khr_lights_punctual.as_ref()?;
    Some(ext.light.value())
}

/// The file's lights (`extensions.KHR_lights_punctual.lights`), empty without the extension.
fn lights_of(document: &gltf::Document) -> &[Light] {
    let root = document.as_json();
    AsRef::<[Light]>::as_ref(root)
}

impl Loader<'_> {
    /// The light `index` placed by `node` with world transform `world`, checked: intensity and
    /// colour finite and non-negative, cone angles within glTF's ranges (0 ≤ inner ≤ outer ≤
    /// π/2; the specification asks inner < outer, and Blender writes inner = outer for a spot
    /// whose blend is 0, which irr takes as a hard-edged cone), a direction the transform does
    /// not collapse. Errors name the light and its node.
    pub(super) fn light(
        &mut self,
        node: &gltf::Node<'_>,
        world: Mat4,
        index: usize,
    ) -> Result<PunctualLight, LoadError> {
        let light = lights_of(self.document).get(index).ok_or_else(|| {
            // The schema check has already refused an index out of range; kept as an error, not
            // a panic, all the same.
            self.err(format!(
                "node {} places light {index}, which does not exist",
                describe(node.index(), node.name())
            ))
        })?;
        let name = format!(
            "light {} (on node {})",
            describe(index, light.name.as_deref()),
            describe(node.index(), node.name())
        );
        let intensity = light.intensity;
        if !(intensity.is_finite() && intensity >= 0.0) {
            return Err(self.err(format!(
                "{name}: intensity {intensity} must be finite and non-negative"
            )));
        }
        let color = Vec3::from_array(light.color);
        if !(color.is_finite() && color.min_element() >= 0.0) {
            return Err(self.err(format!(
                "{name}: color {color} must be finite and non-negative"
            )));
        }
        let strength = color * intensity;
        if !strength.is_finite() {
            return Err(self.err(format!(
                "{name}: intensity × color = {strength} is not finite"
            )));
        }
        if light.range.is_some() {
            self.warnings.add("light-range", 1, |n| {
                format!(
                    "{} range ignored (a non-physical cut-off: irr keeps the inverse-square law)",
                    plural(n, "light's", "lights'")
                )
            });
        }
        let position = world.transform_point3(Vec3::ZERO);
        if !position.is_finite() {
            return Err(self.err(format!("{name}: its position {position} is not finite")));
        }
        let direction = || {
            let d = world.transform_vector3(Vec3::NEG_Z);
            let unit = d.normalize_or_zero();
            if unit == Vec3::ZERO || !unit.is_finite() {
                Err(self.err(format!(
                    "{name}: the node's transform collapses the light's direction (−Z)"
                )))
            } else {
                Ok(unit)
            }
        };
        match light.type_ {
            Checked::Valid(Type::Point) => Ok(PunctualLight::point(position, strength)),
            Checked::Valid(Type::Directional) => {
                Ok(PunctualLight::directional(direction()?, strength))
            }
            Checked::Valid(Type::Spot) => {
                // The specification's defaults when `spot` is left out.
                let (inner, outer) = light.spot.as_ref().map_or((0.0, FRAC_PI_4), |s| {
                    (s.inner_cone_angle, s.outer_cone_angle)
                });
                if !(outer.is_finite() && outer > 0.0 && outer <= FRAC_PI_2) {
                    return Err(self.err(format!(
                        "{name}: outerConeAngle {outer} rad is not in (0, π/2]"
                    )));
                }
                if !(inner.is_finite() && inner >= 0.0 && inner <= outer) {
                    return Err(self.err(format!(
                        "{name}: innerConeAngle {inner} rad is not in [0, outerConeAngle = {outer}]"
                    )));
                }
                Ok(PunctualLight::spot(
                    position,
                    direction()?,
                    strength,
                    inner,
                    outer,
                ))
            }
            // The schema check refuses any other type before the loader runs.
            Checked::Invalid => Err(self.err(format!(
                "{name}: its type is not one of point, spot, directional"
            ))),
        }
    }

    /// Warns of the lights that no node of the rendered scene places (`placed` lights were).
    pub(super) fn count_unplaced_lights(&mut self, placed: &[bool]) {
        let unplaced = placed.iter().filter(|&&p| !p).count();
        self.warnings.add("unplaced-lights", unplaced, |n| {
            format!(
                "{} not placed by any node of the default scene: ignored",
                plural(n, "light is", "lights are")
            )
        });
    }

    /// How many lights the file defines.
    pub(super) fn light_count(&self) -> usize {
        lights_of(self.document).len()
    }
}

#[cfg(test)]
mod tests {
    use crate::PunctualLight;
    use crate::load::{SceneData, load_gltf};
    use crate::testutil::{Gltf, write};
    use glam::Vec3;
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};

    /// A file with one emissive-free triangle and `lights`, placed by the nodes `nodes` (JSON
    /// objects without braces, appended after the mesh node 0), all roots of the default scene
    /// except those named as `children`.
    fn file(lights: &str, nodes: &[&str], required: bool) -> String {
        let mut g = Gltf::default();
        let p = g.vec3(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]);
        let node_list: Vec<String> = (0..=nodes.len())
            .filter(|i| {
                !nodes
                    .iter()
                    .any(|n| n.contains(&format!(r#""children":[{i}]"#)))
            })
            .map(|i| i.to_string())
            .collect();
        let extra: String = nodes.iter().map(|n| format!(",{{{n}}}")).collect();
        let required = if required {
            r#""extensionsRequired":["KHR_lights_punctual"],"#
        } else {
            ""
        };
        g.json(&format!(
            r#"{required}"extensionsUsed":["KHR_lights_punctual"],
            "extensions":{{"KHR_lights_punctual":{{"lights":[{lights}]}}}},
            "scene":0,"scenes":[{{"nodes":[{}]}}],
            "nodes":[{{"mesh":0}}{extra}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}},"material":0}}]}}],
            "materials":[{{"pbrMetallicRoughness":{{"metallicFactor":0}}}}]"#,
            node_list.join(",")
        ))
    }

    fn load(json: String) -> Result<SceneData, String> {
        let d = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        load_gltf(&write(d.path(), "lights.gltf", json)).map_err(|e| e.to_string())
    }

    fn features(s: &SceneData) -> Vec<&str> {
        s.warnings.iter().map(|w| w.feature.as_str()).collect()
    }

    /// Transforms in f32: a few roundings of O(1) values, 1e-6.
    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).abs().max_element() < 1e-6
    }

    /// Blender writes `KHR_lights_punctual` as required: the file loads, the lamp is a point
    /// light at its node's world position (a parent's translation and scale included), with
    /// intensity × color, and the scene has an emitter, so no "no-emitter" warning.
    #[test]
    fn a_required_point_light_loads_at_its_node() {
        let s = load(file(
            r#"{"type":"point","intensity":54.35,"color":[1,0.5,0.25],"name":"Light"}"#,
            &[
                r#""name":"Parent","translation":[1,2,3],"scale":[2,2,2],"children":[2]"#,
                r#""name":"Light","translation":[0.5,0,-1],"rotation":[0.3826834,0,0,0.9238795],
                   "extensions":{"KHR_lights_punctual":{"light":0}}"#,
            ],
            true,
        ))
        .unwrap_or_else(|e| panic!("{e}"));
        assert!(features(&s).is_empty(), "{:?}", s.warnings);
        let [
            PunctualLight::Point {
                position,
                intensity,
            },
        ] = s.lights[..]
        else {
            panic!("{:?}", s.lights)
        };
        // (1, 2, 3) + 2·(0.5, 0, −1).
        assert!(close(position, Vec3::new(2.0, 2.0, 1.0)), "{position}");
        assert!(
            close(intensity, Vec3::new(54.35, 27.175, 13.5875)),
            "{intensity}"
        );
    }

    /// A spot and a directional light shine along their node's −Z: here a node turned by 90°
    /// about +X, whose −Z is world −Y. The spot's cone angles become cosines; without its `spot`
    /// object a spot takes the specification's defaults (inner 0, outer π/4).
    #[test]
    fn spot_and_directional_lights_point_down_their_nodes_minus_z() {
        let down = r#""rotation":[-0.70710677,0,0,0.70710677],"translation":[0,3,0]"#;
        let s = load(file(
            r#"{"type":"spot","intensity":2,"spot":{"innerConeAngle":0.2,"outerConeAngle":0.6}},
               {"type":"directional","intensity":3},
               {"type":"spot"}"#,
            &[
                &format!(r#"{down},"extensions":{{"KHR_lights_punctual":{{"light":0}}}}"#),
                &format!(r#"{down},"extensions":{{"KHR_lights_punctual":{{"light":1}}}}"#),
                &format!(r#"{down},"extensions":{{"KHR_lights_punctual":{{"light":2}}}}"#),
            ],
            false,
        ))
        .unwrap_or_else(|e| panic!("{e}"));
        let expected = [
            PunctualLight::spot(
                Vec3::new(0.0, 3.0, 0.0),
                -Vec3::Y,
                Vec3::splat(2.0),
                0.2,
                0.6,
            ),
            PunctualLight::directional(-Vec3::Y, Vec3::splat(3.0)),
            PunctualLight::spot(
                Vec3::new(0.0, 3.0, 0.0),
                -Vec3::Y,
                Vec3::ONE,
                0.0,
                FRAC_PI_4,
            ),
        ];
        assert_eq!(s.lights.len(), 3);
        for (got, want) in s.lights.iter().zip(expected) {
            match (*got, want) {
                (
                    PunctualLight::Spot {
                        position: p,
                        direction: d,
                        intensity: i,
                        cos_inner: ci,
                        cos_outer: co,
                    },
                    PunctualLight::Spot {
                        position,
                        direction,
                        intensity,
                        cos_inner,
                        cos_outer,
                    },
                ) => {
                    assert!(close(p, position) && close(d, direction), "{got:?}");
                    assert_eq!((i, ci, co), (intensity, cos_inner, cos_outer));
                }
                (
                    PunctualLight::Directional {
                        direction: d,
                        irradiance: e,
                    },
                    PunctualLight::Directional {
                        direction,
                        irradiance,
                    },
                ) => assert!(close(d, direction) && e == irradiance, "{got:?}"),
                _ => panic!("{got:?} vs {want:?}"),
            }
        }
    }

    /// `range` is ignored with a counted warning; lights no node of the scene places are
    /// counted too; a scene lit only by a light of zero intensity still warns that it is black.
    #[test]
    fn range_and_unplaced_lights_are_warned_about() {
        let s = load(file(
            r#"{"type":"point","range":5},{"type":"spot","range":2},{"type":"point"}"#,
            &[
                r#""extensions":{"KHR_lights_punctual":{"light":0}}"#,
                r#""extensions":{"KHR_lights_punctual":{"light":1}}"#,
            ],
            false,
        ))
        .unwrap_or_else(|e| panic!("{e}"));
        let got: Vec<(&str, usize)> = s
            .warnings
            .iter()
            .map(|w| (w.feature.as_str(), w.count))
            .collect();
        assert_eq!(got, [("light-range", 2), ("unplaced-lights", 1)]);
        assert!(s.warnings[0].message.contains("2 lights' range ignored"));
        let dark = load(file(
            r#"{"type":"point","intensity":0}"#,
            &[r#""extensions":{"KHR_lights_punctual":{"light":0}}"#],
            false,
        ))
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(features(&dark), ["no-emitter"]);
    }

    /// Lights irr cannot render are refused with an error naming the light and its node.
    #[test]
    fn bad_lights_are_refused_naming_the_light() {
        let place = r#""name":"Lamp","extensions":{"KHR_lights_punctual":{"light":0}}"#;
        for (light, problem) in [
            (
                r#"{"type":"point","intensity":-1}"#,
                "intensity -1 must be finite and non-negative",
            ),
            (r#"{"type":"point","color":[1,-0.5,1]}"#, "color"),
            (
                r#"{"type":"spot","spot":{"innerConeAngle":0.6,"outerConeAngle":0.3}}"#,
                "innerConeAngle 0.6 rad is not in [0, outerConeAngle = 0.3]",
            ),
            (
                r#"{"type":"spot","spot":{"innerConeAngle":-0.1,"outerConeAngle":0.3}}"#,
                "innerConeAngle -0.1",
            ),
            (
                r#"{"type":"spot","spot":{"innerConeAngle":0.1,"outerConeAngle":1.6}}"#,
                "outerConeAngle 1.6 rad is not in (0, π/2]",
            ),
            (
                r#"{"type":"spot","spot":{"innerConeAngle":0,"outerConeAngle":0}}"#,
                "outerConeAngle 0 rad",
            ),
        ] {
            let e = load(file(
                &format!(r#"{{"name":"Bulb",{}"#, &light[1..]),
                &[place],
                false,
            ))
            .err()
            .unwrap_or_default();
            assert!(
                e.contains("lights.gltf")
                    && e.contains(r#"light 0 "Bulb" (on node 1 "Lamp")"#)
                    && e.contains(problem),
                "{light}: {e}"
            );
        }
        // A directional light whose node has zero scale has no direction.
        let e = load(file(
            r#"{"type":"directional"}"#,
            &[r#""scale":[0,0,0],"extensions":{"KHR_lights_punctual":{"light":0}}"#],
            false,
        ))
        .err()
        .unwrap_or_default();
        assert!(e.contains("collapses the light's direction"), "{e}");
        // An unknown type and a light index out of range are schema errors.
        for (lights, light) in [(r#"{"type":"area"}"#, 0), (r#"{"type":"point"}"#, 3)] {
            let node = format!(r#""extensions":{{"KHR_lights_punctual":{{"light":{light}}}}}"#);
            let e = load(file(lights, &[&node], false))
                .err()
                .unwrap_or_default();
            assert!(
                e.contains("lights.gltf") && e.contains("LightsPunctual"),
                "{e}"
            );
        }
    }

    /// Malformed extension JSON is an error naming the file, never a panic: a node that places
    /// a light when the file defines none, lights that are not a list, a spot of strings, a
    /// light index of the wrong type.
    #[test]
    fn malformed_lights_are_errors() {
        let mut g = Gltf::default();
        let p = g.vec3(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]);
        let mesh = format!(r#""meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}}}}]}}]"#);
        for (root, node) in [
            ("", r#"{"light":0}"#),
            (
                r#""extensions":{"KHR_lights_punctual":{"lights":{}}},"#,
                r#"{"light":0}"#,
            ),
            (
                r#""extensions":{"KHR_lights_punctual":{"lights":[{"type":"spot","spot":{"outerConeAngle":"wide"}}]}},"#,
                r#"{"light":0}"#,
            ),
            (
                r#""extensions":{"KHR_lights_punctual":{"lights":[{"type":"point"}]}},"#,
                r#"{"light":-1}"#,
            ),
            (
                r#""extensions":{"KHR_lights_punctual":{"lights":[{"type":"point"}]}},"#,
                r#"{"light":"0"}"#,
            ),
            (
                r#""extensions":{"KHR_lights_punctual":{"lights":[{"intensity":1}]}},"#,
                r#"{"light":0}"#,
            ),
        ] {
            let json = g.json(&format!(
                r#"{root}"scene":0,"scenes":[{{"nodes":[0,1]}}],
                "nodes":[{{"mesh":0}},{{"extensions":{{"KHR_lights_punctual":{node}}}}}],{mesh}"#
            ));
            let e = load(json).err().unwrap_or_default();
            assert!(e.contains("lights.gltf: "), "{root} {node}: {e}");
        }
    }

    /// Equal cone angles (Blender's spot with blend 0) load as a hard-edged cone; π/2, written
    /// at double precision, rounds to an f32 just above π/2 and still loads.
    #[test]
    fn equal_and_right_angle_cones_load() {
        let s = load(file(
            r#"{"type":"spot","spot":{"innerConeAngle":0.4,"outerConeAngle":0.4}},
               {"type":"spot","spot":{"innerConeAngle":0.5,"outerConeAngle":1.5707963267948966}}"#,
            &[
                r#""extensions":{"KHR_lights_punctual":{"light":0}}"#,
                r#""extensions":{"KHR_lights_punctual":{"light":1}}"#,
            ],
            false,
        ))
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.lights.len(), 2);
        assert!(
            s.lights.iter().all(|l| l.problem().is_none()),
            "{:?}",
            s.lights
        );
        assert!(matches!(s.lights[1], PunctualLight::Spot { cos_outer, .. } if cos_outer == 0.0));
        assert!(FRAC_PI_2 > std::f64::consts::FRAC_PI_2 as f32 - 1e-7);
    }
}
