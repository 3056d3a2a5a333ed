//! `mapkeeper simulate`.

/// Arguments of `mapkeeper simulate`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("'mapkeeper simulate' is not available yet in this build")
}
