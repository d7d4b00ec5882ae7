//! Textures (glTF 2.0 §3.8): a material's `baseColorTexture` and `emissiveTexture`, their
//! samplers, their `KHR_texture_transform`, and the images behind them (PNG and JPEG, from a
//! `bufferView`, a `data:` URI or a file inside the asset root).
//!
//! Images are untrusted like every other part of a scene: each side is at most
//! [`MAX_IMAGE_SIDE`] texels, and the memory decoding takes (the decoder's output, a JPEG's
//! coefficients, the linear texels) is charged to the loader's `Budget` from the header's
//! dimensions before any pixel is decoded. Texels are converted from sRGB to linear with the
//! exact sRGB EOTF (IEC 61966-2-1) once, here; the alpha channel is dropped (irr's surfaces are
//! opaque, and `alphaMode` other than `OPAQUE` is already warned about).

use super::{Loader, describe, plural};
use crate::error::RenderError;
use crate::files::Budget;
use crate::uri::{decode_data_uri, percent_decode, scheme};
use glam::{Affine2, Vec2, Vec3};
use irr_geometry::{Triangle, TriangleMesh};
use irr_integrator::{Filter, Material, Sampler, TexCoords, Texture, TextureRef, Wrap};
use std::collections::BTreeMap;

/// The largest image side irr decodes, in texels: the largest texture most GPUs take, and far
/// beyond what a texture needs to be sharp in an image of [`crate::MAX_DIMENSION`] pixels.
pub const MAX_IMAGE_SIDE: u32 = 16384;

/// The textures the materials read, each loaded once, and the images behind them, each
/// decoded once.
#[derive(Default)]
pub(super) struct Textures {
    /// glTF texture index → index in `list`.
    by_gltf: BTreeMap<usize, u32>,
    /// glTF image index → its texels (shared by every texture made from it).
    images: BTreeMap<usize, Texture>,
    /// The textures, as `TextureRef::texture` indexes them.
    pub(super) list: Vec<Texture>,
    /// Loaded textures whose `minFilter` irr does not follow.
    min_filters_ignored: usize,
}

impl Textures {
    /// Warns of what the file holds and irr did not read: textures and images no material reads
    /// as base colour or emission, and `minFilter`s.
    pub(super) fn warn(&self, loader: &mut Loader<'_>) {
        let d = loader.document;
        let textures = d.textures().len().saturating_sub(self.by_gltf.len());
        loader.warnings.add("textures", textures, |n| {
            format!(
                "{} ignored (irr reads baseColorTexture and emissiveTexture only)",
                plural(n, "texture", "textures")
            )
        });
        let images = d.images().len().saturating_sub(self.images.len());
        loader.warnings.add("images", images, |n| {
            format!(
                "{} ignored (no baseColorTexture or emissiveTexture uses {})",
                plural(n, "image", "images"),
                if n == 1 { "it" } else { "them" }
            )
        });
        loader
            .warnings
            .add("min-filter", self.min_filters_ignored, |n| {
                format!(
                    "{} a minFilter that irr does not follow: irr has no mip maps and filters every lookup with magFilter (a texture smaller than a pixel is averaged by the pixel's samples)",
                    plural(n, "texture has", "textures have")
                )
            });
    }
}

impl Loader<'_> {
    /// The [`TextureRef`] of a material's `textureInfo` (`what` names it in messages), loading
    /// the texture and its image the first time one is met.
    pub(super) fn texture_ref(
        &mut self,
        textures: &mut Textures,
        info: &gltf::json::texture::Info,
        what: &str,
        buffers: &[Vec<u8>],
    ) -> Result<TextureRef, RenderError> {
        let index = info.index.value();
        let texture = match textures.by_gltf.get(&index) {
            Some(&t) => t,
            None => {
                let t = self.texture(textures, index, what, buffers)?;
                let id = u32::try_from(textures.list.len())
                    .map_err(|_| self.err(format!("{what}: too many textures")))?;
                textures.list.push(t);
                textures.by_gltf.insert(index, id);
                id
            }
        };
        let (tex_coord, transform) = match info
            .extensions
            .as_ref()
            .and_then(|e| e.texture_transform.as_ref())
        {
            None => (info.tex_coord, Affine2::IDENTITY),
            Some(t) => {
                let m = texture_transform(t.offset.0, t.rotation.0, t.scale.0);
                if !m.is_finite() {
                    return Err(self.err(format!(
                        "{what}: KHR_texture_transform is not finite (offset, rotation and scale must be finite numbers)"
                    )));
                }
                (t.tex_coord.unwrap_or(info.tex_coord), m)
            }
        };
        Ok(TextureRef {
            texture,
            tex_coord,
            transform,
        })
    }

    /// glTF texture `index`: its image with its sampler.
    fn texture(
        &mut self,
        textures: &mut Textures,
        index: usize,
        what: &str,
        buffers: &[Vec<u8>],
    ) -> Result<Texture, RenderError> {
        let root = self.document.as_json();
        // The schema check (`json::validate`) proved these indices; a lookup costs nothing and
        // keeps a panic impossible.
        let json = root.textures.get(index).ok_or_else(|| {
            self.err(format!(
                "{what}: texture {index} does not exist (the file has {})",
                root.textures.len()
            ))
        })?;
        let name = format!("texture {}", describe(index, json.name.as_deref()));
        let (sampler, min_filter_ignored) = match json.sampler {
            None => (Sampler::default(), false),
            Some(s) => {
                let s = root.samplers.get(s.value()).ok_or_else(|| {
                    self.err(format!("{name}: sampler {} does not exist", s.value()))
                })?;
                sampler(s)
            }
        };
        textures.min_filters_ignored += usize::from(min_filter_ignored);
        let image = json.source.value();
        let texels = match textures.images.get(&image) {
            Some(t) => t.clone(),
            None => {
                let t = self.image(image, &name, buffers)?;
                textures.images.insert(image, t.clone());
                t
            }
        };
        Ok(texels.with_sampler(sampler))
    }

    /// Decodes glTF image `index` (read by `texture`, for messages).
    fn image(
        &mut self,
        index: usize,
        texture: &str,
        buffers: &[Vec<u8>],
    ) -> Result<Texture, RenderError> {
        let root = self.document.as_json();
        let Some(json) = root.images.get(index) else {
            return Err(self.err(format!(
                "{texture}: image {index} does not exist (the file has {})",
                root.images.len()
            )));
        };
        let mut name = format!("image {}", describe(index, json.name.as_deref()));
        let owned;
        let bytes: &[u8] = match (&json.buffer_view, &json.uri) {
            (Some(view), _) => {
                name = format!("{name} (bufferView {})", view.value());
                self.view_bytes(view.value(), buffers)
                    .map_err(|e| self.err(format!("{name}: {e}")))?
            }
            (None, Some(uri)) => {
                if !uri.starts_with("data:") {
                    name = format!("{name} (\"{uri}\")");
                }
                owned = self
                    .read_image_uri(uri)
                    .map_err(|e| self.err(format!("{name}: URI {e}")))?;
                &owned
            }
            (None, None) => {
                return Err(self.err(format!("{name} has neither a uri nor a bufferView")));
            }
        };
        self.budget.allow_images();
        decode_image(bytes, &mut self.budget).map_err(|e| self.err(format!("{name}: {e}")))
    }

    /// The bytes of buffer view `index`, checked against its buffer.
    fn view_bytes<'b>(&self, index: usize, buffers: &'b [Vec<u8>]) -> Result<&'b [u8], String> {
        let root = self.document.as_json();
        let view = root
            .buffer_views
            .get(index)
            .ok_or_else(|| format!("bufferView {index} does not exist"))?;
        let buffer = view.buffer.value();
        let data = buffers
            .get(buffer)
            .ok_or_else(|| format!("buffer {buffer} does not exist"))?;
        let offset = view.byte_offset.map_or(0, |o| o.0);
        let length = view.byte_length.0;
        usize::try_from(offset)
            .ok()
            .zip(usize::try_from(length).ok())
            .and_then(|(o, l)| data.get(o..o.checked_add(l)?))
            .ok_or_else(|| {
                format!(
                    "bufferView {index} spans bytes {offset}..{offset}+{length} but buffer {buffer} has {} bytes",
                    data.len()
                )
            })
    }

    /// The bytes an image URI names: a `data:` URI's payload or a file inside the asset root,
    /// whose size raises the budget as a buffer file's does. Errors complete "URI …".
    fn read_image_uri(&mut self, uri: &str) -> Result<Vec<u8>, String> {
        if let Some(decoded) = decode_data_uri(uri) {
            return decoded;
        }
        if let Some(scheme) = scheme(uri) {
            return Err(format!(
                "scheme '{scheme}:' is not supported (irr reads relative file paths and data: URIs)"
            ));
        }
        let name = percent_decode(uri)?;
        let bytes = self.confinement.read_whole(&name)?;
        self.budget.add_input(bytes.len() as u64);
        Ok(bytes)
    }
}

/// A glTF sampler as irr follows it, and whether its `minFilter` is one irr does not follow (a
/// mipmapped one, or one that differs from `magFilter`).
fn sampler(s: &gltf::json::texture::Sampler) -> (Sampler, bool) {
    use gltf::json::texture::{MagFilter, MinFilter, WrappingMode};
    use gltf::json::validation::Checked;
    let wrap = |w: &Checked<WrappingMode>| match w {
        Checked::Valid(WrappingMode::ClampToEdge) => Wrap::ClampToEdge,
        Checked::Valid(WrappingMode::MirroredRepeat) => Wrap::MirroredRepeat,
        // REPEAT, and (never reached: the schema check refuses them) invalid values.
        _ => Wrap::Repeat,
    };
    let filter = match s.mag_filter {
        Some(Checked::Valid(MagFilter::Nearest)) => Filter::Nearest,
        _ => Filter::Linear,
    };
    let min_ignored = match s.min_filter {
        None => false,
        Some(Checked::Valid(MinFilter::Nearest)) => filter != Filter::Nearest,
        Some(Checked::Valid(MinFilter::Linear)) => filter != Filter::Linear,
        Some(_) => true,
    };
    (
        Sampler {
            wrap_s: wrap(&s.wrap_s),
            wrap_t: wrap(&s.wrap_t),
            filter,
        },
        min_ignored,
    )
}

/// KHR_texture_transform's matrix, translation × rotation × scale (the extension's README):
/// u' = cos·sx·u + sin·sy·v + ox, v' = −sin·sx·u + cos·sy·v + oy.
pub(super) fn texture_transform(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> Affine2 {
    let (sin, cos) = rotation.sin_cos();
    Affine2::from_cols(
        Vec2::new(cos * scale[0], -sin * scale[0]),
        Vec2::new(sin * scale[1], cos * scale[1]),
        Vec2::from_array(offset),
    )
}

/// The sRGB electro-optical transfer function (IEC 61966-2-1): an encoded value in [0, 1] to
/// linear light.
pub(super) fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The kinds of image irr decodes, told by their first bytes (a `mimeType` is only a hint).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Png,
    Jpeg,
}

const PNG_SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a];

fn format_of(bytes: &[u8]) -> Option<Format> {
    if bytes.starts_with(&PNG_SIGNATURE) {
        Some(Format::Png)
    } else if bytes.starts_with(&[0xff, 0xd8, 0xff]) {
        Some(Format::Jpeg)
    } else {
        None
    }
}

/// Refuses an image larger than [`MAX_IMAGE_SIDE`] on a side, or empty.
fn check_size(width: u64, height: u64) -> Result<(), String> {
    if width == 0 || height == 0 {
        return Err(format!("the image is {width}×{height} texels: empty"));
    }
    let max = u64::from(MAX_IMAGE_SIDE);
    if width > max || height > max {
        return Err(format!(
            "the image is {width}×{height} texels; irr reads images up to {MAX_IMAGE_SIDE} texels on a side"
        ));
    }
    Ok(())
}

/// Decodes a PNG or JPEG into linear texels (with the default sampler), charging `budget` for
/// every allocation its header implies before decoding.
fn decode_image(bytes: &[u8], budget: &mut Budget) -> Result<Texture, String> {
    let (width, height, texels) = match format_of(bytes) {
        Some(Format::Png) => decode_png(bytes, budget)?,
        Some(Format::Jpeg) => decode_jpeg(bytes, budget)?,
        None => {
            return Err(
                "is neither PNG nor JPEG (irr reads those two; KHR_texture_basisu and EXT_texture_webp images are not supported)"
                    .to_string(),
            );
        }
    };
    Texture::new(width, height, texels, Sampler::default()).map_err(|e| e.to_string())
}

/// The 256 linear values of 8-bit sRGB codes.
fn srgb8_table() -> [f32; 256] {
    std::array::from_fn(|c| srgb_to_linear(c as f64 / 255.0) as f32)
}

/// Charges the texels of a `width` × `height` image and reserves them.
fn texel_vec(budget: &mut Budget, width: u32, height: u32) -> Result<Vec<Vec3>, String> {
    let n = (width as usize).saturating_mul(height as usize);
    budget.vec::<Vec3>("its linear texels", n)
}

fn decode_png(bytes: &[u8], budget: &mut Budget) -> Result<(u32, u32, Vec<Vec3>), String> {
    // The header first, read here: IHDR is the first chunk (PNG §5.6), width and height its
    // first two big-endian u32s. An absurd size is refused before the decoder sees it.
    if let Some(ihdr) = bytes.get(8..24).filter(|h| &h[4..8] == b"IHDR") {
        let be = |b: &[u8]| u64::from(u32::from_be_bytes([b[0], b[1], b[2], b[3]]));
        check_size(be(&ihdr[8..12]), be(&ihdr[12..16]))?;
    }
    let png_error = |e: png::DecodingError| format!("PNG: {e}");
    let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    // Palettes become RGB, transparency becomes alpha, and depths below 8 bits become 8.
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(png_error)?;
    let (width, height) = (reader.info().width, reader.info().height);
    check_size(u64::from(width), u64::from(height))?;
    let (color, depth) = reader.output_color_type();
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| "PNG: the decoded size overflows".to_string())?;
    let mut decoded = budget.vec::<u8>("its decoded pixels", size)?;
    decoded.resize(size, 0);
    let frame = reader.next_frame(&mut decoded).map_err(png_error)?;
    let channels = color.samples();
    let sample_bytes = match depth {
        png::BitDepth::Sixteen => 2,
        _ => 1,
    };
    let mut texels = texel_vec(budget, width, height)?;
    // Grey (and grey + alpha) repeats its one channel; alpha is dropped.
    let (g, b) = if channels >= 3 { (1, 2) } else { (0, 0) };
    let rows = decoded.chunks_exact(frame.line_size).take(height as usize);
    if sample_bytes == 1 {
        let table = srgb8_table();
        for row in rows {
            for px in row.chunks_exact(channels).take(width as usize) {
                let t = |k: usize| table[usize::from(px[k])];
                texels.push(Vec3::new(t(0), t(g), t(b)));
            }
        }
    } else {
        let table: Vec<f32> = (0..=u16::MAX)
            .map(|c| srgb_to_linear(f64::from(c) / 65535.0) as f32)
            .collect();
        for row in rows {
            for px in row.chunks_exact(2 * channels).take(width as usize) {
                let t =
                    |k: usize| table[usize::from(u16::from_be_bytes([px[2 * k], px[2 * k + 1]]))];
                texels.push(Vec3::new(t(0), t(g), t(b)));
            }
        }
    }
    Ok((width, height, texels))
}

/// Bytes per texel that JPEG decoding takes besides the output: a progressive JPEG keeps every
/// component's DCT coefficients (an i16 each) until its last scan: at most 4 components.
const JPEG_COEFFICIENT_BYTES: usize = 8;

fn decode_jpeg(bytes: &[u8], budget: &mut Budget) -> Result<(u32, u32, Vec<Vec3>), String> {
    use zune_jpeg::zune_core::bytestream::ZCursor;
    use zune_jpeg::zune_core::colorspace::ColorSpace;
    use zune_jpeg::zune_core::options::DecoderOptions;
    let jpeg_error = |e: zune_jpeg::errors::DecodeErrors| format!("JPEG: {e}");
    // The decoder's own size limit is JPEG's (65535): irr checks the size itself, with its
    // own message.
    let options = DecoderOptions::default()
        .jpeg_set_out_colorspace(ColorSpace::RGB)
        .set_max_width(usize::from(u16::MAX))
        .set_max_height(usize::from(u16::MAX));
    let mut decoder = zune_jpeg::JpegDecoder::new_with_options(ZCursor::new(bytes), options);
    decoder.decode_headers().map_err(jpeg_error)?;
    let (w, h) = decoder
        .dimensions()
        .ok_or_else(|| "JPEG: no frame header".to_string())?;
    check_size(w as u64, h as u64)?;
    let (width, height) = (w as u32, h as u32);
    let size = decoder
        .output_buffer_size()
        .ok_or_else(|| "JPEG: the decoded size overflows".to_string())?;
    budget.charge::<u8>(
        "its DCT coefficients",
        (w * h).saturating_mul(JPEG_COEFFICIENT_BYTES),
    )?;
    let mut decoded = budget.vec::<u8>("its decoded pixels", size)?;
    decoded.resize(size, 0);
    decoder.decode_into(&mut decoded).map_err(jpeg_error)?;
    let mut texels = texel_vec(budget, width, height)?;
    let table = srgb8_table();
    for px in decoded.chunks_exact(3) {
        texels.push(Vec3::new(
            table[usize::from(px[0])],
            table[usize::from(px[1])],
            table[usize::from(px[2])],
        ));
    }
    Ok((width, height, texels))
}

/// The texture coordinates of the triangles of `meshes` (given per mesh as
/// [`SceneData::tex_coords`](super::SceneData::tex_coords) holds them) by the id [`irr_geometry::Geometry::build`] gives
/// them: it keeps the triangles [`Triangle::is_kept`] accepts, mesh after mesh, in order. Empty
/// when no material is textured.
pub(crate) fn tex_coords_by_id(
    meshes: &[TriangleMesh],
    materials: &[Material],
    tex_coords: &[Vec<[Vec2; 3]>],
) -> Result<TexCoords, String> {
    let mut out = TexCoords::default();
    if !materials
        .iter()
        .any(|m| m.tex_coord_sets().next().is_some())
    {
        return Ok(out);
    }
    for (mesh, uv) in meshes.iter().zip(tex_coords) {
        let sets = mesh
            .material_ids
            .first()
            .and_then(|&m| materials.get(m as usize))
            .map_or(0, |m: &Material| m.tex_coord_sets().count());
        for (t, idx) in mesh.indices.iter().enumerate() {
            let Some(p) = idx
                .iter()
                .map(|&i| mesh.positions.get(i as usize).copied())
                .collect::<Option<Vec<Vec3>>>()
            else {
                continue;
            };
            if !Triangle::is_kept(&[p[0], p[1], p[2]]) {
                continue;
            }
            let entries = uv.get(t * sets..(t + 1) * sets).unwrap_or(&[]);
            out.push(entries).map_err(|e| e.to_string())?;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_eotf_matches_the_standard() {
        // The ends, the linear segment, and the curve at mid-grey (IEC 61966-2-1:
        // ((0.5 + 0.055)/1.055)^2.4 = 0.21404114…).
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-15);
        assert!((srgb_to_linear(0.04) - 0.04 / 12.92).abs() < 1e-15);
        assert!((srgb_to_linear(0.5) - 0.214_041_140_482_232_5).abs() < 1e-12);
        // Continuous at the joint (to the 1e-6 the standard's rounded constants allow).
        let joint = 0.04045;
        assert!((srgb_to_linear(joint) - ((joint + 0.055) / 1.055f64).powf(2.4)).abs() < 1e-6);
    }

    #[test]
    fn texture_transform_follows_the_extension() {
        // Scale then rotate by 90° then offset: (1, 0) → scale (2, 3) → (2, 0) → rotation
        // [cos sin; −sin cos] → (0, −2) → offset (0.5, 0.25) → (0.5, −1.75).
        let m = texture_transform([0.5, 0.25], std::f32::consts::FRAC_PI_2, [2.0, 3.0]);
        let p = m.transform_point2(Vec2::new(1.0, 0.0));
        assert!(
            (p - Vec2::new(0.5, -1.75)).abs().max_element() < 1e-6,
            "{p}"
        );
        let q = m.transform_point2(Vec2::new(0.0, 1.0));
        assert!((q - Vec2::new(3.5, 0.25)).abs().max_element() < 1e-6, "{q}");
        assert_eq!(
            texture_transform([0.0; 2], 0.0, [1.0; 2]),
            Affine2::IDENTITY
        );
    }

    #[test]
    fn formats_are_told_by_their_bytes() {
        assert_eq!(format_of(&PNG_SIGNATURE), Some(Format::Png));
        assert_eq!(format_of(&[0xff, 0xd8, 0xff, 0xe0]), Some(Format::Jpeg));
        assert_eq!(format_of(b"GIF89a"), None);
        assert_eq!(format_of(&[]), None);
    }
}
