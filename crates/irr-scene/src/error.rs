//! [`LoadError`]: every way reading a scene file can fail, each displayed as one line that
//! names the file and the problem; [`one_line`], which makes any message such a line.

use std::path::{Path, PathBuf};

/// An error from loading a scene file.
///
/// `Display` gives one line: the file first, then the problem, e.g.
/// `assets/box.gltf: buffer 0: cannot read "box.bin" (assets/box.bin): No such file or directory`.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The scene file could not be read at all (missing, a folder, no permission).
    #[error("{}: cannot read: {source}", .path.display())]
    Read {
        /// The scene file.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// The file is not well-formed glTF: truncated or corrupt JSON, a broken .glb container, or
    /// JSON that breaks glTF's schema (an index that points past the end of an array).
    #[error("{}: not a valid glTF 2.0 file: {problem}", .path.display())]
    Parse {
        /// The scene file.
        path: PathBuf,
        /// What is wrong, on one line.
        problem: String,
    },
    /// The file is well-formed but its content cannot be rendered: a buffer URI that points
    /// nowhere, an accessor out of range, non-finite or absurdly large coordinates, a required
    /// extension irr does not support, a camera with an impossible field of view.
    #[error("{}: {problem}", .path.display())]
    Scene {
        /// The scene file.
        path: PathBuf,
        /// What is wrong, on one line.
        problem: String,
    },
}

impl LoadError {
    pub(crate) fn scene(path: &Path, problem: impl std::fmt::Display) -> Self {
        Self::Scene {
            path: path.to_path_buf(),
            problem: one_line(problem),
        }
    }

    pub(crate) fn parse(path: &Path, problem: impl std::fmt::Display) -> Self {
        Self::Parse {
            path: path.to_path_buf(),
            problem: one_line(problem),
        }
    }
}

/// Squeezes a message onto one line that is safe to print: line breaks become `; `, and every
/// other character that a terminal would act on rather than show (see [`is_unprintable`]) is
/// written as a `\u{..}` escape, so a name from a file cannot move the cursor, ring the bell,
/// retitle the window or reorder the text.
pub fn one_line(message: impl std::fmt::Display) -> String {
    let text = message.to_string();
    let mut out = String::with_capacity(text.len());
    for part in text
        .split(['\n', '\r'])
        .map(str::trim)
        .filter(|p| !p.is_empty())
    {
        if !out.is_empty() {
            out.push_str("; ");
        }
        for c in part.chars() {
            if is_unprintable(c) {
                out.extend(c.escape_unicode());
            } else {
                out.push(c);
            }
        }
    }
    out
}

/// Control characters (C0, DEL, C1: ESC, BEL, tab, …) and the invisible format characters that
/// change how text around them is shown (zero-width characters, bidirectional embeddings,
/// overrides and isolates, the byte-order mark).
pub fn is_unprintable(c: char) -> bool {
    c.is_control()
        || matches!(
            c,
            '\u{00AD}'
                | '\u{061C}'
                | '\u{180E}'
                | '\u{200B}'..='\u{200F}'
                | '\u{2028}'..='\u{202E}'
                | '\u{2060}'..='\u{206F}'
                | '\u{FEFF}'
                | '\u{FFF9}'..='\u{FFFB}'
        )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_are_one_line_and_name_the_file() {
        let e = LoadError::parse(Path::new("a/b.gltf"), "first\nsecond\r\n third");
        let text = e.to_string();
        assert_eq!(
            text,
            "a/b.gltf: not a valid glTF 2.0 file: first; second; third"
        );
        assert!(!text.contains('\n'));
    }
}
