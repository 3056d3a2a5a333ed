//! `mapkeeper recover`.

/// Arguments of `mapkeeper recover`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("'mapkeeper recover' is not available yet in this build")
}
