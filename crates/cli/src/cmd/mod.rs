//! One module per subcommand: its arguments and the glue that calls the libraries.

pub mod bench;
pub mod check;
pub mod converge;
pub mod convert;
pub mod experiment;
pub mod generate;
pub mod import_map;
pub mod localise;
pub mod log_input;
pub mod map;
pub mod merge;
pub mod metrics;
pub mod node;
pub mod poses;
mod progress;
pub mod real_data;
pub mod realism;
pub mod recover;
pub mod render;
pub mod run;
pub mod sensor;
pub mod shared_args;
pub mod simulate;
mod site;
pub mod sweep_progress;
pub mod update;
pub mod validate;
mod values;

pub use progress::progress_bar;
pub use site::{load_route, load_site};
pub use values::*;

use anyhow::Context;
use mapkeeper_grid::StagedDir;
use std::path::Path;
use std::time::Instant;

/// Every parameter file of every command: `base` (a preset or the defaults), overridden key by
/// key by the TOML file if one is given, then validated once.
pub fn load_params<T, E>(base: T, file: Option<&Path>, validate: impl FnOnce(&T) -> Result<(), E>) -> anyhow::Result<T>
where
    T: serde::Serialize + serde::de::DeserializeOwned,
    E: std::fmt::Display,
{
    Ok(mapkeeper_harness::config::load_params(base, file, validate)?)
}

/// Starts writing the output folder `out` (a hidden staging folder renamed into place at the
/// end, see [`StagedDir`]), saying on stderr what an interrupted earlier run had left there and
/// was removed.
pub fn output_dir(out: &Path, force: bool) -> anyhow::Result<StagedDir> {
    let dir = StagedDir::create(out, force)?;
    if let Some(left) = dir.leftover() {
        errln!("mapkeeper: note: {left}");
    }
    Ok(dir)
}

/// The default output folder of a command: `results/<stem>-NNN` with the first three-digit
/// counter from 001 whose folder does not exist yet.
pub fn numbered_out(stem: &str) -> std::path::PathBuf {
    (1..)
        .map(|k| std::path::PathBuf::from(format!("results/{stem}-{k:03}")))
        .find(|p| !p.exists())
        .unwrap_or_else(|| std::path::PathBuf::from(format!("results/{stem}")))
}

/// The wall clock the libraries get injected (they read none themselves).
pub struct Wall(pub Instant);

impl Wall {
    /// A clock starting now.
    pub fn start() -> Self {
        Wall(Instant::now())
    }
}

impl mapkeeper_harness::Clock for Wall {
    fn now_ns(&self) -> u64 {
        u64::try_from(self.0.elapsed().as_nanos()).unwrap_or(u64::MAX).max(1)
    }
}

/// A rayon pool of `jobs` threads (default: all cores; `--jobs` is bounded by [`jobs`]).
pub fn thread_pool(jobs: Option<usize>) -> anyhow::Result<rayon::ThreadPool> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(j) = jobs {
        builder = builder.num_threads(j.max(1));
    }
    builder.build().context("thread pool")
}
