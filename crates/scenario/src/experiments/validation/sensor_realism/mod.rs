//! The effect of each sensor-realism switch (issue 13, item 5; `docs/evaluation.md`, Sensor
//! realism): the validation chain of each seed run once per configuration (`ideal`, each
//! effect alone, `realistic`), everything else equal, on a short setting. Each configuration is
//! compared with `ideal` seed by seed (the worlds of one seed are averaged first: they are not
//! independent), so the difference and its interval are the effect of the switch.
//!
//! The worlds, edits and M_1 are the same in every configuration only up to the lidar: M_1 is
//! built from the exploration scans, so a switch changes M_1 too, as it would on a real robot.

pub mod report;

use crate::experiments::ExperimentError;
use crate::experiments::validation::{ValidationParams, ValidationRun, WorldRow, run_seed};
use crate::stats::{PairedDiff, mean, paired_diff};
use mapkeeper_closed_loop::runner::NoClock;
use mapkeeper_closed_loop::trials::{Trials, run_trials};
use mapkeeper_common::ParamError;
use mapkeeper_sim::World;
use mapkeeper_sim::{SensorEffect, SensorRealism};
use serde::{Deserialize, Serialize};

/// Parameters of the experiment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorRealismParams {
    /// Worlds per chain (W_1 … W_N), 2 to 1000. Default 6.
    pub worlds: usize,
    /// Seeds run, 1 to 1000, from `first_seed`. Default 3.
    pub seeds: usize,
    /// First run seed. Default 11 (the validation's; seeds 1-3 are the tuning seeds).
    pub first_seed: u64,
    /// Updater preset. Default `mapkeeper`.
    pub preset: String,
    /// Metres of the route driven in each world (the short setting), > 0. Default 60.
    pub route_length_m: f64,
    /// The configurations: `ideal`, `realistic` or an effect's name (docs/simulator.md), each
    /// with the estimators deskewing timed scans (the default), or with `/raw` appended, without.
    /// Default: ideal, each of the seven effects, realistic, then `motion-distortion/raw` and
    /// `realistic/raw`. `ideal` is added when missing (the reference).
    pub configs: Vec<String>,
}

impl Default for SensorRealismParams {
    fn default() -> Self {
        let mut configs = vec!["ideal".to_string()];
        configs.extend(SensorEffect::ALL.iter().map(|e| e.name().to_string()));
        configs.push("realistic".into());
        configs.extend([format!("motion-distortion{RAW_SUFFIX}"), format!("realistic{RAW_SUFFIX}")]);
        SensorRealismParams {
            worlds: 6,
            seeds: 3,
            first_seed: 11,
            preset: "mapkeeper".into(),
            route_length_m: 60.0,
            configs,
        }
    }
}

impl SensorRealismParams {
    /// The short setting of `--quick`: 3 worlds, 1 seed, 15 m.
    pub fn quick() -> Self {
        Self { worlds: 3, seeds: 1, route_length_m: 15.0, ..Self::default() }
    }
}

/// The suffix of a configuration run without deskewing.
pub const RAW_SUFFIX: &str = "/raw";

/// Whether the estimators deskew timed scans in a configuration (not with [`RAW_SUFFIX`]).
pub fn config_deskews(name: &str) -> bool {
    !name.ends_with(RAW_SUFFIX)
}

/// The realism of a configuration name (a [`RAW_SUFFIX`] aside).
pub fn config_realism(name: &str) -> Result<SensorRealism, String> {
    let name = name.strip_suffix(RAW_SUFFIX).unwrap_or(name);
    match name {
        "ideal" | "realistic" => SensorRealism::profile(name),
        effect => SensorEffect::parse(effect).map(|e| SensorRealism::with_effects(&[e])).map_err(|_| {
            let names: Vec<&str> = SensorEffect::ALL.iter().map(|e| e.name()).collect();
            format!("unknown configuration '{effect}' (ideal, realistic or one of {})", names.join(", "))
        }),
    }
}

impl SensorRealismParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ExperimentError> {
        if !(2..=1000).contains(&self.worlds) {
            return Err(ExperimentError::from(ParamError::rule(
                "sensor_realism.worlds",
                format!("{} is not in 2..=1000", self.worlds),
            )));
        }
        if !(1..=1000).contains(&self.seeds) {
            return Err(ExperimentError::from(ParamError::rule(
                "sensor_realism.seeds",
                format!("{} is not in 1..=1000", self.seeds),
            )));
        }
        if self.first_seed.checked_add(self.seeds as u64).is_none() {
            return Err(ExperimentError::from(ParamError::rule(
                "sensor_realism.first_seed",
                "the last seed overflows 2^64",
            )));
        }
        if !(self.route_length_m.is_finite() && self.route_length_m > 0.0 && self.route_length_m <= 10_000.0) {
            return Err(ExperimentError::from(ParamError::rule(
                "sensor_realism.route_length_m",
                format!("{} is not in (0, 10000]", self.route_length_m),
            )));
        }
        if self.configs.is_empty() {
            return Err(ExperimentError::from(ParamError::rule(
                "sensor_realism.configs",
                "at least one configuration is needed",
            )));
        }
        for (i, c) in self.configs.iter().enumerate() {
            config_realism(c).map_err(|e| {
                ExperimentError::from(ParamError::rule("sensor_realism.configs", format!("[{i}]: {e}")))
            })?;
            if self.configs[..i].contains(c) {
                return Err(ExperimentError::from(ParamError::rule(
                    "sensor_realism.configs",
                    format!("[{i}]: '{c}' is listed twice"),
                )));
            }
        }
        Ok(())
    }

    /// The configurations in run order, `ideal` first.
    pub fn run_configs(&self) -> Vec<String> {
        let mut out = vec!["ideal".to_string()];
        out.extend(self.configs.iter().filter(|c| *c != "ideal").cloned());
        out
    }
}

/// One world of one configuration and seed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RealismRow {
    /// The configuration.
    pub config: String,
    /// The row of the validation (seed, world, scores, localisation, counts).
    #[serde(flatten)]
    pub row: RealismScores,
}

/// The figures kept of a validation row.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RealismScores {
    /// Run seed.
    pub seed: u64,
    /// World i.
    pub world: usize,
    /// CC of M_1 against G_i, %.
    pub cc_static: f64,
    /// CC of M_i against G_i, %.
    pub cc_updated: f64,
    /// MS of M_i against G_i, %.
    pub ms_updated: f64,
    /// OPDF of M_i against G_i, %.
    pub opdf_updated: f64,
    /// Mean position error of the chain localiser (on M_{i-1}), metres.
    pub err_mean_m: f64,
    /// Largest position error of the chain localiser, metres.
    pub err_max_m: f64,
    /// Lost episodes of the chain.
    pub lost_episodes: u64,
    /// Collisions.
    pub collisions: u64,
    /// Whether the route was driven to its end.
    pub route_done: bool,
}

impl RealismScores {
    fn of(r: &WorldRow) -> Self {
        RealismScores {
            seed: r.seed,
            world: r.world,
            cc_static: r.static_map.cc,
            cc_updated: r.updated_map.cc,
            ms_updated: r.updated_map.ms,
            opdf_updated: r.updated_map.opdf,
            err_mean_m: r.loc_updated.mean_error_m,
            err_max_m: r.loc_updated.max_error_m,
            lost_episodes: r.lost.episodes,
            collisions: r.collisions,
            route_done: r.route_done,
        }
    }
}

/// One configuration over every seed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ConfigSummary {
    /// The configuration.
    pub config: String,
    /// The effects it switches on.
    pub effects: Vec<String>,
    /// Mean over worlds and seeds of CC of M_i against G_i, %.
    pub cc_updated_mean: f64,
    /// Mean of MS of M_i against G_i, %.
    pub ms_updated_mean: f64,
    /// Mean of OPDF of M_i against G_i, %.
    pub opdf_updated_mean: f64,
    /// Mean of CC of M_1 against G_i, %.
    pub cc_static_mean: f64,
    /// Mean of the chain localiser's mean error, metres.
    pub err_mean_m: f64,
    /// Largest error of the chain localiser over every run, metres.
    pub err_max_m: f64,
    /// Configuration − ideal in CC of M_i, per seed (mean over its worlds), with 95 % interval.
    pub cc_updated_vs_ideal: PairedDiff,
    /// Configuration − ideal in the mean localisation error, metres, per seed.
    pub err_mean_vs_ideal_m: PairedDiff,
    /// Lost episodes over every run.
    pub lost_episodes: u64,
    /// Collisions over every run.
    pub collisions: u64,
    /// Routes driven to the end, of `runs`.
    pub routes_done: usize,
    /// World runs (seeds × (worlds − 1)).
    pub runs: usize,
}

/// The experiment's result.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SensorRealismResult {
    /// Its parameters.
    pub params: SensorRealismParams,
    /// One summary per configuration, `ideal` first.
    pub summaries: Vec<ConfigSummary>,
    /// Every world run.
    pub rows: Vec<RealismRow>,
}

/// The sweep as [`Trials`]: one job per (configuration, seed), each a short validation chain;
/// the summary compares every configuration with the ideal sensors.
struct RealismTrials<'a> {
    /// W_1; `None`: the embedded default warehouse.
    w1: Option<&'a World>,
    /// The validation parameters of every chain (worlds, preset, route set from the sweep's).
    vp: ValidationParams,
    p: &'a SensorRealismParams,
    configs: Vec<String>,
}

impl Trials for RealismTrials<'_> {
    /// (configuration index, seed).
    type Job = (usize, u64);
    /// One row of scores per world of the chain.
    type Outcome = Vec<RealismScores>;
    type Summary = SensorRealismResult;

    fn draw(&self) -> Vec<(usize, u64)> {
        let (p, n) = (self.p, self.configs.len());
        (0..n).flat_map(|c| (0..p.seeds as u64).map(move |s| (c, p.first_seed + s))).collect()
    }

    fn run(
        &self,
        (c, seed): (usize, u64),
        progress: &(dyn Fn() + Sync),
    ) -> Result<Vec<RealismScores>, ExperimentError> {
        let configs = &self.configs;
        let mut q = self.vp.clone();
        q.runner.sim.realism = config_realism(&configs[c])
            .map_err(|e| ExperimentError::from(ParamError::rule("sensor_realism.configs", e)))?;
        q.runner.deskew = config_deskews(&configs[c]);
        q.mapping.deskew = config_deskews(&configs[c]);
        let run = run_seed(&q, seed, &ValidationRun { w1: self.w1, ..ValidationRun::timed_by(&NoClock) }, &|_| {})?;
        progress();
        Ok(run.rows.iter().map(RealismScores::of).collect())
    }

    fn summarise(&self, runs: Vec<Vec<RealismScores>>) -> Result<SensorRealismResult, ExperimentError> {
        let (p, configs, jobs) = (self.p, &self.configs, self.draw());
        let per_config = |c: usize| -> Vec<&Vec<RealismScores>> {
            jobs.iter().zip(&runs).filter(|((k, _), _)| *k == c).map(|(_, r)| r).collect()
        };
        let seed_means = |c: usize, f: &dyn Fn(&RealismScores) -> f64| -> Vec<f64> {
            per_config(c).iter().map(|rows| mean(rows.iter().map(f))).collect()
        };
        let ideal_cc = seed_means(0, &|r| r.cc_updated);
        let ideal_err = seed_means(0, &|r| r.err_mean_m);
        let diff = |a: &[f64], b: &[f64]| paired_diff(&a.iter().zip(b).map(|(x, y)| x - y).collect::<Vec<_>>());
        let summaries = configs
            .iter()
            .enumerate()
            .map(|(c, name)| {
                let all: Vec<&RealismScores> = per_config(c).into_iter().flatten().collect();
                let effects = config_realism(name).map(|r| r.effects()).unwrap_or_default();
                ConfigSummary {
                    config: name.clone(),
                    effects: effects.iter().map(|e| e.name().to_string()).collect(),
                    cc_updated_mean: mean(all.iter().map(|r| r.cc_updated)),
                    ms_updated_mean: mean(all.iter().map(|r| r.ms_updated)),
                    opdf_updated_mean: mean(all.iter().map(|r| r.opdf_updated)),
                    cc_static_mean: mean(all.iter().map(|r| r.cc_static)),
                    err_mean_m: mean(all.iter().map(|r| r.err_mean_m)),
                    err_max_m: all.iter().map(|r| r.err_max_m).fold(0.0, f64::max),
                    cc_updated_vs_ideal: diff(&seed_means(c, &|r| r.cc_updated), &ideal_cc),
                    err_mean_vs_ideal_m: diff(&seed_means(c, &|r| r.err_mean_m), &ideal_err),
                    lost_episodes: all.iter().map(|r| r.lost_episodes).sum(),
                    collisions: all.iter().map(|r| r.collisions).sum(),
                    routes_done: all.iter().filter(|r| r.route_done).count(),
                    runs: all.len(),
                }
            })
            .collect();
        let rows = jobs
            .iter()
            .zip(&runs)
            .flat_map(|(&(c, _), rows)| {
                let name = &configs[c];
                rows.iter().map(move |r| RealismRow { config: name.clone(), row: *r })
            })
            .collect();
        Ok(SensorRealismResult { params: p.clone(), summaries, rows })
    }
}

/// Runs every configuration × seed ([`mapkeeper_closed_loop::trials::run_trials`]: in parallel on the current rayon pool; the result does not
/// depend on the thread count). `base` gives the world, route, preset-independent parameters
/// and the localiser; its `worlds`, `preset` and route length are set from `p`. `progress` is
/// called once per finished chain.
pub fn run_sensor_realism(
    w1: Option<&World>,
    base: &ValidationParams,
    p: &SensorRealismParams,
    progress: &(dyn Fn() + Sync),
) -> Result<SensorRealismResult, ExperimentError> {
    p.validate()?;
    let configs = p.run_configs();
    let mut vp = base.clone();
    vp.worlds = p.worlds;
    vp.preset.clone_from(&p.preset);
    vp.runner.updater = mapkeeper_updater::UpdaterParams::preset(&p.preset)?;
    vp.saved_worlds.clear();
    vp.route = ValidationParams::truncated_route(&base.route, p.route_length_m);
    vp.validate()?;
    run_trials(&RealismTrials { w1, vp, p, configs }, progress)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn configurations_are_checked_and_ideal_comes_first() {
        let p = SensorRealismParams::default();
        p.validate().unwrap();
        assert_eq!(p.run_configs().len(), 11);
        assert_eq!(p.run_configs()[9..], ["motion-distortion/raw", "realistic/raw"]);
        assert!(!config_deskews("realistic/raw") && config_deskews("realistic"));
        assert_eq!(config_realism("motion-distortion/raw").unwrap(), config_realism("motion-distortion").unwrap());
        assert!(config_realism("fog/raw").is_err());
        assert_eq!(p.run_configs()[0], "ideal");
        let q = SensorRealismParams { configs: vec!["legs".into()], ..p.clone() };
        assert_eq!(q.run_configs(), ["ideal", "legs"]);
        let bad = SensorRealismParams { configs: vec!["legs".into(), "fog".into()], ..p.clone() };
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("sensor_realism.configs") && e.contains("[1]: unknown configuration 'fog'"), "{e}");
        let twice = SensorRealismParams { configs: vec!["legs".into(), "legs".into()], ..p.clone() };
        assert!(twice.validate().unwrap_err().to_string().contains("listed twice"));
        for (worlds, seeds, len) in [(1, 1, 1.0), (6, 0, 1.0), (6, 1, 0.0), (6, 1, f64::NAN)] {
            let q = SensorRealismParams { worlds, seeds, route_length_m: len, ..p.clone() };
            assert!(q.validate().is_err(), "{worlds} {seeds} {len}");
        }
        assert!(config_realism("realistic").unwrap().effects().len() == 7);
        assert!(config_realism("ideal").unwrap().is_ideal());
    }
}
