//! `mapkeeper simulate`: run the simulator on a world and write a sensor log, the true
//! trajectory and the ground-truth map.

use anyhow::Context;
use mapkeeper_grid::{map_io, write_atomic};
use mapkeeper_sensor::{LogHeader, LogRecord, LogWriter, StampedPose, write_tum};
use mapkeeper_sim::{Route, SimParams, Simulator, World, ground_truth_map};
use std::path::PathBuf;

/// Arguments of `mapkeeper simulate`.
#[derive(clap::Args, Debug)]
#[command(
    long_about = "Simulate a world and write a sensor log, the true trajectory and the ground-truth map.\n\n\
Writes DIR/log.jsonl (sensor log, docs/sensor-log.md: odometry and true pose at every 50 Hz tick, \
scans as the lidars fire), DIR/truth.tum (TUM: t x y z qx qy qz qw, t in seconds), \
DIR/ground_truth.yaml + .pgm (ROS map_server, 0.05 m, covering the world), DIR/world.toml (the \
world simulated) and DIR/summary.json (seed, duration, distance, collisions).\n\n\
Without --world the embedded default warehouse is used, with its default 72 m route; a route file \
is TOML: format = \"mapkeeper-route\", version = 1, waypoints = [[x, y], ...] (metres, map frame). \
Without --seconds the run lasts until the route is done (at most 900 s; 60 s without a route).",
    after_help = "Examples:\n  mapkeeper simulate --out runs/default\n  \
mapkeeper simulate --world worlds/warehouse.toml --route route.toml --seconds 120 --seed 3 --out runs/r3"
)]
pub struct Args {
    /// World file (default: the embedded AWS small warehouse).
    #[arg(long, value_name = "FILE")]
    pub world: Option<PathBuf>,
    /// Route file (default: the default warehouse tour when no --world is given, else none).
    #[arg(long, value_name = "FILE")]
    pub route: Option<PathBuf>,
    /// Simulated duration, seconds.
    #[arg(long, value_name = "T")]
    pub seconds: Option<f64>,
    /// Run seed; every random stream derives from it.
    #[arg(long, value_name = "S", default_value_t = 0)]
    pub seed: u64,
    /// Simulator parameters (TOML overriding any field of SimParams).
    #[arg(long, value_name = "FILE")]
    pub params: Option<PathBuf>,
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Overwrite an existing run in DIR.
    #[arg(long)]
    pub force: bool,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let world = match &args.world {
        Some(p) => World::load(p)?,
        None => World::default_warehouse(),
    };
    let route = match (&args.route, &args.world) {
        (Some(p), _) => Some(Route::load(p)?),
        (None, None) => Some(Route::default_warehouse()),
        (None, Some(_)) => None,
    };
    let params: SimParams = match &args.params {
        Some(p) => {
            let text = std::fs::read_to_string(p).with_context(|| format!("{}", p.display()))?;
            toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {}", p.display(), e.message()))?
        }
        None => SimParams::default(),
    };
    let max_s = match args.seconds {
        Some(s) if s.is_finite() && s > 0.0 && s <= 1e6 => s,
        Some(s) => anyhow::bail!("--seconds must be a positive number of seconds, got {s}"),
        None if route.is_some() => 900.0,
        None => 60.0,
    };
    std::fs::create_dir_all(&args.out).with_context(|| format!("{}", args.out.display()))?;
    let log_path = args.out.join("log.jsonl");
    if log_path.exists() && !args.force {
        anyhow::bail!("{} exists; use --force to overwrite", log_path.display());
    }
    let mut sim = Simulator::new(&world, params.clone(), args.seed)?;
    if let Some(r) = &route {
        sim.set_route(r.points());
    }
    let mut meta = serde_json::Map::new();
    meta.insert("tool".into(), format!("mapkeeper simulate {}", env!("CARGO_PKG_VERSION")).into());
    meta.insert("seed".into(), args.seed.into());
    meta.insert("world".into(), world.name.clone().into());
    meta.insert("tick_ns".into(), params.tick_ns.into());
    meta.insert("robot".into(), serde_json::to_value(&params.robot)?);
    meta.insert("lidars".into(), serde_json::to_value(&params.lidars)?);
    meta.insert("odometry".into(), serde_json::to_value(&params.odometry)?);
    let mut log = LogWriter::create(&log_path, &LogHeader::new(meta))?;
    let ticks = (max_s * 1e9 / params.tick_ns as f64).round() as u64;
    let bar = indicatif::ProgressBar::new(ticks);
    let mut truth: Vec<StampedPose> = Vec::new();
    let mut collisions = Vec::new();
    let mut distance = 0.0;
    let mut last = sim.true_pose();
    let mut scans = 0usize;
    let mut route_done = false;
    for k in 0..ticks {
        let out = sim.step();
        log.write(&LogRecord::Odom(out.odometry))?;
        log.write(&LogRecord::Truth(out.truth))?;
        scans += out.scans.len();
        for s in out.scans {
            log.write(&LogRecord::Scan(s))?;
        }
        let p = out.truth.pose_in_map;
        distance += p.distance(&last);
        last = p;
        truth.push(StampedPose { stamp_ns: out.stamp_ns, pose: p });
        collisions.extend(out.collisions);
        if k % 500 == 0 {
            bar.set_position(k);
        }
        if route.is_some() && args.seconds.is_none() && out.route_done {
            route_done = true;
            break;
        }
        route_done = out.route_done;
    }
    bar.finish_and_clear();
    log.finish()?;
    write_tum(&args.out.join("truth.tum"), &truth)?;
    let world_path = args.out.join("world.toml");
    write_atomic(&world_path, world.to_toml_string()?.as_bytes())
        .with_context(|| format!("cannot write {}", world_path.display()))?;
    let g = ground_truth_map(&world, &world.default_map_geometry(0.05)?);
    map_io::save_map(&g, &args.out.join("ground_truth.yaml"))?;
    let seconds = sim.stamp_ns() as f64 / 1e9;
    let summary = serde_json::json!({
        "seed": args.seed,
        "world": world.name,
        "simulated_s": seconds,
        "distance_m": distance,
        "scans": scans,
        "route_done": route_done,
        "collisions": collisions,
    });
    let summary_path = args.out.join("summary.json");
    write_atomic(&summary_path, serde_json::to_string_pretty(&summary)?.as_bytes())
        .with_context(|| format!("cannot write {}", summary_path.display()))?;
    let started = collisions.iter().filter(|c| c.started).count();
    println!(
        "simulated {seconds:.1} s of '{}' (seed {}): {distance:.1} m driven, {scans} scans, {started} collisions{}; wrote {}",
        world.name,
        args.seed,
        if route.is_some() { if route_done { ", route done" } else { ", route not finished" } } else { "" },
        args.out.display()
    );
    Ok(())
}
