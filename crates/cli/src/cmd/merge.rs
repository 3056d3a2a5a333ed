//! `mapkeeper merge`.

/// Arguments of `mapkeeper merge`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("'mapkeeper merge' is not available yet in this build")
}
