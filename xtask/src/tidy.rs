//! The codebase's own rules, checked as ordinary tests (after rust-analyzer's `xtask/src/tidy.rs`):
//!
//! - every `.rs` file under `crates/`, `xtask/` and `tests/` opens with `//!` docs;
//! - the dependency edges between `irr-*` crates are exactly allowed by the table in
//!   docs/ARCHITECTURE.md (read from `cargo metadata`).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Runs every check; the error lists every violation found.
pub fn run(root: &Path) -> Result<(), String> {
    let mut problems = Vec::new();
    problems.extend(files_without_module_docs(root));
    match dependency_violations(root) {
        Ok(v) => problems.extend(v),
        Err(e) => problems.push(e),
    }
    if problems.is_empty() {
        println!("tidy: all checks passed");
        Ok(())
    } else {
        Err(problems.join("\n"))
    }
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            if path.file_name().is_some_and(|n| n == "target") {
                continue;
            }
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// Files whose first non-blank line is not a `//!` comment.
fn files_without_module_docs(root: &Path) -> Vec<String> {
    let mut files = Vec::new();
    for dir in ["crates", "xtask", "tests"] {
        rust_files(&root.join(dir), &mut files);
    }
    files.sort();
    files
        .into_iter()
        .filter(|f| {
            let text = std::fs::read_to_string(f).unwrap_or_default();
            !text
                .lines()
                .find(|l| !l.trim().is_empty())
                .is_some_and(|l| l.starts_with("//!"))
        })
        .map(|f| format!("{} does not open with //! docs", f.display()))
        .collect()
}

/// The allowed edges, read from the table in docs/ARCHITECTURE.md: the rows between the markers
/// `<!-- dependency-table -->` and `<!-- /dependency-table -->`, each `| crate | may depend on |`.
fn allowed_edges(root: &Path) -> Result<BTreeMap<String, BTreeSet<String>>, String> {
    let path = root.join("docs/ARCHITECTURE.md");
    let text = std::fs::read_to_string(&path)
        .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
    let start = text
        .find("<!-- dependency-table -->")
        .ok_or_else(|| format!("{}: no <!-- dependency-table --> marker", path.display()))?;
    let end = text
        .find("<!-- /dependency-table -->")
        .ok_or_else(|| format!("{}: no <!-- /dependency-table --> marker", path.display()))?;
    let mut allowed = BTreeMap::new();
    for line in text[start..end].lines() {
        let cols: Vec<&str> = line.split('|').map(str::trim).collect();
        // | `irr-x` | `irr-a`, `irr-b` |  →  ["", "`irr-x`", "`irr-a`, `irr-b`", ""]
        if cols.len() < 4 || !cols[1].starts_with("`irr-") {
            continue;
        }
        let name = cols[1].trim_matches('`').to_string();
        let deps = cols[2]
            .split(',')
            .map(|d| d.trim().trim_matches('`').to_string())
            .filter(|d| d.starts_with("irr-"))
            .collect();
        allowed.insert(name, deps);
    }
    if allowed.is_empty() {
        return Err(format!(
            "{}: the dependency table has no rows",
            path.display()
        ));
    }
    Ok(allowed)
}

/// Normal (non-dev) dependency edges between irr crates that the table does not allow, and irr
/// crates missing from the table.
fn dependency_violations(root: &Path) -> Result<Vec<String>, String> {
    let allowed = allowed_edges(root)?;
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    let output = Command::new(cargo)
        .args([
            "metadata",
            "--no-deps",
            "--format-version",
            "1",
            "--offline",
        ])
        .current_dir(root)
        .output()
        .map_err(|e| format!("cannot run cargo metadata: {e}"))?;
    if !output.status.success() {
        return Err(format!(
            "cargo metadata failed: {}",
            String::from_utf8_lossy(&output.stderr)
        ));
    }
    let json = String::from_utf8_lossy(&output.stdout);
    Ok(edges_from_metadata(&json)
        .into_iter()
        .filter_map(|(from, to)| match allowed.get(&from) {
            None => Some(format!(
                "{from} is not in docs/ARCHITECTURE.md's dependency table"
            )),
            Some(ok) if !ok.contains(&to) => Some(format!(
                "{from} -> {to} is not allowed by docs/ARCHITECTURE.md"
            )),
            Some(_) => None,
        })
        .collect())
}

/// (package, dependency) pairs between `irr-*` packages that are normal dependencies (`"kind":
/// null` in `cargo metadata`; dev- and build-dependencies may cross the table).
fn edges_from_metadata(json: &str) -> Vec<(String, String)> {
    let Ok(meta) = serde_json::from_str::<serde_json::Value>(json) else {
        return Vec::new();
    };
    let mut edges = Vec::new();
    for package in meta["packages"].as_array().into_iter().flatten() {
        let Some(name) = package["name"].as_str().filter(|n| n.starts_with("irr-")) else {
            continue;
        };
        for dep in package["dependencies"].as_array().into_iter().flatten() {
            if let Some(dep_name) = dep["name"].as_str().filter(|n| n.starts_with("irr-"))
                && dep["kind"].is_null()
            {
                edges.push((name.to_string(), dep_name.to_string()));
            }
        }
    }
    edges
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::workspace_root;

    #[test]
    fn every_rust_file_opens_with_module_docs() {
        let root = workspace_root().unwrap_or_else(|e| panic!("{e}"));
        let problems = files_without_module_docs(&root);
        assert!(problems.is_empty(), "{}", problems.join("\n"));
    }

    #[test]
    fn irr_dependency_edges_follow_the_architecture_table() {
        let root = workspace_root().unwrap_or_else(|e| panic!("{e}"));
        let problems = dependency_violations(&root).unwrap_or_else(|e| vec![e]);
        assert!(problems.is_empty(), "{}", problems.join("\n"));
    }

    #[test]
    fn metadata_scraper_reads_kinds() {
        let json = r#"{"packages":[{"name":"irr-a","version":"0","dependencies":[{"name":"irr-b","kind":null},{"name":"irr-c","kind":"dev"}],"targets":[]}]}"#;
        assert_eq!(
            edges_from_metadata(json),
            vec![("irr-a".into(), "irr-b".into())]
        );
    }
}
