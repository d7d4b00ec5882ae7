//! Test helpers (with the `testing` feature): a tiny glTF writer, so loader tests can state
//! exactly the file they read, and PNG images for its textures.

use crate::{Filter, Sampler, Texture, Wrap};
use glam::{Affine2, Vec3};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Standard base64 with padding (RFC 4648 §4), independent of the decoder under test.
pub fn base64(data: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for chunk in data.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for i in 0..4 {
            if i <= chunk.len() {
                s.push(char::from(ALPHABET[((n >> (18 - 6 * i)) & 63) as usize]));
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// Builds one buffer and its views and accessors; the rest of the JSON is given as text.
#[derive(Default)]
pub struct Gltf {
    /// The buffer's bytes.
    pub bin: Vec<u8>,
    /// The buffer views, as JSON objects.
    pub views: Vec<String>,
    /// The accessors, as JSON objects.
    pub accessors: Vec<String>,
}

impl Gltf {
    fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.views.push(format!(
            r#"{{"buffer":0,"byteOffset":{offset},"byteLength":{}}}"#,
            bytes.len()
        ));
        self.views.len() - 1
    }

    /// A VEC3 FLOAT accessor.
    pub fn vec3(&mut self, values: &[[f32; 3]]) -> usize {
        let bytes: Vec<u8> = values
            .iter()
            .flat_map(|v| v.iter().flat_map(|c| c.to_le_bytes()))
            .collect();
        let view = self.view(&bytes);
        self.accessors.push(format!(
            r#"{{"bufferView":{view},"componentType":5126,"count":{},"type":"VEC3"}}"#,
            values.len()
        ));
        self.accessors.len() - 1
    }

    /// An accessor over `bytes` in a view of their own; `fields` are its other members, e.g.
    /// `"componentType":5121,"normalized":true,"count":3,"type":"VEC2"`.
    pub fn accessor(&mut self, bytes: &[u8], fields: &str) -> usize {
        let view = self.view(bytes);
        self.accessors
            .push(format!(r#"{{"bufferView":{view},{fields}}}"#));
        self.accessors.len() - 1
    }

    /// A buffer view over `bytes` (an image's, say), by index.
    pub fn view_of(&mut self, bytes: &[u8]) -> usize {
        self.view(bytes)
    }

    /// A SCALAR index accessor of component type 5121 (u8), 5123 (u16) or 5125 (u32).
    pub fn indices(&mut self, values: &[u32], component_type: u32) -> usize {
        let bytes: Vec<u8> = match component_type {
            5121 => values.iter().map(|&v| v as u8).collect(),
            5123 => values
                .iter()
                .flat_map(|&v| (v as u16).to_le_bytes())
                .collect(),
            _ => values.iter().flat_map(|&v| v.to_le_bytes()).collect(),
        };
        let view = self.view(&bytes);
        self.accessors.push(format!(
            r#"{{"bufferView":{view},"componentType":{component_type},"count":{},"type":"SCALAR"}}"#,
            values.len()
        ));
        self.accessors.len() - 1
    }

    /// The whole document: `rest` holds the other top-level members (without braces), e.g.
    /// `"scene":0,"scenes":[…],"nodes":[…],"meshes":[…]`; the buffer is a data URI.
    pub fn json(&self, rest: &str) -> String {
        let mut s = String::from(r#"{"asset":{"version":"2.0"},"#);
        let _ = write!(
            s,
            r#""buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}],"#,
            self.bin.len(),
            base64(&self.bin)
        );
        let _ = write!(s, r#""bufferViews":[{}],"#, self.views.join(","));
        let _ = write!(s, r#""accessors":[{}]"#, self.accessors.join(","));
        if !rest.is_empty() {
            s.push(',');
            s.push_str(rest);
        }
        s.push('}');
        s
    }
}

/// Writes `contents` to `dir/name` and returns the path.
pub fn write(dir: &Path, name: &str, contents: impl AsRef<[u8]>) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, contents).unwrap_or_else(|e| panic!("{e}"));
    path
}

/// The workspace's assets folder.
pub fn assets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets")
}

/// The linear value of 8-bit sRGB code `c`, as the loader computes it.
pub fn lin(c: u8) -> f32 {
    crate::load::srgb_to_linear(f64::from(c) / 255.0) as f32
}
/// A PNG of `data` (rows from the top), through the png crate's encoder.
pub fn png_bytes(
    width: u32,
    height: u32,
    color: png::ColorType,
    depth: png::BitDepth,
    palette: Option<&[u8]>,
    data: &[u8],
) -> Vec<u8> {
    let mut out = Vec::new();
    {
        let mut e = png::Encoder::new(&mut out, width, height);
        e.set_color(color);
        e.set_depth(depth);
        if let Some(p) = palette {
            e.set_palette(p.to_vec());
        }
        let mut w = e.write_header().unwrap_or_else(|e| panic!("{e}"));
        w.write_image_data(data).unwrap_or_else(|e| panic!("{e}"));
    }
    out
}
/// CRC-32 of PNG chunks (ISO 3309, as PNG §5.3 specifies), bit by bit.
pub fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xffff_ffffu32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 == 1 {
                0xedb8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}
/// A texture's texels, row by row from the top.
pub fn texels(t: &Texture) -> Vec<Vec3> {
    (0..i64::from(t.height()))
        .flat_map(|y| (0..i64::from(t.width())).map(move |x| (x, y)))
        .map(|(x, y)| t.texel(x, y))
        .collect()
}
/// A 4-vertex quad with TEXCOORD_0 (normalized u8) and TEXCOORD_1 (float), and `rest` (the
/// images, textures, samplers and materials), written as `dir/name`.
pub fn textured_quad(dir: &Path, name: &str, g: &mut Gltf, rest: &str) -> PathBuf {
    let p = g.vec3(&[
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ]);
    let uv0 = g.accessor(
        &[0, 0, 255, 0, 255, 255, 0, 51],
        r#""componentType":5121,"normalized":true,"count":4,"type":"VEC2""#,
    );
    let uv1_floats: Vec<u8> = [0.0f32, 0.0, 2.0, 0.0, 2.0, -1.0, 0.0, -1.0]
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    let uv1 = g.accessor(
        &uv1_floats,
        r#""componentType":5126,"count":4,"type":"VEC2""#,
    );
    let i = g.indices(&[0, 1, 2, 0, 2, 3], 5123);
    let json = g.json(&format!(
        r#""scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p},"TEXCOORD_0":{uv0},"TEXCOORD_1":{uv1}}},"indices":{i},"material":0}}]}}],
        {rest}"#
    ));
    write(dir, name, json)
}

/// `KHR_texture_transform`'s matrix from its offset, rotation and scale, as the loader builds it.
pub fn texture_transform(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> Affine2 {
    crate::load::texture_transform(offset, rotation, scale)
}

/// A 2×2 texture: texel (x, y) has value (x, y, 10·y + x) so a lookup names its texels.
pub fn two_by_two(wrap: Wrap, filter: Filter) -> Texture {
    let texels = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(0.0, 1.0, 10.0),
        Vec3::new(1.0, 1.0, 11.0),
    ];
    let sampler = Sampler {
        wrap_s: wrap,
        wrap_t: wrap,
        filter,
    };
    Texture::new(2, 2, texels, sampler).unwrap_or_else(|e| panic!("{e}"))
}
