//! The binary glTF container (glTF 2.0 specification §4.4 "GLB File Format Specification"):
//! a 12-byte header, a JSON chunk, an optional BIN chunk. Parsed here with every length checked
//! against the bytes actually present, so a truncated or corrupt file gives an error, never a
//! panic or an out-of-bounds read.

/// `glTF` read as a little-endian u32.
const MAGIC: u32 = 0x4654_6C67;
/// `JSON` read as a little-endian u32.
const CHUNK_JSON: u32 = 0x4E4F_534A;
/// `BIN\0` read as a little-endian u32.
const CHUNK_BIN: u32 = 0x004E_4942;

use std::ops::Range;

/// Whether `bytes` start like a binary glTF (and so must be parsed as one).
pub(crate) fn is_glb(bytes: &[u8]) -> bool {
    bytes.starts_with(b"glTF")
}

/// Where the two chunks of a .glb file lie in it (byte ranges), so the caller can take the
/// binary chunk out of the file's bytes without copying it.
pub(crate) struct Glb {
    /// The JSON document.
    pub json: Range<usize>,
    /// The binary buffer that `buffers[0]` without a URI refers to.
    pub bin: Option<Range<usize>>,
}

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// Splits a .glb file into its chunks.
pub(crate) fn parse(bytes: &[u8]) -> Result<Glb, String> {
    let header = |at| {
        u32_at(bytes, at).ok_or_else(|| {
            format!(
                "binary glTF is truncated: {} bytes, shorter than its 12-byte header",
                bytes.len()
            )
        })
    };
    if header(0)? != MAGIC {
        return Err("binary glTF does not start with 'glTF'".to_string());
    }
    let version = header(4)?;
    if version != 2 {
        return Err(format!(
            "binary glTF container version {version} is not supported (irr reads version 2)"
        ));
    }
    let declared = header(8)? as usize;
    if declared > bytes.len() {
        return Err(format!(
            "binary glTF is truncated: its header declares {declared} bytes, the file has {}",
            bytes.len()
        ));
    }
    let bytes = &bytes[..declared];
    let mut at = 12;
    let mut json = None;
    let mut bin = None;
    let mut index = 0;
    while at < bytes.len() {
        let (Some(length), Some(kind)) = (u32_at(bytes, at), u32_at(bytes, at + 4)) else {
            return Err(format!(
                "binary glTF is truncated: chunk {index} header at byte {at} is incomplete"
            ));
        };
        let start = at + 8;
        let end = start
            .checked_add(length as usize)
            .filter(|&e| e <= bytes.len())
            .ok_or_else(|| {
                format!(
                    "binary glTF is truncated: chunk {index} declares {length} bytes, only {} remain",
                    bytes.len().saturating_sub(start)
                )
            })?;
        match (index, kind) {
            (0, CHUNK_JSON) => json = Some(start..end),
            (0, _) => return Err("binary glTF's first chunk is not JSON".to_string()),
            (1, CHUNK_BIN) => bin = Some(start..end),
            (_, CHUNK_JSON) => {
                return Err(format!("binary glTF has a second JSON chunk ({index})"));
            }
            // Unknown chunk types are skipped, as the specification requires.
            _ => {}
        }
        // Chunks are padded to 4-byte boundaries.
        at = end.next_multiple_of(4);
        index += 1;
    }
    let json = json.ok_or_else(|| "binary glTF has no JSON chunk".to_string())?;
    Ok(Glb { json, bin })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    pub(crate) fn build(json: &[u8], bin: Option<&[u8]>) -> Vec<u8> {
        let mut out = Vec::new();
        let pad = |v: &mut Vec<u8>, byte: u8| {
            while !v.len().is_multiple_of(4) {
                v.push(byte);
            }
        };
        let mut j = json.to_vec();
        pad(&mut j, b' ');
        let mut body = Vec::new();
        body.extend_from_slice(&(j.len() as u32).to_le_bytes());
        body.extend_from_slice(&CHUNK_JSON.to_le_bytes());
        body.extend_from_slice(&j);
        if let Some(bin) = bin {
            let mut b = bin.to_vec();
            pad(&mut b, 0);
            body.extend_from_slice(&(b.len() as u32).to_le_bytes());
            body.extend_from_slice(&CHUNK_BIN.to_le_bytes());
            body.extend_from_slice(&b);
        }
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&((12 + body.len()) as u32).to_le_bytes());
        out.extend_from_slice(&body);
        out
    }

    #[test]
    fn round_trip() {
        let file = build(b"{\"a\":1}", Some(&[1, 2, 3]));
        let glb = parse(&file).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(&file[glb.json], b"{\"a\":1} ");
        assert_eq!(glb.bin.map(|r| &file[r]), Some(&[1u8, 2, 3, 0][..]));
    }

    #[test]
    fn every_truncation_is_an_error() {
        let file = build(b"{\"asset\":{\"version\":\"2.0\"}}", Some(&[7; 40]));
        for len in 0..file.len() {
            assert!(parse(&file[..len]).is_err(), "truncated to {len} bytes");
        }
    }

    proptest! {
        #[test]
        fn corrupt_bytes_never_panic(pos in 0usize..64, byte: u8) {
            let mut file = build(b"{\"asset\":{\"version\":\"2.0\"}}", Some(&[7; 16]));
            let p = pos % file.len();
            file[p] = byte;
            let _ = parse(&file);
        }
    }
}
