//! The one trial runner of the experiments.
//!
//! Every experiment has the same skeleton: draw its jobs (trials × presets × conditions, seeds
//! × configurations, …) from its parameters and seed, run each job on its own, then summarise
//! the outcomes. An experiment says what its jobs are, how one runs and how the outcomes are
//! summarised ([`Trials`]); [`run_trials`] does the rest the same way for all of them: the jobs
//! on the caller's rayon pool (`--jobs`), the outcomes collected in job order, so the result is
//! the same whatever the thread count. A job's seed is part of the job: nothing in the runner
//! draws a random number.
//!
//! **One way.** Every experiment family runs its trials as a [`Trials`] through [`run_trials`]:
//! the validation's (preset, seed) chains and its sensor-realism sweep, the recovery suite's
//! Table 1, lost-robot and kidnap runs, check detection, Table 1 with a held pose, kidnaps of the
//! robot, the real logs and the localisers' convergence. A trial's drive is set up one way too
//! ([`crate::setup::Setup::drive`]). [`run_each`] is what [`run_trials`] runs on; an experiment
//! calls it directly only for work that is not a trial (Table 1 with a held pose sets up one
//! chain of worlds per draw before its trials).

use crate::ExperimentError;
use rayon::prelude::*;

/// One experiment's trials: draw, run one, summarise.
pub trait Trials: Sync {
    /// What one run needs beyond the experiment's own state (its draw, its preset, its seed).
    type Job: Send;
    /// What one run gives.
    type Outcome: Send;
    /// What the experiment reports.
    type Summary;

    /// Every job, in the order the outcomes are summarised.
    fn draw(&self) -> Vec<Self::Job>;

    /// Runs one job; calls `progress` after each unit of work it reports (a finished run; for
    /// the validation, a finished world). Runs may be on any thread, in any order.
    fn run(&self, job: Self::Job, progress: &(dyn Fn() + Sync)) -> Result<Self::Outcome, ExperimentError>;

    /// The report of every outcome, given in the order of [`Trials::draw`].
    fn summarise(&self, outcomes: Vec<Self::Outcome>) -> Result<Self::Summary, ExperimentError>;
}

/// Draws the jobs, runs them on the caller's rayon pool and summarises the outcomes, collected
/// in job order ([`run_each`]).
pub fn run_trials<T: Trials>(trials: &T, progress: &(dyn Fn() + Sync)) -> Result<T::Summary, ExperimentError> {
    let outcomes = run_each(trials.draw(), |job| trials.run(job, progress))?;
    trials.summarise(outcomes)
}

/// The runner itself: `run` on every job on the caller's rayon pool, the outcomes in the order
/// of `jobs`. The first error met stops the collection (which one, when several jobs fail, may
/// depend on the thread count; the outputs never do). Only for work that is not a trial (the
/// worlds set up before the trials): trials go through [`run_trials`].
pub fn run_each<J: Send, O: Send>(
    jobs: Vec<J>,
    run: impl Fn(J) -> Result<O, ExperimentError> + Sync + Send,
) -> Result<Vec<O>, ExperimentError> {
    jobs.into_par_iter().map(run).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// Squares of 0..n, the odd ones slowed down so that threads finish out of order.
    struct Squares {
        n: u64,
        fail_at: Option<u64>,
    }

    impl Trials for Squares {
        type Job = u64;
        type Outcome = u64;
        type Summary = (Vec<u64>, u64);

        fn draw(&self) -> Vec<u64> {
            (0..self.n).collect()
        }

        fn run(&self, job: u64, progress: &(dyn Fn() + Sync)) -> Result<u64, ExperimentError> {
            if Some(job) == self.fail_at {
                return Err(ExperimentError::Invalid(format!("job {job} failed")));
            }
            if job % 2 == 1 {
                std::thread::sleep(std::time::Duration::from_millis(2));
            }
            progress();
            Ok(job * job)
        }

        fn summarise(&self, outcomes: Vec<u64>) -> Result<(Vec<u64>, u64), ExperimentError> {
            let sum = outcomes.iter().sum();
            Ok((outcomes, sum))
        }
    }

    fn on_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap_or_else(|e| panic!("{e}"));
        pool.install(f)
    }

    #[test]
    fn outcomes_come_back_in_job_order_whatever_the_thread_count() {
        let t = Squares { n: 40, fail_at: None };
        let expected: Vec<u64> = (0..40).map(|k| k * k).collect();
        for threads in [1, 2, 4] {
            let done = AtomicUsize::new(0);
            let tick = || {
                done.fetch_add(1, Ordering::Relaxed);
            };
            let (outs, sum) = on_threads(threads, || run_trials(&t, &tick)).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(outs, expected, "{threads} threads");
            assert_eq!(sum, expected.iter().sum::<u64>());
            assert_eq!(done.load(Ordering::Relaxed), 40, "one progress call per job");
        }
    }

    #[test]
    fn a_failing_job_fails_the_run_with_its_error() {
        let t = Squares { n: 10, fail_at: Some(7) };
        let err = on_threads(2, || run_trials(&t, &|| {})).err().map(|e| e.to_string());
        assert_eq!(err.as_deref(), Some("job 7 failed"));
    }

    #[test]
    fn jobs_given_directly_come_back_in_their_order() {
        let t = Squares { n: 10, fail_at: None };
        let outs = on_threads(2, || run_each(vec![9, 2, 5], |j| t.run(j, &|| {}))).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(outs, vec![81, 4, 25]);
    }
}
