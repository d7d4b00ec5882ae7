//! Materials and the document-wide features irr ignores.

use super::textures::{Decode, Textures};
use super::{Loader, SUPPORTED_EXTENSIONS, describe, plural};
use crate::error::LoadError;
use crate::{AlphaMode, Material, Texture};
use glam::Vec3;
use std::collections::BTreeMap;

impl Loader<'_> {
    /// Warns, for each extension irr ignores, of the objects that use it (`counts`, from
    /// [`count_extensions`]).
    pub(super) fn count_extensions(&mut self, mut counts: BTreeMap<String, usize>) {
        // Extensions listed as used but never attached to an object still deserve a word.
        for name in self.document.extensions_used() {
            counts.entry(name.to_string()).or_insert(0);
        }
        for (name, count) in counts {
            if SUPPORTED_EXTENSIONS.contains(&name.as_str()) {
                continue;
            }
            let why = match name.as_str() {
                "KHR_draco_mesh_compression" | "EXT_meshopt_compression" => {
                    "compressed geometry is not decoded"
                }
                "KHR_texture_basisu" | "EXT_texture_webp" => "irr reads PNG and JPEG images only",
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

    pub(super) fn count_document_features(&mut self) {
        let d = self.document;
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
        let (mut occlusion, mut specular_colour) = (0, 0);
        for json in &d.as_json().materials {
            // Read from the JSON: the typed accessors look the textures up with an unwrap.
            occlusion += usize::from(json.occlusion_texture.is_some());
            if let Some(s) = json.extensions.as_ref().and_then(|e| e.specular.as_ref()) {
                specular_colour += usize::from(
                    s.specular_texture.is_some()
                        || s.specular_color_texture.is_some()
                        || s.specular_color_factor.0 != [1.0; 3],
                );
            }
        }
        self.warnings.add("occlusion-maps", occlusion, |n| {
            format!(
                "{} ignored (a global-illumination renderer computes occlusion: baked occlusion would count it twice)",
                plural(n, "occlusion texture", "occlusion textures")
            )
        });
        self.warnings.add("specular-colour", specular_colour, |n| {
            format!(
                "{} KHR_materials_specular colour or textures: ignored (irr reads its specularFactor only)",
                plural(n, "material has", "materials have")
            )
        });
    }

    /// The materials in file order, the index the default material will get, and the textures
    /// the materials read (decoded from `buffers` or the files their images name).
    pub(super) fn materials(
        &mut self,
        buffers: &[Vec<u8>],
    ) -> Result<(Vec<Material>, u32, Vec<Texture>), LoadError> {
        let mut out = Vec::new();
        let (mut clamped, mut clamped_factors) = (0, 0);
        // Glass read in part: see the warnings after the loop.
        let mut glass = GlassWarnings::default();
        let mut textures = Textures::default();
        let document = self.document;
        for (m, json) in document.materials().zip(&document.as_json().materials) {
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
            let pbr = &json.pbr_metallic_roughness;
            let specular = json
                .extensions
                .as_ref()
                .and_then(|e| e.specular.as_ref())
                .map_or(1.0, |s| s.specular_factor.0);
            let mut factors = [0.0f32; 3];
            for (slot, (what, value)) in factors.iter_mut().zip([
                ("metallicFactor", pbr.metallic_factor.0),
                ("roughnessFactor", pbr.roughness_factor.0),
                ("KHR_materials_specular specularFactor", specular),
            ]) {
                if !value.is_finite() {
                    return Err(self.err(format!("material {name}: {what} {value} is not finite")));
                }
                *slot = value.clamp(0.0, 1.0);
                if *slot != value {
                    clamped_factors += 1;
                }
            }
            // An unlit material's other factors and textures are the file's fallbacks for
            // renderers without the extension: a black Lambertian that emits nothing.
            let unlit = m.unlit();
            let [metallic, roughness, specular] = if unlit { [0.0, 1.0, 0.0] } else { factors };
            // KHR_materials_ior: 0 is an infinite ior; other values below 1 are outside the
            // extension's range and read as 1 (F0 = 0), counted with the clamped factors.
            let ior = m.ior().unwrap_or(1.5);
            if !ior.is_finite() {
                return Err(self.err(format!(
                    "material {name}: KHR_materials_ior ior {ior} is not finite"
                )));
            }
            let ior = if ior != 0.0 && ior < 1.0 {
                clamped_factors += 1;
                1.0
            } else {
                ior
            };
            // KHR_materials_transmission, read from the JSON (the typed accessor of its texture
            // unwraps the texture's index).
            let extensions = json.extensions.as_ref();
            let transmission_json = extensions.and_then(|e| e.transmission.as_ref());
            let transmission = transmission_json.map_or(0.0, |t| t.transmission_factor.0);
            if !transmission.is_finite() {
                return Err(self.err(format!(
                    "material {name}: KHR_materials_transmission transmissionFactor {transmission} is not finite"
                )));
            }
            let transmission = if (0.0..=1.0).contains(&transmission) {
                transmission
            } else {
                clamped_factors += 1;
                transmission.clamp(0.0, 1.0)
            };
            // KHR_materials_volume: a thickness above 0 makes the surface a volume's boundary,
            // which refracts, and absorbs by its attenuation colour over its distance.
            let volume_json = extensions.and_then(|e| e.volume.as_ref());
            let volume = volume_json
                .is_some_and(|v| v.thickness_factor.0 > 0.0 || v.thickness_texture.is_some());
            let attenuation = match volume_json.filter(|_| volume) {
                None => Vec3::ZERO,
                Some(v) => {
                    let distance = v.attenuation_distance.0;
                    let colour = Vec3::from_array(v.attenuation_color.0);
                    if distance.is_nan() || distance <= 0.0 || !colour.is_finite() {
                        return Err(self.err(format!(
                            "material {name}: KHR_materials_volume attenuationDistance {distance} must be above 0 and attenuationColor {colour} finite"
                        )));
                    }
                    let clamped = colour.clamp(Vec3::ZERO, Vec3::ONE);
                    clamped_factors += usize::from(clamped != colour);
                    // σ = −ln(c)/d: 0 for a white colour or an infinite distance (glTF's
                    // defaults), f32::MAX where c = 0 (ln 0 = −∞).
                    Vec3::from_array(
                        clamped
                            .to_array()
                            .map(|c| (-c.ln() / distance).min(f32::MAX)),
                    )
                }
            };
            let strength = m.emissive_strength().unwrap_or(1.0);
            let emission = Vec3::from_array(m.emissive_factor()) * strength;
            if !emission.is_finite() || emission.min_element() < 0.0 {
                return Err(self.err(format!(
                    "material {name}: emission {emission} (emissiveFactor × emissiveStrength) must be finite and non-negative"
                )));
            }
            let mut optional = |info: Option<&gltf::json::texture::Info>, what, decode| {
                info.map(|info| {
                    let what = format!("material {name} {what}");
                    self.texture_ref(&mut textures, info, &what, buffers, decode)
                })
                .transpose()
            };
            let albedo_texture = optional(
                pbr.base_color_texture.as_ref(),
                "baseColorTexture",
                Decode::Colour,
            )?;
            let emission_texture = optional(
                json.emissive_texture.as_ref().filter(|_| !unlit),
                "emissiveTexture",
                Decode::Colour,
            )?;
            let metallic_roughness_texture = optional(
                pbr.metallic_roughness_texture.as_ref().filter(|_| !unlit),
                "metallicRoughnessTexture",
                Decode::Data,
            )?;
            let transmission_texture = optional(
                transmission_json
                    .and_then(|t| t.transmission_texture.as_ref())
                    .filter(|_| !unlit && transmission > 0.0),
                "transmissionTexture",
                Decode::Data,
            )?;
            let alpha = base[3];
            if !alpha.is_finite() {
                return Err(self.err(format!(
                    "material {name}: baseColorFactor's alpha {alpha} is not finite"
                )));
            }
            let clamped_alpha = alpha.clamp(0.0, 1.0);
            clamped_factors += usize::from(clamped_alpha != alpha);
            let alpha_mode = match m.alpha_mode() {
                gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
                gltf::material::AlphaMode::Blend => AlphaMode::Blend,
                gltf::material::AlphaMode::Mask => {
                    let cutoff = m.alpha_cutoff().unwrap_or(0.5);
                    if !cutoff.is_finite() {
                        return Err(self.err(format!(
                            "material {name}: alphaCutoff {cutoff} is not finite"
                        )));
                    }
                    AlphaMode::Mask(cutoff)
                }
            };
            // The coverage is the base colour texture's alpha channel, on its coordinates; an
            // image whose alpha is 1 everywhere (or that has none) is no alpha texture.
            let alpha_texture = optional(
                pbr.base_color_texture
                    .as_ref()
                    .filter(|_| alpha_mode != AlphaMode::Opaque),
                "baseColorTexture (alpha)",
                Decode::Alpha,
            )?
            .filter(|r| {
                textures
                    .list
                    .get(r.texture as usize)
                    .is_some_and(|t| t.mean() != Vec3::ONE)
            });
            let (normal_texture, normal_scale) =
                match json.normal_texture.as_ref().filter(|_| !unlit) {
                    Some(normal) => {
                        let what = format!("material {name} normalTexture");
                        if !normal.scale.is_finite() {
                            return Err(
                                self.err(format!("{what}: scale {} is not finite", normal.scale))
                            );
                        }
                        let info = self.normal_texture_info(normal, &what)?;
                        let r =
                            self.texture_ref(&mut textures, &info, &what, buffers, Decode::Data)?;
                        (Some(r), normal.scale)
                    }
                    None => (None, 1.0),
                };
            out.push(Material {
                albedo: clamped_albedo,
                emission: if unlit { Vec3::ZERO } else { emission },
                two_sided: m.double_sided(),
                metallic,
                roughness,
                specular,
                ior: if unlit { 1.5 } else { ior },
                transmission: if unlit { 0.0 } else { transmission },
                thin_walled: !volume,
                attenuation: if unlit { Vec3::ZERO } else { attenuation },
                albedo_texture,
                emission_texture,
                metallic_roughness_texture,
                transmission_texture,
                normal_texture,
                normal_scale,
                alpha_mode,
                alpha: clamped_alpha,
                alpha_texture,
                unlit,
            });
            if let Some(m) = out.last().filter(|m| m.transmission > 0.0 && !m.unlit) {
                glass.count(m);
            }
        }
        glass.warn(self);
        textures.warn(self);
        self.warnings.add("albedo-clamped", clamped, |n| {
            format!(
                "{} baseColorFactor outside [0, 1]: clamped",
                plural(n, "material has", "materials have")
            )
        });
        self.warnings.add("factor-clamped", clamped_factors, |n| {
            format!(
                "{} outside [0, 1] (metallicFactor, roughnessFactor, specularFactor, ior or baseColorFactor's alpha): clamped",
                plural(n, "factor", "factors")
            )
        });
        let default = out.len() as u32;
        Ok((out, default, textures.list))
    }

    /// A `normalTexture` as the `textureInfo` it extends (its `scale` aside), with its
    /// `KHR_texture_transform`, which the gltf crate keeps only as JSON there.
    fn normal_texture_info(
        &self,
        normal: &gltf::json::material::NormalTexture,
        what: &str,
    ) -> Result<gltf::json::texture::Info, LoadError> {
        use gltf::json::extensions::texture::{Info, TextureTransform};
        let transform = normal
            .extensions
            .as_ref()
            .and_then(|e| e.others.get("KHR_texture_transform"))
            .map(|v| serde_json::from_value::<TextureTransform>(v.clone()))
            .transpose()
            .map_err(|e| self.err(format!("{what}: KHR_texture_transform: {e}")))?;
        Ok(gltf::json::texture::Info {
            index: normal.index,
            tex_coord: normal.tex_coord,
            extensions: transform.map(|t| Info {
                texture_transform: Some(t),
                others: Default::default(),
            }),
            extras: Default::default(),
        })
    }
}

/// What of glTF's glass the renderer leaves out, counted per material (`Material::transmits`).
#[derive(Default)]
struct GlassWarnings {
    rough: usize,
    tinted: usize,
    emissive: usize,
}

impl GlassWarnings {
    /// The roughness up to which a thin sheet's transmitted light is sharp in glTF's model too:
    /// α = roughness² at irr-bsdf's floor `SMOOTH_ALPHA` (1e-3).
    const SMOOTH_ROUGHNESS: f32 = 0.0316;

    /// Counts what of glass material `m` is left out: for a thin sheet, its roughness and
    /// tint.
    fn count(&mut self, m: &Material) {
        if m.is_emissive() {
            self.emissive += 1;
            return;
        }
        if m.thin_walled {
            self.rough += usize::from(
                m.roughness > Self::SMOOTH_ROUGHNESS || m.metallic_roughness_texture.is_some(),
            );
            let a = m.albedo;
            self.tinted += usize::from(a.x != a.y || a.y != a.z || m.albedo_texture.is_some());
        }
    }

    fn warn(&self, loader: &mut Loader<'_>) {
        let w = &mut loader.warnings;
        w.add("transmission-rough", self.rough, |n| {
            format!(
                "{} rougher than 0.03: light passing through is seen sharp, not blurred (the reflection keeps its roughness)",
                plural(n, "thin glass material is", "thin glass materials are")
            )
        });
        w.add("transmission-tint", self.tinted, |n| {
            format!(
                "{} a coloured or textured base colour: light passing through is dimmed by its mean, not tinted",
                plural(n, "thin glass material has", "thin glass materials have")
            )
        });
        w.add("transmission-emissive", self.emissive, |n| {
            format!(
                "{} KHR_materials_transmission ignored: an emitter is opaque in irr",
                plural(n, "emissive material has", "emissive materials have")
            )
        });
    }
}
