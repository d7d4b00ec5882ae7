//! What an integrator sees of a scene: the geometry, a Lambertian material per id, and the
//! emitters with a sampler over them.

use crate::light::LightSampler;
use glam::Vec3;
use irr_geometry::Geometry;
use thiserror::Error;

/// A Lambertian surface that may also emit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Diffuse reflectance ρ per channel, in [0, 1] (glTF `baseColorFactor.rgb`, linear).
    pub albedo: Vec3,
    /// Emitted radiance Le in W·sr⁻¹·m⁻² per channel, the same in every direction of an emitting
    /// side (glTF `emissiveFactor` × `KHR_materials_emissive_strength.emissiveStrength`).
    pub emission: Vec3,
    /// glTF `doubleSided`: emits from both faces when true, otherwise only from the front face,
    /// the side that the counter-clockwise winding normal (p1−p0)×(p2−p0) points to. Reflection
    /// is two-sided either way.
    pub two_sided: bool,
}

impl Material {
    /// A non-emitting diffuse material.
    pub fn diffuse(albedo: Vec3) -> Self {
        Self {
            albedo,
            emission: Vec3::ZERO,
            two_sided: true,
        }
    }

    /// Whether the material emits at all.
    #[inline]
    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// Radiance emitted from a point with geometric normal `ng` (the winding normal) towards `wo`.
    #[inline]
    pub fn emitted(&self, ng: Vec3, wo: Vec3) -> Vec3 {
        if self.two_sided || ng.dot(wo) > 0.0 {
            self.emission
        } else {
            Vec3::ZERO
        }
    }
}

/// A scene that cannot be assembled.
#[derive(Debug, Error, PartialEq)]
pub enum SceneError {
    /// A triangle names a material the scene does not have.
    #[error("triangle {triangle} uses material {material}, but the scene has {count} materials")]
    MissingMaterial {
        /// The triangle's id in the geometry.
        triangle: u32,
        /// The material id it names.
        material: u32,
        /// How many materials there are.
        count: usize,
    },
    /// A material has a negative or non-finite albedo or emission.
    #[error(
        "material {index} has an invalid value: {what} = {value} (albedo must lie in [0, 1], emission must be finite and ≥ 0)"
    )]
    InvalidMaterial {
        /// The material's index.
        index: usize,
        /// Which field.
        what: &'static str,
        /// The offending value.
        value: Vec3,
    },
}

/// Geometry, materials and the emitters: everything an integrator needs.
#[derive(Debug)]
pub struct Scene {
    geometry: Geometry,
    materials: Vec<Material>,
    lights: LightSampler,
}

impl Scene {
    /// Assembles a scene; every triangle's material id must index `materials`, albedos must lie in
    /// [0, 1] (energy conservation) and emission must be finite and non-negative.
    pub fn new(geometry: Geometry, materials: Vec<Material>) -> Result<Self, SceneError> {
        for (index, m) in materials.iter().enumerate() {
            let valid_albedo = m.albedo.is_finite()
                && m.albedo.min_element() >= 0.0
                && m.albedo.max_element() <= 1.0;
            if !valid_albedo {
                return Err(SceneError::InvalidMaterial {
                    index,
                    what: "albedo",
                    value: m.albedo,
                });
            }
            if !(m.emission.is_finite() && m.emission.min_element() >= 0.0) {
                return Err(SceneError::InvalidMaterial {
                    index,
                    what: "emission",
                    value: m.emission,
                });
            }
        }
        for id in 0..geometry.triangle_count() as u32 {
            let material = geometry.triangle(id).material_id;
            if material as usize >= materials.len() {
                return Err(SceneError::MissingMaterial {
                    triangle: id,
                    material,
                    count: materials.len(),
                });
            }
        }
        let lights = LightSampler::new(&geometry, &materials);
        Ok(Self {
            geometry,
            materials,
            lights,
        })
    }

    /// The triangles and their BVH.
    #[inline]
    pub fn geometry(&self) -> &Geometry {
        &self.geometry
    }

    /// The materials, indexed by a triangle's material id.
    #[inline]
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// The material of triangle `triangle`.
    #[inline]
    pub fn material_of(&self, triangle: u32) -> &Material {
        &self.materials[self.geometry.triangle(triangle).material_id as usize]
    }

    /// The sampler over the emitting triangles.
    #[inline]
    pub fn lights(&self) -> &LightSampler {
        &self.lights
    }

    /// Number of emitting triangles; zero means every image of the scene is black.
    #[inline]
    pub fn emitter_count(&self) -> usize {
        self.lights.len()
    }
}
