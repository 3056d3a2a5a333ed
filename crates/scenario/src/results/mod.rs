//! Results: what every report shares: the claims table ([`claims`]), the figures' size and the
//! error type ([`ResultsError`], with why a folder cannot be merged, [`MergeProblem`]). Each
//! experiment's own report sits in its folder (`experiments/<name>/report.rs`); what is done
//! with validation folders once written (merging shards, comparing presets, the CI check) sits
//! beside the validation (`experiments/validation/{merge,comparison,check}.rs`). Every folder is
//! written through [`mapkeeper_grid::StagedDir`].

pub mod claims;
pub mod html;
mod merge_problem;

pub use merge_problem::MergeProblem;

use std::path::PathBuf;

/// Size of the PNG figures of every report, px.
pub const PNG_SIZE_PX: (u32, u32) = (1200, 750);

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
        problem: MergeProblem,
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
