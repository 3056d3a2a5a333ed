//! The updater's one error type.

/// What can go wrong building a [`crate::MapUpdater`] or choosing its parameters. Bad scans are
/// not errors: they are counted as invalid in the [`crate::StepReport`].
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum UpdaterError {
    /// A parameter is out of range; its name is the field's dotted path for a section's
    /// (`pose_updating.max_rmse_m`).
    #[error("invalid updater parameter '{}': {}", .0.name, .0.problem())]
    InvalidParam(#[from] mapkeeper_common::ParamError),
    /// [`crate::UpdaterParams::preset`] got a name it does not know.
    #[error("unknown updater preset '{name}' (known: {known})")]
    UnknownPreset {
        /// The name given.
        name: String,
        /// The names accepted.
        known: String,
    },
    /// The initial map is unusable (e.g. it has more cells than a `u32` index can address).
    #[error("unusable initial map: {0}")]
    BadMap(String),
}
