//! The hundred-world validation (paper §5.3.2) for one seed, and the summary over seeds.
//!
//! For a seed: generate W_1 … W_N; build M_1 in W_1 (exploration run) and report M_1/G_1; then
//! for i = 2 … N run the closed loop in W_i with the chain localiser and the updater on M_{i-1}
//! and the baseline localiser on M_1, and score M_1/G_i (static) and M_i/G_i (updated) with
//! CC, MS and OPDF, and M_i, M*_i and F_i by structure retention and change class
//! ([`crate::experiments::validation::erosion`]). The chain of worlds is sequential; seeds are independent,
//! so the caller may run them in parallel and merge them in seed order ([`summarise`]).

pub mod checkpoint;
pub mod erosion;
pub mod eta;
pub mod figures;
pub mod html;
pub mod report;
pub mod saved_worlds;
pub mod sensor_realism;
pub mod sweep;

use crate::experiments::ExperimentError;
use crate::experiments::pose_oracle::GivenPoseStats;
use crate::experiments::run_events::LostCounts;
use crate::experiments::runner::{
    Clock, FreshMapParams, LocStats, RunInputs, RunnerParams, Trajectories, UpdaterCounts, run_world, run_world_with,
};
pub use crate::experiments::setup::Scores;
use crate::experiments::validation::erosion::{
    ChangeClassSummary, ChangeClasses, ErosionJudge, Retention, RetentionSummary, change_class_summary,
    retention_summary,
};
pub use crate::stats::histogram_median;
use crate::stats::{IntervalUnits, PairedDiff, chain_diff, chain_units, frac, mean, median};
use crate::worlds::generator::{Edit, GeneratorParams, generate_worlds};
use crate::worlds::mapping::{MappingParams, build_initial_map};
use crate::worlds::observed::{OBSERVATION_STEP_M, restrict_to, route_poses, visible_cells};
use mapkeeper_grid::metrics::{MetricParams, interior_mask, map_metrics, map_metrics_in};
use mapkeeper_grid::{GridGeometry, OccupancyGrid, Point2, Pose2};
use mapkeeper_sim::{Route, World, ground_truth_map};
use mapkeeper_updater::UpdaterParams;
use serde::{Deserialize, Serialize};

/// Which ground truth G_i the map metrics compare with (`validate --ground-truth`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GroundTruth {
    /// The exact raster of all of W_i's geometry over the whole grid (faces never visible from
    /// anywhere are occupied; the cells outside the walls, unknown in G_i and in the maps,
    /// count).
    #[default]
    Exact,
    /// What a noise-free mapper sees driving the exploration route at true poses in W_i (the
    /// paper's G_i were SLAM Toolbox maps of such a run): the exact raster where a beam reaches,
    /// unknown elsewhere; scored over the interior of the outer walls only.
    Observed,
}

impl GroundTruth {
    /// The name used on the command line and in the outputs.
    pub fn name(self) -> &'static str {
        match self {
            GroundTruth::Exact => "exact",
            GroundTruth::Observed => "observed",
        }
    }

    /// The other variant.
    pub fn other(self) -> GroundTruth {
        match self {
            GroundTruth::Exact => GroundTruth::Observed,
            GroundTruth::Observed => GroundTruth::Exact,
        }
    }
}

impl std::str::FromStr for GroundTruth {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "exact" => Ok(GroundTruth::Exact),
            "observed" => Ok(GroundTruth::Observed),
            _ => Err(format!("unknown ground truth '{s}': expected exact or observed")),
        }
    }
}

/// Parameters of the validation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ValidationParams {
    /// Number of worlds N (W_1 … W_N, ≥ 2). Default 100.
    pub worlds: usize,
    /// Name of the updater preset in `runner.updater` (recorded in the outputs). Default "paper".
    pub preset: String,
    /// Map resolution, metres per cell. Default 0.05.
    pub resolution_m: f64,
    /// The route driven in every W_i (i ≥ 2). Default [`Route::default_warehouse`].
    pub route: Route,
    /// The exploration route in W_1 for M_1. Default [`Route::exploration_warehouse`].
    pub exploration_route: Route,
    /// The closed loop. Its `fresh_map` (required here) is by default M_1's mapper and stride
    /// (`mapping`).
    pub runner: RunnerParams,
    /// The scenario generator.
    pub generator: GeneratorParams,
    /// The M_1 exploration run.
    pub mapping: MappingParams,
    /// The map-quality metrics.
    pub metrics: MetricParams,
    /// The ground truth of `map_quality` and the plots (the other variant is reported beside
    /// it). Default [`GroundTruth::Exact`].
    pub ground_truth: GroundTruth,
    /// Worlds whose maps (M_i, G_i) and trajectories are kept for the outputs. Default
    /// [2, 50, 100] (those ≤ `worlds`).
    pub saved_worlds: Vec<usize>,
    /// Update the map only in every k-th world (W_2, W_{2+k}, …; the others are driven with the
    /// updater off, M_i = M_{i-1}), so that k worlds of change meet the check at once (the heavy
    /// change of the experiments issue). Default 1 (every world; not written when 1).
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub update_every: usize,
    /// Worlds whose drive is also written as a ROS 2 MCAP bag into [`Self::mcap_dir`]
    /// (`validate --mcap-worlds`; `docs/real-data.md`). Default none (not written when empty).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub mcap_worlds: Vec<usize>,
    /// Where those bags go, `<preset>-s<seed>-W<i>.mcap` (set by the caller, never read from or
    /// written to a file).
    #[serde(skip)]
    pub mcap_dir: Option<std::path::PathBuf>,
    /// The world W_1 by name (`validate --world`: an embedded world's name or the file as
    /// given). Default none: the embedded default warehouse (not written when none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub world: Option<String>,
    /// W_1 itself, with its scenario resolved ([`ValidationParams::use_site`]); never read from
    /// or written to a file (`world` names it). None: the embedded default warehouse.
    #[serde(skip)]
    pub world_data: Option<World>,
}

fn one() -> usize {
    1
}

// serde's skip_serializing_if passes a reference.
#[allow(clippy::trivially_copy_pass_by_ref)]
fn is_one(v: &usize) -> bool {
    *v == 1
}

impl Default for ValidationParams {
    fn default() -> Self {
        let mapping = MappingParams::default();
        Self {
            worlds: 100,
            preset: "paper".into(),
            resolution_m: 0.05,
            route: Route::default_warehouse(),
            exploration_route: Route::exploration_warehouse(),
            runner: RunnerParams {
                fresh_map: Some(FreshMapParams { mapper: mapping.mapper, scan_stride: mapping.scan_stride }),
                ..RunnerParams::default()
            },
            generator: GeneratorParams::default(),
            mapping,
            metrics: MetricParams::default(),
            ground_truth: GroundTruth::Exact,
            saved_worlds: vec![2, 50, 100],
            update_every: 1,
            mcap_worlds: Vec::new(),
            mcap_dir: None,
            world: None,
            world_data: None,
        }
    }
}

impl ValidationParams {
    /// Defaults with `worlds` worlds and the updater preset `preset`.
    /// The saved worlds are W_2, W_50, W_100 and W_N, those ≤ N.
    pub fn new(worlds: usize, preset: &str) -> Result<Self, ExperimentError> {
        let mut saved_worlds: Vec<usize> = [2, 50, 100, worlds].into_iter().filter(|&w| w <= worlds).collect();
        saved_worlds.sort_unstable();
        saved_worlds.dedup();
        let mut p = Self { worlds, preset: preset.to_string(), saved_worlds, ..Self::default() };
        p.runner.updater = UpdaterParams::preset(preset)?;
        p.validate()?;
        Ok(p)
    }

    /// Runs in `site`'s world (named `name` in the outputs): its route, exploration tour and
    /// storage areas.
    pub fn use_site(&mut self, name: &str, site: &crate::worlds::site::Site) {
        self.route = site.route.clone();
        self.exploration_route = site.exploration.clone();
        self.generator.storage_areas.clone_from(&site.storage);
        self.world = Some(name.to_string());
        self.world_data = Some(site.world.clone());
    }

    /// A shortened route (the first `length_m` metres of the default tour), for quick tests.
    pub fn short_route(length_m: f64) -> Route {
        Self::truncated_route(&Route::default_warehouse(), length_m)
    }

    /// The first `length_m` metres of `route` (all of it when it is shorter).
    pub fn truncated_route(route: &Route, length_m: f64) -> Route {
        let r = route.points();
        if r.is_empty() {
            return route.clone();
        }
        let mut pts = vec![r[0]];
        let mut left = length_m;
        for w in r.windows(2) {
            let d = w[0].distance(w[1]);
            if d >= left {
                let t = left / d;
                pts.push(Point2::new(w[0].x + t * (w[1].x - w[0].x), w[0].y + t * (w[1].y - w[0].y)));
                break;
            }
            pts.push(w[1]);
            left -= d;
        }
        Route::new(&pts)
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<(), ExperimentError> {
        if self.update_every == 0 || self.update_every > 10_000 {
            return Err(ExperimentError::InvalidParam {
                name: "update_every",
                problem: format!("must lie in 1..=10000, got {}", self.update_every),
            });
        }
        if self.worlds < 2 {
            return Err(ExperimentError::InvalidParam {
                name: "worlds",
                problem: format!("need at least 2 worlds, got {}", self.worlds),
            });
        }
        if !(self.resolution_m.is_finite() && self.resolution_m > 0.0) {
            return Err(ExperimentError::InvalidParam {
                name: "resolution_m",
                problem: format!("must be a finite length > 0 m, got {}", self.resolution_m),
            });
        }
        crate::experiments::check_route("route", &self.route, 1)?;
        crate::experiments::check_route("exploration_route", &self.exploration_route, 1)?;
        self.runner.validate()?;
        if self.runner.fresh_map.is_none() {
            return Err(ExperimentError::InvalidParam {
                name: "runner.fresh_map",
                problem: "the validation scores a fresh map of every run: give its mapper and stride".into(),
            });
        }
        self.generator.validate()?;
        self.mapping.validate()?;
        self.metrics.validate()?;
        Ok(())
    }
}

/// M_1, M_i and the best achievable map M*_i scored against one variant of G_i.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GroundTruthScores {
    /// M_1 / G_i.
    pub static_map: Scores,
    /// M_i / G_i.
    pub updated_map: Scores,
    /// M*_i / G_i: the best achievable map (M*_1 = M_1; M*_i is M*_{i-1} with every cell the
    /// route observes in W_i set to its state in W_i).
    pub best_map: Scores,
    /// F_i / G_i: a fresh map of W_i's run alone (the log-odds mapper of M_1, fed the run's
    /// scans at the chain localiser's estimates, no prior).
    pub fresh_map: Scores,
}

/// One world of one seed: a row of `worlds.csv`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WorldRow {
    /// The run seed.
    pub seed: u64,
    /// i in W_i.
    pub world: usize,
    /// Edits that made W_i from W_{i-1}.
    pub edits: usize,
    /// Movable items in W_i.
    pub movable_items: usize,
    /// M_1 / G_i (G_i the run's ground truth, `params.ground_truth`).
    pub static_map: Scores,
    /// M_i / G_i.
    pub updated_map: Scores,
    /// M*_i / G_i, the best achievable map ([`GroundTruthScores::best_map`]).
    pub best_map: Scores,
    /// F_i / G_i, the fresh map of this run ([`GroundTruthScores::fresh_map`]).
    pub fresh_map: Scores,
    /// The same four against the other ground truth variant.
    pub other_ground_truth: GroundTruthScores,
    /// The baseline localiser on M_1.
    pub loc_static: LocStats,
    /// The chain localiser on M_{i-1}.
    pub loc_updated: LocStats,
    /// The updater's verdicts and work.
    pub updater: UpdaterCounts,
    /// Cells that differ between M_{i-1} and M_i.
    pub cells_changed: u64,
    /// Contacts of the robot that began in this world.
    pub collisions: u64,
    /// Simulated time, seconds.
    pub sim_time_s: f64,
    /// Distance driven, metres.
    pub distance_m: f64,
    /// Whether the route was completed.
    pub route_done: bool,
    /// Median updater time per processed scan, microseconds (0 without a clock).
    pub median_scan_us: f64,
    /// The reaction to Lost (episodes, attempts, recoveries, give-ups, time stopped).
    #[serde(default)]
    pub lost: LostCounts,
    /// Structure retention of M_i, M*_i and F_i against the exact G_i, whatever the run's
    /// ground truth (`None` in records written before it was measured; not written then).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub retention: Option<Retention>,
    /// The cells that changed between M_1 and the exact G_i where the route looks, by class,
    /// and the share M_i, M*_i and F_i got right (`None` as for `retention`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub change_classes: Option<ChangeClasses>,
    /// The error of the poses the updater was given, with a pose source other than the chain
    /// localiser (`runner.updater_poses`; absent with the localiser, whose error is
    /// `loc_updated`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub updater_pose_error: Option<GivenPoseStats>,
}

/// Maps and trajectories of a saved world.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SavedWorld {
    /// i in W_i.
    pub world: usize,
    /// M_i.
    pub map: OccupancyGrid,
    /// G_i.
    pub ground_truth: OccupancyGrid,
    /// True, chain and baseline trajectories.
    pub trajectories: Option<Trajectories>,
}

/// Everything one seed produced (serialisable for the checkpoints of `validate --resume`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SeedRun {
    /// The run seed.
    pub seed: u64,
    /// M_1.
    pub initial_map: OccupancyGrid,
    /// G_1.
    pub initial_ground_truth: OccupancyGrid,
    /// M_1 / G_1.
    pub initial_scores: Scores,
    /// One row per world i = 2 … N.
    pub rows: Vec<WorldRow>,
    /// The edits per world (index 0 = W_1, empty).
    pub edits: Vec<Vec<Edit>>,
    /// Saved worlds, in world order.
    pub saved: Vec<SavedWorld>,
    /// Updater time per processed scan over all worlds, microseconds (empty without a clock).
    pub scan_times_us: Vec<u32>,
}

impl SeedRun {
    /// Whether this run lacks the updater's times it would have had with a clock: the updater
    /// processed steps, and none was timed (a run in which it processed none has nothing to
    /// time either way).
    pub fn lacks_times(&self) -> bool {
        self.scan_times_us.is_empty() && self.rows.iter().any(|r| r.updater.processed > 0)
    }

    /// The run as an untimed run (`--no-timing`) would have it: every time removed (the scan
    /// times and the world rows' medians), nothing else changed. A timed checkpoint resumed
    /// with `--no-timing` then writes what an untimed run writes.
    pub fn drop_timing(&mut self) {
        self.scan_times_us.clear();
        for row in &mut self.rows {
            row.median_scan_us = 0.0;
        }
    }

    /// The machine-readable part of this run (everything but maps and trajectories): what
    /// `runs.json` holds and the summary is computed from.
    pub fn record(&self) -> SeedRecord {
        SeedRecord {
            seed: self.seed,
            initial_scores: self.initial_scores,
            rows: self.rows.clone(),
            edits: self.edits.clone(),
            scan_time_histogram_us: scan_time_histogram(&self.scan_times_us),
        }
    }
}

/// One seed in `runs.json`: the per-world rows at full precision, M_1/G_1, the generator's
/// edits and the updater's time per processed scan as a histogram, from which the summary is
/// recomputed exactly.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SeedRecord {
    /// The run seed.
    pub seed: u64,
    /// M_1 / G_1.
    pub initial_scores: Scores,
    /// One row per world i = 2 … N, in world order.
    pub rows: Vec<WorldRow>,
    /// The edits per world (index 0 = W_1, empty).
    pub edits: Vec<Vec<Edit>>,
    /// Updater time per processed scan: `[microseconds, count]` pairs, microseconds strictly
    /// increasing, counts ≥ 1 (empty without a clock).
    pub scan_time_histogram_us: Vec<(u32, u64)>,
}

/// The exact histogram of integer scan times: `(value, count)`, values increasing.
pub fn scan_time_histogram(times_us: &[u32]) -> Vec<(u32, u64)> {
    let mut sorted = times_us.to_vec();
    sorted.sort_unstable();
    let mut h: Vec<(u32, u64)> = Vec::new();
    for t in sorted {
        match h.last_mut() {
            Some((v, c)) if *v == t => *c += 1,
            _ => h.push((t, 1)),
        }
    }
    h
}

/// Merges histograms (each with increasing values) into one.
fn merge_histograms<'a>(hs: impl Iterator<Item = &'a [(u32, u64)]>) -> Vec<(u32, u64)> {
    let mut all: Vec<(u32, u64)> = hs.flat_map(|h| h.iter().copied()).collect();
    all.sort_unstable_by_key(|&(v, _)| v);
    let mut out: Vec<(u32, u64)> = Vec::with_capacity(all.len());
    for (v, c) in all {
        match out.last_mut() {
            Some((w, d)) if *w == v => *d += c,
            _ => out.push((v, c)),
        }
    }
    out
}

/// Which slice of the seeds a run covers: shard `index` (1-based) of `count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Shard {
    /// 1 … `count`.
    pub index: u64,
    /// Number of shards, ≥ 1.
    pub count: u64,
}

impl Shard {
    /// The seeds (or jobs) of this shard: the `index`-th of `count` contiguous, nearly equal
    /// slices of `seeds` (slice sizes differ by at most one). `None` if the shard is out of range or
    /// there are fewer seeds than shards (some shard would be empty).
    pub fn slice<'a, T>(&self, seeds: &'a [T]) -> Option<&'a [T]> {
        if self.count == 0 || self.index == 0 || self.index > self.count || self.count > seeds.len() as u64 {
            return None;
        }
        let n = seeds.len() as u128;
        let (k, c) = (u128::from(self.index), u128::from(self.count));
        let lo = usize::try_from((k - 1) * n / c).ok()?;
        let hi = usize::try_from(k * n / c).ok()?;
        (hi > lo).then(|| &seeds[lo..hi])
    }
}

impl std::str::FromStr for Shard {
    type Err = String;

    /// Parses `k/N` with 1 ≤ k ≤ N.
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("expected k/N with 1 ≤ k ≤ N (e.g. 2/4), got '{s}'");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let index: u64 = k.trim().parse().map_err(|_| bad())?;
        let count: u64 = n.trim().parse().map_err(|_| bad())?;
        if index == 0 || count == 0 || index > count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

/// Value of `runs.json`'s `format` field.
pub const RUNS_FORMAT: &str = "mapkeeper-validation-runs";
/// Version of the `runs.json` layout (3: `params.runner.parallel_baseline` left the parameters
/// for [`crate::RunOptions`], how a run is executed).
pub const RUNS_FORMAT_VERSION: u32 = 3;

/// `runs.json`: the machine-readable record of a validation folder, from which `summary.json`,
/// `worlds.csv`, `edits.json`, `report.md` and the plots are recomputed exactly (what
/// `mapkeeper merge` combines).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ValidationRecord {
    /// Always [`RUNS_FORMAT`].
    pub format: String,
    /// [`RUNS_FORMAT_VERSION`].
    pub format_version: u32,
    /// Producer and version.
    pub tool: String,
    /// Whether the updater was timed (false with `--no-timing`: all times 0).
    pub timing: bool,
    /// Wall time, seconds (the sum over merged folders; 0 when not measured).
    pub wall_time_s: f64,
    /// The shard this folder holds, `None` for a whole run or a merge.
    pub shard: Option<Shard>,
    /// The parameters.
    pub params: ValidationParams,
    /// One record per seed, in seed order.
    pub seeds: Vec<SeedRecord>,
}

impl ValidationRecord {
    /// The record of `runs` (in seed order) made with `params`.
    pub fn new(
        params: &ValidationParams,
        runs: &[SeedRun],
        timing: bool,
        wall_time_s: f64,
        shard: Option<Shard>,
    ) -> Self {
        ValidationRecord {
            format: RUNS_FORMAT.into(),
            format_version: RUNS_FORMAT_VERSION,
            tool: tool_name(),
            timing,
            wall_time_s,
            shard,
            params: params.clone(),
            seeds: runs.iter().map(SeedRun::record).collect(),
        }
    }

    /// The summary of this record.
    pub fn summary(&self) -> Summary {
        summarise_records(&self.params, &self.seeds, self.wall_time_s)
    }
}

fn tool_name() -> String {
    format!("mapkeeper-scenario {}", env!("CARGO_PKG_VERSION"))
}

/// Runs the validation for one seed. `progress(i)` is called after each world i (and with 1
/// after M_1).
pub fn run_seed(
    params: &ValidationParams,
    seed: u64,
    clock: &dyn Clock,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<SeedRun, ExperimentError> {
    params.validate()?;
    match &params.world_data {
        Some(w1) => run_seed_in(w1, params, seed, clock, progress),
        None => run_seed_in(&World::default_warehouse(), params, seed, clock, progress),
    }
}

/// The file name of the MCAP bag of world `i` of a seed (`--mcap-worlds`).
pub fn mcap_name(preset: &str, seed: u64, i: usize) -> String {
    format!("{preset}-s{seed}-W{i:03}.mcap")
}

/// What [`Judge::world`] makes of one world.
struct Judged {
    /// M_1, M_i, M*_i and F_i against the run's ground truth.
    chosen: GroundTruthScores,
    /// The same against the other variant.
    other: GroundTruthScores,
    /// G_i of the run's variant.
    gi: OccupancyGrid,
    /// Structure retention against the exact G_i.
    retention: Retention,
    /// Change classes against the exact G_i.
    change_classes: ChangeClasses,
}

/// Scores maps against both ground truth variants of each world, keeps the best achievable
/// map M*_i of the chain, and scores structure retention and change classes.
struct Judge<'a> {
    params: &'a ValidationParams,
    /// Inside the outer walls of W_1 (they never move: one interior for every world).
    interior: Vec<bool>,
    /// Observation poses along the exploration route (the observed ground truth).
    exploration: Vec<Pose2>,
    /// Observation poses along the route (what an updater can see).
    route: Vec<Pose2>,
    /// M*_i.
    best: OccupancyGrid,
    /// The exact G_1.
    g1: OccupancyGrid,
    /// The running structure mask S_i and W_1's movable items.
    erosion: ErosionJudge,
}

impl<'a> Judge<'a> {
    fn new(
        params: &'a ValidationParams,
        w1: &World,
        m1: &OccupancyGrid,
        g1: OccupancyGrid,
    ) -> Result<Self, ExperimentError> {
        Ok(Judge {
            params,
            interior: interior_mask(&g1),
            exploration: route_poses(&params.exploration_route, OBSERVATION_STEP_M),
            route: route_poses(&params.route, OBSERVATION_STEP_M),
            best: m1.clone(),
            erosion: ErosionJudge::new(w1, m1, &g1)?,
            g1,
        })
    }

    fn observed(&self, exact: &OccupancyGrid) -> OccupancyGrid {
        restrict_to(exact, &visible_cells(exact, &self.exploration, &self.params.runner.sim.lidars))
    }

    /// G_1 of the run's variant and M_1 against it.
    fn initial(&self, m1: &OccupancyGrid) -> Result<(OccupancyGrid, Scores), ExperimentError> {
        let metrics = &self.params.metrics;
        Ok(match self.params.ground_truth {
            GroundTruth::Exact => (self.g1.clone(), Scores::from(map_metrics(m1, &self.g1, metrics)?)),
            GroundTruth::Observed => {
                let observed = self.observed(&self.g1);
                let scores = Scores::from(map_metrics_in(m1, &observed, &self.interior, metrics)?);
                (observed, scores)
            }
        })
    }

    /// Advances M*_{i-1} to M*_i and S_{i-1} to S_i with W_i `wi` and its exact G_i `gi`, and
    /// scores M_1, M_i, M*_i and F_i.
    fn world(
        &mut self,
        wi: &World,
        gi: OccupancyGrid,
        m1: &OccupancyGrid,
        mi: &OccupancyGrid,
        fresh: &OccupancyGrid,
    ) -> Result<Judged, ExperimentError> {
        let seen = visible_cells(&gi, &self.route, &self.params.runner.sim.lidars);
        for ((cell, &truth), &seen) in self.best.cells_mut().iter_mut().zip(gi.cells()).zip(&seen) {
            if seen {
                *cell = truth;
            }
        }
        let (retention, change_classes) = self.erosion.world(wi, &gi, &seen, m1, [mi, &self.best, fresh])?;
        let metrics = &self.params.metrics;
        let exact = GroundTruthScores {
            static_map: Scores::from(map_metrics(m1, &gi, metrics)?),
            updated_map: Scores::from(map_metrics(mi, &gi, metrics)?),
            best_map: Scores::from(map_metrics(&self.best, &gi, metrics)?),
            fresh_map: Scores::from(map_metrics(fresh, &gi, metrics)?),
        };
        let observed_gi = self.observed(&gi);
        let inside = |m: &OccupancyGrid| map_metrics_in(m, &observed_gi, &self.interior, metrics).map(Scores::from);
        let observed = GroundTruthScores {
            static_map: inside(m1)?,
            updated_map: inside(mi)?,
            best_map: inside(&self.best)?,
            fresh_map: inside(fresh)?,
        };
        let (chosen, other, gi) = match self.params.ground_truth {
            GroundTruth::Exact => (exact, observed, gi),
            GroundTruth::Observed => (observed, exact, observed_gi),
        };
        Ok(Judged { chosen, other, gi, retention, change_classes })
    }
}

/// One world of the chain, recorded as an MCAP bag when `params.mcap_worlds` asks for it.
fn run_chain_world(
    inputs: &RunInputs<'_>,
    rp: &RunnerParams,
    params: &ValidationParams,
    seed: u64,
    i: usize,
    clock: &dyn Clock,
) -> Result<crate::experiments::runner::WorldRun, ExperimentError> {
    match &params.mcap_dir {
        Some(dir) if params.mcap_worlds.contains(&i) => {
            let path = dir.join(mcap_name(&params.preset, seed, i));
            let mut rec = mapkeeper_harness::mcap_out::McapRecorder::create(&path)?;
            let run = run_world_with(inputs, rp, seed, &format!("W{i:03}"), clock, &mut [&mut rec])?;
            rec.finish(Some(&run.map))?;
            Ok(run)
        }
        _ => run_world(inputs, rp, seed, &format!("W{i:03}"), clock),
    }
}

/// [`run_seed`] from a given W_1.
pub fn run_seed_in(
    w1: &World,
    params: &ValidationParams,
    seed: u64,
    clock: &dyn Clock,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<SeedRun, ExperimentError> {
    params.validate()?;
    let geometry: GridGeometry = w1.default_map_geometry(params.resolution_m)?;
    let chain = generate_worlds(w1, &params.route, params.worlds, seed, &params.generator)?;
    let m1 = build_initial_map(w1, &params.exploration_route, &geometry, &params.runner.sim, &params.mapping, seed)?;
    let mut judge = Judge::new(params, w1, &m1.map, ground_truth_map(w1, &geometry))?;
    let (g1, initial_scores) = judge.initial(&m1.map)?;
    progress(1);
    let mut rows = Vec::with_capacity(params.worlds - 1);
    let mut saved = Vec::new();
    let mut all_times = Vec::new();
    let mut prev = m1.map.clone();
    // The updater's cross-world memory: M_1 is a surveyed map (empty memory: all established).
    let mut memory = mapkeeper_updater::StructureMemory::default();
    for (k, world) in chain.worlds.iter().enumerate().skip(1) {
        let i = k + 1;
        let keep = params.saved_worlds.contains(&i);
        let mut rp = params.runner.clone();
        rp.record_trajectories = keep;
        rp.run_updater = rp.run_updater && (i - 2).is_multiple_of(params.update_every);
        let inputs = RunInputs {
            world,
            route: &chain.routes[k],
            prev_map: &prev,
            baseline_map: &m1.map,
            prev_memory: Some(&memory),
        };
        let run = run_chain_world(&inputs, &rp, params, seed, i, clock)?;
        // Validated: runner.fresh_map is set, so every run returns its fresh map.
        let fresh = run.fresh_map.as_ref().unwrap_or(&run.map);
        let Judged { chosen, other, gi, retention, change_classes } =
            judge.world(world, ground_truth_map(world, &geometry), &m1.map, &run.map, fresh)?;
        let median_scan_us = median(run.scan_times_us.iter().map(|&t| f64::from(t)).collect()).unwrap_or(0.0);
        all_times.extend_from_slice(&run.scan_times_us);
        rows.push(WorldRow {
            seed,
            world: i,
            edits: chain.edits[k].len(),
            movable_items: world.movable.len(),
            static_map: chosen.static_map,
            updated_map: chosen.updated_map,
            best_map: chosen.best_map,
            fresh_map: chosen.fresh_map,
            other_ground_truth: other,
            loc_static: run.baseline,
            loc_updated: run.chain,
            updater: run.updater,
            cells_changed: run.cells_changed,
            collisions: run.collisions,
            sim_time_s: run.sim_time_s,
            distance_m: run.distance_m,
            route_done: run.route_done,
            median_scan_us,
            lost: run.lost,
            retention: Some(retention),
            change_classes: Some(change_classes),
            updater_pose_error: run.given_pose,
        });
        if keep {
            saved.push(SavedWorld {
                world: i,
                map: run.map.clone(),
                ground_truth: gi,
                trajectories: run.trajectories.clone(),
            });
        }
        prev = run.map;
        memory = run.memory;
        progress(i);
    }
    Ok(SeedRun {
        seed,
        initial_map: m1.map,
        initial_ground_truth: g1,
        initial_scores,
        rows,
        edits: chain.edits,
        saved,
        scan_times_us: all_times,
    })
}

/// Static-vs-updated figures of one map metric.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MetricSummary {
    /// Mean of M_1/G_i over all worlds and seeds, percent.
    pub static_mean: f64,
    /// Mean of M_i/G_i, percent.
    pub updated_mean: f64,
    /// Share of world rows where M_i/G_i > M_1/G_i.
    pub updated_better_fraction: f64,
    /// Mean M_i/G_i over the last world of each seed (W_N), percent.
    pub updated_last: f64,
    /// Mean M_1/G_i over the last world of each seed, percent.
    pub static_last: f64,
    /// Mean over seeds of each seed's mean of M_i/G_i − M_1/G_i over its worlds, percentage
    /// points (equal to `updated_mean − static_mean` when every seed has as many worlds).
    #[serde(default)]
    pub diff_mean: f64,
    /// 95 % interval of `diff_mean` (Student t), `[lo, hi]`: paired with the seeds as units (the
    /// worlds of a seed are not independent), or with one seed over batches of its consecutive
    /// worlds (the summary's `interval_units`); `null` with one seed of fewer than 20 updated worlds.
    #[serde(default)]
    pub diff_ci95: Option<[f64; 2]>,
}

/// Map-quality section of the summary.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MapQuality {
    /// Cross-correlation.
    pub cc: MetricSummary,
    /// Map score.
    pub ms: MetricSummary,
    /// OPDF.
    pub opdf: MetricSummary,
}

/// The best achievable map against one metric: how much of the possible improvement M_i made.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BestSummary {
    /// Mean of M*_i/G_i over all worlds and seeds, percent.
    pub best_mean: f64,
    /// (mean M_i/G_i − mean M_1/G_i) / (mean M*_i/G_i − mean M_1/G_i): the share of the
    /// achievable improvement M_i reaches (1 = all of it, 0 = none, negative = worse than M_1);
    /// `null` when M*_i is no better than M_1 (nothing to achieve).
    pub achieved_fraction: Option<f64>,
}

/// [`BestSummary`] per metric.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BestAchievable {
    /// Cross-correlation.
    pub cc: BestSummary,
    /// Map score.
    pub ms: BestSummary,
    /// OPDF.
    pub opdf: BestSummary,
}

/// The map quality against one ground truth variant, with the best achievable map.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GroundTruthQuality {
    /// M_1 and M_i against it.
    pub map_quality: MapQuality,
    /// M*_i against it.
    pub best_achievable: BestAchievable,
    /// Means over all worlds and seeds of the fresh map F_i against it.
    pub fresh_map: Scores,
}

/// Both ground truth variants side by side.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ByGroundTruth {
    /// The exact raster over the whole grid.
    pub exact: GroundTruthQuality,
    /// What the exploration route observes, over the interior.
    pub observed: GroundTruthQuality,
}

/// One localiser's figures over all worlds and seeds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LocSummary {
    /// Mean over worlds of the per-world mean position error, metres.
    pub mean_error_m: f64,
    /// Largest position error seen, metres.
    pub max_error_m: f64,
    /// Mean of the per-world max error, metres.
    pub mean_max_error_m: f64,
    /// Root mean square over worlds of the per-world RMSE, metres.
    pub rmse_m: f64,
    /// Mean covariance trace.
    pub mean_trace: f64,
    /// Mean λmax.
    pub mean_lambda_max: f64,
}

/// Localisation section of the summary.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Localisation {
    /// Baseline localiser on M_1.
    pub static_map: LocSummary,
    /// Chain localiser on M_{i-1}.
    pub updated_map: LocSummary,
    /// Share of world rows where the chain's mean error is below the baseline's.
    pub updated_better_fraction: f64,
    /// Share of world rows where the chain's mean covariance trace is below the baseline's.
    pub updated_lower_trace_fraction: f64,
    /// Mean over seeds of each seed's mean (over worlds) of the chain's mean position error
    /// minus the baseline's, metres (negative: the chain on M_{i-1} is better).
    #[serde(default)]
    pub error_diff_mean_m: f64,
    /// 95 % interval of `error_diff_mean_m`, `[lo, hi]`, in the units of `diff_ci95`'s.
    #[serde(default)]
    pub error_diff_ci95_m: Option<[f64; 2]>,
}

/// Updater section of the summary.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct UpdaterSummary {
    /// Median updater time per processed scan over all worlds and seeds, microseconds (0 when
    /// not measured).
    pub median_scan_us: f64,
    /// Largest updater change state seen (the sparse cell buffers, growing with the touched
    /// cells), bytes.
    pub max_state_bytes: u64,
    /// Largest map-sized cache of the updater (both grids, clearance field, interior mask,
    /// score grid; growing with the map's area), bytes.
    #[serde(default)]
    pub max_cache_bytes: u64,
    /// Processed scans.
    pub processed_scans: u64,
    /// Valid beams processed.
    pub beams: u64,
    /// Verdicts Update.
    pub update: u64,
    /// Verdicts Suspend.
    pub suspend: u64,
    /// Verdicts Lost.
    pub lost: u64,
    /// Successful pose recoveries.
    pub recovered: u64,
    /// Cell state changes applied.
    pub cell_changes: u64,
    /// Registration before writing over all worlds and seeds (zeros when it is off).
    #[serde(default)]
    pub registration: mapkeeper_updater::RegistrationStats,
    /// "Changed" votes of the memory's healing rule over all worlds and seeds.
    #[serde(default)]
    pub heal_votes: u64,
}

/// `summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Producer and version.
    pub tool: String,
    /// The seeds, in order.
    pub seeds: Vec<u64>,
    /// N.
    pub worlds: usize,
    /// The updater preset.
    pub preset: String,
    /// The localiser preset both localisers were made from (its parameters: `params.runner.filter`).
    #[serde(default = "default_localiser")]
    pub localiser: String,
    /// Wall time of the whole run, seconds (0 when not measured).
    pub wall_time_s: f64,
    /// The units of every 95 % interval of this summary: `seeds`, or with one seed
    /// `world-batches` (docs/evaluation.md, "Intervals").
    #[serde(default)]
    pub interval_units: IntervalUnits,
    /// M_1/G_1, mean over seeds.
    pub initial_map: Scores,
    /// The ground truth of `initial_map` and `map_quality` (`exact` or `observed`).
    pub ground_truth: GroundTruth,
    /// Map quality against that ground truth.
    pub map_quality: MapQuality,
    /// Map quality against both ground truth variants, each with the best achievable map.
    pub by_ground_truth: ByGroundTruth,
    /// Localisation.
    pub localisation: Localisation,
    /// Updater.
    pub updater: UpdaterSummary,
    /// Contacts of the robot over all worlds and seeds.
    pub collisions: u64,
    /// Worlds whose route was completed, of all world rows.
    pub routes_completed: usize,
    /// World rows.
    pub rows: usize,
    /// Simulated time over all worlds and seeds, seconds.
    pub sim_time_s: f64,
    /// The reaction to Lost, summed over all worlds and seeds.
    #[serde(default)]
    pub lost_handling: LostCounts,
    /// The check under heavy change (only with `params.update_every` > 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heavy_change: Option<HeavyChange>,
    /// Structure retention of M_i, M*_i and F_i against the exact G_i: at W_2, at W_N, the
    /// mean, and the target at W_N. Absent when no row has it (records written before it was
    /// measured).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub retention: Option<RetentionSummary>,
    /// The shares of added, removed and moved cells that M_i, M*_i and F_i got right (absent as
    /// `retention`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub change_classes: Option<ChangeClassSummary>,
    /// The error of the poses the updater was given, pooled over all worlds and seeds (only
    /// with a pose source other than the chain localiser, `params.runner.updater_poses`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub updater_pose_error: Option<GivenPoseStats>,
    /// The parameters.
    pub params: ValidationParams,
}

fn default_localiser() -> String {
    "mapkeeper".into()
}

/// Per seed, the mean over its worlds of `f(row)`; their mean and 95 % interval, over the seeds
/// or, with one seed, over batches of its worlds ([`chain_diff`]; the units are
/// [`interval_units`]'s).
fn per_seed_diff(runs: &[SeedRecord], f: impl Fn(&WorldRow) -> f64) -> PairedDiff {
    let per_seed: Vec<Vec<f64>> =
        runs.iter().filter(|r| !r.rows.is_empty()).map(|r| r.rows.iter().map(&f).collect()).collect();
    chain_diff(&per_seed).0
}

/// The units of the intervals of a summary of `runs` ([`chain_units`] of the seeds with worlds).
pub fn interval_units(runs: &[SeedRecord]) -> IntervalUnits {
    let worlds: Vec<usize> = runs.iter().map(|r| r.rows.len()).filter(|&n| n > 0).collect();
    chain_units(&worlds)
}

/// The three scores of a row against the run's own ground truth (`other` false) or the other one.
fn row_scores(w: &WorldRow, other: bool) -> GroundTruthScores {
    if other {
        w.other_ground_truth
    } else {
        GroundTruthScores {
            static_map: w.static_map,
            updated_map: w.updated_map,
            best_map: w.best_map,
            fresh_map: w.fresh_map,
        }
    }
}

fn metric_summary(runs: &[SeedRecord], other: bool, f: impl Fn(&Scores) -> f64) -> MetricSummary {
    let rows = || runs.iter().flat_map(|r| r.rows.iter()).map(|w| row_scores(w, other));
    let last = || runs.iter().filter_map(|r| r.rows.last()).map(|w| row_scores(w, other));
    let diff = per_seed_diff(runs, |w| {
        let g = row_scores(w, other);
        f(&g.updated_map) - f(&g.static_map)
    });
    MetricSummary {
        diff_mean: diff.mean,
        diff_ci95: diff.ci95,
        static_mean: mean(rows().map(|w| f(&w.static_map))),
        updated_mean: mean(rows().map(|w| f(&w.updated_map))),
        updated_better_fraction: frac(rows().map(|w| f(&w.updated_map) > f(&w.static_map))),
        updated_last: mean(last().map(|w| f(&w.updated_map))),
        static_last: mean(last().map(|w| f(&w.static_map))),
    }
}

fn map_quality(runs: &[SeedRecord], other: bool) -> MapQuality {
    MapQuality {
        cc: metric_summary(runs, other, |s| s.cc),
        ms: metric_summary(runs, other, |s| s.ms),
        opdf: metric_summary(runs, other, |s| s.opdf),
    }
}

fn best_summary(runs: &[SeedRecord], other: bool, q: &MetricSummary, f: impl Fn(&Scores) -> f64) -> BestSummary {
    let best_mean = mean(runs.iter().flat_map(|r| r.rows.iter()).map(|w| f(&row_scores(w, other).best_map)));
    let possible = best_mean - q.static_mean;
    let achieved_fraction = (possible > 1e-9).then(|| (q.updated_mean - q.static_mean) / possible);
    BestSummary { best_mean, achieved_fraction }
}

fn ground_truth_quality(runs: &[SeedRecord], other: bool) -> GroundTruthQuality {
    let q = map_quality(runs, other);
    let best_achievable = BestAchievable {
        cc: best_summary(runs, other, &q.cc, |s| s.cc),
        ms: best_summary(runs, other, &q.ms, |s| s.ms),
        opdf: best_summary(runs, other, &q.opdf, |s| s.opdf),
    };
    let fresh = |f: fn(&Scores) -> f64| {
        mean(runs.iter().flat_map(|r| r.rows.iter()).map(|w| f(&row_scores(w, other).fresh_map)))
    };
    let fresh_map = Scores { cc: fresh(|s| s.cc), ms: fresh(|s| s.ms), opdf: fresh(|s| s.opdf) };
    GroundTruthQuality { map_quality: q, best_achievable, fresh_map }
}

fn loc_summary(runs: &[SeedRecord], f: impl Fn(&WorldRow) -> &LocStats) -> LocSummary {
    let rows = || runs.iter().flat_map(|r| r.rows.iter()).map(&f);
    LocSummary {
        mean_error_m: mean(rows().map(|s| s.mean_error_m)),
        max_error_m: rows().map(|s| s.max_error_m).fold(0.0, f64::max),
        mean_max_error_m: mean(rows().map(|s| s.max_error_m)),
        rmse_m: mean(rows().map(|s| s.rmse_m * s.rmse_m)).sqrt(),
        mean_trace: mean(rows().map(|s| s.mean_trace)),
        mean_lambda_max: mean(rows().map(|s| s.mean_lambda_max)),
    }
}

/// The summary over seeds (in the given order). `wall_time_s` is supplied by the caller.
pub fn summarise(params: &ValidationParams, runs: &[SeedRun], wall_time_s: f64) -> Summary {
    let records: Vec<SeedRecord> = runs.iter().map(SeedRun::record).collect();
    summarise_records(params, &records, wall_time_s)
}

/// [`summarise`] from the seeds' records (e.g. read back from `runs.json` files): the same
/// summary, bit for bit.
pub fn summarise_records(params: &ValidationParams, runs: &[SeedRecord], wall_time_s: f64) -> Summary {
    let rows = || runs.iter().flat_map(|r| r.rows.iter());
    let times = merge_histograms(runs.iter().map(|r| r.scan_time_histogram_us.as_slice()));
    let sum_u = |f: fn(&UpdaterCounts) -> u64| rows().map(|w| f(&w.updater)).sum::<u64>();
    let loc_diff = per_seed_diff(runs, |w| w.loc_updated.mean_error_m - w.loc_static.mean_error_m);
    Summary {
        tool: tool_name(),
        seeds: runs.iter().map(|r| r.seed).collect(),
        worlds: params.worlds,
        preset: params.preset.clone(),
        localiser: params.runner.localiser.clone(),
        wall_time_s,
        interval_units: interval_units(runs),
        initial_map: Scores {
            cc: mean(runs.iter().map(|r| r.initial_scores.cc)),
            ms: mean(runs.iter().map(|r| r.initial_scores.ms)),
            opdf: mean(runs.iter().map(|r| r.initial_scores.opdf)),
        },
        ground_truth: params.ground_truth,
        map_quality: map_quality(runs, false),
        by_ground_truth: match params.ground_truth {
            GroundTruth::Exact => {
                ByGroundTruth { exact: ground_truth_quality(runs, false), observed: ground_truth_quality(runs, true) }
            }
            GroundTruth::Observed => {
                ByGroundTruth { exact: ground_truth_quality(runs, true), observed: ground_truth_quality(runs, false) }
            }
        },
        localisation: Localisation {
            static_map: loc_summary(runs, |w| &w.loc_static),
            updated_map: loc_summary(runs, |w| &w.loc_updated),
            updated_better_fraction: frac(rows().map(|w| w.loc_updated.mean_error_m < w.loc_static.mean_error_m)),
            updated_lower_trace_fraction: frac(rows().map(|w| w.loc_updated.mean_trace < w.loc_static.mean_trace)),
            error_diff_mean_m: loc_diff.mean,
            error_diff_ci95_m: loc_diff.ci95,
        },
        updater: UpdaterSummary {
            median_scan_us: histogram_median(&times),
            max_state_bytes: rows().map(|w| w.updater.max_state_bytes).max().unwrap_or(0),
            max_cache_bytes: rows().map(|w| w.updater.cache_bytes).max().unwrap_or(0),
            processed_scans: sum_u(|u| u.processed),
            beams: sum_u(|u| u.beams),
            update: sum_u(|u| u.update),
            suspend: sum_u(|u| u.suspend),
            lost: sum_u(|u| u.lost),
            recovered: sum_u(|u| u.recovered),
            cell_changes: sum_u(|u| u.cell_changes),
            registration: rows().fold(Default::default(), |mut a, w| {
                a.add(&w.updater.registration);
                a
            }),
            heal_votes: sum_u(|u| u.heal_votes),
        },
        collisions: rows().map(|w| w.collisions).sum(),
        routes_completed: rows().filter(|w| w.route_done).count(),
        rows: rows().count(),
        sim_time_s: rows().map(|w| w.sim_time_s).sum(),
        lost_handling: rows().fold(LostCounts::default(), |a, w| a.add(&w.lost)),
        heavy_change: (params.update_every > 1).then(|| heavy_change(params.update_every, runs)),
        retention: retention_summary(runs),
        change_classes: change_class_summary(runs),
        updater_pose_error: (!params.runner.updater_poses.is_localiser())
            .then(|| GivenPoseStats::pool(rows().filter_map(|w| w.updater_pose_error.as_ref()))),
        params: params.clone(),
    }
}

impl Summary {
    /// This summary as versions before `interval_units` made it: with one seed, no interval
    /// (the same summary with several seeds, or with too few worlds for batches).
    pub fn without_one_seed_intervals(mut self) -> Summary {
        if self.interval_units == IntervalUnits::WorldBatches {
            let b = &mut self.by_ground_truth;
            for q in [&mut self.map_quality, &mut b.exact.map_quality, &mut b.observed.map_quality] {
                for m in [&mut q.cc, &mut q.ms, &mut q.opdf] {
                    m.diff_ci95 = None;
                }
            }
            self.localisation.error_diff_ci95_m = None;
            self.interval_units = IntervalUnits::Seeds;
        }
        self
    }
}

/// How the localisation check behaves when k worlds of change meet it at once
/// ([`ValidationParams::update_every`]), over the worlds whose map was updated.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeavyChange {
    /// k.
    pub update_every: usize,
    /// World rows whose map was updated (over all seeds).
    pub update_worlds: usize,
    /// Suspend among their processed steps.
    pub suspend_share: f64,
    /// Lost among them.
    pub lost_share: f64,
    /// Mean position error of the chain localiser in those worlds, metres (how well localised
    /// the robot was while the check said so).
    pub mean_error_m: f64,
    /// Update worlds where fewer than half the processed steps said Update ("stuck").
    pub stuck_worlds: usize,
    /// Longest run of consecutive stuck update worlds in one seed.
    pub longest_stuck_run: usize,
    /// Mean cells changed per update world.
    pub mean_cells_changed: f64,
}

fn heavy_change(k: usize, runs: &[SeedRecord]) -> HeavyChange {
    let updated = |w: &&WorldRow| (w.world - 2).is_multiple_of(k);
    let rows: Vec<&WorldRow> = runs.iter().flat_map(|r| r.rows.iter()).filter(updated).collect();
    let processed: u64 = rows.iter().map(|w| w.updater.processed).sum();
    let share = |n: u64| if processed == 0 { 0.0 } else { n as f64 / processed as f64 };
    let stuck = |w: &WorldRow| w.updater.processed == 0 || 2 * w.updater.update < w.updater.processed;
    let longest = runs
        .iter()
        .map(|r| {
            let (mut best, mut cur) = (0, 0);
            for w in r.rows.iter().filter(updated) {
                cur = if stuck(w) { cur + 1 } else { 0 };
                best = best.max(cur);
            }
            best
        })
        .max()
        .unwrap_or(0);
    HeavyChange {
        update_every: k,
        update_worlds: rows.len(),
        suspend_share: share(rows.iter().map(|w| w.updater.suspend).sum()),
        lost_share: share(rows.iter().map(|w| w.updater.lost).sum()),
        mean_error_m: mean(rows.iter().map(|w| w.loc_updated.mean_error_m)),
        stuck_worlds: rows.iter().filter(|w| stuck(w)).count(),
        longest_stuck_run: longest,
        mean_cells_changed: mean(rows.iter().map(|w| w.cells_changed as f64)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn histogram_median_is_the_median_of_the_values_and_merges_exactly() {
        // A deterministic scramble of small integers with repeats.
        let times: Vec<u32> = (0..101u32).map(|k| (k * 37 + 11) % 23 + 100).collect();
        for n in [0, 1, 2, 3, 10, 51, 100, 101] {
            let v = times[..n].to_vec();
            let h = scan_time_histogram(&v);
            assert!(h.windows(2).all(|w| w[0].0 < w[1].0), "values increase");
            assert_eq!(h.iter().map(|&(_, c)| c).sum::<u64>(), n as u64);
            assert_eq!(
                histogram_median(&h),
                median(v.iter().map(|&t| f64::from(t)).collect()).unwrap_or(0.0),
                "n = {n}"
            );
        }
        let (a, b) = times.split_at(40);
        let merged = merge_histograms([scan_time_histogram(a), scan_time_histogram(b)].iter().map(Vec::as_slice));
        assert_eq!(merged, scan_time_histogram(&times));
        assert_eq!(histogram_median(&[(7, 2), (9, 2)]), 8.0);
    }

    #[test]
    fn shards_cover_the_seeds_once_in_order() {
        let seeds: Vec<u64> = (10..17).collect();
        for count in 1..=7 {
            let joined: Vec<u64> = (1..=count)
                .flat_map(|index| Shard { index, count }.slice(&seeds).expect("non-empty").to_vec())
                .collect();
            assert_eq!(joined, seeds, "{count} shards");
        }
        assert_eq!(Shard { index: 2, count: 3 }.slice(&seeds), Some(&seeds[2..4]));
        assert_eq!(Shard { index: 0, count: 3 }.slice(&seeds), None);
        assert_eq!(Shard { index: 4, count: 3 }.slice(&seeds), None);
        assert_eq!(Shard { index: 1, count: 0 }.slice(&seeds), None);
        assert_eq!(Shard { index: 8, count: 8 }.slice(&seeds), None, "more shards than seeds");
    }

    #[test]
    fn params_of_every_preset_survive_json_and_toml() {
        for preset in mapkeeper_updater::PRESET_NAMES {
            let p = ValidationParams::new(4, preset).expect("valid");
            let json = serde_json::to_string(&p).expect("json");
            assert_eq!(serde_json::from_str::<ValidationParams>(&json).expect("read json"), p, "{preset}");
            let toml = toml::to_string(&p).expect("toml");
            assert_eq!(toml::from_str::<ValidationParams>(&toml).expect("read toml"), p, "{preset}");
        }
    }

    #[test]
    fn saved_worlds_hold_the_last_world() {
        assert_eq!(ValidationParams::new(3, "paper").expect("valid").saved_worlds, vec![2, 3]);
        assert_eq!(ValidationParams::new(100, "paper").expect("valid").saved_worlds, vec![2, 50, 100]);
        assert_eq!(ValidationParams::new(60, "paper").expect("valid").saved_worlds, vec![2, 50, 60]);
    }
}
