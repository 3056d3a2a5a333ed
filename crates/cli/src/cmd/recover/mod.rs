//! `mapkeeper recover` (= `mapkeeper experiment recovery-suite`): the robustness experiments of
//! the paper (§5.3.1, §5.4) and the pose-recovery stress suite; the wall clock is read here
//! (not in the libraries).

mod print;

use super::load_params;
use anyhow::Context;
use mapkeeper_scenario::experiments::recovery::Progress;
use mapkeeper_scenario::experiments::recovery::report::write_recovery;
use mapkeeper_scenario::{RecoveryParams, run_recovery};
use print::print_kidnap;
use std::path::PathBuf;
use std::time::Instant;

/// Largest `--trials`.
const MAX_TRIALS: usize = 10_000;

/// Arguments of `mapkeeper recover`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Experiments: the localisation-check demo (0.5 m start error: updates suspended, then \
resumed), Table 1 with a start error (0.7 m, always-update against the check, CC/MS/OPDF of M_2 against G_2; \
`experiment table1-held-pose` holds the pose wrong instead), the lost robot (1.5 m: Lost, pose updating, map not \
corrupted) and the kidnap suite of the estimate (N seeded trials: the chain localiser's estimate displaced by 0.5-3 m \
and up to ±45° while the robot drives, on a stale map M_1 in W_k and on the current world's map G_k; `experiment \
kidnap-robot` moves the robot itself).\n\n\
Output in OUT (default results/recover-s<SEED>-<N>t-<counter>): summary.json, kidnap_trials.csv, table1.csv, \
lost_robot.csv, demo_timeline.csv, report.md. Same seed => identical files whatever --jobs, except wall_time_s (0 with --no-timing: then identical). \
Definitions: docs/recovery.md.")]
pub struct Args {
    /// Kidnap trials per map case (stale and best), 0 to 10000 (0 runs the other
    /// experiments only; 10000 is 50 × the default, hours of work).
    #[arg(long, value_name = "N", default_value_t = 200, value_parser = super::count_in(0, MAX_TRIALS), allow_hyphen_values = true)]
    pub trials: usize,
    /// Run seed (any whole number from 0 to 2^64 − 1).
    #[arg(long, value_name = "S", default_value_t = 1, value_parser = super::seed, allow_hyphen_values = true)]
    pub seed: u64,
    #[command(flatten)]
    pub output: super::shared_args::OutputArgs,
    #[command(flatten)]
    pub threads: super::shared_args::JobsArg,
    #[command(flatten)]
    pub timing: super::shared_args::TimingArg,
    /// Localiser preset of the chain localiser: mapkeeper, mapkeeper-real, amcl or amcl-joint (docs/localiser.md); a
    /// --params file's `[runner.filter]` fields override it. Recorded in summary.json
    /// (`params.runner.localiser`, `params.runner.filter`) and report.md.
    #[arg(long, value_name = "NAME", default_value = "mapkeeper")]
    pub localiser: String,
    /// Parameter file (TOML, any field of the recovery parameters; see docs/recovery.md).
    #[arg(long, value_name = "FILE")]
    pub params: Option<PathBuf>,
    #[command(flatten)]
    pub site: super::shared_args::WorldArgs,
    /// Skip the best case (map = current world) of the kidnap suite.
    #[arg(long)]
    pub no_best_case: bool,
}

fn default_out(seed: u64, trials: usize) -> PathBuf {
    super::numbered_out(&format!("recover-s{seed}-{trials}t"))
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut base = RecoveryParams::default();
    base.runner.set_localiser(&args.localiser).context("--localiser")?;
    let mut params = load_params(base, args.params.as_deref(), RecoveryParams::validate)?;
    params.kidnap.trials = args.trials;
    if args.no_best_case {
        params.kidnap.best_case = false;
    }
    let (w1, _) = super::site::site_world(args.site.load()?, &mut params)?;
    params.validate().context("--trials / --no-best-case / --world")?;
    let out = args.output.out.clone().unwrap_or_else(|| default_out(args.seed, args.trials));
    let dir = super::output_dir(&out, args.output.force)?;
    let cases = if params.kidnap.best_case { 2 } else { 1 };
    let pool = super::thread_pool(args.threads.jobs)?;
    let bar = pool.install(|| super::progress_bar("recover", 4 + (cases * args.trials) as u64, "steps", &out));
    let start = Instant::now();
    let progress = |_: Progress| bar.inc(1);
    let mut results = pool.install(|| run_recovery(&w1, &params, args.seed, &progress))?;
    bar.finish_and_clear();
    let wall_time_s = args.timing.wall_s(start);
    results.summary.wall_time_s = wall_time_s;
    write_recovery(&dir, &results)?;
    let out = dir.finish()?;
    let s = &results.summary;
    outln!(
        "recover: seed {}, {} kidnap trials per case, localiser {}, {:.1} s wall",
        args.seed,
        args.trials,
        params.runner.localiser,
        wall_time_s
    );
    let d = &s.demo;
    outln!(
        "loc-check demo: first Suspend {:?} s, first Update {:?} s, verdicts U{} S{} L{}: suspended then updated: {}",
        d.first_suspend_s,
        d.first_update_s,
        d.verdicts.update,
        d.verdicts.suspend,
        d.verdicts.lost,
        d.suspended_then_updated
    );
    let t = &s.table1;
    outln!("{:<10} {:>14} {:>10} {:>14}", "Table 1", "always-update", "check", "paper");
    for (name, a, c, pa, pc) in [
        ("CC %", t.always_update.cc, t.check.cc, t.paper_always_update.cc, t.paper_check.cc),
        ("MS %", t.always_update.ms, t.check.ms, t.paper_always_update.ms, t.paper_check.ms),
        ("OPDF %", t.always_update.opdf, t.check.opdf, t.paper_always_update.opdf, t.paper_check.opdf),
    ] {
        outln!("{name:<10} {a:>14.2} {c:>10.2} {:>14}", format!("{pa:.2} → {pc:.2}"));
    }
    outln!("Table 1 direction reproduced: {}", t.direction_reproduced);
    let l = &s.lost_robot;
    outln!(
        "lost robot ({} runs, {:.1} m): Lost {} recovered {} (pose updating {}), OPDF/G_2 {:.2} vs {:.2} without \
         error ({:.2} always-update), not corrupted: {}",
        l.runs,
        l.start_error_m,
        l.detected,
        l.recovered,
        l.recovered_by_pose_updating,
        l.with_error.opdf,
        l.without_error.opdf,
        l.always_update_with_error.opdf,
        l.not_corrupted
    );
    print_kidnap("stale", &s.kidnap);
    if let Some(b) = &s.kidnap_best_case {
        print_kidnap("best", b);
    }
    outln!("wrote {}", out.display());
    Ok(())
}
