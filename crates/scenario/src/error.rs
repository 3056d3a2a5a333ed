//! The crate's umbrella error: each job module has its own type ([`WorldsError`],
//! [`ExperimentError`], [`ResultsError`]); this one carries any of them for callers that run
//! several jobs (the command line).

use crate::experiments::ExperimentError;
use crate::results::ResultsError;
use mapkeeper_closed_loop::worlds::WorldsError;

/// Any error of the scenario crate.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ScenarioError {
    /// Generating worlds or M_1.
    #[error(transparent)]
    Worlds(#[from] WorldsError),
    /// Running an experiment.
    #[error(transparent)]
    Experiment(#[from] ExperimentError),
    /// Writing or merging results.
    #[error(transparent)]
    Results(#[from] ResultsError),
}
