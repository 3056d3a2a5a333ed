//! Helpers shared by the CLI's end-to-end tests: a scratch folder, the binary, paths as text.
#![allow(dead_code, clippy::unwrap_used)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh folder `mapkeeper-<group>-<name>-<pid>` in the temporary folder.
pub fn scratch(group: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mapkeeper-{group}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs the `mapkeeper` binary built for these tests.
pub fn mapkeeper(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mapkeeper")).args(args).output().unwrap()
}

/// A path as `&str` (test paths are UTF-8).
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}
