//! `mapkeeper map`.

/// Arguments of `mapkeeper map`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("'mapkeeper map' is not available yet in this build")
}
