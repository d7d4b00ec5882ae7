//! The JSON before the typed document: extension counts and the checks `gltf` leaves out.

use super::describe;
use crate::error::LoadError;
use std::collections::BTreeMap;
use std::path::Path;

/// Counts the objects that use each extension (the keys of every `"extensions"` object) in one
/// streaming pass over the JSON, without building a tree. serde_json's nesting limit (128)
/// bounds the recursion.
pub(super) fn count_extensions(json: &[u8]) -> Result<BTreeMap<String, usize>, String> {
    use serde::de::{DeserializeSeed, Deserializer, MapAccess, SeqAccess, Visitor};

    /// Walks one JSON value; `extensions` says it is the value of an `"extensions"` key.
    struct Walk<'c> {
        counts: &'c mut BTreeMap<String, usize>,
        extensions: bool,
    }

    impl<'de> DeserializeSeed<'de> for Walk<'_> {
        type Value = ();
        fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
            d.deserialize_any(self)
        }
    }

    impl<'de> Visitor<'de> for Walk<'_> {
        type Value = ();
        fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("any JSON value")
        }
        fn visit_bool<E>(self, _: bool) -> Result<(), E> {
            Ok(())
        }
        fn visit_i64<E>(self, _: i64) -> Result<(), E> {
            Ok(())
        }
        fn visit_u64<E>(self, _: u64) -> Result<(), E> {
            Ok(())
        }
        fn visit_f64<E>(self, _: f64) -> Result<(), E> {
            Ok(())
        }
        fn visit_str<E>(self, _: &str) -> Result<(), E> {
            Ok(())
        }
        fn visit_unit<E>(self) -> Result<(), E> {
            Ok(())
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
            while seq
                .next_element_seed(Walk {
                    counts: &mut *self.counts,
                    extensions: false,
                })?
                .is_some()
            {}
            Ok(())
        }
        fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
            while let Some(key) = map.next_key::<std::borrow::Cow<'de, str>>()? {
                if self.extensions {
                    *self.counts.entry(key.to_string()).or_default() += 1;
                }
                map.next_value_seed(Walk {
                    counts: &mut *self.counts,
                    extensions: !self.extensions && key == "extensions",
                })?;
            }
            Ok(())
        }
    }

    let mut counts = BTreeMap::new();
    let mut de = serde_json::Deserializer::from_slice(json);
    Walk {
        counts: &mut counts,
        extensions: false,
    }
    .deserialize(&mut de)
    .and_then(|()| de.end())
    .map_err(|e| e.to_string())?;
    Ok(counts)
}

/// Checks what `gltf`'s own validation does not, and without which it or its accessors panic:
/// each camera has the object its `type` names (`Camera::projection` unwraps it), each
/// animation channel's target node exists (`Target::node` unwraps it), and each
/// primitive's attribute accessors exist (the schema check indexes `accessors` with `POSITION`'s
/// before it checks the index). (Sparse indices of a non-integer type, an `unreachable!()` in
/// `Indices::index_type`, are already refused when the JSON is deserialized.)
pub(super) fn prevalidate(path: &Path, root: &gltf::json::Root) -> Result<(), LoadError> {
    use gltf::json::camera::Type;
    use gltf::json::validation::Checked;
    for (i, camera) in root.cameras.iter().enumerate() {
        let missing = match camera.type_ {
            Checked::Valid(Type::Perspective) if camera.perspective.is_none() => {
                Some(("perspective", "perspective"))
            }
            Checked::Valid(Type::Orthographic) if camera.orthographic.is_none() => {
                Some(("orthographic", "orthographic"))
            }
            _ => None,
        };
        if let Some((kind, object)) = missing {
            return Err(LoadError::parse(
                path,
                format!(
                    "camera {}: its type is \"{kind}\" but it has no \"{object}\" object",
                    describe(i, camera.name.as_deref())
                ),
            ));
        }
    }
    // `animation::Target::node` unwraps the node; the schema check does not cover it.
    for (a, animation) in root.animations.iter().enumerate() {
        for (c, channel) in animation.channels.iter().enumerate() {
            let node = channel.target.node.value();
            if node >= root.nodes.len() {
                return Err(LoadError::parse(
                    path,
                    format!(
                        "animation {} channel {c}: target node {node} does not exist (the file has {})",
                        describe(a, animation.name.as_deref()),
                        root.nodes.len()
                    ),
                ));
            }
        }
    }
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            for index in primitive.attributes.values() {
                if index.value() >= root.accessors.len() {
                    return Err(LoadError::parse(
                        path,
                        format!(
                            "mesh {} primitive {p}: attribute accessor {} does not exist (the file has {})",
                            describe(m, mesh.name.as_deref()),
                            index.value(),
                            root.accessors.len()
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Checks the document against glTF's schema (indices in range, required members present),
/// as `gltf::Document::from_json` would, except that it tolerates missing `min`/`max` on
/// `POSITION` accessors (the specification requires them, many exporters omit them, and irr
/// does not use them) and a spot light without its `spot` object (the `gltf` crate asks for it,
/// but `KHR_lights_punctual` gives it defaults), and its verdict on required extensions: the
/// loader has checked those against the extensions irr reads, a list that differs from the
/// crate's (which lacks `KHR_materials_specular`).
pub(super) fn validate(path: &Path, root: &gltf::json::Root) -> Result<(), LoadError> {
    use gltf::json::validation::{Error, Validate};
    let mut problems = Vec::new();
    root.validate(root, gltf::json::Path::new, &mut |at, error| {
        let at = at().to_string();
        let harmless = (matches!(error, Error::Missing)
            && (at.ends_with("[\"POSITION\"].min")
                || at.ends_with("[\"POSITION\"].max")
                // The gltf crate names the extension's field `khrLightsPunctual` in paths.
                || (at.contains("khrLightsPunctual") && at.ends_with(".spot"))))
            || (matches!(error, Error::Unsupported) && at.starts_with("extensionsRequired"));
        if !harmless {
            problems.push(format!("{at}: {error}"));
        }
    });
    if problems.is_empty() {
        Ok(())
    } else {
        Err(LoadError::parse(path, problems.join("; ")))
    }
}
