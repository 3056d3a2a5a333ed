//! How long a validation sweep will take: an estimate before it starts (from the costs measured
//! on the reference machine) and, as worlds finish, one from this run's own world times.
//!
//! A sweep is a list of jobs (preset × seed), each a chain of worlds run one after the other on
//! one thread, the jobs spread over the threads. The cost of a world differs by preset (a
//! `paper-strict` robot stands through thousands of Lost steps, simulated at full rate), by
//! localiser and by route, and it drifts along the chain as the map changes; a progress bar that
//! counts worlds and divides the time so far by them (the second release's, 13 minutes estimated
//! for a 72-minute run) is wrong on all three counts. This estimator:
//!
//! - prices each job's remaining worlds at its **own preset's recent world time** (the mean of
//!   the last [`RECENT`] worlds finished by that preset's jobs, so the drift is followed);
//! - prices a preset with no finished world yet at its prior ([`prior_world_s`]) times the ratio
//!   of measured to prior time of the presets already measured (this machine against the
//!   reference);
//! - and lays the remaining work out on the threads as the run does (the running jobs first,
//!   then the waiting ones in order on the first thread free), so a sweep of 6 jobs on 2 threads
//!   is 3 rounds, not 6 ÷ 2 of an average.
//!
//! It reads no clock: the caller passes the time (seconds since the run started).

use std::collections::VecDeque;

/// Worlds whose times make a preset's current world time.
pub const RECENT: usize = 10;

/// The seconds one world takes, one job per core on the reference machine (2 cores, both busy),
/// for `preset` with the `localiser` preset on a route of `route_m` metres; measured from the
/// hundred-world runs of `docs/benchmarks.md` (the default warehouse tour is 72 m). A prior: the
/// estimate replaces it with this run's own times as soon as worlds finish.
pub fn prior_world_s(preset: &str, localiser: &str, route_m: f64) -> f64 {
    // amcl, 72 m: the ratios of paper (10 seeds × 100 worlds in 2,727 s on 2 cores) and mapkeeper
    // (5 × 100 in 994 s), scaled to the default run after issue 29's first round (both, 3 seeds,
    // 600 worlds in 575 s on 2 cores: 1.9 s a world); paper-strict 15-24 min a seed before it
    // (about 12 s a world; not measured since).
    let amcl = match preset {
        "mapkeeper" | "mapkeeper-shift" => 2.3,
        "paper-strict" => 12.0,
        _ => 1.6,
    };
    let localiser_factor = match localiser {
        "mapkeeper" => LOCALISER_MAPKEEPER_FACTOR,
        _ => 1.0,
    };
    amcl * localiser_factor * (route_m / 72.0).max(0.05)
}

/// The `mapkeeper` localiser's world time against `amcl`'s (the same run otherwise).
const LOCALISER_MAPKEEPER_FACTOR: f64 = 0.6;

#[derive(Clone, Debug)]
struct Job {
    preset: usize,
    worlds: usize,
    done: usize,
    /// When its last world finished (seconds since the start).
    last_s: Option<f64>,
}

/// The estimator of one sweep (see the module docs).
#[derive(Clone, Debug)]
pub struct SweepEta {
    threads: usize,
    jobs: Vec<Job>,
    prior: Vec<f64>,
    /// Per preset: the durations of its recently finished worlds.
    recent: Vec<VecDeque<f64>>,
    /// Over all measured worlds: (measured seconds, prior seconds).
    measured: (f64, f64),
}

/// An estimate of the time left.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Seconds left.
    pub remaining_s: f64,
    /// Whether it rests on this run's own world times (else on the priors alone).
    pub measured: bool,
}

impl SweepEta {
    /// A sweep of `jobs` (preset index, worlds) on `threads` threads, with the prior world time
    /// of each preset index.
    pub fn new(jobs: &[(usize, usize)], prior: Vec<f64>, threads: usize) -> Self {
        let presets = prior.len();
        Self {
            threads: threads.max(1),
            jobs: jobs.iter().map(|&(preset, worlds)| Job { preset, worlds, done: 0, last_s: None }).collect(),
            prior,
            recent: vec![VecDeque::new(); presets],
            measured: (0.0, 0.0),
        }
    }

    /// Job `job` was read back from a checkpoint: nothing left to run.
    pub fn resumed(&mut self, job: usize) {
        if let Some(j) = self.jobs.get_mut(job) {
            j.done = j.worlds;
        }
    }

    /// World `world` of job `job` finished at `now_s`.
    pub fn world_done(&mut self, job: usize, world: usize, now_s: f64) {
        let Some(j) = self.jobs.get_mut(job) else { return };
        // A world's time is the time since the job's previous world; the first world of a job
        // (M_1 built, W_1 scored) has no start to measure from and is not a chain world.
        if let (Some(last), true) = (j.last_s, world >= 2)
            && let Some(recent) = self.recent.get_mut(j.preset)
        {
            let took = (now_s - last).max(0.0);
            if recent.len() == RECENT {
                recent.pop_front();
            }
            recent.push_back(took);
            self.measured.0 += took;
            self.measured.1 += self.prior.get(j.preset).copied().unwrap_or(0.0);
        }
        j.done = j.done.max(world);
        j.last_s = Some(now_s);
    }

    /// Seconds one world of preset `p` takes now: its recent times, else its prior scaled to
    /// this machine, else the prior.
    fn world_s(&self, p: usize) -> f64 {
        let prior = self.prior.get(p).copied().unwrap_or(0.0);
        match self.recent.get(p) {
            Some(r) if !r.is_empty() => r.iter().sum::<f64>() / r.len() as f64,
            _ if self.measured.1 > 0.0 => prior * self.measured.0 / self.measured.1,
            _ => prior,
        }
    }

    /// The time left at `now_s`.
    pub fn estimate(&self, now_s: f64) -> Estimate {
        // Threads free at: the running jobs' ends first, then `now_s` for the others.
        let mut free: Vec<f64> = Vec::with_capacity(self.threads);
        let mut waiting = Vec::new();
        for j in &self.jobs {
            let left = (j.worlds - j.done.min(j.worlds)) as f64 * self.world_s(j.preset);
            match j.last_s {
                _ if j.done >= j.worlds => {}
                Some(last) if free.len() < self.threads => {
                    free.push(now_s + (left - (now_s - last)).max(0.0));
                }
                _ => waiting.push(left),
            }
        }
        free.resize(self.threads.max(free.len()), now_s);
        for left in waiting {
            if let Some(t) = free.iter_mut().min_by(|a, b| a.total_cmp(b)) {
                *t += left;
            }
        }
        let end = free.iter().copied().fold(now_s, f64::max);
        Estimate { remaining_s: end - now_s, measured: self.measured.1 > 0.0 }
    }
}

/// A duration for people: `45 s`, `12 min`, `1 h 05 min`, `27 days 9 h`.
pub fn human_duration(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    match s {
        0..=89 => format!("{s} s"),
        90..=3599 => format!("{} min", (s + 30) / 60),
        3600..=172_799 => format!("{} h {:02} min", s / 3600, (s % 3600 + 30) / 60),
        _ => format!("{} days {} h", s / 86_400, (s % 86_400 + 1800) / 3600),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn before_any_world_the_priors_are_laid_out_on_the_threads() {
        // Two presets × three seeds of 100 worlds on 2 threads: 6 jobs, 3 rounds.
        let jobs: Vec<(usize, usize)> = (0..6).map(|k| (k / 3, 100)).collect();
        let eta = SweepEta::new(&jobs, vec![2.0, 4.0], 2);
        let e = eta.estimate(0.0);
        assert!(!e.measured);
        // Jobs in order on the first free thread: [200, 200] → [400, 200] → [400, 600] →
        // [800, 600] → [800, 1000]: the last ends at 1000 s.
        assert_eq!(e.remaining_s, 1000.0);
        // One thread: the sum.
        assert_eq!(SweepEta::new(&jobs, vec![2.0, 4.0], 1).estimate(0.0).remaining_s, 1800.0);
    }

    #[test]
    fn measured_times_replace_the_priors_and_scale_the_unmeasured_presets() {
        // Preset 0 runs at 3 s a world, not its prior 1 s; preset 1 has no world yet.
        let jobs = [(0, 10), (1, 10)];
        let mut eta = SweepEta::new(&jobs, vec![1.0, 2.0], 1);
        for w in 1..=4 {
            eta.world_done(0, w, 3.0 * w as f64);
        }
        let e = eta.estimate(12.0);
        assert!(e.measured);
        // Job 0: 6 worlds × 3 s; job 1: 10 × (2 s × 3/1) on the same thread after it.
        assert!((e.remaining_s - (18.0 + 60.0)).abs() < 1e-9, "{e:?}");
        // Time spent in the current world counts against it.
        let later = eta.estimate(14.0);
        assert!((later.remaining_s - (16.0 + 60.0)).abs() < 1e-9, "{later:?}");
    }

    #[test]
    fn a_drift_along_the_chain_is_followed() {
        // Worlds get slower: 1 s each for 20 worlds, then 5 s each.
        let mut eta = SweepEta::new(&[(0, 100)], vec![1.0], 1);
        let mut t = 0.0;
        for w in 1..=40 {
            t += if w <= 20 { 1.0 } else { 5.0 };
            eta.world_done(0, w, t);
        }
        // The last ten worlds took 5 s each: 60 left × 5 s (a mean over all would say 3 s).
        assert!((eta.estimate(t).remaining_s - 300.0).abs() < 1e-9);
    }

    #[test]
    fn resumed_and_finished_jobs_cost_nothing() {
        let mut eta = SweepEta::new(&[(0, 5), (0, 5)], vec![1.0], 2);
        eta.resumed(0);
        assert_eq!(eta.estimate(0.0).remaining_s, 5.0);
        for w in 1..=5 {
            eta.world_done(1, w, w as f64);
        }
        assert_eq!(eta.estimate(5.0).remaining_s, 0.0);
        // Out-of-range jobs are ignored.
        eta.world_done(7, 1, 1.0);
    }

    #[test]
    fn priors_follow_preset_localiser_and_route() {
        assert!(prior_world_s("paper-strict", "amcl", 72.0) > prior_world_s("paper", "amcl", 72.0));
        assert!(prior_world_s("paper", "mapkeeper", 72.0) < prior_world_s("paper", "amcl", 72.0));
        assert!((prior_world_s("paper", "amcl", 36.0) * 2.0 - prior_world_s("paper", "amcl", 72.0)).abs() < 1e-12);
        assert_eq!(human_duration(42.4), "42 s");
        assert_eq!(human_duration(600.0), "10 min");
        assert_eq!(human_duration(4320.0), "1 h 12 min");
        assert_eq!(human_duration(657.3 * 3600.0), "27 days 9 h");
    }
}
