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

/// A cap on the memory that the loader spends on data whose size the file states (element
/// counts, instancing): every such allocation is charged here first, so a small file cannot ask
/// for gigabytes.
///
/// The limit is [`Budget::BASE`] plus [`Budget::FACTOR`] times the bytes of the files read (the
/// scene file and its buffers). The factor covers the loader's legitimate expansion: a one-byte
/// index of a triangle strip becomes a 12-byte triangle, a 4-byte material id and a 4-byte index
/// (20×), and a mesh instanced by several nodes is copied once per node.
///
/// Images expand far more than geometry (a 4096² texture of flat colour compresses to a few
/// KiB and takes 192 MiB as linear f32 texels), so a scene that decodes images gets
/// [`Budget::IMAGES`] more, once: enough for six 4096² textures whatever the files' size, and
/// still a bound on what a small hostile file can make irr allocate.
#[derive(Debug)]
pub(crate) struct Budget {
    limit: u64,
    spent: u64,
    images_allowed: bool,
}

impl Budget {
    /// Bytes every scene may use whatever its size.
    pub(crate) const BASE: u64 = 16 << 20;
    /// Bytes per byte of input.
    pub(crate) const FACTOR: u64 = 64;
    /// Bytes added once for a scene's decoded images.
    pub(crate) const IMAGES: u64 = 1 << 30;

    /// The budget for a scene whose files hold `input_bytes` bytes.
    pub(crate) fn for_input(input_bytes: u64) -> Self {
        Self {
            limit: Self::BASE.saturating_add(Self::FACTOR.saturating_mul(input_bytes)),
            spent: 0,
            images_allowed: false,
        }
    }

    /// Adds [`Budget::IMAGES`] to the limit, the first time only.
    pub(crate) fn allow_images(&mut self) {
        if !self.images_allowed {
            self.images_allowed = true;
            self.limit = self.limit.saturating_add(Self::IMAGES);
        }
    }

    /// Raises the limit for `bytes` more bytes of input (a buffer or image file read).
    pub(crate) fn add_input(&mut self, bytes: u64) {
        self.limit = self
            .limit
            .saturating_add(Self::FACTOR.saturating_mul(bytes));
    }

    /// Charges `count` items of `T` for `what`, or says why they exceed the budget.
    pub(crate) fn charge<T>(&mut self, what: &str, count: usize) -> Result<(), String> {
        let bytes = (count as u64).saturating_mul(size_of::<T>() as u64);
        let spent = self.spent.saturating_add(bytes);
        if spent > self.limit {
            return Err(format!(
                "{what} needs {count} elements ({bytes} bytes), which would take the scene past {} MiB of memory (irr allows {} MiB plus {}× the size of the scene's files{})",
                self.limit >> 20,
                Self::BASE >> 20,
                Self::FACTOR,
                if self.images_allowed {
                    format!(", plus {} MiB for images", Self::IMAGES >> 20)
                } else {
                    String::new()
                }
            ));
        }
        self.spent = spent;
        Ok(())
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
        let mut b = Budget::for_input(1000);
        let limit = Budget::BASE + 64_000;
        assert!(b.charge::<u8>("a", limit as usize).is_ok());
        let e = b.charge::<u8>("b", 1).err().unwrap_or_default();
        assert!(e.starts_with("b needs 1 elements"), "{e}");
        assert!(b.vec::<[f32; 3]>("c", usize::MAX).is_err());
    }
}
