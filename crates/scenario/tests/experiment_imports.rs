//! The experiments' folders stand apart: each experiment (a folder, or `convergence.rs`) imports
//! what every experiment shares (the closed loop of `mapkeeper-closed-loop`, which cannot
//! import an experiment by its dependencies, and the scores and the reference-pose scoring at the
//! top of `experiments/`) and
//! never another experiment; the shared file imports no experiment; `results/claims.rs` imports
//! no report (docs/ARCHITECTURE.md).
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};

const EXPERIMENTS: [&str; 8] = [
    "validation",
    "check_detection",
    "table1_hold",
    "kidnap_robot",
    "recovery",
    "real_data",
    "real_scans",
    "convergence",
];
const SHARED: [&str; 2] = ["scores", "reference"];

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// Every `.rs` file under `path` (or `path` itself if it is a file).
fn files(path: &Path) -> Vec<PathBuf> {
    if path.is_file() {
        return vec![path.to_path_buf()];
    }
    let mut out = Vec::new();
    for e in std::fs::read_dir(path).unwrap() {
        out.extend(files(&e.unwrap().path()));
    }
    out.sort();
    out
}

/// The experiment or shared module at `experiments/<name>` (a folder or a file).
fn module(name: &str) -> PathBuf {
    let dir = src().join("experiments").join(name);
    if dir.is_dir() { dir } else { dir.with_extension("rs") }
}

/// Every `experiments::<name>` written in the code (not in comments) of `path`'s files, as
/// (file, line, name), `name` among `names`.
fn imports(path: &Path, names: &[&str]) -> Vec<(String, usize, String)> {
    let mut found = Vec::new();
    for file in files(path) {
        let text = std::fs::read_to_string(&file).unwrap();
        for (n, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            for name in names {
                let pat = format!("experiments::{name}");
                let hit = code
                    .match_indices(&pat)
                    .any(|(i, _)| !code[i + pat.len()..].starts_with(|c: char| c.is_alphanumeric() || c == '_'));
                if hit {
                    let rel = file.strip_prefix(src()).unwrap_or(&file).display().to_string();
                    found.push((rel, n + 1, name.to_string()));
                }
            }
        }
    }
    found
}

#[test]
fn no_experiment_imports_another() {
    let mut seen_shared = 0;
    for e in EXPERIMENTS {
        let path = module(e);
        assert!(path.exists(), "{} is missing", path.display());
        let other: Vec<_> = imports(&path, &EXPERIMENTS).into_iter().filter(|(_, _, n)| n != e).collect();
        assert!(other.is_empty(), "{e} imports another experiment: {other:?}");
        seen_shared += imports(&path, &SHARED).len();
    }
    assert!(seen_shared >= 3, "the scan must see the experiments' imports of the shared scores ({seen_shared})");
}

#[test]
fn the_shared_files_import_no_experiment() {
    for s in SHARED {
        let found = imports(&module(s), &EXPERIMENTS);
        assert!(found.is_empty(), "{s} (shared) imports an experiment: {found:?}");
    }
}

#[test]
fn the_claims_import_no_report() {
    let text = std::fs::read_to_string(src().join("results").join("claims.rs")).unwrap();
    let code: String = text.lines().map(|l| l.split("//").next().unwrap_or("")).collect::<Vec<_>>().join("\n");
    assert!(!code.contains("::report"), "results/claims.rs imports a report (the reports import the claims)");
}

#[test]
fn the_scan_sees_an_import_written_in_code_and_not_one_in_a_comment() {
    let dir = std::env::temp_dir().join(format!("mapkeeper-imports-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("probe.rs");
    std::fs::write(&file, "use crate::experiments::validation::Scores;\n// crate::experiments::recovery\nuse crate::experiments::validations;\n")
        .unwrap();
    let found = imports(&file, &EXPERIMENTS);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(found.len(), 1, "{found:?}");
    assert_eq!((found[0].1, found[0].2.as_str()), (1, "validation"));
}
