//! Atomic outputs: every file the project writes goes through [`write_atomic`], and every
//! result folder through [`StagedDir`] (written in a hidden staging folder beside the target,
//! renamed into place at the end; an existing non-empty folder is refused unless replacing it
//! is asked for), so an interrupted run never leaves a file or folder that looks complete.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// An output could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OutputError {
    /// The output folder (or file) exists and is not empty, and replacing it was not asked for.
    #[error("{0}: exists and is not empty (use --force to replace it)")]
    Exists(PathBuf),
    /// The output is an existing file where a folder is to be written.
    #[error("{0}: exists and is not a folder")]
    NotAFolder(PathBuf),
    /// Another running process is writing this output folder.
    #[error("{}: another run{} is writing this folder (it holds the lock {}); wait for it to end", target.display(), pid.map(|p| format!(" (pid {p})")).unwrap_or_default(), lock.display())]
    InUse {
        /// The output folder.
        target: PathBuf,
        /// Its lock file.
        lock: PathBuf,
        /// The writer's process id, when readable.
        pid: Option<u32>,
    },
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

/// A result folder being written: files go to a hidden staging folder beside the target,
/// `.NAME.partial`, which [`StagedDir::finish`] renames into place; so a killed run never leaves
/// a folder under the target's name that looks complete.
///
/// A lock file beside it, `.NAME.partial.lock`, holds an exclusive advisory lock
/// ([`std::fs::File::try_lock`]: `flock` on Unix) for as long as the folder is being written, and
/// the writer's process id as text (for messages). The operating system releases the lock when
/// the writer ends, however it ends, so a lock that can be taken belongs to no running writer. A
/// second run into a folder being written is an error ([`OutputError::InUse`]); a staging folder
/// or lock left by a run that no longer runs is removed and reported ([`StagedDir::leftover`]).
/// Dropped without [`StagedDir::finish`] (an error or a panic), the staging folder and the lock
/// are removed.
///
/// [`StagedDir::sub`] gives a folder inside this one (a sweep's per-preset folders), moved into
/// place with it.
#[derive(Debug)]
pub struct StagedDir {
    target: PathBuf,
    staging: PathBuf,
    /// The lock file and its open handle holding the lock; `None` for a folder inside another
    /// staged folder.
    lock: Option<(PathBuf, std::fs::File)>,
    force: bool,
    finished: bool,
    leftover: Option<Leftover>,
}

/// What an interrupted earlier run left behind, found and removed by [`StagedDir::create`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Leftover {
    /// The staging folder (it may be gone already when only the lock was left).
    pub staging: PathBuf,
    /// Whether the staging folder was there (otherwise only its lock file was).
    pub folder: bool,
    /// Files that were in it.
    pub files: usize,
    /// The process id of the run that left it, when its lock file was readable.
    pub pid: Option<u32>,
}

impl std::fmt::Display for Leftover {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let who =
            self.pid.map_or_else(|| "an interrupted run".to_string(), |p| format!("an interrupted run (pid {p})"));
        if !self.folder {
            write!(f, "{}.lock: removed the lock file {who} left", self.staging.display())
        } else if self.files == 0 {
            write!(f, "{}: removed the incomplete folder {who} left (no file in it yet)", self.staging.display())
        } else {
            write!(f, "{}: removed the incomplete folder {who} left ({} files)", self.staging.display(), self.files)
        }
    }
}

fn is_empty_dir(p: &Path) -> bool {
    std::fs::read_dir(p).map(|mut d| d.next().is_none()).unwrap_or(false)
}

fn count_files(p: &Path) -> usize {
    let Ok(entries) = std::fs::read_dir(p) else { return 0 };
    entries
        .flatten()
        .map(|e| match e.file_type() {
            Ok(t) if t.is_dir() => count_files(&e.path()),
            Ok(_) => 1,
            Err(_) => 0,
        })
        .sum()
}

/// Whether `file` (an open handle) is still the file at `path` (not removed or replaced since
/// it was opened). Without a way to tell (not Unix), taken to be.
fn same_file(file: &std::fs::File, path: &Path) -> std::io::Result<bool> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt as _;
        let (open, named) = (file.metadata()?, std::fs::metadata(path));
        Ok(named.is_ok_and(|n| n.dev() == open.dev() && n.ino() == open.ino()))
    }
    #[cfg(not(unix))]
    {
        let _ = (file, path);
        Ok(true)
    }
}

/// Takes the lock `lock` (creating the file): `Ok(Some((handle, previous text)))` once held,
/// `Ok(None)` if another process holds it. A lock file removed or replaced between opening and
/// locking it (by a writer finishing) is opened again.
fn take_lock(lock: &Path) -> std::io::Result<Option<(std::fs::File, String)>> {
    use std::io::{Read as _, Seek as _};
    loop {
        let mut f = std::fs::OpenOptions::new().read(true).write(true).create(true).truncate(false).open(lock)?;
        match f.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => return Ok(None),
            Err(std::fs::TryLockError::Error(e)) => return Err(e),
        }
        if !same_file(&f, lock)? {
            continue;
        }
        let mut previous = String::new();
        // A lock file holding something else than text is still a leftover.
        let _ = f.read_to_string(&mut previous);
        f.set_len(0)?;
        f.rewind()?;
        f.write_all(format!("{}\n", std::process::id()).as_bytes())?;
        f.sync_all()?;
        return Ok(Some((f, previous)));
    }
}

/// `.NAME.SUFFIX` beside `target` (`NAME` its last component, `out` if it has none; beside it
/// in `.` if it has no parent): where a run keeps what belongs to its output folder without
/// being part of it (the staging folder, its lock, `validate`'s job checkpoints).
pub fn hidden_sibling(target: &Path, suffix: &str) -> PathBuf {
    let name = target.file_name().map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
    let parent = match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    parent.join(format!(".{name}.{suffix}"))
}

impl StagedDir {
    /// Starts writing `target`. Fails if `target` exists, is not an empty folder and `force` is
    /// false, or if another running process is writing it. Removes what an interrupted run left
    /// (see [`StagedDir::leftover`]).
    pub fn create(target: &Path, force: bool) -> Result<StagedDir, OutputError> {
        if target.exists() && !force && !is_empty_dir(target) {
            return Err(OutputError::Exists(target.to_path_buf()));
        }
        if target.is_file() {
            return Err(OutputError::NotAFolder(target.to_path_buf()));
        }
        let staging = hidden_sibling(target, "partial");
        let lock = hidden_sibling(target, "partial.lock");
        let parent = staging.parent().map_or_else(|| PathBuf::from("."), Path::to_path_buf);
        std::fs::create_dir_all(&parent).map_err(OutputError::io(&parent))?;
        let Some((handle, previous)) = take_lock(&lock).map_err(OutputError::io(&lock))? else {
            let pid = std::fs::read_to_string(&lock).ok().and_then(|t| t.trim().parse().ok());
            return Err(OutputError::InUse { target: target.to_path_buf(), lock, pid });
        };
        // A lock file that existed and could be taken, or a staging folder: a run's leftovers.
        let pid = previous.trim().parse().ok();
        let mut leftover =
            (!previous.is_empty()).then(|| Leftover { staging: staging.clone(), folder: false, files: 0, pid });
        if staging.exists() {
            let files = count_files(&staging);
            leftover = Some(Leftover { staging: staging.clone(), folder: true, files, pid });
            if let Err(e) = std::fs::remove_dir_all(&staging) {
                let _ = std::fs::remove_file(&lock);
                return Err(OutputError::Io { path: staging, source: e });
            }
        }
        let dir = StagedDir {
            target: target.to_path_buf(),
            staging,
            lock: Some((lock, handle)),
            force,
            finished: false,
            leftover,
        };
        std::fs::create_dir_all(&dir.staging).map_err(OutputError::io(&dir.staging))?;
        Ok(dir)
    }

    /// What an interrupted earlier run had left in this place, now removed (for the caller to
    /// report).
    pub fn leftover(&self) -> Option<&Leftover> {
        self.leftover.as_ref()
    }

    /// A folder `name` inside this one, written in its staging folder and moved into place with
    /// it; its [`StagedDir::finish`] only returns where it will be.
    pub fn sub(&self, name: &str) -> Result<StagedDir, OutputError> {
        let staging = self.staging.join(name);
        if staging.exists() {
            return Err(OutputError::Exists(self.target.join(name)));
        }
        std::fs::create_dir_all(&staging).map_err(OutputError::io(&staging))?;
        Ok(StagedDir {
            target: self.target.join(name),
            staging,
            lock: None,
            force: self.force,
            finished: false,
            leftover: None,
        })
    }

    /// Where files go while writing.
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// Where the folder will be once finished.
    pub fn target(&self) -> &Path {
        &self.target
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

    /// Moves the finished folder into place (replacing an existing one only if allowed) and
    /// releases the lock. For a folder made by [`StagedDir::sub`], only returns where it will be
    /// once its parent is finished.
    pub fn finish(mut self) -> Result<PathBuf, OutputError> {
        self.finished = true;
        let Some(lock) = self.lock.as_ref().map(|(p, _)| p.clone()) else { return Ok(self.target.clone()) };
        if self.target.exists() {
            if !self.force && !is_empty_dir(&self.target) {
                self.finished = false;
                return Err(OutputError::Exists(self.target.clone()));
            }
            if let Err(e) = std::fs::remove_dir_all(&self.target) {
                self.finished = false;
                return Err(OutputError::Io { path: self.target.clone(), source: e });
            }
        }
        if let Err(e) = std::fs::rename(&self.staging, &self.target) {
            self.finished = false;
            return Err(OutputError::Io { path: self.target.clone(), source: e });
        }
        // Removed while still held, so a run waiting on it opens a new one (see `take_lock`).
        std::fs::remove_file(&lock).map_err(OutputError::io(&lock))?;
        Ok(self.target.clone())
    }
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        if self.finished {
            return;
        }
        if let Some((lock, _)) = &self.lock {
            let _ = std::fs::remove_dir_all(&self.staging);
            let _ = std::fs::remove_file(lock);
        }
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

#[cfg(test)]
mod leftover_tests {
    use super::*;

    fn base(tag: &str) -> PathBuf {
        let b = std::env::temp_dir().join(format!("mapkeeper-leftover-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&b);
        std::fs::create_dir_all(&b).unwrap();
        b
    }

    #[test]
    fn a_killed_runs_folder_is_reported_and_removed() {
        let b = base("killed");
        let target = b.join("out");
        // What a run killed mid-way leaves: the staging folder with some files, and its lock
        // file (no longer held) naming the process.
        std::fs::create_dir_all(b.join(".out.partial/seed-1")).unwrap();
        std::fs::write(b.join(".out.partial/seed-1/a.csv"), "x").unwrap();
        std::fs::write(b.join(".out.partial/runs.json"), "{").unwrap();
        std::fs::write(b.join(".out.partial.lock"), "2147483000\n").unwrap();
        let s = StagedDir::create(&target, false).unwrap();
        let left = s.leftover().expect("the leftover is reported").clone();
        assert_eq!(left, Leftover { staging: b.join(".out.partial"), folder: true, files: 2, pid: Some(2147483000) });
        assert!(left.to_string().contains("pid 2147483000") && left.to_string().contains("2 files"), "{left}");
        assert!(!s.path().join("runs.json").exists(), "the old files are gone");
        s.write("summary.json", b"{}").unwrap();
        s.finish().unwrap();
        let names: Vec<_> = std::fs::read_dir(&b).unwrap().flatten().map(|e| e.file_name()).collect();
        assert_eq!(names, vec![std::ffi::OsString::from("out")], "no staging folder or lock left");
        // A lock alone (killed between the rename and the lock's removal) is reported too.
        std::fs::write(b.join(".again.partial.lock"), "2147483000\n").unwrap();
        let s = StagedDir::create(&b.join("again"), false).unwrap();
        assert_eq!(s.leftover().map(|l| (l.folder, l.files)), Some((false, 0)));
        assert!(s.leftover().unwrap().to_string().contains("removed the lock file"));
        drop(s);
        let _ = std::fs::remove_dir_all(&b);
    }

    #[test]
    fn a_folder_being_written_by_a_running_process_is_refused() {
        let b = base("inuse");
        let target = b.join("out");
        let first = StagedDir::create(&target, false).unwrap();
        first.write("a.txt", b"1").unwrap();
        match StagedDir::create(&target, true) {
            Err(OutputError::InUse { pid, .. }) => assert_eq!(pid, Some(std::process::id())),
            other => panic!("expected InUse, got {other:?}"),
        }
        assert!(first.path().join("a.txt").exists(), "the writer's files are untouched");
        first.finish().unwrap();
        assert!(target.join("a.txt").exists());
        let _ = std::fs::remove_dir_all(&b);
    }

    #[test]
    fn an_unfinished_folder_is_removed_when_dropped_and_sub_folders_move_with_their_parent() {
        let b = base("drop");
        let target = b.join("out");
        let s = StagedDir::create(&target, false).unwrap();
        s.write("half.txt", b"1").unwrap();
        drop(s);
        assert_eq!(std::fs::read_dir(&b).unwrap().count(), 0, "no staging folder, no lock");
        let s = StagedDir::create(&target, false).unwrap();
        assert!(s.leftover().is_none());
        let sub = s.sub("paper").unwrap();
        sub.write("runs.json", b"[]").unwrap();
        assert!(matches!(s.sub("paper"), Err(OutputError::Exists(_))));
        assert_eq!(sub.finish().unwrap(), target.join("paper"));
        assert!(!target.exists(), "a sub-folder's finish moves nothing");
        s.write("summary.json", b"{}").unwrap();
        s.finish().unwrap();
        assert!(target.join("paper/runs.json").is_file() && target.join("summary.json").is_file());
        assert!(matches!(StagedDir::create(&target.join("summary.json"), true), Err(OutputError::NotAFolder(_))));
        let _ = std::fs::remove_dir_all(&b);
    }

    #[test]
    fn a_lock_file_nobody_holds_is_a_leftover_whatever_it_holds() {
        let b = base("garbage");
        std::fs::write(b.join(".out.partial.lock"), "garbage").unwrap();
        let s = StagedDir::create(&b.join("out"), false).unwrap();
        assert_eq!(s.leftover().map(|l| (l.folder, l.pid)), Some((false, None)));
        assert_eq!(std::fs::read_to_string(b.join(".out.partial.lock")).unwrap(), format!("{}\n", std::process::id()));
        s.finish().unwrap();
        assert!(!b.join(".out.partial.lock").exists());
        let _ = std::fs::remove_dir_all(&b);
    }
}
