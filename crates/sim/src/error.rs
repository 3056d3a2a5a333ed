//! The crate's one error type.

use std::path::PathBuf;

/// Everything that can go wrong in the simulator crate. File errors name the file (or the
/// origin string given for text), the entry and the problem.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A world or route file is not valid TOML of the expected shape (syntax, types, unknown keys).
    #[error("{origin}: {message}")]
    Parse {
        /// File name (or the origin given for text).
        origin: String,
        /// What the parser said, with line and column.
        message: String,
    },
    /// A world or route file parses but one entry is wrong.
    #[error("{origin}: {entry}: {problem}")]
    Invalid {
        /// File name (or the origin given for text).
        origin: String,
        /// The entry, e.g. `movable[3] "box-12"`.
        entry: String,
        /// What is wrong with it.
        problem: String,
    },
    /// A parameter struct holds an unusable value.
    #[error("{component}: {error}")]
    Params {
        /// The parameter struct, e.g. `RobotParams` or `lidars[1]`.
        component: String,
        /// The parameter, its value and what it must be.
        #[source]
        error: mapkeeper_common::ParamError,
    },
    /// A grid could not be built.
    #[error(transparent)]
    Grid(#[from] mapkeeper_grid::GridError),
    /// The simulation cannot be built from this world (e.g. a rapier shape was refused).
    #[error("cannot build the simulation: {0}")]
    Build(String),
}

pub(crate) fn params_err(component: impl Into<String>, error: mapkeeper_common::ParamError) -> SimError {
    SimError::Params { component: component.into(), error }
}
