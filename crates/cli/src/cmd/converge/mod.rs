//! `mapkeeper converge`: how long the localiser presets take to correct a start error on the
//! default warehouse W_1 with its true map (docs/localiser.md, "Convergence").

mod seeds;

use anyhow::{Context, bail};
use mapkeeper_localiser::FilterParams;
use mapkeeper_scenario::experiments::convergence::{
    ConvergenceParams, run_convergence, runs_csv, samples_csv, summary_markdown,
};
use mapkeeper_sim::World;
use seeds::{SeedList, parse_seeds};
use std::path::PathBuf;

/// Largest `--hold` and `--max-time`, simulated seconds.
const MAX_RUN_S: f64 = 3600.0;
/// Most `--errors` entries.
const MAX_ERRORS: usize = 1000;

/// Arguments of `mapkeeper converge`.
#[derive(clap::Args, Debug)]
#[command(after_help = "For each localiser preset, seed and start error: drive the default route in the \
embedded default warehouse W_1 on its ground-truth map (localiser only: no updater, no baseline), the \
localiser started at the true pose displaced by the error in a seeded direction with the preset's initial \
covariance. Converged: position error below --threshold and staying below it for --hold seconds.\n\n\
Output in OUT: summary.md (medians, maxima, not-converged counts per localiser and error), runs.csv (one line \
per run) and runs/<localiser>-e<error>-s<seed>.csv (error at every scan tick).")]
pub struct Args {
    /// Localiser presets, comma-separated (mapkeeper, amcl).
    #[arg(long, value_name = "L1,L2,…", value_delimiter = ',', default_value = "amcl,mapkeeper")]
    pub localisers: Vec<String>,
    /// Seeds: a range `A-B` or a comma-separated list (at most 100000 seeds, no repeats).
    #[arg(long, value_name = "A-B|S1,S2,…", default_value = "1-10", value_parser = parse_seeds, allow_hyphen_values = true)]
    pub seeds: SeedList,
    /// Start errors, metres, comma-separated; each 0 to 100 m (the warehouse is 15 m × 22 m),
    /// at most 1000 of them.
    #[arg(long, value_name = "M1,M2,…", value_delimiter = ',', default_value = "0.5,0.7,1.5", value_parser = super::real_in(0.0, super::MAX_START_ERROR_M, "m"), allow_hyphen_values = true)]
    pub errors: Vec<f64>,
    /// Converged: position error below this, metres (> 0 and ≤ 100 m).
    #[arg(long, value_name = "METRES", default_value_t = 0.1, value_parser = super::positive_up_to(super::MAX_START_ERROR_M, "m"), allow_hyphen_values = true)]
    pub threshold: f64,
    /// ... staying below it this long, seconds (0 to 3600 s).
    #[arg(long, value_name = "SECONDS", default_value_t = 2.0, value_parser = super::real_in(0.0, MAX_RUN_S, "s"), allow_hyphen_values = true)]
    pub hold: f64,
    /// Cap of each run, simulated seconds (> 0 and ≤ 3600 s, 30 × the default).
    #[arg(long, value_name = "SECONDS", default_value_t = 120.0, value_parser = super::positive_up_to(MAX_RUN_S, "s"), allow_hyphen_values = true)]
    pub max_time: f64,
    /// Drive only the first this-many metres of the route (> 0 and ≤ 10000 m).
    #[arg(long, value_name = "METRES", value_parser = super::route_length, allow_hyphen_values = true)]
    pub route_length: Option<f64>,
    /// TOML file overriding FilterParams fields of every localiser preset given (for
    /// diagnostics; the file is named in summary.md).
    #[arg(long, value_name = "FILE.toml")]
    pub params: Option<PathBuf>,
    #[command(flatten)]
    pub output: super::shared_args::RequiredOutputArgs,
    #[command(flatten)]
    pub threads: super::shared_args::JobsArg,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    if args.errors.len() > MAX_ERRORS {
        bail!("--errors: at most {MAX_ERRORS} start errors, got {}", args.errors.len());
    }
    let mut params = ConvergenceParams {
        localisers: args.localisers.iter().map(|l| l.trim().to_string()).collect(),
        seeds: args.seeds.0.clone(),
        errors_m: args.errors.clone(),
        threshold_m: args.threshold,
        hold_s: args.hold,
        max_sim_time_s: args.max_time,
        ..ConvergenceParams::default()
    };
    if let Some(len) = args.route_length {
        params.route = mapkeeper_scenario::ValidationParams::short_route(len);
    }
    if let Some(file) = args.params.as_deref() {
        for l in &params.localisers {
            let preset = FilterParams::preset(l).with_context(|| format!("--localisers: '{l}'"))?;
            params.filters.push(super::load_params(preset, Some(file), FilterParams::validate)?);
        }
    }
    if let Err(e) = params.validate() {
        bail!("--localisers / --seeds / --errors: {e}");
    }
    let dir = super::output_dir(&args.output.out, args.output.force)?;
    let pool = super::thread_pool(args.threads.jobs)?;
    let bar = pool.install(|| super::progress_bar("converge", params.jobs().len() as u64, "runs", &args.output.out));
    let w1 = World::default_warehouse();
    let runs = pool.install(|| run_convergence(&w1, &params, &|| bar.inc(1)))?;
    bar.finish_and_clear();
    for r in &runs {
        dir.write(&format!("runs/{}-e{}-s{}.csv", r.localiser, r.start_error_m, r.seed), samples_csv(r).as_bytes())?;
    }
    dir.write("runs.csv", runs_csv(&runs).as_bytes())?;
    let table = summary_markdown(&params, &runs);
    let route = if args.route_length.is_some() { "shortened default route" } else { "default route" };
    let md =
        format!("# Convergence from a start error\n\nW_1 (default warehouse), ground-truth map, {route}.\n\n{table}");
    dir.write("summary.md", md.as_bytes())?;
    let out = dir.finish()?;
    out!("{table}");
    outln!("wrote {}", out.display());
    Ok(())
}
