//! The validation's parameters: the science of a run (worlds, routes, presets, metrics) and
//! which ground truth the maps are scored against; and the shards a run's seeds are sliced into.

use crate::experiments::ExperimentError;
use mapkeeper_closed_loop::runner::{FreshMapParams, RunnerParams};
use mapkeeper_closed_loop::worlds::generator::GeneratorParams;
use mapkeeper_closed_loop::worlds::mapping::MappingParams;
use mapkeeper_common::ParamError;
use mapkeeper_grid::Point2;
use mapkeeper_grid::metrics::MetricParams;
use mapkeeper_sim::Route;
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
    /// Worlds whose drive is also written as a ROS 2 MCAP bag into the run's MCAP folder
    /// (`ValidationRun::mcap_dir`)
    /// (`validate --mcap-worlds`; `docs/real-data.md`). Default none (not written when empty).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub mcap_worlds: Vec<usize>,
    /// The world W_1 by name (`validate --world`: an embedded world's name or the file as
    /// given). Default none: the embedded default warehouse (not written when none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub world: Option<String>,
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
            world: None,
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
    /// storage areas; the world itself is given beside the parameters
    /// (`ValidationRun::w1`, `SweepPlan::w1`).
    pub fn use_site(&mut self, name: &str, site: &mapkeeper_closed_loop::worlds::site::Site) {
        self.route = site.route.clone();
        self.exploration_route = site.exploration.clone();
        self.generator.storage_areas.clone_from(&site.storage);
        self.world = Some(name.to_string());
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
            return Err(ExperimentError::InvalidParam(ParamError::new(
                "update_every",
                self.update_every,
                "must lie in 1..=10000",
            )));
        }
        if self.worlds < 2 {
            return Err(ExperimentError::InvalidParam(ParamError::new(
                "worlds",
                self.worlds,
                "need at least 2 worlds",
            )));
        }
        if !(self.resolution_m.is_finite() && self.resolution_m > 0.0) {
            return Err(ExperimentError::InvalidParam(ParamError::new(
                "resolution_m",
                self.resolution_m,
                "must be a finite length > 0 m",
            )));
        }
        crate::experiments::check_route("route", &self.route, 1)?;
        crate::experiments::check_route("exploration_route", &self.exploration_route, 1)?;
        self.runner.validate()?;
        if self.runner.fresh_map.is_none() {
            return Err(ExperimentError::InvalidParam(ParamError::rule(
                "runner.fresh_map",
                "the validation scores a fresh map of every run: give its mapper and stride",
            )));
        }
        self.generator.validate()?;
        self.mapping.validate()?;
        self.metrics.validate()?;
        Ok(())
    }
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

#[cfg(test)]
mod tests {
    use super::*;

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
