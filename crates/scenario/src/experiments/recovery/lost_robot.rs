//! The lost robot: a 1.5 m start error; the check says Lost, pose updating recovers the pose, and
//! M_2 is compared with the map of the same run without the error.

use crate::experiments::ExperimentError;
use crate::experiments::scores::Scores;
use crate::experiments::scores::{mean_scores, scores};
use crate::stats::{mean, median};
use mapkeeper_closed_loop::controls::{Kidnap, TrackSample};
use mapkeeper_closed_loop::runner::WorldRun;
use mapkeeper_closed_loop::setup::{Drive, Setup, recovery_time};
use mapkeeper_closed_loop::trials::{Trials, run_trials};
use mapkeeper_grid::metrics::map_metrics;
use mapkeeper_updater::UpdaterParams;
use serde::{Deserialize, Serialize};

use super::table1::start_kidnap;
use mapkeeper_closed_loop::setup::params::RecoveryParams;

/// One lost-robot run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LostRun {
    /// Run index.
    pub run: usize,
    /// Direction of the start error, radians.
    pub direction_rad: f64,
    /// The check said Lost.
    pub detected: bool,
    /// First Lost, seconds.
    pub first_lost_s: Option<f64>,
    /// Poses returned by pose updating.
    pub recoveries: usize,
    /// Pose recoveries refused.
    pub failed_recoveries: u64,
    /// Largest position error of a returned pose, metres.
    pub worst_recovery_error_m: Option<f64>,
    /// The chain localiser's error came under the criterion for good, at this time, seconds.
    pub recovered_s: Option<f64>,
    /// The chain localiser's final error, metres.
    pub final_error_m: Option<f64>,
    /// M_2/G_2 of this run.
    pub with_error: Scores,
    /// M_2/G_2 of the same run without the start error.
    pub without_error: Scores,
    /// M_2/G_2 of this run with `always-update` (no check, no pose updating).
    pub always_update_with_error: Scores,
    /// OPDF between M_2 of this run and M_2 without the error.
    pub opdf_vs_without_error: f64,
    /// Cells that differ between the two maps.
    pub cells_differing: u64,
    /// CC, MS and OPDF within the tolerance of the run without error.
    pub not_corrupted: bool,
}

/// `summary.json` `lost_robot`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LostSummary {
    /// i of W_i.
    pub world: usize,
    /// Initial error, metres.
    pub start_error_m: f64,
    /// Runs.
    pub runs: usize,
    /// Runs in which the check said Lost.
    pub detected: usize,
    /// Runs recovered (error under the criterion for good, by pose updating or the localiser).
    pub recovered: usize,
    /// Runs recovered with at least one pose from pose updating.
    pub recovered_by_pose_updating: usize,
    /// Median recovery time, seconds.
    pub median_recovery_s: Option<f64>,
    /// Poses returned by pose updating that were wrong (error above the criterion).
    pub wrong_recoveries: usize,
    /// Mean M_2/G_2 with the error.
    pub with_error: Scores,
    /// Mean M_2/G_2 without it.
    pub without_error: Scores,
    /// Mean M_2/G_2 with the error and `always-update`.
    pub always_update_with_error: Scores,
    /// Mean OPDF between the maps with and without the error.
    pub opdf_vs_without_error: f64,
    /// Every run's map is within the tolerance of the run without error.
    pub not_corrupted: bool,
}

/// The lost-robot runs as [`Trials`]: per error direction, three jobs on the same drive: with
/// the start error, without it (the reference), and with it under `always-update`.
struct LostTrials<'a> {
    drive: Drive<'a>,
    params: &'a RecoveryParams,
    seed: u64,
}

impl Trials for LostTrials<'_> {
    /// (run, kind: 0 with the error, 1 without, 2 with it and `always-update`).
    type Job = (usize, usize);
    /// The start error's direction and the run.
    type Outcome = (f64, WorldRun);
    type Summary = (LostSummary, Vec<LostRun>);

    fn draw(&self) -> Vec<(usize, usize)> {
        (0..self.params.lost.runs).flat_map(|r| [(r, 0), (r, 1), (r, 2)]).collect()
    }

    fn run(&self, (r, k): (usize, usize), progress: &(dyn Fn() + Sync)) -> Result<(f64, WorldRun), ExperimentError> {
        let l = &self.params.lost;
        let label = format!("lost-{r:03}");
        let (dir, kid) = start_kidnap(
            self.seed,
            &format!("{label}/error"),
            l.start_error_m,
            l.init_sigma_xy_m,
            l.init_sigma_yaw_rad,
        );
        let mut rp = self.params.runner.clone();
        rp.record_timeline = true;
        match k {
            0 => rp.kidnap = Some(kid),
            1 => rp.kidnap = Some(Kidnap { dx_m: 0.0, dy_m: 0.0, ..kid }),
            _ => {
                rp.kidnap = Some(kid);
                rp.updater = UpdaterParams::always_update();
            }
        }
        let run = self.drive.run(&rp, self.seed, &label)?;
        progress();
        Ok((dir, run))
    }

    fn summarise(&self, results: Vec<(f64, WorldRun)>) -> Result<(LostSummary, Vec<LostRun>), ExperimentError> {
        let (l, c, params) = (&self.params.lost, &self.params.success, self.params);
        let g = self.drive.truth;
        let mut runs = Vec::with_capacity(l.runs);
        for (r, triple) in results.chunks(3).enumerate() {
            let [(dir, err), (_, reference), (_, au)] = triple else { continue };
            let track = err.kidnap.as_ref().map(|k| k.track.as_slice()).unwrap_or_default();
            let recs = err.kidnap.as_ref().map(|k| k.recoveries.as_slice()).unwrap_or_default();
            let with_error = scores(&err.map, g, &params.metrics)?;
            let without_error = scores(&reference.map, g, &params.metrics)?;
            let tol = l.corruption_tolerance_pct;
            runs.push(LostRun {
                run: r,
                direction_rad: *dir,
                detected: err.updater.lost > 0,
                first_lost_s: err.kidnap.as_ref().and_then(|k| k.first_lost_s),
                recoveries: recs.len(),
                failed_recoveries: err.kidnap.as_ref().map_or(0, |k| k.failed_recoveries),
                worst_recovery_error_m: recs.iter().map(|s| s.error_m).reduce(f64::max),
                recovered_s: recovery_time(track, c),
                final_error_m: track.last().map(|s| s.error_m),
                with_error,
                without_error,
                always_update_with_error: scores(&au.map, g, &params.metrics)?,
                opdf_vs_without_error: map_metrics(&err.map, &reference.map, &params.metrics)?.opdf,
                cells_differing: err.map.cells().iter().zip(reference.map.cells()).filter(|(a, b)| a != b).count()
                    as u64,
                not_corrupted: with_error.cc >= without_error.cc - tol
                    && with_error.ms >= without_error.ms - tol
                    && with_error.opdf >= without_error.opdf - tol,
            });
        }
        let is_wrong = |s: &TrackSample| !c.holds(s.error_m, s.yaw_error_rad);
        let wrong_recoveries = results
            .chunks(3)
            .filter_map(|t| t.first())
            .filter_map(|(_, r)| r.kidnap.as_ref())
            .map(|k| k.recoveries.iter().filter(|s| is_wrong(s)).count())
            .sum();
        let summary = LostSummary {
            world: l.world,
            start_error_m: l.start_error_m,
            runs: runs.len(),
            detected: runs.iter().filter(|r| r.detected).count(),
            recovered: runs.iter().filter(|r| r.recovered_s.is_some()).count(),
            recovered_by_pose_updating: runs.iter().filter(|r| r.recovered_s.is_some() && r.recoveries > 0).count(),
            median_recovery_s: median(runs.iter().filter_map(|r| r.recovered_s).collect()),
            wrong_recoveries,
            with_error: mean_scores(runs.iter().map(|r| &r.with_error)),
            without_error: mean_scores(runs.iter().map(|r| &r.without_error)),
            always_update_with_error: mean_scores(runs.iter().map(|r| &r.always_update_with_error)),
            opdf_vs_without_error: mean(runs.iter().map(|r| r.opdf_vs_without_error)),
            not_corrupted: !runs.is_empty() && runs.iter().all(|r| r.not_corrupted),
        };
        Ok((summary, runs))
    }
}

/// The lost robot: per run and the summary.
pub fn run_lost_robot(
    setup: &Setup,
    params: &RecoveryParams,
    seed: u64,
) -> Result<(LostSummary, Vec<LostRun>), ExperimentError> {
    let l = &params.lost;
    let drive = setup.drive(
        l.world,
        setup.initial_map(params.initial_map),
        &params.tour,
        l.tour_position_m,
        l.route_length_m,
    )?;
    run_trials(&LostTrials { drive, params, seed }, &|| {})
}
