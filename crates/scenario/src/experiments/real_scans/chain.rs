//! Passes of a real log as worlds (issue 52, items 2 and 3): the log replayed as W_2 … W_K,
//! each pass localising on M_{k-1} and updating it into M_k, as `validate` chains worlds, and
//! every M_k scored against G, the map at the reference poses, over the cells the log observes.
//!
//! The place did not change between passes, only the map did: M_k should converge towards G
//! and never decay. Scores per pass ([`PassScores`]): CC, MS and OPDF of M_k against G over
//! G's known cells ([`observed_cells`]); the fresh map F_k (the pass's scans alone at the poses
//! the updater was given, mapped as G was); structure retention (cells occupied in M_1 and G
//! that M_k keeps); the share of each edit class's cells M_k has as G has them; the
//! localiser's error against the reference. The oracle M*_k (G on every observed cell, M_{k-1}
//! elsewhere) is the ceiling: every pass observes the same cells, so it is G on the scored
//! cells and scores 100 on each metric, by construction.

use super::edits::StaleMap;
use crate::experiments::ExperimentError;
use crate::experiments::reference::{ErrorStats, MAP_POSE_GAP_NS, error_stats};
use mapkeeper_grid::metrics::erosion::{ChangeCells, ClassShares, StructureMask};
use mapkeeper_grid::metrics::{MetricParams, map_metrics_in};
use mapkeeper_grid::{CellState, OccupancyGrid};
use mapkeeper_harness::jobs::map::{MapLogParams, map_log};
use mapkeeper_harness::jobs::update::{PoseInput, update_log};
use mapkeeper_harness::{DEFAULT_SYNC_WINDOW_NS, LogSource, NoClock, OdometryAt, ReplayOptions};
use mapkeeper_localiser::FilterParams;
use mapkeeper_sensor::{LogRecord, SensorLog, StampedPose, TruePose};
use mapkeeper_updater::UpdaterParams;
use serde::Serialize;

/// Where the poses given to the updater come from on every pass.
#[derive(Clone, Debug, PartialEq)]
pub enum PoseSourceConfig {
    /// The log's reference poses.
    Reference,
    /// A localiser on M_{k-1}, from the log's first reference pose with its initial covariance.
    Localiser {
        /// Its name in tables (`mapkeeper-real`, `amcl`).
        name: String,
        /// Its parameters.
        params: Box<FilterParams>,
    },
}

impl PoseSourceConfig {
    /// Its name in tables: `reference` or the localiser's.
    pub fn name(&self) -> &str {
        match self {
            PoseSourceConfig::Reference => "reference",
            PoseSourceConfig::Localiser { name, .. } => name,
        }
    }
}

/// CC, MS and OPDF of a map against G over the observed cells, percent.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct MapScores {
    /// Cross-correlation.
    pub cc: f64,
    /// Map score.
    pub ms: f64,
    /// Occupied picture-distance function.
    pub opdf: f64,
}

/// The share of each edit class's cells a map has as G has them, percent (`None`: the stale
/// map has no cell of that class).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Restored {
    /// Structure M_1 lacked.
    pub added: Option<f64>,
    /// Boxes M_1 had and the place lacks.
    pub removed: Option<f64>,
    /// Both places of moved items.
    pub moved: Option<f64>,
}

impl Restored {
    fn of(s: &ClassShares) -> Self {
        Self { added: s.added.percent(), removed: s.removed.percent(), moved: s.moved.percent() }
    }
}

/// One pass: M_k's scores and what the pass did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PassScores {
    /// k in W_k (2 … K).
    pub pass: usize,
    /// M_k against G.
    #[serde(flatten)]
    pub scores: MapScores,
    /// The fresh map F_k against G (the pass's scans alone, at the updater's poses).
    pub fresh: MapScores,
    /// Cells occupied in M_1 and G that M_k keeps, percent.
    pub retention: f64,
    /// Each edit class's cells M_k has as G has them.
    pub restored: Restored,
    /// The poses' error against the reference (`None` for the reference poses).
    pub pose_error: Option<ErrorStats>,
    /// Verdicts: Update, Suspend, Lost.
    pub verdicts: (u64, u64, u64),
    /// Lost episodes of the localiser and how many pose updating ended.
    pub lost_episodes: u64,
    /// Cells that differ between M_{k-1} and M_k.
    pub cells_changed: usize,
}

/// One chain: a log, an edit seed, an updater preset, a pose source.
#[derive(Clone, Debug, Serialize)]
pub struct ChainResult {
    /// The log's name.
    pub log: String,
    /// The edit seed (the stale map's).
    pub edit_seed: u64,
    /// The updater preset.
    pub preset: String,
    /// The pose source: `reference`, `mapkeeper-real`, `amcl`.
    pub poses: String,
    /// M_1 against G.
    pub m1: MapScores,
    /// M_K against G (the last pass; M_1's with no pass).
    #[serde(rename = "final")]
    pub last: MapScores,
    /// The last pass's fresh map F_K against G.
    pub fresh: MapScores,
    /// The oracle M*_k against G (the ceiling).
    pub oracle: MapScores,
    /// Cells occupied in M_1 and G that M_K keeps, percent.
    pub retention: f64,
    /// Each edit class's cells M_K has as G has them.
    pub restored: Restored,
    /// Cells occupied in M_1 and G (the retention's denominator).
    pub structure_cells: u64,
    /// Observed cells of each class: (added, removed, moved).
    pub class_cells: (u64, u64, u64),
    /// Pass 2 … K.
    pub per_pass: Vec<PassScores>,
    /// The maps M_2 … M_K (kept for the report's figures when asked).
    #[serde(skip)]
    pub maps: Vec<OccupancyGrid>,
}

/// What every chain of one log and one edit seed shares: G, the stale map and what is scored.
#[derive(Clone, Debug)]
pub struct ChainSetup<'a> {
    /// The log's name.
    pub name: &'a str,
    /// The log.
    pub log: &'a SensorLog,
    /// G.
    pub truth_map: &'a OccupancyGrid,
    /// M_1 and its edits.
    pub stale: &'a StaleMap,
    /// The edit seed.
    pub edit_seed: u64,
    /// How G was mapped (the fresh maps are mapped the same way, on G's grid).
    pub mapper: &'a MapLogParams,
    /// The metrics' parameters.
    pub metrics: MetricParams,
}

/// The cells G observed: free or occupied in G.
pub fn observed_cells(truth_map: &OccupancyGrid) -> Vec<bool> {
    truth_map.cells().iter().map(|&c| c != CellState::Unknown).collect()
}

/// The oracle M*: `map` with G's state on every cell G observed.
pub fn oracle_map(map: &OccupancyGrid, truth_map: &OccupancyGrid) -> OccupancyGrid {
    let mut m = map.clone();
    for (c, &t) in m.cells_mut().iter_mut().zip(truth_map.cells()) {
        if t != CellState::Unknown {
            *c = t;
        }
    }
    m
}

fn chain_error(s: &ChainSetup<'_>, what: impl std::fmt::Display) -> ExperimentError {
    ExperimentError::Invalid(format!("{} (edit seed {}): {what}", s.name, s.edit_seed))
}

/// How a pass replays the log: odometry interpolated at each step, unsynchronised lidars
/// grouped as `mapkeeper update` groups them (the real-data experiment's updater runs).
fn pass_options() -> ReplayOptions {
    ReplayOptions {
        odometry_at: OdometryAt::Interpolated,
        sync_window_ns: DEFAULT_SYNC_WINDOW_NS,
        ..ReplayOptions::default()
    }
}

/// How G and the fresh maps are replayed: a scan is mapped at a pose at most
/// [`MAP_POSE_GAP_NS`] from it (the real-data experiment's rule).
pub fn map_options() -> ReplayOptions {
    ReplayOptions { max_truth_gap_ns: MAP_POSE_GAP_NS, ..ReplayOptions::default() }
}

/// `log` with its truth records replaced by `poses` (the map at those poses is the fresh map).
fn with_poses(log: &SensorLog, poses: &[StampedPose]) -> SensorLog {
    let mut out = SensorLog { header: log.header.clone(), records: Vec::with_capacity(log.records.len()) };
    out.records.extend(log.records.iter().filter(|r| !matches!(r, LogRecord::Truth(_))).cloned());
    out.records.extend(poses.iter().map(|p| LogRecord::Truth(TruePose { stamp_ns: p.stamp_ns, pose_in_map: p.pose })));
    out
}

/// Runs one chain: `passes` passes (W_2 … W_{passes+1}) of `preset` with `poses`; `seed`
/// seeds the localiser's streams (one per pass). `keep_maps` keeps M_2 … M_K.
pub fn run_chain(
    s: &ChainSetup<'_>,
    preset: &str,
    poses: &PoseSourceConfig,
    passes: usize,
    seed: u64,
    keep_maps: bool,
) -> Result<ChainResult, ExperimentError> {
    let updater = UpdaterParams::preset(preset).map_err(|e| chain_error(s, e))?;
    let observed = observed_cells(s.truth_map);
    let score = |m: &OccupancyGrid| -> Result<MapScores, ExperimentError> {
        let r = map_metrics_in(m, s.truth_map, &observed, &s.metrics).map_err(|e| chain_error(s, e))?;
        Ok(MapScores { cc: r.cc, ms: r.ms, opdf: r.opdf })
    };
    let m1 = &s.stale.map;
    let change =
        ChangeCells::new(m1, s.truth_map, &observed, Some(&s.stale.footprints)).map_err(|e| chain_error(s, e))?;
    let structure = StructureMask::new(m1, s.truth_map).map_err(|e| chain_error(s, e))?;
    let options = pass_options();
    let source = || LogSource::new(s.log.clone(), s.name.to_string(), options);
    let truth = source().truth().to_vec();
    let mut result = ChainResult {
        log: s.name.to_string(),
        edit_seed: s.edit_seed,
        preset: preset.to_string(),
        poses: poses.name().to_string(),
        m1: score(m1)?,
        last: score(m1)?,
        fresh: score(m1)?,
        oracle: score(&oracle_map(m1, s.truth_map))?,
        retention: 100.0,
        restored: Restored::of(&change.score(m1).map_err(|e| chain_error(s, e))?),
        structure_cells: structure.count(),
        class_cells: {
            use mapkeeper_grid::metrics::erosion::ChangeClass::{Added, Moved, Removed};
            (change.cells(Added), change.cells(Removed), change.cells(Moved))
        },
        per_pass: Vec::new(),
        maps: Vec::new(),
    };
    let mut map = m1.clone();
    for k in 2..=passes + 1 {
        let input = match poses {
            PoseSourceConfig::Reference => PoseInput::LoggedTruth,
            PoseSourceConfig::Localiser { params, .. } => PoseInput::Localise {
                params: params.clone(),
                seed: mapkeeper_common::stream_seed(seed, &format!("real-scans/pass-{k}")),
                init: None,
            },
        };
        let run = update_log(source(), map.clone(), updater.clone(), input, &NoClock, &mut [])
            .map_err(|e| chain_error(s, format!("pass {k}: {e}")))?;
        let fresh_log = with_poses(s.log, &run.poses);
        let fresh_source = LogSource::new(fresh_log, s.name.to_string(), map_options());
        let fresh = map_log(fresh_source, Some(*s.truth_map.geometry()), s.mapper)
            .map_err(|e| chain_error(s, format!("pass {k}, fresh map: {e}")))?
            .map;
        let cells_changed = map.cells().iter().zip(run.map.cells()).filter(|(a, b)| a != b).count();
        let pose_error = match poses {
            PoseSourceConfig::Reference => None,
            PoseSourceConfig::Localiser { .. } => Some(error_stats(&run.poses, &truth).0),
        };
        result.per_pass.push(PassScores {
            pass: k,
            scores: score(&run.map)?,
            fresh: score(&fresh)?,
            retention: structure.retention(&run.map).map_err(|e| chain_error(s, e))?.percent().unwrap_or(100.0),
            restored: Restored::of(&change.score(&run.map).map_err(|e| chain_error(s, e))?),
            pose_error,
            verdicts: (run.stats.updates, run.stats.suspends, run.stats.losts),
            lost_episodes: run.lost_episodes.len() as u64,
            cells_changed,
        });
        map = run.map;
        if keep_maps {
            result.maps.push(map.clone());
        }
    }
    if let Some(p) = result.per_pass.last() {
        (result.last, result.fresh, result.retention, result.restored) = (p.scores, p.fresh, p.retention, p.restored);
    }
    Ok(result)
}

/// One pass of a log without reference poses: what it did, unscored.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct UnscoredPass {
    /// k in W_k.
    pub pass: usize,
    /// Verdicts: Update, Suspend, Lost.
    pub verdicts: (u64, u64, u64),
    /// Lost episodes of the localiser.
    pub lost_episodes: u64,
    /// Cells that became occupied.
    pub to_occupied: usize,
    /// Cells that became free.
    pub to_free: usize,
    /// Other changes (to or from unknown).
    pub other_changes: usize,
}

/// The passes of a log without reference poses on a given map.
#[derive(Clone, Debug, Serialize)]
pub struct UnscoredChain {
    /// The log's name.
    pub log: String,
    /// The updater preset.
    pub preset: String,
    /// The localiser.
    pub poses: String,
    /// Pass 2 … K.
    pub per_pass: Vec<UnscoredPass>,
}

/// The passes of `log` (no reference poses) from `map`, each localising on M_{k-1} from the
/// localiser's global initialisation; what each changed. The reference cannot be a pose
/// source here.
pub fn run_unscored_chain(
    name: &str,
    log: &SensorLog,
    map: &OccupancyGrid,
    preset: &str,
    poses: &PoseSourceConfig,
    passes: usize,
    seed: u64,
) -> Result<UnscoredChain, ExperimentError> {
    let err = |what: String| ExperimentError::Invalid(format!("{name}: {what}"));
    let PoseSourceConfig::Localiser { params, .. } = poses else {
        return Err(err("no reference poses to give the updater".into()));
    };
    let updater = UpdaterParams::preset(preset).map_err(|e| err(e.to_string()))?;
    let options = pass_options();
    let mut out = UnscoredChain {
        log: name.to_string(),
        preset: preset.to_string(),
        poses: poses.name().to_string(),
        per_pass: Vec::new(),
    };
    let mut current = map.clone();
    for k in 2..=passes + 1 {
        let input = PoseInput::Localise {
            params: params.clone(),
            seed: mapkeeper_common::stream_seed(seed, &format!("real-scans/pass-{k}")),
            init: None,
        };
        let source = LogSource::new(log.clone(), name.to_string(), options);
        let run = update_log(source, current.clone(), updater.clone(), input, &NoClock, &mut [])
            .map_err(|e| err(format!("pass {k}: {e}")))?;
        let diff = current.diff(&run.map).map_err(|e| err(e.to_string()))?;
        let to_occupied = diff.iter().filter(|(_, _, b)| *b == CellState::Occupied).count();
        let to_free = diff.iter().filter(|(_, _, b)| *b == CellState::Free).count();
        out.per_pass.push(UnscoredPass {
            pass: k,
            verdicts: (run.stats.updates, run.stats.suspends, run.stats.losts),
            lost_episodes: run.lost_episodes.len() as u64,
            to_occupied,
            to_free,
            other_changes: diff.len() - to_occupied - to_free,
        });
        current = run.map;
    }
    Ok(out)
}

#[cfg(test)]
mod tests;
