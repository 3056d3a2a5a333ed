//! `mapkeeper metrics`.

/// Arguments of `mapkeeper metrics`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("'mapkeeper metrics' is not available yet in this build")
}
