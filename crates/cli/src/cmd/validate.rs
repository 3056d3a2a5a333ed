//! `mapkeeper validate`.

/// Arguments of `mapkeeper validate`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("'mapkeeper validate' is not available yet in this build")
}
