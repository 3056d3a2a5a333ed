//! One module per subcommand: its arguments and the glue that calls the libraries.

pub mod generate;
pub mod localise;
pub mod map;
pub mod merge;
pub mod metrics;
pub mod recover;
pub mod render;
pub mod run;
pub mod simulate;
pub mod update;
pub mod validate;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::time::Instant;

/// The wall clock the libraries get injected (they read none themselves).
pub struct Wall(pub Instant);

impl Wall {
    /// A clock starting now.
    pub fn start() -> Self {
        Wall(Instant::now())
    }
}

impl mapkeeper_scenario::Clock for Wall {
    fn now_ns(&self) -> u64 {
        u64::try_from(self.0.elapsed().as_nanos()).unwrap_or(u64::MAX).max(1)
    }
}

/// A progress bar of `len` `unit`s on a terminal's stderr, hidden otherwise.
pub fn progress_bar(len: u64, unit: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    if std::io::stderr().is_terminal() {
        bar.set_style(
            ProgressStyle::with_template(&format!(
                "{{elapsed_precise}} [{{bar:40}}] {{pos}}/{{len}} {unit}, eta {{eta}}"
            ))
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
    } else {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    bar
}

/// A rayon pool of `jobs` threads (default: all cores).
pub fn thread_pool(jobs: Option<usize>) -> anyhow::Result<rayon::ThreadPool> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(j) = jobs {
        builder = builder.num_threads(j.max(1));
    }
    builder.build().context("thread pool")
}
