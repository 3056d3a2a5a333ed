//! `mapkeeper experiment real-data`: the localiser and the updater on recorded logs with
//! reference poses (the CARMEN logs of `../shared/data/carmen/`, or the user's own); `real-scans`
//! ([`scans`]) judges the updater on them against the map at the reference poses.

mod reading;
pub mod scans;

use super::load_params;
use anyhow::Context;
use mapkeeper_grid::mapper::MapperParams;
use mapkeeper_harness::config::params_from_toml_str;
use mapkeeper_harness::jobs::map::MapLogParams;
use mapkeeper_localiser::FilterParams;
use mapkeeper_scenario::experiments::real_data::report::write_real_data;
use mapkeeper_scenario::experiments::real_data::{
    LocaliserConfig, ODOMETRY_TUNED_LOCALISER_TOML, RealDataParams, run_real_data,
};
pub use reading::ReadingFlags;
use reading::read;
use std::path::PathBuf;
use std::time::Instant;

/// The shared CARMEN logs, relative to the working folder, used when no `--log` is given.
const SHARED_LOGS: [&str; 3] = [
    "../shared/data/carmen/intel-corrected.log.gz",
    "../shared/data/carmen/freiburg-079-corrected.log.gz",
    "../shared/data/carmen/aces-corrected.log.gz",
];

/// The three shared CARMEN logs (`--log` not given), or an error saying where they were looked for.
fn shared_logs() -> anyhow::Result<Vec<PathBuf>> {
    let shared: Vec<PathBuf> = SHARED_LOGS.iter().map(PathBuf::from).collect();
    anyhow::ensure!(
        shared.iter().all(|p| p.is_file()),
        "--log: none given, and the shared CARMEN logs are not at ../shared/data/carmen/ (run from the clone's \
folder with ../shared beside it, or name logs with --log)"
    );
    Ok(shared)
}

/// Arguments of `mapkeeper experiment real-data`.
#[derive(clap::Args, Debug)]
#[command(after_help = "For each log (with reference poses: a CARMEN corrected log, or a bag with --truth-topic): \
the map at the reference poses (0.05 m, no-return beams do not clear), the localiser from the first reference pose \
with the raw odometry, the error against the reference (targets: RMSE <= 0.05 m, largest <= 0.25 m), where the \
odometry contradicts the reference, how well the reference agrees with its own map (each scan matched from its \
reference pose), and the updater over the log on its own map with the reference poses and with the estimate of \
`mapkeeper-real`. Three localiser configurations: `mapkeeper` (the simulator's preset as it is), `odometry-tuned` (the \
second release's configuration for real logs: crates/scenario/params/odometry_tuned_localiser.toml over `mapkeeper`, \
no scan matching) and `mapkeeper-real` (the preset for real logs, with the scan-matching front end; --params \
overrides its fields); both tuned on the Intel log only. Without --log: the three logs of ../shared/data/carmen/. Output in OUT (default results/real-data-s<SEED>-<counter>): \
summary.json, report.md, and per log map.yaml, reference.tum, estimate_<config>.tum (TUM, for evo), errors_<config>.csv, \
odometry_vs_reference.csv, changes_<preset>_<poses>.png. Definitions: docs/real-data.md.")]
pub struct Args {
    /// A log to run (repeat for several; the reading flags apply to each). Default: the three
    /// CARMEN logs of ../shared/data/carmen/.
    #[arg(long = "log", value_name = "PATH")]
    pub logs: Vec<PathBuf>,
    /// How the logs are read (--log is taken from above).
    #[command(flatten)]
    pub reading: ReadingFlags,
    /// TOML overriding any FilterParams field of the `mapkeeper-real` configuration (its
    /// scan matcher under `[scan_match]`).
    #[arg(long, value_name = "FILE.toml")]
    pub params: Option<PathBuf>,
    /// Updater presets run over each log, comma-separated.
    #[arg(long, value_name = "A,B", value_delimiter = ',', default_value = "paper,mapkeeper")]
    pub presets: Vec<String>,
    /// First localiser seed (any whole number from 0 to 2^64 − 1).
    #[arg(long, value_name = "S", default_value_t = 0, value_parser = super::seed, allow_hyphen_values = true)]
    pub seed: u64,
    /// Localiser seeds: S, S + 1, …, 1 to 1000 (each configuration runs once per seed).
    #[arg(long, value_name = "K", default_value_t = 3, value_parser = super::count_in(1, 1000), allow_hyphen_values = true)]
    pub seeds: usize,
    #[command(flatten)]
    pub output: super::shared_args::OutputArgs,
    #[command(flatten)]
    pub timing: super::shared_args::TimingArg,
    #[command(flatten)]
    pub threads: super::shared_args::JobsArg,
}

fn default_out(seed: u64) -> PathBuf {
    super::numbered_out(&format!("real-data-s{seed}"))
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let logs: Vec<PathBuf> = if args.logs.is_empty() { shared_logs()? } else { args.logs.clone() };
    for p in &args.presets {
        mapkeeper_updater::UpdaterParams::preset(p).with_context(|| format!("--presets: '{p}'"))?;
    }
    let base = FilterParams::preset("mapkeeper")?;
    let odometry_tuned = params_from_toml_str(base, ODOMETRY_TUNED_LOCALISER_TOML, FilterParams::validate)
        .map_err(|e| anyhow::anyhow!("the embedded odometry_tuned_localiser.toml: {e}"))?;
    let real_preset = FilterParams::preset("mapkeeper-real")?;
    let logs_params = load_params(real_preset, args.params.as_deref(), FilterParams::validate)?;
    let logs_description = match &args.params {
        Some(p) => format!("the mapkeeper-real preset with the overrides of {}", p.display()),
        None => "the mapkeeper-real preset: the scan-matching front end on (tuned on the Intel log only)".into(),
    };
    let params = RealDataParams {
        mapper: MapLogParams {
            mapper: MapperParams::default(),
            no_return_clear_m: 0.0,
            resolution_m: 0.05,
            margin_m: 1.0,
        },
        localisers: vec![
            LocaliserConfig {
                name: "mapkeeper".into(),
                description: "the mapkeeper preset as it is".into(),
                params: base,
            },
            LocaliserConfig {
                name: "odometry-tuned".into(),
                description: "the second release's configuration for real logs: the mapkeeper preset with the \
overrides of crates/scenario/params/odometry_tuned_localiser.toml, odometry-driven (tuned on the Intel log only)"
                    .into(),
                params: odometry_tuned,
            },
            LocaliserConfig { name: "mapkeeper-real".into(), description: logs_description, params: logs_params },
        ],
        updater_presets: args.presets.clone(),
        seeds: (0..args.seeds as u64).map(|k| args.seed.wrapping_add(k)).collect(),
        reference_fit: real_preset.scan_match,
    };
    let datasets = logs.iter().map(|p| read(p, &args.reading)).collect::<anyhow::Result<Vec<_>>>()?;
    let out = args.output.out.clone().unwrap_or_else(|| default_out(args.seed));
    let dir = super::output_dir(&out, args.output.force)?;
    let pool = super::thread_pool(args.threads.jobs)?;
    let start = Instant::now();
    let results = pool.install(|| run_real_data(&datasets, &params, &|| {}))?;
    let wall = args.timing.wall_s(start);
    write_real_data(&dir, &results, &params, wall)?;
    let out = dir.finish()?;
    for d in &results {
        for l in &d.localisers {
            outln!(
                "{} ({} scans, {:.0} m): {} mean RMSE {:.4} m, mean max {:.3} m over {} seeds; both targets met by {} of them",
                d.name,
                d.scans,
                d.path_m,
                l.localiser,
                l.mean_rmse_m,
                l.mean_max_m,
                l.by_seed.len(),
                l.seeds_meeting_targets
            );
        }
    }
    outln!("{:.1} s wall; wrote {}", wall, out.display());
    Ok(())
}
