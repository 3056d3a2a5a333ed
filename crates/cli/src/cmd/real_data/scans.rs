//! `mapkeeper experiment real-scans`: the updater and pose recovery judged on real logs with
//! reference poses (issue 52; `docs/real-data.md`, "Real scans, known truth").

use super::reading::{ReadingFlags, read};
use super::shared_logs;
use crate::cmd::load_params;
use anyhow::Context;
use mapkeeper_grid::mapper::MapperParams;
use mapkeeper_grid::metrics::MetricParams;
use mapkeeper_harness::jobs::map::MapLogParams;
use mapkeeper_localiser::FilterParams;
use mapkeeper_scenario::experiments::real_scans::chain::PoseSourceConfig;
use mapkeeper_scenario::experiments::real_scans::edits::EditParams;
use mapkeeper_scenario::experiments::real_scans::kidnap::RealKidnapParams;
use mapkeeper_scenario::experiments::real_scans::report::write_real_scans;
use mapkeeper_scenario::experiments::real_scans::{LogInput, LogResult, RealScansParams, chain_count, run_real_scans};
use std::path::PathBuf;
use std::time::Instant;

/// The presets every run compares, unless `--presets` says otherwise.
const DEFAULT_PRESETS: &str = "paper,paper-strict,authors,mapkeeper,mapkeeper-no-registration";

/// Arguments of `mapkeeper experiment real-scans`.
#[derive(clap::Args, Debug)]
#[command(after_help = "For each log with reference poses (a CARMEN corrected log, or a bag with --truth-topic): G = \
the map at the reference poses (0.05 m, no-return beams do not clear); per edit seed a stale map M_1 made from G by \
seeded edits (structure M_1 lacks, boxes the place lacks, items moved; amounts from the warehouse's W_50 against W_1, \
--edit-params overrides them); the log replayed as W_2 ... W_K, each pass localising on M_(k-1) from the first \
reference pose and updating it into M_k, with every preset and pose source; every M_k scored against G over the \
cells G observed (CC, MS, OPDF), with M_1, the fresh map, the oracle, structure retention, the share of each edit \
class restored and the poses' error. A log without reference poses needs --map: its passes run on that map, \
unscored. Without --log: the three logs of ../shared/data/carmen/. Output in OUT (default \
results/real-scans-s<SEED>-<counter>): summary.json, report.md, report.html, per log G.yaml, M_1.yaml, ms_<poses>.png \
and errors/<preset>_<poses>_W<kk>.png. Definitions: docs/real-data.md.")]
pub struct Args {
    /// A log to run (repeat for several; the reading flags apply to each). Default: the three
    /// CARMEN logs of ../shared/data/carmen/.
    #[arg(long = "log", value_name = "PATH")]
    pub logs: Vec<PathBuf>,
    /// How the logs are read (--log is taken from above).
    #[command(flatten)]
    pub reading: ReadingFlags,
    /// The map a log without reference poses starts from (ROS map_server YAML): it has no truth,
    /// so its passes run on this map and are not scored.
    #[arg(long, value_name = "MAP.yaml")]
    pub map: Option<PathBuf>,
    /// K: the stale map is W_1 and the log is replayed as W_2 ... W_K; 3 to 1000.
    #[arg(long, value_name = "K", default_value_t = 10, value_parser = crate::cmd::count_in(3, 1000), allow_hyphen_values = true)]
    pub worlds: usize,
    /// First edit seed (any whole number from 0 to 2^64 − 1): the stale maps and the
    /// localisers' draws.
    #[arg(long, value_name = "S", default_value_t = 1, value_parser = crate::cmd::seed, allow_hyphen_values = true)]
    pub seed: u64,
    /// Edit seeds: S, S + 1, ..., 1 to 1000 (one stale map per seed and log; the intervals are
    /// over them).
    #[arg(long, value_name = "N", default_value_t = 5, value_parser = crate::cmd::count_in(1, 1000), allow_hyphen_values = true)]
    pub seeds: usize,
    /// Updater presets, comma-separated.
    #[arg(long, value_name = "A,B", value_delimiter = ',', default_value = DEFAULT_PRESETS)]
    pub presets: Vec<String>,
    /// Pose sources, comma-separated: reference (the log's reference poses), mapkeeper-real,
    /// amcl (or any localiser preset: each localises on M_(k-1) from the first reference pose).
    #[arg(long, value_name = "A,B", value_delimiter = ',', default_value = "reference,mapkeeper-real,amcl")]
    pub poses: Vec<String>,
    /// TOML overriding any field of the stale map's edits (docs/real-data.md), e.g.
    /// `removed_share = 0.2`.
    #[arg(long, value_name = "FILE.toml")]
    pub edit_params: Option<PathBuf>,
    /// Only the first N scans of each log (a short run), 10 to 10000000.
    #[arg(long, value_name = "N", value_parser = crate::cmd::count_in(10, 10_000_000), allow_hyphen_values = true)]
    pub first_scans: Option<usize>,
    /// Spliced kidnaps per log (cuts 0.5-5 m apart, each paired with the unspliced log, on the
    /// first edit seed's stale map and on G; with the presets paper, authors and mapkeeper, or
    /// those of --presets when it is given), 0 to 10000; 0: none.
    #[arg(long, value_name = "N", default_value_t = 20, value_parser = crate::cmd::count_in(0, 10_000), allow_hyphen_values = true)]
    pub kidnap_cuts: usize,
    /// The localisers of the spliced kidnaps, comma-separated (mapkeeper-real, amcl, ...).
    #[arg(long, value_name = "A,B", value_delimiter = ',', default_value = "mapkeeper-real")]
    pub kidnap_localisers: Vec<String>,
    /// A short setting for tests: K = 3, one edit seed, the first 150 scans of each log, the
    /// presets paper and mapkeeper, the reference poses and mapkeeper-real, 2 kidnap cuts (flags
    /// given explicitly still win for --presets and --poses).
    #[arg(long)]
    pub quick: bool,
    #[command(flatten)]
    pub output: crate::cmd::shared_args::OutputArgs,
    #[command(flatten)]
    pub timing: crate::cmd::shared_args::TimingArg,
    #[command(flatten)]
    pub threads: crate::cmd::shared_args::JobsArg,
}

fn pose_source(name: &str) -> anyhow::Result<PoseSourceConfig> {
    if name == "reference" {
        return Ok(PoseSourceConfig::Reference);
    }
    let params = FilterParams::preset(name).with_context(|| {
        format!("--poses: '{name}' is neither `reference` nor a localiser preset (mapkeeper-real, amcl, mapkeeper, amcl-joint)")
    })?;
    Ok(PoseSourceConfig::Localiser { name: name.to_string(), params: Box::new(params) })
}

/// The run's parameters from the flags (`--quick` applied).
fn params(args: &Args) -> anyhow::Result<RealScansParams> {
    let defaults_presets = args.presets.join(",") == DEFAULT_PRESETS;
    let presets =
        if args.quick && defaults_presets { vec!["paper".into(), "mapkeeper".into()] } else { args.presets.clone() };
    let default_poses = args.poses.join(",") == "reference,mapkeeper-real,amcl";
    let poses = if args.quick && default_poses {
        vec!["reference".into(), "mapkeeper-real".into()]
    } else {
        args.poses.clone()
    };
    let pose_sources = poses.iter().map(|p| pose_source(p)).collect::<anyhow::Result<Vec<_>>>()?;
    let edits = load_params(EditParams::default(), args.edit_params.as_deref(), EditParams::validate)?;
    let (worlds, seeds) = if args.quick { (3, 1) } else { (args.worlds, args.seeds) };
    let cuts = if args.quick { args.kidnap_cuts.min(2) } else { args.kidnap_cuts };
    let kidnaps = if cuts > 0 {
        for l in &args.kidnap_localisers {
            FilterParams::preset(l).with_context(|| format!("--kidnap-localisers: '{l}'"))?;
        }
        let mut k = RealKidnapParams::default();
        k.cuts.count = cuts;
        k.localisers = args.kidnap_localisers.clone();
        // The three presets by default; the run's own when --presets (or --quick) says.
        if !defaults_presets || args.quick {
            k.presets = presets.clone();
        }
        Some(k)
    } else {
        None
    };
    let params = RealScansParams {
        mapper: MapLogParams {
            mapper: MapperParams::default(),
            no_return_clear_m: 0.0,
            resolution_m: 0.05,
            margin_m: 1.0,
        },
        edits,
        edit_seeds: (0..seeds as u64).map(|k| args.seed.wrapping_add(k)).collect(),
        worlds,
        presets,
        pose_sources,
        metrics: MetricParams::default(),
        keep_maps: true,
        kidnaps,
    };
    params.validate().map_err(|e| anyhow::anyhow!("{e}"))?;
    Ok(params)
}

/// The logs (cut to `--first-scans`), each with the map a log without reference poses starts from.
fn inputs(args: &Args) -> anyhow::Result<Vec<LogInput>> {
    let logs = if args.logs.is_empty() { shared_logs()? } else { args.logs.clone() };
    let scans = if args.quick { Some(args.first_scans.unwrap_or(150)) } else { args.first_scans };
    let map = match &args.map {
        Some(p) => Some(mapkeeper_grid::map_io::load_map(p).with_context(|| format!("--map {}", p.display()))?),
        None => None,
    };
    let mut inputs = Vec::new();
    for p in &logs {
        let mut dataset = read(p, &args.reading)?;
        if let Some(n) = scans {
            dataset = dataset.first_scans(n);
        }
        anyhow::ensure!(
            dataset.has_reference() || map.is_some(),
            "--log {}: the log has no reference poses; give --map (the map its passes start from: they run unscored) \
or --truth-topic (a topic of reference poses)",
            p.display()
        );
        inputs.push(LogInput { dataset, map: map.clone() });
    }
    Ok(inputs)
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let params = params(&args)?;
    let inputs = inputs(&args)?;
    let out =
        args.output.out.clone().unwrap_or_else(|| crate::cmd::numbered_out(&format!("real-scans-s{}", args.seed)));
    let dir = crate::cmd::output_dir(&out, args.output.force)?;
    let pool = crate::cmd::thread_pool(args.threads.jobs)?;
    let total = chain_count(&inputs, &params);
    let bar = pool.install(|| crate::cmd::progress_bar("experiment real-scans", total as u64, "chains", &out));
    let start = Instant::now();
    let results = pool.install(|| run_real_scans(&inputs, &params, &|| bar.inc(1)))?;
    bar.finish_and_clear();
    let wall = args.timing.wall_s(start);
    write_real_scans(&dir, &results, &params, wall)?;
    let out = dir.finish()?;
    print_lines(&results, params.worlds);
    outln!("{:.1} s wall; wrote {}", wall, out.display());
    Ok(())
}

/// The lines printed for `mapkeeper`: the kidnaps and each pose source's pass K.
fn print_lines(results: &[LogResult], worlds: usize) {
    for r in results {
        if let Some(k) = &r.kidnaps {
            for x in k.summaries.iter().filter(|x| x.preset == "mapkeeper") {
                outln!(
                    "{}: spliced kidnaps, mapkeeper, {} on {}: {:.0} % of {} recovered, {:.0} % wrong, {:.0} % false Lost",
                    r.name,
                    x.localiser,
                    x.map,
                    100.0 * x.recovered_rate,
                    x.trials,
                    100.0 * x.wrong_rate,
                    100.0 * x.false_lost_rate
                );
            }
        }
        for c in r.summaries.iter().filter(|c| c.preset == "mapkeeper") {
            outln!(
                "{} ({} scans), mapkeeper, poses {}: MS {:.2} → {:.2} (pass {worlds}), CC {:.2} → {:.2}, OPDF {:.2} → {:.2}; retention {:.2} %",
                r.name,
                r.scans,
                c.poses,
                c.m1.ms,
                c.last.ms,
                c.m1.cc,
                c.last.cc,
                c.m1.opdf,
                c.last.opdf,
                c.retention
            );
        }
    }
}
