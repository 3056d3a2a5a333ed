//! Atomic outputs: every file the project writes goes through [`write_atomic`], and every
//! result folder through [`StagedDir`] (written in a hidden staging folder beside the target,
//! renamed into place at the end; an existing non-empty folder is refused unless replacing it
//! is asked for), so an interrupted run never leaves a file or folder that looks complete.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

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

/// A file being written atomically: the bytes go to a temporary file beside the target
/// (`.NAME.tmp-PID-K`, unique per process and file), which [`AtomicFile::commit`] syncs and
/// renames over the target. Dropped without a commit, the temporary is removed, so a reader
/// never sees a half-written file under the target's name.
#[derive(Debug)]
pub struct AtomicFile {
    path: PathBuf,
    tmp: PathBuf,
    file: std::fs::File,
    committed: bool,
}

impl AtomicFile {
    /// Starts writing `path`.
    pub fn create(path: &Path) -> std::io::Result<Self> {
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        let name = path.file_name().map_or_else(|| "file".into(), |n| n.to_string_lossy().into_owned());
        let k = COUNTER.fetch_add(1, Ordering::Relaxed);
        let tmp = path.with_file_name(format!(".{name}.tmp-{}-{k}", std::process::id()));
        let file = std::fs::File::create(&tmp)?;
        Ok(Self { path: path.to_path_buf(), tmp, file, committed: false })
    }

    /// The file being written (the temporary).
    pub fn file(&mut self) -> &mut std::fs::File {
        &mut self.file
    }

    /// Syncs the temporary and renames it over the target.
    pub fn commit(mut self) -> std::io::Result<()> {
        self.file.sync_all()?;
        std::fs::rename(&self.tmp, &self.path)?;
        self.committed = true;
        Ok(())
    }
}

impl std::io::Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.file.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Writes `bytes` to `path` through an [`AtomicFile`]: a temporary beside it, synced, then
/// renamed over `path`. On error the temporary is removed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut f = AtomicFile::create(path)?;
    f.file().write_all(bytes)?;
    f.commit()
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
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().flatten().map(|e| e.file_name()).collect();
        assert_eq!(left, vec![std::ffi::OsString::from("out.txt")], "no temporary left");
        // Dropped before the commit: nothing under the target's name, no temporary.
        let mut f = AtomicFile::create(&dir.join("half.txt")).unwrap();
        f.file().write_all(b"half").unwrap();
        drop(f);
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
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
