//! `mapkeeper converge`: how long the localiser presets take to correct a start error on the
//! default warehouse W_1 with its true map (docs/localiser.md, "Convergence").

use anyhow::{Context, bail};
use mapkeeper_localiser::FilterParams;
use mapkeeper_scenario::experiments::convergence::{
    ConvergenceParams, run_convergence, runs_csv, samples_csv, summary_markdown,
};
use mapkeeper_sim::World;
use std::path::PathBuf;

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
    /// Seeds: a range `A-B` or a comma-separated list.
    #[arg(long, value_name = "A-B|S1,S2,…", default_value = "1-10", value_parser = parse_seeds)]
    pub seeds: SeedList,
    /// Start errors, metres, comma-separated.
    #[arg(long, value_name = "M1,M2,…", value_delimiter = ',', default_value = "0.5,0.7,1.5", value_parser = super::non_negative)]
    pub errors: Vec<f64>,
    /// Converged: position error below this, metres.
    #[arg(long, value_name = "METRES", default_value_t = 0.1, value_parser = super::positive)]
    pub threshold: f64,
    /// ... staying below it this long, seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = 2.0, value_parser = super::non_negative)]
    pub hold: f64,
    /// Cap of each run, simulated seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = 120.0, value_parser = super::positive)]
    pub max_time: f64,
    /// Drive only the first this-many metres of the route.
    #[arg(long, value_name = "METRES", value_parser = super::positive)]
    pub route_length: Option<f64>,
    /// TOML file overriding FilterParams fields of every localiser preset given (for
    /// diagnostics; the file is named in summary.md).
    #[arg(long, value_name = "FILE.toml")]
    pub params: Option<PathBuf>,
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Replace an existing non-empty output folder.
    #[arg(long)]
    pub force: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub jobs: Option<usize>,
}

/// A parsed `--seeds`.
#[derive(Clone, Debug)]
pub struct SeedList(pub Vec<u64>);

/// Parses `A-B` (inclusive, A ≤ B, at most 100000 seeds) or `S1,S2,…` (no repeats).
pub fn parse_seeds(s: &str) -> Result<SeedList, String> {
    let num = |p: &str| p.trim().parse::<u64>().map_err(|e| format!("'{p}' is not a seed: {e}"));
    let seeds: Vec<u64> = if let Some((a, b)) = s.split_once('-') {
        let (a, b) = (num(a)?, num(b)?);
        if a > b || b - a >= 100_000 {
            return Err(format!("range '{s}' must be A-B with A ≤ B and at most 100000 seeds"));
        }
        (a..=b).collect()
    } else {
        s.split(',').map(num).collect::<Result<_, _>>()?
    };
    if let Some((i, d)) = seeds.iter().enumerate().find(|(i, d)| seeds[..*i].contains(d)) {
        return Err(format!("seed {d} given twice (entry {})", i + 1));
    }
    Ok(SeedList(seeds))
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
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
    let dir = super::output_dir(&args.out, args.force)?;
    let bar = super::progress_bar(params.jobs().len() as u64, "runs");
    let w1 = World::default_warehouse();
    let runs = super::thread_pool(args.jobs)?.install(|| run_convergence(&w1, &params, &|| bar.inc(1)))?;
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
    print!("{table}");
    println!("wrote {}", out.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeds_parse_as_ranges_and_lists() {
        assert_eq!(parse_seeds("1-3").unwrap().0, vec![1, 2, 3]);
        assert_eq!(parse_seeds("4,2").unwrap().0, vec![4, 2]);
        assert_eq!(parse_seeds("7").unwrap().0, vec![7]);
        for bad in ["3-1", "x", "1,1", "1-", ""] {
            assert!(parse_seeds(bad).is_err(), "{bad}");
        }
    }
}
