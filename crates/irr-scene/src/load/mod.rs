//! glTF 2.0 loading: a `.gltf` (with external or `data:` URI buffers) or `.glb` file becomes
//! world-space triangle meshes, metallic-roughness materials with their textures, and a camera.
//!
//! # What irr reads
//! - The default scene (`scene`, else the first), its node hierarchy and transforms (matrix or
//!   TRS; normals by the inverse transpose; a negative determinant flips the winding so the
//!   front face stays where the file meant it); `EXT_mesh_gpu_instancing`'s instances. A
//!   primitive whose data (accessors, mode, the texture sets its material reads) is drawn more
//!   than once, by several nodes, by instancing, or by meshes that share its accessors, is kept
//!   once as an object-space prototype and placed by each draw's transform
//!   ([`SceneData::instances`]); a mirroring draw and a primitive with morph targets are copied
//!   into world space instead.
//! - Triangle primitives (`TRIANGLES`, `TRIANGLE_STRIP`, `TRIANGLE_FAN`), indexed (u8, u16, u32
//!   indices) or not; `POSITION`, `NORMAL` if present, and the `TEXCOORD_n` a textured material
//!   reads (float, or normalized unsigned byte or short; with `KHR_mesh_quantization` the 8- and
//!   16-bit integer types it allows, `TANGENT` too); `COLOR_0` (RGB or RGBA, float or
//!   normalized), which multiplies the base colour.
//! - Materials: the metallic-roughness model (irr-bsdf, the specification's Appendix B):
//!   `baseColorFactor.rgb`, `metallicFactor` and `roughnessFactor` (clamped into [0, 1], with a
//!   warning), and `KHR_materials_specular`'s `specularFactor` (1 without the extension; 0 with
//!   `metallicFactor` 0 makes a Lambertian surface of albedo `baseColorFactor`) and
//!   `KHR_materials_ior`'s `ior` (the dielectric's F0; 1.5 without it) and
//!   `KHR_materials_transmission`'s factor (glass, rendered as a thin sheet that light passes
//!   straight through, or with `KHR_materials_volume`'s thickness above 0 as a volume's
//!   refracting boundary, absorbing by its attenuation colour and distance; its texture's red
//!   channel multiplies the factor: the blur of a rough sheet and the tint of a coloured one
//!   are left out, each with a warning);
//!   `emissiveFactor` times
//!   `KHR_materials_emissive_strength.emissiveStrength` (1 without the extension) is the emitted
//!   radiance in W·sr⁻¹·m⁻²; `doubleSided` says whether a surface emits from both faces or only
//!   from its front face (counter-clockwise winding). A primitive without a material gets glTF's
//!   default material (a white rough metal), with a warning.
//! - `baseColorTexture`, `emissiveTexture`, `metallicRoughnessTexture` and `normalTexture`
//!   (module `textures`): PNG or JPEG images from a `bufferView`, a `data:` URI or a file
//!   inside the asset root, converted from sRGB to linear once (the metallic-roughness and
//!   normal textures are linear data, only scaled to [0, 1]) and multiplied by
//!   `baseColorFactor` / the emission / the metallic (blue) and roughness (green) factors at
//!   shading time (the colour's alpha is read only as coverage, below); their `texCoord`; the sampler's `wrapS`/`wrapT`
//!   (`REPEAT`, `CLAMP_TO_EDGE`, `MIRRORED_REPEAT`) and `magFilter` (`NEAREST`, or `LINEAR`:
//!   bilinear, the default); and `KHR_texture_transform` (offset, rotation, scale, texCoord).
//! - For a normal texture, its `scale` and the primitive's `TANGENT` (world space; the
//!   handedness flips under a mirroring transform), or, without it, MikkTSpace tangents
//!   computed from the normal texture's coordinates (module `mesh`).
//! - `alphaMode` `MASK` (with `alphaCutoff`) and `BLEND`: the coverage α is `baseColorFactor.a`
//!   × the base colour texture's alpha channel (decoded as data) × `COLOR_0`'s alpha; the
//!   integrators trace cut-outs and stochastic transparency (irr-integrator's `Scene::blocks`).
//! - `KHR_materials_unlit`: the base colour (factor × texture × `COLOR_0`, with its coverage)
//!   seen as is by camera rays, met by no other ray (irr-scene's `Material::unlit`); the
//!   material's other factors and textures, the extension's fallbacks, are left unread.
//! - Every perspective camera, in the order of a depth-first walk of the scene's nodes, with its
//!   node's name (the first is the default; `--camera N` picks another).
//! - `KHR_lights_punctual` (lights.rs): every point, spot and directional light that a node of
//!   the scene places, at the node's world position, shining along the node's −Z; `intensity` ×
//!   `color` in candela (point, spot) or lux (directional), taken in the unit of irr's emitted
//!   radiance (no 683 lm/W factor, see irr-integrator's `PunctualLight`); a spot's
//!   `innerConeAngle` and `outerConeAngle` with glTF's smooth falloff.
//!
//! # What irr ignores, always with a warning
//! Occlusion textures (baked occlusion would darken light that a global-illumination renderer
//! already shadows: counted twice), `KHR_materials_specular`'s colour and textures, textures and
//! images no base-colour, emissive, metallic-roughness or normal texture uses, `minFilter` (no mip maps: every lookup uses
//! `magFilter`), vertex colours past
//! `COLOR_0`, morph targets, skins, animation channels that move no camera (module
//! `animation`: those that move a camera's node or a node above it are read), points and lines,
//! orthographic cameras, other
//! scenes, a light's `range` (a non-physical cut-off), lights no node of the scene places, and
//! every extension except `KHR_materials_emissive_strength`, `KHR_materials_ior`,
//! `KHR_materials_specular`, `KHR_materials_transmission`, `KHR_texture_transform`,
//! `KHR_lights_punctual` and `KHR_materials_unlit` (volume, clearcoat, …). A textured material on a
//! primitive without the `TEXCOORD_n` it reads is read at (0, 0). Each becomes one [`Warning`]
//! with a count.
//!
//! # What irr refuses, with a [`LoadError`]
//! Files it cannot read or parse, buffers or images that point nowhere, outside the asset root
//! or are shorter than declared, accessors out of range, indices past the vertex count,
//! non-finite coordinates or coordinates beyond [`MAX_COORDINATE`], non-finite material factors,
//! non-finite texture
//! coordinates or texture transforms, images that are neither PNG nor JPEG, are damaged, or
//! exceed [`MAX_IMAGE_SIDE`] on a side, scenes past their [`MemoryLimit`] (what is loaded, and
//! with [`SceneData::check_memory`] what its BVH will take), accessors without a buffer view
//! past the allowance sized by the files (`files::Budget`), non-finite or negative
//! emission, lights with a non-finite or negative intensity or colour, spot cone angles outside
//! 0 ≤ inner ≤ outer ≤ π/2 (outer > 0), and required extensions it does not support.

mod animation;
mod buffers;
mod instancing;
mod json;
mod lights;
mod materials;
mod mesh;
mod nodes;
#[cfg(test)]
mod tests;
mod textures;

pub use textures::MAX_IMAGE_SIDE;
pub use textures::{attribute_by_id, tex_coords_by_id};
#[cfg(any(test, feature = "testing"))]
pub(crate) use textures::{srgb_to_linear, texture_transform};

use json::{count_extensions, prevalidate, validate};

use crate::camera::{Camera, NamedCamera};
use crate::error::{LoadError, one_line};
use crate::files::{
    Budget, Confinement, LoadOptions, MAX_JSON_BYTES, MemoryLimit, gib, read_scene_file,
};
use crate::glb;
use crate::{Material, PunctualLight, Texture};
use glam::{Vec2, Vec3, Vec4};
use instancing::{PrimitiveKey, Prototypes, bounds_of, corners, material_of, mirrors};
use irr_geometry::{Instance, TriangleMesh};
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

/// The largest coordinate magnitude (metres, after the node transforms) that irr accepts.
///
/// Ray-triangle tests multiply differences of two coordinates (edge vectors, ≤ 2·10¹⁸) by each
/// other; the product, ≤ 4·10³⁶, and a sum of three such terms stay below f32::MAX ≈ 3.4·10³⁸.
/// Beyond this a scene overflows to infinity inside the intersection code.
pub const MAX_COORDINATE: f32 = 1e18;

/// The most bytes a renderer's light sampler holds per emitting triangle (irr-integrator's
/// `LightSampler` is held to it by a test): what [`SceneData::check_memory`] charges for each,
/// placed copies included.
pub const BYTES_PER_EMITTER: u64 = 64;

/// The extensions irr reads.
const SUPPORTED_EXTENSIONS: [&str; 10] = [
    "EXT_mesh_gpu_instancing",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_texture_transform",
    "KHR_lights_punctual",
    "KHR_materials_unlit",
    "KHR_mesh_quantization",
];

/// A feature of the file that irr ignored, with how many times it occurs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Warning {
    /// The scene file.
    pub file: PathBuf,
    /// A short stable key for the feature: `textures`, `occlusion-maps`, `extension:KHR_lights_punctual`…
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
    /// One mesh per primitive drawn once (or drawn mirrored), in world space; `material_ids`
    /// index `materials`.
    pub meshes: Vec<TriangleMesh>,
    /// One mesh per primitive drawn more than once, in its object space: `instances` place
    /// them (see irr-geometry's `Geometry::build_instanced`).
    pub prototypes: Vec<TriangleMesh>,
    /// The draws of the prototypes: each one's transform and material.
    pub instances: Vec<Instance>,
    /// The materials, in the file's order, plus glTF's default material at the end if a
    /// primitive has none.
    pub materials: Vec<Material>,
    /// The textures the materials read (`TextureRef::texture` indexes them): linear RGB.
    pub textures: Vec<Texture>,
    /// The per-triangle arrays below hold one entry per mesh, then one per prototype (whose
    /// tangents are in object space).
    ///
    /// Per mesh, the texture coordinates of its triangles: for triangle t, entries
    /// `t·k..(t+1)·k`, where k is the number of sets its material reads
    /// (`Material::tex_coord_sets`); empty for an untextured material.
    pub tex_coords: Vec<Vec<[Vec2; 3]>>,
    /// Per mesh, the `COLOR_0` colours at its triangles' vertices, one triple per triangle;
    /// empty for a mesh without them.
    pub colours: Vec<Vec<[Vec3; 3]>>,
    /// Per mesh, the `COLOR_0` alphas at its triangles' vertices, one triple per triangle,
    /// which scale the coverage α; empty for a mesh without them or whose alphas are all 1.
    pub alphas: Vec<Vec<[f32; 3]>>,
    /// Per mesh, the world-space tangents at its triangles' vertices (xyz a unit tangent, w
    /// = ±1 the bitangent's sign), one triple per triangle, for a mesh whose material has a
    /// normal texture (the file's `TANGENT`, else MikkTSpace's); empty for the others.
    pub tangents: Vec<Vec<[Vec4; 3]>>,
    /// The file's first perspective camera, if any: `cameras[0]`'s.
    pub camera: Option<Camera>,
    /// Every perspective camera of the default scene, in depth-first order of its nodes.
    pub cameras: Vec<NamedCamera>,
    /// The `KHR_lights_punctual` lights the scene's nodes place, in world space, in the
    /// depth-first order of the nodes.
    pub lights: Vec<PunctualLight>,
    /// Everything irr ignored, one entry per feature.
    pub warnings: Vec<Warning>,
    /// The number of triangles whose material emits (a scene with none, and no light, renders
    /// black under the path tracer unless given a background).
    pub emissive_triangles: usize,
    /// The bounds of every vertex, `None` for a scene without triangles.
    pub bounds: Option<(Vec3, Vec3)>,
    /// An FNV-1a digest of every byte the scene was read from: the scene file, then each
    /// buffer and image file it names, in the order read. Two loads of the same files give the
    /// same digest; a changed byte in any of them gives another.
    pub digest: u64,
    /// The animation channels that move a mesh or a light (its node or a node above it, or its
    /// morph weights): irr renders them in their rest pose, so the scene is not static.
    pub animated_content: usize,
    /// The memory limit it was loaded within, for the checks of what the renderer builds from
    /// it (its BVH).
    pub memory_limit: MemoryLimit,
}

impl SceneData {
    /// The bytes its arrays hold (meshes, texels, per-triangle attributes), counted from their
    /// lengths.
    #[must_use]
    pub fn heap_bytes(&self) -> u64 {
        fn bytes<T>(v: &[T]) -> u64 {
            size_of_val(v) as u64
        }
        let meshes: u64 = self
            .meshes
            .iter()
            .chain(&self.prototypes)
            .map(|m| {
                bytes(&m.positions)
                    + bytes(&m.indices)
                    + bytes(&m.material_ids)
                    + m.normals.as_deref().map_or(0, bytes)
            })
            .sum();
        let texels: u64 = self
            .textures
            .iter()
            .map(|t| u64::from(t.width()) * u64::from(t.height()) * size_of::<Vec3>() as u64)
            .sum();
        meshes
            + bytes(&self.instances)
            + texels
            + self.tex_coords.iter().map(|a| bytes(a)).sum::<u64>()
            + self.colours.iter().map(|a| bytes(a)).sum::<u64>()
            + self.alphas.iter().map(|a| bytes(a)).sum::<u64>()
            + self.tangents.iter().map(|a| bytes(a)).sum::<u64>()
    }

    /// Refuses a scene whose arrays and BVH would not fit its memory limit, before the BVH is
    /// built: its arrays ([`SceneData::heap_bytes`]) plus
    /// [`irr_geometry::BUILT_BYTES_PER_TRIANGLE`] a triangle bound what the build holds at its
    /// peak (it frees the meshes as it goes). Returns that estimate.
    pub fn check_memory(&self) -> Result<u64, LoadError> {
        let triangles: u64 = self
            .meshes
            .iter()
            .chain(&self.prototypes)
            .map(|m| m.indices.len() as u64)
            .sum();
        // The light sampler's arrays: placements can make a small file emit from billions of
        // triangles.
        let loaded = self
            .heap_bytes()
            .saturating_add((self.emissive_triangles as u64).saturating_mul(BYTES_PER_EMITTER));
        let bvh = triangles
            .saturating_mul(irr_geometry::BUILT_BYTES_PER_TRIANGLE)
            .saturating_add(
                (self.instances.len() as u64)
                    .saturating_mul(irr_geometry::BUILT_BYTES_PER_INSTANCE),
            );
        let need = loaded.saturating_add(bvh);
        if need > self.memory_limit.bytes {
            return Err(LoadError::scene(
                &self.path,
                format!(
                    "the scene needs about {} of memory ({} loaded, {} for the BVH of its {triangles} triangles at {} bytes each), past its memory limit of {}",
                    gib(need),
                    gib(loaded),
                    gib(bvh),
                    irr_geometry::BUILT_BYTES_PER_TRIANGLE,
                    self.memory_limit
                ),
            ));
        }
        Ok(need)
    }
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
pub fn load_gltf(path: &Path) -> Result<SceneData, LoadError> {
    load_gltf_with(path, &LoadOptions::default())
}

/// [`load_gltf`] with options: [`LoadOptions::asset_root`] widens (or moves) the folder that
/// buffer URIs may read from.
pub fn load_gltf_with(path: &Path, options: &LoadOptions) -> Result<SceneData, LoadError> {
    let read_error = |problem: String| LoadError::Read {
        path: path.to_path_buf(),
        source: std::io::Error::other(problem),
    };
    let mut bytes = read_scene_file(path).map_err(read_error)?;
    let file_bytes = bytes.len() as u64;
    let confinement = Confinement::new(path, options).map_err(read_error)?;
    confinement.digest_part(&bytes);
    let (json_range, bin_range) = if glb::is_glb(&bytes) {
        let g = glb::parse(&bytes).map_err(|e| LoadError::parse(path, e))?;
        (g.json, g.bin)
    } else {
        (0..bytes.len(), None)
    };
    let json_bytes = bytes.get(json_range).unwrap_or_default();
    if json_bytes.is_empty() {
        return Err(LoadError::parse(path, "the file is empty"));
    }
    if json_bytes.len() > MAX_JSON_BYTES {
        return Err(LoadError::parse(
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
        count_extensions(json_bytes).map_err(|e| LoadError::parse(path, format!("JSON: {e}")))?;
    let root: gltf::json::Root = gltf::json::deserialize::from_slice(json_bytes)
        .map_err(|e| LoadError::parse(path, format!("glTF schema: {e}")))?;
    for ext in &root.extensions_required {
        if !SUPPORTED_EXTENSIONS.contains(&ext.as_str()) {
            return Err(LoadError::scene(
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
        budget: Budget::new(options.memory_limit(), file_bytes),
    }
    .load(extension_counts, blob)
}

struct Loader<'a> {
    path: &'a Path,
    document: &'a gltf::Document,
    warnings: Warnings,
    confinement: Confinement,
    budget: Budget,
}

impl<'a> Loader<'a> {
    fn err(&self, problem: impl std::fmt::Display) -> LoadError {
        LoadError::scene(self.path, problem)
    }

    fn load(
        mut self,
        extension_counts: BTreeMap<String, usize>,
        blob: Option<Vec<u8>>,
    ) -> Result<SceneData, LoadError> {
        let version = &self.document.as_json().asset.version;
        if !version.starts_with("2.") {
            return Err(LoadError::parse(
                self.path,
                format!("asset.version is \"{version}\"; irr reads glTF 2.x"),
            ));
        }
        self.count_extensions(extension_counts);
        self.count_document_features();
        let buffers = self.load_buffers(blob)?;
        let (mut materials, default_material, textures) = self.materials(&buffers)?;
        let mut meshes = Vec::new();
        let camera_nodes = self
            .document
            .nodes()
            .filter(|n| n.camera().is_some())
            .count();
        let mut cameras = self
            .budget
            .vec::<NamedCamera>("the cameras", camera_nodes)
            .map_err(|e| self.err(e))?;
        let mut tex_coords = Vec::new();
        let mut colours = Vec::new();
        let mut tangents = Vec::new();
        let mut alphas = Vec::new();
        let mut used_default_material = 0;
        let mut lights = Vec::new();
        let mut placed = vec![false; self.light_count()];
        let nodes = self.walk_nodes()?;
        // Every node's draws first, to learn which primitives are drawn more than once.
        let mut draws = Vec::with_capacity(nodes.len());
        for (node, world) in &nodes {
            draws.push(match node.mesh() {
                Some(_) => self.instances(node, *world, &buffers)?,
                None => Vec::new(),
            });
        }
        let mut drawn: HashMap<PrimitiveKey, usize> = HashMap::new();
        for ((node, _), transforms) in nodes.iter().zip(&draws) {
            let Some(mesh) = node.mesh() else { continue };
            let unmirrored = transforms.iter().filter(|m| !mirrors(m)).count();
            for primitive in mesh.primitives() {
                let (_, sets, normal_set) = material_of(&primitive, &materials, default_material);
                if let Some(key) = PrimitiveKey::of(&primitive, &sets, normal_set) {
                    *drawn.entry(key).or_default() += unmirrored;
                }
            }
        }
        let mut prototypes = Prototypes::default();
        for ((node, world), transforms) in nodes.into_iter().zip(draws) {
            if let Some(index) = lights::light_index(self.document, &node) {
                lights.push(self.light(&node, world, index)?);
                if let Some(p) = placed.get_mut(index) {
                    *p = true;
                }
            }
            if let Some(cam) = node.camera() {
                match cam.projection() {
                    gltf::camera::Projection::Perspective(p) => cameras.push(NamedCamera {
                        node: node.index(),
                        name: node.name().map(str::to_string),
                        camera: self.camera(&node, world, &p)?,
                        path: None,
                    }),
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
                for world in transforms {
                    for primitive in mesh.primitives() {
                        let file_material = primitive.material().index();
                        let (material_id, sets, normal_set) =
                            material_of(&primitive, &materials, default_material);
                        let key = PrimitiveKey::of(&primitive, &sets, normal_set)
                            .filter(|k| !mirrors(&world) && drawn.get(k).is_some_and(|&n| n > 1));
                        if let Some(key) = key {
                            if self.place(
                                &mut prototypes,
                                key,
                                (&node, &mesh, &primitive),
                                world,
                                (material_id, &sets, normal_set),
                                &buffers,
                            )? {
                                used_default_material += usize::from(file_material.is_none());
                            }
                            continue;
                        }
                        if let Some(p) = self.primitive(
                            &node,
                            &mesh,
                            &primitive,
                            world,
                            (material_id, &sets, normal_set),
                            &buffers,
                        )? {
                            used_default_material += usize::from(file_material.is_none());
                            meshes.push(p.mesh);
                            tex_coords.push(p.tex_coords);
                            colours.push(p.colours);
                            alphas.push(p.alphas);
                            tangents.push(p.tangents);
                        }
                    }
                }
            }
        }
        let Prototypes {
            meshes: prototype_meshes,
            instances,
            tex_coords: prototype_tex_coords,
            colours: prototype_colours,
            alphas: prototype_alphas,
            tangents: prototype_tangents,
            ..
        } = prototypes;
        tex_coords.extend(prototype_tex_coords);
        colours.extend(prototype_colours);
        alphas.extend(prototype_alphas);
        tangents.extend(prototype_tangents);
        if used_default_material > 0 {
            // The specification's default material: base colour 1, metallic 1, roughness 1, a
            // white rough metal, single-sided.
            materials.push(Material {
                two_sided: false,
                ..Material::metallic_roughness(Vec3::ONE, 1.0, 1.0)
            });
            self.warnings.add("default-material", used_default_material, |n| {
                format!(
                    "{} no material: glTF's default material is used (a white rough metal: baseColorFactor 1, metallicFactor 1, roughnessFactor 1)",
                    plural(n, "primitive has", "primitives have")
                )
            });
        }
        let (paths, animated_content) = self.camera_paths(&buffers, &cameras)?;
        for (camera, path) in cameras.iter_mut().zip(paths) {
            camera.path = path;
        }
        if self.document.cameras().len() > 0 && cameras.is_empty() {
            self.warnings.add("unplaced-camera", 1, |_| {
                "no perspective camera is attached to a node of the scene: irr frames the scene's bounds instead".to_string()
            });
        }
        let emits = |id: u32| {
            materials
                .get(id as usize)
                .is_some_and(|m| m.emission.max_element() > 0.0)
        };
        let emissive_triangles = meshes
            .iter()
            .flat_map(|m| m.material_ids.iter())
            .filter(|&&id| emits(id))
            .count()
            + instances
                .iter()
                .filter(|i| i.material_id.is_some_and(emits))
                .map(|i| prototype_meshes[i.prototype as usize].indices.len())
                .sum::<usize>();
        self.count_unplaced_lights(&placed);
        let emitting_lights = lights
            .iter()
            .filter(|l| l.strength().max_element() > 0.0)
            .count();
        if emissive_triangles == 0 && emitting_lights == 0 {
            let unlit = materials.iter().any(|m| m.unlit);
            self.warnings.add("no-emitter", 1, move |_| {
                if unlit {
                    "the scene has no emissive triangles and no lights: only its unlit surfaces (KHR_materials_unlit) and a background will show".to_string()
                } else {
                    "the scene has no emissive triangles and no lights: the image will be black unless lit by a background (ambient occlusion needs no light)".to_string()
                }
            });
        }
        let placed_corners = instances.iter().flat_map(|i| {
            let (lo, hi) = bounds_of(&prototype_meshes[i.prototype as usize]);
            corners(lo, hi).map(|c| i.to_world.transform_point3(c.as_dvec3()).as_vec3())
        });
        let bounds = meshes
            .iter()
            .flat_map(|m| m.positions.iter().copied())
            .chain(placed_corners)
            .fold(None, |acc: Option<(Vec3, Vec3)>, p| {
                Some(match acc {
                    Some((lo, hi)) => (lo.min(p), hi.max(p)),
                    None => (p, p),
                })
            });
        Ok(SceneData {
            path: self.path.to_path_buf(),
            meshes,
            prototypes: prototype_meshes,
            instances,
            materials,
            textures,
            tex_coords,
            colours,
            alphas,
            tangents,
            camera: cameras.first().map(|c| c.camera),
            cameras,
            lights,
            warnings: self.warnings.finish(),
            emissive_triangles,
            bounds,
            digest: self.confinement.digest(),
            animated_content,
            memory_limit: self.budget.limit(),
        })
    }
}

/// `3 "name"` or `3` for an object without a name.
fn describe(index: usize, name: Option<&str>) -> String {
    match name {
        Some(n) => format!("{index} \"{}\"", one_line(n)),
        None => index.to_string(),
    }
}
