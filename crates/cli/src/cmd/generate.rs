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
    /// Number of worlds, 1 to 10000 (each is a world file and a ground-truth map on disk).
    #[arg(long, value_name = "N", default_value_t = 100, value_parser = super::count_in(1, super::MAX_WORLDS), allow_hyphen_values = true)]
    pub worlds: usize,
    /// Run seed (any whole number from 0 to 2^64 − 1).
    #[arg(long, value_name = "S", default_value_t = 1, value_parser = super::seed, allow_hyphen_values = true)]
    pub seed: u64,
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Replace an existing non-empty output folder.
    #[arg(long)]
    pub force: bool,
    /// Map resolution, metres per cell, 0.005 to 10 (5 mm is below the lidars' 1 cm range
    /// quantisation and gives ~13 M cells per map; 10 m leaves a handful of cells).
    #[arg(long, value_name = "METRES", default_value_t = 0.05, value_parser = super::resolution, allow_hyphen_values = true)]
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
