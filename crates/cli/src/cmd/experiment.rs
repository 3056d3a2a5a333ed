//! `mapkeeper experiment NAME`: one experiment of the paper's claims per subcommand, each into a
//! folder of its own with `summary.json`, CSV, figures and `report.md`; `--quick` runs a short
//! setting (the tests use it). The wall clock is read here, not in the libraries.

use super::load_params;
use anyhow::Context;
use mapkeeper_grid::StagedDir;
use mapkeeper_scenario::RecoveryParams;
use mapkeeper_scenario::experiments::check_detection::{CheckDetectionParams, run_check_detection};
use mapkeeper_scenario::experiments::kidnap_robot::{KidnapRobotParams, run_kidnap_robot};
use mapkeeper_scenario::experiments::table1_hold::{Table1HoldParams, VARIANTS, run_table1_hold};
use mapkeeper_scenario::results::check_detection_report::write_check_detection;
use mapkeeper_scenario::results::kidnap_robot_report::write_kidnap_robot;
use mapkeeper_scenario::results::table1_hold_report::write_table1_hold;
use mapkeeper_sim::World;
use serde::{Deserialize, Serialize};
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

/// The experiments.
#[derive(clap::Subcommand, Debug)]
pub enum Which {
    /// How well the localisation check sees a bad pose: detection rate, false alarms and
    /// latency of each updater preset against injected pose errors in stale worlds.
    CheckDetection(CheckDetectionArgs),
    /// Table 1 for real: the pose held wrong for T s (or the localiser from a 0.7 m start) on
    /// the whole tour of W_2; always-update / check / check without pose updating per preset.
    Table1(Table1Args),
    /// Real kidnaps: the robot itself moved 0.5-3 m and up to ±180° (odometry blind) in late,
    /// stale worlds; recoveries by pose updating apart from the filter's own, map damage.
    KidnapRobot(KidnapRobotArgs),
    /// Real logs with reference poses (CARMEN, bags): the localiser's error against the
    /// reference, where odometry contradicts it, the updater on each log's own map.
    RealData(super::real_data::Args),
    /// Each sensor-realism switch alone (and all of them) against the ideal lidars: map
    /// quality and localisation of the validation chain on a short setting.
    SensorRealism(super::realism::Args),
}

/// Arguments of `mapkeeper experiment kidnap-robot`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Each trial drives up to 60 m of the tour from a seeded place in a seeded world W_k (k = 50..100) on the map of W_1; at 3-6 s the robot itself is put 0.5-3 m away in free space, turned by up to ±180°, and its odometry does not see the move. Each trial is paired with the same run without the kidnap. Output in OUT (default results/kidnap-robot-s<SEED>-<N>t-<counter>): summary.json (kidnap_robot.{trials, recovered_rate_pose_updating, recovered_rate_filter, failed_rate, false_lost_rate, median_recovery_s, map_damage.{cc,ms,opdf}}), trials.csv, report.md. Definitions: docs/recovery.md, \"Real kidnaps\"."
)]
pub struct KidnapRobotArgs {
    /// Trials, 1 to 100000 (default 100).
    #[arg(long, value_name = "N", value_parser = super::count_in(1, MAX_TRIALS), allow_hyphen_values = true)]
    pub trials: Option<usize>,
    /// Run seed (any whole number from 0 to 2^64 − 1).
    #[arg(long, value_name = "S", default_value_t = 41, value_parser = super::seed, allow_hyphen_values = true)]
    pub seed: u64,
    /// Updater preset (default paper).
    #[arg(long, value_name = "NAME")]
    pub preset: Option<String>,
    /// A short setting for tests: 3 trials (unless --trials is given), worlds W_2-W_3, a 6 s
    /// recovery window, a 15 m drive.
    #[arg(long)]
    pub quick: bool,
    /// The flags every experiment has.
    #[command(flatten)]
    pub common: Common,
}

/// The parameter file of `experiment kidnap-robot`.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct KidnapRobotFile {
    recovery: RecoveryParams,
    kidnap_robot: KidnapRobotParams,
}

fn kidnap_robot(args: KidnapRobotArgs) -> anyhow::Result<()> {
    let mut base = KidnapRobotFile::default();
    base.recovery.runner.set_localiser(&args.common.localiser).context("--localiser")?;
    if args.quick {
        base.kidnap_robot = KidnapRobotParams::quick();
    }
    let mut file = load_params(base, args.common.params.as_deref(), |f: &KidnapRobotFile| {
        f.recovery.validate()?;
        f.kidnap_robot.validate()
    })?;
    let p = &mut file.kidnap_robot;
    if let Some(n) = args.trials {
        p.trials = n;
    }
    if let Some(v) = args.preset {
        p.preset = v;
    }
    p.validate().context("--trials / --preset")?;
    let (default, total) = (default_out("kidnap-robot", args.seed, p.trials), p.trials);
    let (w1, world) = site_world(args.common.world.as_deref(), args.common.route.as_deref(), &mut file.recovery)?;
    let (mut r, wall_time_s, dir) =
        run_timed("kidnap-robot", &args.common, &w1, default, total, "trials", |w1, progress| {
            Ok(run_kidnap_robot(w1, &file.recovery, &file.kidnap_robot, args.seed, progress)?)
        })?;
    r.wall_time_s = wall_time_s;
    r.world = world;
    write_kidnap_robot(&dir, &r)?;
    let out = dir.finish()?;
    let k = &r.kidnap_robot;
    outln!(
        "kidnap-robot: {}, seed {}, preset {}, {} trials ({} moved), {:.1} s wall: recovered by pose updating {:.1} %, \
         by the filter {:.1} %, failed {:.1} %, Lost without kidnap {:.1} % (well localised {:.1} %), median recovery \
         {}, map damage CC {:.2} MS {:.2} OPDF {:.2}",
        r.world,
        r.seed,
        k.preset,
        k.trials,
        k.applied,
        r.wall_time_s,
        100.0 * k.recovered_rate_pose_updating,
        100.0 * k.recovered_rate_filter,
        100.0 * k.failed_rate,
        100.0 * k.false_lost_rate,
        100.0 * k.false_lost_well_localised_rate,
        k.median_recovery_s.map_or_else(|| "–".into(), |v| format!("{v:.2} s")),
        k.map_damage.cc,
        k.map_damage.ms,
        k.map_damage.opdf
    );
    outln!("wrote {}", out.display());
    Ok(())
}

/// Arguments of `mapkeeper experiment table1`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Each trial has its own world seed (its own W_2), start place on the tour and error (0.3-1.0 m in any direction relative to the heading, up to ±10°). Conditions: hold_<T>s for T in 0, 5, 10, 20, 30 (the pose the updater is given is held wrong for T s from the start, then right) and amcl_start (the localiser starts 0.7 m off and corrects itself). Variants: always_update, check, check_no_pose_updating. Output in OUT (default results/table1-s<SEED>-<N>t-<counter>): summary.json (table1.<preset>.<condition>.<variant>.{cc, ms, opdf, ..._ci95, vs_always_update, wrong_flips}), runs.csv, report.md, cc_by_hold.{svg,png}. Definitions: docs/recovery.md, \"Table 1 with a held error\"."
)]
pub struct Table1Args {
    /// Trials, 1 to 100000 (default 10).
    #[arg(long, value_name = "N", value_parser = super::count_in(1, MAX_TRIALS), allow_hyphen_values = true)]
    pub trials: Option<usize>,
    /// Run seed (any whole number from 0 to 2^64 − 1).
    #[arg(long, value_name = "S", default_value_t = 31, value_parser = super::seed, allow_hyphen_values = true)]
    pub seed: u64,
    /// Updater presets compared, comma-separated (default paper,mapkeeper).
    #[arg(long, value_name = "A,B", value_delimiter = ',')]
    pub presets: Option<Vec<String>>,
    /// A short setting for tests: 2 trials (unless --trials is given), holds 0 and 2 s, a 6 m
    /// drive, preset paper.
    #[arg(long)]
    pub quick: bool,
    /// The flags every experiment has.
    #[command(flatten)]
    pub common: Common,
}

/// The parameter file of `experiment table1`.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct Table1File {
    recovery: RecoveryParams,
    table1: Table1HoldParams,
}

fn table1(args: Table1Args) -> anyhow::Result<()> {
    let mut base = Table1File::default();
    base.recovery.runner.set_localiser(&args.common.localiser).context("--localiser")?;
    if args.quick {
        base.table1 = Table1HoldParams::quick();
    }
    let mut file = load_params(base, args.common.params.as_deref(), |f: &Table1File| {
        f.recovery.validate()?;
        f.table1.validate()
    })?;
    let p = &mut file.table1;
    if let Some(n) = args.trials {
        p.trials = n;
    }
    if let Some(v) = args.presets {
        p.presets = v;
    }
    p.validate().context("--trials / --presets")?;
    let runs = p.trials * p.presets.len() * p.conditions().len() * VARIANTS.len();
    let default = default_out("table1", args.seed, p.trials);
    let (w1, world) = site_world(args.common.world.as_deref(), args.common.route.as_deref(), &mut file.recovery)?;
    let (mut r, wall_time_s, dir) = run_timed("table1", &args.common, &w1, default, runs, "runs", |w1, progress| {
        Ok(run_table1_hold(w1, &file.recovery, &file.table1, args.seed, progress)?)
    })?;
    r.summary.wall_time_s = wall_time_s;
    write_table1_hold(&dir, &r)?;
    let out = dir.finish()?;
    outln!(
        "table1: {world}, seed {}, {} trials, {} runs, localiser {}, {:.1} s wall",
        args.seed,
        r.summary.params.trials,
        runs,
        r.summary.recovery.runner.localiser,
        r.summary.wall_time_s
    );
    for (preset, by_cond) in &r.summary.table1 {
        for (cond, by_var) in by_cond {
            let line: Vec<String> = by_var
                .iter()
                .map(|(v, c)| {
                    format!(
                        "{v} CC {:.2} MS {:.2} OPDF \
         {:.2}",
                        c.cc, c.ms, c.opdf
                    )
                })
                .collect();
            outln!("{preset:<10} {cond:<11} {}", line.join(" | "));
        }
    }
    outln!("wrote {}", out.display());
    Ok(())
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
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Worker threads, 1 to 1024 (default: all cores).
    #[arg(long, value_name = "N", value_parser = super::jobs, allow_hyphen_values = true)]
    pub jobs: Option<usize>,
    /// The world W_1: `warehouse` (the default), `lab`, or a world file (an imported map:
    /// `mapkeeper import-map`); its tour and storage areas from the file, planned and derived
    /// when absent.
    #[arg(long, value_name = "NAME|FILE")]
    pub world: Option<PathBuf>,
    /// Route file overriding the world's route (the tour).
    #[arg(long, value_name = "FILE")]
    pub route: Option<PathBuf>,
    /// Replace an existing non-empty output folder.
    #[arg(long)]
    pub force: bool,
}

/// W_1 of `--world` / `--route` (the default warehouse without them), with the recovery
/// parameters' tour, exploration route and storage areas taken from it; and its name.
pub(super) fn site_world(
    world: Option<&std::path::Path>,
    route: Option<&std::path::Path>,
    recovery: &mut RecoveryParams,
) -> anyhow::Result<(World, String)> {
    let Some((name, site)) = super::load_site(world, route, true)? else {
        return Ok((World::default_warehouse(), "warehouse".into()));
    };
    recovery.tour = site.route;
    recovery.exploration_route = site.exploration;
    recovery.generator.storage_areas = site.storage;
    recovery.validate().context("--world / --route")?;
    Ok((site.world, name))
}

/// Makes the output folder (`--out`, else `default`), then runs `work` in W_1 on the `--jobs`
/// pool with a progress bar of `total` `unit`s; returns its result, the wall time in seconds
/// and the folder to write into.
fn run_timed<R: Send>(
    name: &str,
    c: &Common,
    w1: &World,
    default: PathBuf,
    total: usize,
    unit: &str,
    work: impl FnOnce(&World, &(dyn Fn() + Sync)) -> anyhow::Result<R> + Send,
) -> anyhow::Result<(R, f64, StagedDir)> {
    let out = c.out.clone().unwrap_or(default);
    let dir = super::output_dir(&out, c.force)?;
    let pool = super::thread_pool(c.jobs)?;
    let bar = pool.install(|| super::progress_bar(&format!("experiment {name}"), total as u64, unit, &out));
    let start = Instant::now();
    let progress = || bar.inc(1);
    let r = pool.install(|| work(w1, &progress))?;
    bar.finish_and_clear();
    Ok((r, start.elapsed().as_secs_f64(), dir))
}

/// Arguments of `mapkeeper experiment check-detection`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Each trial drives a few seconds of the tour from a seeded place in a seeded world W_k \
(k = 2..--max-world) on the stale map of W_1; after 2 s the pose the updater is given is held wrong by 0-1.5 m in \
any direction and 0-±20° (20 % of the trials: no error) while the localiser runs on. Every preset runs the same \
trials. Output in OUT (default results/check-detection-s<SEED>-<N>t-<counter>): summary.json \
(check_detection.<preset>.{detection_rate, false_alarm_rate, median_latency_s, ...}), trials.csv, report.md, \
detection_by_error.{svg,png}. Same seed => identical files whatever --jobs, except wall_time_s. Definitions: \
docs/recovery.md, \"Check detection\".")]
pub struct CheckDetectionArgs {
    /// Trials per preset, 1 to 100000 (default 200).
    #[arg(long, value_name = "N", value_parser = super::count_in(1, MAX_TRIALS), allow_hyphen_values = true)]
    pub trials: Option<usize>,
    /// Run seed (any whole number from 0 to 2^64 − 1).
    #[arg(long, value_name = "S", default_value_t = 21, value_parser = super::seed, allow_hyphen_values = true)]
    pub seed: u64,
    /// Updater presets compared, comma-separated (default paper,mapkeeper,mapkeeper-shift).
    #[arg(long, value_name = "A,B", value_delimiter = ',')]
    pub presets: Option<Vec<String>>,
    /// Worlds are drawn from W_2 … W_N, 2 to 1000 (default 100).
    #[arg(long, value_name = "N", value_parser = super::count_in(2, 1000), allow_hyphen_values = true)]
    pub max_world: Option<usize>,
    /// A short setting for tests: 6 trials (unless --trials is given), worlds up to W_4, 1.5 s
    /// after the onset.
    #[arg(long)]
    pub quick: bool,
    /// The flags every experiment has.
    #[command(flatten)]
    pub common: Common,
}

/// The parameter file of `experiment check-detection`.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct CheckDetectionFile {
    recovery: RecoveryParams,
    check_detection: CheckDetectionParams,
}

fn default_out(stem: &str, seed: u64, trials: usize) -> PathBuf {
    super::numbered_out(&format!("{stem}-s{seed}-{trials}t"))
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    match args.which {
        Which::CheckDetection(a) => check_detection(a),
        Which::Table1(a) => table1(a),
        Which::KidnapRobot(a) => kidnap_robot(a),
        Which::RealData(a) => super::real_data::run(a),
        Which::SensorRealism(a) => super::realism::run(a),
    }
}

fn check_detection(args: CheckDetectionArgs) -> anyhow::Result<()> {
    let mut base = CheckDetectionFile::default();
    base.recovery.runner.set_localiser(&args.common.localiser).context("--localiser")?;
    if args.quick {
        base.check_detection = CheckDetectionParams::quick();
    }
    let mut file = load_params(base, args.common.params.as_deref(), |f: &CheckDetectionFile| {
        f.recovery.validate()?;
        f.check_detection.validate()
    })?;
    let p = &mut file.check_detection;
    if let Some(n) = args.trials {
        p.trials = n;
    }
    if let Some(v) = args.presets {
        p.presets = v;
    }
    if let Some(k) = args.max_world {
        p.max_world = k;
    }
    p.validate().context("--trials / --presets / --max-world")?;
    let (default, total) = (default_out("check-detection", args.seed, p.trials), p.trials * p.presets.len());
    let (w1, world) = site_world(args.common.world.as_deref(), args.common.route.as_deref(), &mut file.recovery)?;
    let (mut r, wall_time_s, dir) =
        run_timed("check-detection", &args.common, &w1, default, total, "runs", |w1, progress| {
            Ok(run_check_detection(w1, &file.recovery, &file.check_detection, args.seed, progress)?)
        })?;
    r.summary.wall_time_s = wall_time_s;
    write_check_detection(&dir, &r)?;
    let out = dir.finish()?;
    outln!(
        "check-detection: {world}, seed {}, {} trials per preset, worlds W_2-W_{}, localiser {}, {:.1} s wall",
        args.seed,
        r.summary.trials,
        r.summary.params.max_world,
        r.summary.recovery.runner.localiser,
        r.summary.wall_time_s
    );
    for (name, d) in &r.summary.check_detection {
        outln!(
            "{name:<12} detection {:.1} % ({}/{}), false alarms {:.2} % of {} clean steps, median latency {}",
            100.0 * d.detection_rate,
            d.detection.hits,
            d.detection.of,
            100.0 * d.false_alarm_rate,
            d.false_alarms.of,
            d.median_latency_s.map_or_else(|| "–".into(), |v| format!("{v:.2} s"))
        );
    }
    outln!("wrote {}", out.display());
    Ok(())
}
