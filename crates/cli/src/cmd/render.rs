//! `mapkeeper render`.

/// Arguments of `mapkeeper render`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("'mapkeeper render' is not available yet in this build")
}
