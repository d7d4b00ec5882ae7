//! Sampling the lights: points on the emitting triangles, and the punctual lights.
//!
//! A light sample picks one light with probability proportional to its emitted power (pbrt-v4's
//! `PowerLightSampler`), then, for a triangle, a point uniformly by area on it (pbrt-v4's
//! `Triangle::Sample`). The power of a triangle of area A emitting radiance Le from s sides
//! (1 or 2) is Φ = π·A·s·Le; a punctual light's is [`PunctualLight::power`]; the channels are
//! averaged into one scalar for the choice. Lights of zero power are left out: they light
//! nothing. (For a textured emitter, `Scene` passes Le = the emission factor × the texture's
//! mean: the choice only, the sampled point's radiance is read from the texture.)

use glam::{Vec2, Vec3};
use irr_geometry::Geometry;
use irr_sampling::{sample_uniform_triangle, uniform_triangle_pdf};
use irr_scene::Material;
use irr_scene::PunctualLight;

/// A light chosen by [`LightSampler::sample`].
#[derive(Clone, Copy, Debug)]
pub enum LightSample {
    /// A point on an emitting triangle.
    Area {
        /// The point.
        position: Vec3,
        /// The triangle's winding normal (unit), not flipped.
        normal: Vec3,
        /// The emitting triangle's id.
        triangle: u32,
        /// The point's barycentric coordinate of vertex 1 (an emissive texture is read there).
        b1: f32,
        /// The point's barycentric coordinate of vertex 2.
        b2: f32,
        /// Probability density of choosing this point, per unit area (choice of triangle ×
        /// 1/area).
        pdf_area: f32,
    },
    /// A punctual light (a delta distribution: chosen, never sampled within).
    Punctual {
        /// The light.
        light: PunctualLight,
        /// The probability of choosing it.
        probability: f32,
    },
}

/// The emitting triangles and the punctual lights, with a cumulative distribution by power.
/// Entries `0..triangles.len()` of the distribution are the triangles, the rest the punctual
/// lights in their order.
#[derive(Clone, Debug, Default)]
pub struct LightSampler {
    /// Emitting triangle ids.
    triangles: Vec<u32>,
    /// Their areas.
    areas: Vec<f32>,
    /// Their unit winding normals, computed once here rather than per sample.
    normals: Vec<Vec3>,
    /// The punctual lights of non-zero power.
    punctual: Vec<PunctualLight>,
    /// Probability of choosing each entry.
    probabilities: Vec<f32>,
    /// cdf[i] = probability of choosing one of entries 0..=i; the last entry is exactly 1.
    cdf: Vec<f32>,
    /// For every triangle of a geometry without placements, its index in `triangles`, or
    /// `u32::MAX`; empty with placements, whose ids may number billions: `triangles` (in
    /// increasing id order) is then searched.
    light_of_triangle: Vec<u32>,
}

impl LightSampler {
    /// Collects the emitting triangles of `geometry`.
    pub fn new(geometry: &Geometry, materials: &[Material]) -> Self {
        Self::with_punctual(geometry, materials, &[])
    }

    /// Collects the emitting triangles of `geometry` and the punctual lights `lights`.
    /// Directional lights' power needs the radius of the scene's bounding sphere, taken from the
    /// geometry's core bounds ([`Geometry::core_bounds`]: without a far ground plane, whose
    /// width would give the sun almost every sample; 1 if it has none, e.g. no triangles).
    pub fn with_punctual(
        geometry: &Geometry,
        materials: &[Material],
        lights: &[PunctualLight],
    ) -> Self {
        let dense = geometry.placements().next().is_none();
        let mut s = Self {
            light_of_triangle: if dense {
                vec![u32::MAX; geometry.triangle_count()]
            } else {
                Vec::new()
            },
            ..Self::default()
        };
        let mut powers = Vec::new();
        let emissive = |id: u32| {
            materials
                .get(geometry.material_id(id) as usize)
                .filter(|m| m.is_emissive())
        };
        for id in candidate_emitters(geometry, materials) {
            // The material first: only an emitter's vertices are read back from the BVH.
            let Some(m) = emissive(id) else {
                continue;
            };
            let tri = geometry.triangle(id);
            let area = tri.area();
            if area <= 0.0 || !area.is_finite() {
                continue;
            }
            let sides = if m.two_sided { 2.0 } else { 1.0 };
            let power = std::f64::consts::PI
                * f64::from(area)
                * sides
                * f64::from(m.emission.element_sum())
                / 3.0;
            if dense {
                s.light_of_triangle[id as usize] = s.triangles.len() as u32;
            }
            s.triangles.push(id);
            s.areas.push(area);
            s.normals.push(tri.normal());
            powers.push(power);
        }
        // A directional light lights what the scene is about, not a far ground plane: its
        // power is measured over the core bounds (computed once per geometry, only with one).
        let radius = if lights
            .iter()
            .any(|l| matches!(l, PunctualLight::Directional { .. }))
        {
            let (lo, hi) = geometry.core_bounds();
            let r = 0.5 * f64::from((hi - lo).length());
            if r.is_finite() && r > 0.0 { r } else { 1.0 }
        } else {
            // No light reads it.
            1.0
        };
        for light in lights {
            let power = light.power(radius);
            if power > 0.0 && power.is_finite() {
                s.punctual.push(*light);
                powers.push(power);
            }
        }
        // Accumulate in f64 so that thousands of small emitters do not lose their share.
        let total: f64 = powers.iter().sum();
        let mut running = 0.0f64;
        for p in &powers {
            running += p;
            s.probabilities.push((p / total) as f32);
            s.cdf.push((running / total) as f32);
        }
        if let Some(last) = s.cdf.last_mut() {
            *last = 1.0;
        }
        s
    }

    /// The heap bytes its arrays hold (at most [`irr_scene::BYTES_PER_EMITTER`] an emitting
    /// triangle, beside the table of a geometry without placements: 4 bytes a triangle).
    #[must_use]
    pub fn heap_bytes(&self) -> usize {
        self.triangles.capacity() * size_of::<u32>()
            + self.areas.capacity() * size_of::<f32>()
            + self.normals.capacity() * size_of::<Vec3>()
            + self.punctual.capacity() * size_of::<PunctualLight>()
            + (self.probabilities.capacity() + self.cdf.capacity()) * size_of::<f32>()
            + self.light_of_triangle.capacity() * size_of::<u32>()
    }

    /// Number of lights: emitting triangles plus punctual lights.
    #[inline]
    pub fn len(&self) -> usize {
        self.cdf.len()
    }

    /// Whether the scene has no light.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.cdf.is_empty()
    }

    /// Number of punctual lights (those of non-zero power).
    #[inline]
    pub fn punctual_count(&self) -> usize {
        self.punctual.len()
    }

    /// Chooses a light with `u_choice` ∈ [0, 1) and, for a triangle, a point on it with
    /// `u_point` ∈ [0, 1)² (unused for a punctual light: the caller draws it either way, so the
    /// number of random dimensions per sample never depends on the light chosen).
    pub fn sample(&self, geometry: &Geometry, u_choice: f32, u_point: Vec2) -> Option<LightSample> {
        if self.cdf.is_empty() {
            return None;
        }
        // The first entry whose cumulative probability exceeds u_choice.
        let i = self
            .cdf
            .partition_point(|&c| c <= u_choice)
            .min(self.cdf.len() - 1);
        let Some(&id) = self.triangles.get(i) else {
            return Some(LightSample::Punctual {
                light: self.punctual[i - self.triangles.len()],
                probability: self.probabilities[i],
            });
        };
        let tri = geometry.triangle(id);
        let b = sample_uniform_triangle(u_point);
        // `Triangle::point` keeps the point within half an ulp of the triangle's plane, the
        // accuracy `Ray::spawn_to` assumes when it offsets the shadow ray's end off the light.
        Some(LightSample::Area {
            position: tri.point(b[1], b[2]),
            normal: self.normals[i],
            triangle: id,
            b1: b[1],
            b2: b[2],
            pdf_area: self.probabilities[i] * uniform_triangle_pdf(self.areas[i]),
        })
    }

    /// The probability with which [`Self::sample`] chooses punctual light `index` (in the order
    /// of [`Self::punctual_lights`]); zero past the end.
    #[inline]
    pub fn punctual_probability(&self, index: usize) -> f32 {
        self.probabilities
            .get(self.triangles.len() + index)
            .copied()
            .filter(|_| index < self.punctual.len())
            .unwrap_or(0.0)
    }

    /// The punctual lights the sampler chooses among (those of non-zero power).
    #[inline]
    pub fn punctual_lights(&self) -> &[PunctualLight] {
        &self.punctual
    }

    /// The density per unit area with which [`Self::sample`] picks a point on `triangle`: zero
    /// for a triangle that does not emit.
    #[inline]
    pub fn pdf_area(&self, triangle: u32) -> f32 {
        let i = if self.light_of_triangle.is_empty() {
            self.triangles.binary_search(&triangle).ok()
        } else {
            self.light_of_triangle
                .get(triangle as usize)
                .filter(|&&i| i != u32::MAX)
                .map(|&i| i as usize)
        };
        match i {
            Some(i) => self.probabilities[i] * uniform_triangle_pdf(self.areas[i]),
            None => 0.0,
        }
    }
}

/// The ids that may emit, in increasing order: every world triangle, and the triangles of each
/// placement whose material (its own, or one of its prototype's) emits; a placement of a
/// prototype none of whose materials emit is skipped whole, so a geometry of many placements
/// is not walked id by id.
fn candidate_emitters<'a>(
    geometry: &'a Geometry,
    materials: &'a [Material],
) -> impl Iterator<Item = u32> + 'a {
    let emits = move |id: u32| {
        materials
            .get(geometry.material_id(id) as usize)
            .is_some_and(Material::is_emissive)
    };
    let mut prototype_emits = std::collections::HashMap::new();
    let placed = geometry
        .placements()
        .filter(move |p| {
            let ids = p.first_id..p.first_id + p.count;
            match p.material_id {
                Some(m) => materials.get(m as usize).is_some_and(Material::is_emissive),
                None => *prototype_emits
                    .entry(p.prototype)
                    .or_insert_with(|| ids.clone().any(emits)),
            }
        })
        .flat_map(|p| p.first_id..p.first_id + p.count);
    (0..geometry.world_triangle_count() as u32).chain(placed)
}
