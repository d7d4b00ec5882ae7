//! A cache file: the records of a cache in a compact, versioned, checksummed binary format.
//!
//! Layout (all integers and floats little-endian):
//!
//! | offset | size | content |
//! |---|---|---|
//! | 0 | 8 | magic `IRRCACHE` |
//! | 8 | 4 | format version, `u32` ([`FORMAT_VERSION`]) |
//! | 12 | 4 | value type tag, `u32` ([`CacheValue::TAG`]) |
//! | 16 | 4 | channels per value, `u32` ([`CacheValue::CHANNELS`]) |
//! | 20 | 8 | record count n, `u64` |
//! | 28 | n·4·(15 + 7·C) | the records, each: position (3 `f32`), normal (3), radius (1), unclamped radius (1), minimum radius (1), aspect (1), minor axis (3), curvature (2), value (C), translation gradient (3·C, axis-major), rotation gradient (3·C) |
//! | end | 8 | FNV-1a 64-bit hash of every byte before it |
//!
//! An RGB record takes 144 bytes in the file, as in memory. Only the records are stored; the metric
//! is the reader's choice ([`IrradianceCache::read_from`] takes one), so a cache built once can be
//! reused with another accuracy. Read back with the same metric, the cache is the same: the records
//! are bit for bit those written (neighbour clamping's changes included), and every octree cell
//! lists its records in index order whatever the history of the cache (the octree keeps cells
//! sorted), so interpolation sums in the same order and gives the same bits.
//!
//! Version history: 1 stored no unclamped or minimum radius; 2 added them; 3 added the ellipse
//! of anisotropic records (aspect and minor axis); version 4 (this one) adds their curvature.
//! An older file is refused with [`CacheFileError::Version`].
//!
//! The checksum is FNV-1a: each byte is XORed into the state, which is then multiplied by an odd
//! constant, a bijection modulo 2⁶⁴; so two inputs of the same length that differ in exactly one
//! byte always hash differently, and any single corrupted byte is detected.

use crate::cache::IrradianceCache;
use crate::metric::ErrorMetric;
use crate::record::{InsertError, Record};
use crate::value::CacheValue;
use glam::Vec3;
use std::io::{self, Read, Write};
use thiserror::Error;

/// The first eight bytes of every cache file.
pub const MAGIC: [u8; 8] = *b"IRRCACHE";
/// The format version this crate writes and reads.
pub const FORMAT_VERSION: u32 = 4;

const HEADER_BYTES: usize = 28;

/// Why a cache file could not be read or written.
#[derive(Debug, Error)]
pub enum CacheFileError {
    /// The underlying reader or writer failed.
    #[error("cache file i/o: {0}")]
    Io(#[from] io::Error),
    /// The file ends early.
    #[error("cache file is truncated")]
    Truncated,
    /// The file does not start with the cache magic bytes.
    #[error("not an irr cache file (bad magic bytes)")]
    NotACacheFile,
    /// The file was written by another version of the format.
    #[error(
        "cache file format version {found} is not supported (this build reads version {supported})"
    )]
    Version {
        /// The version in the file.
        found: u32,
        /// The version this build reads.
        supported: u32,
    },
    /// The file holds another value type.
    #[error(
        "cache file holds values of type tag {found_tag} with {found_channels} channels, expected tag {expected_tag} with {expected_channels}"
    )]
    ValueType {
        /// The tag in the file.
        found_tag: u32,
        /// The channel count in the file.
        found_channels: u32,
        /// The tag of the requested type.
        expected_tag: u32,
        /// The channel count of the requested type.
        expected_channels: u32,
    },
    /// The checksum does not match: the file is corrupt.
    #[error("cache file checksum mismatch (corrupt file)")]
    Checksum,
    /// A record in the file is not valid.
    #[error("cache file record {index} is invalid: {source}")]
    Record {
        /// The record's position in the file.
        index: u64,
        /// Why it was refused.
        source: InsertError,
    },
}

/// FNV-1a, 64-bit (Fowler, Noll & Vo).
#[derive(Clone, Copy)]
struct Fnv(u64);

impl Fnv {
    const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01b3;

    fn new() -> Self {
        Self(Self::OFFSET)
    }
    fn update(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(Self::PRIME);
        }
    }
}

/// A writer that hashes what it writes.
struct HashWriter<W> {
    inner: W,
    hash: Fnv,
}

impl<W: Write> HashWriter<W> {
    fn write(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.hash.update(bytes);
        self.inner.write_all(bytes)
    }
}

/// A reader that hashes what it reads, and reports a short read as [`CacheFileError::Truncated`].
struct HashReader<R> {
    inner: R,
    hash: Fnv,
}

impl<R: Read> HashReader<R> {
    fn read(&mut self, buf: &mut [u8]) -> Result<(), CacheFileError> {
        read_exact(&mut self.inner, buf)?;
        self.hash.update(buf);
        Ok(())
    }
    fn u32(&mut self) -> Result<u32, CacheFileError> {
        let mut b = [0; 4];
        self.read(&mut b)?;
        Ok(u32::from_le_bytes(b))
    }
}

fn read_exact(r: &mut impl Read, buf: &mut [u8]) -> Result<(), CacheFileError> {
    r.read_exact(buf).map_err(|e| match e.kind() {
        io::ErrorKind::UnexpectedEof => CacheFileError::Truncated,
        _ => CacheFileError::Io(e),
    })
}

/// Number of `f32`s in one record of `V`.
const fn floats_per_record<V: CacheValue>() -> usize {
    15 + 7 * V::CHANNELS
}

fn encode_record<V: CacheValue>(r: &Record<V>, out: &mut Vec<u8>) {
    let mut put = |x: f32| out.extend_from_slice(&x.to_le_bytes());
    r.position.to_array().into_iter().for_each(&mut put);
    r.normal.to_array().into_iter().for_each(&mut put);
    put(r.radius);
    put(r.unclamped_radius);
    put(r.min_radius);
    put(r.aspect);
    r.tangent.to_array().into_iter().for_each(&mut put);
    r.curvature.into_iter().for_each(&mut put);
    r.value.channels().iter().copied().for_each(&mut put);
    for g in r.translation_gradient.iter().chain(&r.rotation_gradient) {
        g.channels().iter().copied().for_each(&mut put);
    }
}

fn decode_record<V: CacheValue>(bytes: &[u8]) -> Record<V> {
    let mut floats = bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]));
    let mut next = move || floats.next().unwrap_or(f32::NAN);
    let position = Vec3::new(next(), next(), next());
    let normal = Vec3::new(next(), next(), next());
    let radius = next();
    let unclamped_radius = next();
    let min_radius = next();
    let aspect = next();
    let tangent = Vec3::new(next(), next(), next());
    let curvature = [next(), next()];
    let value = V::from_fn(|_| next());
    let translation_gradient = std::array::from_fn(|_| V::from_fn(|_| next()));
    let rotation_gradient = std::array::from_fn(|_| V::from_fn(|_| next()));
    Record {
        position,
        normal,
        radius,
        unclamped_radius,
        min_radius,
        aspect,
        tangent,
        value,
        translation_gradient,
        rotation_gradient,
        curvature,
    }
}

impl<V: CacheValue, M: ErrorMetric> IrradianceCache<V, M> {
    /// Writes the cache's records (see the module docs for the format). Writes in blocks, so an
    /// unbuffered `File` is fine; writing to a temporary file and renaming it is the caller's.
    pub fn write_to<W: Write>(&self, writer: W) -> Result<(), CacheFileError> {
        write_records(self.records(), writer)
    }

    /// Reads a cache written by [`IrradianceCache::write_to`], filing its records with `metric`.
    /// Refuses, with the reason, a file that is truncated, foreign, of another version or value
    /// type, corrupt (checksum), or that holds an invalid record. Bytes after the checksum are not
    /// read.
    pub fn read_from<R: Read>(reader: R, metric: M) -> Result<Self, CacheFileError> {
        let records = read_records::<V, R>(reader)?;
        let mut cache = Self::new(metric);
        cache.extend(records).map_err(|e| CacheFileError::Record {
            index: e.index as u64,
            source: e.source,
        })?;
        Ok(cache)
    }
}

/// Writes `records` in the cache file format (module docs): what [`IrradianceCache::write_to`]
/// writes for a cache holding them in this order. For tools that join or filter the records of
/// several caches without filing them (no metric is needed).
pub fn write_records<V: CacheValue, W: Write>(
    records: &[Record<V>],
    writer: W,
) -> Result<(), CacheFileError> {
    let mut w = HashWriter {
        inner: writer,
        hash: Fnv::new(),
    };
    let mut header = Vec::with_capacity(HEADER_BYTES);
    header.extend_from_slice(&MAGIC);
    header.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    header.extend_from_slice(&V::TAG.to_le_bytes());
    header.extend_from_slice(&(V::CHANNELS as u32).to_le_bytes());
    header.extend_from_slice(&(records.len() as u64).to_le_bytes());
    w.write(&header)?;
    let mut block = Vec::with_capacity(64 * 1024);
    for r in records {
        encode_record(r, &mut block);
        if block.len() >= 60 * 1024 {
            w.write(&block)?;
            block.clear();
        }
    }
    w.write(&block)?;
    let hash = w.hash.0;
    w.inner.write_all(&hash.to_le_bytes())?;
    w.inner.flush()?;
    Ok(())
}

/// Reads the records of a cache file, in file order, each checked as
/// [`IrradianceCache::insert`] checks it ([`Record::validated`]); refuses what
/// [`IrradianceCache::read_from`] refuses, except a radius the reader's metric could not file.
pub fn read_records<V: CacheValue, R: Read>(reader: R) -> Result<Vec<Record<V>>, CacheFileError> {
    let mut r = HashReader {
        inner: reader,
        hash: Fnv::new(),
    };
    let mut magic = [0; 8];
    r.read(&mut magic)?;
    if magic != MAGIC {
        return Err(CacheFileError::NotACacheFile);
    }
    let version = r.u32()?;
    if version != FORMAT_VERSION {
        return Err(CacheFileError::Version {
            found: version,
            supported: FORMAT_VERSION,
        });
    }
    let (tag, channels) = (r.u32()?, r.u32()?);
    if tag != V::TAG || channels as usize != V::CHANNELS {
        return Err(CacheFileError::ValueType {
            found_tag: tag,
            found_channels: channels,
            expected_tag: V::TAG,
            expected_channels: V::CHANNELS as u32,
        });
    }
    let mut count = [0; 8];
    r.read(&mut count)?;
    let count = u64::from_le_bytes(count);

    // Read every record before checking any, so a corrupt count or payload is reported as
    // a checksum (or truncation) error, not as whatever garbage it decodes to. The count is
    // not trusted for allocation: memory grows with what is actually read.
    let record_bytes = 4 * floats_per_record::<V>();
    let mut payload = Vec::new();
    let mut buf = vec![0u8; record_bytes * 1024];
    let mut left = count;
    while left > 0 {
        let n = left.min(1024) as usize;
        let chunk = &mut buf[..n * record_bytes];
        r.read(chunk)?;
        payload.extend_from_slice(chunk);
        left -= n as u64;
    }
    let mut stored = [0; 8];
    read_exact(&mut r.inner, &mut stored)?;
    if u64::from_le_bytes(stored) != r.hash.0 {
        return Err(CacheFileError::Checksum);
    }
    payload
        .chunks_exact(record_bytes)
        .enumerate()
        .map(|(index, bytes)| {
            decode_record::<V>(bytes)
                .validated()
                .map_err(|source| CacheFileError::Record {
                    index: index as u64,
                    source,
                })
        })
        .collect()
}
