//! `mapkeeper generate`: writes a seeded scenario set (worlds, ground-truth maps, route,
//! manifest) that another project's tests can consume without this code.

mod logs;

use anyhow::Context;
use logs::write_logs;
use mapkeeper_closed_loop::{GeneratorParams, generate_worlds};
use mapkeeper_scenario::experiments::validation::report::write_scenario_set;
use mapkeeper_sim::{Route, World};

/// Arguments of `mapkeeper generate`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Writes W_1 (the default warehouse) … W_N, each made from the previous one by a few \
seeded edits to movable items (add, remove, move, rotate), never near the route.\n\n\
Output in OUT: manifest.json (seed, worlds, tool version, files, edits), route.toml, \
worlds/W_001.toml …, ground_truth/G_001.yaml + .pgm … (ROS map_server, 0.05 m). \
The same seed gives byte-identical files. The folder is written atomically.\n\nWith --logs jsonl|mcap, also one simulated drive of the route in each world as a sensor log: logs/W_001.jsonl (docs/sensor-log.md) or logs/W_001.mcap (a ROS 2 bag: scans, odometry, /tf, /tf_static, /truth; docs/real-data.md), each world's drive seeded from --seed and the world's number, and logs/logs.json (per world: file, seed, scans, distance, duration, whether the route was done, collisions), so a team's CI can replay the scenario set through its own stack.")]
pub struct Args {
    /// Number of worlds, 1 to 10000 (each is a world file and a ground-truth map on disk).
    #[arg(long, value_name = "N", default_value_t = 100, value_parser = super::count_in(1, super::MAX_WORLDS), allow_hyphen_values = true)]
    pub worlds: usize,
    /// Run seed (any whole number from 0 to 2^64 − 1).
    #[arg(long, value_name = "S", default_value_t = 1, value_parser = super::seed, allow_hyphen_values = true)]
    pub seed: u64,
    #[command(flatten)]
    pub output: super::shared_args::RequiredOutputArgs,
    /// Map resolution, metres per cell, 0.005 to 10 (5 mm is below the lidars' 1 cm range
    /// quantisation and gives ~13 M cells per map; 10 m leaves a handful of cells).
    #[arg(long, value_name = "METRES", default_value_t = 0.05, value_parser = super::resolution, allow_hyphen_values = true)]
    pub resolution: f64,
    /// Harder worlds: from W_2 on, each world's tour starts at a seeded waypoint and is driven
    /// either way, the robot starting there; each world's route is written as `routes/R_NNN.toml`
    /// (listed in manifest.json).
    #[arg(long)]
    pub route_variants: bool,
    /// Harder worlds: from W_2 on, people stop and stand at each waypoint for a seeded time up to
    /// this many seconds, 0 to 600.
    #[arg(long, value_name = "SECONDS", value_parser = super::real_in(0.0, 600.0, "s"), allow_hyphen_values = true)]
    pub people_pause_s: Option<f64>,
    #[command(flatten)]
    pub site: super::shared_args::WorldArgs,
    /// Also write one simulated drive of each world as a sensor log: jsonl or mcap.
    #[arg(long, value_name = "FORMAT", value_parser = ["jsonl", "mcap"])]
    pub logs: Option<String>,
    /// With --logs: worker threads, 1 to 1024 (default: all cores; the logs are the same for any
    /// count).
    #[arg(long, value_name = "N", value_parser = super::jobs, allow_hyphen_values = true)]
    pub jobs: Option<usize>,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut params = GeneratorParams {
        route_variants: args.route_variants,
        people_pause_s: args.people_pause_s.unwrap_or(0.0),
        ..GeneratorParams::default()
    };
    let (w1, route) = match args.site.load()? {
        Some((_, site)) => {
            params.storage_areas = site.storage;
            (site.world, site.route)
        }
        None => (World::default_warehouse(), Route::default_warehouse()),
    };
    let geometry = w1.default_map_geometry(args.resolution).context("map geometry")?;
    let chain = generate_worlds(&w1, &route, args.worlds, args.seed, &params)?;
    let dir = super::output_dir(&args.output.out, args.output.force)?;
    let manifest = write_scenario_set(&dir, &chain, &route, args.seed, &geometry)?;
    if let Some(format) = &args.logs {
        write_logs(&dir, &chain.worlds, &chain.routes, args.seed, format, args.jobs)?;
    }
    let out = dir.finish()?;
    let edits: usize = chain.edits.iter().map(Vec::len).sum();
    outln!(
        "wrote {} worlds ({} edits, {} movable items in W_{}){} to {}",
        manifest.worlds,
        edits,
        chain.worlds.last().map_or(0, |w| w.movable.len()),
        manifest.worlds,
        args.logs.as_ref().map_or_else(String::new, |f| format!(" and a {f} drive log of each")),
        out.display()
    );
    Ok(())
}
