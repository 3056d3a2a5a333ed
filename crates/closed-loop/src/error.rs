//! What can go wrong while running the closed loop or an experiment on it: one error for every
//! experiment ([`ExperimentError`]), and the checks the experiments' parameters share.

use crate::worlds::WorldsError;
use mapkeeper_common::ParamError;

/// What can go wrong while running an experiment.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExperimentError {
    /// A parameter is out of range (checked once, where a run starts).
    #[error("parameter {} is invalid: {}", .0.name, .0.problem())]
    InvalidParam(#[from] ParamError),
    /// The worlds or M_1 could not be made.
    #[error(transparent)]
    Worlds(#[from] WorldsError),
    /// The simulator refused a world or its parameters.
    #[error(transparent)]
    Sim(#[from] mapkeeper_sim::SimError),
    /// The localiser refused its parameters or an initial pose.
    #[error("localiser: {0}")]
    Localiser(#[from] mapkeeper_localiser::LocaliserError),
    /// The updater refused its parameters or map.
    #[error("updater: {0}")]
    Updater(#[from] mapkeeper_updater::UpdaterError),
    /// The closed loop failed (a source, a control or the baseline's thread).
    #[error("closed loop: {0}")]
    Loop(#[from] mapkeeper_harness::HarnessError),
    /// A map-quality metric failed (e.g. geometry mismatch).
    #[error("metrics: {0}")]
    Metrics(#[from] mapkeeper_grid::metrics::MetricsError),
    /// An input cannot be used (a recorded log without reference poses, a preset unknown).
    #[error("{0}")]
    Invalid(String),
    /// A job's checkpoint (`validate --resume`) cannot be written, read or used.
    #[error("checkpoint {}: {problem}", path.display())]
    Checkpoint {
        /// The checkpoint file or folder.
        path: std::path::PathBuf,
        /// What is wrong.
        problem: String,
    },
}

/// Checks the largest turn an experiment draws (`name`: the parameter): at most a full turn.
/// Angles wrap, so anything up to 2π is harmless; beyond, a draw's range of ±`v` could be of
/// infinite width (rand panics).
pub fn check_turn(name: &'static str, v: f64) -> Result<(), ExperimentError> {
    if v > std::f64::consts::TAU {
        return Err(ExperimentError::from(ParamError::rule(
            name,
            format!("must be at most 2π (a full turn), got {v:e}"),
        )));
    }
    Ok(())
}

/// Checks a route given in an experiment's parameters (`name`: the parameter): at least one
/// waypoint (`min_points`, for tours that must go somewhere), every one finite, and a finite
/// length. Routes parsed from a file of their own are checked by `Route::from_toml_str`; a
/// route inside a parameter file is not, so that a waypoint at `inf` (TOML has it) would reach
/// the random draws along the route.
pub fn check_route(name: &'static str, route: &mapkeeper_sim::Route, min_points: usize) -> Result<(), ExperimentError> {
    if let Some((entry, problem)) = route.problem() {
        return Err(ExperimentError::from(ParamError::rule(name, format!("{entry}: {problem}"))));
    }
    if route.waypoints.len() < min_points {
        return Err(ExperimentError::from(ParamError::rule(
            name,
            format!("needs at least {min_points} waypoints, got {}", route.waypoints.len()),
        )));
    }
    let length = route.length_m();
    if !length.is_finite() {
        return Err(ExperimentError::from(ParamError::rule(
            name,
            format!("its length must be finite, got {length} m"),
        )));
    }
    Ok(())
}
