//! irr-scene is the scene irr renders, as a file describes it.
//!
//! # What it owns
//! - [`Material`]: glTF 2.0's metallic-roughness material with its emission, coverage α
//!   ([`AlphaMode`]) and the textures it reads ([`TextureRef`]).
//! - [`Texture`] (linear RGB texels with glTF's samplers: [`Wrap`], [`Filter`]) and the
//!   per-triangle attributes textures need: [`TexCoords`], [`VertexColours`],
//!   [`VertexTangents`].
//! - [`PunctualLight`]: `KHR_lights_punctual`'s point, spot and directional lights, and the
//!   light they bring to a point ([`Incidence`]).
//!
//! # What it must not know
//! How light is estimated: no integrator, no BSDF sampling, no ray tracing beyond the
//! triangle meshes it hands irr-geometry.
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

mod material;
mod punctual;
mod texture;

pub use material::{AlphaMode, Material};
pub use punctual::{Incidence, PunctualLight};
pub use texture::{
    Filter, Sampler, TexCoords, Texture, TextureError, TextureRef, TooManyAttributeTriangles,
    TooManyTexCoords, VertexAttribute, VertexColours, VertexTangents, Wrap,
};
