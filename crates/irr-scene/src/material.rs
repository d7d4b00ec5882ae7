//! A surface's material: glTF 2.0's metallic-roughness reflection, its emission, its coverage α
//! and the textures it reads.

use crate::texture::TextureRef;
use glam::Vec3;

/// A surface's reflection (glTF 2.0's metallic-roughness model, irr-bsdf's
/// `MetallicRoughness`) and emission.
///
/// With `metallic` 0 and `specular` 0 the reflection is exactly Lambertian, f = albedo/π
/// ([`Material::diffuse`]); glTF files get the specification's defaults (specular 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// The base colour per channel, in [0, 1] (glTF `baseColorFactor.rgb`, linear): the
    /// diffuse reflectance ρ of a Lambertian material, a metal's reflectance at normal incidence.
    pub albedo: Vec3,
    /// glTF `metallicFactor`, in [0, 1]: 0 a dielectric (a diffuse base under a GGX specular
    /// coat), 1 a metal, mixed linearly between.
    pub metallic: f32,
    /// glTF `roughnessFactor`, in [0, 1]: the GGX width is α = roughness² (at least
    /// irr-bsdf's `MIN_ALPHA`).
    pub roughness: f32,
    /// `KHR_materials_specular`'s `specularFactor`, in [0, 1]: the dielectric's specular weight
    /// (1 without the extension; 0 leaves the dielectric Lambertian).
    pub specular: f32,
    /// `KHR_materials_ior`'s `ior`: the dielectric's index of refraction, which sets its
    /// specular reflectance at normal incidence F0 = ((ior − 1)/(ior + 1))² (0.04 at the
    /// default 1.5); 0 stands for an infinite ior (F0 = 1), as the extension allows. At least
    /// 1 otherwise, and finite.
    pub ior: f32,
    /// `KHR_materials_transmission`'s `transmissionFactor`, in [0, 1]: the share of the
    /// dielectric's base that transmits light instead of reflecting it diffusely (glass). A
    /// thin sheet ([`Material::thin_walled`]) lets its transmitted light pass straight through
    /// ([`Material::passes_straight`]; irr-bsdf's `with_straight_transmission`); a volume's
    /// boundary refracts it (irr-bsdf's rough dielectric BTDF). 0: opaque.
    pub transmission: f32,
    /// Whether a transmitting material is a thin sheet (glTF's default) rather than the
    /// boundary of a volume (`KHR_materials_volume` with a thickness above 0), which refracts.
    pub thin_walled: bool,
    /// The absorption coefficient σ per unit length of the volume a refracting material bounds
    /// (`KHR_materials_volume`: −ln(`attenuationColor`)/`attenuationDistance` per channel, at
    /// most `f32::MAX` for a black colour): light crossing a length d of it keeps e^(−σd)
    /// (Beer–Lambert). Zero: clear. Finite and non-negative; unused by a thin sheet.
    pub attenuation: Vec3,
    /// Emitted radiance Le in W·sr⁻¹·m⁻² per channel, the same in every direction of an emitting
    /// side (glTF `emissiveFactor` × `KHR_materials_emissive_strength.emissiveStrength`).
    pub emission: Vec3,
    /// glTF `doubleSided`: emits from both faces when true, otherwise only from the front face,
    /// the side that the counter-clockwise winding normal (p1−p0)×(p2−p0) points to. Reflection
    /// is two-sided either way.
    pub two_sided: bool,
    /// glTF `baseColorTexture`: the albedo at a point is `albedo` × this texture there (linear
    /// RGB in [0, 1]); `None`: `albedo` everywhere.
    pub albedo_texture: Option<TextureRef>,
    /// glTF `emissiveTexture`: the emitted radiance at a point is `emission` × this texture
    /// there; `None`: `emission` everywhere.
    pub emission_texture: Option<TextureRef>,
    /// glTF `metallicRoughnessTexture` (linear, not sRGB): at a point, the roughness is
    /// `roughness` × its green channel and the metallic factor `metallic` × its blue channel;
    /// `None`: the factors everywhere.
    pub metallic_roughness_texture: Option<TextureRef>,
    /// `KHR_materials_transmission`'s `transmissionTexture`: its red channel (linear data)
    /// multiplies [`Material::transmission`].
    pub transmission_texture: Option<TextureRef>,
    /// glTF `normalTexture` (linear, not sRGB): a tangent-space normal per texel, each channel
    /// c mapped to 2c − 1, whose x and y are scaled by `normal_scale`, turning the shading
    /// normal within the frame of the triangle's [`VertexTangents`](crate::VertexTangents); `None`: the interpolated
    /// vertex normal.
    pub normal_texture: Option<TextureRef>,
    /// glTF `normalTexture.scale`: the factor on the normal texture's x and y (finite; 1 by
    /// default, 0 leaves the vertex normal).
    pub normal_scale: f32,
    /// glTF `alphaMode` with `alphaCutoff`: whether and how the coverage α cuts the surface
    /// out (irr-integrator's `Scene::blocks`).
    pub alpha_mode: AlphaMode,
    /// glTF `baseColorFactor.a`, in [0, 1]: the coverage α, times `alpha_texture` there.
    pub alpha: f32,
    /// The alpha channel of glTF's `baseColorTexture` (in every channel), read only when
    /// `alpha_mode` is not opaque; `None`: `alpha` everywhere.
    pub alpha_texture: Option<TextureRef>,
    /// `KHR_materials_unlit`: the surface is its base colour (albedo × texture × vertex colour)
    /// as radiance to camera rays, unlit and unshaded, and no other ray meets it: it casts no
    /// shadow, lights nothing and shows in no reflection, as Blender's glTF importer makes it
    /// (an emission seen only by camera rays, transparent to the rest), so both integrators
    /// see the same scene without it. Its other factors are the file's fallbacks for
    /// renderers without the extension, and irr's loader leaves them at a black Lambertian's.
    pub unlit: bool,
}

/// How a material's coverage α (glTF `baseColorFactor.a` × the base colour texture's alpha)
/// makes its surface transparent (glTF `alphaMode`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    /// α is ignored: the surface is opaque everywhere (glTF `OPAQUE`, the default).
    Opaque,
    /// A cut-out: the surface is there where α ≥ the cutoff and absent elsewhere (glTF `MASK`
    /// with `alphaCutoff`, 0.5 by default).
    Mask(f32),
    /// Stochastic transparency (glTF `BLEND`): each ray meets the surface with probability α
    /// and passes through it otherwise, so that the image's expectation is the surface blended
    /// over what lies behind it by α.
    Blend,
}

impl Material {
    /// A non-emitting, untextured Lambertian material: f = albedo/π.
    pub fn diffuse(albedo: Vec3) -> Self {
        Self {
            albedo,
            metallic: 0.0,
            roughness: 1.0,
            specular: 0.0,
            ior: 1.5,
            transmission: 0.0,
            thin_walled: true,
            attenuation: Vec3::ZERO,
            emission: Vec3::ZERO,
            two_sided: true,
            albedo_texture: None,
            emission_texture: None,
            metallic_roughness_texture: None,
            transmission_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            alpha_mode: AlphaMode::Opaque,
            alpha: 1.0,
            alpha_texture: None,
            unlit: false,
        }
    }

    /// An untextured `KHR_materials_unlit` surface of colour `base_color`, seen from both sides.
    pub fn unlit(base_color: Vec3) -> Self {
        Self {
            unlit: true,
            ..Self::diffuse(base_color)
        }
    }

    /// A black, untextured emitter of radiance `emission` from the front of its triangles only
    /// (the side their winding faces), as glTF's single-sided emissive materials.
    pub fn emitter(emission: Vec3) -> Self {
        Self {
            emission,
            two_sided: false,
            ..Self::diffuse(Vec3::ZERO)
        }
    }

    /// A non-emitting, untextured glTF metallic-roughness material with the specification's full
    /// specular reflection (specular weight 1).
    pub fn metallic_roughness(base_color: Vec3, metallic: f32, roughness: f32) -> Self {
        Self {
            metallic,
            roughness,
            specular: 1.0,
            ..Self::diffuse(base_color)
        }
    }

    /// Whether the reflection is exactly Lambertian (metallic 0 and specular weight 0), so that
    /// an integrator shades it with f = albedo/π and cosine sampling.
    #[inline]
    pub fn is_lambertian(&self) -> bool {
        self.metallic == 0.0 && self.specular == 0.0
    }

    /// Whether the material's emission factor is non-zero (a texture can still make it black
    /// in places).
    #[inline]
    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// Whether a point with geometric normal `ng` (the winding normal) emits towards `wo` at
    /// all: always for a two-sided material, else only from the front face. The radiance is
    /// irr-integrator's `Scene::emitted` (it reads the emissive texture).
    #[inline]
    pub fn emits_towards(&self, ng: Vec3, wo: Vec3) -> bool {
        self.two_sided || ng.dot(wo) > 0.0
    }

    /// The texture coordinate sets this material reads, in the order a triangle's entries of
    /// [`TexCoords`](crate::TexCoords) hold them: each distinct set once, in the order of first use by the albedo,
    /// the emission, the metallic-roughness, the normal and the alpha texture. Between 0 and 5
    /// sets (glTF's alpha texture is the base colour texture's, on its set).
    pub fn tex_coord_sets(&self) -> impl Iterator<Item = u32> {
        let mut sets = [0u32; 5];
        let mut n = 0;
        for t in self.textures().into_iter().flatten() {
            if !sets[..n].contains(&t.tex_coord) {
                sets[n] = t.tex_coord;
                n += 1;
            }
        }
        sets.into_iter().take(n)
    }

    /// The albedo, emission, metallic-roughness, normal, alpha and transmission textures, in
    /// that order.
    #[inline]
    fn textures(&self) -> [Option<TextureRef>; 6] {
        [
            self.albedo_texture,
            self.emission_texture,
            self.metallic_roughness_texture,
            self.normal_texture,
            self.alpha_texture,
            self.transmission_texture,
        ]
    }

    /// Whether some ray can pass through the material's surface: a cut-out or a blend whose α
    /// is textured or below the cutoff (below 1 for a blend), or glass
    /// ([`Material::transmits`]). A scene none of whose materials can is traced without asking
    /// about any hit.
    pub fn can_cut_out(&self) -> bool {
        self.passes_straight()
            || match self.alpha_mode {
                AlphaMode::Opaque => false,
                AlphaMode::Mask(cutoff) => self.alpha_texture.is_some() || self.alpha < cutoff,
                AlphaMode::Blend => self.alpha_texture.is_some() || self.alpha < 1.0,
            }
    }

    /// Whether the material transmits light (glass): a transmission factor above 0 on a
    /// material that neither emits (an emitter's light is sampled as if every ray met it) nor
    /// is unlit (which no ray but the camera's meets).
    pub fn transmits(&self) -> bool {
        self.transmission > 0.0 && !self.unlit && !self.is_emissive()
    }

    /// Whether the surface bounds a volume and refracts: a transmitting material that is not a
    /// thin sheet ([`Material::transmits`], [`Material::thin_walled`]).
    pub fn refracts(&self) -> bool {
        self.transmits() && !self.thin_walled
    }

    /// Whether the volume the surface bounds absorbs ([`Material::refracts`] and a non-zero
    /// [`Material::attenuation`]).
    pub fn absorbs(&self) -> bool {
        self.refracts() && self.attenuation != Vec3::ZERO
    }

    /// Whether rays pass straight through the surface, with the probability of its straight
    /// transmittance: a transmitting thin sheet ([`Material::transmits`] and
    /// [`Material::thin_walled`]). A volume's boundary stops every ray and refracts by its BSDF.
    pub fn passes_straight(&self) -> bool {
        self.transmits() && self.thin_walled
    }

    /// The index among [`Material::tex_coord_sets`] of the set `texture` reads.
    #[inline]
    pub fn slot(&self, texture: &TextureRef) -> usize {
        self.tex_coord_sets()
            .position(|s| s == texture.tex_coord)
            .unwrap_or(0)
    }
}
