//! The progress of a long command on stderr.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::path::Path;

/// The progress of a long command: a bar on a terminal, and on any stderr (CI logs too) a line
/// at the first unit done and at each tenth, with the time left at this run's own rate so far
/// (its units are alike: trials, runs, drives; `validate`, whose worlds are not, has its own,
/// `sweep_progress`).
pub struct Progress {
    bar: ProgressBar,
    what: String,
    unit: String,
    total: u64,
    start: std::time::Instant,
    /// Units done, and the next tenth at which a line is printed.
    state: std::sync::Mutex<(u64, u64)>,
}

impl Progress {
    /// One unit done.
    pub fn inc(&self, n: u64) {
        self.bar.inc(n);
        let mut s = match self.state.lock() {
            Ok(s) => s,
            Err(p) => p.into_inner(),
        };
        let first = s.0 == 0;
        s.0 += n;
        let (done, total) = (s.0, self.total.max(1));
        if (first || done * 10 >= s.1 * total) && done < total {
            while done * 10 >= s.1 * total {
                s.1 += 1;
            }
            let elapsed = self.start.elapsed().as_secs_f64();
            let left = elapsed / done as f64 * (total - done) as f64;
            let line = format!(
                "{}: {done}/{total} {} after {}; about {} left (at this run's rate so far)",
                self.what,
                self.unit,
                mapkeeper_scenario::experiments::validation::eta::human_duration(elapsed),
                mapkeeper_scenario::experiments::validation::eta::human_duration(left)
            );
            self.bar.suspend(|| errln!("{line}"));
        }
    }

    /// Removes the bar.
    pub fn finish_and_clear(&self) {
        self.bar.finish_and_clear();
    }
}

/// The progress of `what` (the command's name) over `len` `unit`s, writing `out` (see
/// [`Progress`]); prints first what it runs and where it writes.
pub fn progress_bar(what: &str, len: u64, unit: &str, out: &Path) -> Progress {
    errln!(
        "{what}: {len} {unit} to run, on {} thread(s); writing {}; Ctrl-C stops it as a kill does (nothing left that looks complete)",
        rayon::current_num_threads(),
        out.display()
    );
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
    Progress {
        bar,
        what: what.to_string(),
        unit: unit.to_string(),
        total: len,
        start: std::time::Instant::now(),
        state: std::sync::Mutex::new((0, 1)),
    }
}
