//! What an integrator sees of a scene: the geometry, a glTF metallic-roughness material per id
//! (Lambertian as a special case), the
//! textures those materials read with the texture coordinates of their triangles, the emitters
//! (emitting triangles and punctual lights) with a sampler over them, and the background.

use crate::light::LightSampler;
use crate::path::ShadingPoint;
use glam::{Vec2, Vec3};
use irr_bsdf::MetallicRoughness;
use irr_geometry::{Geometry, Hit, HitFilter, Ray, SurfacePoint};
use irr_scene::{
    AlphaMode, Material, PunctualLight, TexCoords, Texture, TextureRef, VertexAttribute,
    VertexColours, VertexTangents,
};
use thiserror::Error;

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
    /// A material names a texture the scene does not have, or a texture transform that is
    /// not finite.
    #[error("material {index}: its {what} {problem}")]
    InvalidTextureRef {
        /// The material's index.
        index: usize,
        /// `albedo texture`, `emission texture`, `metallic-roughness texture`, `normal texture`
        /// or `alpha texture`.
        what: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// A textured material's triangle lacks texture coordinates, or an untextured one has
    /// some.
    #[error(
        "triangle {triangle} has {found} texture coordinate sets, but its material reads {expected}"
    )]
    TexCoords {
        /// The triangle's id in the geometry.
        triangle: u32,
        /// How many sets its material reads.
        expected: usize,
        /// How many it has.
        found: usize,
    },
    /// The texture coordinates do not cover the geometry's triangles one for one.
    #[error(
        "texture coordinates are given for {found} triangles, but the geometry has {triangles}"
    )]
    TexCoordCount {
        /// The geometry's triangles.
        triangles: usize,
        /// The triangles the texture coordinates cover.
        found: usize,
    },
    /// A material has an albedo, metallic, roughness or specular weight outside [0, 1], or a
    /// negative or non-finite emission (a scalar is reported in all three channels).
    #[error(
        "material {index} has an invalid value: {what} = {value} (albedo, metallic, roughness and specular must lie in [0, 1], emission must be finite and ≥ 0)"
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
    /// Vertex colours that do not cover the geometry's triangles one for one, or a colour
    /// outside [0, 1] or not finite.
    #[error("vertex colours: {problem}")]
    InvalidVertexColours {
        /// What is wrong.
        problem: String,
    },
    /// Vertex tangents that do not cover the geometry's triangles one for one, or a tangent
    /// that is not finite or has a zero direction.
    #[error("vertex tangents: {problem}")]
    InvalidVertexTangents {
        /// What is wrong.
        problem: String,
    },
    /// A background radiance that is negative or not finite.
    #[error("the background radiance {value} must be finite and ≥ 0 in every channel")]
    InvalidBackground {
        /// The offending value.
        value: Vec3,
    },
}

/// Geometry, materials, textures, the emitters and the background: everything an integrator
/// needs.
///
/// [`Scene::new`] makes a scene lit by its emitting triangles alone, with a black background;
/// [`Scene::with_textures`] adds textures, [`Scene::with_lights`] punctual lights and
/// [`Scene::with_background`] a constant background radiance.
#[derive(Debug)]
pub struct Scene {
    geometry: Geometry,
    materials: Vec<Material>,
    textures: Vec<Texture>,
    tex_coords: TexCoords,
    colours: VertexColours,
    tangents: VertexTangents,
    alphas: VertexAttribute<f32>,
    /// Whether some material can cut its surface out ([`Material::can_cut_out`]) or is unlit
    /// (met by camera rays only): rays are then traced with [`Scene::blocks`] as the hit
    /// filter.
    cutouts: bool,
    /// Whether some material is unlit ([`Material::unlit`]): camera rays are then traced with
    /// [`CameraRays`] as the hit filter.
    unlit: bool,
    /// Whether some material bounds an absorbing volume ([`Material::attenuation`]): only then
    /// does [`Scene::segment_transmittance`] look at a segment's material.
    absorbs: bool,
    lights: LightSampler,
    background: Vec3,
}

impl Scene {
    /// Assembles an untextured scene; every triangle's material id must index `materials`,
    /// albedos must lie in [0, 1] (energy conservation) and emission must be finite and
    /// non-negative.
    pub fn new(geometry: Geometry, materials: Vec<Material>) -> Result<Self, SceneError> {
        Self::with_textures(geometry, materials, Vec::new(), TexCoords::default())
    }

    /// [`Scene::new`] with textures: every [`TextureRef`] must index `textures` with a finite
    /// transform, an albedo texture must stay within [0, 1], and `tex_coords` must hold, for
    /// every unique triangle by attribute id (`Geometry::attribute_id`: placed triangles share
    /// their prototype's), one triple per set its material reads
    /// ([`Material::tex_coord_sets`]), or be empty when no material is textured.
    ///
    /// The light sampler chooses a textured emitter by its emission factor × the texture's
    /// mean over the whole image (positive wherever the texture can emit, so every emitting
    /// point keeps a non-zero density); the radiance of a sampled point is the texture's there.
    pub fn with_textures(
        geometry: Geometry,
        materials: Vec<Material>,
        textures: Vec<Texture>,
        tex_coords: TexCoords,
    ) -> Result<Self, SceneError> {
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
            // irr-bsdf's `with_ior` reads 0 as an infinite ior; (0, 1) has no meaning.
            if !(m.ior.is_finite() && (m.ior == 0.0 || m.ior >= 1.0)) {
                return Err(SceneError::InvalidMaterial {
                    index,
                    what: "ior",
                    value: Vec3::splat(m.ior),
                });
            }
            for (what, x) in [
                ("metallic", m.metallic),
                ("roughness", m.roughness),
                ("specular", m.specular),
                ("transmission", m.transmission),
            ] {
                if !(0.0..=1.0).contains(&x) {
                    return Err(SceneError::InvalidMaterial {
                        index,
                        what,
                        value: Vec3::splat(x),
                    });
                }
            }
            if !(m.attenuation.is_finite() && m.attenuation.min_element() >= 0.0) {
                return Err(SceneError::InvalidMaterial {
                    index,
                    what: "attenuation",
                    value: m.attenuation,
                });
            }
            // An unlit surface is its colour to the camera and nothing to any other ray: it
            // cannot emit light for them either.
            if m.unlit && m.is_emissive() {
                return Err(SceneError::InvalidMaterial {
                    index,
                    what: "emission of an unlit material",
                    value: m.emission,
                });
            }
            if !(m.emission.is_finite() && m.emission.min_element() >= 0.0) {
                return Err(SceneError::InvalidMaterial {
                    index,
                    what: "emission",
                    value: m.emission,
                });
            }
            let cutoff = match m.alpha_mode {
                AlphaMode::Mask(c) => c,
                _ => 0.0,
            };
            if !((0.0..=1.0).contains(&m.alpha) && cutoff.is_finite()) {
                return Err(SceneError::InvalidMaterial {
                    index,
                    what: "alpha or alpha cutoff",
                    value: Vec3::new(m.alpha, cutoff, 0.0),
                });
            }
            if !m.normal_scale.is_finite() {
                return Err(SceneError::InvalidMaterial {
                    index,
                    what: "normal scale",
                    value: Vec3::splat(m.normal_scale),
                });
            }
        }
        for id in distinct_triangles(&geometry) {
            let material = geometry.material_id(id);
            if material as usize >= materials.len() {
                return Err(SceneError::MissingMaterial {
                    triangle: id,
                    material,
                    count: materials.len(),
                });
            }
        }
        check_textures(&geometry, &materials, &textures, &tex_coords)?;
        let lights = LightSampler::new(&geometry, &light_weights(&materials, &textures));
        let unlit = materials.iter().any(|m| m.unlit);
        let cutouts = unlit || materials.iter().any(Material::can_cut_out);
        let absorbs = materials.iter().any(Material::absorbs);
        Ok(Self {
            geometry,
            materials,
            textures,
            tex_coords,
            colours: VertexColours::default(),
            tangents: VertexTangents::default(),
            alphas: VertexAttribute::default(),
            cutouts,
            unlit,
            absorbs,
            lights,
            background: Vec3::ZERO,
        })
    }

    /// The diffuse reflectance ρ (the base colour) at barycentrics (b1, b2) of triangle
    /// `triangle`: the material's albedo × its texture there × the triangle's vertex colour
    /// there.
    #[inline]
    pub fn albedo(&self, triangle: u32, b1: f32, b2: f32) -> Vec3 {
        let m = self.material_of(triangle);
        let base = match &m.albedo_texture {
            None => m.albedo,
            Some(t) => m.albedo * self.lookup(triangle, t, b1, b2),
        };
        match self
            .colours
            .at(self.geometry.attribute_id(triangle), b1, b2)
        {
            None => base,
            Some(c) => base * c,
        }
    }

    /// The scene with per-vertex colours (glTF `COLOR_0`), which multiply the base colour:
    /// `colours` must cover every unique triangle by attribute id (or be empty), each colour finite and in
    /// [0, 1] (so the albedo stays in [0, 1]).
    pub fn with_vertex_colours(mut self, colours: VertexColours) -> Result<Self, SceneError> {
        if colours.is_empty() {
            return Ok(self);
        }
        let valid = |c: &Vec3| c.is_finite() && c.min_element() >= 0.0 && c.max_element() <= 1.0;
        self.check_per_vertex(&colours, valid, "is not a colour in [0, 1]")
            .map_err(|problem| SceneError::InvalidVertexColours { problem })?;
        self.colours = colours;
        Ok(self)
    }

    /// The scene with per-vertex tangents (glTF `TANGENT`, world space; a placed triangle's
    /// in its prototype's object space), which orient the normal textures: `tangents` must
    /// cover every unique triangle by attribute id (or be empty), each finite with a non-zero
    /// direction. A triangle of a normal-textured material without tangents shades with its
    /// vertex normals.
    pub fn with_tangents(mut self, tangents: VertexTangents) -> Result<Self, SceneError> {
        if tangents.is_empty() {
            return Ok(self);
        }
        let valid = |t: &glam::Vec4| t.is_finite() && t.truncate() != Vec3::ZERO;
        self.check_per_vertex(&tangents, valid, "is not finite or has no direction")
            .map_err(|problem| SceneError::InvalidVertexTangents { problem })?;
        self.tangents = tangents;
        Ok(self)
    }

    /// Whether `values` covers the geometry's triangles one for one and every value is
    /// `valid`; else what is wrong (`invalid` says what an invalid value is).
    fn check_per_vertex<T>(
        &self,
        values: &VertexAttribute<T>,
        valid: impl Fn(&T) -> bool,
        invalid: &str,
    ) -> Result<(), String>
    where
        T: Copy + std::fmt::Display + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
    {
        if values.triangle_count() != self.geometry.unique_triangle_count() {
            return Err(format!(
                "given for {} triangles, but the geometry has {}",
                values.triangle_count(),
                self.geometry.unique_triangle_count()
            ));
        }
        match values.all().iter().flatten().find(|v| !valid(v)) {
            Some(v) => Err(format!("{v} {invalid}")),
            None => Ok(()),
        }
    }

    /// The shading normal at `surface`: the interpolated vertex normal
    /// ([`SurfacePoint::shading_normal`]), turned by the material's normal texture where it has
    /// one (glTF 2.0 §3.9.3: n = normalize(t·x + b·y + n·z) for the texel's (x, y, z) = (2c −
    /// 1)·(scale, scale, 1), with t the tangent made orthogonal to n and b = w·(n × t)). The
    /// result is a unit vector on the winding normal's side, at least `MIN_COS_TO_GEOMETRY`
    /// above its surface: a texel that would turn it further is clamped there.
    #[inline]
    pub fn shading_normal(&self, surface: &SurfacePoint) -> Vec3 {
        let n = surface.shading_normal;
        if self.tangents.is_empty() {
            return n;
        }
        let (triangle, b1, b2) = (surface.triangle, surface.b1, surface.b2);
        let m = self.material_of(triangle);
        let (Some(texture), Some(tangent)) = (
            &m.normal_texture,
            self.tangents
                .at(self.geometry.attribute_id(triangle), b1, b2),
        ) else {
            return n;
        };
        // A placed triangle's tangents are its prototype's, in object space.
        let tangent = self
            .geometry
            .vector_to_world(triangle, tangent.truncate())
            .extend(tangent.w);
        let c = self.lookup(triangle, texture, b1, b2) * 2.0 - Vec3::ONE;
        let t = tangent.truncate();
        let Some(t) = (t - n * n.dot(t)).try_normalize() else {
            return n;
        };
        let b = n.cross(t) * if tangent.w < 0.0 { -1.0 } else { 1.0 };
        let scale = m.normal_scale;
        let Some(bumped) = (t * (c.x * scale) + b * (c.y * scale) + n * c.z).try_normalize() else {
            return n;
        };
        let ng = surface.geometric_normal;
        let above = bumped.dot(ng);
        if above >= MIN_COS_TO_GEOMETRY {
            return bumped;
        }
        // Below the surface or too close to it: its tangential part, lifted to the limit.
        let tangential = (bumped - ng * above).normalize_or_zero();
        (tangential * (1.0 - MIN_COS_TO_GEOMETRY * MIN_COS_TO_GEOMETRY).sqrt()
            + ng * MIN_COS_TO_GEOMETRY)
            .normalize_or(ng)
    }

    /// `surface` prepared for shading towards `wo`: [`ShadingPoint::new`] with the normal
    /// texture's [`Scene::shading_normal`].
    #[inline(always)]
    pub fn shading_point(&self, surface: &SurfacePoint, wo: Vec3) -> ShadingPoint {
        if self.tangents.is_empty() {
            ShadingPoint::new(surface, wo)
        } else {
            self.bumped_shading_point(surface, wo)
        }
    }

    /// [`Scene::shading_point`] in a scene with normal textures, out of line: inlined, the
    /// normal texture's arithmetic cost the path tracer 2–3 % on scenes without any.
    #[inline(never)]
    fn bumped_shading_point(&self, surface: &SurfacePoint, wo: Vec3) -> ShadingPoint {
        ShadingPoint::new(
            &SurfacePoint {
                shading_normal: self.shading_normal(surface),
                ..*surface
            },
            wo,
        )
    }

    /// The coverage α at barycentrics (b1, b2) of triangle `triangle`: the material's `alpha`
    /// × its alpha texture there × the triangle's vertex alpha there (glTF 2.0 §3.9.4).
    #[inline]
    pub fn alpha(&self, triangle: u32, b1: f32, b2: f32) -> f32 {
        let m = self.material_of(triangle);
        let a = match &m.alpha_texture {
            None => m.alpha,
            Some(t) => m.alpha * self.lookup(triangle, t, b1, b2).x,
        };
        match self.alphas.at(self.geometry.attribute_id(triangle), b1, b2) {
            None => a,
            Some(v) => a * v,
        }
    }

    /// The scene with per-vertex alphas (glTF `COLOR_0`'s fourth component), which multiply
    /// the coverage α: `alphas` must cover every unique triangle by attribute id (or be empty), each in [0, 1].
    pub fn with_vertex_alphas(mut self, alphas: VertexAttribute<f32>) -> Result<Self, SceneError> {
        if alphas.is_empty() {
            return Ok(self);
        }
        self.check_per_vertex(
            &alphas,
            |a| (0.0..=1.0).contains(a),
            "is not an alpha in [0, 1]",
        )
        .map_err(|problem| SceneError::InvalidVertexColours {
            problem: format!("alphas: {problem}"),
        })?;
        self.alphas = alphas;
        // Vertex alphas below 1 can cut any non-opaque material.
        self.cutouts |= self
            .materials
            .iter()
            .any(|m| m.alpha_mode != AlphaMode::Opaque);
        Ok(self)
    }

    /// Whether `hit` stops `ray`: always on an opaque material; on a cut-out where α reaches
    /// the cutoff; on a blend with probability α, decided by a hash of the ray and the
    /// triangle ([`coverage_sample`]), so that the same ray always gets the same answer, in
    /// any thread.
    /// An unlit surface stops no ray but a camera ray ([`Scene::intersect_camera`]).
    #[inline]
    pub fn blocks(&self, ray: &Ray, hit: &Hit) -> bool {
        !self.material_of(hit.triangle).unlit && self.covers(ray, hit)
    }

    /// Whether the coverage α of `hit`'s surface stops `ray` ([`Scene::blocks`] without the
    /// unlit surfaces' exception).
    /// Glass ([`Material::transmits`]) lets the ray pass with
    /// [`Scene::pass_probability`], decided by another hash of the ray and the triangle.
    #[inline]
    fn covers(&self, ray: &Ray, hit: &Hit) -> bool {
        let m = self.material_of(hit.triangle);
        let covered = match m.alpha_mode {
            AlphaMode::Opaque => true,
            AlphaMode::Mask(cutoff) => self.alpha(hit.triangle, hit.b1, hit.b2) >= cutoff,
            AlphaMode::Blend => {
                let a = self.alpha(hit.triangle, hit.b1, hit.b2);
                a >= 1.0 || (a > 0.0 && coverage_sample(ray, hit.triangle) < a)
            }
        };
        covered
            && !(m.passes_straight()
                && pass_sample(ray, hit.triangle)
                    < self.pass_probability(hit.triangle, hit.b1, hit.b2, ray.direction))
    }

    /// What light keeps over the segment that leaves the surface point `x` along `wi` and meets
    /// the next surface at `distance` (`None`: it leaves the scene): Beer–Lambert's e^(−σ·d)
    /// where the segment runs inside the volume that `x`'s refracting material bounds (`wi`
    /// against its outward, winding normal) and absorbs ([`Material::attenuation`]); 1
    /// elsewhere. Volumes are taken as closed and not nested: the medium is the one whose
    /// boundary the segment leaves.
    #[inline]
    pub fn segment_transmittance(&self, x: &ShadingPoint, wi: Vec3, distance: Option<f32>) -> Vec3 {
        if !self.absorbs {
            return Vec3::ONE;
        }
        let m = self.material_of(x.triangle);
        if !m.absorbs() {
            return Vec3::ONE;
        }
        if wi.dot(self.geometry.geometric_normal(x.triangle)) >= 0.0 {
            return Vec3::ONE;
        }
        let d = distance.unwrap_or(f32::INFINITY);
        // σ·d = 0·∞ (a clear channel of an open mesh) keeps everything.
        Vec3::from_array(
            m.attenuation
                .to_array()
                .map(|s| if s == 0.0 { 1.0 } else { (-s * d).exp() }),
        )
    }

    /// The probability with which a ray along `direction` passes straight through the glass
    /// at barycentrics (b1, b2) of triangle `triangle` ([`Material::passes_straight`]; 0 for
    /// any other material, a volume's refracting boundary included): the mean over the colour channels of the sheet's straight
    /// transmittance τ (1 − F)/(1 + F) at the ray's angle to the winding normal (irr-bsdf's
    /// `sheet_transmittance`), τ the base colour × transmission × (1 − metallic).
    ///
    /// A ray stopped there meets the sheet's reflection divided by the probability of
    /// stopping (`Bsdf::at`), so the pair is unbiased: for a grey base colour exactly what a
    /// smooth thin pane transmits and reflects, shadow rays and the light cache's paths
    /// included. A coloured base colour's hue is not given to the light passing through (the
    /// loader warns): a ray either passes or not, and carries no tint.
    #[inline]
    pub fn pass_probability(&self, triangle: u32, b1: f32, b2: f32, direction: Vec3) -> f32 {
        if !self.material_of(triangle).passes_straight() {
            return 0.0;
        }
        let ng = self.geometry.geometric_normal(triangle);
        let cos = direction.dot(ng).abs() / direction.length();
        let t = self.reflection(triangle, b1, b2).sheet_transmittance(cos);
        (t.x + t.y + t.z) / 3.0
    }

    /// The radiance a light sample takes from barycentrics (b1, b2) of emitting triangle
    /// `triangle` towards `wo` ([`Scene::emitted`]), times the share of it that next-event
    /// estimation takes in a scene with cut-outs: 0 or 1 on a cut-out (nothing from where it is
    /// cut away), α on a blend (a ray that meets it does so with probability α, and then takes
    /// its whole emission).
    #[inline(always)]
    pub fn emitted_to_light_sample(
        &self,
        triangle: u32,
        (b1, b2): (f32, f32),
        ng: Vec3,
        wo: Vec3,
    ) -> Vec3 {
        let le = self.emitted(triangle, b1, b2, ng, wo);
        if self.cutouts {
            le * self.emitter_coverage(triangle, b1, b2)
        } else {
            le
        }
    }

    /// The share of [`Scene::emitted_to_light_sample`]; out of line, so that a scene without
    /// cut-outs keeps its light sampling as it was.
    #[cold]
    #[inline(never)]
    fn emitter_coverage(&self, triangle: u32, b1: f32, b2: f32) -> f32 {
        match self.material_of(triangle).alpha_mode {
            AlphaMode::Opaque => 1.0,
            AlphaMode::Mask(cutoff) => f32::from(u8::from(self.alpha(triangle, b1, b2) >= cutoff)),
            AlphaMode::Blend => self.alpha(triangle, b1, b2),
        }
    }

    /// The closest hit of a camera ray `ray`: as [`Scene::intersect`], and an unlit surface
    /// ([`Material::unlit`]) where its coverage and side let the camera see it (from its front
    /// only when single-sided, as glTF viewers cull its back).
    #[inline]
    pub fn intersect_camera(&self, ray: &Ray) -> Option<Hit> {
        if self.unlit {
            self.geometry.intersect_filtered(ray, &CameraRays(self))
        } else {
            self.intersect(ray)
        }
    }

    /// Whether triangle `triangle`'s material is unlit ([`Material::unlit`]).
    #[inline]
    pub fn is_unlit(&self, triangle: u32) -> bool {
        self.unlit && self.material_of(triangle).unlit
    }

    /// The closest hit of `ray` that [`Scene::blocks`] it (every hit, in a scene without
    /// cut-outs).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if self.cutouts {
            self.intersect_cut(ray)
        } else {
            self.geometry.intersect(ray)
        }
    }

    /// Whether anything [`Scene::blocks`] `ray` before its end.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        if self.cutouts {
            self.occluded_cut(ray)
        } else {
            self.geometry.occluded(ray)
        }
    }

    /// [`Scene::intersect`] for a coherent batch (irr-geometry's `intersect_many`).
    pub fn intersect_many(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        if self.cutouts {
            self.intersect_many_cut(rays, hits);
        } else {
            self.geometry.intersect_many(rays, hits);
        }
    }

    /// [`Scene::intersect`] for incoherent rays (irr-geometry's `intersect_stream`).
    pub fn intersect_stream(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        if self.cutouts {
            self.intersect_stream_cut(rays, hits);
        } else {
            self.geometry.intersect_stream(rays, hits);
        }
    }

    /// [`Scene::occluded`] for incoherent rays (irr-geometry's `occluded_stream`).
    pub fn occluded_stream(&self, rays: &[Ray], occluded: &mut [bool]) {
        if self.cutouts {
            self.occluded_stream_cut(rays, occluded);
        } else {
            self.geometry.occluded_stream(rays, occluded);
        }
    }

    // The filtered queries, out of line: a scene without cut-outs keeps its hot loops as they
    // were (inlined, the filtered traversal made the path tracer 3 % slower on the Cornell box).
    #[cold]
    #[inline(never)]
    fn intersect_cut(&self, ray: &Ray) -> Option<Hit> {
        self.geometry.intersect_filtered(ray, self)
    }

    #[cold]
    #[inline(never)]
    fn occluded_cut(&self, ray: &Ray) -> bool {
        self.geometry.occluded_filtered(ray, self)
    }

    #[cold]
    #[inline(never)]
    fn intersect_many_cut(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        self.geometry.intersect_many_filtered(rays, hits, self);
    }

    #[cold]
    #[inline(never)]
    fn intersect_stream_cut(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        self.geometry.intersect_stream_filtered(rays, hits, self);
    }

    #[cold]
    #[inline(never)]
    fn occluded_stream_cut(&self, rays: &[Ray], occluded: &mut [bool]) {
        self.geometry.occluded_stream_filtered(rays, occluded, self);
    }

    /// The metallic factor and the roughness at barycentrics (b1, b2) of triangle `triangle`:
    /// the material's factors × the blue and green channels of its metallic-roughness texture
    /// there.
    #[inline]
    pub fn metallic_roughness(&self, triangle: u32, b1: f32, b2: f32) -> (f32, f32) {
        let m = self.material_of(triangle);
        match &m.metallic_roughness_texture {
            None => (m.metallic, m.roughness),
            Some(t) => {
                let v = self.lookup(triangle, t, b1, b2);
                (m.metallic * v.z, m.roughness * v.y)
            }
        }
    }

    /// The transmission factor at barycentrics (b1, b2) of triangle `triangle`: the material's
    /// factor × the red channel of its transmission texture there.
    #[inline]
    pub fn transmission(&self, triangle: u32, b1: f32, b2: f32) -> f32 {
        let m = self.material_of(triangle);
        match &m.transmission_texture {
            None => m.transmission,
            Some(t) => m.transmission * self.lookup(triangle, t, b1, b2).x,
        }
    }

    /// The reflection at barycentrics (b1, b2) of triangle `triangle`: its material's
    /// metallic-roughness parameters (textured: [`Scene::metallic_roughness`]) with the
    /// (textured) [`Scene::albedo`] as base colour, and its (textured) transmission.
    #[inline]
    pub fn reflection(&self, triangle: u32, b1: f32, b2: f32) -> MetallicRoughness {
        let (metallic, roughness) = self.metallic_roughness(triangle, b1, b2);
        let material = self.material_of(triangle);
        let reflection = MetallicRoughness::with_specular(
            self.albedo(triangle, b1, b2),
            metallic,
            roughness,
            material.specular,
        )
        .with_ior(material.ior);
        if material.passes_straight() {
            reflection
                .with_transmission(self.transmission(triangle, b1, b2), true)
                .with_straight_transmission()
        } else if material.refracts() {
            reflection.with_transmission(self.transmission(triangle, b1, b2), false)
        } else {
            reflection
        }
    }

    /// Radiance emitted from barycentrics (b1, b2) of triangle `triangle`, whose geometric
    /// normal is `ng` (the winding normal), towards `wo`: the material's emission × its
    /// emissive texture there, on the sides it emits from.
    #[inline]
    pub fn emitted(&self, triangle: u32, b1: f32, b2: f32, ng: Vec3, wo: Vec3) -> Vec3 {
        let m = self.material_of(triangle);
        if !m.emits_towards(ng, wo) {
            return Vec3::ZERO;
        }
        match &m.emission_texture {
            None => m.emission,
            Some(t) => m.emission * self.lookup(triangle, t, b1, b2),
        }
    }

    /// [`Scene::emitted`] at a surface point (its triangle, barycentrics and winding normal),
    /// towards `wo`.
    #[inline]
    pub fn emitted_at(&self, surface: &SurfacePoint, wo: Vec3) -> Vec3 {
        self.emitted(
            surface.triangle,
            surface.b1,
            surface.b2,
            surface.geometric_normal,
            wo,
        )
    }

    /// The coordinate at which `texture`, read by the material of `triangle`, is looked up at
    /// barycentrics (b1, b2): the interpolated coordinate of its set, then its transform.
    #[inline]
    pub fn tex_coord(&self, triangle: u32, texture: &TextureRef, b1: f32, b2: f32) -> Vec2 {
        let m = self.material_of(triangle);
        let uv = self.tex_coords.at(
            self.geometry.attribute_id(triangle),
            m.slot(texture),
            b1,
            b2,
        );
        texture.transform.transform_point2(uv)
    }

    #[inline]
    fn lookup(&self, triangle: u32, t: &TextureRef, b1: f32, b2: f32) -> Vec3 {
        self.textures[t.texture as usize].lookup(self.tex_coord(triangle, t, b1, b2))
    }

    /// The textures, indexed by [`TextureRef::texture`].
    #[inline]
    pub fn textures(&self) -> &[Texture] {
        &self.textures
    }

    /// The texture coordinates of the triangles of textured materials.
    #[inline]
    pub fn tex_coords(&self) -> &TexCoords {
        &self.tex_coords
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
        self.lights = LightSampler::with_punctual(
            &self.geometry,
            &light_weights(&self.materials, &self.textures),
            &lights,
        );
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
        &self.materials[self.geometry.material_id(triangle) as usize]
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

/// The scene's surfaces as a camera ray sees them ([`Scene::intersect_camera`]): unlit surfaces
/// too, where their coverage and side let it.
struct CameraRays<'a>(&'a Scene);

impl HitFilter for CameraRays<'_> {
    #[inline]
    fn accept(&self, ray: &Ray, hit: &Hit) -> bool {
        let scene = self.0;
        let m = scene.material_of(hit.triangle);
        if !m.unlit {
            return scene.blocks(ray, hit);
        }
        let front = m.two_sided
            || scene
                .geometry
                .triangle(hit.triangle)
                .normal()
                .dot(ray.direction)
                < 0.0;
        front && scene.covers(ray, hit)
    }
}

/// The scene's surfaces as irr-geometry sees them: a hit counts where it [`Scene::blocks`] the
/// ray.
impl HitFilter for Scene {
    #[inline]
    fn accept(&self, ray: &Ray, hit: &Hit) -> bool {
        self.blocks(ray, hit)
    }
}

/// A uniform number in [0, 1) that depends only on the ray's bits and the triangle: the
/// choice of stochastic transparency ([`AlphaMode::Blend`]). Rays of different samples differ
/// in their origin or direction, so their choices are independent; one ray asked twice gets
/// one answer.
#[inline]
pub fn coverage_sample(ray: &Ray, triangle: u32) -> f32 {
    ray_sample(ray, u64::from(triangle))
}

/// [`coverage_sample`]'s number for glass ([`Scene::pass_probability`]), independent of it (a
/// material may both blend and transmit).
#[inline]
pub fn pass_sample(ray: &Ray, triangle: u32) -> f32 {
    ray_sample(ray, u64::from(triangle) | 1 << 32)
}

/// A uniform number in [0, 1) from the ray's bits and `key`.
#[inline]
fn ray_sample(ray: &Ray, key: u64) -> f32 {
    let bits = |a: f32, b: f32| (u64::from(a.to_bits()) << 32) | u64::from(b.to_bits());
    let (o, d) = (ray.origin, ray.direction);
    let key = irr_sampling::rng::hash_keys(&[bits(o.x, o.y), bits(o.z, d.x), bits(d.y, d.z), key]);
    irr_sampling::rng::bits_to_unit_f32((key >> 32) as u32)
}

/// The least cosine between a normal-textured shading normal and the winding normal
/// ([`Scene::shading_normal`]): a shading normal at or below the surface would leave no
/// direction that is above both, so no light at all; 0.01 (89.4°) keeps every texel's
/// tilt but the extreme ones.
pub const MIN_COS_TO_GEOMETRY: f32 = 0.01;

/// The materials as the light sampler weighs them, by their `emission`: for a textured
/// emitter, the factor × the texture's mean (every [`TextureRef`] checked to be in range).
fn light_weights(materials: &[Material], textures: &[Texture]) -> Vec<Material> {
    materials
        .iter()
        .map(|m| match m.emission_texture {
            Some(t) => Material {
                emission: m.emission * textures[t.texture as usize].mean(),
                ..*m
            },
            None => *m,
        })
        .collect()
}

/// The checks of [`Scene::with_textures`] on textures and texture coordinates.
fn check_textures(
    geometry: &Geometry,
    materials: &[Material],
    textures: &[Texture],
    tex_coords: &TexCoords,
) -> Result<(), SceneError> {
    let mut textured = false;
    for (index, m) in materials.iter().enumerate() {
        for (what, r) in [
            ("albedo texture", m.albedo_texture),
            ("emission texture", m.emission_texture),
            ("metallic-roughness texture", m.metallic_roughness_texture),
            ("normal texture", m.normal_texture),
            ("alpha texture", m.alpha_texture),
            ("transmission texture", m.transmission_texture),
        ] {
            let Some(r) = r else { continue };
            textured = true;
            let problem = match textures.get(r.texture as usize) {
                None => Some(format!(
                    "is texture {}, but the scene has {} textures",
                    r.texture,
                    textures.len()
                )),
                Some(_) if !r.transform.is_finite() => {
                    Some("has a texture transform that is not finite".to_string())
                }
                Some(t) if what != "emission texture" && t.max_value() > 1.0 => Some(format!(
                    "has a texel of {} (albedo, metallic, roughness, normal and alpha texels must lie in [0, 1])",
                    t.max_value()
                )),
                Some(_) => None,
            };
            if let Some(problem) = problem {
                return Err(SceneError::InvalidTextureRef {
                    index,
                    what,
                    problem,
                });
            }
        }
    }
    if !textured && tex_coords.is_empty() {
        return Ok(());
    }
    if tex_coords.triangle_count() != geometry.unique_triangle_count() {
        return Err(SceneError::TexCoordCount {
            triangles: geometry.unique_triangle_count(),
            found: tex_coords.triangle_count(),
        });
    }
    for triangle in distinct_triangles(geometry) {
        let m = &materials[geometry.material_id(triangle) as usize];
        let expected = m.tex_coord_sets().count();
        let found = tex_coords.of(geometry.attribute_id(triangle)).len();
        if found != expected {
            return Err(SceneError::TexCoords {
                triangle,
                expected,
                found,
            });
        }
    }
    Ok(())
}

/// The ids of a triangle of every distinct (per-vertex data, material) pair: every world
/// triangle, and of the placements, each prototype's triangles once per material it is placed
/// with (a placement of the prototype's own materials, or of one of its own), in id order. What
/// a check of every triangle's material and per-vertex data needs to look at, however many times
/// the prototypes are placed.
pub(crate) fn distinct_triangles(geometry: &Geometry) -> impl Iterator<Item = u32> + '_ {
    let mut seen = std::collections::HashSet::new();
    let placed = geometry
        .placements()
        .filter(move |p| seen.insert((p.prototype, p.material_id)))
        .flat_map(|p| p.first_id..p.first_id + p.count);
    (0..geometry.world_triangle_count() as u32).chain(placed)
}
