//! irr-scene is the scene irr renders, as a file describes it.
//!
//! # What it owns
//! - [`load_gltf`]: glTF 2.0 (`.gltf` with external or `data:` buffers, `.glb`) into
//!   world-space triangle meshes, and prototypes with their placements for what is drawn more
//!   than once ([`SceneData`]), with metallic-roughness materials, their
//!   base-colour, emissive, metallic-roughness, normal and alpha textures (PNG and JPEG images,
//!   decoded to linear RGB here) and vertex colours, `KHR_lights_punctual` lights and the file's
//!   cameras; every ignored feature becomes a [`Warning`] with a count, every unreadable input
//!   a one-line [`LoadError`]. The file is untrusted: it reads nothing outside its folder (or
//!   [`LoadOptions::asset_root`]) and sizes no allocation beyond its budget (`files.rs`).
//! - [`Camera`]: glTF's pinhole and orthographic cameras (look down local −Z), or a default one
//!   framing the scene; [`animation`]: the node animations that move cameras.
//! - [`Material`]: glTF 2.0's metallic-roughness material with its emission, coverage α
//!   ([`AlphaMode`]) and the textures it reads ([`TextureRef`]).
//! - [`Texture`] (linear RGB texels with glTF's samplers: [`Wrap`], [`Filter`]) and the
//!   per-triangle attributes textures need: [`TexCoords`], [`VertexColours`],
//!   [`VertexTangents`].
//! - [`PunctualLight`]: `KHR_lights_punctual`'s point, spot and directional lights, and the
//!   light they bring to a point ([`Incidence`]).
//!
//! # What it must not know
//! How light is estimated: no integrator, no BSDF, no BVH. It hands irr-geometry plain
//! triangle meshes; assembling them into a scene to trace is irr-integrator's `Scene` (and
//! irr-render's `load_scene`).
//!
//! # Example
//! ```
//! use glam::Vec3;
//! use irr_scene::Material;
//!
//! // A Lambertian grey: f = albedo/π, no emission, nothing cut out.
//! let grey = Material::diffuse(Vec3::splat(0.5));
//! assert!(grey.is_lambertian() && !grey.is_emissive() && !grey.can_cut_out());
//! ```

mod accessor;
pub mod animation;
mod camera;
mod digest;
mod error;
mod files;
mod glb;
mod load;
mod material;
mod punctual;
#[cfg(any(test, feature = "testing"))]
pub mod testutil;
mod texture;
mod uri;

pub use camera::{Camera, CameraRay, NamedCamera, Projection};
pub use digest::Fnv;
pub use error::{LoadError, is_unprintable, one_line};
pub use files::{
    LimitSource, LoadOptions, MAX_JSON_BYTES, MAX_SCENE_BYTES, MemoryLimit, gib, machine_memory,
    open_regular, read_prefix,
};
pub use load::{
    BYTES_PER_EMITTER, MAX_COORDINATE, MAX_IMAGE_SIDE, SceneData, Warning, attribute_by_id,
    load_gltf, load_gltf_with, tex_coords_by_id,
};

pub use material::{AlphaMode, Material};
pub use punctual::{Incidence, PunctualLight};
pub use texture::{
    Filter, Sampler, TexCoords, Texture, TextureError, TextureRef, TooManyAttributeTriangles,
    TooManyTexCoords, VertexAttribute, VertexColours, VertexTangents, Wrap,
};
