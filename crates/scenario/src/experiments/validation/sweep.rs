//! A sweep of the validation over (preset × seed) jobs, preset by preset, optionally one
//! shard of it: the plan (checked before anything runs), the runs (in parallel on the
//! caller's rayon pool, collected in job order), and the runs of one preset.

use crate::experiments::ExperimentError;
use crate::experiments::validation::checkpoint::Checkpoints;
use crate::experiments::validation::{SeedRun, Shard, ValidationParams, ValidationRun, run_seed};
use mapkeeper_closed_loop::runner::{Clock, Execution, NoClock, RunOptions};
use mapkeeper_closed_loop::trials::{Trials, run_trials};
use mapkeeper_common::ParamError;
use mapkeeper_sim::World;
use std::path::PathBuf;

/// What to sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepSpec {
    /// Updater presets, in order (one or more, no repeats).
    pub presets: Vec<String>,
    /// Worlds N per seed.
    pub worlds: usize,
    /// First seed.
    pub first_seed: u64,
    /// Number of seeds (≥ 1).
    pub seeds: u64,
    /// Drive only the first this-many metres of the route.
    pub route_length_m: Option<f64>,
    /// Run only this shard of the job list.
    pub shard: Option<Shard>,
    /// Localiser preset of both localisers (`mapkeeper_localiser::LOCALISER_PRESETS`).
    pub localiser: String,
    /// The ground truth of the map metrics.
    pub ground_truth: crate::GroundTruth,
    /// The world W_1 (its name in the outputs and its resolved scenario); `None`: the embedded
    /// default warehouse.
    pub site: Option<(String, mapkeeper_closed_loop::worlds::site::Site)>,
}

/// A checked sweep: what it computes (each preset's parameters, the jobs) and, beside it, what
/// it is given and how it runs (W_1, the threads, the MCAP folders), never inside the
/// parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepPlan {
    /// The presets' names.
    pub presets: Vec<String>,
    /// Each preset's validation parameters.
    pub params: Vec<ValidationParams>,
    /// This shard's jobs: (preset index, seed), preset by preset.
    pub jobs: Vec<(usize, u64)>,
    /// W_1 with its scenario resolved; `None`: the embedded default warehouse.
    pub w1: Option<World>,
    /// The threads of every world's run.
    pub options: RunOptions,
    /// Each preset's folder of MCAP bags (`--mcap-worlds`); `None`: no bag is written.
    pub mcap_dirs: Vec<Option<PathBuf>>,
}

impl SweepSpec {
    /// Checks the spec and lists the jobs.
    pub fn plan(&self) -> Result<SweepPlan, ExperimentError> {
        if self.seeds == 0 {
            return Err(ExperimentError::from(ParamError::rule("seeds", "must be at least 1")));
        }
        let presets = &self.presets;
        if presets.is_empty() || presets.iter().any(|p| p.trim().is_empty()) {
            return Err(ExperimentError::from(ParamError::rule("presets", "needs preset names separated by commas")));
        }
        if let Some((i, p)) = presets.iter().enumerate().find(|(i, p)| presets[..*i].contains(p)) {
            return Err(ExperimentError::from(ParamError::rule(
                "presets",
                format!("names '{p}' twice (entry {})", i + 1),
            )));
        }
        let mut params = Vec::with_capacity(presets.len());
        for preset in presets {
            let mut p = ValidationParams::new(self.worlds, preset)?;
            p.runner.set_localiser(&self.localiser)?;
            p.ground_truth = self.ground_truth;
            if let Some((name, site)) = &self.site {
                p.use_site(name, site);
            }
            if let Some(len) = self.route_length_m {
                if !(len.is_finite() && len > 0.0) {
                    return Err(ExperimentError::from(ParamError::new(
                        "route_length",
                        len,
                        "must be a positive number of metres",
                    )));
                }
                p.route = ValidationParams::truncated_route(&p.route, len);
            }
            params.push(p);
        }
        let seeds: Vec<u64> = (0..self.seeds).map(|k| self.first_seed.saturating_add(k)).collect();
        if seeds.windows(2).any(|w| w[0] == w[1]) {
            return Err(ExperimentError::from(ParamError::rule(
                "seeds",
                format!("seed {} with {} seeds runs past the largest seed", self.first_seed, self.seeds),
            )));
        }
        let all: Vec<(usize, u64)> = (0..presets.len()).flat_map(|p| seeds.iter().map(move |&s| (p, s))).collect();
        let jobs = match self.shard {
            None => all,
            Some(sh) => sh.slice(&all).map(<[_]>::to_vec).ok_or_else(|| {
                ExperimentError::from(ParamError::rule(
                    "shard",
                    format!(
                        "{}/{}: {} job(s) ({} preset(s) × {} seed(s)) cannot make {} non-empty shards",
                        sh.index,
                        sh.count,
                        all.len(),
                        presets.len(),
                        self.seeds,
                        sh.count
                    ),
                ))
            })?,
        };
        let mcap_dirs = vec![None; presets.len()];
        let w1 = self.site.as_ref().map(|(_, site)| site.world.clone());
        Ok(SweepPlan { presets: presets.clone(), params, jobs, w1, options: RunOptions::default(), mcap_dirs })
    }
}

impl SweepPlan {
    /// The presets (indices) that have jobs in this shard, in order.
    pub fn groups(&self) -> Vec<usize> {
        (0..self.presets.len()).filter(|&p| self.jobs.iter().any(|j| j.0 == p)).collect()
    }

    /// Worlds in all jobs (for progress).
    pub fn total_worlds(&self) -> u64 {
        self.jobs.iter().map(|&(p, _)| self.params[p].worlds as u64).sum()
    }

    /// Runs every job on the current rayon pool; `progress` is called after each world.
    pub fn run(&self, clock: &dyn Clock, progress: &(dyn Fn(usize) + Sync)) -> Result<Vec<SeedRun>, ExperimentError> {
        self.run_resuming(vec![None; self.jobs.len()], None, clock, &|_, world| progress(world))
    }

    /// The finished runs of this plan's jobs found in `checkpoints` (in job order; `None`: to
    /// run). A checkpoint another run wrote is an error.
    pub fn load_checkpoints(&self, checkpoints: &Checkpoints) -> Result<Vec<Option<SeedRun>>, ExperimentError> {
        self.jobs.iter().map(|&(p, s)| checkpoints.load(&self.params[p], &self.given(p, &NoClock), s)).collect()
    }

    /// What preset `p`'s runs are given beside their parameters, timed by `clock`.
    pub fn given<'a>(&'a self, p: usize, clock: &'a dyn Clock) -> ValidationRun<'a> {
        ValidationRun {
            w1: self.w1.as_ref(),
            exec: Execution { options: self.options, clock },
            mcap_dir: self.mcap_dirs.get(p).and_then(Option::as_deref),
        }
    }

    /// Runs the jobs that `done` (in job order) does not hold, on the current rayon pool, each
    /// written to `checkpoints` as soon as it finishes; `progress(job, world)` is called after
    /// each world (for a job already done, once per world at the start). The runs come back in job order,
    /// the same whichever were resumed.
    pub fn run_resuming(
        &self,
        done: Vec<Option<SeedRun>>,
        checkpoints: Option<&Checkpoints>,
        clock: &dyn Clock,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Vec<SeedRun>, ExperimentError> {
        if done.len() != self.jobs.len() {
            return Err(ExperimentError::Invalid(format!("{} finished runs for {} jobs", done.len(), self.jobs.len())));
        }
        for (k, (&(p, _), _)) in self.jobs.iter().zip(&done).enumerate().filter(|(_, (_, d))| d.is_some()) {
            (1..=self.params[p].worlds).for_each(|w| progress(k, w));
        }
        let done = done.into_iter().map(std::sync::Mutex::new).collect();
        let trials = SweepTrials { plan: self, done, checkpoints, clock, progress };
        run_trials(&trials, &|| {})
    }

    /// The runs of preset `p`, in job order.
    pub fn runs_of(&self, p: usize, runs: &[SeedRun]) -> Vec<SeedRun> {
        self.jobs.iter().zip(runs).filter(|(j, _)| j.0 == p).map(|(_, r)| r.clone()).collect()
    }
}

/// A plan's jobs as [`Trials`]: one job per (preset, seed), each the chain of one seed; a job
/// found done is given back as it is. The validation reports its progress per (job, world)
/// through its own callback (the time-left estimate needs both), not through the runner's.
struct SweepTrials<'a> {
    plan: &'a SweepPlan,
    /// The finished runs found in the checkpoints, in job order (`None`: to run), each taken
    /// by its job.
    done: Vec<std::sync::Mutex<Option<SeedRun>>>,
    checkpoints: Option<&'a Checkpoints>,
    clock: &'a dyn Clock,
    progress: &'a (dyn Fn(usize, usize) + Sync),
}

impl Trials for SweepTrials<'_> {
    /// The job's index in the plan.
    type Job = usize;
    type Outcome = SeedRun;
    type Summary = Vec<SeedRun>;

    fn draw(&self) -> Vec<usize> {
        (0..self.plan.jobs.len()).collect()
    }

    fn run(&self, k: usize, _: &(dyn Fn() + Sync)) -> Result<SeedRun, ExperimentError> {
        let found = self.done[k].lock().unwrap_or_else(std::sync::PoisonError::into_inner).take();
        if let Some(run) = found {
            return Ok(run);
        }
        let (p, s) = self.plan.jobs[k];
        let (params, given) = (&self.plan.params[p], self.plan.given(p, self.clock));
        let run = run_seed(params, s, &given, &|w| (self.progress)(k, w))?;
        if let Some(c) = self.checkpoints {
            c.save(params, &given, &run)?;
        }
        Ok(run)
    }

    fn summarise(&self, runs: Vec<SeedRun>) -> Result<Vec<SeedRun>, ExperimentError> {
        Ok(runs)
    }
}
