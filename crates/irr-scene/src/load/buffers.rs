//! Buffers: the .glb's binary chunk, `data:` URIs and files beside the scene.

use super::Loader;
use crate::error::LoadError;
use crate::uri::{decode_data_uri, percent_decode, scheme};

impl Loader<'_> {
    /// The bytes of each buffer: the .glb's binary chunk, a `data:` URI's payload, or the first
    /// `byteLength` bytes of a file inside the asset root. Charges what it reads to the budget's
    /// input.
    pub(super) fn load_buffers(
        &mut self,
        mut blob: Option<Vec<u8>>,
    ) -> Result<Vec<Vec<u8>>, LoadError> {
        let mut out = Vec::new();
        for buffer in self.document.buffers() {
            let i = buffer.index();
            let length = buffer.length();
            let data = match buffer.source() {
                gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                    self.err(format!(
                        "buffer {i} has no URI and the file has no binary chunk (a .glb's BIN), or a second buffer claims it"
                    ))
                })?,
                gltf::buffer::Source::Uri(uri) => {
                    let data = self.read_uri(i, uri, length)?;
                    self.budget.add_input(data.len() as u64);
                    data
                }
            };
            if data.len() < length {
                // A data: URI or the .glb's own chunk, both inside the scene file: naming its
                // size reveals nothing of another file.
                return Err(self.err(format!(
                    "buffer {i} has {} bytes but its byteLength says {length}",
                    data.len()
                )));
            }
            out.push(data);
        }
        Ok(out)
    }

    fn read_uri(&self, i: usize, uri: &str, length: usize) -> Result<Vec<u8>, LoadError> {
        if let Some(decoded) = decode_data_uri(uri) {
            return decoded.map_err(|e| self.err(format!("buffer {i}: {e}")));
        }
        if let Some(scheme) = scheme(uri) {
            return Err(self.err(format!(
                "buffer {i}: URI scheme '{scheme}:' is not supported (irr reads relative file paths and data: URIs)"
            )));
        }
        let name = percent_decode(uri).map_err(|e| self.err(format!("buffer {i}: {e}")))?;
        self.confinement
            .read(&name, length as u64)
            .map_err(|e| self.err(format!("buffer {i}: URI \"{uri}\" {e}")))
    }
}
