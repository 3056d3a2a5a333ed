//! The updater's folders import one way: `support/` neither of the others, `paper/` only
//! `support/` (and itself), `additions/` both. The additions reach the paper's steps through
//! parameters and the hooks `updater.rs` fills (docs/updater.md, "Layout").
#![allow(clippy::unwrap_used)]

use std::path::Path;

/// Every `crate::<folder>` path written in the code (not in comments) of `folder`'s files, as
/// (file, line, folder named).
fn crate_paths(folder: &str) -> Vec<(String, usize, String)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("src").join(folder);
    let mut found = Vec::new();
    let mut files: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
    files.sort();
    assert!(files.len() >= 3, "{}: expected the folder's files", dir.display());
    for file in files {
        let text = std::fs::read_to_string(&file).unwrap();
        for (n, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            for folder in ["paper", "additions", "support"] {
                if code.contains(&format!("crate::{folder}")) {
                    found.push((file.file_name().unwrap().to_string_lossy().into_owned(), n + 1, folder.to_string()));
                }
            }
        }
    }
    found
}

#[test]
fn support_imports_neither_paper_nor_additions() {
    let back: Vec<_> = crate_paths("support").into_iter().filter(|(_, _, f)| f != "support").collect();
    assert!(back.is_empty(), "support/ reaches up: {back:?}");
}

#[test]
fn paper_imports_support_only() {
    let paths = crate_paths("paper");
    let back: Vec<_> = paths.iter().filter(|(_, _, f)| f == "additions").collect();
    assert!(back.is_empty(), "paper/ imports the additions: {back:?}");
    assert!(paths.iter().any(|(_, _, f)| f == "support"), "the scan must see paper/'s imports of support/");
}
