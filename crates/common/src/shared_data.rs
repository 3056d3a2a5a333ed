//! The team's reference data in `../shared` beside the checkout (real ROS maps, CARMEN logs;
//! never committed), as the tests find it. A clone without it runs every test: the ones that
//! need the data print a note and skip. Where `MAPKEEPER_REQUIRE_SHARED=1` (`.ci/run` sets it),
//! an absent file is a failure instead, so that a skip cannot pass as a pass.

use std::path::{Path, PathBuf};

/// The environment variable that turns an absent file of `../shared` into a panic.
pub const REQUIRE_VAR: &str = "MAPKEEPER_REQUIRE_SHARED";

/// The folder `shared` beside the checkout (which need not exist).
pub fn root() -> PathBuf {
    // This crate is `<checkout>/crates/common`.
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared")
}

/// `../shared/<rel>` if that file or folder exists; else `None` after printing a note naming
/// it and `test`, or a panic when [`REQUIRE_VAR`] is `1`.
pub fn path(rel: &str, test: &str) -> Option<PathBuf> {
    find(&root(), rel, test, std::env::var(REQUIRE_VAR).is_ok_and(|v| v == "1"))
}

fn find(root: &Path, rel: &str, test: &str, required: bool) -> Option<PathBuf> {
    let p = root.join(rel);
    if p.exists() {
        return Some(p);
    }
    let what = format!("{} is absent (no ../shared beside the checkout)", p.display());
    assert!(!required, "{what}, and {REQUIRE_VAR}=1 requires it: {test} would have skipped");
    println!("note: {what}: {test} skipped");
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_present_path_is_found_and_an_absent_one_skips_unless_required() {
        let root = std::env::temp_dir().join(format!("mapkeeper-shared-data-{}", std::process::id()));
        std::fs::create_dir_all(root.join("maps")).unwrap();
        assert_eq!(find(&root, "maps", "t", true), Some(root.join("maps")));
        assert_eq!(find(&root, "logs/x.log", "t", false), None);
        let required = std::panic::catch_unwind(|| find(&root, "logs/x.log", "the test", true));
        let message = required.unwrap_err();
        let text = message.downcast_ref::<String>().unwrap();
        assert!(text.contains("x.log") && text.contains(REQUIRE_VAR) && text.contains("the test"), "{text}");
        let _ = std::fs::remove_dir_all(&root);
    }
}
