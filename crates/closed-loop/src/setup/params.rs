//! Parameters of the robustness experiments (`docs/recovery.md`).

use crate::ExperimentError;
use crate::runner::RunnerParams;
use crate::worlds::generator::GeneratorParams;
use crate::worlds::mapping::MappingParams;
use crate::{check_route, check_turn};
use mapkeeper_common::ParamError;
use mapkeeper_grid::metrics::MetricParams;
use mapkeeper_sim::Route;
use serde::{Deserialize, Serialize};

/// Which map of W_1 the robot starts from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum InitialMapKind {
    /// G_1, the exact ground truth of W_1 (the paper's §5.3.1 assumes M_1 = G_1, "built
    /// correctly").
    GroundTruth,
    /// M_1 built by the log-odds mapper in W_1 (as in the validation): unobserved cells stay
    /// unknown and count as occupied for the beam classifier.
    Mapped,
}

impl InitialMapKind {
    /// `ground-truth` or `mapped`.
    pub fn name(self) -> &'static str {
        match self {
            InitialMapKind::GroundTruth => "ground-truth",
            InitialMapKind::Mapped => "mapped",
        }
    }
}

/// What counts as a recovered pose, and for how long it must hold.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SuccessCriterion {
    /// Position error below this, metres. Default 0.2.
    pub max_error_m: f64,
    /// Yaw error below this, radians. Default 5° (0.0873).
    pub max_yaw_error_rad: f64,
    /// The error must stay below both limits from the recovery time to the end of the run,
    /// and the run goes on this long after the latest accepted recovery time, seconds.
    /// Default 2.
    pub hold_s: f64,
}

impl Default for SuccessCriterion {
    fn default() -> Self {
        Self { max_error_m: 0.2, max_yaw_error_rad: 5f64.to_radians(), hold_s: 2.0 }
    }
}

impl SuccessCriterion {
    /// Whether a pose `error_m` and `yaw_error_rad` (absolute) off the truth counts as right:
    /// under both limits.
    pub fn holds(&self, error_m: f64, yaw_error_rad: f64) -> bool {
        error_m < self.max_error_m && yaw_error_rad < self.max_yaw_error_rad
    }
}

/// The localisation-check demo (§5.3.1, Fig. 16).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DemoParams {
    /// i of the world W_i driven (on M_1). Default 2.
    pub world: usize,
    /// Where the drive starts, metres along the tour. Default 42 (the east aisle at (1.0,
    /// 2.45) heading north: see `docs/recovery.md` for why not the tour's start).
    pub tour_position_m: f64,
    /// Initial error of the estimate, metres, to the right of the start heading (the paper:
    /// 0.5 m, no yaw error). Default 0.5.
    pub start_error_m: f64,
    /// Spread of the initial particle cloud in x and y, metres: the localiser is confident in
    /// its wrong start. Default 0.1.
    pub init_sigma_xy_m: f64,
    /// Spread in yaw, radians. Default 0.05.
    pub init_sigma_yaw_rad: f64,
    /// Simulated time, seconds (the paper shows 60 s). Default 60.
    pub duration_s: f64,
}

impl Default for DemoParams {
    fn default() -> Self {
        Self {
            world: 2,
            tour_position_m: 42.0,
            start_error_m: 0.5,
            init_sigma_xy_m: 0.1,
            init_sigma_yaw_rad: 0.05,
            duration_s: 60.0,
        }
    }
}

/// The Table 1 analog (§5.3.1, Fig. 17-20): `always-update` against the localisation check.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Table1Params {
    /// i of the world W_i driven (on M_1); maps are scored against G_i. Default 2.
    pub world: usize,
    /// Where the drive starts, metres along the tour. Default 0 (the validation's start).
    pub tour_position_m: f64,
    /// Initial error, metres, in a seeded direction per run (no yaw error). Default 0.7.
    pub start_error_m: f64,
    /// Spread of the initial particle cloud in x and y, metres. Default 0.1.
    pub init_sigma_xy_m: f64,
    /// Spread in yaw, radians. Default 0.05.
    pub init_sigma_yaw_rad: f64,
    /// Runs (error directions); both updaters drive each run with the same sensor data
    /// until their maps differ. Default 10.
    pub runs: usize,
    /// Length of the drive from the start along the default tour, metres. Default 9.5: the
    /// tour's first leg, a straight line (the paper: "the robot will move in a straight line
    /// until the localisation algorithm recovers the right pose").
    pub route_length_m: f64,
}

impl Default for Table1Params {
    fn default() -> Self {
        Self {
            world: 2,
            tour_position_m: 0.0,
            start_error_m: 0.7,
            init_sigma_xy_m: 0.1,
            init_sigma_yaw_rad: 0.05,
            runs: 10,
            route_length_m: 9.5,
        }
    }
}

/// The lost robot (§5.4, Fig. 28): a start error too large for the localiser.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LostParams {
    /// i of the world W_i driven (on M_1). Default 2.
    pub world: usize,
    /// Where the drive starts, metres along the tour. Default 0 (the validation's start).
    pub tour_position_m: f64,
    /// Initial error, metres, in a seeded direction per run (no yaw error). Default 1.5.
    pub start_error_m: f64,
    /// Spread of the initial particle cloud in x and y, metres. Default 0.1.
    pub init_sigma_xy_m: f64,
    /// Spread in yaw, radians. Default 0.05.
    pub init_sigma_yaw_rad: f64,
    /// Runs (error directions). Default 5.
    pub runs: usize,
    /// Length of the drive along the default tour, metres. Default 30.
    pub route_length_m: f64,
    /// "Not corrupted": CC, MS and OPDF of M_2/G_2 at most this far below those of the same
    /// run without the error, percentage points. Default 1.
    pub corruption_tolerance_pct: f64,
}

impl Default for LostParams {
    fn default() -> Self {
        Self {
            world: 2,
            tour_position_m: 0.0,
            start_error_m: 1.5,
            init_sigma_xy_m: 0.1,
            init_sigma_yaw_rad: 0.05,
            runs: 5,
            route_length_m: 30.0,
            corruption_tolerance_pct: 1.0,
        }
    }
}

/// The kidnap stress suite.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct KidnapParams {
    /// Trials per map case. Default 200.
    pub trials: usize,
    /// Smallest displacement of the estimate, metres. Default 0.5.
    pub min_displacement_m: f64,
    /// Largest displacement, metres. Default 3.0.
    pub max_displacement_m: f64,
    /// Largest yaw displacement (uniform in ±this), radians. Default 45°.
    pub max_yaw_rad: f64,
    /// Earliest kidnap time after the start of a trial, seconds. Default 3.
    pub kidnap_min_s: f64,
    /// Latest kidnap time, seconds. Default 6.
    pub kidnap_max_s: f64,
    /// Recovery must happen within this long after the kidnap, seconds. Default 20.
    pub recovery_window_s: f64,
    /// Spread of the displaced particle cloud in x and y, metres (the localiser believes the
    /// wrong pose). Default 0.1.
    pub sigma_xy_m: f64,
    /// Spread in yaw, radians. Default 0.05.
    pub sigma_yaw_rad: f64,
    /// Stale case: W_k with k drawn uniformly from 2 ..= this, on a map of W_1. Default 10.
    pub stale_max_world: usize,
    /// The stale case's map of W_1. Default [`InitialMapKind::Mapped`] (M_1 as in the
    /// validation).
    pub stale_map: InitialMapKind,
    /// Route of a trial: this far along the default tour from a random point of it, metres
    /// (long enough never to end before the run does). Default 70.
    pub route_length_m: f64,
    /// Edges of the displacement bins of the report, metres, increasing. Default
    /// [0.5, 1.0, 1.5, 2.0, 2.5, 3.0].
    pub bin_edges_m: Vec<f64>,
    /// Run the best case (map = G_k of the current world) as well. Default true.
    pub best_case: bool,
}

impl Default for KidnapParams {
    fn default() -> Self {
        Self {
            trials: 200,
            min_displacement_m: 0.5,
            max_displacement_m: 3.0,
            max_yaw_rad: 45f64.to_radians(),
            kidnap_min_s: 3.0,
            kidnap_max_s: 6.0,
            recovery_window_s: 20.0,
            sigma_xy_m: 0.1,
            sigma_yaw_rad: 0.05,
            stale_max_world: 10,
            stale_map: InitialMapKind::Mapped,
            route_length_m: 70.0,
            bin_edges_m: vec![0.5, 1.0, 1.5, 2.0, 2.5, 3.0],
            best_case: true,
        }
    }
}

/// Parameters of all robustness experiments.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RecoveryParams {
    /// Map resolution, metres per cell. Default 0.05.
    pub resolution_m: f64,
    /// The exploration route for M_1. Default [`Route::exploration_warehouse`].
    pub exploration_route: Route,
    /// The tour driven (or the part of it each experiment drives). Default
    /// [`Route::default_warehouse`].
    pub tour: Route,
    /// The closed loop (start error 0; the baseline localiser is not run). Default
    /// [`RunnerParams::default`] with those changes.
    pub runner: RunnerParams,
    /// The scenario generator.
    pub generator: GeneratorParams,
    /// The M_1 exploration run.
    pub mapping: MappingParams,
    /// The map-quality metrics.
    pub metrics: MetricParams,
    /// The map of W_1 the demo, Table 1 and the lost robot start from. Default
    /// [`InitialMapKind::GroundTruth`] (the paper's §5.3.1: M_1 = G_1).
    pub initial_map: InitialMapKind,
    /// What counts as recovered.
    pub success: SuccessCriterion,
    /// The localisation-check demo.
    pub demo: DemoParams,
    /// The Table 1 analog.
    pub table1: Table1Params,
    /// The lost robot.
    pub lost: LostParams,
    /// The kidnap suite.
    pub kidnap: KidnapParams,
}

impl Default for RecoveryParams {
    fn default() -> Self {
        let runner = RunnerParams {
            start_error_m: 0.0,
            start_error_yaw_rad: 0.0,
            run_baseline: false,
            ..RunnerParams::default()
        };
        Self {
            resolution_m: 0.05,
            exploration_route: Route::exploration_warehouse(),
            tour: Route::default_warehouse(),
            runner,
            generator: GeneratorParams::default(),
            mapping: MappingParams::default(),
            metrics: MetricParams::default(),
            initial_map: InitialMapKind::GroundTruth,
            success: SuccessCriterion::default(),
            demo: DemoParams::default(),
            table1: Table1Params::default(),
            lost: LostParams::default(),
            kidnap: KidnapParams::default(),
        }
    }
}

fn check_pos(name: &'static str, v: f64) -> Result<(), ExperimentError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(ExperimentError::from(ParamError::new(name, v, "must be finite and > 0")))
    }
}

fn check_non_neg(name: &'static str, v: f64) -> Result<(), ExperimentError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(ExperimentError::from(ParamError::new(name, v, "must be finite and ≥ 0")))
    }
}

impl RecoveryParams {
    /// Defaults with `trials` kidnap trials per map case.
    pub fn with_trials(trials: usize) -> Result<Self, ExperimentError> {
        let mut p = Self::default();
        p.kidnap.trials = trials;
        p.validate()?;
        Ok(p)
    }

    /// The number of worlds to generate (W_1 … W_K).
    pub fn worlds_needed(&self) -> usize {
        self.demo.world.max(self.table1.world).max(self.lost.world).max(self.kidnap.stale_max_world).max(2)
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<(), ExperimentError> {
        check_pos("resolution_m", self.resolution_m)?;
        check_route("exploration_route", &self.exploration_route, 1)?;
        check_route("tour", &self.tour, 2)?;
        if self.tour.length_m() <= 0.0 {
            return Err(ExperimentError::from(ParamError::rule("tour", "the tour has zero length")));
        }
        self.runner.validate()?;
        self.generator.validate()?;
        self.mapping.validate()?;
        self.metrics.validate()?;
        let s = &self.success;
        check_pos("success.max_error_m", s.max_error_m)?;
        check_pos("success.max_yaw_error_rad", s.max_yaw_error_rad)?;
        check_non_neg("success.hold_s", s.hold_s)?;
        for (name, w) in [
            ("demo.world", self.demo.world),
            ("table1.world", self.table1.world),
            ("lost.world", self.lost.world),
            ("kidnap.stale_max_world", self.kidnap.stale_max_world),
        ] {
            if !(2..=1000).contains(&w) {
                return Err(ExperimentError::from(ParamError::new(name, w, "must lie in 2..=1000")));
            }
        }
        let d = &self.demo;
        for (name, v) in [
            ("demo.tour_position_m", self.demo.tour_position_m),
            ("table1.tour_position_m", self.table1.tour_position_m),
            ("lost.tour_position_m", self.lost.tour_position_m),
        ] {
            if !v.is_finite() {
                return Err(ExperimentError::from(ParamError::new(name, v, "must be finite")));
            }
        }
        check_non_neg("demo.start_error_m", d.start_error_m)?;
        check_non_neg("demo.init_sigma_xy_m", d.init_sigma_xy_m)?;
        check_non_neg("demo.init_sigma_yaw_rad", d.init_sigma_yaw_rad)?;
        check_pos("demo.duration_s", d.duration_s)?;
        let t = &self.table1;
        check_non_neg("table1.start_error_m", t.start_error_m)?;
        check_non_neg("table1.init_sigma_xy_m", t.init_sigma_xy_m)?;
        check_non_neg("table1.init_sigma_yaw_rad", t.init_sigma_yaw_rad)?;
        check_pos("table1.route_length_m", t.route_length_m)?;
        let l = &self.lost;
        check_non_neg("lost.start_error_m", l.start_error_m)?;
        check_non_neg("lost.init_sigma_xy_m", l.init_sigma_xy_m)?;
        check_non_neg("lost.init_sigma_yaw_rad", l.init_sigma_yaw_rad)?;
        check_pos("lost.route_length_m", l.route_length_m)?;
        check_non_neg("lost.corruption_tolerance_pct", l.corruption_tolerance_pct)?;
        let k = &self.kidnap;
        check_non_neg("kidnap.min_displacement_m", k.min_displacement_m)?;
        check_non_neg("kidnap.max_displacement_m", k.max_displacement_m)?;
        if k.min_displacement_m > k.max_displacement_m {
            return Err(ExperimentError::from(ParamError::rule(
                "kidnap.min_displacement_m",
                "must not exceed max_displacement_m",
            )));
        }
        check_non_neg("kidnap.max_yaw_rad", k.max_yaw_rad)?;
        check_turn("kidnap.max_yaw_rad", k.max_yaw_rad)?;
        check_non_neg("kidnap.kidnap_min_s", k.kidnap_min_s)?;
        check_non_neg("kidnap.kidnap_max_s", k.kidnap_max_s)?;
        if k.kidnap_min_s > k.kidnap_max_s {
            return Err(ExperimentError::from(ParamError::rule("kidnap.kidnap_min_s", "must not exceed kidnap_max_s")));
        }
        check_pos("kidnap.recovery_window_s", k.recovery_window_s)?;
        check_non_neg("kidnap.sigma_xy_m", k.sigma_xy_m)?;
        check_non_neg("kidnap.sigma_yaw_rad", k.sigma_yaw_rad)?;
        check_pos("kidnap.route_length_m", k.route_length_m)?;
        if k.bin_edges_m.len() < 2
            || k.bin_edges_m.iter().any(|v| !v.is_finite())
            || k.bin_edges_m.windows(2).any(|w| w[0] >= w[1])
        {
            return Err(ExperimentError::from(ParamError::rule(
                "kidnap.bin_edges_m",
                "needs at least two finite, increasing edges",
            )));
        }
        Ok(())
    }
}
