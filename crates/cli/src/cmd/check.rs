//! `mapkeeper check`: a validation's results against a stored baseline, pass / fail for a
//! team's CI (`mapkeeper_scenario::experiments::validation::check`, `docs/evaluation.md`, "A gate for CI").

use anyhow::Context;
use mapkeeper_scenario::experiments::validation::check::Baseline;
use std::path::PathBuf;

/// Arguments of `mapkeeper check`.
#[derive(clap::Args, Debug)]
#[command(
    long_about = "Compare a validation's results (a `validate` output folder, one preset or a sweep) with a stored \
baseline and exit with status 1, naming each metric that regressed beyond its tolerance: per preset the mean \
gain of M_i over M_1 on CC, MS and OPDF, the share of worlds where M_i beats M_1, the structure retention at \
the last world, the chain localiser's mean error on M_{i-1} and the share of Lost verdicts. --write-baseline \
writes the baseline from a run instead, each tolerance the 95 % half-width of a difference of two means over \
the run's seeds (or a floor per metric); edit a tolerance in the file to loosen or tighten it. The run checked \
must have the baseline's setting (worlds, seeds, ground truth). Exit status: 0 pass, 1 regression, 2 an error (a \
folder or file that cannot be read, another setting).",
    after_help = "Examples:\n  mapkeeper validate --preset mapkeeper --worlds 10 --seeds 3 --no-timing --out ci/run\n  \
mapkeeper check ci/run --write-baseline ci/baseline.json\n  mapkeeper check ci/run --baseline ci/baseline.json"
)]
pub struct Args {
    /// The results: a `validate` output folder (runs.json and summary.json), or a sweep's
    /// folder with one such folder per preset.
    #[arg(value_name = "RESULTS")]
    pub results: PathBuf,
    /// The baseline to check against (JSON, as --write-baseline writes it).
    #[arg(long, value_name = "FILE", required_unless_present = "write_baseline", conflicts_with = "write_baseline")]
    pub baseline: Option<PathBuf>,
    /// Write the baseline measured from RESULTS to this file instead of checking.
    #[arg(long, value_name = "FILE")]
    pub write_baseline: Option<PathBuf>,
    /// Replace an existing baseline file.
    #[arg(long, requires = "write_baseline")]
    pub force: bool,
}

/// Runs the subcommand: `Ok(true)` passes, `Ok(false)` is a regression.
pub fn run(args: Args) -> anyhow::Result<bool> {
    let measured = Baseline::of(&args.results)?;
    if let Some(out) = &args.write_baseline {
        if out.exists() && !args.force {
            anyhow::bail!("--write-baseline: {} exists (--force replaces it)", out.display());
        }
        mapkeeper_grid::write_atomic(out, measured.to_json()?.as_bytes())
            .with_context(|| format!("--write-baseline: {}", out.display()))?;
        let n: usize = measured.presets.values().map(|m| m.len()).sum();
        outln!("check: wrote {} ({} metrics of {} preset(s))", out.display(), n, measured.presets.len());
        return Ok(true);
    }
    let Some(path) = &args.baseline else { anyhow::bail!("--baseline or --write-baseline is needed") };
    let baseline = Baseline::load(path).context("--baseline")?;
    let verdict = baseline.check(&measured).map_err(|e| anyhow::anyhow!("{}: {e}", args.results.display()))?;
    for m in &verdict.improvements {
        outln!("improved  {m}");
    }
    for m in &verdict.regressions {
        outln!("REGRESSED {m}");
    }
    let pass = verdict.regressions.is_empty();
    outln!(
        "check: {} of {} metrics regressed beyond their tolerance, {} improved: {}",
        verdict.regressions.len(),
        verdict.checked,
        verdict.improvements.len(),
        if pass { "pass" } else { "FAIL" }
    );
    Ok(pass)
}
