//! `mapkeeper update`.

/// Arguments of `mapkeeper update`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("'mapkeeper update' is not available yet in this build")
}
