//! What an integrator sees of a scene: the geometry, a Lambertian material per id, the
//! emitters (emitting triangles and punctual lights) with a sampler over them, and the
//! background.

use crate::light::LightSampler;
use crate::punctual::PunctualLight;
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
    /// A punctual light that cannot be rendered (see [`PunctualLight::problem`]).
    #[error("punctual light {index}: {problem}")]
    InvalidLight {
        /// The light's index in the list given to [`Scene::with_lights`].
        index: usize,
        /// What is wrong with it.
        problem: String,
    },
    /// A background radiance that is negative or not finite.
    #[error("the background radiance {value} must be finite and ≥ 0 in every channel")]
    InvalidBackground {
        /// The offending value.
        value: Vec3,
    },
}

/// Geometry, materials, the emitters and the background: everything an integrator needs.
///
/// [`Scene::new`] makes a scene lit by its emitting triangles alone, with a black background;
/// [`Scene::with_lights`] adds punctual lights and [`Scene::with_background`] a constant
/// background radiance.
#[derive(Debug)]
pub struct Scene {
    geometry: Geometry,
    materials: Vec<Material>,
    lights: LightSampler,
    background: Vec3,
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
            background: Vec3::ZERO,
        })
    }

    /// The scene lit also by `lights` (replacing any given before), which join the emitting
    /// triangles in next-event estimation, chosen by power. Refuses a light with a non-finite
    /// position, a direction that is not a unit vector, a negative or non-finite strength, or
    /// spot cosines out of range (see [`PunctualLight::problem`]).
    pub fn with_lights(mut self, lights: Vec<PunctualLight>) -> Result<Self, SceneError> {
        for (index, light) in lights.iter().enumerate() {
            if let Some(problem) = light.problem() {
                return Err(SceneError::InvalidLight { index, problem });
            }
        }
        self.lights = LightSampler::with_punctual(&self.geometry, &self.materials, &lights);
        Ok(self)
    }

    /// The scene with a constant background radiance (W·sr⁻¹·m⁻² per channel; black by
    /// default), seen by every ray that leaves the scene. Refuses a negative or non-finite value.
    pub fn with_background(mut self, radiance: Vec3) -> Result<Self, SceneError> {
        if !(radiance.is_finite() && radiance.min_element() >= 0.0) {
            return Err(SceneError::InvalidBackground { value: radiance });
        }
        self.background = radiance;
        Ok(self)
    }

    /// The radiance of every direction in which a ray leaves the scene (black by default).
    #[inline]
    pub fn background(&self) -> Vec3 {
        self.background
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

    /// The sampler over the emitting triangles and the punctual lights.
    #[inline]
    pub fn lights(&self) -> &LightSampler {
        &self.lights
    }

    /// Number of lights (emitting triangles plus punctual lights of non-zero power); zero with
    /// a black background means every image of the scene is black.
    #[inline]
    pub fn emitter_count(&self) -> usize {
        self.lights.len()
    }
}
