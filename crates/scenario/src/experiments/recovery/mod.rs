//! The robustness experiments (paper §5.3.1, §5.4; the product specification's "Robustness
//! experiments") and the pose-recovery stress suite:
//!
//! - **Localisation-check demo** ([`run_demo`]): in W_2 on M_1 the chain localiser starts 0.5 m
//!   to the right of the true start (the paper: true (2.0, 9.5, 0), estimate (2.0, 9.0, 0));
//!   the updater should Suspend until the localiser has converged, then Update.
//! - **Table 1 analog** ([`run_table1`]): ~0.7 m start error, `always-update` against the
//!   `paper` preset (with the localisation check), M_2 scored against G_2 with CC, MS, OPDF,
//!   over several seeded error directions.
//! - **Lost robot** ([`run_lost_robot`]): 1.5 m start error; the check says Lost, pose
//!   updating recovers the pose, and M_2 is compared with the map of the same run without
//!   the error.
//! - **Kidnap suite** ([`run_kidnap_suite`]): N seeded trials, each a short drive on the
//!   default tour from a random point of it in a generated world W_k, with the chain
//!   localiser's estimate displaced by 0.5-3 m and up to ±45° at a random time (the robot
//!   keeps driving); the map is stale (M_1 in W_k) or, the paper's best case (Fig. 29), the
//!   current world's ground truth G_k. Each trial is paired with the same run without the
//!   kidnap (same seed: identical until the kidnap) for the false-Lost rate and the map
//!   damage.
//!
//! Everything is deterministic: every random draw comes from a stream named after the run
//! seed and the trial, trials run in parallel (rayon) and are collected in order, and no
//! clock is read (the caller measures the wall time).

mod demo;
mod kidnap;
mod lost_robot;
pub mod report;
mod table1;

pub use demo::{DemoSummary, VerdictSegment, run_demo};
pub use kidnap::{
    BinSummary, KidnapSummary, KidnapTrial, MapCase, TrialDraw, draw_trial, run_kidnap_suite, run_kidnap_trial,
    summarise_kidnap,
};
pub use lost_robot::{LostRun, LostSummary, run_lost_robot};
pub use mapkeeper_closed_loop::controls::VerdictCounts;
pub use mapkeeper_closed_loop::setup::params::{
    DemoParams, InitialMapKind, KidnapParams, LostParams, RecoveryParams, SuccessCriterion, Table1Params,
};
pub use table1::{MetricFractions, Table1Run, Table1Summary, run_table1};

use crate::experiments::ExperimentError;
use mapkeeper_closed_loop::controls::TimelineSample;
use mapkeeper_closed_loop::setup::prepare;
use mapkeeper_sim::World;
use serde::{Deserialize, Serialize};

/// `summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RecoverySummary {
    /// Producer and version.
    pub tool: String,
    /// The run seed.
    pub seed: u64,
    /// Wall time of the whole run, seconds (supplied by the caller; 0 when not measured).
    pub wall_time_s: f64,
    /// The localisation-check demo.
    pub demo: DemoSummary,
    /// The Table 1 analog.
    pub table1: Table1Summary,
    /// The lost robot.
    pub lost_robot: LostSummary,
    /// The kidnap suite on a stale map.
    pub kidnap: KidnapSummary,
    /// The kidnap suite on the current world's map (absent if not run).
    pub kidnap_best_case: Option<KidnapSummary>,
    /// The parameters.
    pub params: RecoveryParams,
}

/// Everything the experiments produced.
#[derive(Clone, Debug, PartialEq)]
pub struct RecoveryResults {
    /// The summary.
    pub summary: RecoverySummary,
    /// The demo's processed steps.
    pub demo_timeline: Vec<TimelineSample>,
    /// Table 1 runs.
    pub table1_runs: Vec<Table1Run>,
    /// Lost-robot runs.
    pub lost_runs: Vec<LostRun>,
    /// Kidnap trials, both cases.
    pub trials: Vec<KidnapTrial>,
}

/// Progress reports of [`run_recovery`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// Worlds generated and M_1 built.
    Prepared,
    /// One of demo, Table 1, lost robot done.
    Experiment,
    /// One kidnap trial (one case) done.
    Trial,
}

/// Runs every experiment with `seed` in W_1 = `w1`. `wall_time_s` of the summary is 0 (the
/// caller sets it).
pub fn run_recovery(
    w1: &World,
    params: &RecoveryParams,
    seed: u64,
    progress: &(dyn Fn(Progress) + Sync),
) -> Result<RecoveryResults, ExperimentError> {
    params.validate()?;
    let setup = prepare(w1, params, seed)?;
    progress(Progress::Prepared);
    let (demo, demo_timeline) = run_demo(&setup, params, seed)?;
    progress(Progress::Experiment);
    let (table1, table1_runs) = run_table1(&setup, params, seed)?;
    progress(Progress::Experiment);
    let (lost_robot, lost_runs) = run_lost_robot(&setup, params, seed)?;
    progress(Progress::Experiment);
    let trials = run_kidnap_suite(&setup, params, seed, &|| progress(Progress::Trial))?;
    let summary = RecoverySummary {
        tool: format!("mapkeeper-scenario {}", env!("CARGO_PKG_VERSION")),
        seed,
        wall_time_s: 0.0,
        demo,
        table1,
        lost_robot,
        kidnap: summarise_kidnap(MapCase::Stale, &trials, &params.kidnap),
        kidnap_best_case: params.kidnap.best_case.then(|| summarise_kidnap(MapCase::Best, &trials, &params.kidnap)),
        params: params.clone(),
    };
    Ok(RecoveryResults { summary, demo_timeline, table1_runs, lost_runs, trials })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_are_in_range_and_seeded() {
        let p = RecoveryParams::default();
        for t in 0..50 {
            let d = draw_trial(&p, 3, t);
            assert_eq!(d, draw_trial(&p, 3, t));
            assert!((2..=p.kidnap.stale_max_world).contains(&d.world));
            assert!((0.5..=3.0).contains(&d.displacement_m));
            assert!(d.yaw_rad.abs() <= 45f64.to_radians());
            assert!((3.0..=6.0).contains(&d.kidnap_s));
        }
        assert_ne!(draw_trial(&p, 3, 0), draw_trial(&p, 4, 0));
    }

    #[test]
    fn bad_params_are_refused() {
        let mut p = RecoveryParams::default();
        p.kidnap.min_displacement_m = 4.0;
        assert!(p.validate().is_err());
        let mut p = RecoveryParams::default();
        p.kidnap.bin_edges_m = vec![1.0, 1.0];
        assert!(p.validate().is_err());
        let mut p = RecoveryParams::default();
        p.demo.world = 1;
        assert!(p.validate().is_err());
        assert!(RecoveryParams::default().validate().is_ok());
    }

    /// Values TOML accepts (`inf`, `nan`, 1e308) that would make a draw's range of non-finite
    /// width (rand panics) are refused by name before any draw.
    #[test]
    fn non_finite_routes_and_huge_angles_are_refused_by_name() {
        let refusal = |p: &RecoveryParams| p.validate().expect_err("refused").to_string();
        let mut p = RecoveryParams::default();
        p.tour.waypoints[1][0] = f64::INFINITY;
        let e = refusal(&p);
        assert!(e.contains("tour") && e.contains("waypoints[1]: must be finite"), "{e}");
        let mut p = RecoveryParams::default();
        p.exploration_route.waypoints[0][1] = f64::NAN;
        let e = refusal(&p);
        assert!(e.contains("exploration_route") && e.contains("waypoints[0]: must be finite"), "{e}");
        let mut p = RecoveryParams::default();
        p.tour.waypoints = vec![[0.0, 0.0], [1e308, 0.0], [-1e308, 0.0]];
        let e = refusal(&p);
        assert!(e.contains("tour") && e.contains("length must be finite"), "{e}");
        let mut p = RecoveryParams::default();
        p.kidnap.max_yaw_rad = 1e308;
        let e = refusal(&p);
        assert!(e.contains("kidnap.max_yaw_rad") && e.contains("at most 2π (a full turn), got 1e308"), "{e}");
        p.kidnap.max_yaw_rad = std::f64::consts::TAU;
        p.validate().expect("a turn of up to a full turn is accepted");
        for t in 0..20 {
            assert!(draw_trial(&p, 1, t).yaw_rad.abs() <= std::f64::consts::TAU);
        }
    }
}
