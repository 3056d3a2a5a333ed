//! `mapkeeper experiment sensor-realism`: the validation chain once per sensor-realism
//! configuration (ideal, each effect alone, realistic) on a short setting, and each one's
//! effect on map quality and localisation against `ideal` (docs/evaluation.md, Sensor realism).

mod print;

mod flags;

use anyhow::Context;
use flags::apply_flags;
use mapkeeper_scenario::experiments::validation::sensor_realism::report::write_sensor_realism;
use mapkeeper_scenario::experiments::validation::sensor_realism::{SensorRealismParams, run_sensor_realism};
use mapkeeper_scenario::{GroundTruth, SweepSpec};
use print::print_table;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `mapkeeper experiment sensor-realism`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Each configuration runs the whole chain of every seed (W_1's map M_1 from the \
exploration scans, then W_2 … W_N driven with the updater), the first --route-length metres of the route in \
each world, everything but the lidars' realism equal. Output in OUT (default \
results/sensor-realism-s<SEED>-<N>w-<counter>): summary.json (configs[].{cc_updated_mean, \
cc_updated_vs_ideal, err_mean_m, err_mean_vs_ideal_m, ...}), worlds.csv, report.md. Same seeds => identical \
files whatever --jobs. The switches: docs/simulator.md, Sensor realism.\n\nExample:\n  mapkeeper experiment \
sensor-realism --worlds 6 --seeds 3\n  mapkeeper experiment sensor-realism --world lab --robot \
summit-xl-steel-ust20lx --configs legs,unsync")]
pub struct Args {
    /// Worlds per chain, 2 to 1000 (default 6).
    #[arg(long, value_name = "N", value_parser = super::count_in(2, 1000), allow_hyphen_values = true)]
    pub worlds: Option<usize>,
    /// Seeds, 1 to 1000 (default 3).
    #[arg(long, value_name = "K", value_parser = super::count_in(1, 1000), allow_hyphen_values = true)]
    pub seeds: Option<usize>,
    /// First run seed (any whole number from 0 to 2^64 − 1; default 11).
    #[arg(long, value_name = "S", value_parser = super::seed, allow_hyphen_values = true)]
    pub seed: Option<u64>,
    /// Updater preset (default mapkeeper).
    #[arg(long, value_name = "NAME")]
    pub preset: Option<String>,
    /// Metres of the route driven in each world, > 0 and ≤ 10000 (default 60).
    #[arg(long, value_name = "METRES", value_parser = super::route_length, allow_hyphen_values = true)]
    pub route_length: Option<f64>,
    /// Configurations, comma-separated: ideal, realistic or effect names (mixed-pixels,
    /// range-noise, motion-distortion, unsync, extrinsic-error, latency, legs), each with `/raw`
    /// appended to run it without deskewing the timed scans (e.g. motion-distortion/raw).
    /// Default: ideal, each effect, realistic, motion-distortion/raw, realistic/raw. `ideal`, the
    /// reference, is always run.
    #[arg(long, value_name = "C1,C2,…", value_delimiter = ',')]
    pub configs: Option<Vec<String>>,
    #[command(flatten)]
    pub site: super::shared_args::WorldArgs,
    /// Robot: an embedded robot's name or a robot file (as `validate --robot`).
    #[arg(long, value_name = "NAME|FILE")]
    pub robot: Option<PathBuf>,
    /// A short setting for tests: 3 worlds, 1 seed, 15 m (unless given).
    #[arg(long)]
    pub quick: bool,
    /// Localiser preset: amcl, mapkeeper, mapkeeper-real or amcl-joint (docs/localiser.md).
    #[arg(long, value_name = "NAME", default_value = "amcl")]
    pub localiser: String,
    /// Parameter file (TOML) with a `[sensor_realism]` table (any of its fields; the flags
    /// override it).
    #[arg(long, value_name = "FILE")]
    pub params: Option<PathBuf>,
    #[command(flatten)]
    pub output: super::shared_args::OutputArgs,
    #[command(flatten)]
    pub threads: super::shared_args::JobsArg,
}

/// The parameter file.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
struct File {
    sensor_realism: SensorRealismParams,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut base = File::default();
    if args.quick {
        base.sensor_realism = SensorRealismParams::quick();
    }
    let mut file = super::load_params(base, args.params.as_deref(), |f: &File| f.sensor_realism.validate())?;
    let p = &mut file.sensor_realism;
    apply_flags(&args, p);
    p.validate().context("--worlds / --seeds / --seed / --preset / --route-length / --configs")?;
    mapkeeper_localiser::FilterParams::preset(&args.localiser).context("--localiser")?;
    let spec = SweepSpec {
        presets: vec![p.preset.clone()],
        worlds: p.worlds,
        first_seed: p.first_seed,
        seeds: 1,
        route_length_m: None,
        shard: None,
        localiser: args.localiser.clone(),
        ground_truth: GroundTruth::Exact,
        site: args.site.load()?,
    };
    let world_name = spec.site.as_ref().map_or_else(|| "warehouse".to_string(), |(n, _)| n.clone());
    let mut plan = spec.plan()?;
    let mut vp = plan.params.swap_remove(0);
    if let Some(path) = &args.robot {
        mapkeeper_sim::RobotFile::named_or_load(path).context("--robot")?.apply(&mut vp.runner.sim);
        vp.runner.sim.validate().context("--robot")?;
    }
    let out = args.output.out.clone().unwrap_or_else(|| default_out(p.first_seed, p.worlds));
    let dir = super::output_dir(&out, args.output.force)?;
    let pool = super::thread_pool(args.threads.jobs)?;
    let chains = (p.run_configs().len() * p.seeds) as u64;
    let bar = pool.install(|| super::progress_bar("experiment sensor-realism", chains, "chains", &out));
    let start = Instant::now();
    let r = pool.install(|| run_sensor_realism(plan.w1.as_ref(), &vp, p, &|| bar.inc(1)))?;
    bar.finish_and_clear();
    let header = format!(
        "World `{world_name}`, robot `{}`, localiser `{}`.",
        args.robot.as_ref().map_or_else(|| "summit-xl-steel (S300 pair)".into(), |r| r.display().to_string()),
        args.localiser
    );
    write_sensor_realism(&dir, &r, &header)?;
    let written = dir.finish()?;
    outln!(
        "sensor-realism: {} configurations × {} seed(s) × {} worlds of {world_name}, preset {}, {:.1} s wall",
        r.summaries.len(),
        p.seeds,
        p.worlds,
        p.preset,
        start.elapsed().as_secs_f64()
    );
    print_table(&r);
    outln!("wrote {}", written.display());
    Ok(())
}

fn default_out(seed: u64, worlds: usize) -> PathBuf {
    super::numbered_out(&format!("sensor-realism-s{seed}-{worlds}w"))
}
