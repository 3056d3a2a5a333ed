//! The crate's error type.

use std::path::PathBuf;

/// Everything that can go wrong in the scenario crate.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// A parameter is out of range (checked once, at construction).
    #[error("parameter {name} is invalid: {problem}")]
    InvalidParam {
        /// The field.
        name: &'static str,
        /// What is wrong.
        problem: String,
    },
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
    /// The mapper refused its parameters.
    #[error("mapper: {0}")]
    Mapper(#[from] mapkeeper_grid::mapper::MapperError),
    /// A map-quality metric failed (e.g. geometry mismatch).
    #[error("metrics: {0}")]
    Metrics(#[from] mapkeeper_grid::metrics::MetricsError),
    /// Reading or writing a map file failed.
    #[error(transparent)]
    MapIo(#[from] mapkeeper_grid::map_io::MapIoError),
    /// Writing a trajectory failed.
    #[error(transparent)]
    Tum(#[from] mapkeeper_sensor::tum::TumError),
    /// A file or folder could not be read, written or renamed.
    #[error("{path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// An output could not be written (or exists and replacing it was not asked for).
    #[error(transparent)]
    Output(#[from] mapkeeper_grid::OutputError),
    /// Serialising an output failed.
    #[error("{what}: {message}")]
    Serialise {
        /// Which output.
        what: String,
        /// The cause.
        message: String,
    },
    /// The generator could not make a valid world.
    #[error("scenario generator: {0}")]
    Generator(String),
    /// Writing a figure failed.
    #[error(transparent)]
    Plot(#[from] mapkeeper_plot::PlotError),
    /// A result folder cannot be merged (or read back).
    #[error("{}: cannot merge: {problem}", dir.display())]
    Merge {
        /// The result folder.
        dir: PathBuf,
        /// What is wrong with it.
        problem: crate::merge::MergeProblem,
    },
}

impl ScenarioError {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> ScenarioError {
        let path = path.into();
        move |source| ScenarioError::Io { path, source }
    }
}
