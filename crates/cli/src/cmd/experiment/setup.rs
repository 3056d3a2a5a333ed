//! What every experiment of the recovery family sets up the same way: its parameter file
//! (`[recovery]` and its own table; its world W_1 is `cmd::site::site_world`).

use super::Common;
use anyhow::Context;
use mapkeeper_scenario::RecoveryParams;
use mapkeeper_scenario::experiments::ExperimentError;
use serde::Serialize;
use serde::de::DeserializeOwned;

/// The parameter file of an experiment of the recovery family: `[recovery]` and the experiment's
/// own table.
pub(super) trait ExperimentFile: Default + Serialize + DeserializeOwned {
    /// The `[recovery]` table.
    fn recovery_mut(&mut self) -> &mut RecoveryParams;
    /// The experiment's own table set to its `--quick` setting.
    fn set_quick(&mut self);
    /// Both tables checked.
    fn check(&self) -> Result<(), ExperimentError>;
}

/// An experiment's parameters, one way for all: the defaults with `--localiser`, then the
/// `--quick` setting, then the `--params` file laid over them, validated.
pub(super) fn load_file<F: ExperimentFile>(c: &Common, quick: bool) -> anyhow::Result<F> {
    let mut base = F::default();
    base.recovery_mut().runner.set_localiser(&c.localiser).context("--localiser")?;
    if quick {
        base.set_quick();
    }
    crate::cmd::load_params(base, c.params.as_deref(), F::check)
}
