//! `mapkeeper experiment check-detection`.

use super::{Common, ExperimentFile, ExperimentTable, MAX_TRIALS, default_out, load_file, run_timed, site_world};
use anyhow::Context;
use mapkeeper_scenario::experiments::ExperimentError;
use mapkeeper_scenario::experiments::check_detection::report::write_check_detection;
use mapkeeper_scenario::experiments::check_detection::{CheckDetectionParams, run_check_detection};

/// Arguments of `mapkeeper experiment check-detection`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Each trial drives a few seconds of the tour from a seeded place in a seeded world W_k \
(k = 2..--max-world) on the stale map of W_1; after 2 s the pose the updater is given is held wrong by 0-1.5 m in \
any direction and 0-±20° (20 % of the trials: no error) while the localiser runs on. Every preset runs the same \
trials. Output in OUT (default results/check-detection-s<SEED>-<N>t-<counter>): summary.json \
(check_detection.<preset>.{detection_rate, false_alarm_rate, median_latency_s, ...}), trials.csv, report.md, \
detection_by_error.{svg,png}. Same seed => identical files whatever --jobs, except wall_time_s (0 with --no-timing: then identical). Definitions: \
docs/recovery.md, \"Check detection\".")]
pub struct CheckDetectionArgs {
    /// Trials per preset, 1 to 100000 (default 200).
    #[arg(long, value_name = "N", value_parser = super::super::count_in(1, MAX_TRIALS), allow_hyphen_values = true)]
    pub trials: Option<usize>,
    /// Run seed (any whole number from 0 to 2^64 − 1).
    #[arg(long, value_name = "S", default_value_t = 21, value_parser = super::super::seed, allow_hyphen_values = true)]
    pub seed: u64,
    /// Updater presets compared, comma-separated (default paper,mapkeeper,mapkeeper-shift).
    #[arg(long, value_name = "A,B", value_delimiter = ',')]
    pub presets: Option<Vec<String>>,
    /// Worlds are drawn from W_2 … W_N, 2 to 1000 (default 100).
    #[arg(long, value_name = "N", value_parser = super::super::count_in(2, 1000), allow_hyphen_values = true)]
    pub max_world: Option<usize>,
    /// A short setting for tests: 6 trials (unless --trials is given), worlds up to W_4, 1.5 s
    /// after the onset.
    #[arg(long)]
    pub quick: bool,
    /// The flags every experiment has.
    #[command(flatten)]
    pub common: Common,
}

/// `[check_detection]`, the own table of `experiment check-detection`'s parameter file.
impl ExperimentTable for CheckDetectionParams {
    const TABLE: &'static str = "check_detection";
    const KEYS: &'static [&'static str] = &["recovery", "check_detection"];

    fn quick() -> Self {
        CheckDetectionParams::quick()
    }

    fn check(&self) -> Result<(), ExperimentError> {
        self.validate()
    }
}

pub(super) fn run(args: CheckDetectionArgs) -> anyhow::Result<()> {
    let mut file: ExperimentFile<CheckDetectionParams> = load_file(&args.common, args.quick)?;
    let p = &mut file.own;
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
    let (w1, world) = site_world(args.common.site.load()?, &mut file.recovery)?;
    let (mut r, wall_time_s, dir) =
        run_timed("check-detection", &args.common, &w1, default, total, "runs", |w1, progress| {
            Ok(run_check_detection(w1, &file.recovery, &file.own, args.seed, progress)?)
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
