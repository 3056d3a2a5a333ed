//! `mapkeeper generate`.

/// Arguments of `mapkeeper generate`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("'mapkeeper generate' is not available yet in this build")
}
