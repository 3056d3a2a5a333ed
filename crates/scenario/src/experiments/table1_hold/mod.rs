//! Table 1 for real (issue 12, item 4; `docs/recovery.md`, "Table 1 with a held error"): the
//! robot drives the whole tour of W_2 (so it sees every edit of W_2) on the map of W_1 while the
//! pose the updater is given is held wrong for T seconds from the start ([`PoseErrorHold`]: a
//! seeded 0.3-1.0 m offset in any direction relative to the heading, up to ±10° of heading),
//! then is right (a localiser that converged after T s); or, the paper's own setting, the
//! chain localiser starts 0.7 m off and corrects itself (`amcl_start`). Each trial has its own
//! world seed (its own W_2), start place on the tour and error, and every (preset, hold,
//! variant) drives it with the same sensor data until their maps differ. Variants:
//! `always_update` (no localisation check: the paper's "old approach"), `check` (the preset as
//! it is), `check_no_pose_updating` (the check without pose updating). M_2 is scored against
//! G_2 (CC, MS, OPDF) and the wrongly flipped cells are counted (cells of M_2 that differ from
//! the initial map and from G_2, where G_2 is known).

pub mod report;

use crate::experiments::ExperimentError;
use crate::experiments::scores::Scores;
use crate::experiments::scores::{mean_scores, scores};
use crate::stats::{mean, paired_diff};
use mapkeeper_closed_loop::controls::{Kidnap, PoseErrorHold};
use mapkeeper_closed_loop::setup::params::RecoveryParams;
use mapkeeper_closed_loop::setup::{Setup, prepare};
use mapkeeper_closed_loop::trials::{Trials, run_each, run_trials};
use mapkeeper_common::ParamError;
use mapkeeper_grid::{CellState, OccupancyGrid};
use mapkeeper_sim::World;
use mapkeeper_sim::seeds::{stream_rng, stream_seed};
use mapkeeper_updater::UpdaterParams;
use rand::RngExt;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// The variants of each preset, in order.
pub const VARIANTS: [&str; 3] = ["always_update", "check", "check_no_pose_updating"];

/// Parameters of the experiment (`[table1]` of a parameter file).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Table1HoldParams {
    /// Trials (each its own world seed, place and error). Default 10.
    pub trials: usize,
    /// Updater presets. Default `paper`, `mapkeeper`.
    pub presets: Vec<String>,
    /// Hold durations T, seconds. Default 0, 5, 10, 20, 30.
    pub holds_s: Vec<f64>,
    /// Also run the chain localiser from a start error of this size (no hold), metres; 0 = off.
    /// Default 0.7 (the paper's).
    pub amcl_start_error_m: f64,
    /// Smallest held position error, metres. Default 0.3.
    pub min_error_m: f64,
    /// Largest held position error, metres. Default 1.0.
    pub max_error_m: f64,
    /// Largest held heading error, radians. Default 10° (0.1745).
    pub max_yaw_rad: f64,
    /// Length of the drive, metres; 0 = the whole tour. Default 0.
    pub route_length_m: f64,
}

impl Default for Table1HoldParams {
    fn default() -> Self {
        Self {
            trials: 10,
            presets: vec!["paper".into(), "mapkeeper".into()],
            holds_s: vec![0.0, 5.0, 10.0, 20.0, 30.0],
            amcl_start_error_m: 0.7,
            min_error_m: 0.3,
            max_error_m: 1.0,
            max_yaw_rad: 10f64.to_radians(),
            route_length_m: 0.0,
        }
    }
}

impl Table1HoldParams {
    /// The short setting of `--quick`: 2 trials, holds of 0 and 2 s, 6 m, `paper` only.
    pub fn quick() -> Self {
        Self {
            trials: 2,
            holds_s: vec![0.0, 2.0],
            route_length_m: 6.0,
            presets: vec!["paper".into()],
            ..Self::default()
        }
    }
}

impl Table1HoldParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ExperimentError> {
        if self.trials == 0 {
            return Err(ExperimentError::from(ParamError::rule("table1.trials", "must be ≥ 1")));
        }
        if self.presets.is_empty() {
            return Err(ExperimentError::from(ParamError::rule("table1.presets", "needs at least one preset")));
        }
        for p in &self.presets {
            UpdaterParams::preset(p)
                .map_err(|e| ExperimentError::from(ParamError::rule("table1.presets", e.to_string())))?;
        }
        if self.holds_s.is_empty() || self.holds_s.iter().any(|t| !(t.is_finite() && *t >= 0.0)) {
            return Err(ExperimentError::from(ParamError::rule(
                "table1.holds_s",
                format!("needs finite values ≥ 0, got {:?}", self.holds_s),
            )));
        }
        for (name, v) in [
            ("table1.amcl_start_error_m", self.amcl_start_error_m),
            ("table1.min_error_m", self.min_error_m),
            ("table1.max_error_m", self.max_error_m),
            ("table1.max_yaw_rad", self.max_yaw_rad),
            ("table1.route_length_m", self.route_length_m),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ExperimentError::from(ParamError::new(name, v, "must be finite and ≥ 0")));
            }
        }
        if self.min_error_m > self.max_error_m {
            return Err(ExperimentError::from(ParamError::rule("table1.min_error_m", "must not exceed max_error_m")));
        }
        Ok(())
    }

    /// The row labels: `hold_<T>s` per hold, then `amcl_start` if on.
    pub fn conditions(&self) -> Vec<String> {
        let mut v: Vec<String> = self.holds_s.iter().map(|&t| hold_name(t)).collect();
        if self.amcl_start_error_m > 0.0 {
            v.push("amcl_start".into());
        }
        v
    }
}

/// One trial's draw.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Table1Draw {
    /// Trial index.
    pub trial: usize,
    /// The seed of its worlds and runs.
    pub seed: u64,
    /// Start of the drive on the tour, metres.
    pub tour_position_m: f64,
    /// Held position error, metres.
    pub error_m: f64,
    /// Its direction relative to the heading at the start, radians.
    pub direction_rel_rad: f64,
    /// Held heading error, radians.
    pub yaw_error_rad: f64,
    /// Direction of the `amcl_start` error (map frame), radians.
    pub start_direction_rad: f64,
}

/// The draw of trial `t` of run seed `seed`.
pub fn draw_table1(p: &Table1HoldParams, tour_length_m: f64, seed: u64, t: usize) -> Table1Draw {
    let name = format!("table1-hold/{t:04}");
    let mut rng = stream_rng(seed, &name);
    Table1Draw {
        trial: t,
        seed: stream_seed(seed, &format!("{name}/seed")),
        tour_position_m: rng.random_range(0.0..tour_length_m.max(1e-9)),
        error_m: p.min_error_m + rng.random::<f64>() * (p.max_error_m - p.min_error_m),
        direction_rel_rad: rng.random_range(-PI..PI),
        yaw_error_rad: rng.random_range(-1.0..=1.0) * p.max_yaw_rad,
        start_direction_rad: rng.random_range(-PI..PI),
    }
}

/// One run: a trial under one preset, condition and variant.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Table1HoldRun {
    /// The draw.
    pub draw: Table1Draw,
    /// Preset.
    pub preset: String,
    /// `hold_<T>s` or `amcl_start`.
    pub condition: String,
    /// One of [`VARIANTS`].
    pub variant: String,
    /// M_2 against G_2.
    pub scores: Scores,
    /// The initial map against G_2 (nothing updated).
    pub static_scores: Scores,
    /// Cells of M_2 that differ from the initial map and from G_2 (G_2 known).
    pub wrong_flips: u64,
    /// Cells of M_2 that differ from the initial map.
    pub cells_changed: u64,
    /// Verdicts Suspend and Lost.
    pub suspends: u64,
    /// Verdicts Lost.
    pub losts: u64,
    /// Poses recovered by pose updating.
    pub recoveries: u64,
    /// The route was completed.
    pub route_done: bool,
}

/// Mean and paired interval of one metric.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MeanCi {
    /// Mean over trials.
    pub mean: f64,
    /// 95 % Student-t interval over trials, [lo, hi] (`None` with one trial).
    pub ci95: Option<[f64; 2]>,
}

fn mean_ci(v: &[f64]) -> MeanCi {
    let d = paired_diff(v);
    MeanCi { mean: d.mean, ci95: d.ci95 }
}

/// The condition name of a hold of `t` seconds (`hold_30s`).
pub fn hold_name(t: f64) -> String {
    format!("hold_{t}s")
}

/// One cell of the table: `table1.<preset>.<condition>.<variant>`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Table1Cell {
    /// Mean CC of M_2/G_2 over trials, %.
    pub cc: f64,
    /// Mean MS, %.
    pub ms: f64,
    /// Mean OPDF, %.
    pub opdf: f64,
    /// Intervals of the three.
    pub cc_ci95: Option<[f64; 2]>,
    /// MS interval.
    pub ms_ci95: Option<[f64; 2]>,
    /// OPDF interval.
    pub opdf_ci95: Option<[f64; 2]>,
    /// This variant − `always_update`, paired over trials: CC, MS, OPDF points.
    pub vs_always_update: BTreeMap<String, MeanCi>,
    /// Mean wrongly flipped cells.
    pub wrong_flips: f64,
    /// Mean changed cells.
    pub cells_changed: f64,
    /// Mean Suspend + Lost verdicts.
    pub alarms: f64,
    /// Runs.
    pub runs: usize,
}

/// `summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Table1HoldSummary {
    /// Producer and version.
    pub tool: String,
    /// Run seed.
    pub seed: u64,
    /// Wall time, seconds (set by the caller).
    pub wall_time_s: f64,
    /// The initial map against G_2, mean over trials.
    pub static_map: Scores,
    /// `table1.<preset>.<condition>.<variant>`.
    pub table1: Table,
    /// The paper's Table 1 (always-update "old", with the check "new").
    pub paper_table1: BTreeMap<String, Scores>,
    /// Parameters.
    pub params: Table1HoldParams,
    /// The loop and worlds.
    pub recovery: RecoveryParams,
}

/// Everything the experiment produced.
#[derive(Clone, Debug, PartialEq)]
pub struct Table1HoldResults {
    /// The summary.
    pub summary: Table1HoldSummary,
    /// Every run.
    pub runs: Vec<Table1HoldRun>,
}

fn wrong_flips(map: &OccupancyGrid, initial: &OccupancyGrid, g: &OccupancyGrid) -> (u64, u64) {
    let (mut wrong, mut changed) = (0, 0);
    for ((m, i), t) in map.cells().iter().zip(initial.cells()).zip(g.cells()) {
        if m != i {
            changed += 1;
            if *t != CellState::Unknown && m != t {
                wrong += 1;
            }
        }
    }
    (wrong, changed)
}

fn variant_params(preset: &UpdaterParams, variant: &str) -> UpdaterParams {
    let mut u = preset.clone();
    match variant {
        "always_update" => u.localisation_check = false,
        "check_no_pose_updating" => u.pose_updating.enabled = false,
        _ => {}
    }
    u
}

/// The table: `<preset>.<condition>.<variant>` over the runs.
type Table = BTreeMap<String, BTreeMap<String, BTreeMap<String, Table1Cell>>>;

fn tabulate(runs: &[Table1HoldRun], p: &Table1HoldParams, conditions: &[String]) -> Table {
    let mut table1 = BTreeMap::new();
    for name in &p.presets {
        let mut by_cond = BTreeMap::new();
        for cond in conditions {
            let pick = |variant: &str| -> Vec<&Table1HoldRun> {
                runs.iter().filter(|r| &r.preset == name && &r.condition == cond && r.variant == variant).collect()
            };
            let au = pick("always_update");
            let mut by_var = BTreeMap::new();
            for variant in VARIANTS {
                let v = pick(variant);
                let col = |f: &dyn Fn(&Scores) -> f64| v.iter().map(|r| f(&r.scores)).collect::<Vec<f64>>();
                let (cc, ms, opdf) = (col(&|s| s.cc), col(&|s| s.ms), col(&|s| s.opdf));
                let mut vs = BTreeMap::new();
                for (m, f) in
                    [("cc", (|s: &Scores| s.cc) as fn(&Scores) -> f64), ("ms", |s| s.ms), ("opdf", |s| s.opdf)]
                {
                    let diffs: Vec<f64> = v.iter().zip(&au).map(|(a, b)| f(&a.scores) - f(&b.scores)).collect();
                    vs.insert(m.to_string(), mean_ci(&diffs));
                }
                by_var.insert(
                    variant.to_string(),
                    Table1Cell {
                        cc: mean(cc.iter().copied()),
                        ms: mean(ms.iter().copied()),
                        opdf: mean(opdf.iter().copied()),
                        cc_ci95: mean_ci(&cc).ci95,
                        ms_ci95: mean_ci(&ms).ci95,
                        opdf_ci95: mean_ci(&opdf).ci95,
                        vs_always_update: vs,
                        wrong_flips: mean(v.iter().map(|r| r.wrong_flips as f64)),
                        cells_changed: mean(v.iter().map(|r| r.cells_changed as f64)),
                        alarms: mean(v.iter().map(|r| r.suspends as f64)),
                        runs: v.len(),
                    },
                );
            }
            by_cond.insert(cond.clone(), by_var);
        }
        table1.insert(name.clone(), by_cond);
    }
    table1
}

/// The initial map against G_2, mean over the trials.
fn static_scores(runs: &[Table1HoldRun], p: &Table1HoldParams, conditions: &[String]) -> Scores {
    let first: Vec<&Table1HoldRun> = runs
        .iter()
        .filter(|r| r.preset == p.presets[0] && r.condition == conditions[0] && r.variant == VARIANTS[0])
        .collect();
    mean_scores(first.iter().map(|r| &r.static_scores))
}

/// Condition `c` of `p.conditions()` on the run's parameters: a held error or a start error.
fn set_condition(
    run_p: &mut mapkeeper_closed_loop::runner::RunnerParams,
    p: &Table1HoldParams,
    recovery: &RecoveryParams,
    d: &Table1Draw,
    start_yaw: f64,
    c: usize,
) {
    if let Some(&hold) = p.holds_s.get(c) {
        let dir = start_yaw + d.direction_rel_rad;
        run_p.pose_error = Some(PoseErrorHold {
            at_s: 0.0,
            hold_s: hold,
            dx_m: d.error_m * dir.cos(),
            dy_m: d.error_m * dir.sin(),
            dyaw_rad: d.yaw_error_rad,
        });
    } else {
        let e = p.amcl_start_error_m;
        run_p.kidnap = Some(Kidnap {
            at_s: 0.0,
            dx_m: e * d.start_direction_rad.cos(),
            dy_m: e * d.start_direction_rad.sin(),
            dyaw_rad: 0.0,
            sigma_xy_m: recovery.table1.init_sigma_xy_m,
            sigma_yaw_rad: recovery.table1.init_sigma_yaw_rad,
        });
    }
}

/// The trials of one run of the experiment: every draw under every preset, condition and
/// variant, each draw in worlds of its own seed.
struct Table1Trials<'a> {
    recovery: &'a RecoveryParams,
    p: &'a Table1HoldParams,
    seed: u64,
    draws: Vec<Table1Draw>,
    setups: Vec<Setup>,
    presets: Vec<UpdaterParams>,
    conditions: Vec<String>,
}

impl Trials for Table1Trials<'_> {
    /// (trial, preset, condition, variant) indices.
    type Job = (usize, usize, usize, usize);
    type Outcome = Table1HoldRun;
    type Summary = Table1HoldResults;

    fn draw(&self) -> Vec<Self::Job> {
        let mut jobs = Vec::new();
        for t in 0..self.draws.len() {
            for k in 0..self.presets.len() {
                for c in 0..self.conditions.len() {
                    jobs.extend((0..VARIANTS.len()).map(|v| (t, k, c, v)));
                }
            }
        }
        jobs
    }

    fn run(&self, (t, k, c, v): Self::Job, progress: &(dyn Fn() + Sync)) -> Result<Table1HoldRun, ExperimentError> {
        let (recovery, p) = (self.recovery, self.p);
        let d = self.draws[t];
        let setup = &self.setups[t];
        let length = if p.route_length_m > 0.0 { p.route_length_m } else { recovery.tour.length_m() };
        let drive =
            setup.drive(2, setup.initial_map(recovery.initial_map), &recovery.tour, d.tour_position_m, length)?;
        let (map, g) = (drive.map, drive.truth);
        let mut run_p = recovery.runner.clone();
        run_p.updater = variant_params(&self.presets[k], VARIANTS[v]);
        set_condition(&mut run_p, p, recovery, &d, drive.start.yaw, c);
        let run = drive.run(&run_p, d.seed, &format!("table1-hold-{t:04}"))?;
        let (wrong, changed) = wrong_flips(&run.map, map, g);
        progress();
        Ok(Table1HoldRun {
            draw: d,
            preset: p.presets[k].clone(),
            condition: self.conditions[c].clone(),
            variant: VARIANTS[v].to_string(),
            scores: scores(&run.map, g, &recovery.metrics)?,
            static_scores: scores(map, g, &recovery.metrics)?,
            wrong_flips: wrong,
            cells_changed: changed,
            suspends: run.updater.suspend + run.updater.lost,
            losts: run.updater.lost,
            recoveries: run.updater.recovered,
            route_done: run.route_done,
        })
    }

    fn summarise(&self, runs: Vec<Table1HoldRun>) -> Result<Table1HoldResults, ExperimentError> {
        let p = self.p;
        let paper_table1 = BTreeMap::from([
            ("always_update".to_string(), Scores { cc: 66.86, ms: 55.11, opdf: 90.40 }),
            ("check".to_string(), Scores { cc: 70.03, ms: 61.24, opdf: 95.87 }),
        ]);
        let summary = Table1HoldSummary {
            tool: format!("mapkeeper-scenario {}", env!("CARGO_PKG_VERSION")),
            seed: self.seed,
            wall_time_s: 0.0,
            static_map: static_scores(&runs, p, &self.conditions),
            table1: tabulate(&runs, p, &self.conditions),
            paper_table1,
            params: p.clone(),
            recovery: self.recovery.clone(),
        };
        Ok(Table1HoldResults { summary, runs })
    }
}

/// Runs every trial under every preset, condition and variant ([`run_trials`]: in parallel,
/// collected in order). `progress` is called once per finished run.
pub fn run_table1_hold(
    w1: &World,
    recovery: &RecoveryParams,
    p: &Table1HoldParams,
    seed: u64,
    progress: &(dyn Fn() + Sync),
) -> Result<Table1HoldResults, ExperimentError> {
    p.validate()?;
    let mut rp = recovery.clone();
    rp.kidnap.stale_max_world = 2;
    rp.demo.world = 2;
    rp.table1.world = 2;
    rp.lost.world = 2;
    let tour_len = recovery.tour.length_m();
    let draws: Vec<Table1Draw> = (0..p.trials).map(|t| draw_table1(p, tour_len, seed, t)).collect();
    // Each draw's worlds are its own (seeded by the draw): generated once, in parallel.
    let setups = run_each(draws.clone(), |d| prepare(w1, &rp, d.seed))?;
    let trials = Table1Trials {
        recovery,
        p,
        seed,
        draws,
        setups,
        presets: p.presets.iter().map(|n| UpdaterParams::preset(n)).collect::<Result<_, _>>()?,
        conditions: p.conditions(),
    };
    run_trials(&trials, progress)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_are_seeded_and_in_range_and_conditions_are_named() {
        let p = Table1HoldParams::default();
        for t in 0..50 {
            let d = draw_table1(&p, 70.0, 3, t);
            assert_eq!(d, draw_table1(&p, 70.0, 3, t));
            assert!((0.3..=1.0).contains(&d.error_m) && d.yaw_error_rad.abs() <= p.max_yaw_rad + 1e-12);
        }
        assert_ne!(draw_table1(&p, 70.0, 3, 0).seed, draw_table1(&p, 70.0, 3, 1).seed);
        assert_eq!(p.conditions(), ["hold_0s", "hold_5s", "hold_10s", "hold_20s", "hold_30s", "amcl_start"]);
        let mut q = p.clone();
        q.min_error_m = 2.0;
        assert!(q.validate().is_err());
        let mut q = p;
        q.holds_s = vec![f64::NAN];
        assert!(q.validate().is_err());
    }

    #[test]
    fn wrong_flips_count_changed_cells_that_disagree_with_known_truth() {
        use mapkeeper_grid::{GridGeometry, Pose2};
        let g = GridGeometry::new(4, 1, 1.0, Pose2::IDENTITY).unwrap_or_else(|e| panic!("{e}"));
        let mk = |c: [CellState; 4]| {
            let mut m = OccupancyGrid::filled(g, CellState::Free);
            m.cells_mut().copy_from_slice(&c);
            m
        };
        use CellState::{Free as F, Occupied as O, Unknown as U};
        let initial = mk([F, F, O, O]);
        let truth = mk([O, F, F, U]);
        let map = mk([O, O, F, F]);
        // Cell 0 flipped right, 1 wrong, 2 right, 3 unknown in the truth (not counted as wrong).
        assert_eq!(wrong_flips(&map, &initial, &truth), (1, 4));
    }
}
