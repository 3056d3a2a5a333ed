//! `mapkeeper merge`: combine validation folders (shards of one sweep, or runs of other seeds
//! with the same parameters) into one folder, as if one run had made it.

use mapkeeper_scenario::experiments::validation::comparison::{is_sweep_dir, merge_sweeps};
use mapkeeper_scenario::experiments::validation::merge::merge_dirs;
use std::path::PathBuf;

/// Arguments of `mapkeeper merge`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Each DIR is a `mapkeeper validate` folder (or an earlier merge). Their runs.json records \
are checked (summary.json must agree, every seed-S/ folder must be there) and must have the same tool \
version, parameters (worlds, preset, everything) and timing mode, and no seed twice. OUT gets runs.json, \
summary.json, worlds.csv, edits.json, report.md and plots/ recomputed over all seeds in seed order (the \
same files a single run over those seeds writes; wall_time_s is the sum), and the seed-S/ folders copied.\n\n\
Sweep folders (validate --presets …, e.g. its shards) are merged whole when the first DIR is one: every \
DIR must be a sweep over the same presets; each preset's folders are merged into OUT/<preset> as above, \
and OUT/summary.json and OUT/report.md compare the merged presets side by side (the files of the \
unsharded sweep).")]
pub struct Args {
    /// The result folders to merge.
    #[arg(required = true, value_name = "DIR")]
    pub dirs: Vec<PathBuf>,
    #[command(flatten)]
    pub output: super::shared_args::RequiredOutputArgs,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    if args.dirs.first().is_some_and(|d| is_sweep_dir(d)) {
        let out = super::output_dir(&args.output.out, args.output.force)?;
        let c = merge_sweeps(&args.dirs, &out)?;
        out.finish()?;
        let merged: Vec<&str> = c.rows.iter().filter(|r| r.seed.is_none()).map(|r| r.preset.as_str()).collect();
        outln!("merge: {} sweep folder(s), presets {merged:?}, {} worlds", args.dirs.len(), c.worlds);
        outln!("wrote {}", args.output.out.display());
        return Ok(());
    }
    let out = super::output_dir(&args.output.out, args.output.force)?;
    let (_, summary) = merge_dirs(&args.dirs, &out)?;
    out.finish()?;
    outln!(
        "merge: {} folder(s), seeds {:?}, {} worlds, preset {}",
        args.dirs.len(),
        summary.seeds,
        summary.worlds,
        summary.preset
    );
    out!("{}", summary.table());
    outln!("wrote {}", args.output.out.display());
    Ok(())
}
