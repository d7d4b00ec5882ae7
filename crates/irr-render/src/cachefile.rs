//! A persistent irradiance cache (`--cache FILE`): the first level's records of one render, kept
//! for a later render of the same scene, camera and settings.
//!
//! Layout (little-endian):
//!
//! | offset | size | content |
//! |---|---|---|
//! | 0 | 8 | magic `IRRICSC1` |
//! | 8 | 8 | fingerprint: FNV-1a of the scene file's bytes, the image size, the camera and the cache settings |
//! | 16 | 8 | n, the number of leak-guard distances (one per record) |
//! | 24 | 4·n | the leak-guard distances, `f32` |
//! | 24 + 4n | … | the records, in irr-cache's versioned, checksummed format (`IrradianceCache::write_to`) |
//!
//! A file made for another scene, camera, image size or settings has another fingerprint and is
//! refused with an error naming the file: never a wrong image. A file of another irr-cache format
//! version is refused by irr-cache's own check. The file is written to a temporary file in the same
//! folder and renamed into place, so an interrupted write never leaves half a file.

use crate::error::RenderError;
use irr_cache::IrradianceCache;
use irr_integrator::IrradianceCacheIntegrator;
use irr_integrator::ic::IcMetric;
use std::io::{Read, Write};
use std::path::Path;

/// The first eight bytes of a cache file.
pub const MAGIC: [u8; 8] = *b"IRRICSC1";

/// FNV-1a over `parts`, each prefixed by its length (so parts cannot run into each other).
pub fn fingerprint(parts: &[&[u8]]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    for p in parts {
        eat(&(p.len() as u64).to_le_bytes());
        eat(p);
    }
    h
}

/// Writes the first level's records of `integrator` to `path` with `fingerprint`.
pub fn write_cache_file(
    path: &Path,
    fingerprint: u64,
    integrator: &IrradianceCacheIntegrator,
) -> Result<(), RenderError> {
    let cache = integrator
        .cache(0)
        .ok_or_else(|| RenderError::write(path, "the integrator has no cache"))?;
    let occluders = integrator.occluder_distances();
    let mut bytes = Vec::with_capacity(24 + 4 * occluders.len() + 128 * cache.len());
    bytes.extend_from_slice(&MAGIC);
    bytes.extend_from_slice(&fingerprint.to_le_bytes());
    bytes.extend_from_slice(&(occluders.len() as u64).to_le_bytes());
    for o in occluders {
        bytes.extend_from_slice(&o.to_le_bytes());
    }
    cache
        .write_to(&mut bytes)
        .map_err(|e| RenderError::write(path, e.to_string()))?;
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let mut temp = tempfile::Builder::new()
        .prefix(".irr-")
        .suffix(".tmp")
        .tempfile_in(folder)
        .map_err(|e| RenderError::write(path, format!("cannot create a temporary file: {e}")))?;
    temp.write_all(&bytes)
        .and_then(|()| temp.as_file().sync_all())
        .map_err(|e| RenderError::write(path, e.to_string()))?;
    temp.persist(path)
        .map_err(|e| RenderError::write(path, e.error.to_string()))?;
    Ok(())
}

/// Reads a cache file written by [`write_cache_file`] for `fingerprint`, filing its records with
/// `metric`; returns the cache and the leak-guard distances. At most `max_bytes` are read.
pub fn read_cache_file(
    path: &Path,
    fingerprint: u64,
    metric: IcMetric,
    max_bytes: u64,
) -> Result<(IrradianceCache<irr_cache::Rgb, IcMetric>, Vec<f32>), RenderError> {
    let bad = |problem: String| RenderError::CacheFile {
        path: path.to_path_buf(),
        problem,
    };
    let file = std::fs::File::open(path).map_err(|e| bad(format!("cannot open: {e}")))?;
    if !file.metadata().map(|m| m.is_file()).unwrap_or(false) {
        return Err(bad("not a regular file".into()));
    }
    let mut bytes = Vec::new();
    file.take(max_bytes)
        .read_to_end(&mut bytes)
        .map_err(|e| bad(format!("cannot read: {e}")))?;
    if bytes.len() < 24 || bytes[..8] != MAGIC {
        return Err(bad("not an irr cache file (bad magic bytes)".into()));
    }
    let word = |at: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&bytes[at..at + 8]);
        u64::from_le_bytes(b)
    };
    let found = word(8);
    if found != fingerprint {
        return Err(bad(format!(
            "this cache was made for another scene, camera, image size or cache settings \
             (fingerprint {found:016x}, this render's is {fingerprint:016x}); delete it or choose another file"
        )));
    }
    let n = word(16);
    let end = n
        .checked_mul(4)
        .and_then(|b| b.checked_add(24))
        .filter(|&e| e <= bytes.len() as u64)
        .ok_or_else(|| bad("truncated (leak-guard distances)".into()))? as usize;
    let occluders: Vec<f32> = bytes[24..end]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    if occluders.iter().any(|o| o.is_nan() || *o < 0.0) {
        return Err(bad("a leak-guard distance is negative or NaN".into()));
    }
    let cache =
        IrradianceCache::read_from(&bytes[end..], metric).map_err(|e| bad(e.to_string()))?;
    if cache.len() != occluders.len() {
        return Err(bad(format!(
            "{} records but {} leak-guard distances",
            cache.len(),
            occluders.len()
        )));
    }
    Ok((cache, occluders))
}
