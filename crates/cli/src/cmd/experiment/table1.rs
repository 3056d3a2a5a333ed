//! `mapkeeper experiment table1`.

use super::{Common, ExperimentFile, ExperimentTable, MAX_TRIALS, default_out, load_file, run_timed, site_world};
use anyhow::Context;
use mapkeeper_scenario::experiments::ExperimentError;
use mapkeeper_scenario::experiments::table1_hold::report::write_table1_hold;
use mapkeeper_scenario::experiments::table1_hold::{Table1HoldParams, VARIANTS, run_table1_hold};

/// Arguments of `mapkeeper experiment table1`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Each trial has its own world seed (its own W_2), start place on the tour and error (0.3-1.0 m in any direction relative to the heading, up to ±10°). Conditions: hold_<T>s for T in 0, 5, 10, 20, 30 (the pose the updater is given is held wrong for T s from the start, then right) and amcl_start (the localiser starts 0.7 m off and corrects itself). Variants: always_update, check, check_no_pose_updating. Output in OUT (default results/table1-s<SEED>-<N>t-<counter>): summary.json (table1.<preset>.<condition>.<variant>.{cc, ms, opdf, ..._ci95, vs_always_update, wrong_flips}), runs.csv, report.md, cc_by_hold.{svg,png}. Definitions: docs/recovery.md, \"Table 1 with a held error\"."
)]
pub struct Table1Args {
    /// Trials, 1 to 100000 (default 10).
    #[arg(long, value_name = "N", value_parser = super::super::count_in(1, MAX_TRIALS), allow_hyphen_values = true)]
    pub trials: Option<usize>,
    /// Run seed (any whole number from 0 to 2^64 − 1).
    #[arg(long, value_name = "S", default_value_t = 31, value_parser = super::super::seed, allow_hyphen_values = true)]
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

/// `[table1]`, the own table of `experiment table1`'s parameter file.
impl ExperimentTable for Table1HoldParams {
    const TABLE: &'static str = "table1";
    const KEYS: &'static [&'static str] = &["recovery", "table1"];

    fn quick() -> Self {
        Table1HoldParams::quick()
    }

    fn check(&self) -> Result<(), ExperimentError> {
        self.validate()
    }
}

pub(super) fn run(args: Table1Args) -> anyhow::Result<()> {
    let mut file: ExperimentFile<Table1HoldParams> = load_file(&args.common, args.quick)?;
    let p = &mut file.own;
    if let Some(n) = args.trials {
        p.trials = n;
    }
    if let Some(v) = args.presets {
        p.presets = v;
    }
    p.validate().context("--trials / --presets")?;
    let runs = p.trials * p.presets.len() * p.conditions().len() * VARIANTS.len();
    let default = default_out("table1", args.seed, p.trials);
    let (w1, world) = site_world(args.common.site.load()?, &mut file.recovery)?;
    let (mut r, wall_time_s, dir) = run_timed("table1", &args.common, &w1, default, runs, "runs", |w1, progress| {
        Ok(run_table1_hold(w1, &file.recovery, &file.own, args.seed, progress)?)
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
