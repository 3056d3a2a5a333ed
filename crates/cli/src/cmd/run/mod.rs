//! `mapkeeper run`: one world end to end (simulate, localise, update); writes the updated map,
//! the trajectories and a summary.

mod outputs;

use anyhow::Context;
use mapkeeper_closed_loop::runner::Execution;
use mapkeeper_closed_loop::{RunInputs, RunnerParams, run_world_with};
use mapkeeper_grid::map_io::{load_map, save_map};
use outputs::{run_log, write_outputs};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `mapkeeper run`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Drives the route in WORLD with a localiser on MAP (and a baseline localiser on \
--baseline-map, default MAP), the updater turning MAP into the updated map.\n\n\
Output in OUT: map.yaml + map.pgm (the updated map), true.tum, chain.tum, baseline.tum and \
run.json (localisation statistics, verdict counts, cells changed, collisions).")]
pub struct Args {
    /// The world: `warehouse`, `lab` (embedded), or a world file (TOML, docs/world-format.md);
    /// its route is driven (planned when it has none) unless --route is given.
    #[arg(long, value_name = "NAME|FILE", required_unless_present = "log")]
    pub world: Option<PathBuf>,
    /// Instead of a world: a recorded log (any format `--log` takes: jsonl, MCAP, ROS 1 bag,
    /// CARMEN): the chain localiser and the updater run over it on MAP, as `mapkeeper update
    /// --localise` (output: map.yaml, poses.tum, scans.csv, recovered.tum, recoveries.csv, lost.csv).
    #[arg(long, value_name = "PATH", conflicts_with_all = ["world", "route", "baseline_map"])]
    pub log: Option<PathBuf>,
    /// With --log: where its times come from and which scans are kept (as `convert` takes them).
    #[command(flatten)]
    pub time: super::log_input::TimeFlags,
    /// The map to localise on and update (ROS map_server YAML).
    #[arg(long, value_name = "MAP.yaml")]
    pub map: PathBuf,
    /// The baseline localiser's map (default: MAP).
    #[arg(long, value_name = "MAP.yaml")]
    pub baseline_map: Option<PathBuf>,
    /// Route file (default: the world's route, or a planned patrol when it has none).
    #[arg(long, value_name = "FILE")]
    pub route: Option<PathBuf>,
    /// Updater preset (default mapkeeper, the recommended one; `mapkeeper update --help` lists
    /// them all).
    #[arg(long, default_value = "mapkeeper")]
    pub preset: String,
    /// TOML file overriding any field of the updater preset (as `mapkeeper update --params`).
    #[arg(long, value_name = "FILE.toml")]
    pub params: Option<PathBuf>,
    /// Localiser preset of both localisers: auto (mapkeeper in a world; on a --log, mapkeeper-real
    /// for an imported bag or CARMEN log, mapkeeper for this project's own log.jsonl), mapkeeper,
    /// mapkeeper-real, amcl or amcl-joint (docs/localiser.md); recorded in run.json with its
    /// parameters.
    #[arg(long, value_name = "NAME", default_value = "auto")]
    pub localiser: String,
    /// Run seed (any whole number from 0 to 2^64 − 1).
    #[arg(long, value_name = "S", default_value_t = 1, value_parser = super::seed, allow_hyphen_values = true)]
    pub seed: u64,
    /// Start error of the localisers, metres, 0 to 100 (the warehouse is 15 m × 22 m).
    #[arg(long, value_name = "METRES", default_value_t = 0.05, value_parser = super::real_in(0.0, super::MAX_START_ERROR_M, "m"), allow_hyphen_values = true)]
    pub start_error: f64,
    #[command(flatten)]
    pub output: super::shared_args::RequiredOutputArgs,
    #[command(flatten)]
    pub timing: super::shared_args::TimingArg,
    /// Also write the run as a ROS 2 MCAP bag (scans, odometry, /tf, truth, estimate, particle
    /// cloud, verdicts, the map as it changes; docs/real-data.md) for Foxglove or ros2 bag.
    #[arg(long, value_name = "FILE.mcap")]
    pub mcap: Option<PathBuf>,
    /// Robot file and sensor realism (with --world).
    #[command(flatten)]
    pub sensor: super::sensor::SensorArgs,
    /// The updater's pose source (with --world; recorded in run.json when not the chain
    /// localiser).
    #[command(flatten)]
    pub poses: super::poses::PoseArgs,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let in_world = super::log_input::resolve_localiser(&args.localiser, false);
    mapkeeper_localiser::FilterParams::preset(in_world).context("--localiser")?;
    let world_path = match (&args.world, &args.log) {
        (Some(_), _) if !args.time.is_default() => {
            anyhow::bail!("--time-source, --rate, --keep-every and --every-m need --log (a world's times are its own)")
        }
        (Some(w), _) => w.clone(),
        (None, Some(_)) if args.sensor.is_set() => {
            anyhow::bail!("--robot, --sensor-profile and --sensor-effects need --world (a log brings its own scans)")
        }
        (None, Some(_)) if args.poses.is_set() => {
            anyhow::bail!("--poses and the pose noise flags need --world (on a log: `mapkeeper update --true-poses`)")
        }
        (None, Some(log)) => return run_log(&args, log),
        (None, None) => anyhow::bail!("--world or --log is required"),
    };
    let Some((_, site)) = super::load_site(Some(&world_path), args.route.as_deref(), false)? else {
        anyhow::bail!("--world is required");
    };
    let (world, route) = (site.world, site.route);
    let map = load_map(&args.map)?;
    let baseline = match &args.baseline_map {
        Some(p) => load_map(p)?,
        None => map.clone(),
    };
    let mut params = RunnerParams {
        updater: super::update::load_updater_params(&args.preset, args.params.as_deref())?,
        start_error_m: args.start_error,
        record_trajectories: true,
        ..RunnerParams::default()
    };
    params.set_localiser(in_world).context("--localiser")?;
    params.updater_poses = args.poses.updater_poses()?;
    args.sensor.apply(&mut params.sim)?;
    let dir = super::output_dir(&args.output.out, args.output.force)?;
    let start = Instant::now();
    let wall_clock = super::Wall::start();
    let clock = args.timing.clock(&wall_clock);
    let inputs = RunInputs { world: &world, route: &route, prev_map: &map, baseline_map: &baseline, prev_memory: None };
    let (checked, exec) = (params.checked().context("closed-loop run")?, Execution::timed_by(clock));
    let r = match args.mcap.as_deref() {
        Some(path) => {
            let mut rec = mapkeeper_harness::mcap_out::McapRecorder::create(path)?;
            let r = run_world_with(&inputs, checked, args.seed, "run", &exec, &mut [&mut rec])
                .context("closed-loop run")?;
            outln!("wrote {}", rec.finish(Some(&r.map))?.display());
            r
        }
        None => run_world_with(&inputs, checked, args.seed, "run", &exec, &mut []).context("closed-loop run")?,
    };
    let wall = args.timing.wall_s(start);
    save_map(&r.map, &dir.file("map.yaml")?)?;
    write_outputs(&dir, &args, &world_path, &params, &r, wall)?;
    let out = dir.finish()?;
    outln!(
        "run: {:.1} s simulated in {wall:.1} s; chain error mean {:.3} m max {:.3} m; baseline mean {:.3} m; \
         Update {} Suspend {} Lost {}; {} cells changed; {} collisions{}; wrote {}",
        r.sim_time_s,
        r.chain.mean_error_m,
        r.chain.max_error_m,
        r.baseline.mean_error_m,
        r.updater.update,
        r.updater.suspend,
        r.updater.lost,
        r.cells_changed,
        r.collisions,
        r.given_pose.map_or(String::new(), |e| format!(
            "; updater poses {}, error RMSE {:.3} m",
            params.updater_poses.name(),
            e.rmse_m
        )),
        out.display()
    );
    Ok(())
}
