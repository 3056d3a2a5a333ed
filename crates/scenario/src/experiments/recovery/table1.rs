//! The Table 1 analog: a ~0.7 m start error, `always-update` against the preset with the
//! localisation check, M_2 scored against G_2 over seeded error directions.

use crate::experiments::ExperimentError;
use crate::experiments::scores::Scores;
use crate::experiments::scores::{mean_scores, scores};
use crate::stats::frac;
use mapkeeper_closed_loop::controls::{Kidnap, VerdictCounts};
use mapkeeper_closed_loop::runner::WorldRun;
use mapkeeper_closed_loop::setup::{Drive, Setup};
use mapkeeper_closed_loop::trials::{Trials, run_trials};
use mapkeeper_sim::seeds::stream_rng;
use mapkeeper_updater::UpdaterParams;
use rand::RngExt;
use serde::{Deserialize, Serialize};

use super::demo::counts;
use mapkeeper_closed_loop::setup::params::RecoveryParams;

/// One Table 1 run (one error direction, both updaters).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Table1Run {
    /// Run index.
    pub run: usize,
    /// Direction of the start error, radians (map frame).
    pub direction_rad: f64,
    /// M_2/G_2 with `always-update`.
    pub always_update: Scores,
    /// M_2/G_2 with the localisation check (`paper`).
    pub check: Scores,
    /// Verdicts of the `paper` run.
    pub check_verdicts: VerdictCounts,
    /// Cells changed by `always-update`.
    pub always_update_cells_changed: u64,
    /// Cells changed with the check.
    pub check_cells_changed: u64,
}

/// Fractions per metric.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MetricFractions {
    /// CC.
    pub cc: f64,
    /// MS.
    pub ms: f64,
    /// OPDF.
    pub opdf: f64,
}

/// `summary.json` `table1`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Table1Summary {
    /// i of W_i.
    pub world: usize,
    /// Initial error, metres.
    pub start_error_m: f64,
    /// Runs.
    pub runs: usize,
    /// Mean M_2/G_2 with `always-update`.
    pub always_update: Scores,
    /// Mean M_2/G_2 with the localisation check.
    pub check: Scores,
    /// The initial map against G_2 (nothing updated).
    pub static_map: Scores,
    /// Share of runs where the check's map scores higher.
    pub check_better_fraction: MetricFractions,
    /// The check's mean is higher on all three metrics (the paper's Table 1 direction).
    pub direction_reproduced: bool,
    /// The paper's Table 1, always-update ("old").
    pub paper_always_update: Scores,
    /// The paper's Table 1, with the check ("new").
    pub paper_check: Scores,
}

/// A start error of `error_m` at `t = 0` in a direction drawn from `stream`.
pub(super) fn start_kidnap(
    seed: u64,
    stream: &str,
    error_m: f64,
    sigma_xy_m: f64,
    sigma_yaw_rad: f64,
) -> (f64, Kidnap) {
    let mut rng = stream_rng(seed, stream);
    let dir = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
    let k = Kidnap {
        at_s: 0.0,
        dx_m: error_m * dir.cos(),
        dy_m: error_m * dir.sin(),
        dyaw_rad: 0.0,
        sigma_xy_m,
        sigma_yaw_rad,
    };
    (dir, k)
}

/// The Table 1 runs as [`Trials`]: one job per (error direction, updater), both updaters on the
/// same drive with the same start error; the summary pairs them.
struct Table1Trials<'a> {
    drive: Drive<'a>,
    params: &'a RecoveryParams,
    seed: u64,
    /// `always-update`, then the `paper` preset with the localisation check.
    presets: [UpdaterParams; 2],
}

impl Trials for Table1Trials<'_> {
    /// (run, updater: 0 `always-update`, 1 the check).
    type Job = (usize, usize);
    /// The start error's direction and the run.
    type Outcome = (f64, WorldRun);
    type Summary = (Table1Summary, Vec<Table1Run>);

    fn draw(&self) -> Vec<(usize, usize)> {
        (0..self.params.table1.runs).flat_map(|r| [(r, 0), (r, 1)]).collect()
    }

    fn run(&self, (r, k): (usize, usize), progress: &(dyn Fn() + Sync)) -> Result<(f64, WorldRun), ExperimentError> {
        let t = &self.params.table1;
        let label = format!("table1-{r:03}");
        let (dir, kid) = start_kidnap(
            self.seed,
            &format!("{label}/error"),
            t.start_error_m,
            t.init_sigma_xy_m,
            t.init_sigma_yaw_rad,
        );
        let mut rp = self.params.runner.clone();
        rp.updater = self.presets[k].clone();
        rp.kidnap = Some(kid);
        rp.record_timeline = true;
        let run = self.drive.run(&rp, self.seed, &label)?;
        progress();
        Ok((dir, run))
    }

    fn summarise(&self, results: Vec<(f64, WorldRun)>) -> Result<(Table1Summary, Vec<Table1Run>), ExperimentError> {
        let (t, params) = (&self.params.table1, self.params);
        let (map, g) = (self.drive.map, self.drive.truth);
        let mut runs = Vec::with_capacity(t.runs);
        for (r, pair) in results.chunks(2).enumerate() {
            let [(dir, au), (_, ck)] = pair else { continue };
            runs.push(Table1Run {
                run: r,
                direction_rad: *dir,
                always_update: scores(&au.map, g, &params.metrics)?,
                check: scores(&ck.map, g, &params.metrics)?,
                check_verdicts: counts(&ck.timeline),
                always_update_cells_changed: au.cells_changed,
                check_cells_changed: ck.cells_changed,
            });
        }
        let always_update = mean_scores(runs.iter().map(|r| &r.always_update));
        let check = mean_scores(runs.iter().map(|r| &r.check));
        let summary = Table1Summary {
            world: t.world,
            start_error_m: t.start_error_m,
            runs: runs.len(),
            always_update,
            check,
            static_map: scores(map, g, &params.metrics)?,
            check_better_fraction: MetricFractions {
                cc: frac(runs.iter().map(|r| r.check.cc > r.always_update.cc)),
                ms: frac(runs.iter().map(|r| r.check.ms > r.always_update.ms)),
                opdf: frac(runs.iter().map(|r| r.check.opdf > r.always_update.opdf)),
            },
            direction_reproduced: !runs.is_empty()
                && check.cc > always_update.cc
                && check.ms > always_update.ms
                && check.opdf > always_update.opdf,
            paper_always_update: Scores { cc: 66.86, ms: 55.11, opdf: 90.40 },
            paper_check: Scores { cc: 70.03, ms: 61.24, opdf: 95.87 },
        };
        Ok((summary, runs))
    }
}

/// The Table 1 analog: per run and the summary.
pub fn run_table1(
    setup: &Setup,
    params: &RecoveryParams,
    seed: u64,
) -> Result<(Table1Summary, Vec<Table1Run>), ExperimentError> {
    let t = &params.table1;
    let drive = setup.drive(
        t.world,
        setup.initial_map(params.initial_map),
        &params.tour,
        t.tour_position_m,
        t.route_length_m,
    )?;
    let presets = [UpdaterParams::always_update(), UpdaterParams::paper()];
    run_trials(&Table1Trials { drive, params, seed, presets }, &|| {})
}
