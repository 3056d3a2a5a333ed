//! `mapkeeper simulate`: run the simulator on a world and write a sensor log, the true
//! trajectory and the ground-truth map.

use super::load_params;
use mapkeeper_closed_loop::recording::{DriveSpec, record_drive};
use mapkeeper_grid::map_io;
use mapkeeper_sensor::{SensorLog, write_tum};
use mapkeeper_sim::{Route, SimParams, World, ground_truth_map};
use std::path::PathBuf;

/// Largest `--seconds`: one simulated day.
const MAX_SECONDS: f64 = 86_400.0;

/// Arguments of `mapkeeper simulate`.
#[derive(clap::Args, Debug)]
#[command(
    long_about = "Simulate a world and write a sensor log, the true trajectory and the ground-truth map.\n\n\
Writes DIR/log.jsonl (sensor log, docs/sensor-log.md: odometry and true pose at every 50 Hz tick, \
scans as the lidars fire), DIR/truth.tum (TUM: t x y z qx qy qz qw, t in seconds), \
DIR/ground_truth.yaml + .pgm (ROS map_server, 0.05 m, covering the world), DIR/world.toml (the \
world simulated) and DIR/summary.json (seed, duration, distance, collisions).\n\n\
Without --world the embedded default warehouse is used, with its default 72 m route; a world file \
drives its own route ([route], docs/world-format.md) unless --route is given; a route file \
is TOML: format = \"mapkeeper-route\", version = 1, waypoints = [[x, y], ...] (metres, map frame). \
Without --seconds the run lasts until the route is done (at most 900 s; 60 s without a route).",
    after_help = "Examples:\n  mapkeeper simulate --out runs/default\n  \
mapkeeper simulate --world worlds/warehouse.toml --route route.toml --seconds 120 --seed 3 --out runs/r3"
)]
pub struct Args {
    /// World file (default: the embedded AWS small warehouse).
    #[arg(long, value_name = "FILE")]
    pub world: Option<PathBuf>,
    /// Route file (default: the default warehouse tour when no --world is given, else the
    /// world's `[route]`, or none when it has none).
    #[arg(long, value_name = "FILE")]
    pub route: Option<PathBuf>,
    /// Simulated duration, seconds: > 0 and ≤ 86400 (a day; the log grows by about 0.1 MB
    /// per simulated second).
    #[arg(long, value_name = "T", value_parser = super::positive_up_to(MAX_SECONDS, "s"), allow_hyphen_values = true)]
    pub seconds: Option<f64>,
    /// Run seed; every random stream derives from it (any whole number from 0 to 2^64 − 1).
    #[arg(long, value_name = "S", default_value_t = 0, value_parser = super::seed, allow_hyphen_values = true)]
    pub seed: u64,
    /// Simulator parameters (TOML overriding any field of SimParams).
    #[arg(long, value_name = "FILE")]
    pub params: Option<PathBuf>,
    #[command(flatten)]
    pub output: super::shared_args::RequiredOutputArgs,
    /// Also write the drive as a ROS 2 MCAP bag (scans, odometry, /tf, /tf_static, true poses;
    /// docs/real-data.md) for Foxglove, ros2 bag or a team's own stack.
    #[arg(long, value_name = "FILE.mcap")]
    pub mcap: Option<PathBuf>,
    /// Robot file and sensor realism.
    #[command(flatten)]
    pub sensor: super::sensor::SensorArgs,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let world = match &args.world {
        Some(p) => World::load(p)?,
        None => World::default_warehouse(),
    };
    let route = match (&args.route, &args.world) {
        (Some(p), _) => Some(super::load_route(p, &world)?),
        (None, None) => Some(Route::default_warehouse()),
        (None, Some(_)) => world.route.as_ref().map(mapkeeper_sim::WorldRoute::route),
    };
    let mut params = load_params(SimParams::default(), args.params.as_deref(), SimParams::validate)?;
    args.sensor.apply(&mut params)?;
    let seconds = args.seconds.unwrap_or(if route.is_some() { 900.0 } else { 60.0 });
    let dir = super::output_dir(&args.output.out, args.output.force)?;
    let spec = DriveSpec {
        world: &world,
        route: route.as_ref(),
        params: &params,
        seed: args.seed,
        seconds,
        stop_at_route_end: args.seconds.is_none(),
        tool: "mapkeeper simulate",
    };
    let bar = indicatif::ProgressBar::new((seconds * 1e9 / params.tick_ns as f64).round() as u64);
    let d = record_drive(&spec, &dir.file("log.jsonl")?, &|k| bar.set_position(k))?;
    bar.finish_and_clear();
    let mcap = match &args.mcap {
        Some(p) => Some(mapkeeper_logs::write_log_mcap(&SensorLog::read(&dir.file("log.jsonl")?)?, p)?),
        None => None,
    };
    write_tum(&dir.file("truth.tum")?, &d.truth)?;
    dir.write("world.toml", world.to_toml_string()?.as_bytes())?;
    let g = ground_truth_map(&world, &world.default_map_geometry(0.05)?);
    map_io::save_map(&g, &dir.file("ground_truth.yaml")?)?;
    let summary = serde_json::json!({
        "seed": args.seed,
        "world": world.name,
        "simulated_s": d.simulated_s,
        "distance_m": d.distance_m,
        "scans": d.scans,
        "route_done": d.route_done,
        "collisions": d.collisions,
    });
    dir.write("summary.json", serde_json::to_string_pretty(&summary)?.as_bytes())?;
    let out = dir.finish()?;
    let started = d.collisions.iter().filter(|c| c.started).count();
    let route_note = match (&route, d.route_done) {
        (None, _) => "",
        (Some(_), true) => ", route done",
        (Some(_), false) => ", route not finished",
    };
    outln!(
        "simulated {:.1} s of '{}' (seed {}): {:.1} m driven, {} scans, {started} collisions{route_note}; wrote {}",
        d.simulated_s,
        world.name,
        args.seed,
        d.distance_m,
        d.scans,
        out.display()
    );
    if let Some(p) = mcap {
        outln!("wrote {}", p.display());
    }
    Ok(())
}
