//! Reading the files a scene names, confined and bounded.
//!
//! A scene file is untrusted input: its buffer URIs may point anywhere (`/etc/shadow`,
//! `../../secret`, `%2e%2e/`, a symlink out of the folder, `/dev/zero`, a FIFO), and its sizes may
//! lie. The rules, applied to every file irr reads for a scene:
//! - **Regular files only.** Folders, devices, FIFOs and sockets are refused before they are
//!   read (a FIFO is opened without blocking), so no read can block or run forever.
//! - **Bounded.** The scene file is read up to [`MAX_SCENE_BYTES`] (its JSON up to
//!   [`MAX_JSON_BYTES`]); a buffer file is read up to the `byteLength` its buffer declares, never
//!   further, however large the file is; an image file whole, up to [`MAX_SCENE_BYTES`], and its
//!   decoded size is charged to the [`Budget`] from its header before it is decoded.
//! - **Within the memory limit.** Everything the loader allocates is charged first against the
//!   scene's [`MemoryLimit`] (what the machine holds, or `--max-memory`); data that no bytes of a
//!   file hold (an accessor without a buffer view) also against an allowance sized by the files.
//! - **Confined.** A buffer or image URI is read only if the file it names, after resolving `..` and
//!   symbolic links, lies inside the *asset root*: the scene file's folder, unless the user names
//!   another folder ([`LoadOptions::asset_root`], `--asset-root`). Absolute paths and URIs that
//!   climb out of the root are refused before the file system is asked about them, so an error
//!   never tells whether a file outside the root exists, how large it is, or what it holds.
//!
//! Error messages never quote a file's bytes, and give sizes only of files inside the root.

use crate::digest::Fnv;
use std::cell::Cell;
use std::fs::File;
use std::io::Read;
use std::path::{Component, Path, PathBuf};

/// The largest scene file irr reads: 4 GiB − 1, the most a binary glTF's 32-bit length field
/// can declare.
pub const MAX_SCENE_BYTES: u64 = u32::MAX as u64;

/// The largest JSON document irr parses (a `.gltf` file, or a `.glb`'s JSON chunk): 512 MiB.
/// The largest scenes in the glTF sample repositories keep their JSON under 100 MiB; a larger
/// JSON is almost surely a mistake, and parsing it would take several times its size in memory.
pub const MAX_JSON_BYTES: usize = 512 << 20;

/// How the loader may reach files beyond the scene file itself.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// The folder whose files buffer URIs may name (after resolving `..` and symbolic links).
    /// `None`: the scene file's own folder.
    pub asset_root: Option<PathBuf>,
    /// The most bytes the scene may take in memory (`irr --max-memory`). `None`:
    /// [`MemoryLimit::machine`], three quarters of what this machine holds.
    pub max_memory: Option<u64>,
}

impl LoadOptions {
    /// The memory limit these options set.
    #[must_use]
    pub fn memory_limit(&self) -> MemoryLimit {
        self.max_memory
            .map_or_else(MemoryLimit::machine, MemoryLimit::bytes)
    }
}

/// How many bytes a scene may take in memory, and where the figure comes from (for messages).
///
/// It bounds what the loader allocates and, once loaded, what the scene takes with its BVH
/// (irr-render checks that before the build): a scene over it is refused with the figures
/// instead of exhausting the machine. It is the only bound on what a file's repeats may cost (a
/// mesh placed by many nodes, accessors shared by many primitives): those are how users'
/// scenes are built, so only the machine limits them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryLimit {
    /// The limit in bytes.
    pub bytes: u64,
    /// Where it comes from.
    pub source: LimitSource,
}

/// Where a [`MemoryLimit`] comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LimitSource {
    /// The user set it (`--max-memory`, [`LoadOptions::max_memory`]).
    Set,
    /// Three quarters of the machine's memory, this many bytes.
    Machine(u64),
    /// The machine's memory could not be read.
    Unknown,
}

impl MemoryLimit {
    /// The limit when the machine's memory cannot be read: 4 GiB.
    pub const UNKNOWN_MACHINE: u64 = 4 << 30;

    /// A limit the user set, in bytes.
    #[must_use]
    pub fn bytes(bytes: u64) -> Self {
        Self {
            bytes,
            source: LimitSource::Set,
        }
    }

    /// Three quarters of this machine's memory (its physical memory, or its control group's
    /// limit where that is lower), leaving a quarter to the system, the renderer's working
    /// memory (film, caches) and other programs; [`Self::UNKNOWN_MACHINE`] if neither can be
    /// read.
    #[must_use]
    pub fn machine() -> Self {
        match machine_memory() {
            Some(m) => Self {
                bytes: m / 4 * 3,
                source: LimitSource::Machine(m),
            },
            None => Self {
                bytes: Self::UNKNOWN_MACHINE,
                source: LimitSource::Unknown,
            },
        }
    }

    /// Where the figure comes from, for messages: "3/4 of this machine's 23.5 GiB" or "set
    /// by --max-memory".
    #[must_use]
    pub fn source(&self) -> String {
        match self.source {
            LimitSource::Set => "set by --max-memory".to_string(),
            LimitSource::Unknown => {
                "this machine's memory is unknown; --max-memory sets it".to_string()
            }
            LimitSource::Machine(m) => {
                format!("3/4 of this machine's {}; --max-memory sets it", gib(m))
            }
        }
    }
}

impl std::fmt::Display for MemoryLimit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} ({})", gib(self.bytes), self.source())
    }
}

/// `bytes` in GiB with one decimal ("23.5 GiB"), or in MiB below 1 GiB.
#[must_use]
pub fn gib(bytes: u64) -> String {
    if bytes >= 1 << 30 {
        format!("{:.1} GiB", bytes as f64 / f64::from(1u32 << 30))
    } else {
        format!("{:.1} MiB", bytes as f64 / f64::from(1u32 << 20))
    }
}

/// The memory this process may use: the machine's physical memory, or its control group's
/// limit where one is set and lower (a container). `None` where neither can be read.
#[must_use]
pub fn machine_memory() -> Option<u64> {
    let mut system = sysinfo::System::new().ok()?;
    system.refresh_memory();
    let total = system.total_memory();
    let limit = system
        .cgroup_limits()
        .map(|c| c.total_memory)
        .filter(|&c| c > 0)
        .map_or(total, |c| c.min(total));
    (limit > 0).then_some(limit)
}

/// Opens `path` for reading only if it is a regular file, and returns it with its size.
///
/// The file is checked twice: by name before it is opened (so a FIFO is never opened), and by
/// handle after (so a file swapped in between is still caught). On Unix it is also opened with
/// `O_NONBLOCK`, so even a FIFO swapped in at the last moment cannot block the open.
pub fn open_regular(path: &Path) -> Result<(File, u64), String> {
    let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if !meta.is_file() {
        return Err(not_regular(&meta));
    }
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(|e| e.to_string())?;
    let meta = file.metadata().map_err(|e| e.to_string())?;
    if !meta.is_file() {
        return Err(not_regular(&meta));
    }
    Ok((file, meta.len()))
}

fn not_regular(meta: &std::fs::Metadata) -> String {
    let kind = if meta.is_dir() {
        "a folder"
    } else {
        "a device, FIFO or socket"
    };
    format!("it is {kind}, not a regular file")
}

/// Reads exactly `len` bytes from the start of `file` (whose size is at least `len`), reserving
/// the memory fallibly.
pub fn read_prefix(file: File, len: u64) -> Result<Vec<u8>, String> {
    let capacity = usize::try_from(len).map_err(|_| format!("{len} bytes do not fit in memory"))?;
    let mut bytes = Vec::new();
    bytes
        .try_reserve_exact(capacity)
        .map_err(|_| format!("cannot allocate {len} bytes"))?;
    file.take(len)
        .read_to_end(&mut bytes)
        .map_err(|e| e.to_string())?;
    if bytes.len() as u64 != len {
        return Err(format!(
            "the file shrank while it was read ({} of {len} bytes)",
            bytes.len()
        ));
    }
    Ok(bytes)
}

/// Reads the scene file itself: a regular file of at most [`MAX_SCENE_BYTES`].
pub(crate) fn read_scene_file(path: &Path) -> Result<Vec<u8>, String> {
    let (file, len) = open_regular(path)?;
    if len > MAX_SCENE_BYTES {
        return Err(format!(
            "the file has {len} bytes, more than irr reads ({MAX_SCENE_BYTES} bytes, the most a .glb can declare)"
        ));
    }
    read_prefix(file, len)
}

/// The folder a file lives in (`.` for a bare file name).
fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Where buffer files may be read from: the canonical asset root, and the canonical folder that
/// relative URIs start from (the scene file's).
#[derive(Debug)]
pub(crate) struct Confinement {
    root: PathBuf,
    folder: PathBuf,
    /// The digest of every byte read through it, in the order read.
    digest: Cell<Fnv>,
}

impl Confinement {
    /// The confinement for the scene file `scene`: relative URIs start from its folder, and may
    /// reach only files inside `options.asset_root` (default: that folder).
    pub(crate) fn new(scene: &Path, options: &LoadOptions) -> Result<Self, String> {
        let folder = folder_of(scene);
        let folder = folder
            .canonicalize()
            .map_err(|e| format!("cannot resolve the scene's folder: {e}"))?;
        let root = match &options.asset_root {
            None => folder.clone(),
            Some(root) => root
                .canonicalize()
                .map_err(|e| format!("cannot resolve the asset root {}: {e}", root.display()))?,
        };
        Ok(Self {
            root,
            folder,
            digest: Cell::new(Fnv::default()),
        })
    }

    /// Reads the first `len` bytes of the file that the (percent-decoded) relative reference
    /// `name` names, if it lies inside the root and is a regular file of at least `len` bytes.
    /// Errors are for a message that starts with the buffer and its URI.
    pub(crate) fn read(&self, name: &str, len: u64) -> Result<Vec<u8>, String> {
        let (file, size, real) = self.open(name, "buffer")?;
        if size < len {
            return Err(format!(
                "names {}, which has {size} bytes, but the buffer's byteLength says {len}",
                real.display()
            ));
        }
        let bytes = read_prefix(file, len)
            .map_err(|e| format!("cannot be read: {}: {e}", real.display()))?;
        self.digest_part(&bytes);
        Ok(bytes)
    }

    /// Reads the whole file that the (percent-decoded) relative reference `name` names (an
    /// image), under the same rules as [`Confinement::read`]; at most [`MAX_SCENE_BYTES`].
    /// Errors are for a message that starts with the image and its URI.
    pub(crate) fn read_whole(&self, name: &str) -> Result<Vec<u8>, String> {
        let (file, size, real) = self.open(name, "image")?;
        if size > MAX_SCENE_BYTES {
            return Err(format!(
                "names {}, which has {size} bytes, more than irr reads ({MAX_SCENE_BYTES} bytes)",
                real.display()
            ));
        }
        let bytes = read_prefix(file, size)
            .map_err(|e| format!("cannot be read: {}: {e}", real.display()))?;
        self.digest_part(&bytes);
        Ok(bytes)
    }

    /// Adds `bytes` (one file's, the scene file's or one it names) to the digest.
    pub(crate) fn digest_part(&self, bytes: &[u8]) {
        let mut d = self.digest.get();
        d.update_part(bytes);
        self.digest.set(d);
    }

    /// The digest of every file read so far, in the order read.
    pub(crate) fn digest(&self) -> u64 {
        self.digest.get().finish()
    }

    /// Opens the regular file that `name` names inside the root (`kind`: what names it, for
    /// messages), with its size and canonical path.
    fn open(&self, name: &str, kind: &str) -> Result<(File, u64, PathBuf), String> {
        let outside = || {
            format!(
                "leads outside the folder irr reads {kind}s from ({}); name a wider folder with --asset-root to allow it",
                self.root.display()
            )
        };
        let relative = Path::new(name);
        if relative.has_root()
            || relative
                .components()
                .any(|c| matches!(c, Component::Prefix(_) | Component::RootDir))
        {
            return Err(format!(
                "is an absolute path; {kind} URIs must be relative to the scene file ({})",
                outside()
            ));
        }
        // First without the file system: `..` must not climb above the root. This answers the
        // same for files that exist and files that do not.
        let lexical = normalize(&self.folder.join(relative));
        if !lexical.starts_with(&self.root) {
            return Err(outside());
        }
        // Then with it: symbolic links must not lead out either.
        let real = lexical
            .canonicalize()
            .map_err(|e| format!("points nowhere: cannot read {}: {e}", lexical.display()))?;
        if !real.starts_with(&self.root) {
            return Err(format!("is a symbolic link that {}", outside()));
        }
        let (file, size) =
            open_regular(&real).map_err(|e| format!("cannot be read: {}: {e}", real.display()))?;
        Ok((file, size, real))
    }
}

/// `path` with `.` removed and each `..` taking away the component before it, without asking
/// the file system (so it never follows a link). `..` above the root stays at the root.
fn normalize(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    out
}

/// What the loader may allocate: every allocation whose size a file states (element counts,
/// images, instancing) is charged here first, so that no file makes irr allocate past its limits.
///
/// Two limits:
/// - the scene's [`MemoryLimit`], for everything: loaded arrays, repeats of shared data, decoded
///   images;
/// - for data that no bytes of a file hold (an accessor without a buffer view, whose count a
///   few bytes of JSON state freely), [`Budget::BASE`] plus [`Budget::FACTOR`] times the bytes of
///   the files read. The factor covers what honest files do with it (sparse accessors over a
///   zero base, morph targets); a file asking more is an allocation bomb, refused however much
///   memory the machine has.
#[derive(Debug)]
pub(crate) struct Budget {
    limit: MemoryLimit,
    spent: u64,
    unbacked_limit: u64,
    unbacked: u64,
}

impl Budget {
    /// Bytes of unbacked data every scene may use whatever its size.
    pub(crate) const BASE: u64 = 16 << 20;
    /// Bytes of unbacked data per byte of input.
    pub(crate) const FACTOR: u64 = 64;

    /// The budget for a scene whose files hold `input_bytes` bytes, within `limit`.
    pub(crate) fn new(limit: MemoryLimit, input_bytes: u64) -> Self {
        Self {
            limit,
            spent: 0,
            unbacked_limit: Self::BASE.saturating_add(Self::FACTOR.saturating_mul(input_bytes)),
            unbacked: 0,
        }
    }

    /// Raises the unbacked allowance for `bytes` more bytes of input (a buffer or image file
    /// read).
    pub(crate) fn add_input(&mut self, bytes: u64) {
        self.unbacked_limit = self
            .unbacked_limit
            .saturating_add(Self::FACTOR.saturating_mul(bytes));
    }

    /// The bytes charged and not refunded.
    pub(crate) fn spent(&self) -> u64 {
        self.spent
    }

    /// The scene's memory limit.
    pub(crate) fn limit(&self) -> MemoryLimit {
        self.limit
    }

    /// Charges `count` items of `T` for `what`, or says why they exceed the memory limit.
    pub(crate) fn charge<T>(&mut self, what: &str, count: usize) -> Result<(), String> {
        let bytes = (count as u64).saturating_mul(size_of::<T>() as u64);
        let spent = self.spent.saturating_add(bytes);
        if spent > self.limit.bytes {
            return Err(format!(
                "{what} needs {count} elements ({}), which would take the scene past its memory limit of {}",
                gib(bytes),
                self.limit
            ));
        }
        self.spent = spent;
        Ok(())
    }

    /// Charges `count` items of `T` that no bytes of a file hold to the unbacked allowance (the
    /// allocation is charged to the memory limit by [`Budget::vec`] as any other).
    pub(crate) fn charge_unbacked<T>(&mut self, what: &str, count: usize) -> Result<(), String> {
        let bytes = (count as u64).saturating_mul(size_of::<T>() as u64);
        let unbacked = self.unbacked.saturating_add(bytes);
        if unbacked > self.unbacked_limit {
            return Err(format!(
                "{what} states {count} elements ({}) with no buffer data behind them, past the {} MiB of memory irr allows such data ({} MiB plus {}× the size of the scene's files)",
                gib(bytes),
                self.unbacked_limit >> 20,
                Self::BASE >> 20,
                Self::FACTOR,
            ));
        }
        self.unbacked = unbacked;
        Ok(())
    }

    /// Gives back `count` items of `T` charged before (a temporary copy dropped), so that the
    /// tally is what the loader holds, not all it ever held.
    pub(crate) fn refund<T>(&mut self, count: usize) {
        let bytes = (count as u64).saturating_mul(size_of::<T>() as u64);
        self.spent = self.spent.saturating_sub(bytes);
    }

    /// A vector with room for `count` items of `T`, charged to the budget and reserved fallibly.
    pub(crate) fn vec<T>(&mut self, what: &str, count: usize) -> Result<Vec<T>, String> {
        self.charge::<T>(what, count)?;
        let mut v = Vec::new();
        v.try_reserve_exact(count)
            .map_err(|_| format!("{what}: cannot allocate {count} elements"))?;
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalize_removes_dots_without_the_file_system() {
        assert_eq!(
            normalize(Path::new("/a/b/../c/./d")),
            PathBuf::from("/a/c/d")
        );
        assert_eq!(normalize(Path::new("/a/../../..")), PathBuf::from("/"));
    }

    #[test]
    fn budget_refuses_past_its_limit() {
        let mut b = Budget::new(MemoryLimit::bytes(1 << 20), 0);
        assert!(b.charge::<u8>("a", 1 << 20).is_ok());
        let e = b.charge::<u8>("b", 1).err().unwrap_or_default();
        assert!(e.starts_with("b needs 1 elements"), "{e}");
        assert!(
            e.contains("memory limit of 1.0 MiB (set by --max-memory)"),
            "{e}"
        );
        assert!(b.vec::<[f32; 3]>("c", usize::MAX).is_err());
        // A refund makes room again.
        b.refund::<u8>(1);
        assert!(b.charge::<u8>("d", 1).is_ok());
        assert_eq!(b.spent(), 1 << 20);
    }

    /// Unbacked data has its own allowance, sized by the files read, whatever the memory limit.
    #[test]
    fn unbacked_data_is_bounded_by_the_files() {
        let mut b = Budget::new(MemoryLimit::bytes(u64::MAX), 1000);
        let allowance = Budget::BASE + Budget::FACTOR * 1000;
        assert!(b.charge_unbacked::<u8>("a", allowance as usize).is_ok());
        let e = b.charge_unbacked::<u8>("b", 1).err().unwrap_or_default();
        assert!(e.contains("no buffer data behind them"), "{e}");
        // Reading another file raises it.
        b.add_input(1);
        assert!(b.charge_unbacked::<u8>("c", 64).is_ok());
        assert!(b.charge_unbacked::<u8>("d", 1).is_err());
    }

    /// The machine's limit is three quarters of a figure this machine reports.
    #[test]
    fn the_default_limit_comes_from_the_machine() {
        let limit = LoadOptions::default().memory_limit();
        match limit.source {
            LimitSource::Unknown => assert_eq!(limit.bytes, MemoryLimit::UNKNOWN_MACHINE),
            LimitSource::Machine(m) => assert_eq!(limit.bytes, m / 4 * 3),
            LimitSource::Set => panic!("the default limit names no machine: {limit:?}"),
        }
        let set = LoadOptions {
            max_memory: Some(5 << 30),
            ..LoadOptions::default()
        };
        assert_eq!(set.memory_limit(), MemoryLimit::bytes(5 << 30));
        assert_eq!(gib(5 << 30), "5.0 GiB");
        assert_eq!(gib(3 << 19), "1.5 MiB");
    }
}
