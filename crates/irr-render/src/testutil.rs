//! Test helpers: a tiny glTF writer, so loader tests can state exactly the file they read.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Standard base64 with padding (RFC 4648 §4), independent of the decoder under test.
pub(crate) fn base64(data: &[u8]) -> String {
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
pub(crate) struct Gltf {
    pub bin: Vec<u8>,
    pub views: Vec<String>,
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
pub(crate) fn write(dir: &Path, name: &str, contents: impl AsRef<[u8]>) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, contents).unwrap_or_else(|e| panic!("{e}"));
    path
}

/// The workspace's assets folder.
pub(crate) fn assets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets")
}
