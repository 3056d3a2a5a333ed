//! `mapkeeper run`.

/// Arguments of `mapkeeper run`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("'mapkeeper run' is not available yet in this build")
}
