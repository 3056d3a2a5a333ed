//! The file-level import graph of the workspace's crates, for the test that no crate's files
//! import each other round a circle (`tests/import_circles.rs`, issue 56).
//!
//! A file A is tied to a file B when A's code (comments, string literals and test code left
//! out: `#[cfg(test)]` items, inline `mod tests { … }`, files named `tests.rs`) names an item
//! that B defines, through
//!
//! - a `use` declaration (brace groups, `self`, renames and multi-line trees unfolded), or a
//!   path written in code (`crate::a::b::f(…)`), starting at `crate::`, `super::`, `self::` or
//!   a module or name in scope (`child::X`, an imported module); `Self::` and other crates'
//!   paths are not followed;
//! - re-exports on the way: `pub use child::X` in a parent is itself the parent's tie to the
//!   child, and a file naming `crate::X` is tied to the file defining `X`, not to the one
//!   re-exporting it (for an item of another crate, to the file whose `use` brings it in);
//! - a glob import (`use super::*`, `use part::*`): by each name of the glob that the file's
//!   code uses.
//!
//! A `mod x;` declaration is not a tie. A tie from a file to a file of an enclosing module
//! (`super::Args` in `cmd/run/outputs.rs` to `cmd/run/mod.rs`, the crate's error type in
//! `lib.rs`) is upward: a folder's `mod.rs` declares its files, calls and re-exports them, and
//! they share its types; that is how Rust lays out a module, not a circle, so upward ties are
//! recorded but not followed when circles are sought. Every other tie is: a circle through a
//! parent and files outside it (`results/mod.rs` → `results/merge.rs` →
//! `experiments/validation/report.rs` → `results/mod.rs`) is found.
//!
//! Modules follow Rust's layout: `lib.rs`, `main.rs` and `mod.rs` own their folder's files,
//! `a.rs` owns `a/`, an inline `mod m { mod x; }` owns `m/`. What the scan does not see: names
//! made by macros, and paths inside attribute strings (`#[serde(with = "…")]`).

mod graph;
mod lex;
mod parse;
mod resolve;
mod scc;
mod tree;

pub use graph::{Circle, CrateGraph, Ties};
use std::path::{Path, PathBuf};

/// The import graph of the crate in `dir` (its `src/lib.rs` and `src/main.rs` trees).
///
/// # Errors
///
/// A file of the module tree that cannot be read.
pub fn scan_crate(dir: &Path) -> std::io::Result<CrateGraph> {
    let tree = tree::load(&dir.join("src"))?;
    let edges = resolve::edges(&tree);
    let enclosing = tree.enclosing();
    Ok(CrateGraph { dir: dir.to_path_buf(), files: tree.files, edges, enclosing, missing: tree.missing })
}

/// The import graphs of every crate under `crates_dir` (each folder holding a `src/`), in the
/// order of their folders' names.
///
/// # Errors
///
/// The folder, or a file of a crate's module tree, cannot be read.
pub fn scan_crates(crates_dir: &Path) -> std::io::Result<Vec<CrateGraph>> {
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(crates_dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("src").is_dir())
        .collect();
    dirs.sort();
    dirs.iter().map(|d| scan_crate(d)).collect()
}
