//! glTF 2.0 loading: a `.gltf` (with external or `data:` URI buffers) or `.glb` file becomes
//! world-space triangle meshes, diffuse materials and a camera.
//!
//! # What irr reads
//! - The default scene (`scene`, else the first), its node hierarchy and transforms (matrix or
//!   TRS; normals by the inverse transpose; a negative determinant flips the winding so the
//!   front face stays where the file meant it).
//! - Triangle primitives (`TRIANGLES`, `TRIANGLE_STRIP`, `TRIANGLE_FAN`), indexed (u8, u16, u32
//!   indices) or not; `POSITION` and, if present, `NORMAL`.
//! - Materials: `baseColorFactor.rgb` is the diffuse albedo; `emissiveFactor` times
//!   `KHR_materials_emissive_strength.emissiveStrength` (1 without the extension) is the emitted
//!   radiance in W·sr⁻¹·m⁻²; `doubleSided` says whether a surface emits from both faces or only
//!   from its front face (counter-clockwise winding). A primitive without a material gets glTF's
//!   default material (white, albedo 1), with a warning.
//! - The first perspective camera met in a depth-first walk of the scene's nodes.
//!
//! # What irr ignores, always with a warning
//! Textures and images, metallic reflection (`metallicFactor > 0`), transparency (`alphaMode`
//! other than `OPAQUE`), vertex colours, morph targets, skins, animations, points and lines,
//! orthographic cameras, other scenes, and every extension except
//! `KHR_materials_emissive_strength` (lights, transmission, …). Each becomes one [`Warning`] with
//! a count. glTF's dielectric specular layer (the 4 % reflection of its metallic-roughness BRDF
//! at `metallicFactor = 0`) is not modelled: irr's surfaces are Lambertian.
//!
//! # What irr refuses, with a [`RenderError`]
//! Files it cannot read or parse, buffers that point nowhere or are shorter than declared,
//! accessors out of range, indices past the vertex count, non-finite coordinates or coordinates
//! beyond [`MAX_COORDINATE`], non-finite or negative emission, and required extensions it does
//! not support.

use crate::accessor::{read_indices, read_vec3};
use crate::camera::Camera;
use crate::error::{RenderError, one_line};
use crate::files::{Budget, Confinement, LoadOptions, MAX_JSON_BYTES, read_scene_file};
use crate::glb;
use crate::uri::{decode_data_uri, percent_decode};
use glam::{Mat3, Mat4, Quat, Vec3};
use irr_geometry::TriangleMesh;
use irr_integrator::Material;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The largest coordinate magnitude (metres, after the node transforms) that irr accepts.
///
/// Ray-triangle tests multiply differences of two coordinates (edge vectors, ≤ 2·10¹⁸) by each
/// other; the product, ≤ 4·10³⁶, and a sum of three such terms stay below f32::MAX ≈ 3.4·10³⁸.
/// Beyond this a scene overflows to infinity inside the intersection code.
pub const MAX_COORDINATE: f32 = 1e18;

/// The one extension irr reads.
const SUPPORTED_EXTENSIONS: [&str; 1] = ["KHR_materials_emissive_strength"];

/// A feature of the file that irr ignored, with how many times it occurs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Warning {
    /// The scene file.
    pub file: PathBuf,
    /// A short stable key for the feature: `textures`, `metallic`, `extension:KHR_lights_punctual`…
    pub feature: String,
    /// How many times the file uses it.
    pub count: usize,
    /// The full message, e.g. `3 textures ignored (irr uses baseColorFactor only)`.
    pub message: String,
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.file.display(), self.message)
    }
}

/// A glTF file read into plain data: world-space meshes, materials, the camera, and the
/// warnings about what was ignored.
#[derive(Clone, Debug)]
pub struct SceneData {
    /// The file it came from.
    pub path: PathBuf,
    /// One mesh per primitive instance, in world space; `material_ids` index `materials`.
    pub meshes: Vec<TriangleMesh>,
    /// The materials, in the file's order, plus glTF's default material at the end if a
    /// primitive has none.
    pub materials: Vec<Material>,
    /// The file's first perspective camera, if any.
    pub camera: Option<Camera>,
    /// Everything irr ignored, one entry per feature.
    pub warnings: Vec<Warning>,
    /// The number of triangles whose material emits (a scene with none renders black under the
    /// path tracer).
    pub emissive_triangles: usize,
    /// The bounds of every vertex, `None` for a scene without triangles.
    pub bounds: Option<(Vec3, Vec3)>,
}

/// Writes a warning's line from its final count.
type Message = Box<dyn Fn(usize) -> String>;

/// Collects warnings, merging counts per feature, in first-seen order.
struct Warnings {
    file: PathBuf,
    order: Vec<String>,
    counts: BTreeMap<String, (usize, Message)>,
}

impl Warnings {
    fn new(file: &Path) -> Self {
        Self {
            file: file.to_path_buf(),
            order: Vec::new(),
            counts: BTreeMap::new(),
        }
    }

    /// Adds `n` occurrences of `feature`; `message(count)` writes the final line.
    fn add(&mut self, feature: &str, n: usize, message: impl Fn(usize) -> String + 'static) {
        if n == 0 {
            return;
        }
        match self.counts.get_mut(feature) {
            Some((count, _)) => *count += n,
            None => {
                self.order.push(feature.to_string());
                self.counts
                    .insert(feature.to_string(), (n, Box::new(message)));
            }
        }
    }

    fn finish(self) -> Vec<Warning> {
        let Self {
            file,
            order,
            mut counts,
        } = self;
        order
            .into_iter()
            .filter_map(|feature| {
                let (count, message) = counts.remove(&feature)?;
                Some(Warning {
                    file: file.clone(),
                    // Extension names come from the file: escaped like every message.
                    message: one_line(message(count)),
                    feature,
                    count,
                })
            })
            .collect()
    }
}

fn plural(n: usize, one: &str, many: &str) -> String {
    if n == 1 {
        format!("{n} {one}")
    } else {
        format!("{n} {many}")
    }
}

/// Reads a glTF 2.0 file (`.gltf` or `.glb`) into plain data, reading buffer files only from
/// the scene file's folder. See the module docs for what is read, ignored (with a warning) and
/// refused (with an error).
pub fn load_gltf(path: &Path) -> Result<SceneData, RenderError> {
    load_gltf_with(path, &LoadOptions::default())
}

/// [`load_gltf`] with options: [`LoadOptions::asset_root`] widens (or moves) the folder that
/// buffer URIs may read from.
pub fn load_gltf_with(path: &Path, options: &LoadOptions) -> Result<SceneData, RenderError> {
    let read_error = |problem: String| RenderError::Read {
        path: path.to_path_buf(),
        source: std::io::Error::other(problem),
    };
    let mut bytes = read_scene_file(path).map_err(read_error)?;
    let file_bytes = bytes.len() as u64;
    let confinement = Confinement::new(path, options).map_err(read_error)?;
    let (json_range, bin_range) = if glb::is_glb(&bytes) {
        let g = glb::parse(&bytes).map_err(|e| RenderError::parse(path, e))?;
        (g.json, g.bin)
    } else {
        (0..bytes.len(), None)
    };
    let json_bytes = bytes.get(json_range).unwrap_or_default();
    if json_bytes.is_empty() {
        return Err(RenderError::parse(path, "the file is empty"));
    }
    if json_bytes.len() > MAX_JSON_BYTES {
        return Err(RenderError::parse(
            path,
            format!(
                "its JSON has {} bytes, more than irr parses ({MAX_JSON_BYTES} bytes)",
                json_bytes.len()
            ),
        ));
    }
    // Every extension the file uses, counted in a streaming pass that builds no tree (the typed
    // document drops the extensions the gltf crate does not know).
    let extension_counts =
        count_extensions(json_bytes).map_err(|e| RenderError::parse(path, format!("JSON: {e}")))?;
    let root: gltf::json::Root = gltf::json::deserialize::from_slice(json_bytes)
        .map_err(|e| RenderError::parse(path, format!("glTF schema: {e}")))?;
    for ext in &root.extensions_required {
        if !SUPPORTED_EXTENSIONS.contains(&ext.as_str()) {
            return Err(RenderError::scene(
                path,
                format!("requires extension {ext}, which irr does not support"),
            ));
        }
    }
    prevalidate(path, &root)?;
    validate(path, &root)?;
    // The .glb's binary chunk becomes buffer 0's bytes in place; the JSON text is no longer
    // needed.
    let blob = match bin_range {
        Some(r) => {
            bytes.truncate(r.end);
            bytes.drain(..r.start);
            Some(bytes)
        }
        None => {
            drop(bytes);
            None
        }
    };
    let document = gltf::Document::from_json_without_validation(root);
    Loader {
        path,
        document: &document,
        warnings: Warnings::new(path),
        confinement,
        budget: Budget::for_input(file_bytes),
    }
    .load(extension_counts, blob)
}

/// Counts the objects that use each extension (the keys of every `"extensions"` object) in one
/// streaming pass over the JSON, without building a tree. serde_json's nesting limit (128)
/// bounds the recursion.
fn count_extensions(json: &[u8]) -> Result<BTreeMap<String, usize>, String> {
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
/// each camera has the object its `type` names (`Camera::projection` unwraps it), and each
/// primitive's attribute accessors exist (the schema check indexes `accessors` with `POSITION`'s
/// before it checks the index). (Sparse indices of a non-integer type, an `unreachable!()` in
/// `Indices::index_type`, are already refused when the JSON is deserialized.)
fn prevalidate(path: &Path, root: &gltf::json::Root) -> Result<(), RenderError> {
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
            return Err(RenderError::parse(
                path,
                format!(
                    "camera {}: its type is \"{kind}\" but it has no \"{object}\" object",
                    describe(i, camera.name.as_deref())
                ),
            ));
        }
    }
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            for index in primitive.attributes.values() {
                if index.value() >= root.accessors.len() {
                    return Err(RenderError::parse(
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
/// `POSITION` accessors: the specification requires them, many exporters omit them, and irr
/// does not use them.
fn validate(path: &Path, root: &gltf::json::Root) -> Result<(), RenderError> {
    use gltf::json::validation::{Error, Validate};
    let mut problems = Vec::new();
    root.validate(root, gltf::json::Path::new, &mut |at, error| {
        let at = at().to_string();
        let harmless = matches!(error, Error::Missing)
            && (at.ends_with("[\"POSITION\"].min") || at.ends_with("[\"POSITION\"].max"));
        if !harmless {
            problems.push(format!("{at}: {error}"));
        }
    });
    if problems.is_empty() {
        Ok(())
    } else {
        Err(RenderError::parse(path, problems.join("; ")))
    }
}

struct Loader<'a> {
    path: &'a Path,
    document: &'a gltf::Document,
    warnings: Warnings,
    confinement: Confinement,
    budget: Budget,
}

impl<'a> Loader<'a> {
    fn err(&self, problem: impl std::fmt::Display) -> RenderError {
        RenderError::scene(self.path, problem)
    }

    fn load(
        mut self,
        extension_counts: BTreeMap<String, usize>,
        blob: Option<Vec<u8>>,
    ) -> Result<SceneData, RenderError> {
        let version = &self.document.as_json().asset.version;
        if !version.starts_with("2.") {
            return Err(RenderError::parse(
                self.path,
                format!("asset.version is \"{version}\"; irr reads glTF 2.x"),
            ));
        }
        self.count_extensions(extension_counts);
        self.count_document_features();
        let buffers = self.load_buffers(blob)?;
        let (mut materials, default_material) = self.materials()?;
        let mut meshes = Vec::new();
        let mut camera = None;
        let mut used_default_material = 0;
        for (node, world) in self.walk_nodes()? {
            if let Some(cam) = node.camera() {
                match cam.projection() {
                    gltf::camera::Projection::Perspective(p) if camera.is_none() => {
                        camera = Some(self.camera(&node, world, &p)?);
                    }
                    gltf::camera::Projection::Perspective(_) => {
                        self.warnings.add("extra-cameras", 1, |n| {
                            format!(
                                "{} ignored (irr renders through the first perspective camera)",
                                plural(n, "more camera", "more cameras")
                            )
                        })
                    }
                    gltf::camera::Projection::Orthographic(_) => {
                        self.warnings.add("orthographic", 1, |n| {
                            format!(
                                "{} ignored (irr has perspective cameras only)",
                                plural(n, "orthographic camera", "orthographic cameras")
                            )
                        })
                    }
                }
            }
            if let Some(mesh) = node.mesh() {
                for primitive in mesh.primitives() {
                    let file_material = primitive.material().index();
                    let material_id = file_material.map_or(default_material, |i| i as u32);
                    if let Some(m) =
                        self.primitive(&node, &mesh, &primitive, world, material_id, &buffers)?
                    {
                        used_default_material += usize::from(file_material.is_none());
                        meshes.push(m);
                    }
                }
            }
        }
        if used_default_material > 0 {
            materials.push(Material {
                albedo: Vec3::ONE,
                emission: Vec3::ZERO,
                two_sided: false,
            });
            self.warnings.add("default-material", used_default_material, |n| {
                format!(
                    "{} no material: glTF's default material is used as white diffuse (albedo 1)",
                    plural(n, "primitive has", "primitives have")
                )
            });
        }
        if self.document.cameras().len() > 0 && camera.is_none() {
            self.warnings.add("unplaced-camera", 1, |_| {
                "no perspective camera is attached to a node of the scene: irr frames the scene's bounds instead".to_string()
            });
        }
        let emissive_triangles = meshes
            .iter()
            .flat_map(|m| m.material_ids.iter())
            .filter(|&&id| {
                materials
                    .get(id as usize)
                    .is_some_and(|m| m.emission.max_element() > 0.0)
            })
            .count();
        if emissive_triangles == 0 {
            self.warnings.add("no-emitter", 1, |_| {
                "the scene has no emissive triangles: the image will be black (ambient occlusion does not need them)".to_string()
            });
        }
        let bounds = meshes.iter().flat_map(|m| m.positions.iter()).fold(
            None,
            |acc: Option<(Vec3, Vec3)>, &p| {
                Some(match acc {
                    Some((lo, hi)) => (lo.min(p), hi.max(p)),
                    None => (p, p),
                })
            },
        );
        Ok(SceneData {
            path: self.path.to_path_buf(),
            meshes,
            materials,
            camera,
            warnings: self.warnings.finish(),
            emissive_triangles,
            bounds,
        })
    }

    /// Warns, for each extension irr ignores, of the objects that use it (`counts`, from
    /// [`count_extensions`]).
    fn count_extensions(&mut self, mut counts: BTreeMap<String, usize>) {
        // Extensions listed as used but never attached to an object still deserve a word.
        for name in self.document.extensions_used() {
            counts.entry(name.to_string()).or_insert(0);
        }
        for (name, count) in counts {
            if SUPPORTED_EXTENSIONS.contains(&name.as_str()) {
                continue;
            }
            let why = match name.as_str() {
                "KHR_lights_punctual" => "irr's only lights are emissive triangles",
                "KHR_draco_mesh_compression" | "EXT_meshopt_compression" => {
                    "compressed geometry is not decoded"
                }
                "KHR_texture_transform" | "KHR_texture_basisu" | "EXT_texture_webp" => {
                    "irr does not use textures"
                }
                _ => "irr does not support it",
            };
            let feature = format!("extension:{name}");
            // An extension only in `extensionsUsed` still gets one line, with count 1.
            self.warnings.add(&feature, count.max(1), move |n| {
                format!(
                    "extension {name} ignored ({}; {})",
                    plural(n, "use", "uses"),
                    why
                )
            });
        }
    }

    fn count_document_features(&mut self) {
        let d = self.document;
        let textures = d.textures().len();
        self.warnings.add("textures", textures, |n| {
            format!(
                "{} ignored (irr uses baseColorFactor and emissiveFactor only)",
                plural(n, "texture", "textures")
            )
        });
        let images = d.images().len();
        self.warnings.add("images", images, |n| {
            format!(
                "{} ignored (irr does not use textures)",
                plural(n, "image", "images")
            )
        });
        self.warnings.add("animations", d.animations().len(), |n| {
            format!(
                "{} ignored (irr renders the rest pose)",
                plural(n, "animation", "animations")
            )
        });
        self.warnings.add("skins", d.skins().len(), |n| {
            format!(
                "{} ignored (irr renders the unskinned positions)",
                plural(n, "skin", "skins")
            )
        });
        let scenes = d.scenes().len();
        self.warnings.add("scenes", scenes.saturating_sub(1), |n| {
            format!(
                "{} ignored (irr renders the default scene)",
                plural(n, "other scene", "other scenes")
            )
        });
        let (mut metallic, mut alpha) = (0, 0);
        for m in d.materials() {
            if m.pbr_metallic_roughness().metallic_factor() > 0.0 {
                metallic += 1;
            }
            if m.alpha_mode() != gltf::material::AlphaMode::Opaque {
                alpha += 1;
            }
        }
        self.warnings.add("metallic", metallic, |n| {
            format!(
                "{} metallicFactor > 0: metallic reflection ignored (irr's surfaces are diffuse, albedo baseColorFactor)",
                plural(n, "material has", "materials have")
            )
        });
        self.warnings.add("alpha", alpha, |n| {
            format!(
                "{} alphaMode BLEND or MASK: transparency ignored (irr's surfaces are opaque)",
                plural(n, "material has", "materials have")
            )
        });
    }

    /// The bytes of each buffer: the .glb's binary chunk, a `data:` URI's payload, or the first
    /// `byteLength` bytes of a file inside the asset root. Charges what it reads to the budget's
    /// input.
    fn load_buffers(&mut self, mut blob: Option<Vec<u8>>) -> Result<Vec<Vec<u8>>, RenderError> {
        let mut out = Vec::new();
        for buffer in self.document.buffers() {
            let i = buffer.index();
            let length = buffer.length();
            let data = match buffer.source() {
                gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                    self.err(format!(
                        "buffer {i} has no URI and the file has no binary chunk (a .glb's BIN), or a second buffer claims it"
                    ))
                })?,
                gltf::buffer::Source::Uri(uri) => {
                    let data = self.read_uri(i, uri, length)?;
                    self.budget.add_input(data.len() as u64);
                    data
                }
            };
            if data.len() < length {
                // A data: URI or the .glb's own chunk, both inside the scene file: naming its
                // size reveals nothing of another file.
                return Err(self.err(format!(
                    "buffer {i} has {} bytes but its byteLength says {length}",
                    data.len()
                )));
            }
            out.push(data);
        }
        Ok(out)
    }

    fn read_uri(&self, i: usize, uri: &str, length: usize) -> Result<Vec<u8>, RenderError> {
        if let Some(decoded) = decode_data_uri(uri) {
            return decoded.map_err(|e| self.err(format!("buffer {i}: {e}")));
        }
        // A scheme (RFC 3986 §3.1) is letters, digits, '+', '-', '.' before the first ':'.
        if let Some((scheme, _)) = uri.split_once(':') {
            let is_scheme = !scheme.is_empty()
                && scheme
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c));
            if is_scheme {
                return Err(self.err(format!(
                    "buffer {i}: URI scheme '{scheme}:' is not supported (irr reads relative file paths and data: URIs)"
                )));
            }
        }
        let name = percent_decode(uri).map_err(|e| self.err(format!("buffer {i}: {e}")))?;
        self.confinement
            .read(&name, length as u64)
            .map_err(|e| self.err(format!("buffer {i}: URI \"{uri}\" {e}")))
    }

    /// The materials in file order, and the index the default material will get.
    fn materials(&mut self) -> Result<(Vec<Material>, u32), RenderError> {
        let mut out = Vec::new();
        let mut clamped = 0;
        for m in self.document.materials() {
            let name = describe(m.index().unwrap_or(0), m.name());
            let base = m.pbr_metallic_roughness().base_color_factor();
            let albedo = Vec3::new(base[0], base[1], base[2]);
            if !albedo.is_finite() {
                return Err(self.err(format!(
                    "material {name}: baseColorFactor {albedo} is not finite"
                )));
            }
            let clamped_albedo = albedo.clamp(Vec3::ZERO, Vec3::ONE);
            if clamped_albedo != albedo {
                clamped += 1;
            }
            let strength = m.emissive_strength().unwrap_or(1.0);
            let emission = Vec3::from_array(m.emissive_factor()) * strength;
            if !emission.is_finite() || emission.min_element() < 0.0 {
                return Err(self.err(format!(
                    "material {name}: emission {emission} (emissiveFactor × emissiveStrength) must be finite and non-negative"
                )));
            }
            out.push(Material {
                albedo: clamped_albedo,
                emission,
                two_sided: m.double_sided(),
            });
        }
        self.warnings.add("albedo-clamped", clamped, |n| {
            format!(
                "{} baseColorFactor outside [0, 1]: clamped",
                plural(n, "material has", "materials have")
            )
        });
        let default = out.len() as u32;
        Ok((out, default))
    }

    /// The nodes of the default scene that hold a mesh or a camera, in depth-first order, each
    /// with its world transform.
    fn walk_nodes(&mut self) -> Result<Vec<(gltf::Node<'a>, Mat4)>, RenderError> {
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
        // Only nodes with a mesh or a camera are kept: the others matter only through the
        // transforms they pass on.
        let kept = d
            .nodes()
            .filter(|n| n.mesh().is_some() || n.camera().is_some())
            .count();
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
            if node.mesh().is_some() || node.camera().is_some() {
                out.push((node, world));
            }
        }
        Ok(out)
    }

    fn local_transform(&self, node: &gltf::Node<'_>) -> Result<Mat4, RenderError> {
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

    fn camera(
        &self,
        node: &gltf::Node<'_>,
        world: Mat4,
        p: &gltf::camera::Perspective<'_>,
    ) -> Result<Camera, RenderError> {
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

    fn primitive(
        &mut self,
        node: &gltf::Node<'_>,
        mesh: &gltf::Mesh<'_>,
        primitive: &gltf::Primitive<'_>,
        world: Mat4,
        material_id: u32,
        buffers: &[Vec<u8>],
    ) -> Result<Option<TriangleMesh>, RenderError> {
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
        let colours = primitive
            .attributes()
            .filter(|(s, _)| matches!(s, gltf::Semantic::Colors(_)))
            .count();
        self.warnings.add("vertex-colours", colours, |n| {
            format!(
                "{} (COLOR_n) ignored (irr uses baseColorFactor only)",
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
        let count = triangles.len();
        Ok(Some(TriangleMesh {
            positions,
            indices: triangles,
            normals,
            material_ids: vec![material_id; count],
        }))
    }
}

/// `3 "name"` or `3` for an object without a name.
fn describe(index: usize, name: Option<&str>) -> String {
    match name {
        Some(n) => format!("{index} \"{}\"", one_line(n)),
        None => index.to_string(),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{Gltf, assets, write};

    fn dir() -> tempfile::TempDir {
        tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"))
    }

    fn load(path: &Path) -> SceneData {
        load_gltf(path).unwrap_or_else(|e| panic!("{e}"))
    }

    fn load_err(path: &Path) -> String {
        match load_gltf(path) {
            Ok(_) => panic!("{} loaded but should not", path.display()),
            Err(e) => e.to_string(),
        }
    }

    const TRIANGLE: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

    /// One emissive material, one node with `node_extra`, one mesh whose primitive is
    /// `primitive`.
    fn one_mesh(g: &Gltf, node_extra: &str, primitive: &str) -> String {
        g.json(&format!(
            r#""scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0{node_extra}}}],
            "meshes":[{{"primitives":[{primitive}]}}],
            "materials":[{{"emissiveFactor":[1,1,1]}}]"#
        ))
    }

    fn world_triangles(s: &SceneData) -> Vec<[Vec3; 3]> {
        s.meshes
            .iter()
            .flat_map(|m| {
                m.indices
                    .iter()
                    .map(|t| t.map(|i| m.positions[i as usize]))
                    .collect::<Vec<_>>()
            })
            .collect()
    }

    #[test]
    fn cornell_box_loads_with_its_measured_data() {
        let s = load(&assets().join("cornell-box.gltf"));
        assert!(s.warnings.is_empty(), "{:?}", s.warnings);
        // 8 surfaces: floor, ceiling, back, two walls, light (1 quad each), blocks (5 quads).
        let triangles: usize = s.meshes.iter().map(|m| m.indices.len()).sum();
        assert_eq!(triangles, 2 * (6 + 5 + 5));
        assert_eq!(s.emissive_triangles, 2);
        let light = s
            .materials
            .iter()
            .find(|m| m.emission.max_element() > 0.0)
            .unwrap_or_else(|| panic!("no light"));
        // emissiveFactor (1, 12/17, 4/17) × strength 17 = (17, 12, 4), to f32 rounding of one
        // division and one product: 2 ulp of 17 ≈ 4e-6.
        assert!(
            (light.emission - Vec3::new(17.0, 12.0, 4.0))
                .abs()
                .max_element()
                < 4e-6
        );
        assert!(!light.two_sided);
        let cam = s.camera.unwrap_or_else(|| panic!("no camera"));
        assert!((cam.position - Vec3::new(0.278, 0.273, -0.8)).length() < 1e-6);
        assert!((cam.forward - Vec3::Z).length() < 1e-6);
        assert!((cam.yfov - 2.0 * (12.5f32 / 35.0).atan()).abs() < 1e-6);
        let (lo, hi) = s.bounds.unwrap_or_else(|| panic!("no bounds"));
        assert!((hi - Vec3::new(0.556, 0.5488, 0.5592)).abs().max_element() < 1e-6);
        assert_eq!(lo, Vec3::ZERO);
    }

    #[test]
    fn glb_and_data_uri_assets_load() {
        let furnace = load(&assets().join("furnace.glb"));
        assert_eq!(furnace.meshes[0].indices.len(), 320);
        assert!(furnace.materials[0].two_sided);
        let disk = load(&assets().join("disk-light.gltf"));
        assert_eq!(disk.emissive_triangles, 256);
        let ao = load(&assets().join("ao-plane.gltf"));
        assert_eq!(ao.emissive_triangles, 0);
        assert_eq!(
            ao.warnings
                .iter()
                .map(|w| w.feature.as_str())
                .collect::<Vec<_>>(),
            ["no-emitter"]
        );
        assert!(ao.warnings[0].to_string().contains("ao-plane.gltf: "));
        assert!(ao.warnings[0].message.contains("the image will be black"));
    }

    #[test]
    fn index_types_and_non_indexed_give_the_same_triangles() {
        let d = dir();
        let quad = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        let order = [0u32, 1, 2, 0, 2, 3];
        let mut reference = None;
        for ct in [5121, 5123, 5125] {
            let mut g = Gltf::default();
            let p = g.vec3(&quad);
            let i = g.indices(&order, ct);
            let json = one_mesh(
                &g,
                "",
                &format!(r#"{{"attributes":{{"POSITION":{p}}},"indices":{i}}}"#),
            );
            let s = load(&write(d.path(), &format!("q{ct}.gltf"), json));
            let tris = world_triangles(&s);
            assert_eq!(tris.len(), 2);
            match &reference {
                None => reference = Some(tris),
                Some(r) => assert_eq!(&tris, r),
            }
        }
        let mut g = Gltf::default();
        let flat: Vec<[f32; 3]> = order.iter().map(|&i| quad[i as usize]).collect();
        let p = g.vec3(&flat);
        let json = one_mesh(&g, "", &format!(r#"{{"attributes":{{"POSITION":{p}}}}}"#));
        let s = load(&write(d.path(), "flat.gltf", json));
        assert_eq!(Some(world_triangles(&s)), reference);
    }

    #[test]
    fn strips_and_fans_keep_the_winding() {
        let d = dir();
        // Four vertices of a quad in the z = 0 plane, counter-clockwise seen from +z.
        let strip = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
        ];
        for (mode, verts) in [
            (5, strip),
            (
                6,
                [
                    [0.0, 0.0, 0.0],
                    [1.0, 0.0, 0.0],
                    [1.0, 1.0, 0.0],
                    [0.0, 1.0, 0.0],
                ],
            ),
        ] {
            let mut g = Gltf::default();
            let p = g.vec3(&verts);
            let json = one_mesh(
                &g,
                "",
                &format!(r#"{{"attributes":{{"POSITION":{p}}},"mode":{mode}}}"#),
            );
            let s = load(&write(d.path(), &format!("m{mode}.gltf"), json));
            let tris = world_triangles(&s);
            assert_eq!(tris.len(), 2, "mode {mode}");
            for t in tris {
                let n = (t[1] - t[0]).cross(t[2] - t[0]);
                assert!(n.z > 0.0, "mode {mode}: triangle {t:?} faces away");
            }
        }
    }

    #[test]
    fn node_hierarchy_transforms_compose() {
        let d = dir();
        let mut g = Gltf::default();
        let p = g.vec3(&TRIANGLE);
        // Parent: translate by (10, 0, 0); child: scale 2, then a quarter turn about Z given as
        // a column-major matrix; the mesh hangs on the child.
        let json = g.json(&format!(
            r#""scene":0,"scenes":[{{"nodes":[0]}}],
            "nodes":[{{"translation":[10,0,0],"children":[1]}},
                     {{"mesh":0,"matrix":[0,2,0,0, -2,0,0,0, 0,0,2,0, 0,0,0,1]}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}}}}]}}],
            "materials":[]"#
        ));
        let s = load(&write(d.path(), "h.gltf", json));
        let t = world_triangles(&s)[0];
        // (1,0,0) → scaled and turned to (0,2,0) → translated to (10,2,0); (0,1,0) → (8,0,0).
        assert_eq!(
            t,
            [
                Vec3::new(10.0, 0.0, 0.0),
                Vec3::new(10.0, 2.0, 0.0),
                Vec3::new(8.0, 0.0, 0.0)
            ]
        );
    }

    #[test]
    fn mirroring_keeps_the_front_face_and_normals_use_the_inverse_transpose() {
        let d = dir();
        let mut g = Gltf::default();
        // A triangle in the plane x + y = 1, front face (counter-clockwise) toward +x+y, with
        // its shading normals given.
        let verts = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let p = g.vec3(&verts);
        let n = g.vec3(&[[0.57735, 0.57735, 0.57735]; 3]);
        let prim = format!(r#"{{"attributes":{{"POSITION":{p},"NORMAL":{n}}}}}"#);
        for (name, scale) in [("plain", [1.0, 1.0, 1.0]), ("mirror", [-1.0, 3.0, 1.0])] {
            let json = one_mesh(
                &g,
                &format!(r#","scale":[{},{},{}]"#, scale[0], scale[1], scale[2]),
                &prim,
            );
            let s = load(&write(d.path(), &format!("{name}.gltf"), json));
            let m = &s.meshes[0];
            let t = m.indices[0].map(|i| m.positions[i as usize]);
            let front = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
            let normal = m.normals.as_ref().unwrap_or_else(|| panic!("no normals"))[0];
            // The shading normal (transformed by the inverse transpose) stays perpendicular to
            // the transformed surface and on its front side. Tolerance: f32 rounding of a few
            // products of O(1) values, 1e-6.
            assert!((t[1] - t[0]).dot(normal).abs() < 1e-6, "{name}");
            assert!((t[2] - t[0]).dot(normal).abs() < 1e-6, "{name}");
            assert!(
                front.dot(normal) > 0.999,
                "{name}: front {front} normal {normal}"
            );
        }
    }

    #[test]
    fn ignored_features_are_counted_in_warnings() {
        let d = dir();
        let mut g = Gltf::default();
        let p = g.vec3(&TRIANGLE);
        let json = g.json(&format!(
            r#""extensionsUsed":["KHR_lights_punctual","KHR_materials_transmission"],
            "extensions":{{"KHR_lights_punctual":{{"lights":[{{"type":"point"}}]}}}},
            "scene":0,"scenes":[{{"nodes":[0,1,2]}},{{"nodes":[]}}],
            "nodes":[{{"mesh":0}},{{"extensions":{{"KHR_lights_punctual":{{"light":0}}}}}},{{"mesh":1}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}},"material":0}},
                                     {{"attributes":{{"POSITION":{p}}},"material":1}},
                                     {{"attributes":{{"POSITION":{p}}},"mode":0}}]}},
                      {{"primitives":[{{"attributes":{{"POSITION":{p}}}}}]}}],
            "images":[{{"uri":"a.png"}}],"textures":[{{"source":0}},{{"source":0}}],
            "materials":[{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}}}}}},
                         {{"pbrMetallicRoughness":{{"metallicFactor":0}},"alphaMode":"BLEND",
                           "extensions":{{"KHR_materials_transmission":{{"transmissionFactor":1}}}}}}]"#
        ));
        let s = load(&write(d.path(), "w.gltf", json));
        let got: Vec<(&str, usize)> = s
            .warnings
            .iter()
            .map(|w| (w.feature.as_str(), w.count))
            .collect();
        for expected in [
            ("extension:KHR_lights_punctual", 2),
            ("extension:KHR_materials_transmission", 1),
            ("textures", 2),
            ("images", 1),
            ("scenes", 1),
            // Material 0 keeps glTF's default metallicFactor of 1.
            ("metallic", 1),
            ("alpha", 1),
            ("non-triangle", 1),
            ("default-material", 1),
        ] {
            assert!(got.contains(&expected), "missing {expected:?} in {got:?}");
        }
        let text: Vec<String> = s.warnings.iter().map(ToString::to_string).collect();
        assert!(
            text.iter()
                .all(|t| t.starts_with(&format!("{}: ", d.path().join("w.gltf").display())))
        );
        assert!(
            text.iter().any(|t| t.ends_with(
                "2 textures ignored (irr uses baseColorFactor and emissiveFactor only)"
            )),
            "{text:?}"
        );
        // The default material is appended after the file's two.
        assert_eq!(s.materials.len(), 3);
        assert_eq!(s.meshes.last().map(|m| m.material_ids[0]), Some(2));
    }

    #[test]
    fn sparse_accessors_substitute_values() {
        let d = dir();
        let mut g = Gltf::default();
        let p = g.vec3(&[[0.0; 3]; 3]);
        // Replace vertices 1 and 2 by (1,0,0) and (0,1,0).
        let idx = g.indices(&[1, 2], 5123);
        let vals = g.vec3(&[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        let idx_view = g.accessors[idx]
            .split(',')
            .next()
            .map(|s| s.replace(r#"{"bufferView":"#, ""))
            .unwrap_or_default();
        let val_view = g.accessors[vals]
            .split(',')
            .next()
            .map(|s| s.replace(r#"{"bufferView":"#, ""))
            .unwrap_or_default();
        g.accessors[p] = format!(
            r#"{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",
               "sparse":{{"count":2,"indices":{{"bufferView":{idx_view},"componentType":5123}},
                          "values":{{"bufferView":{val_view}}}}}}}"#
        );
        let json = one_mesh(&g, "", &format!(r#"{{"attributes":{{"POSITION":{p}}}}}"#));
        let s = load(&write(d.path(), "sparse.gltf", json));
        assert_eq!(world_triangles(&s)[0], TRIANGLE.map(Vec3::from_array));
    }

    #[test]
    fn bad_content_is_refused_with_the_reason() {
        let d = dir();
        let mut g = Gltf::default();
        let p = g.vec3(&TRIANGLE);
        let i = g.indices(&[0, 1, 7], 5123);
        let prim = format!(r#"{{"attributes":{{"POSITION":{p}}},"indices":{i}}}"#);
        let e = load_err(&write(d.path(), "idx.gltf", one_mesh(&g, "", &prim)));
        // The entry is named, not its value (bytes of a file are never echoed).
        assert!(
            e.contains("idx.gltf") && e.contains("index entry 2") && e.contains("3 vertices"),
            "{e}"
        );
        assert!(!e.contains("index 7"), "{e}");

        let mut g = Gltf::default();
        let p = g.vec3(&TRIANGLE);
        g.accessors[p] = g.accessors[p].replace(r#""count":3"#, r#""count":4"#);
        let prim = format!(r#"{{"attributes":{{"POSITION":{p}}}}}"#);
        let e = load_err(&write(d.path(), "range.gltf", one_mesh(&g, "", &prim)));
        assert!(
            e.contains("range.gltf") && e.contains("out of range"),
            "{e}"
        );

        for (name, bad) in [("nan", f32::NAN), ("inf", f32::INFINITY), ("huge", 1e30)] {
            let mut g = Gltf::default();
            let p = g.vec3(&[[0.0, 0.0, 0.0], [bad, 0.0, 0.0], [0.0, 1.0, 0.0]]);
            let prim = format!(r#"{{"attributes":{{"POSITION":{p}}}}}"#);
            let e = load_err(&write(
                d.path(),
                &format!("{name}.gltf"),
                one_mesh(&g, "", &prim),
            ));
            assert!(
                e.contains(&format!("{name}.gltf")) && e.contains("vertex 1"),
                "{e}"
            );
        }

        // A node that is its own child.
        let mut g = Gltf::default();
        let p = g.vec3(&TRIANGLE);
        let json = g.json(&format!(
            r#""scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0,"children":[0]}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}}}}]}}]"#
        ));
        let e = load_err(&write(d.path(), "cycle.gltf", json));
        assert!(
            e.contains("cycle.gltf") && e.contains("reached twice"),
            "{e}"
        );

        // A required extension irr cannot honour.
        let g = Gltf::default();
        let json = g.json(r#""extensionsRequired":["KHR_draco_mesh_compression"],"extensionsUsed":["KHR_draco_mesh_compression"]"#);
        let e = load_err(&write(d.path(), "draco.gltf", json));
        assert!(
            e.contains("draco.gltf") && e.contains("requires extension KHR_draco_mesh_compression"),
            "{e}"
        );
    }
}
