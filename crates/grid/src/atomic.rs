//! Atomic outputs: every file the project writes goes through [`write_atomic`], and every
//! result folder through [`StagedDir`] (written in a hidden staging folder beside the target,
//! renamed into place at the end; an existing non-empty folder is refused unless replacing it
//! is asked for), so an interrupted run never leaves a file or folder that looks complete.

use std::io::Write as _;
use std::path::{Path, PathBuf};

/// An output could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The output folder (or file) exists and is not empty, and replacing it was not asked for.
    #[error("{0}: exists and is not empty (use --force to replace it)")]
    Exists(PathBuf),
    /// A file or folder could not be created, written or renamed.
    #[error("{path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

impl OutputError {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> OutputError {
        let path = path.into();
        move |source| OutputError::Io { path, source }
    }
}

/// Refuses to overwrite an existing output file unless `force`.
pub fn check_output_file(path: &Path, force: bool) -> Result<(), OutputError> {
    if path.exists() && !force {
        return Err(OutputError::Exists(path.to_path_buf()));
    }
    Ok(())
}

/// Writes `bytes` to `path` through a temporary file in the same folder (`.NAME.tmp`), synced,
/// then renamed over `path`. On error the temporary file is removed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let name = path.file_name().map_or_else(|| "file".into(), |n| n.to_string_lossy().into_owned());
    let tmp = path.with_file_name(format!(".{name}.tmp"));
    let result = std::fs::File::create(&tmp)
        .and_then(|mut f| f.write_all(bytes).and_then(|()| f.sync_all()))
        .and_then(|()| std::fs::rename(&tmp, path));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// A result folder being written.
#[derive(Debug)]
pub struct StagedDir {
    target: PathBuf,
    staging: PathBuf,
    force: bool,
}

fn is_empty_dir(p: &Path) -> bool {
    std::fs::read_dir(p).map(|mut d| d.next().is_none()).unwrap_or(false)
}

impl StagedDir {
    /// Starts writing `target`. Fails if `target` exists, is not an empty folder and `force` is
    /// false.
    pub fn create(target: &Path, force: bool) -> Result<StagedDir, OutputError> {
        if target.exists() && !force && !is_empty_dir(target) {
            return Err(OutputError::Exists(target.to_path_buf()));
        }
        let name = target.file_name().map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
        let parent = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        std::fs::create_dir_all(&parent).map_err(OutputError::io(&parent))?;
        let staging = parent.join(format!(".{name}.partial"));
        if staging.exists() {
            std::fs::remove_dir_all(&staging).map_err(OutputError::io(&staging))?;
        }
        std::fs::create_dir_all(&staging).map_err(OutputError::io(&staging))?;
        Ok(StagedDir { target: target.to_path_buf(), staging, force })
    }

    /// Where files go while writing.
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// A path inside the staging folder, its parent folders created.
    pub fn file(&self, rel: &str) -> Result<PathBuf, OutputError> {
        let p = self.staging.join(rel);
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent).map_err(OutputError::io(parent))?;
        }
        Ok(p)
    }

    /// Writes `bytes` to `rel` inside the folder.
    pub fn write(&self, rel: &str, bytes: &[u8]) -> Result<(), OutputError> {
        let p = self.file(rel)?;
        write_atomic(&p, bytes).map_err(OutputError::io(&p))?;
        Ok(())
    }

    /// Moves the finished folder into place (replacing an existing one only if allowed).
    pub fn finish(self) -> Result<PathBuf, OutputError> {
        if self.target.exists() {
            if !self.force && !is_empty_dir(&self.target) {
                return Err(OutputError::Exists(self.target.clone()));
            }
            std::fs::remove_dir_all(&self.target).map_err(OutputError::io(&self.target))?;
        }
        std::fs::rename(&self.staging, &self.target).map_err(OutputError::io(&self.target))?;
        Ok(self.target)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_and_leaves_no_temporary() {
        let dir = std::env::temp_dir().join(format!("mapkeeper-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("out.txt");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        assert!(!dir.join(".out.txt.tmp").exists());
        assert!(write_atomic(&dir.join("missing/out.txt"), b"x").is_err());
    }
}

#[cfg(test)]
mod staged_tests {
    use super::*;

    #[test]
    fn refuses_non_empty_and_replaces_with_force() {
        let base = std::env::temp_dir().join(format!("mapkeeper-staged-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&base);
        let target = base.join("out");
        let s = StagedDir::create(&target, false).unwrap();
        s.write("a/b.txt", b"one").unwrap();
        assert!(!target.exists(), "nothing visible before finish");
        s.finish().unwrap();
        assert_eq!(std::fs::read(target.join("a/b.txt")).unwrap(), b"one");
        assert!(matches!(StagedDir::create(&target, false), Err(OutputError::Exists(_))));
        let s = StagedDir::create(&target, true).unwrap();
        s.write("c.txt", b"two").unwrap();
        s.finish().unwrap();
        assert!(!target.join("a/b.txt").exists());
        assert_eq!(std::fs::read(target.join("c.txt")).unwrap(), b"two");
        std::fs::remove_dir_all(&base).unwrap();
    }
}
