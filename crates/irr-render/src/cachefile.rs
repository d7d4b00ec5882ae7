//! A persistent irradiance cache (`--cache FILE`): every level's records, kept for a later
//! render. A file holds one of three things:
//!
//! - **a view's cache**: the records of one render, for a later render of the same scene,
//!   camera, image size, settings and seed (all in its fingerprint);
//! - **a shard of a sequence's cache**: the records that the views of a contiguous run of a
//!   walkthrough's key frames add to an empty cache ([`CacheOrigin::Shard`]). Shards are
//!   computed independently (on any machine, in any order) and joined by
//!   [`merge_shards`] (`irr cache merge`);
//! - **a sequence's cache**: every shard's records joined, which every frame of the walkthrough
//!   reads without adding records. Its fingerprint holds the scene, the settings, the seed, the
//!   image size, the camera's index, the key frames' times and the shard count, not one
//!   camera.
//!
//! Layout (little-endian):
//!
//! | offset | size | content |
//! |---|---|---|
//! | 0 | 8 | magic `IRRICSC5` (the last byte is the version of this layout and of the light transport its records were computed with: 5 since files can hold a sequence's shards) |
//! | 8 | 8 | fingerprint: FNV-1a of what the records depend on (the caller's: irr-cli hashes the scene file's bytes, the image size, the camera or the key frames, the cache settings, the background and the seed) |
//! | 16 | 8 | origin: 0 a view, 1 a shard, 2 a sequence |
//! | 24 | 8 | the shard's index (0 unless a shard) |
//! | 32 | 8 | S, the sequence's number of shards (1 for a view) |
//! | 40 | 8 | the camera whose animation the key frames follow: 0 the file's default, i + 1 camera i |
//! | 48 | 8 | K, the number of key frames (0 for a view) |
//! | 56 | 8·K | the key frames' times in seconds (`f64`), in order |
//! | 56 + 8K | 8 | L, the number of cache levels (the first, then each cached bounce level) |
//!
//! then, for each level in turn:
//!
//! | size | content |
//! |---|---|
//! | 8 | n, the level's number of records |
//! | 20·n | per record, what the leak guard keeps: the nearest hit distance of its gather (`f32`, finite, ≥ 0), then its geometric normal (3 `f32`, finite, not zero); then its noise, the estimated relative standard error of its irradiance (`f32`, finite, ≥ 0) |
//! | 8 | the byte length of the level's records |
//! | … | the records, in irr-cache's versioned, checksummed format (`irr_cache::io`) |
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
//!
//! **Merging** is canonical: the shards in index order, each one's records in its own order,
//! level by level, whatever order the files are named in. A record equal to one an earlier
//! shard holds (the same level, position and normal, to the bit: two views that placed a
//! record at the same point) is a duplicate and is dropped, keeping the earlier shard's.
//! Records of different shards whose spheres overlap are all kept: each is a valid estimate
//! where it stands, and dropping one could leave a point uncovered. So the merged file is the
//! same bytes whichever machine computed which shard, and a merged cache filed with the same
//! settings is the cache a single process builds shard by shard and joins the same way (irr-cache
//! files a record list the same whatever its history).

use crate::error::RenderError;
use crate::output::write_file_atomically;
use glam::Vec3;
use irr_cache::{IrradianceCache, Record, Rgb};
use irr_integrator::{
    CacheBuilder, CachedLevel, GuardRecord, IcSettings, IrradianceCacheIntegrator,
};
use irr_scene::Fnv;
use irr_scene::{open_regular, read_prefix};
use std::path::{Path, PathBuf};

/// The first eight bytes of a cache file.
pub const MAGIC: [u8; 8] = *b"IRRICSC5";

/// The bytes of one record's entry: its leak-guard data and its noise.
pub const ENTRY_BYTES: usize = 20;

/// The most key frames a file may list (a sequence of 10⁶ frames at a key frame each).
pub const MAX_KEY_FRAMES: u64 = 1 << 20;

/// The most shards a sequence's cache may be split into.
pub const MAX_SHARDS: u32 = 1 << 16;

/// FNV-1a over `parts`, each prefixed by its length (so parts cannot run into each other).
pub fn fingerprint(parts: &[&[u8]]) -> u64 {
    let mut h = Fnv::default();
    for p in parts {
        h.update_part(p);
    }
    h.finish()
}

/// The key frames a sequence's cache was built from.
#[derive(Clone, Debug, PartialEq)]
pub struct KeyFrames {
    /// The scene's camera whose animation they follow, by index (`None`: the default camera).
    pub camera: Option<u32>,
    /// Their times in seconds along the animation, in order; the light cache of the
    /// construction (and of every frame's own gathers) is built from the first one's view.
    pub times: Vec<f64>,
}

impl KeyFrames {
    /// The key frames of shard `index` of `shards`: contiguous runs, as even as they come
    /// (shard i gets key frames ⌊iK/S⌋ up to ⌊(i+1)K/S⌋).
    pub fn shard(&self, index: u32, shards: u32) -> std::ops::Range<usize> {
        let k = self.times.len() as u64;
        let at = |i: u32| (k * u64::from(i) / u64::from(shards.max(1))) as usize;
        at(index)..at(index + 1)
    }
}

/// What a cache file's records were built from (module docs).
#[derive(Clone, Debug, PartialEq)]
pub enum CacheOrigin {
    /// One view; its camera is part of the fingerprint.
    View,
    /// Shard `index` of `shards` of a sequence's key frames.
    Shard {
        /// Its index, below `shards`.
        index: u32,
        /// The sequence's number of shards.
        shards: u32,
        /// Every key frame of the sequence (the shard's are [`KeyFrames::shard`]).
        keys: KeyFrames,
    },
    /// Every shard of a sequence, joined.
    Sequence {
        /// The number of shards joined.
        shards: u32,
        /// The key frames.
        keys: KeyFrames,
    },
}

impl CacheOrigin {
    /// The sequence's key frames and shard count (`None` for a view's cache).
    pub fn sequence(&self) -> Option<(&KeyFrames, u32)> {
        match self {
            Self::View => None,
            Self::Shard { shards, keys, .. } | Self::Sequence { shards, keys } => {
                Some((keys, *shards))
            }
        }
    }

    fn describe(&self) -> String {
        match self {
            Self::View => "one view's cache".into(),
            Self::Shard { index, shards, .. } => {
                format!("shard {index} of {shards} of a sequence's cache")
            }
            Self::Sequence { shards, .. } => format!("a sequence's cache ({shards} shards joined)"),
        }
    }
}

/// One level's records with what the integrator keeps beside each: its leak-guard data and
/// its noise, in record order.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelRecords {
    /// The records.
    pub records: Vec<Record<Rgb>>,
    /// The leak guard's data, one entry per record.
    pub guard: Vec<GuardRecord>,
    /// The estimated relative standard error of each record's irradiance.
    pub noise: Vec<f32>,
}

/// Everything a cache file holds.
#[derive(Clone, Debug, PartialEq)]
pub struct CacheContents {
    /// What the records depend on, hashed (module docs).
    pub fingerprint: u64,
    /// What they were built from.
    pub origin: CacheOrigin,
    /// Every level, first to deepest.
    pub levels: Vec<LevelRecords>,
}

impl CacheContents {
    /// The records of every level of `integrator`'s cache.
    pub fn of(
        integrator: &IrradianceCacheIntegrator,
        fingerprint: u64,
        origin: CacheOrigin,
    ) -> Result<Self, String> {
        let mut levels = Vec::new();
        for level in 0..integrator.levels() as usize {
            let cache = integrator
                .cache(level)
                .ok_or_else(|| format!("the integrator has no level {level}"))?;
            let guard = integrator.guard_records(level).to_vec();
            let noise = integrator.record_noise(level).to_vec();
            if guard.len() != cache.len() || noise.len() != cache.len() {
                return Err(format!(
                    "level {level}: {} records, {} leak-guard entries and {} noise entries",
                    cache.len(),
                    guard.len(),
                    noise.len()
                ));
            }
            levels.push(LevelRecords {
                records: cache.records().to_vec(),
                guard,
                noise,
            });
        }
        Ok(Self {
            fingerprint,
            origin,
            levels,
        })
    }

    /// The records of every level: their count.
    pub fn record_count(&self) -> usize {
        self.levels.iter().map(|l| l.records.len()).sum()
    }

    /// Every level filed with `settings`' metric of that level, for
    /// `IrradianceCacheIntegrator::load_levels`.
    pub fn file(self, settings: &IcSettings) -> Result<Vec<CachedLevel>, String> {
        if self.levels.len() != settings.levels() as usize {
            return Err(format!(
                "{} cache levels, but these settings have {}",
                self.levels.len(),
                settings.levels()
            ));
        }
        let mut levels = Vec::with_capacity(self.levels.len());
        for (level, l) in (0u32..).zip(self.levels) {
            let metric = settings.metric_at(level).map_err(|e| e.to_string())?;
            let mut cache = IrradianceCache::new(metric);
            cache
                .extend(l.records)
                .map_err(|e| format!("level {level}, record {}: {}", e.index, e.source))?;
            levels.push(CachedLevel {
                cache,
                guard: l.guard,
                noise: l.noise,
            });
        }
        Ok(levels)
    }

    /// The file's bytes (module docs).
    pub fn encode(&self) -> Result<Vec<u8>, String> {
        let word = |bytes: &mut Vec<u8>, w: u64| bytes.extend_from_slice(&w.to_le_bytes());
        let mut bytes = Vec::new();
        bytes.extend_from_slice(&MAGIC);
        word(&mut bytes, self.fingerprint);
        let (kind, index, shards, keys) = match &self.origin {
            CacheOrigin::View => (0, 0, 1, None),
            CacheOrigin::Shard {
                index,
                shards,
                keys,
            } => (1, *index, *shards, Some(keys)),
            CacheOrigin::Sequence { shards, keys } => (2, 0, *shards, Some(keys)),
        };
        word(&mut bytes, kind);
        word(&mut bytes, u64::from(index));
        word(&mut bytes, u64::from(shards));
        word(
            &mut bytes,
            keys.and_then(|k| k.camera).map_or(0, |c| u64::from(c) + 1),
        );
        let times = keys.map_or(&[][..], |k| &k.times);
        word(&mut bytes, times.len() as u64);
        for t in times {
            bytes.extend_from_slice(&t.to_le_bytes());
        }
        word(&mut bytes, self.levels.len() as u64);
        for l in &self.levels {
            if l.guard.len() != l.records.len() || l.noise.len() != l.records.len() {
                return Err(format!(
                    "{} records, {} leak-guard entries and {} noise entries",
                    l.records.len(),
                    l.guard.len(),
                    l.noise.len()
                ));
            }
            word(&mut bytes, l.records.len() as u64);
            for (g, n) in l.guard.iter().zip(&l.noise) {
                bytes.extend_from_slice(&g.nearest_hit.to_le_bytes());
                for c in g.geometric_normal.to_array() {
                    bytes.extend_from_slice(&c.to_le_bytes());
                }
                bytes.extend_from_slice(&n.to_le_bytes());
            }
            let mut records = Vec::with_capacity(136 * l.records.len() + 36);
            irr_cache::io::write_records(&l.records, &mut records).map_err(|e| e.to_string())?;
            word(&mut bytes, records.len() as u64);
            bytes.extend_from_slice(&records);
        }
        let checksum = fingerprint(&[&bytes]);
        bytes.extend_from_slice(&checksum.to_le_bytes());
        Ok(bytes)
    }

    /// Decodes a file's bytes; the error says what is wrong, on one line.
    pub fn decode(bytes: &[u8]) -> Result<Self, String> {
        if bytes.len() < 64 + 8 || bytes[..7] != MAGIC[..7] {
            return Err("not an irr cache file (bad magic bytes)".into());
        }
        if bytes[7] != MAGIC[7] {
            return Err(format!(
                "written in another version of irr's cache file layout ({}; this build reads {}); delete it or choose another file",
                char::from(bytes[7]).escape_default(),
                char::from(MAGIC[7])
            ));
        }
        let (body, sum) = bytes.split_at(bytes.len() - 8);
        let word = |b: &[u8]| {
            let mut w = [0u8; 8];
            w.copy_from_slice(&b[..8]);
            u64::from_le_bytes(w)
        };
        if word(sum) != fingerprint(&[body]) {
            return Err("checksum mismatch (corrupt file)".into());
        }
        let mut at = 8usize;
        // The next `n` bytes of the body, or an error naming what is cut short.
        let mut take = |n: u64, what: &str| -> Result<&[u8], String> {
            let end = usize::try_from(n)
                .ok()
                .and_then(|n| at.checked_add(n))
                .filter(|&e| e <= body.len())
                .ok_or_else(|| format!("truncated ({what})"))?;
            let part = &body[at..end];
            at = end;
            Ok(part)
        };
        let fingerprint = word(take(8, "fingerprint")?);
        let kind = word(take(8, "origin")?);
        let index = word(take(8, "shard index")?);
        let shards = word(take(8, "shard count")?);
        let camera = word(take(8, "camera")?);
        let k = word(take(8, "key frame count")?);
        if k > MAX_KEY_FRAMES {
            return Err(format!(
                "{k} key frames, more than irr reads ({MAX_KEY_FRAMES})"
            ));
        }
        let times: Vec<f64> = take(8 * k, "key frames")?
            .chunks_exact(8)
            .map(|c| f64::from_bits(word(c)))
            .collect();
        if let Some(t) = times.iter().find(|t| !t.is_finite()) {
            return Err(format!("a key frame's time is {t}, not finite"));
        }
        let camera = match camera {
            0 => None,
            c => Some(
                u32::try_from(c - 1).map_err(|_| format!("camera index {} out of range", c - 1))?,
            ),
        };
        let shards = u32::try_from(shards)
            .ok()
            .filter(|s| (1..=MAX_SHARDS).contains(s))
            .ok_or_else(|| format!("{shards} shards: must be 1 to {MAX_SHARDS}"))?;
        let keys = KeyFrames { camera, times };
        let origin = match kind {
            0 if index == 0 && shards == 1 && keys.times.is_empty() && keys.camera.is_none() => {
                CacheOrigin::View
            }
            1 | 2
                if keys.times.len() >= shards as usize
                    && (kind == 2 || index < u64::from(shards)) =>
            {
                if kind == 1 {
                    CacheOrigin::Shard {
                        index: index as u32,
                        shards,
                        keys,
                    }
                } else if index == 0 {
                    CacheOrigin::Sequence { shards, keys }
                } else {
                    return Err(format!("a sequence's cache with shard index {index}"));
                }
            }
            _ => {
                return Err(format!(
                    "origin {kind} with shard {index} of {shards} and {} key frames is not one irr writes",
                    keys.times.len()
                ));
            }
        };
        let count = word(take(8, "level count")?);
        let float = |b: &[u8]| f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        let mut levels = Vec::new();
        for level in 0..count {
            // Each level takes at least 16 bytes: a count beyond the file is refused here,
            // before any allocation it would size.
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
                    return Err(format!(
                        "level {level}, record {i}: the leak guard's distance {nearest_hit} is not finite and non-negative"
                    ));
                }
                if !(normal.is_finite() && normal.length_squared() > 0.0) {
                    return Err(format!(
                        "level {level}, record {i}: the leak guard's geometric normal is not finite and non-zero"
                    ));
                }
                let relative_error = float(&entry[16..20]);
                if !(relative_error.is_finite() && relative_error >= 0.0) {
                    return Err(format!(
                        "level {level}, record {i}: the noise {relative_error} is not finite and non-negative"
                    ));
                }
                guard.push(GuardRecord {
                    nearest_hit,
                    geometric_normal: normal,
                });
                noise.push(relative_error);
            }
            let size = word(take(8, "records' length")?);
            let records = irr_cache::io::read_records::<Rgb, _>(take(size, "records")?)
                .map_err(|e| format!("level {level}: {e}"))?;
            if records.len() != guard.len() {
                return Err(format!(
                    "level {level}: {} records but {} leak-guard entries",
                    records.len(),
                    guard.len()
                ));
            }
            levels.push(LevelRecords {
                records,
                guard,
                noise,
            });
        }
        if at != body.len() {
            return Err(format!("{} bytes after the last level", body.len() - at));
        }
        Ok(Self {
            fingerprint,
            origin,
            levels,
        })
    }

    /// Reads and decodes the file at `path` (no larger than `max_bytes`, refused before it is
    /// read); the error names the file.
    pub fn read(path: &Path, max_bytes: u64) -> Result<Self, RenderError> {
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
        Self::decode(&bytes).map_err(bad)
    }

    /// Writes the file at `path`, atomically (a temporary file renamed into place); refused if
    /// it would exceed `max_bytes`, the most a reader takes, so that no file is written that
    /// the frames would refuse.
    pub fn write(&self, path: &Path, max_bytes: u64) -> Result<(), RenderError> {
        let bytes = self.encode().map_err(|e| RenderError::write(path, e))?;
        if bytes.len() as u64 > max_bytes {
            return Err(RenderError::write(
                path,
                format!(
                    "the cache would take {} bytes, more than irr reads ({max_bytes})",
                    bytes.len()
                ),
            ));
        }
        write_file_atomically(path, &bytes)
    }
}

/// Writes every level of `integrator`'s cache to `path`, as one view's cache with `fingerprint`.
pub fn write_cache_file(
    path: &Path,
    fingerprint: u64,
    integrator: &IrradianceCacheIntegrator,
) -> Result<(), RenderError> {
    CacheContents::of(integrator, fingerprint, CacheOrigin::View)
        .map_err(|e| RenderError::write(path, e))?
        .write(path, u64::MAX)
}

/// Reads one view's cache written by [`write_cache_file`] for `fingerprint`, filing each level's
/// records with `settings`' metric of that level; returns the levels, first to deepest, for
/// `IrradianceCacheIntegrator::load_levels`. A file larger than `max_bytes` is refused before
/// it is read; so is a sequence's cache or a shard of one.
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
    let contents = CacheContents::read(path, max_bytes)?;
    if contents.origin != CacheOrigin::View {
        return Err(bad(format!(
            "this file holds {}, made for --frames with --shared-cache, not for one view",
            contents.origin.describe()
        )));
    }
    check_fingerprint(path, contents.fingerprint, fingerprint)?;
    contents.file(settings).map_err(bad)
}

/// Refuses a file whose fingerprint is not `expected`, with an error naming the file.
pub fn check_fingerprint(path: &Path, found: u64, expected: u64) -> Result<(), RenderError> {
    if found == expected {
        return Ok(());
    }
    Err(RenderError::CacheFile {
        path: path.to_path_buf(),
        problem: format!(
            "this cache was made for another scene, camera, image size, cache setting or seed \
             (fingerprint {found:016x}, this render's is {expected:016x}); delete it or choose another file"
        ),
    })
}

/// What [`merge_shards`] did.
#[derive(Clone, Debug, PartialEq)]
pub struct MergeReport {
    /// Records per shard, in index order (every level).
    pub shard_records: Vec<usize>,
    /// Records dropped as duplicates of an earlier shard's.
    pub duplicates: usize,
}

/// Joins the shards of one sequence's cache, given in any order, into the sequence's cache
/// (module docs: canonical order, duplicates dropped). Refuses, naming the shard by its file in
/// `names`, shards of different sequences, settings or shard counts, a missing or repeated
/// index, and anything that is not a shard.
pub fn merge_shards(
    shards: Vec<(PathBuf, CacheContents)>,
) -> Result<(CacheContents, MergeReport), RenderError> {
    let bad = |path: &Path, problem: String| RenderError::CacheFile {
        path: path.to_path_buf(),
        problem,
    };
    let Some((first_path, first)) = shards.first().map(|(p, c)| (p.clone(), c)) else {
        return Err(RenderError::Setting {
            option: "irr cache merge",
            problem: "no shard files named".into(),
        });
    };
    let (keys, count) = match &first.origin {
        CacheOrigin::Shard { shards, keys, .. } => (keys.clone(), *shards),
        other => {
            return Err(bad(
                &first_path,
                format!("this file holds {}, not a shard", other.describe()),
            ));
        }
    };
    let (fingerprint, levels) = (first.fingerprint, first.levels.len());
    let mut by_index: Vec<Option<(PathBuf, Vec<LevelRecords>)>> = vec![None; count as usize];
    for (path, shard) in shards {
        let CacheOrigin::Shard {
            index,
            shards: of,
            keys: k,
        } = &shard.origin
        else {
            return Err(bad(
                &path,
                format!("this file holds {}, not a shard", shard.origin.describe()),
            ));
        };
        if shard.fingerprint != fingerprint
            || *of != count
            || *k != keys
            || shard.levels.len() != levels
        {
            return Err(bad(
                &path,
                format!(
                    "not a shard of the same sequence as {} (another scene, setting, seed, key frames or shard count)",
                    first_path.display()
                ),
            ));
        }
        let Some(slot) = by_index.get_mut(*index as usize) else {
            return Err(bad(
                &path,
                format!("shard index {index} is not below {count}"),
            ));
        };
        if let Some((earlier, _)) = slot {
            return Err(bad(
                &path,
                format!(
                    "shard {index} of {count} is named twice (also {})",
                    earlier.display()
                ),
            ));
        }
        *slot = Some((path, shard.levels));
    }
    let missing: Vec<String> = (0..count)
        .filter(|&i| by_index[i as usize].is_none())
        .map(|i| i.to_string())
        .collect();
    if !missing.is_empty() {
        return Err(RenderError::Setting {
            option: "irr cache merge",
            problem: format!("shards {} of {count} are missing", missing.join(", ")),
        });
    }
    let mut merged: Vec<LevelRecords> = (0..levels)
        .map(|_| LevelRecords {
            records: Vec::new(),
            guard: Vec::new(),
            noise: Vec::new(),
        })
        .collect();
    let mut report = MergeReport {
        shard_records: Vec::with_capacity(count as usize),
        duplicates: 0,
    };
    // A record's identity for the duplicate rule: its position and normal, to the bit.
    let key = |r: &Record<Rgb>| {
        (
            r.position.to_array().map(f32::to_bits),
            r.normal.to_array().map(f32::to_bits),
        )
    };
    let mut seen: Vec<std::collections::HashSet<([u32; 3], [u32; 3])>> =
        vec![std::collections::HashSet::new(); levels];
    for (_, shard) in by_index.into_iter().flatten() {
        report
            .shard_records
            .push(shard.iter().map(|l| l.records.len()).sum());
        for ((out, l), seen) in merged.iter_mut().zip(shard).zip(&mut seen) {
            // Only earlier shards' records count: a shard's own records are kept as built.
            let mine: Vec<_> = l.records.iter().map(key).collect();
            for (((r, g), n), k) in l.records.into_iter().zip(l.guard).zip(l.noise).zip(&mine) {
                if seen.contains(k) {
                    report.duplicates += 1;
                    continue;
                }
                out.records.push(r);
                out.guard.push(g);
                out.noise.push(n);
            }
            seen.extend(mine);
        }
    }
    Ok((
        CacheContents {
            fingerprint,
            origin: CacheOrigin::Sequence {
                shards: count,
                keys,
            },
            levels: merged,
        },
        report,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keys() -> KeyFrames {
        KeyFrames {
            camera: Some(1),
            times: vec![0.0, 0.5, 1.0, 1.25],
        }
    }

    /// A level of `n` records along x, starting at `x0`.
    fn level(x0: f32, n: usize) -> LevelRecords {
        let records: Vec<Record<Rgb>> = (0..n)
            .map(|i| {
                Record::new(
                    Vec3::new(x0 + i as f32, 0.5, -2.0),
                    Vec3::Y,
                    0.25 + i as f32,
                    Rgb::splat(1.0 + i as f32),
                )
            })
            .collect();
        LevelRecords {
            guard: (0..n)
                .map(|i| GuardRecord {
                    nearest_hit: 0.1 * i as f32,
                    geometric_normal: Vec3::Y,
                })
                .collect(),
            noise: (0..n).map(|i| 0.01 * i as f32).collect(),
            records,
        }
    }

    fn shard(index: u32, x0: f32, n: usize) -> (PathBuf, CacheContents) {
        (
            PathBuf::from(format!("shard{index}.irrc")),
            CacheContents {
                fingerprint: 7,
                origin: CacheOrigin::Shard {
                    index,
                    shards: 3,
                    keys: keys(),
                },
                levels: vec![level(x0, n), level(x0 + 0.5, 1)],
            },
        )
    }

    #[test]
    fn every_origin_round_trips_and_a_changed_byte_is_refused() {
        for origin in [
            CacheOrigin::View,
            shard(2, 0.0, 1).1.origin,
            CacheOrigin::Sequence {
                shards: 4,
                keys: keys(),
            },
        ] {
            let contents = CacheContents {
                fingerprint: 0xfeed,
                origin,
                levels: vec![level(1.0, 3), level(-4.0, 0)],
            };
            let bytes = contents.encode().unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(CacheContents::decode(&bytes), Ok(contents.clone()));
            let mut bad = bytes.clone();
            bad[50] ^= 1;
            assert!(CacheContents::decode(&bad).is_err());
        }
    }

    /// The shards in any order give the same merged bytes: shard 0's records, then 1's, then
    /// 2's, level by level; a record repeated from an earlier shard is dropped with its guard
    /// and noise entries.
    #[test]
    fn merging_is_canonical_and_drops_repeated_records() {
        // Shard 2's first level starts with the record at x = 1, which shard 0 also holds.
        let shards = [shard(0, 0.0, 2), shard(1, 10.0, 3), shard(2, 1.0, 2)];
        let orders = [[0, 1, 2], [2, 1, 0], [1, 2, 0]];
        let merged: Vec<Vec<u8>> = orders
            .iter()
            .map(|o| {
                let (m, report) = merge_shards(o.iter().map(|&i| shards[i].clone()).collect())
                    .unwrap_or_else(|e| panic!("{e}"));
                // Every shard's second level is one record at x0 + 0.5; none repeat.
                assert_eq!(report.duplicates, 1);
                assert_eq!(report.shard_records, vec![3, 4, 3]);
                m.encode().unwrap_or_else(|e| panic!("{e}"))
            })
            .collect();
        assert!(merged.iter().all(|m| *m == merged[0]));
        let m = CacheContents::decode(&merged[0]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            m.origin,
            CacheOrigin::Sequence {
                shards: 3,
                keys: keys()
            }
        );
        let xs: Vec<f32> = m.levels[0].records.iter().map(|r| r.position.x).collect();
        assert_eq!(xs, vec![0.0, 1.0, 10.0, 11.0, 12.0, 2.0]);
        // Shard 2's second record (x = 2, its index 1) kept its own guard and noise entries.
        assert_eq!(m.levels[0].noise[5], 0.01);
        assert_eq!(m.levels[0].guard.len(), 6);
        assert_eq!(m.levels[1].records.len(), 3);
    }

    #[test]
    fn merging_refuses_missing_repeated_foreign_and_non_shards() {
        let err = |v: Vec<(PathBuf, CacheContents)>| {
            merge_shards(v)
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default()
        };
        let e = err(vec![shard(0, 0.0, 1), shard(2, 5.0, 1)]);
        assert!(e.contains("shards 1 of 3 are missing"), "{e}");
        let e = err(vec![shard(0, 0.0, 1), shard(1, 5.0, 1), shard(1, 6.0, 1)]);
        assert!(
            e.contains("shard1.irrc") && e.contains("named twice"),
            "{e}"
        );
        let mut other = shard(1, 5.0, 1);
        other.1.fingerprint = 8;
        let e = err(vec![shard(0, 0.0, 1), other, shard(2, 6.0, 1)]);
        assert!(
            e.contains("shard1.irrc") && e.contains("same sequence"),
            "{e}"
        );
        let mut view = shard(1, 5.0, 1);
        view.1.origin = CacheOrigin::View;
        let e = err(vec![shard(0, 0.0, 1), view]);
        assert!(
            e.contains("shard1.irrc") && e.contains("not a shard"),
            "{e}"
        );
        assert!(err(Vec::new()).contains("no shard files"));
    }

    #[test]
    fn key_frames_split_into_contiguous_runs() {
        let k = KeyFrames {
            camera: None,
            times: (0..7).map(f64::from).collect(),
        };
        let runs: Vec<_> = (0..3).map(|i| k.shard(i, 3)).collect();
        assert_eq!(runs, vec![0..2, 2..4, 4..7]);
        assert_eq!(k.shard(0, 1), 0..7);
    }
}
