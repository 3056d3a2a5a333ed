//! Real data (issue 14, item 4): for each recorded log with reference poses (the CARMEN logs of
//! `../shared/data/carmen/`, or a user's own), build the map at the reference poses, localise
//! with the raw odometry from the reference's first pose, score the estimate against the
//! reference, and run the updater over the log on the log's own map (`docs/real-data.md`).
//!
//! Each localiser configuration is scored on every log; the figures say where a log's
//! odometry contradicts its reference (steps whose odometry increment differs from the
//! reference increment by more than [`DISAGREEMENT_M`]), which is where a filter that trusts
//! odometry loses track.

pub mod report;

pub use crate::experiments::reference::{
    Dataset, ErrorStats, LOST_M, MAP_POSE_GAP_NS, TARGET_MAX_M, TARGET_RMSE_M, error_stats,
};

use crate::experiments::ExperimentError;
use crate::stats::{median, percentile};
use mapkeeper_closed_loop::trials::{Trials, run_trials};
use mapkeeper_grid::{OccupancyGrid, Pose2, angle_diff};
use mapkeeper_harness::jobs::localise::localise_log;
use mapkeeper_harness::jobs::map::{MapLogParams, map_log};
use mapkeeper_harness::jobs::update::{PoseInput, update_log};
use mapkeeper_harness::{DEFAULT_SYNC_WINDOW_NS, LogSource, NoClock, OdometryAt, ReplayOptions};
use mapkeeper_localiser::{BeamSelection, BeamSet, FilterParams, ScanMatchParams, ScanMatcher};
use mapkeeper_sensor::{SensorLog, StampedPose, interpolate};
use mapkeeper_updater::UpdaterParams;
use serde::Serialize;

/// The overrides of the `odometry-tuned` localiser configuration, the second release's
/// configuration for real logs (TOML over the `mapkeeper` preset; odometry-driven, no scan
/// matching; tuned on the Intel log only).
pub const ODOMETRY_TUNED_LOCALISER_TOML: &str = include_str!("../../../params/odometry_tuned_localiser.toml");

/// A step whose odometry increment differs from the reference increment by more than this
/// contradicts the reference, metres.
pub const DISAGREEMENT_M: f64 = 0.1;

/// A localiser configuration.
#[derive(Clone, Debug)]
pub struct LocaliserConfig {
    /// Its name in tables.
    pub name: String,
    /// What it is (preset, overrides, what it was tuned on).
    pub description: String,
    /// Its parameters.
    pub params: FilterParams,
}

/// What to run.
#[derive(Clone, Debug)]
pub struct RealDataParams {
    /// The mapper building each log's map at its reference poses.
    pub mapper: MapLogParams,
    /// The localiser configurations, each scored on every log.
    pub localisers: Vec<LocaliserConfig>,
    /// The updater presets run over each log on its own map.
    pub updater_presets: Vec<String>,
    /// The localiser seeds: each configuration runs once per seed on every log.
    pub seeds: Vec<u64>,
    /// The scan matcher measuring how well the reference agrees with its own map.
    pub reference_fit: ScanMatchParams,
}

/// One localiser configuration on one log, over the seeds.
#[derive(Clone, Debug, Serialize)]
pub struct LocaliserResult {
    /// The configuration's name.
    pub localiser: String,
    /// The error of each seed's run, in seed order.
    pub by_seed: Vec<ErrorStats>,
    /// The mean over the seeds of the position RMSE, metres.
    pub mean_rmse_m: f64,
    /// The mean over the seeds of the largest error, metres.
    pub mean_max_m: f64,
    /// Seeds whose run met both targets.
    pub seeds_meeting_targets: usize,
    /// Per estimate of the first seed's run: (time s, position error m, yaw error deg).
    #[serde(skip)]
    pub series: Vec<(f64, f64, f64)>,
    /// The first seed's estimates.
    #[serde(skip)]
    pub estimates: Vec<StampedPose>,
}

/// The updater over one log on the log's own map.
#[derive(Clone, Debug, Serialize)]
pub struct UpdaterResult {
    /// The preset.
    pub preset: String,
    /// The poses given to it: `reference` or the name of a localiser configuration.
    pub poses: String,
    /// Steps processed by the updater.
    pub processed: u64,
    /// Verdicts: Update, Suspend, Lost.
    pub updates: u64,
    /// Suspend verdicts.
    pub suspends: u64,
    /// Lost verdicts.
    pub losts: u64,
    /// Cells that became occupied.
    pub to_occupied: usize,
    /// Cells that became free.
    pub to_free: usize,
    /// Other changes (to or from unknown).
    pub other_changes: usize,
    /// With the localiser's poses: how many of the changed cells the reference-pose run of the
    /// same preset changed the same way (the rest are owed to the estimate's error, or to what
    /// only these poses saw). `None` for the reference-pose run itself.
    pub same_as_reference: Option<usize>,
    /// The updated map.
    #[serde(skip)]
    pub map: Option<OccupancyGrid>,
}

/// Where the log's odometry contradicts its reference.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Disagreement {
    /// Steps (consecutive scans) compared.
    pub steps: usize,
    /// Steps whose odometry and reference increments differ by more than [`DISAGREEMENT_M`].
    pub contradicting: usize,
    /// The longest run of consecutive contradicting steps.
    pub longest_run: usize,
    /// When that run starts, seconds.
    pub longest_run_start_s: f64,
    /// Per step: (time s, |odometry increment − reference increment| m).
    #[serde(skip)]
    pub series: Vec<(f64, f64)>,
}

/// How well the reference poses agree with the map built from them: each scan is matched against
/// that map from its reference pose by the scan matcher of the `mapkeeper-real` localiser
/// ([`ScanMatchParams`] as given). The distance each accepted match moves from the reference is
/// the disagreement between the reference and its own map: a localiser that follows the map
/// cannot agree with the reference much better than this.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReferenceFit {
    /// Scans with a reference pose and at least one usable beam.
    pub scans: usize,
    /// Of these, the scans whose match was accepted.
    pub accepted: usize,
    /// Median distance from the reference to the match, metres (accepted matches).
    pub median_m: f64,
    /// RMS distance, metres.
    pub rms_m: f64,
    /// 95th percentile, metres.
    pub p95_m: f64,
    /// RMS yaw difference, degrees.
    pub yaw_rms_deg: f64,
}

/// One log's results.
#[derive(Clone, Debug, Serialize)]
pub struct DatasetResult {
    /// Its name.
    pub name: String,
    /// Its source.
    pub source: String,
    /// Scans.
    pub scans: usize,
    /// From the first to the last scan, seconds.
    pub duration_s: f64,
    /// Length of the reference path, metres.
    pub path_m: f64,
    /// The map's size, cells (width, height) and occupied cells.
    pub map_cells: (usize, usize, usize),
    /// Where odometry contradicts the reference.
    pub disagreement: Disagreement,
    /// How well the reference agrees with the map built from it.
    pub reference_fit: ReferenceFit,
    /// Each localiser configuration.
    pub localisers: Vec<LocaliserResult>,
    /// Each updater run.
    pub updaters: Vec<UpdaterResult>,
    /// The map at the reference poses.
    #[serde(skip)]
    pub map: Option<OccupancyGrid>,
    /// The reference at the scans.
    #[serde(skip)]
    pub reference: Vec<StampedPose>,
}

/// The experiment as [`Trials`]: one job per log (its map, every localiser configuration and
/// seed, then the updaters), the logs on the caller's rayon pool; the results in the logs' order.
struct RealDataTrials<'a> {
    datasets: &'a [Dataset],
    params: &'a RealDataParams,
}

impl Trials for RealDataTrials<'_> {
    /// The log's index.
    type Job = usize;
    type Outcome = DatasetResult;
    type Summary = Vec<DatasetResult>;

    fn draw(&self) -> Vec<usize> {
        (0..self.datasets.len()).collect()
    }

    fn run(&self, d: usize, progress: &(dyn Fn() + Sync)) -> Result<DatasetResult, ExperimentError> {
        let r = run_dataset(&self.datasets[d], self.params);
        progress();
        r
    }

    fn summarise(&self, results: Vec<DatasetResult>) -> Result<Vec<DatasetResult>, ExperimentError> {
        Ok(results)
    }
}

/// Runs the experiment on every dataset (in parallel on the caller's rayon pool; the results
/// in the datasets' order, the same whatever the thread count); `progress` after each.
pub fn run_real_data(
    datasets: &[Dataset],
    params: &RealDataParams,
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<DatasetResult>, ExperimentError> {
    if params.seeds.is_empty() {
        return Err(ExperimentError::Invalid("real-data: no localiser seed".into()));
    }
    run_trials(&RealDataTrials { datasets, params }, progress)
}

/// An error of one dataset (or preset) of the experiment, named.
fn dataset_error(name: &str, e: impl std::fmt::Display) -> ExperimentError {
    ExperimentError::Invalid(format!("{name}: {e}"))
}

fn run_dataset(d: &Dataset, params: &RealDataParams) -> Result<DatasetResult, ExperimentError> {
    let source = |options: ReplayOptions| LogSource::new(d.log.clone(), d.source.clone(), options);
    let replay = ReplayOptions::default();
    // The log's time-ordered tracks, read once.
    let (truth, odometry) = {
        let probe = source(replay);
        (probe.truth().to_vec(), probe.odometry().to_vec())
    };
    if truth.is_empty() {
        return Err(dataset_error(&d.name, "the log has no reference poses (truth records)"));
    }
    let map_options = ReplayOptions { max_truth_gap_ns: MAP_POSE_GAP_NS, ..replay };
    let map = map_log(source(map_options), None, &params.mapper).map_err(|e| dataset_error(&d.name, e))?.map;
    let mut scan_stamps: Vec<u64> = d.log.scans().map(|s| s.stamp_ns).collect();
    scan_stamps.sort_unstable();
    scan_stamps.dedup();
    let reference: Vec<StampedPose> = scan_stamps
        .iter()
        .filter_map(|&t| interpolate(&truth, t).map(|pose| StampedPose { stamp_ns: t, pose }))
        .collect();
    let disagreement = disagreement(&reference, &odometry);
    let reference_fit = reference_fit(&d.log, &truth, &map, params.reference_fit);
    let mut localisers = Vec::new();
    for c in &params.localisers {
        let mut r = LocaliserResult {
            localiser: c.name.clone(),
            by_seed: Vec::new(),
            mean_rmse_m: 0.0,
            mean_max_m: 0.0,
            seeds_meeting_targets: 0,
            series: Vec::new(),
            estimates: Vec::new(),
        };
        for (k, &seed) in params.seeds.iter().enumerate() {
            let (run, _) = localise_log(source(replay), &map, c.params, None, seed, &mut [])
                .map_err(|e| dataset_error(&d.name, e))?;
            let (error, series) = error_stats(&run.estimates, &truth);
            if k == 0 {
                (r.series, r.estimates) = (series, run.estimates);
            }
            r.by_seed.push(error);
        }
        let n = r.by_seed.len().max(1) as f64;
        r.mean_rmse_m = r.by_seed.iter().map(|e| e.rmse_m).sum::<f64>() / n;
        r.mean_max_m = r.by_seed.iter().map(|e| e.max_m).sum::<f64>() / n;
        r.seeds_meeting_targets = r.by_seed.iter().filter(|e| e.targets_met).count();
        localisers.push(r);
    }
    let estimate = localisers.last().map(|l| (l.localiser.clone(), l.estimates.clone()));
    let updaters = run_updaters(d, params, &map, estimate)?;
    let path_m = reference.windows(2).map(|w| w[0].pose.distance(&w[1].pose)).sum();
    let span = |v: &[u64]| v.last().zip(v.first()).map_or(0.0, |(b, a)| (b - a) as f64 * 1e-9);
    let g = map.geometry();
    Ok(DatasetResult {
        name: d.name.clone(),
        source: d.source.clone(),
        scans: d.log.scans().count(),
        duration_s: span(&scan_stamps),
        path_m,
        map_cells: (g.width(), g.height(), map.count(mapkeeper_grid::CellState::Occupied)),
        disagreement,
        reference_fit,
        localisers,
        updaters,
        map: Some(map),
        reference,
    })
}

/// The updater presets over the log on its own map, given the reference poses and then (if any)
/// the named estimate; the estimate's runs count the changes they share with the reference's.
fn run_updaters(
    d: &Dataset,
    params: &RealDataParams,
    map: &OccupancyGrid,
    estimate: Option<(String, Vec<StampedPose>)>,
) -> Result<Vec<UpdaterResult>, ExperimentError> {
    let options = ReplayOptions {
        odometry_at: OdometryAt::Interpolated,
        sync_window_ns: DEFAULT_SYNC_WINDOW_NS,
        ..ReplayOptions::default()
    };
    let mut updaters = Vec::new();
    for preset in &params.updater_presets {
        let up = UpdaterParams::preset(preset).map_err(|e| dataset_error(&d.name, e))?;
        let mut inputs = vec![("reference".to_string(), PoseInput::LoggedTruth)];
        if let Some((name, track)) = &estimate {
            inputs.push((name.clone(), PoseInput::Track(track.clone())));
        }
        let mut reference_run: Option<OccupancyGrid> = None;
        for (poses, input) in inputs {
            let source = LogSource::new(d.log.clone(), d.source.clone(), options);
            let r = update_log(source, map.clone(), up.clone(), input, &NoClock, &mut [])
                .map_err(|e| dataset_error(&d.name, e))?;
            let mut result = updater_result(preset, &poses, map, r.map, &r.stats)?;
            match (&reference_run, &result.map) {
                (Some(reference), Some(after)) => {
                    result.same_as_reference =
                        Some(same_changes(map, reference, after).map_err(|e| dataset_error(&d.name, e))?)
                }
                (None, Some(after)) => reference_run = Some(after.clone()),
                _ => {}
            }
            updaters.push(result);
        }
    }
    Ok(updaters)
}

fn updater_result(
    preset: &str,
    poses: &str,
    before: &OccupancyGrid,
    after: OccupancyGrid,
    stats: &mapkeeper_updater::UpdaterStats,
) -> Result<UpdaterResult, ExperimentError> {
    use mapkeeper_grid::CellState::{Free, Occupied};
    let diff = before.diff(&after).map_err(|e| dataset_error(preset, e))?;
    let to_occupied = diff.iter().filter(|(_, _, b)| *b == Occupied).count();
    let to_free = diff.iter().filter(|(_, _, b)| *b == Free).count();
    Ok(UpdaterResult {
        preset: preset.to_string(),
        poses: poses.to_string(),
        processed: stats.processed,
        updates: stats.updates,
        suspends: stats.suspends,
        losts: stats.losts,
        to_occupied,
        to_free,
        other_changes: diff.len() - to_occupied - to_free,
        same_as_reference: None,
        map: Some(after),
    })
}

/// The cells `after` changed from `before` to the same state as `reference` did.
fn same_changes(
    before: &OccupancyGrid,
    reference: &OccupancyGrid,
    after: &OccupancyGrid,
) -> Result<usize, mapkeeper_grid::GridError> {
    let reference: std::collections::HashSet<(mapkeeper_grid::CellCoord, mapkeeper_grid::CellState)> =
        before.diff(reference)?.into_iter().map(|(c, _, b)| (c, b)).collect();
    Ok(before.diff(after)?.into_iter().filter(|(c, _, b)| reference.contains(&(*c, *b))).count())
}

/// Matches every scan of `log` against `map` from the reference pose at its time
/// ([`ReferenceFit`]). The beams are chosen as the `mapkeeper-real` localiser chooses them
/// (`max_beams` per lidar, evenly over the valid readings).
pub fn reference_fit(log: &SensorLog, truth: &[StampedPose], map: &OccupancyGrid, sm: ScanMatchParams) -> ReferenceFit {
    let matcher = ScanMatcher::new(map, sm);
    let max_range = FilterParams::mapkeeper_real().laser_max_range_m;
    let mut beams = BeamSet::new();
    let (mut dist, mut yaw) = (Vec::new(), Vec::new());
    let mut scans = 0;
    for scan in log.scans() {
        let Some(at) = interpolate(truth, scan.stamp_ns) else { continue };
        beams.clear();
        if scan.validate().is_err()
            || beams.add_scan(scan, sm.max_beams, max_range, BeamSelection::EvenlyOverValid) == 0
        {
            continue;
        }
        scans += 1;
        if let Some(m) = matcher.match_scan(&at, beams.endpoints()).filter(|m| m.accepted) {
            dist.push(m.pose_in_map.distance(&at));
            yaw.push(angle_diff(m.pose_in_map.yaw, at.yaw).to_degrees());
        }
    }
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt();
    ReferenceFit {
        scans,
        accepted: dist.len(),
        median_m: median(dist.clone()).unwrap_or(0.0),
        rms_m: rms(&dist),
        p95_m: percentile(dist.clone(), 0.95).unwrap_or(0.0),
        yaw_rms_deg: rms(&yaw),
    }
}

/// Compares the odometry increment with the reference increment between consecutive scans.
pub fn disagreement(reference: &[StampedPose], odometry: &[StampedPose]) -> Disagreement {
    let at = |t: u64| interpolate(odometry, t);
    let mut series = Vec::new();
    let (mut contradicting, mut run, mut longest, mut longest_start, mut run_start) = (0, 0, 0, 0.0, 0.0);
    for w in reference.windows(2) {
        let (Some(o0), Some(o1)) = (at(w[0].stamp_ns), at(w[1].stamp_ns)) else { continue };
        let odo: Pose2 = o0.between(&o1);
        let refd: Pose2 = w[0].pose.between(&w[1].pose);
        let d = ((odo.x - refd.x).powi(2) + (odo.y - refd.y).powi(2)).sqrt();
        let t = w[1].stamp_ns as f64 * 1e-9;
        series.push((t, d));
        if d > DISAGREEMENT_M {
            contradicting += 1;
            if run == 0 {
                run_start = t;
            }
            run += 1;
            if run > longest {
                (longest, longest_start) = (run, run_start);
            }
        } else {
            run = 0;
        }
    }
    Disagreement {
        steps: series.len(),
        contradicting,
        longest_run: longest,
        longest_run_start_s: longest_start,
        series,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track(poses: &[(f64, f64)]) -> Vec<StampedPose> {
        poses
            .iter()
            .enumerate()
            .map(|(i, &(x, y))| StampedPose { stamp_ns: i as u64 * 1_000_000_000, pose: Pose2::new(x, y, 0.0) })
            .collect()
    }

    #[test]
    fn errors_and_targets() {
        let truth = track(&[(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (3.0, 0.0)]);
        let est = track(&[(0.0, 0.03), (1.0, -0.03), (2.0, 0.03), (3.0, 0.6)]);
        let (s, series) = error_stats(&est, &truth);
        assert_eq!(series.len(), 4);
        assert!((s.max_m - 0.6).abs() < 1e-12 && !s.targets_met);
        assert!((s.rmse_m - ((3.0 * 0.0009 + 0.36) / 4.0f64).sqrt()).abs() < 1e-12);
        assert!((s.lost_share - 0.25).abs() < 1e-12);
        let (s, _) = error_stats(&est[..3], &truth);
        assert!(s.targets_met && (s.rmse_m - 0.03).abs() < 1e-12);
    }

    #[test]
    fn disagreement_counts_contradicting_runs() {
        let reference = track(&[(0.0, 0.0), (0.1, 0.0), (0.2, 0.0), (0.1, 0.0), (0.0, 0.0), (0.1, 0.0)]);
        // The odometry goes forward all along: steps 3 and 4 (reference backwards) contradict.
        let odometry = track(&[(0.0, 0.0), (0.1, 0.0), (0.2, 0.0), (0.3, 0.0), (0.4, 0.0), (0.5, 0.0)]);
        let d = disagreement(&reference, &odometry);
        assert_eq!((d.steps, d.contradicting, d.longest_run), (5, 2, 2));
        assert!((d.longest_run_start_s - 3.0).abs() < 1e-12);
    }
}
