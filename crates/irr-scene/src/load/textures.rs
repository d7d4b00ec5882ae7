//! Textures (glTF 2.0 §3.8): a material's `baseColorTexture`, `emissiveTexture`,
//! `metallicRoughnessTexture` and `normalTexture`, their samplers, their
//! `KHR_texture_transform`, and the images behind them (PNG and JPEG, from a `bufferView`, a
//! `data:` URI or a file inside the asset root).
//!
//! Images are untrusted like every other part of a scene: each side is at most
//! [`MAX_IMAGE_SIDE`] texels, and the memory decoding takes (the decoder's output, a JPEG's
//! coefficients, the linear texels) is charged to the loader's `Budget` from the header's
//! dimensions before any pixel is decoded. Colour textures' texels are converted from sRGB to
//! linear with the exact sRGB EOTF (IEC 61966-2-1) once, here; metallic-roughness and normal
//! textures' are linear already (glTF 2.0 §3.9.2) and are only scaled to [0, 1]. The alpha
//! channel is decoded, as a texture of its own, only for a material whose `alphaMode` reads
//! it ([`Decode::Alpha`]; it takes three channels, like every irr texture).

use super::{Loader, describe, plural};
use crate::error::LoadError;
use crate::files::Budget;
#[cfg(test)]
use crate::files::MemoryLimit;
use crate::uri::{decode_data_uri, percent_decode, scheme};
use crate::{Filter, Material, Sampler, TexCoords, Texture, TextureRef, VertexAttribute, Wrap};
use glam::{Affine2, Vec2, Vec3};
use irr_geometry::{Triangle, TriangleMesh};
use std::collections::BTreeMap;

/// The largest image side irr decodes, in texels: the largest texture most GPUs take, and far
/// beyond what a texture needs to be sharp in an image of irr-render's `MAX_DIMENSION` pixels.
pub const MAX_IMAGE_SIDE: u32 = 16384;

/// How an image's codes become texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(super) enum Decode {
    /// Colours: RGB through the sRGB EOTF (base colour, emission).
    Colour,
    /// Data: RGB codes scaled to [0, 1] (metallic-roughness, normals).
    Data,
    /// Coverage: the alpha channel scaled to [0, 1], in all three channels (1 for an image
    /// without alpha).
    Alpha,
}

/// The textures the materials read, each loaded once, and the images behind them, each
/// decoded once.
#[derive(Default)]
pub(super) struct Textures {
    /// (glTF texture index, how it is decoded) → index in `list`.
    by_gltf: BTreeMap<(usize, Decode), u32>,
    /// (glTF image index, how it is decoded) → its texels (shared by every texture made from
    /// it).
    images: BTreeMap<(usize, Decode), Texture>,
    /// The textures, as `TextureRef::texture` indexes them.
    pub(super) list: Vec<Texture>,
    /// Loaded textures whose `minFilter` irr does not follow.
    min_filters_ignored: usize,
}

impl Textures {
    /// Warns of what the file holds and irr did not read: textures and images no material reads
    /// as base colour, emission, metallic-roughness or normals, and `minFilter`s.
    pub(super) fn warn(&self, loader: &mut Loader<'_>) {
        let d = loader.document;
        let distinct = |keys: &mut dyn Iterator<Item = usize>| {
            keys.collect::<std::collections::BTreeSet<_>>().len()
        };
        let textures = d
            .textures()
            .len()
            .saturating_sub(distinct(&mut self.by_gltf.keys().map(|k| k.0)));
        loader.warnings.add("textures", textures, |n| {
            format!(
                "{} ignored (irr reads baseColorTexture, emissiveTexture, metallicRoughnessTexture and normalTexture only)",
                plural(n, "texture", "textures")
            )
        });
        let images = d
            .images()
            .len()
            .saturating_sub(distinct(&mut self.images.keys().map(|k| k.0)));
        loader.warnings.add("images", images, |n| {
            format!(
                "{} ignored (no baseColorTexture, emissiveTexture, metallicRoughnessTexture or normalTexture uses {})",
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
    /// the texture and its image the first time one is met, decoded as `decode` says (colours,
    /// data or coverage).
    pub(super) fn texture_ref(
        &mut self,
        textures: &mut Textures,
        info: &gltf::json::texture::Info,
        what: &str,
        buffers: &[Vec<u8>],
        decode: Decode,
    ) -> Result<TextureRef, LoadError> {
        let index = info.index.value();
        let texture = match textures.by_gltf.get(&(index, decode)) {
            Some(&t) => t,
            None => {
                let t = self.texture(textures, index, what, buffers, decode)?;
                let id = u32::try_from(textures.list.len())
                    .map_err(|_| self.err(format!("{what}: too many textures")))?;
                textures.list.push(t);
                textures.by_gltf.insert((index, decode), id);
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
        decode: Decode,
    ) -> Result<Texture, LoadError> {
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
        // Once per glTF texture, though it may load more than once (as colour, data, alpha).
        let first = !textures.by_gltf.keys().any(|k| k.0 == index);
        textures.min_filters_ignored += usize::from(min_filter_ignored && first);
        let image = json.source.value();
        let texels = match textures.images.get(&(image, decode)) {
            Some(t) => t.clone(),
            None => {
                let t = self.image(image, &name, buffers, decode)?;
                textures.images.insert((image, decode), t.clone());
                t
            }
        };
        Ok(texels.with_sampler(sampler))
    }

    /// Decodes glTF image `index` (read by `texture`, for messages) as `decode` says.
    fn image(
        &mut self,
        index: usize,
        texture: &str,
        buffers: &[Vec<u8>],
        decode: Decode,
    ) -> Result<Texture, LoadError> {
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
        if decode == Decode::Alpha && !has_alpha(bytes) {
            // Coverage 1 everywhere, without decoding (or charging) the image again.
            return Texture::new(1, 1, vec![Vec3::ONE], Sampler::default())
                .map_err(|e| self.err(format!("{name}: {e}")));
        }
        decode_image(bytes, &mut self.budget, decode).map_err(|e| self.err(format!("{name}: {e}")))
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
pub(crate) fn texture_transform(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> Affine2 {
    let (sin, cos) = rotation.sin_cos();
    Affine2::from_cols(
        Vec2::new(cos * scale[0], -sin * scale[0]),
        Vec2::new(sin * scale[1], cos * scale[1]),
        Vec2::from_array(offset),
    )
}

/// The sRGB electro-optical transfer function (IEC 61966-2-1): an encoded value in [0, 1] to
/// linear light.
pub(crate) fn srgb_to_linear(c: f64) -> f64 {
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

/// Whether an image can carry alpha: a PNG of colour type grey + alpha or RGBA, or with a
/// `tRNS` chunk before its image data (PNG §11.3.2); JPEG never does.
fn has_alpha(bytes: &[u8]) -> bool {
    if format_of(bytes) != Some(Format::Png) {
        return false;
    }
    // IHDR's colour type: after the signature (8), IHDR's length and type (8), width and
    // height (8) and the bit depth (1).
    if matches!(bytes.get(25), Some(4 | 6)) {
        return true;
    }
    let mut at = 8usize;
    while let Some(header) = bytes.get(at..at + 8) {
        let length = u32::from_be_bytes([header[0], header[1], header[2], header[3]]) as usize;
        match &header[4..8] {
            b"tRNS" => return true,
            b"IDAT" | b"IEND" => return false,
            _ => at = at.saturating_add(12).saturating_add(length),
        }
    }
    false
}

/// Decodes a PNG or JPEG into linear texels (with the default sampler), charging `budget` for
/// every allocation its header implies before decoding, as `decode` says: colour codes through
/// the sRGB EOTF, data codes scaled to [0, 1], or the alpha channel scaled to [0, 1].
fn decode_image(bytes: &[u8], budget: &mut Budget, decode: Decode) -> Result<Texture, String> {
    let (width, height, texels) = match format_of(bytes) {
        Some(Format::Png) => decode_png(bytes, budget, decode)?,
        Some(Format::Jpeg) => decode_jpeg(bytes, budget, decode)?,
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

/// The values of 8-bit codes: sRGB colours ([`srgb8_table`]) or, for data and alpha, c/255.
fn code8_table(decode: Decode) -> [f32; 256] {
    if decode != Decode::Colour {
        std::array::from_fn(|c| (c as f64 / 255.0) as f32)
    } else {
        srgb8_table()
    }
}

/// Charges the texels of a `width` × `height` image and reserves them.
fn texel_vec(budget: &mut Budget, width: u32, height: u32) -> Result<Vec<Vec3>, String> {
    let n = (width as usize).saturating_mul(height as usize);
    budget.vec::<Vec3>("its linear texels", n)
}

fn decode_png(
    bytes: &[u8],
    budget: &mut Budget,
    decode: Decode,
) -> Result<(u32, u32, Vec<Vec3>), String> {
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
    // Grey (and grey + alpha) repeats its one channel; alpha, the last channel of grey +
    // alpha and RGBA, is read only as coverage.
    let has_alpha = channels == 2 || channels == 4;
    let channel_of = |k: usize| match decode {
        Decode::Alpha => has_alpha.then_some(channels - 1),
        _ if channels >= 3 => Some(k),
        _ => Some(0),
    };
    let [r, g, b] = [0, 1, 2].map(channel_of);
    let rows = decoded.chunks_exact(frame.line_size).take(height as usize);
    if sample_bytes == 1 {
        let table = code8_table(decode);
        for row in rows {
            for px in row.chunks_exact(channels).take(width as usize) {
                let t = |k: Option<usize>| k.map_or(1.0, |k| table[usize::from(px[k])]);
                texels.push(Vec3::new(t(r), t(g), t(b)));
            }
        }
    } else {
        let table: Vec<f32> = (0..=u16::MAX)
            .map(|c| {
                let v = f64::from(c) / 65535.0;
                (if decode == Decode::Colour {
                    srgb_to_linear(v)
                } else {
                    v
                }) as f32
            })
            .collect();
        for row in rows {
            for px in row.chunks_exact(2 * channels).take(width as usize) {
                let t = |k: Option<usize>| {
                    k.map_or(1.0, |k| {
                        table[usize::from(u16::from_be_bytes([px[2 * k], px[2 * k + 1]]))]
                    })
                };
                texels.push(Vec3::new(t(r), t(g), t(b)));
            }
        }
    }
    Ok((width, height, texels))
}

/// Bytes per texel that JPEG decoding takes besides the output: a progressive JPEG keeps every
/// component's DCT coefficients (an i16 each) until its last scan: at most 4 components.
const JPEG_COEFFICIENT_BYTES: usize = 8;

fn decode_jpeg(
    bytes: &[u8],
    budget: &mut Budget,
    decode: Decode,
) -> Result<(u32, u32, Vec<Vec3>), String> {
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
    if decode == Decode::Alpha {
        // JPEG has no alpha: every texel is fully covered.
        texels.resize(w * h, Vec3::ONE);
        return Ok((width, height, texels));
    }
    let table = code8_table(decode);
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
pub fn tex_coords_by_id(
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
        for t in kept_triangles(mesh) {
            let entries = uv.get(t * sets..(t + 1) * sets).unwrap_or(&[]);
            out.push(entries).map_err(|e| e.to_string())?;
        }
    }
    Ok(out)
}

/// The indices, in order, of the triangles of `mesh` that [`irr_geometry::Geometry::build`]
/// keeps ([`Triangle::is_kept`]; a triangle whose indices point past the positions is skipped
/// too).
fn kept_triangles(mesh: &TriangleMesh) -> impl Iterator<Item = usize> + '_ {
    mesh.indices.iter().enumerate().filter_map(|(t, idx)| {
        let p = idx.map(|i| mesh.positions.get(i as usize).copied());
        match p {
            [Some(a), Some(b), Some(c)] if Triangle::is_kept(&[a, b, c]) => Some(t),
            _ => None,
        }
    })
}

/// The per-vertex values of the triangles of `meshes` (per mesh, one triple per triangle, or
/// none: [`SceneData::colours`](super::SceneData::colours),
/// [`SceneData::tangents`](super::SceneData::tangents)) by the id the geometry gives each kept
/// triangle; empty when no mesh has any.
pub fn attribute_by_id<T>(
    meshes: &[TriangleMesh],
    values: &[Vec<[T; 3]>],
) -> Result<VertexAttribute<T>, String>
where
    T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
{
    let mut out = VertexAttribute::default();
    if values.iter().all(Vec::is_empty) {
        return Ok(out);
    }
    for (mesh, c) in meshes.iter().zip(values) {
        for t in kept_triangles(mesh) {
            out.push(c.get(t).copied()).map_err(|e| e.to_string())?;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::files::LoadOptions;
    use crate::load::{load_gltf, load_gltf_with};
    use crate::testutil::{Gltf, base64, crc32, lin, png_bytes, texels, textured_quad, write};
    use crate::uri::decode_base64;

    /// A valid 1×1 RGB PNG whose header claims `width` × `height` (with a correct CRC, so only
    /// the size is wrong).
    pub(crate) fn png_claiming(width: u32, height: u32) -> Vec<u8> {
        let mut p = png_bytes(
            1,
            1,
            png::ColorType::Rgb,
            png::BitDepth::Eight,
            None,
            &[1, 2, 3],
        );
        p[16..20].copy_from_slice(&width.to_be_bytes());
        p[20..24].copy_from_slice(&height.to_be_bytes());
        let crc = crc32(&p[12..29]);
        p[29..33].copy_from_slice(&crc.to_be_bytes());
        p
    }

    fn decode(bytes: &[u8]) -> Result<Texture, String> {
        let mut budget = Budget::new(MemoryLimit::bytes(1 << 30), bytes.len() as u64);
        decode_image(bytes, &mut budget, Decode::Colour)
    }

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
        let e = decode(b"GIF89a....").err().unwrap_or_default();
        assert!(e.contains("neither PNG nor JPEG"), "{e}");
    }

    #[test]
    fn every_png_colour_type_and_depth_decodes_to_linear_rgb() {
        use png::{BitDepth, ColorType};
        let expect = |got: &Texture, want: &[[u8; 3]]| {
            let want: Vec<Vec3> = want
                .iter()
                .map(|c| Vec3::new(lin(c[0]), lin(c[1]), lin(c[2])))
                .collect();
            assert_eq!(texels(got), want);
        };
        let rgb = png_bytes(
            2,
            1,
            ColorType::Rgb,
            BitDepth::Eight,
            None,
            &[0, 128, 255, 10, 20, 30],
        );
        expect(
            &decode(&rgb).unwrap_or_else(|e| panic!("{e}")),
            &[[0, 128, 255], [10, 20, 30]],
        );
        // Alpha is dropped, whatever its value.
        let rgba = png_bytes(
            1,
            2,
            ColorType::Rgba,
            BitDepth::Eight,
            None,
            &[1, 2, 3, 0, 4, 5, 6, 255],
        );
        expect(
            &decode(&rgba).unwrap_or_else(|e| panic!("{e}")),
            &[[1, 2, 3], [4, 5, 6]],
        );
        let grey = png_bytes(2, 1, ColorType::Grayscale, BitDepth::Eight, None, &[7, 200]);
        expect(
            &decode(&grey).unwrap_or_else(|e| panic!("{e}")),
            &[[7, 7, 7], [200, 200, 200]],
        );
        let grey_alpha = png_bytes(
            1,
            1,
            ColorType::GrayscaleAlpha,
            BitDepth::Eight,
            None,
            &[99, 0],
        );
        expect(
            &decode(&grey_alpha).unwrap_or_else(|e| panic!("{e}")),
            &[[99, 99, 99]],
        );
        let palette = [255, 0, 0, 0, 0, 255];
        let indexed = png_bytes(
            2,
            1,
            ColorType::Indexed,
            BitDepth::Eight,
            Some(&palette),
            &[1, 0],
        );
        expect(
            &decode(&indexed).unwrap_or_else(|e| panic!("{e}")),
            &[[0, 0, 255], [255, 0, 0]],
        );
        // 1-bit grey: 0b10 in the row's first byte's top bits → white, black.
        let bits = png_bytes(
            2,
            1,
            ColorType::Grayscale,
            BitDepth::One,
            None,
            &[0b1000_0000],
        );
        expect(
            &decode(&bits).unwrap_or_else(|e| panic!("{e}")),
            &[[255, 255, 255], [0, 0, 0]],
        );
        // 16 bits per sample (big-endian): 0x8000 is 32768/65535 before the EOTF.
        let deep = png_bytes(
            1,
            1,
            ColorType::Rgb,
            BitDepth::Sixteen,
            None,
            &[0x80, 0, 0xff, 0xff, 0, 0],
        );
        let t = decode(&deep).unwrap_or_else(|e| panic!("{e}"));
        let half = srgb_to_linear(32768.0 / 65535.0) as f32;
        assert_eq!(texels(&t), vec![Vec3::new(half, 1.0, 0.0)]);
    }

    /// 16×16 JPEGs, left half sRGB (200, 100, 50), right half (20, 60, 240), made by libjpeg
    /// (`cjpeg -quality 100 -sample 1x1 -baseline`, and `-progressive`).
    const JPEG_BASELINE: &str = "/9j/4AAQSkZJRgABAQAAAQABAAD/2wBDAAEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQH/2wBDAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQH/wAARCAAQABADAREAAhEBAxEB/8QAHwAAAQUBAQEBAQEAAAAAAAAAAAECAwQFBgcICQoL/8QAtRAAAgEDAwIEAwUFBAQAAAF9AQIDAAQRBRIhMUEGE1FhByJxFDKBkaEII0KxwRVS0fAkM2JyggkKFhcYGRolJicoKSo0NTY3ODk6Q0RFRkdISUpTVFVWV1hZWmNkZWZnaGlqc3R1dnd4eXqDhIWGh4iJipKTlJWWl5iZmqKjpKWmp6ipqrKztLW2t7i5usLDxMXGx8jJytLT1NXW19jZ2uHi4+Tl5ufo6erx8vP09fb3+Pn6/8QAHwEAAwEBAQEBAQEBAQAAAAAAAAECAwQFBgcICQoL/8QAtREAAgECBAQDBAcFBAQAAQJ3AAECAxEEBSExBhJBUQdhcRMiMoEIFEKRobHBCSMzUvAVYnLRChYkNOEl8RcYGRomJygpKjU2Nzg5OkNERUZHSElKU1RVVldYWVpjZGVmZ2hpanN0dXZ3eHl6goOEhYaHiImKkpOUlZaXmJmaoqOkpaanqKmqsrO0tba3uLm6wsPExcbHyMnK0tPU1dbX2Nna4uPk5ebn6Onq8vP09fb3+Pn6/9oADAMBAAIRAxEAPwDn6/yvP9sD8R6/9Fg/5Nz9uK/86c/6yD8R6/8ARYP+Tc//2Q==";
    const JPEG_PROGRESSIVE: &str = "/9j/4AAQSkZJRgABAQAAAQABAAD/2wBDAAEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQH/2wBDAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQH/wgARCAAQABADAREAAhEBAxEB/8QAFQABAQAAAAAAAAAAAAAAAAAACAX/xAAWAQEBAQAAAAAAAAAAAAAAAAAJCgj/2gAMAwEAAhADEAAAAZ+V9sCOiwm25OmsgjosJv8A/8QAFBABAAAAAAAAAAAAAAAAAAAAIP/aAAgBAQABBQIf/8QAFBEBAAAAAAAAAAAAAAAAAAAAIP/aAAgBAwEBPwEf/8QAFBEBAAAAAAAAAAAAAAAAAAAAIP/aAAgBAgEBPwEf/8QAFBABAAAAAAAAAAAAAAAAAAAAIP/aAAgBAQAGPwIf/8QAFBABAAAAAAAAAAAAAAAAAAAAIP/aAAgBAQABPyEf/9oADAMBAAIAAwAAABAAD//EABQRAQAAAAAAAAAAAAAAAAAAACD/2gAIAQMBAT8QH//EABQRAQAAAAAAAAAAAAAAAAAAACD/2gAIAQIBAT8QH//EABQQAQAAAAAAAAAAAAAAAAAAACD/2gAIAQEAAT8QH//Z";

    /// Decoded as coverage, an image gives its alpha channel scaled to [0, 1] in all three
    /// channels (8 and 16 bits, RGBA and grey + alpha), and 1 where it has none (RGB, JPEG).
    #[test]
    fn alpha_decodes_as_coverage() {
        use png::{BitDepth, ColorType};
        let alpha = |bytes: &[u8]| {
            let t = decode_image(
                bytes,
                &mut Budget::new(MemoryLimit::bytes(1 << 30), bytes.len() as u64),
                Decode::Alpha,
            )
            .unwrap_or_else(|e| panic!("{e}"));
            texels(&t)
        };
        let rgba = png_bytes(
            2,
            1,
            ColorType::Rgba,
            BitDepth::Eight,
            None,
            &[9, 9, 9, 0, 9, 9, 9, 51],
        );
        assert_eq!(alpha(&rgba), [Vec3::ZERO, Vec3::splat(0.2)]);
        let grey_alpha = png_bytes(
            1,
            1,
            ColorType::GrayscaleAlpha,
            BitDepth::Sixteen,
            None,
            &[0, 0, 255, 255],
        );
        assert_eq!(alpha(&grey_alpha), [Vec3::ONE]);
        let rgb = png_bytes(1, 1, ColorType::Rgb, BitDepth::Eight, None, &[1, 2, 3]);
        assert_eq!(alpha(&rgb), [Vec3::ONE]);
        let jpeg = decode_base64(JPEG_BASELINE).unwrap_or_else(|e| panic!("{e}"));
        assert!(alpha(&jpeg).iter().all(|&t| t == Vec3::ONE));
    }

    #[test]
    fn jpegs_decode_to_linear_rgb() {
        for (name, text) in [
            ("baseline", JPEG_BASELINE),
            ("progressive", JPEG_PROGRESSIVE),
        ] {
            let bytes = decode_base64(text).unwrap_or_else(|e| panic!("{e}"));
            let t = decode(&bytes).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!((t.width(), t.height()), (16, 16));
            // JPEG is lossy: at quality 100 without chroma subsampling libjpeg's own decoder
            // returns these blocks within 1 code of the input, and IDCTs may differ by one
            // more code (ITU-T T.83's accuracy bound), so each channel is within ±2 codes.
            for (x, want) in [(2, [200u8, 100, 50]), (13, [20, 60, 240])] {
                let got = t.texel(x, 5);
                for c in 0..3 {
                    let (lo, hi) = (
                        lin(want[c].saturating_sub(2)),
                        lin(want[c].saturating_add(2)),
                    );
                    assert!(
                        (lo..=hi).contains(&got[c]),
                        "{name}: texel {x}, channel {c}: {} not in [{lo}, {hi}]",
                        got[c]
                    );
                }
            }
        }
    }

    #[test]
    fn absurd_or_damaged_images_are_refused_before_decoding() {
        let e = decode(&png_claiming(100_000, 100_000))
            .err()
            .unwrap_or_default();
        assert!(e.contains("100000×100000") && e.contains("16384"), "{e}");
        let e = decode(&png_claiming(0, 5)).err().unwrap_or_default();
        assert!(e.contains("empty"), "{e}");
        // Within the side limit, but the 1×1 image's data cannot fill it: refused by the
        // decoder before the budget is asked for 16000²·(3 + 12) bytes.
        let e = decode(&png_claiming(16000, 16000))
            .err()
            .unwrap_or_default();
        assert!(e.starts_with("PNG: "), "{e}");
        // Past the budget: a 1200² RGB image is 4.3 MB decoded plus 17.3 MB of f32 texels, more
        // than a 16 MiB memory limit; refused before its texels are allocated, and decoded
        // within 1 GiB.
        let big = png_bytes(
            1200,
            1200,
            png::ColorType::Rgb,
            png::BitDepth::Eight,
            None,
            &vec![0; 1200 * 1200 * 3],
        );
        let e = decode_image(
            &big,
            &mut Budget::new(MemoryLimit::bytes(16 << 20), 0),
            Decode::Colour,
        )
        .err()
        .unwrap_or_default();
        assert!(
            e.starts_with("its linear texels needs 1440000 elements"),
            "{e}"
        );
        assert!(decode(&big).is_ok());
        // A truncated PNG: the decoder's error, not a panic.
        let whole = png_bytes(
            64,
            64,
            png::ColorType::Rgb,
            png::BitDepth::Eight,
            None,
            &(0..64 * 64 * 3)
                .map(|i| (i * 7 % 251) as u8)
                .collect::<Vec<u8>>(),
        );
        for cut in [whole.len() / 2, 40, 20, 9] {
            let e = decode(&whole[..cut]).err().unwrap_or_default();
            assert!(e.starts_with("PNG: "), "cut at {cut}: {e}");
        }
        // A truncated JPEG is decoded as far as it goes or refused, never a panic.
        let jpeg = decode_base64(JPEG_BASELINE).unwrap_or_else(|e| panic!("{e}"));
        for cut in [jpeg.len() / 2, 20, 3] {
            let _ = decode(&jpeg[..cut]);
        }
    }

    /// Damaged images (bytes flipped, set to extreme values, or cut short, a few at a time,
    /// from a fixed counter-based generator) are refused or decoded, never a panic (a decoded
    /// one went through `Texture::new`, which checks its texel count against its size).
    #[test]
    fn damaged_images_never_panic() {
        let png = png_bytes(
            16,
            16,
            png::ColorType::Rgba,
            png::BitDepth::Eight,
            None,
            &(0..16 * 16 * 4)
                .map(|i| (i * 13 % 256) as u8)
                .collect::<Vec<u8>>(),
        );
        let jpegs = [JPEG_BASELINE, JPEG_PROGRESSIVE]
            .map(|t| decode_base64(t).unwrap_or_else(|e| panic!("{e}")));
        // SplitMix64 (Steele et al. 2014), one stream per case.
        let next = |state: &mut u64| {
            *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = *state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^ (z >> 31)
        };
        for (name, original) in [
            ("png", &png),
            ("baseline", &jpegs[0]),
            ("progressive", &jpegs[1]),
        ] {
            for case in 0..300u64 {
                let mut state = case;
                let mut bytes = original.clone();
                for _ in 0..1 + next(&mut state) % 4 {
                    let at = (next(&mut state) % bytes.len() as u64) as usize;
                    match next(&mut state) % 4 {
                        0 => bytes[at] ^= 1 << (next(&mut state) % 8),
                        1 => bytes[at] = 0xff,
                        2 => bytes[at] = 0,
                        _ => bytes.truncate(at.max(1)),
                    }
                }
                let result = std::panic::catch_unwind(|| decode(&bytes));
                match result {
                    Err(_) => panic!("{name} case {case}: the decoder panicked"),
                    Ok(Ok(t)) => assert!(t.width() >= 1 && t.height() >= 1),
                    Ok(Err(_)) => {}
                }
            }
        }
    }

    #[test]
    fn bad_textures_are_refused_naming_the_file_and_the_image() {
        let d = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        std::fs::create_dir(d.path().join("scene")).unwrap_or_else(|e| panic!("{e}"));
        let grey = png_bytes(
            1,
            1,
            png::ColorType::Grayscale,
            png::BitDepth::Eight,
            None,
            &[128],
        );
        write(d.path(), "outside.png", &grey);
        let material = r#""materials":[{"pbrMetallicRoughness":{"baseColorTexture":{"index":0}}}]"#;
        for (case, rest, needles) in [
            (
                "index",
                r#""images":[{"uri":"a.png"}],"textures":[{"source":0}],"materials":[{"pbrMetallicRoughness":{"baseColorTexture":{"index":5}}}]"#
                    .to_string(),
                vec!["baseColorTexture.index", "Index out of bounds"],
            ),
            (
                "outside",
                format!(
                    r#""images":[{{"uri":"../outside.png"}}],"textures":[{{"source":0}}],{material}"#
                ),
                vec!["image 0", "outside the folder irr reads images from"],
            ),
            (
                "absolute",
                format!(
                    r#""images":[{{"uri":"/etc/passwd"}}],"textures":[{{"source":0}}],{material}"#
                ),
                vec!["image 0", "absolute path"],
            ),
            (
                "missing",
                format!(
                    r#""images":[{{"uri":"nothing.png","name":"wood"}}],"textures":[{{"source":0}}],{material}"#
                ),
                vec!["image 0 \"wood\"", "nothing.png", "points nowhere"],
            ),
            (
                "scheme",
                format!(
                    r#""images":[{{"uri":"https://example.com/a.png"}}],"textures":[{{"source":0}}],{material}"#
                ),
                vec!["image 0", "scheme 'https:'"],
            ),
            (
                "not-an-image",
                format!(
                    r#""images":[{{"uri":"data:image/png;base64,{}"}}],"textures":[{{"source":0}}],{material}"#,
                    base64(b"hello")
                ),
                vec!["image 0", "neither PNG nor JPEG"],
            ),
            (
                "huge",
                format!(
                    r#""images":[{{"uri":"data:image/png;base64,{}"}}],"textures":[{{"source":0}}],{material}"#,
                    base64(&png_claiming(100_000, 100_000))
                ),
                vec!["image 0", "100000×100000", "16384"],
            ),
            (
                "transform",
                format!(
                    r#""extensionsUsed":["KHR_texture_transform"],"images":[{{"uri":"data:image/png;base64,{}"}}],"textures":[{{"source":0}}],
                    "materials":[{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0,"extensions":{{"KHR_texture_transform":{{"scale":[1e39,1]}}}}}}}}}}]"#,
                    base64(&grey)
                ),
                vec!["baseColorTexture", "KHR_texture_transform is not finite"],
            ),
        ] {
            let mut g = Gltf::default();
            let path = textured_quad(
                &d.path().join("scene"),
                &format!("{case}.gltf"),
                &mut g,
                &rest,
            );
            let e = match load_gltf_with(&path, &LoadOptions::default()) {
                Ok(_) => panic!("{case}: loaded"),
                Err(e) => e.to_string(),
            };
            assert!(e.contains(&format!("{case}.gltf")), "{case}: {e}");
            assert!(!e.contains('\n'), "{case}: {e}");
            for n in needles {
                assert!(e.contains(n), "{case}: no '{n}' in: {e}");
            }
        }
    }

    #[test]
    fn texture_coordinates_follow_the_ids_of_kept_triangles() {
        // Mesh 0: a degenerate triangle (dropped by the geometry) between two good ones; mesh
        // 1, untextured, then mesh 2, textured. Each triangle's coordinates name it.
        let good = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let mesh = |tris: &[[Vec3; 3]], material: u32| TriangleMesh {
            positions: tris.iter().flatten().copied().collect(),
            indices: (0..tris.len() as u32)
                .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
                .collect(),
            normals: None,
            material_ids: vec![material; tris.len()],
        };
        let meshes = [
            mesh(&[good, [Vec3::ZERO, Vec3::X, Vec3::X * 2.0], good], 0),
            mesh(&[good], 1),
            mesh(&[good], 0),
        ];
        let tag = |k: f32| [Vec2::splat(k); 3];
        let materials = [
            Material {
                albedo_texture: Some(TextureRef::new(0, 0)),
                ..Material::diffuse(Vec3::ONE)
            },
            Material::diffuse(Vec3::ONE),
        ];
        let uv = vec![vec![tag(1.0), tag(2.0), tag(3.0)], vec![], vec![tag(4.0)]];
        let c = tex_coords_by_id(&meshes, &materials, &uv).unwrap_or_else(|e| panic!("{e}"));
        let geometry = irr_geometry::Geometry::build(&meshes).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(c.triangle_count(), geometry.triangle_count());
        assert_eq!(c.of(0), [tag(1.0)]);
        assert_eq!(c.of(1), [tag(3.0)]);
        assert!(c.of(2).is_empty());
        assert_eq!(c.of(3), [tag(4.0)]);
        // No textured material: nothing stored.
        let plain = [Material::diffuse(Vec3::ONE); 2];
        assert!(
            tex_coords_by_id(&meshes, &plain, &uv)
                .unwrap_or_else(|e| panic!("{e}"))
                .is_empty()
        );
    }

    #[test]
    fn texture_coordinates_must_be_readable_and_a_missing_set_reads_zero() {
        let d = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let grey = base64(&png_bytes(
            1,
            1,
            png::ColorType::Grayscale,
            png::BitDepth::Eight,
            None,
            &[9],
        ));
        let mut g = Gltf::default();
        let p = g.vec3(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        let raw_u8 = g.accessor(&[0; 6], r#""componentType":5121,"count":3,"type":"VEC2""#);
        let short = g.accessor(&[0; 8], r#""componentType":5126,"count":1,"type":"VEC2""#);
        let nan: Vec<u8> = [0.0f32, f32::NAN, 0.0, 0.0, 0.0, 0.0]
            .iter()
            .flat_map(|f| f.to_le_bytes())
            .collect();
        let nan = g.accessor(&nan, r#""componentType":5126,"count":3,"type":"VEC2""#);
        let u16s: Vec<u8> = [0u16, 65535, 32768, 0, 0, 0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let u16s = g.accessor(
            &u16s,
            r#""componentType":5123,"normalized":true,"count":3,"type":"VEC2""#,
        );
        let rest = |texcoord: &str| {
            g.json(&format!(
                r#""scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
                "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}{texcoord}}},"material":0}}]}}],
                "images":[{{"uri":"data:image/png;base64,{grey}"}}],"textures":[{{"source":0}}],
                "materials":[{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}}}}}}]"#
            ))
        };
        for (case, attribute, needle) in [
            ("raw", format!(r#","TEXCOORD_0":{raw_u8}"#), "normalized"),
            (
                "count",
                format!(r#","TEXCOORD_0":{short}"#),
                "TEXCOORD_0 has 1 elements but POSITION has 3",
            ),
            (
                "nan",
                format!(r#","TEXCOORD_0":{nan}"#),
                "TEXCOORD_0 element 0 is not finite",
            ),
        ] {
            let e = match load_gltf(&write(d.path(), &format!("{case}.gltf"), rest(&attribute))) {
                Ok(_) => panic!("{case}: loaded"),
                Err(e) => e.to_string(),
            };
            assert!(e.contains(needle), "{case}: {e}");
        }
        let ok = load_gltf(&write(
            d.path(),
            "u16.gltf",
            rest(&format!(r#","TEXCOORD_0":{u16s}"#)),
        ))
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            ok.tex_coords,
            vec![vec![[
                Vec2::new(0.0, 1.0),
                Vec2::new(32768.0 / 65535.0, 0.0),
                Vec2::ZERO
            ]]]
        );
        let missing =
            load_gltf(&write(d.path(), "none.gltf", rest(""))).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(missing.tex_coords, vec![vec![[Vec2::ZERO; 3]]]);
        assert!(
            missing
                .warnings
                .iter()
                .any(|w| w.feature == "missing-texcoord"),
            "{:?}",
            missing.warnings
        );
    }
}
