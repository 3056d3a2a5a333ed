//! `mapkeeper experiment NAME`: one experiment of the paper's claims per subcommand, each into a
//! folder of its own with `summary.json`, CSV, figures and `report.md`; `--quick` runs a short
//! setting (the tests use it). The wall clock is read here, not in the libraries. One file per
//! experiment of the recovery family; `real-data` (with `real-scans`) and `sensor-realism` are `cmd::real_data` and
//! `cmd::realism`.

mod check_detection;
mod kidnap_robot;
mod setup;
mod table1;

pub(super) use crate::cmd::site::site_world;
pub use check_detection::CheckDetectionArgs;
pub use kidnap_robot::KidnapRobotArgs;
use setup::{ExperimentFile, ExperimentTable, load_file};
pub use table1::Table1Args;

use mapkeeper_grid::StagedDir;
use mapkeeper_sim::World;
use std::path::PathBuf;
use std::time::Instant;

/// Largest `--trials`.
const MAX_TRIALS: usize = 100_000;

/// Arguments of `mapkeeper experiment`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub which: Which,
}

/// The experiments. The paper's robustness claims are the first four; two of them come in two
/// variants, named apart: Table 1 with a start error (`recovery-suite`) or with the pose held
/// wrong (`table1-held-pose`), and kidnaps of the estimate (`recovery-suite`) or of the robot
/// itself (`kidnap-robot`).
#[derive(clap::Subcommand, Debug)]
pub enum Which {
    /// The recovery suite (also `mapkeeper recover`): the localisation-check demo, Table 1 with
    /// a 0.7 m start error, the lost robot, and kidnaps of the estimate (the robot drives on).
    #[command(name = "recovery-suite")]
    RecoverySuite(super::recover::Args),
    /// How well the localisation check sees a bad pose: detection rate, false alarms and
    /// latency of each updater preset against injected pose errors in stale worlds.
    CheckDetection(CheckDetectionArgs),
    /// Table 1 with the pose held wrong for T s (and the localiser from a 0.7 m start) on the
    /// whole tour of W_2; always-update / check / check without pose updating per preset.
    #[command(name = "table1-held-pose", visible_alias = "table1")]
    Table1(Table1Args),
    /// Kidnaps of the robot: the robot itself moved 0.5-3 m and up to ±180° (odometry blind) in late,
    /// stale worlds; recoveries by pose updating apart from the filter's own, map damage.
    KidnapRobot(KidnapRobotArgs),
    /// Real logs with reference poses (CARMEN, bags): the localiser's error against the
    /// reference, where odometry contradicts it, the updater on each log's own map.
    RealData(super::real_data::Args),
    /// Real scans, known truth: a stale map made from the map at a real log's reference poses by
    /// seeded edits, the log replayed as worlds W_2 ... W_K, every map scored against the truth.
    RealScans(super::real_data::scans::Args),
    /// Each sensor-realism switch alone (and all of them) against the ideal lidars: map
    /// quality and localisation of the validation chain on a short setting.
    SensorRealism(super::realism::Args),
}

/// The flags every experiment has.
#[derive(clap::Args, Debug)]
pub struct Common {
    /// Localiser preset: amcl, mapkeeper, mapkeeper-real or amcl-joint (docs/localiser.md).
    #[arg(long, value_name = "NAME", default_value = "amcl")]
    pub localiser: String,
    /// Parameter file (TOML): `[recovery]` (worlds, loop; docs/recovery.md) and the
    /// experiment's own table (`[check_detection]`, `[table1]` or `[kidnap_robot]`: any of its
    /// fields).
    #[arg(long, value_name = "FILE")]
    pub params: Option<PathBuf>,
    #[command(flatten)]
    pub output: super::shared_args::OutputArgs,
    #[command(flatten)]
    pub threads: super::shared_args::JobsArg,
    #[command(flatten)]
    pub site: super::shared_args::WorldArgs,
    #[command(flatten)]
    pub timing: super::shared_args::TimingArg,
}

/// Makes the output folder (`--out`, else `default`), then runs `work` in W_1 on the `--jobs`
/// pool with a progress bar of `total` `unit`s; returns its result, the wall time in seconds
/// (0 with `--no-timing`) and the folder to write into.
fn run_timed<R: Send>(
    name: &str,
    c: &Common,
    w1: &World,
    default: PathBuf,
    total: usize,
    unit: &str,
    work: impl FnOnce(&World, &(dyn Fn() + Sync)) -> anyhow::Result<R> + Send,
) -> anyhow::Result<(R, f64, StagedDir)> {
    let out = c.output.out.clone().unwrap_or(default);
    let dir = super::output_dir(&out, c.output.force)?;
    let pool = super::thread_pool(c.threads.jobs)?;
    let bar = pool.install(|| super::progress_bar(&format!("experiment {name}"), total as u64, unit, &out));
    let start = Instant::now();
    let progress = || bar.inc(1);
    let r = pool.install(|| work(w1, &progress))?;
    bar.finish_and_clear();
    Ok((r, c.timing.wall_s(start), dir))
}

fn default_out(stem: &str, seed: u64, trials: usize) -> PathBuf {
    super::numbered_out(&format!("{stem}-s{seed}-{trials}t"))
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    match args.which {
        Which::RecoverySuite(a) => super::recover::run(a),
        Which::CheckDetection(a) => check_detection::run(a),
        Which::Table1(a) => table1::run(a),
        Which::KidnapRobot(a) => kidnap_robot::run(a),
        Which::RealData(a) => super::real_data::run(a),
        Which::RealScans(a) => super::real_data::scans::run(a),
        Which::SensorRealism(a) => super::realism::run(a),
    }
}
