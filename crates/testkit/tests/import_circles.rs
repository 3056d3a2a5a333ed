//! No two files of a crate import each other, directly or round a longer circle (issue 56:
//! "0 import circles at file level in every crate, held by a test"). Every crate under
//! `crates/` is scanned (`mapkeeper_testkit::import_graph`: a file is tied to the file that
//! defines what it names, test code left out); a circle fails the test, listing its files and,
//! per tie, the names that make it, so the failure says what to move.
//!
//! The scanner is tested first on small trees written to a temporary folder, so that the check
//! cannot pass by seeing nothing.
#![allow(clippy::unwrap_used)]

use mapkeeper_testkit::corpus::workspace_root;
use mapkeeper_testkit::import_graph::{CrateGraph, scan_crate, scan_crates};
use std::path::PathBuf;

/// A crate folder under the temporary folder, with `files` (path under `src/`, text) written.
fn synthetic(name: &str, files: &[(&str, &str)]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mapkeeper-import-circles-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    for (path, text) in files {
        let file = dir.join("src").join(path);
        std::fs::create_dir_all(file.parent().unwrap()).unwrap();
        std::fs::write(file, text).unwrap();
    }
    dir
}

fn scan(name: &str, files: &[(&str, &str)]) -> CrateGraph {
    let dir = synthetic(name, files);
    let graph = scan_crate(&dir).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(graph.missing.is_empty(), "{:?}", graph.missing);
    graph
}

/// The names tying `from` to `to`.
fn ties(g: &CrateGraph, from: &str, to: &str) -> Vec<String> {
    g.edges.get(&(from.to_string(), to.to_string())).map(|t| t.keys().cloned().collect()).unwrap_or_default()
}

#[test]
fn a_circle_is_found_with_the_names_that_tie_it() {
    let g = scan(
        "circle",
        &[
            ("lib.rs", "mod a;\nmod b;\nmod c;\npub use a::Alpha;\n"),
            ("a.rs", "use crate::b::Beta;\npub struct Alpha(Beta);\n"),
            ("b.rs", "pub struct Beta;\nimpl Beta {\n    fn gamma() -> u8 { crate::c::gamma() }\n}\n"),
            ("c.rs", "pub fn gamma() -> u8 { let _ = super::Alpha; 1 }\n"),
        ],
    );
    // lib.rs re-exports Alpha: a tie to a.rs, but `super::Alpha` in c.rs is a tie to a.rs,
    // where Alpha is defined, not to lib.rs.
    assert_eq!(ties(&g, "lib.rs", "a.rs"), ["Alpha"]);
    assert_eq!(ties(&g, "c.rs", "a.rs"), ["Alpha"]);
    assert!(ties(&g, "c.rs", "lib.rs").is_empty());
    let circles = g.circles();
    assert_eq!(circles.len(), 1, "{circles:?}");
    assert_eq!(circles[0].files, ["a.rs", "b.rs", "c.rs"]);
    let text = circles[0].to_string();
    assert!(text.contains("3 files import each other round a circle"), "{text}");
    assert!(text.contains("a.rs → b.rs: Beta (line 1)"), "{text}");
    assert!(text.contains("b.rs → c.rs: gamma (line 3)"), "{text}");
    assert!(text.contains("c.rs → a.rs: Alpha (line 1)"), "{text}");
}

#[test]
fn a_name_only_in_a_comment_a_string_or_test_code_is_no_tie() {
    let g = scan(
        "comments",
        &[
            ("lib.rs", "mod a;\nmod b;\n#[cfg(test)]\nmod tests;\n"),
            (
                "a.rs",
                "// use crate::b::B;\n/* crate::b::B */\n/// [`crate::b::B`]\npub fn f() -> &'static str { \"crate::b::B\" }\n#[cfg(test)]\nmod tests {\n    use crate::b::B;\n}\n#[cfg(test)]\nfn helper() { crate::b::B; }\n",
            ),
            ("b.rs", "pub struct B;\npub fn g() { crate::a::f(); }\n"),
            ("tests.rs", "use crate::b::B;\n"),
        ],
    );
    assert!(!g.files.contains("tests.rs"));
    assert_eq!(g.edges.len(), 1, "{:?}", g.edges);
    assert_eq!(ties(&g, "b.rs", "a.rs"), ["f"]);
    assert!(g.circles().is_empty());
}

#[test]
fn brace_groups_globs_and_multi_line_uses_are_resolved() {
    let g = scan(
        "braces",
        &[
            ("lib.rs", "pub mod a;\npub mod b;\nmod user;\n"),
            ("a/mod.rs", "pub mod x;\npub mod y;\npub use y::Why as Y2;\n"),
            ("a/x.rs", "pub struct X;\npub fn ex() {}\n"),
            ("a/y.rs", "pub struct Why;\npub struct Z;\n"),
            ("b.rs", "pub mod parts;\npub use parts::*;\n"),
            ("b/parts.rs", "pub fn part() {}\npub fn unused_part() {}\n"),
            (
                "user.rs",
                "use crate::{\n    a::{x::{self, X}, Y2},\n    b::*,\n};\nfn f(_: X, _: Y2) { x::ex(); part(); }\n",
            ),
        ],
    );
    assert_eq!(ties(&g, "user.rs", "a/x.rs"), ["X", "ex"]);
    // Y2 is `a::y::Why`, re-exported by a/mod.rs: the tie is to a/y.rs, named by the item.
    assert_eq!(ties(&g, "user.rs", "a/y.rs"), ["Why"]);
    assert_eq!(ties(&g, "a/mod.rs", "a/y.rs"), ["Why"]);
    // The glob of b brings b's glob of parts: only the name used ties.
    assert_eq!(ties(&g, "user.rs", "b/parts.rs"), ["part"]);
    assert!(ties(&g, "user.rs", "a/mod.rs").is_empty() && ties(&g, "user.rs", "b.rs").is_empty());
}

#[test]
fn super_and_relative_paths_and_inline_modules_are_resolved() {
    let g = scan(
        "super",
        &[
            ("lib.rs", "pub mod outer {\n    pub mod inner;\n}\nmod top;\npub fn root_fn() {}\n"),
            ("outer/inner.rs", "pub mod leaf;\npub fn inner_fn() { super::super::top::Top::new(); }\n"),
            ("outer/inner/leaf.rs", "use super::inner_fn;\npub fn leaf_fn() { inner_fn(); crate::root_fn(); }\n"),
            (
                "top.rs",
                "pub struct Top;\nimpl Top { pub fn new() {} }\nfn t() {\n    crate::outer::inner::inner_fn();\n}\n",
            ),
        ],
    );
    assert_eq!(
        g.files.iter().map(String::as_str).collect::<Vec<_>>(),
        ["lib.rs", "outer/inner.rs", "outer/inner/leaf.rs", "top.rs"]
    );
    assert_eq!(ties(&g, "outer/inner.rs", "top.rs"), ["Top"]);
    assert_eq!(ties(&g, "outer/inner/leaf.rs", "outer/inner.rs"), ["inner_fn"]);
    assert_eq!(ties(&g, "outer/inner/leaf.rs", "lib.rs"), ["root_fn"]);
    assert_eq!(ties(&g, "top.rs", "outer/inner.rs"), ["inner_fn"]);
    // A file naming what an enclosing module defines is tied upward; those ties make no circle.
    assert!(g.is_upward("outer/inner/leaf.rs", "outer/inner.rs") && g.is_upward("outer/inner/leaf.rs", "lib.rs"));
    assert!(!g.is_upward("top.rs", "outer/inner.rs") && !g.is_upward("outer/inner.rs", "top.rs"));
    let circles = g.circles();
    assert_eq!(circles.len(), 1);
    assert_eq!(circles[0].files, ["outer/inner.rs", "top.rs"]);
    assert!(circles[0].to_string().contains("top.rs → outer/inner.rs: inner_fn (line 4)"), "{}", circles[0]);
}

#[test]
fn a_parent_and_its_files_are_no_circle_but_a_circle_through_the_parent_is() {
    let files = [
        ("lib.rs", "mod report;\nmod results;\n"),
        ("results/mod.rs", "mod merge;\npub use merge::merge;\npub struct ResultsError;\n"),
        ("results/merge.rs", "use super::ResultsError;\npub fn merge() -> ResultsError { ResultsError }\n"),
        ("report.rs", "pub fn write() {}\n"),
    ];
    let g = scan("upward", &files);
    assert_eq!(ties(&g, "results/mod.rs", "results/merge.rs"), ["merge"]);
    assert_eq!(ties(&g, "results/merge.rs", "results/mod.rs"), ["ResultsError"]);
    assert!(g.circles().is_empty(), "{:?}", g.circles());
    // The merge writes a report that names the results' error: a circle through the parent.
    let mut files = files.to_vec();
    files[2].1 = "use super::ResultsError;\npub fn merge() -> ResultsError { crate::report::write(); ResultsError }\n";
    files[3].1 = "pub fn write() -> crate::results::ResultsError { todo!() }\n";
    let circles = scan("upward-circle", &files).circles();
    assert_eq!(circles.len(), 1);
    assert_eq!(circles[0].files, ["report.rs", "results/merge.rs", "results/mod.rs"]);
    // The upward tie (merge.rs → mod.rs) is not listed: it is not what makes the circle.
    assert_eq!(circles[0].edges.len(), 3, "{}", circles[0]);
}

#[test]
fn an_item_of_another_crate_is_tied_to_the_file_that_brings_it_in() {
    let g = scan(
        "external",
        &[
            ("lib.rs", "mod runner;\nmod user;\n"),
            ("runner.rs", "pub use other_crate::{Clock, NoClock};\nuse std::fmt;\n"),
            (
                "user.rs",
                "use crate::runner::Clock;\nuse other_crate::Own;\nfn f(_: &dyn Clock, _: Own) { crate::runner::NoClock; }\n",
            ),
        ],
    );
    assert_eq!(ties(&g, "user.rs", "runner.rs"), ["Clock", "NoClock"]);
    assert_eq!(g.edge_count(), 1, "{:?}", g.edges);
}

#[test]
fn a_mod_declaration_alone_is_no_tie_and_a_missing_file_is_reported() {
    let dir = synthetic("mods", &[("lib.rs", "mod a;\nmod gone;\n"), ("a.rs", "pub fn f() {}\n")]);
    let g = scan_crate(&dir).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(g.edges.is_empty(), "{:?}", g.edges);
    assert_eq!(g.missing, ["lib.rs:2: mod gone: neither gone.rs nor gone/mod.rs"]);
}

/// Every crate under `crates/`, each named by its folder from the checkout's root
/// (`crates/scenario`).
fn workspace_crates() -> Vec<CrateGraph> {
    let root = workspace_root();
    let mut graphs = scan_crates(&root.join("crates")).unwrap();
    for g in &mut graphs {
        g.dir = g.dir.strip_prefix(&root).unwrap().to_path_buf();
    }
    graphs
}

#[test]
fn the_scan_sees_every_crate_and_its_imports() {
    let graphs = workspace_crates();
    let names: Vec<String> = graphs.iter().map(|g| g.dir.file_name().unwrap().to_string_lossy().into_owned()).collect();
    for expected in ["cli", "common", "grid", "harness", "localiser", "logs", "sensor", "sim", "testkit", "updater"] {
        assert!(names.iter().any(|n| n == expected), "crate {expected} not scanned: {names:?}");
    }
    let missing: Vec<&String> = graphs.iter().flat_map(|g| &g.missing).collect();
    assert!(missing.is_empty(), "module files the scan could not find: {missing:?}");
    let files: usize = graphs.iter().map(|g| g.files.len()).sum();
    let edges: usize = graphs.iter().map(CrateGraph::edge_count).sum();
    eprintln!("import graph: {} crates, {files} files, {edges} ties between files", graphs.len());
    assert!(files > 150, "{files} files");
    assert!(edges > 200, "only {edges} ties between files: the scan is blind");
    // Each crate of more than one file has its files tied somewhere.
    for g in &graphs {
        assert!(g.files.len() < 2 || g.edge_count() > 0, "{}: no ties among {:?}", g.dir.display(), g.files);
    }
}

#[test]
fn no_crate_has_an_import_circle() {
    let circles: Vec<String> = workspace_crates().iter().flat_map(CrateGraph::circles).map(|c| c.to_string()).collect();
    assert!(
        circles.is_empty(),
        "{} import circle(s) at file level; move what ties them (issue 56):\n{}",
        circles.len(),
        circles.join("\n")
    );
}
