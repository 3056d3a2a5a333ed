//! Real scans, known truth (issue 52): the updater and pose recovery judged on real logs with
//! reference poses. G is the map at the reference poses; a seeded edit generator makes a stale
//! map M_1 of the real place ([`edits`]); the log replayed again and again is the chain of worlds
//! W_2 … W_K, each pass localising on M_{k-1} and updating it into M_k ([`chain`]); and a log
//! spliced so that the odometry carries no motion across a cut is a real kidnap ([`splice`],
//! [`kidnap`]). [`summary`] gathers the chains over the edit seeds; [`report`] writes the folder.
//!
//! A log without reference poses has no truth: given a map, it runs the passes on that map as
//! M_1 (no synthetic edits: without a reference path they could not be kept off the robot's
//! path) and reports what changed ([`UnscoredChain`]).

pub mod chain;
pub mod edits;
pub mod kidnap;
pub mod report;
pub mod splice;
pub mod summary;
#[cfg(test)]
mod test_logs;

use crate::experiments::ExperimentError;
use crate::experiments::reference::Dataset;
use chain::{ChainResult, ChainSetup, PoseSourceConfig, UnscoredChain, map_options, run_chain, run_unscored_chain};
use edits::{EditParams, StaleMap, stale_map};
use mapkeeper_closed_loop::trials::{Trials, run_trials};
use mapkeeper_grid::metrics::MetricParams;
use mapkeeper_grid::{CellState, OccupancyGrid, Point2};
use mapkeeper_harness::LogSource;
use mapkeeper_harness::jobs::map::{MapLogParams, map_log};
use rayon::prelude::*;
use serde::Serialize;
use summary::{ChainSummary, summarise};

/// What to run.
#[derive(Clone, Debug)]
pub struct RealScansParams {
    /// How G (and each pass's fresh map) is mapped.
    pub mapper: MapLogParams,
    /// How the stale map is made.
    pub edits: EditParams,
    /// The edit seeds: one stale map per seed and log.
    pub edit_seeds: Vec<u64>,
    /// K: the chain is W_1 (M_1) and the passes W_2 … W_K. At least 3 (pass 3 is the no-decay
    /// reference).
    pub worlds: usize,
    /// The updater presets.
    pub presets: Vec<String>,
    /// The pose sources.
    pub pose_sources: Vec<PoseSourceConfig>,
    /// The metrics' parameters.
    pub metrics: MetricParams,
    /// Keep the maps of every pass of the first edit seed (the report's figures).
    pub keep_maps: bool,
    /// The spliced kidnaps, on the first edit seed's stale map and on G (`None`: not run).
    pub kidnaps: Option<kidnap::RealKidnapParams>,
}

impl RealScansParams {
    /// Checks the run's shape (the presets, the seeds, K).
    pub fn validate(&self) -> Result<(), ExperimentError> {
        let bad = |name: &str, problem: &str| {
            Err(ExperimentError::InvalidParam(mapkeeper_common::ParamError::rule(name, problem)))
        };
        if !(3..=1000).contains(&self.worlds) {
            return bad("worlds", "K must be 3 to 1000 (W_1 is the stale map; pass 3 is the no-decay reference)");
        }
        if self.edit_seeds.is_empty() {
            return bad("edit_seeds", "at least one edit seed");
        }
        if self.presets.is_empty() || self.pose_sources.is_empty() {
            return bad("presets", "at least one updater preset and one pose source");
        }
        for p in &self.presets {
            mapkeeper_updater::UpdaterParams::preset(p)
                .map_err(|e| ExperimentError::Invalid(format!("updater preset '{p}': {e}")))?;
        }
        self.edits.validate().map_err(ExperimentError::InvalidParam)?;
        if let Some(k) = &self.kidnaps {
            k.validate().map_err(|e| ExperimentError::InvalidParam(e.within("kidnaps")))?;
        }
        Ok(())
    }
}

/// One log's stale map for one edit seed, as reported.
#[derive(Clone, Debug, Serialize)]
pub struct StaleSummary {
    /// The edit seed.
    pub edit_seed: u64,
    /// Edits made.
    pub edits: usize,
    /// Cells per class asked for: (added, removed, moved).
    pub target_cells: (usize, usize, usize),
    /// Cells per class made.
    pub made_cells: (usize, usize, usize),
    /// Cells of G's unknown space made free floor behind pieces of structure.
    pub floor_behind: usize,
    /// The edits.
    pub edit_list: Vec<edits::Edit>,
}

/// One log's results.
#[derive(Clone, Debug, Serialize)]
pub struct LogResult {
    /// Its name.
    pub name: String,
    /// Where it came from.
    pub source: String,
    /// Scans.
    pub scans: usize,
    /// The reference path's length, metres (0 without reference poses).
    pub path_m: f64,
    /// G's size: (width, height) cells, observed cells, occupied cells.
    pub map_cells: ((usize, usize), usize, usize),
    /// Why the log is not scored (no reference poses), if it is not.
    pub note: Option<String>,
    /// The stale map of each edit seed.
    pub stale: Vec<StaleSummary>,
    /// Every chain (edit seed × preset × pose source).
    pub chains: Vec<ChainResult>,
    /// The chains over the edit seeds, per preset and pose source.
    pub summaries: Vec<ChainSummary>,
    /// Without reference poses: the passes on the given map, unscored.
    pub unscored: Vec<UnscoredChain>,
    /// The spliced kidnaps (on the first edit seed's stale map and on G), if run.
    pub kidnaps: Option<kidnap::RealKidnapResults>,
    /// G (or the given map).
    #[serde(skip)]
    pub truth_map: Option<OccupancyGrid>,
    /// The first edit seed's M_1.
    #[serde(skip)]
    pub first_stale: Option<OccupancyGrid>,
}

/// A log and, for a log without reference poses, the map to start from.
#[derive(Clone, Debug)]
pub struct LogInput {
    /// The log.
    pub dataset: Dataset,
    /// The map a log without reference poses starts from (ignored for a log with them).
    pub map: Option<OccupancyGrid>,
}

/// G and the stale maps of one log.
struct Prepared {
    truth_map: OccupancyGrid,
    path_m: f64,
    stale: Vec<StaleMap>,
}

fn prepare(input: &LogInput, params: &RealScansParams) -> Result<Option<Prepared>, ExperimentError> {
    let d = &input.dataset;
    let source = LogSource::new(d.log.clone(), d.name.clone(), map_options());
    if source.truth().is_empty() {
        return Ok(None);
    }
    let path: Vec<Point2> = source.truth().iter().map(|t| t.pose.position()).collect();
    let path_m = source.truth().windows(2).map(|w| w[0].pose.distance(&w[1].pose)).sum();
    let truth_map = map_log(source, None, &params.mapper)
        .map_err(|e| ExperimentError::Invalid(format!("{}: the map at the reference poses: {e}", d.name)))?
        .map;
    let stale = params
        .edit_seeds
        .par_iter()
        .map(|&seed| stale_map(&truth_map, &path, &params.edits, seed))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Some(Prepared { truth_map, path_m, stale }))
}

/// The chains as [`Trials`]: one job per (log, edit seed, preset, pose source), on the
/// caller's rayon pool, the outcomes in job order.
struct ChainTrials<'a> {
    logs: &'a [LogInput],
    prepared: &'a [Option<Prepared>],
    params: &'a RealScansParams,
}

/// One chain to run: (log, edit seed index, preset index, pose source index).
type ChainJob = (usize, usize, usize, usize);

/// What one job gave.
enum ChainOutcome {
    Scored(Box<ChainResult>),
    Unscored(UnscoredChain),
}

impl Trials for ChainTrials<'_> {
    type Job = ChainJob;
    type Outcome = ChainOutcome;
    type Summary = Vec<ChainOutcome>;

    fn draw(&self) -> Vec<ChainJob> {
        let p = self.params;
        let mut jobs = Vec::new();
        for (l, prepared) in self.prepared.iter().enumerate() {
            // A log without reference poses runs once per preset and localiser, on its map.
            let seeds = if prepared.is_some() { p.edit_seeds.len() } else { 1 };
            for s in 0..seeds {
                for pr in 0..p.presets.len() {
                    for (ps, source) in p.pose_sources.iter().enumerate() {
                        if prepared.is_some() || *source != PoseSourceConfig::Reference {
                            jobs.push((l, s, pr, ps));
                        }
                    }
                }
            }
        }
        jobs
    }

    fn run(&self, (l, s, pr, ps): ChainJob, progress: &(dyn Fn() + Sync)) -> Result<ChainOutcome, ExperimentError> {
        let p = self.params;
        let d = &self.logs[l].dataset;
        let passes = p.worlds - 1;
        let seed = p.edit_seeds[s];
        let outcome = match &self.prepared[l] {
            Some(prep) => {
                let setup = ChainSetup {
                    name: &d.name,
                    log: &d.log,
                    truth_map: &prep.truth_map,
                    stale: &prep.stale[s],
                    edit_seed: seed,
                    mapper: &p.mapper,
                    metrics: p.metrics,
                };
                let keep = p.keep_maps && s == 0;
                ChainOutcome::Scored(Box::new(run_chain(
                    &setup,
                    &p.presets[pr],
                    &p.pose_sources[ps],
                    passes,
                    seed,
                    keep,
                )?))
            }
            None => {
                let Some(map) = &self.logs[l].map else {
                    return Err(ExperimentError::Invalid(format!(
                        "{}: the log has no reference poses, and no map was given to start from",
                        d.name
                    )));
                };
                ChainOutcome::Unscored(run_unscored_chain(
                    &d.name,
                    &d.log,
                    map,
                    &p.presets[pr],
                    &p.pose_sources[ps],
                    passes,
                    seed,
                )?)
            }
        };
        progress();
        Ok(outcome)
    }

    fn summarise(&self, outcomes: Vec<ChainOutcome>) -> Result<Vec<ChainOutcome>, ExperimentError> {
        Ok(outcomes)
    }
}

/// Runs the experiment's chains on every log (in parallel on the caller's rayon pool; the same
/// results whatever the thread count); `progress` after each chain. The number of chains is
/// [`chain_count`].
pub fn run_real_scans(
    logs: &[LogInput],
    params: &RealScansParams,
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<LogResult>, ExperimentError> {
    params.validate()?;
    let prepared = logs.par_iter().map(|l| prepare(l, params)).collect::<Result<Vec<_>, _>>()?;
    let outcomes = run_trials(&ChainTrials { logs, prepared: &prepared, params }, progress)?;
    let mut results: Vec<LogResult> = logs
        .iter()
        .zip(&prepared)
        .map(|(input, prep)| {
            let d = &input.dataset;
            let map = prep.as_ref().map(|p| &p.truth_map).or(input.map.as_ref());
            let (observed, occupied, size) = map.map_or((0, 0, (0, 0)), |m| {
                let g = m.geometry();
                (
                    m.cells().iter().filter(|&&c| c != CellState::Unknown).count(),
                    m.count(CellState::Occupied),
                    (g.width(), g.height()),
                )
            });
            LogResult {
                name: d.name.clone(),
                source: d.source.clone(),
                scans: d.log.scans().count(),
                path_m: prep.as_ref().map_or(0.0, |p| p.path_m),
                map_cells: (size, observed, occupied),
                note: prep.is_none().then(|| {
                    "no reference poses: nothing to score the maps against; the map given is M_1 as it is (no \
synthetic edits: without a reference path they could not be kept off the robot's path), and the report says what \
each pass changed"
                        .to_string()
                }),
                stale: prep.as_ref().map_or_else(Vec::new, |p| {
                    p.stale
                        .iter()
                        .zip(&params.edit_seeds)
                        .map(|(s, &seed)| StaleSummary {
                            edit_seed: seed,
                            edits: s.edits.len(),
                            target_cells: s.target_cells,
                            made_cells: s.made_cells,
                            floor_behind: s.edits.iter().map(|e| e.floor_behind).sum(),
                            edit_list: s.edits.clone(),
                        })
                        .collect()
                }),
                chains: Vec::new(),
                summaries: Vec::new(),
                unscored: Vec::new(),
                kidnaps: None,
                truth_map: map.cloned(),
                first_stale: prep.as_ref().and_then(|p| p.stale.first().map(|s| s.map.clone())),
            }
        })
        .collect();
    let jobs = ChainTrials { logs, prepared: &prepared, params }.draw();
    for ((l, ..), outcome) in jobs.into_iter().zip(outcomes) {
        match outcome {
            ChainOutcome::Scored(c) => results[l].chains.push(*c),
            ChainOutcome::Unscored(u) => results[l].unscored.push(u),
        }
    }
    for r in &mut results {
        r.summaries = summarise(&r.chains, &params.presets, &params.pose_sources);
    }
    if let Some(k) = &params.kidnaps {
        for ((r, input), prep) in results.iter_mut().zip(logs).zip(&prepared) {
            let Some(prep) = prep else { continue };
            let Some(stale) = prep.stale.first() else { continue };
            let maps = [("stale", &stale.map), ("truth", &prep.truth_map)];
            r.kidnaps = Some(kidnap::run_real_kidnap(&input.dataset, &maps, k, params.edit_seeds[0], progress)?);
        }
    }
    Ok(results)
}

/// The number of chains and kidnap trials [`run_real_scans`] runs (its progress count).
pub fn chain_count(logs: &[LogInput], params: &RealScansParams) -> usize {
    let with_reference = logs.iter().filter(|l| l.dataset.has_reference()).count();
    let localisers = params.pose_sources.iter().filter(|s| **s != PoseSourceConfig::Reference).count();
    let kidnaps = params
        .kidnaps
        .as_ref()
        .map_or(0, |k| k.cuts.count * k.seeds_per_cut * 2 * k.localisers.len() * k.presets.len());
    with_reference * (params.edit_seeds.len() * params.presets.len() * params.pose_sources.len() + kidnaps)
        + (logs.len() - with_reference) * params.presets.len() * localisers
}
