//! [`RenderError`]: every way loading, rendering or writing can fail, each displayed as one line
//! that names the file (or the option) and the problem.

use irr_scene::LoadError;
#[cfg(test)]
use irr_scene::is_unprintable;
pub(crate) use irr_scene::one_line;
use std::path::{Path, PathBuf};

/// An error from loading a scene, checking settings, rendering or writing the output.
///
/// `Display` gives one line: the file (or option) first, then the problem, e.g.
/// `assets/box.gltf: buffer 0: cannot read "box.bin" (assets/box.bin): No such file or directory`.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The scene file could not be loaded (irr-scene's [`LoadError`], its message as is).
    #[error(transparent)]
    Load(#[from] LoadError),
    /// The file was read but its content cannot be assembled into a scene to render (a
    /// material or texture the integrator refuses, a BVH that cannot be built).
    #[error("{}: {problem}", .path.display())]
    Scene {
        /// The scene file.
        path: PathBuf,
        /// What is wrong, on one line.
        problem: String,
    },
    /// A render setting (image size, samples per pixel, threads) is out of range.
    #[error("{option}: {problem}")]
    Setting {
        /// The setting, as the command line names it (`--width`).
        option: &'static str,
        /// What is wrong, on one line.
        problem: String,
    },
    /// The output could not be written (folder missing or read-only, disk full, wrong extension).
    #[error("{}: cannot write: {problem}", .path.display())]
    Write {
        /// The output file.
        path: PathBuf,
        /// What is wrong, on one line.
        problem: String,
    },
    /// A persistent irradiance cache (`--cache`) could not be used: unreadable, foreign,
    /// corrupt, or made for another scene, camera or settings.
    #[error("{}: {problem}", .path.display())]
    CacheFile {
        /// The cache file.
        path: PathBuf,
        /// What is wrong, on one line.
        problem: String,
    },
    /// An image file could not be read back (tests and tools read EXRs).
    #[error("{}: cannot read image: {problem}", .path.display())]
    ReadImage {
        /// The image file.
        path: PathBuf,
        /// What is wrong, on one line.
        problem: String,
    },
}

impl RenderError {
    pub(crate) fn scene(path: &Path, problem: impl std::fmt::Display) -> Self {
        Self::Scene {
            path: path.to_path_buf(),
            problem: one_line(problem),
        }
    }

    pub(crate) fn write(path: &Path, problem: impl std::fmt::Display) -> Self {
        Self::Write {
            path: path.to_path_buf(),
            problem: one_line(problem),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Names from a file reach the terminal without raw control characters.
    #[test]
    fn control_characters_are_escaped() {
        let e = RenderError::scene(
            Path::new("a.gltf"),
            "node 0 \"\u{1b}]0;pwned\u{7}\u{1b}[2J\u{202e}evil\ttab\"",
        );
        let text = e.to_string();
        assert_eq!(
            text,
            "a.gltf: node 0 \"\\u{1b}]0;pwned\\u{7}\\u{1b}[2J\\u{202e}evil\\u{9}tab\""
        );
        assert!(!text.chars().any(is_unprintable));
    }
}
