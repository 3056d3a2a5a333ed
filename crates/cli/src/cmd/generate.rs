//! `mapkeeper generate`: writes a seeded scenario set (worlds, ground-truth maps, route,
//! manifest) that another project's tests can consume without this code.

use anyhow::Context;
use mapkeeper_scenario::results::report::write_scenario_set;
use mapkeeper_scenario::{GeneratorParams, generate_worlds};
use mapkeeper_sim::{Route, World};
use std::path::PathBuf;

/// Arguments of `mapkeeper generate`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Writes W_1 (the default warehouse) … W_N, each made from the previous one by a few \
seeded edits to movable items (add, remove, move, rotate), never near the route.\n\n\
Output in OUT: manifest.json (seed, worlds, tool version, files, edits), route.toml, \
worlds/W_001.toml …, ground_truth/G_001.yaml + .pgm … (ROS map_server, 0.05 m). \
The same seed gives byte-identical files. The folder is written atomically.")]
pub struct Args {
    /// Number of worlds.
    #[arg(long, default_value_t = 100)]
    pub worlds: usize,
    /// Run seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Replace an existing non-empty output folder.
    #[arg(long)]
    pub force: bool,
    /// Map resolution, metres per cell.
    #[arg(long, default_value_t = 0.05)]
    pub resolution: f64,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let w1 = World::default_warehouse();
    let route = Route::default_warehouse();
    let geometry = w1.default_map_geometry(args.resolution).context("map geometry")?;
    let chain = generate_worlds(&w1, &route, args.worlds, args.seed, &GeneratorParams::default())?;
    let dir = super::output_dir(&args.out, args.force)?;
    let manifest = write_scenario_set(&dir, &chain, &route, args.seed, &geometry)?;
    let out = dir.finish()?;
    let edits: usize = chain.edits.iter().map(Vec::len).sum();
    println!(
        "wrote {} worlds ({} edits, {} movable items in W_{}) to {}",
        manifest.worlds,
        edits,
        chain.worlds.last().map_or(0, |w| w.movable.len()),
        manifest.worlds,
        out.display()
    );
    Ok(())
}
