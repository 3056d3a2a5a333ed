//! `mapkeeper experiment kidnap-robot`.

use super::{Common, ExperimentFile, ExperimentTable, MAX_TRIALS, default_out, load_file, run_timed, site_world};
use anyhow::Context;
use mapkeeper_scenario::experiments::ExperimentError;
use mapkeeper_scenario::experiments::kidnap_robot::report::write_kidnap_robot;
use mapkeeper_scenario::experiments::kidnap_robot::{KidnapMap, KidnapRobotParams, run_kidnap_robot};

/// Arguments of `mapkeeper experiment kidnap-robot`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Each trial drives up to 60 m of the tour from a seeded place in a seeded world W_k (k = 50..100) on the map of W_1, on M_{k-1} of the preset's own chain and on G_{k-1} (--maps); at 3-6 s the robot itself is put 0.5-3 m away in free space, turned by up to ±180°, and its odometry does not see the move. Each trial is paired with the same run without the kidnap. Output in OUT (default results/kidnap-robot-s<SEED>-<N>t-<counter>): summary.json (by_map[], kidnap_robot = the first map's: {trials, recovered_rate_pose_updating, recovered_rate_filter, failed_rate, false_lost_rate, median_recovery_s, map_damage.{cc,ms,opdf}}), trials.csv, report.md. Definitions: docs/recovery.md, \"Real kidnaps\"."
)]
pub struct KidnapRobotArgs {
    /// Trials, 1 to 100000 (default 100).
    #[arg(long, value_name = "N", value_parser = super::super::count_in(1, MAX_TRIALS), allow_hyphen_values = true)]
    pub trials: Option<usize>,
    /// Run seed (any whole number from 0 to 2^64 − 1).
    #[arg(long, value_name = "S", default_value_t = 41, value_parser = super::super::seed, allow_hyphen_values = true)]
    pub seed: u64,
    /// Updater preset (default paper).
    #[arg(long, value_name = "NAME")]
    pub preset: Option<String>,
    /// The maps the robot localises on, each trial run on each, side by side (default all
    /// three): `w1` (the map of W_1), `chain` (M_{k-1}, kept by the preset's updater through
    /// the chain of the same seed, run first), `truth` (G_{k-1}). Comma-separated.
    #[arg(long, value_name = "LIST")]
    pub maps: Option<String>,
    /// A short setting for tests: 3 trials (unless --trials is given), worlds W_2-W_3, a 6 s
    /// recovery window, a 15 m drive.
    #[arg(long)]
    pub quick: bool,
    /// The flags every experiment has.
    #[command(flatten)]
    pub common: Common,
}

/// `[kidnap_robot]`, the own table of `experiment kidnap-robot`'s parameter file.
impl ExperimentTable for KidnapRobotParams {
    const TABLE: &'static str = "kidnap_robot";
    const KEYS: &'static [&'static str] = &["recovery", "kidnap_robot"];

    fn quick() -> Self {
        KidnapRobotParams::quick()
    }

    fn check(&self) -> Result<(), ExperimentError> {
        self.validate()
    }
}

pub(super) fn run(args: KidnapRobotArgs) -> anyhow::Result<()> {
    let mut file: ExperimentFile<KidnapRobotParams> = load_file(&args.common, args.quick)?;
    let p = &mut file.own;
    if let Some(n) = args.trials {
        p.trials = n;
    }
    if let Some(v) = args.preset {
        p.preset = v;
    }
    if let Some(v) = args.maps {
        p.maps = KidnapMap::parse_list(&v).map_err(|e| anyhow::anyhow!("--maps {v:?}: {e}"))?;
    }
    p.validate().context("--trials / --preset / --maps")?;
    let (default, total) = (default_out("kidnap-robot", args.seed, p.trials), p.trials * p.maps.len());
    let (w1, world) = site_world(args.common.site.load()?, &mut file.recovery)?;
    let (mut r, wall_time_s, dir) =
        run_timed("kidnap-robot", &args.common, &w1, default, total, "trials", |w1, progress| {
            Ok(run_kidnap_robot(w1, &file.recovery, &file.own, args.seed, progress)?)
        })?;
    r.wall_time_s = wall_time_s;
    r.world = world;
    write_kidnap_robot(&dir, &r)?;
    let out = dir.finish()?;
    outln!("kidnap-robot: {}, seed {}, preset {}, {:.1} s wall", r.world, r.seed, r.kidnap_robot.preset, r.wall_time_s);
    for k in &r.by_map {
        outln!(
            "  on {}: {} trials ({} moved): recovered by pose updating {:.1} %, by the filter {:.1} %, failed {:.1} %, \
             right handovers held {}, Lost without kidnap {:.1} % (well localised {:.1} %), median recovery {}, map \
             damage CC {:.2} MS {:.2} OPDF {:.2}",
            k.map.label(),
            k.trials,
            k.applied,
            100.0 * k.recovered_rate_pose_updating,
            100.0 * k.recovered_rate_filter,
            100.0 * k.failed_rate,
            k.handover_held_rate.map_or_else(|| "–".into(), |v| format!("{:.1} %", 100.0 * v)),
            100.0 * k.false_lost_rate,
            100.0 * k.false_lost_well_localised_rate,
            k.median_recovery_s.map_or_else(|| "–".into(), |v| format!("{v:.2} s")),
            k.map_damage.cc,
            k.map_damage.ms,
            k.map_damage.opdf
        );
    }
    outln!("wrote {}", out.display());
    Ok(())
}
