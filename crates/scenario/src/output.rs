//! Writing result folders: atomically (everything goes to a hidden staging folder beside the
//! target, which is renamed into place at the end), refusing an existing non-empty folder
//! unless asked to replace it.

use crate::ScenarioError;
use mapkeeper_grid::map_io::write_atomic;
use std::path::{Path, PathBuf};

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
    pub fn create(target: &Path, force: bool) -> Result<StagedDir, ScenarioError> {
        if target.exists() && !force && !is_empty_dir(target) {
            return Err(ScenarioError::OutputExists(target.to_path_buf()));
        }
        let name = target.file_name().map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
        let parent = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        std::fs::create_dir_all(&parent).map_err(ScenarioError::io(&parent))?;
        let staging = parent.join(format!(".{name}.partial"));
        if staging.exists() {
            std::fs::remove_dir_all(&staging).map_err(ScenarioError::io(&staging))?;
        }
        std::fs::create_dir_all(&staging).map_err(ScenarioError::io(&staging))?;
        Ok(StagedDir { target: target.to_path_buf(), staging, force })
    }

    /// Where files go while writing.
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// A path inside the staging folder, its parent folders created.
    pub fn file(&self, rel: &str) -> Result<PathBuf, ScenarioError> {
        let p = self.staging.join(rel);
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent).map_err(ScenarioError::io(parent))?;
        }
        Ok(p)
    }

    /// Writes `bytes` to `rel` inside the folder.
    pub fn write(&self, rel: &str, bytes: &[u8]) -> Result<(), ScenarioError> {
        let p = self.file(rel)?;
        write_atomic(&p, bytes)?;
        Ok(())
    }

    /// Moves the finished folder into place (replacing an existing one only if allowed).
    pub fn finish(self) -> Result<PathBuf, ScenarioError> {
        if self.target.exists() {
            if !self.force && !is_empty_dir(&self.target) {
                return Err(ScenarioError::OutputExists(self.target.clone()));
            }
            std::fs::remove_dir_all(&self.target).map_err(ScenarioError::io(&self.target))?;
        }
        std::fs::rename(&self.staging, &self.target).map_err(ScenarioError::io(&self.target))?;
        Ok(self.target)
    }
}

#[cfg(test)]
mod tests {
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
        assert!(matches!(StagedDir::create(&target, false), Err(ScenarioError::OutputExists(_))));
        let s = StagedDir::create(&target, true).unwrap();
        s.write("c.txt", b"two").unwrap();
        s.finish().unwrap();
        assert!(!target.join("a/b.txt").exists());
        assert_eq!(std::fs::read(target.join("c.txt")).unwrap(), b"two");
        std::fs::remove_dir_all(&base).unwrap();
    }
}
