//! `mapkeeper localise`.

/// Arguments of `mapkeeper localise`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("'mapkeeper localise' is not available yet in this build")
}
