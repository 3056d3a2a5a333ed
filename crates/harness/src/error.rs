//! The harness's error type.

use crate::source::SourceError;

/// What can go wrong while running the loop.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum HarnessError {
    /// The source could not deliver a step.
    #[error(transparent)]
    Source(#[from] SourceError),
    /// The localiser refused a request (initialisation at a non-finite pose or covariance).
    #[error("localiser: {0}")]
    Localiser(#[from] mapkeeper_localiser::LocaliserError),
    /// The updater could not be built.
    #[error("updater: {0}")]
    Updater(#[from] mapkeeper_updater::UpdaterError),
    /// A request the session cannot serve (e.g. setting the estimate of a recorded track).
    #[error("{0}")]
    Unsupported(String),
    /// A job's input cannot be used (a log without scans, a pose track without poses).
    #[error("{0}")]
    Invalid(String),
    /// The baseline localiser's thread panicked.
    #[error("the baseline localiser's thread panicked")]
    BaselinePanicked,
    /// The fresh map's thread ([`crate::jobs::map::ThreadedEstimateMapper`]) panicked.
    #[error("the fresh map's thread panicked")]
    MapperPanicked,
    /// Parameters (a preset, a parameter file) were refused.
    #[error(transparent)]
    Params(#[from] mapkeeper_common::ParamsError),
}
