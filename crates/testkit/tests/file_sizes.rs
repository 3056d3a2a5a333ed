//! No source file of any crate is over 800 lines (issue 56: a file a reader can hold; a file
//! that grows past it is split by what it holds, its unit tests first into a `tests.rs`
//! beside it). Every `.rs` file under `crates/*/src/` is counted, tests included.
#![allow(clippy::unwrap_used)]

use mapkeeper_testkit::corpus::workspace_root;
use std::path::{Path, PathBuf};

/// The most lines a source file may have.
const MAX_LINES: usize = 800;

/// Every `.rs` file under `dir`, sorted.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else { return out };
    for e in entries {
        let path = e.unwrap().path();
        if path.is_dir() {
            out.extend(rust_files(&path));
        } else if path.extension().is_some_and(|x| x == "rs") {
            out.push(path);
        }
    }
    out.sort();
    out
}

/// The files over `max` lines among `files`, with their counts.
fn too_long(files: &[PathBuf], max: usize) -> Vec<(PathBuf, usize)> {
    files
        .iter()
        .map(|f| (f.clone(), std::fs::read_to_string(f).unwrap().lines().count()))
        .filter(|(_, n)| *n > max)
        .collect()
}

#[test]
fn no_source_file_is_over_800_lines() {
    let crates = workspace_root().join("crates");
    let files: Vec<PathBuf> = std::fs::read_dir(&crates)
        .unwrap()
        .map(|e| e.unwrap().path().join("src"))
        .filter(|src| src.is_dir())
        .flat_map(|src| rust_files(&src))
        .collect();
    assert!(files.len() > 200, "the count must see the crates' files ({} found)", files.len());
    let long = too_long(&files, MAX_LINES);
    let list: Vec<String> = long.iter().map(|(f, n)| format!("{}: {n} lines", f.display())).collect();
    assert!(
        long.is_empty(),
        "source files over {MAX_LINES} lines (split them by what they hold):\n{}",
        list.join("\n")
    );
}

#[test]
fn the_count_sees_a_long_file() {
    let dir = std::env::temp_dir().join(format!("mapkeeper-file-sizes-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    std::fs::write(dir.join("short.rs"), "fn a() {}\n".repeat(3)).unwrap();
    std::fs::write(dir.join("sub").join("long.rs"), "// line\n".repeat(MAX_LINES + 1)).unwrap();
    let files = rust_files(&dir);
    let long = too_long(&files, MAX_LINES);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(files.len(), 2);
    assert_eq!(long.len(), 1);
    assert!(long[0].0.ends_with("sub/long.rs") && long[0].1 == MAX_LINES + 1, "{long:?}");
}
