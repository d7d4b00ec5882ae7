//! A persistent irradiance cache (`--cache FILE`): every level's records of one render, kept for
//! a later render of the same scene, camera, image size, settings and seed.
//!
//! Layout (little-endian):
//!
//! | offset | size | content |
//! |---|---|---|
//! | 0 | 8 | magic `IRRICSC4` (the last byte is the version of this layout and of the light transport its records were computed with: 4 since glTF files render with glossy materials) |
//! | 8 | 8 | fingerprint: FNV-1a of what the render's records depend on (the caller's: irr-cli hashes the scene file's bytes, the image size, the camera, the cache settings, the background and the seed) |
//! | 16 | 8 | L, the number of cache levels (the first, then each cached bounce level) |
//!
//! then, for each level in turn:
//!
//! | size | content |
//! |---|---|
//! | 8 | n, the level's number of records |
//! | 20·n | per record, what the leak guard keeps: the nearest hit distance of its gather (`f32`, finite, ≥ 0), then its geometric normal (3 `f32`, finite, not zero); then its noise, the estimated relative standard error of its irradiance (`f32`, finite, ≥ 0) |
//! | 8 | the byte length of the level's records |
//! | … | the records, in irr-cache's versioned, checksummed format (`IrradianceCache::write_to`) |
//!
//! and last, 8 bytes: FNV-1a of every byte before them ([`fingerprint`] of them).
//!
//! The checksum covers the whole file, so a changed byte anywhere is refused as corrupt rather
//! than read as a different distance or normal (a distance of +∞ would switch the leak guard off
//! for its record). A file made for another scene, camera, image size, setting or seed has
//! another fingerprint and is refused with an error naming the file: never a wrong image. The
//! file is opened only if it is a regular file, without blocking (a FIFO is refused, never
//! waited on), and written to a temporary file in the same folder and renamed into place, so an
//! interrupted write never leaves half a file.

use crate::digest::Fnv;
use crate::error::RenderError;
use crate::files::{open_regular, read_prefix};
use crate::output::write_file_atomically;
use glam::Vec3;
use irr_cache::IrradianceCache;
use irr_integrator::{
    CacheBuilder, CachedLevel, GuardRecord, IcSettings, IrradianceCacheIntegrator,
};
use std::path::Path;

/// The first eight bytes of a cache file.
pub const MAGIC: [u8; 8] = *b"IRRICSC4";

/// The bytes of one record's entry: its leak-guard data and its noise.
pub const ENTRY_BYTES: usize = 20;

/// FNV-1a over `parts`, each prefixed by its length (so parts cannot run into each other).
pub fn fingerprint(parts: &[&[u8]]) -> u64 {
    let mut h = Fnv::default();
    for p in parts {
        h.update_part(p);
    }
    h.finish()
}

/// Writes every level of `integrator`'s cache to `path` with `fingerprint`.
pub fn write_cache_file(
    path: &Path,
    fingerprint: u64,
    integrator: &IrradianceCacheIntegrator,
) -> Result<(), RenderError> {
    let levels = integrator.levels() as usize;
    let mut bytes = Vec::new();
    bytes.extend_from_slice(&MAGIC);
    bytes.extend_from_slice(&fingerprint.to_le_bytes());
    bytes.extend_from_slice(&(levels as u64).to_le_bytes());
    for level in 0..levels {
        let cache = integrator.cache(level).ok_or_else(|| {
            RenderError::write(path, format!("the integrator has no level {level}"))
        })?;
        let guard = integrator.guard_records(level);
        let noise = integrator.record_noise(level);
        if noise.len() != guard.len() {
            return Err(RenderError::write(
                path,
                format!(
                    "level {level}: {} leak-guard entries but {} noise entries",
                    guard.len(),
                    noise.len()
                ),
            ));
        }
        bytes.extend_from_slice(&(guard.len() as u64).to_le_bytes());
        for (g, n) in guard.iter().zip(noise) {
            bytes.extend_from_slice(&g.nearest_hit.to_le_bytes());
            for c in g.geometric_normal.to_array() {
                bytes.extend_from_slice(&c.to_le_bytes());
            }
            bytes.extend_from_slice(&n.to_le_bytes());
        }
        let mut records = Vec::with_capacity(128 * cache.len() + 36);
        cache
            .write_to(&mut records)
            .map_err(|e| RenderError::write(path, e.to_string()))?;
        bytes.extend_from_slice(&(records.len() as u64).to_le_bytes());
        bytes.extend_from_slice(&records);
    }
    let checksum = self::fingerprint(&[&bytes]);
    bytes.extend_from_slice(&checksum.to_le_bytes());
    write_file_atomically(path, &bytes)
}

/// Reads a cache file written by [`write_cache_file`] for `fingerprint`, filing each level's
/// records with `settings`' metric of that level; returns the levels, first to deepest, for
/// `IrradianceCacheIntegrator::load_levels`. A file larger than `max_bytes` is refused before
/// it is read.
pub fn read_cache_file(
    path: &Path,
    fingerprint: u64,
    settings: &IcSettings,
    max_bytes: u64,
) -> Result<Vec<CachedLevel>, RenderError> {
    let bad = |problem: String| RenderError::CacheFile {
        path: path.to_path_buf(),
        problem,
    };
    let (file, len) = open_regular(path).map_err(|e| bad(format!("cannot open: {e}")))?;
    if len > max_bytes {
        return Err(bad(format!(
            "the file has {len} bytes, more than irr reads ({max_bytes})"
        )));
    }
    let bytes = read_prefix(file, len).map_err(|e| bad(format!("cannot read: {e}")))?;
    if bytes.len() < 24 + 8 || bytes[..7] != MAGIC[..7] {
        return Err(bad("not an irr cache file (bad magic bytes)".into()));
    }
    if bytes[7] != MAGIC[7] {
        return Err(bad(format!(
            "written in another version of irr's cache file layout ({}; this build reads {}); delete it or choose another file",
            char::from(bytes[7]).escape_default(),
            char::from(MAGIC[7])
        )));
    }
    let (body, sum) = bytes.split_at(bytes.len() - 8);
    let word = |b: &[u8]| {
        let mut w = [0u8; 8];
        w.copy_from_slice(&b[..8]);
        u64::from_le_bytes(w)
    };
    if word(sum) != self::fingerprint(&[body]) {
        return Err(bad("checksum mismatch (corrupt file)".into()));
    }
    let found = word(&body[8..16]);
    if found != fingerprint {
        return Err(bad(format!(
            "this cache was made for another scene, camera, image size, cache setting or seed \
             (fingerprint {found:016x}, this render's is {fingerprint:016x}); delete it or choose another file"
        )));
    }
    let count = word(&body[16..24]);
    if count != u64::from(settings.levels()) {
        return Err(bad(format!(
            "{count} cache levels, but these settings have {}",
            settings.levels()
        )));
    }
    let mut at = 24usize;
    // The next `n` bytes of the body, or an error naming what is cut short.
    let mut take = |n: u64, what: &str| -> Result<&[u8], RenderError> {
        let end = usize::try_from(n)
            .ok()
            .and_then(|n| at.checked_add(n))
            .filter(|&e| e <= body.len())
            .ok_or_else(|| bad(format!("truncated ({what})")))?;
        let part = &body[at..end];
        at = end;
        Ok(part)
    };
    let float = |b: &[u8]| f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    let mut levels = Vec::new();
    for level in 0..settings.levels() {
        let metric = settings.metric_at(level).map_err(|e| bad(e.to_string()))?;
        let n = word(take(8, "record count")?);
        let entries = take(n.saturating_mul(ENTRY_BYTES as u64), "records' entries")?;
        let mut guard = Vec::with_capacity(entries.len() / ENTRY_BYTES);
        let mut noise = Vec::with_capacity(entries.len() / ENTRY_BYTES);
        for (i, entry) in entries.chunks_exact(ENTRY_BYTES).enumerate() {
            let nearest_hit = float(&entry[0..4]);
            let normal = Vec3::new(
                float(&entry[4..8]),
                float(&entry[8..12]),
                float(&entry[12..16]),
            );
            if !(nearest_hit.is_finite() && nearest_hit >= 0.0) {
                return Err(bad(format!(
                    "level {level}, record {i}: the leak guard's distance {nearest_hit} is not finite and non-negative"
                )));
            }
            if !(normal.is_finite() && normal.length_squared() > 0.0) {
                return Err(bad(format!(
                    "level {level}, record {i}: the leak guard's geometric normal is not finite and non-zero"
                )));
            }
            let relative_error = float(&entry[16..20]);
            if !(relative_error.is_finite() && relative_error >= 0.0) {
                return Err(bad(format!(
                    "level {level}, record {i}: the noise {relative_error} is not finite and non-negative"
                )));
            }
            guard.push(GuardRecord {
                nearest_hit,
                geometric_normal: normal,
            });
            noise.push(relative_error);
        }
        let size = word(take(8, "records' length")?);
        let records = take(size, "records")?;
        let cache = IrradianceCache::read_from(records, metric)
            .map_err(|e| bad(format!("level {level}: {e}")))?;
        if cache.len() != guard.len() {
            return Err(bad(format!(
                "level {level}: {} records but {} leak-guard entries",
                cache.len(),
                guard.len()
            )));
        }
        levels.push(CachedLevel {
            cache,
            guard,
            noise,
        });
    }
    if at != body.len() {
        return Err(bad(format!(
            "{} bytes after the last level",
            body.len() - at
        )));
    }
    Ok(levels)
}
