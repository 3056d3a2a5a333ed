//! Results: the validation's report folder ([`report`]) and figures ([`figures`]), the
//! recovery suite's ([`recovery_report`]), and merging the folders of a sharded sweep
//! ([`merge`]). Every folder is written through [`mapkeeper_grid::StagedDir`].

pub mod check_detection_report;
pub mod claims;
pub mod comparison;
pub mod figures;
pub mod gate;
pub mod html;
pub mod kidnap_robot_report;
pub mod merge;
pub mod real_data_report;
pub mod recovery_report;
pub mod report;
pub mod saved_worlds;
pub mod sensor_realism_report;
pub mod table1_hold_report;

use std::path::PathBuf;

/// What can go wrong while writing or merging results.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ResultsError {
    /// An output could not be written (or exists and replacing it was not asked for).
    #[error(transparent)]
    Output(#[from] mapkeeper_grid::OutputError),
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
    /// Serialising an output failed.
    #[error("{what}: {message}")]
    Serialise {
        /// Which output.
        what: String,
        /// The cause.
        message: String,
    },
    /// Writing a figure failed.
    #[error(transparent)]
    Plot(#[from] mapkeeper_plot::PlotError),
    /// A result folder cannot be merged (or read back).
    #[error("{}: cannot merge: {problem}", dir.display())]
    Merge {
        /// The result folder.
        dir: PathBuf,
        /// What is wrong with it.
        problem: merge::MergeProblem,
    },
    /// A world or route could not be serialised.
    #[error(transparent)]
    Sim(#[from] mapkeeper_sim::SimError),
    /// A map-quality metric failed while re-scoring.
    #[error("metrics: {0}")]
    Metrics(#[from] mapkeeper_grid::metrics::MetricsError),
    /// A results folder or a baseline file that cannot be used (the message names it).
    #[error("{0}")]
    Invalid(String),
}

impl ResultsError {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> ResultsError {
        let path = path.into();
        move |source| ResultsError::Io { path, source }
    }
}
