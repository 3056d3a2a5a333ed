//! The progress of a validation sweep: a bar on a terminal, and lines anywhere, with an estimate
//! of the time left that follows this run's own world times per preset
//! ([`mapkeeper_scenario::experiments::validation::eta`]). The wall clock is read here, not in the library.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use mapkeeper_scenario::SweepPlan;
use mapkeeper_scenario::experiments::validation::eta::{Estimate, SweepEta, human_duration, prior_world_s};
use std::io::IsTerminal as _;
use std::sync::Mutex;
use std::time::Instant;

/// The estimator, the bar and when the last line was printed.
pub struct SweepProgress {
    eta: Mutex<State>,
    bar: ProgressBar,
    start: Instant,
    total: u64,
    resumed: Vec<bool>,
}

struct State {
    eta: SweepEta,
    done: u64,
    /// The next share of the worlds (in tenths) at which a line is printed.
    next_tenth: u64,
    first_line: bool,
}

impl SweepProgress {
    /// The progress of `plan` on `threads` threads with the `localiser` preset; `resumed[k]`:
    /// job k was read back from a checkpoint.
    pub fn new(plan: &SweepPlan, localiser: &str, threads: usize, resumed: Vec<bool>) -> Self {
        let prior: Vec<f64> = plan
            .presets
            .iter()
            .zip(&plan.params)
            .map(|(name, p)| prior_world_s(name, localiser, p.route.length_m()))
            .collect();
        let jobs: Vec<(usize, usize)> = plan.jobs.iter().map(|&(p, _)| (p, plan.params[p].worlds)).collect();
        let mut eta = SweepEta::new(&jobs, prior, threads);
        for (k, _) in resumed.iter().enumerate().filter(|(_, r)| **r) {
            eta.resumed(k);
        }
        let total = plan.total_worlds();
        let bar = ProgressBar::new(total);
        if std::io::stderr().is_terminal() {
            bar.set_style(
                ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} worlds, {msg}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
        } else {
            bar.set_draw_target(ProgressDrawTarget::hidden());
        }
        let progress = Self {
            eta: Mutex::new(State { eta, done: 0, next_tenth: 1, first_line: true }),
            bar,
            start: Instant::now(),
            total,
            resumed,
        };
        let first = progress.estimate();
        progress.bar.set_message(describe(first));
        progress
    }

    /// The estimate now.
    pub fn estimate(&self) -> Estimate {
        let now = self.start.elapsed().as_secs_f64();
        match self.eta.lock() {
            Ok(s) => s.eta.estimate(now),
            Err(p) => p.into_inner().eta.estimate(now),
        }
    }

    /// World `world` of job `job` finished.
    pub fn world_done(&self, job: usize, world: usize) {
        self.bar.inc(1);
        let now = self.start.elapsed().as_secs_f64();
        let mut s = match self.eta.lock() {
            Ok(s) => s,
            Err(p) => p.into_inner(),
        };
        s.done += 1;
        if !self.resumed.get(job).copied().unwrap_or(false) {
            s.eta.world_done(job, world, now);
        }
        let e = s.eta.estimate(now);
        self.bar.set_message(describe(e));
        // A line at the first estimate from measured worlds, then at each tenth of the worlds
        // (the bar is hidden off a terminal: CI logs get the lines).
        let tenth_reached = s.done * 10 >= s.next_tenth * self.total;
        if (e.measured && s.first_line) || (tenth_reached && s.done < self.total) {
            if e.measured {
                s.first_line = false;
            }
            while s.done * 10 >= s.next_tenth * self.total {
                s.next_tenth += 1;
            }
            let line =
                format!("validate: {}/{} worlds after {}; {}", s.done, self.total, human_duration(now), describe(e));
            self.bar.suspend(|| errln!("{line}"));
        }
    }

    /// Removes the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

/// `about 12 min left (from this run's world times)`.
pub fn describe(e: Estimate) -> String {
    format!(
        "about {} left ({})",
        human_duration(e.remaining_s),
        if e.measured { "from this run's world times" } else { "from the reference machine's costs" }
    )
}
