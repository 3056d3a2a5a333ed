//! Convergence from a start error (`mapkeeper converge`, docs/localiser.md): for each localiser
//! preset, seed and start error, the closed loop (localiser only: no updater, no baseline) drives
//! the route in W_1 on its ground-truth map, the localiser started at the true pose displaced by
//! the error in a seeded direction (no yaw error), with the preset's initial covariance.
//!
//! **Convergence rule:** the run has converged at the first recorded step (every scan tick,
//! gated estimates included) whose position error is below `threshold_m` and stays below it at
//! every step of the following `hold_s` seconds, the run lasting at least that long; the time is
//! the simulated time of that step and the distance the true distance travelled until then.
//! Never so within the run (ended by `max_sim_time_s` or the route's end): not converged.

use crate::experiments::ExperimentError;
use crate::stats::median;
use mapkeeper_closed_loop::runner::{RunInputs, RunnerParams, run_world};
use mapkeeper_closed_loop::trials::{Trials, run_trials};
use mapkeeper_common::ParamError;
use mapkeeper_grid::OccupancyGrid;
use mapkeeper_harness::NoClock;
use mapkeeper_localiser::FilterParams;
use mapkeeper_sim::{Route, World, ground_truth_map};
use std::fmt::Write as _;

/// What to measure.
#[derive(Clone, Debug, PartialEq)]
pub struct ConvergenceParams {
    /// Localiser presets (`mapkeeper_localiser::LOCALISER_PRESETS`), in order.
    pub localisers: Vec<String>,
    /// The filter parameters of each localiser, if not its preset's (e.g. a parameter file's
    /// overrides): empty, or one per entry of `localisers`.
    pub filters: Vec<FilterParams>,
    /// Run seeds (the error direction and all noise derive from the seed only, so every
    /// preset and error sees the same direction and the same sensor noise for a seed).
    pub seeds: Vec<u64>,
    /// Start errors, metres.
    pub errors_m: Vec<f64>,
    /// Converged: position error below this, metres. Default 0.1.
    pub threshold_m: f64,
    /// ... and staying below it this long, seconds. Default 2.
    pub hold_s: f64,
    /// Run cap, simulated seconds. Default 120.
    pub max_sim_time_s: f64,
    /// Map resolution, metres per cell. Default 0.05.
    pub resolution_m: f64,
    /// The route. Default [`Route::default_warehouse`].
    pub route: Route,
}

impl Default for ConvergenceParams {
    fn default() -> Self {
        Self {
            localisers: vec!["amcl".into(), "mapkeeper".into()],
            filters: Vec::new(),
            seeds: (1..=10).collect(),
            errors_m: vec![0.5, 0.7, 1.5],
            threshold_m: 0.1,
            hold_s: 2.0,
            max_sim_time_s: 120.0,
            resolution_m: 0.05,
            route: Route::default_warehouse(),
        }
    }
}

impl ConvergenceParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ExperimentError> {
        if self.localisers.is_empty() || self.seeds.is_empty() || self.errors_m.is_empty() {
            return Err(ExperimentError::from(ParamError::rule(
                "localisers/seeds/errors",
                "each needs at least one entry",
            )));
        }
        for l in &self.localisers {
            RunnerParams::default().set_localiser(l)?;
        }
        if !(self.filters.is_empty() || self.filters.len() == self.localisers.len()) {
            return Err(ExperimentError::from(ParamError::rule(
                "filters",
                format!("{} given for {} localisers", self.filters.len(), self.localisers.len()),
            )));
        }
        for f in &self.filters {
            f.validate()?;
        }
        crate::experiments::check_route("route", &self.route, 1)?;
        if let Some(e) = self.errors_m.iter().find(|e| !(e.is_finite() && **e >= 0.0)) {
            return Err(ExperimentError::from(ParamError::new("errors", e, "must be finite distances ≥ 0 m")));
        }
        for (name, v) in [
            ("threshold_m", self.threshold_m),
            ("max_sim_time_s", self.max_sim_time_s),
            ("resolution_m", self.resolution_m),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ExperimentError::from(ParamError::new(name, v, "must be finite and > 0")));
            }
        }
        if !(self.hold_s.is_finite() && self.hold_s >= 0.0) {
            return Err(ExperimentError::from(ParamError::new("hold_s", self.hold_s, "must be finite and ≥ 0")));
        }
        Ok(())
    }

    /// The jobs: (localiser index, seed, error index), localiser by localiser, then error.
    pub fn jobs(&self) -> Vec<(usize, u64, usize)> {
        let mut jobs = Vec::new();
        for l in 0..self.localisers.len() {
            for e in 0..self.errors_m.len() {
                jobs.extend(self.seeds.iter().map(|&s| (l, s, e)));
            }
        }
        jobs
    }
}

/// One recorded step of a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConvergenceSample {
    /// Simulated time, seconds.
    pub t_s: f64,
    /// True distance travelled, metres.
    pub distance_m: f64,
    /// Position error of the estimate, metres.
    pub error_m: f64,
    /// Absolute yaw error, radians.
    pub yaw_error_rad: f64,
}

/// One run.
#[derive(Clone, Debug, PartialEq)]
pub struct ConvergenceRun {
    /// The localiser preset.
    pub localiser: String,
    /// The seed.
    pub seed: u64,
    /// The start error, metres.
    pub start_error_m: f64,
    /// Time of convergence, seconds (`None`: not converged).
    pub converged_s: Option<f64>,
    /// Distance travelled until then, metres.
    pub converged_distance_m: Option<f64>,
    /// Length of the run, simulated seconds.
    pub sim_time_s: f64,
    /// Distance travelled in the run, metres.
    pub distance_m: f64,
    /// Every step.
    pub samples: Vec<ConvergenceSample>,
}

/// Index of the first sample that satisfies the convergence rule (module docs).
pub fn first_converged(samples: &[ConvergenceSample], threshold_m: f64, hold_s: f64) -> Option<usize> {
    let end = samples.last()?.t_s;
    let mut candidate: Option<usize> = None;
    for (i, s) in samples.iter().enumerate() {
        if s.error_m < threshold_m {
            let c = *candidate.get_or_insert(i);
            if s.t_s - samples[c].t_s >= hold_s {
                return Some(c);
            }
        } else {
            candidate = None;
        }
    }
    candidate.filter(|&c| end - samples[c].t_s >= hold_s)
}

/// Runs one job on `map` (the ground truth of `w1`).
pub fn run_job(
    w1: &World,
    map: &OccupancyGrid,
    params: &ConvergenceParams,
    (l, seed, e): (usize, u64, usize),
) -> Result<ConvergenceRun, ExperimentError> {
    let mut rp = RunnerParams {
        start_error_m: params.errors_m[e],
        start_error_yaw_rad: 0.0,
        run_updater: false,
        run_baseline: false,
        max_sim_time_s: params.max_sim_time_s,
        record_trajectories: true,
        ..RunnerParams::default()
    };
    rp.set_localiser(&params.localisers[l])?;
    if let Some(f) = params.filters.get(l) {
        rp.filter = *f;
    }
    rp.init_sigma_xy_m = rp.filter.initial_cov_xx_m2.max(rp.filter.initial_cov_yy_m2).sqrt();
    rp.init_sigma_yaw_rad = rp.filter.initial_cov_aa_rad2.sqrt();
    let inputs = RunInputs { world: w1, route: &params.route, prev_map: map, baseline_map: map, prev_memory: None };
    let run = run_world(&inputs, &rp, seed, "converge", &NoClock)?;
    let traj = run.trajectories.unwrap_or_default();
    let mut samples = Vec::with_capacity(traj.truth.len());
    let mut distance_m = 0.0;
    for (k, (t, c)) in traj.truth.iter().zip(&traj.chain).enumerate() {
        if k > 0 {
            distance_m += traj.truth[k - 1].pose.distance(&t.pose);
        }
        samples.push(ConvergenceSample {
            t_s: t.stamp_ns as f64 / 1e9,
            distance_m,
            error_m: c.pose.distance(&t.pose),
            yaw_error_rad: mapkeeper_grid::angle_diff(c.pose.yaw, t.pose.yaw).abs(),
        });
    }
    let hit = first_converged(&samples, params.threshold_m, params.hold_s);
    Ok(ConvergenceRun {
        localiser: params.localisers[l].clone(),
        seed,
        start_error_m: params.errors_m[e],
        converged_s: hit.map(|i| samples[i].t_s),
        converged_distance_m: hit.map(|i| samples[i].distance_m),
        sim_time_s: run.sim_time_s,
        distance_m: run.distance_m,
        samples,
    })
}

/// The convergence runs as [`Trials`]: one job per (localiser, seed, start error), each a drive
/// of W_1 on its ground-truth map; the outcomes are the runs, in job order.
struct ConvergenceTrials<'a> {
    w1: &'a World,
    map: OccupancyGrid,
    params: &'a ConvergenceParams,
}

impl Trials for ConvergenceTrials<'_> {
    /// (localiser index, seed, start error index), as [`ConvergenceParams::jobs`] lists them.
    type Job = (usize, u64, usize);
    type Outcome = ConvergenceRun;
    type Summary = Vec<ConvergenceRun>;

    fn draw(&self) -> Vec<(usize, u64, usize)> {
        self.params.jobs()
    }

    fn run(&self, job: (usize, u64, usize), progress: &(dyn Fn() + Sync)) -> Result<ConvergenceRun, ExperimentError> {
        let r = run_job(self.w1, &self.map, self.params, job);
        progress();
        r
    }

    fn summarise(&self, runs: Vec<ConvergenceRun>) -> Result<Vec<ConvergenceRun>, ExperimentError> {
        Ok(runs)
    }
}

/// Every job ([`run_trials`]: in parallel on the caller's rayon pool, in job order); `progress`
/// after each.
pub fn run_convergence(
    w1: &World,
    params: &ConvergenceParams,
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<ConvergenceRun>, ExperimentError> {
    params.validate()?;
    let map = ground_truth_map(w1, &w1.default_map_geometry(params.resolution_m)?);
    run_trials(&ConvergenceTrials { w1, map, params }, progress)
}

/// A run's steps as CSV (`t_s,distance_m,error_m,yaw_error_rad`).
pub fn samples_csv(run: &ConvergenceRun) -> String {
    let mut s = String::from("t_s,distance_m,error_m,yaw_error_rad\n");
    for x in &run.samples {
        let _ = writeln!(s, "{:.3},{:.4},{:.4},{:.5}", x.t_s, x.distance_m, x.error_m, x.yaw_error_rad);
    }
    s
}

/// One line per run as CSV.
pub fn runs_csv(runs: &[ConvergenceRun]) -> String {
    let mut s =
        String::from("localiser,seed,start_error_m,converged,converged_s,converged_distance_m,sim_time_s,distance_m\n");
    let opt = |v: Option<f64>| v.map_or(String::new(), |x| format!("{x:.3}"));
    for r in runs {
        let (c, d) = (opt(r.converged_s), opt(r.converged_distance_m));
        let ok = r.converged_s.is_some();
        let _ = writeln!(
            s,
            "{},{},{},{ok},{c},{d},{:.3},{:.3}",
            r.localiser, r.seed, r.start_error_m, r.sim_time_s, r.distance_m
        );
    }
    s
}

/// The markdown table: per (localiser, error) the median and maximum time and distance to
/// converge over the converged runs, and how many did not converge.
pub fn summary_markdown(params: &ConvergenceParams, runs: &[ConvergenceRun]) -> String {
    let mut s = format!(
        "Converged: position error < {} m and staying so for {} s; runs capped at {} s of simulated time \
         (or the route's end); seeds {:?}.\n\n\
         | localiser | start error (m) | runs | median time (s) | max time (s) | median distance (m) | max distance (m) | not converged |\n\
         |---|---|---|---|---|---|---|---|\n",
        params.threshold_m, params.hold_s, params.max_sim_time_s, params.seeds
    );
    let fmt = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |x| format!("{x:.1}"));
    let max = |v: &[f64]| v.iter().copied().reduce(f64::max);
    for l in &params.localisers {
        for &e in &params.errors_m {
            let group: Vec<&ConvergenceRun> =
                runs.iter().filter(|r| &r.localiser == l && r.start_error_m == e).collect();
            let t: Vec<f64> = group.iter().filter_map(|r| r.converged_s).collect();
            let d: Vec<f64> = group.iter().filter_map(|r| r.converged_distance_m).collect();
            let not = group.len() - t.len();
            let _ = writeln!(
                s,
                "| {l} | {e} | {} | {} | {} | {} | {} | {not} |",
                group.len(),
                fmt(median(t.clone())),
                fmt(max(&t)),
                fmt(median(d.clone())),
                fmt(max(&d))
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn samples(errors: &[f64]) -> Vec<ConvergenceSample> {
        let at = |(i, &e): (usize, &f64)| ConvergenceSample {
            t_s: i as f64,
            distance_m: 0.5 * i as f64,
            error_m: e,
            yaw_error_rad: 0.0,
        };
        errors.iter().enumerate().map(at).collect()
    }

    #[test]
    fn convergence_needs_the_error_to_stay_below_for_the_hold_time() {
        // Below at 1, up again at 2; below from 3 on for 2 s (3, 4, 5).
        let s = samples(&[0.5, 0.05, 0.2, 0.09, 0.08, 0.07]);
        assert_eq!(first_converged(&s, 0.1, 2.0), Some(3));
        assert_eq!(first_converged(&s, 0.1, 0.0), Some(1));
        // Below from 3 on but the run ends after 1 s: not converged.
        assert_eq!(first_converged(&s[..5], 0.1, 2.0), None);
        assert_eq!(first_converged(&samples(&[0.5, 0.4]), 0.1, 0.0), None);
        assert_eq!(first_converged(&[], 0.1, 2.0), None);
    }

    #[test]
    fn parameters_are_checked() {
        let p = ConvergenceParams::default();
        p.validate().unwrap();
        assert_eq!(p.jobs().len(), 2 * 10 * 3);
        let bad = ConvergenceParams { localisers: vec!["nope".into()], ..p.clone() };
        assert!(bad.validate().unwrap_err().to_string().contains("nope"));
        let bad = ConvergenceParams { errors_m: vec![f64::NAN], ..p.clone() };
        assert!(bad.validate().is_err());
        let bad = ConvergenceParams { seeds: vec![], ..p };
        assert!(bad.validate().is_err());
    }
}
