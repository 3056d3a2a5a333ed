//! `mapkeeper validate`: the hundred-world validation of the paper (§5.3.2), over one or more
//! seeds in parallel; the wall clock is read here (not in the libraries).

mod args;
mod plan;
mod resume;
mod save_maps;

pub use args::Args;

use super::sweep_progress::{SweepProgress, describe};
use anyhow::Context;
use args::default_out;
use mapkeeper_scenario::ValidationRecord;
use mapkeeper_scenario::experiments::validation::checkpoint::Checkpoints;
use mapkeeper_scenario::experiments::validation::comparison::{Comparison, write_comparison};
use mapkeeper_scenario::experiments::validation::report::write_validation;
use mapkeeper_updater::UpdaterParams;
use plan::{apply_overrides, output_dirs, plan_line, plan_mcap, simulate_ahead_if_cores_free, spec_of};
use resume::{finished_jobs, is_complete};
use std::time::Instant;

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let sweep = args.preset.is_none();
    let spec = spec_of(&args)?;
    mapkeeper_localiser::FilterParams::preset(&args.localiser).context("--localiser")?;
    let mut plan = spec.plan()?;
    if let Some(file) = args.updater_params.as_deref() {
        for p in &mut plan.params {
            p.runner.updater = super::load_params(p.runner.updater.clone(), Some(file), UpdaterParams::validate)?;
        }
    }
    apply_overrides(&args, &mut plan)?;
    let out = args.output.out.clone().unwrap_or_else(|| default_out(args.seed, args.worlds, args.shard));
    if let Some(&w) = args.mcap_worlds.iter().find(|&&w| w > args.worlds) {
        anyhow::bail!("--mcap-worlds: world {w} is beyond --worlds {}", args.worlds);
    }
    if args.resume && is_complete(&out, &plan, sweep, &args)? {
        outln!("validate: {} is complete (--resume): nothing to run", out.display());
        return Ok(());
    }
    let (top, dirs) = output_dirs(&out, &plan, sweep, args.output.force)?;
    plan_mcap(&mut plan, &dirs, &args.mcap_worlds)?;
    let checkpoints = Checkpoints::beside(&out);
    let done = finished_jobs(&plan, &checkpoints, &out, args.resume, !args.timing.no_timing)?;
    let start = Instant::now();
    let wall = super::Wall::start();
    let clock = args.timing.clock(&wall);
    let to_run = done.iter().filter(|d| d.is_none()).count();
    let pool = simulate_ahead_if_cores_free(&mut plan, to_run, super::thread_pool(args.threads.jobs)?);
    let threads = pool.current_num_threads();
    let progress = SweepProgress::new(&plan, &args.localiser, threads, done.iter().map(Option::is_some).collect());
    outln!("{}", plan_line(&args, &plan, &out, to_run, threads));
    outln!("validate: {}; Ctrl-C stops it as a kill does (--resume continues)", describe(progress.estimate()));
    let runs =
        pool.install(|| plan.run_resuming(done, Some(&checkpoints), clock, &|k, w| progress.world_done(k, w)))?;
    progress.finish();
    let elapsed_s = start.elapsed().as_secs_f64();
    let wall_time_s = if args.timing.no_timing { 0.0 } else { elapsed_s };
    let mut records = Vec::new();
    for (p, dir) in plan.groups().into_iter().zip(dirs) {
        let group = plan.runs_of(p, &runs);
        let record = ValidationRecord::new(&plan.params[p], &group, !args.timing.no_timing, wall_time_s, args.shard);
        let summary = write_validation(&dir, &group, &record)?;
        if let Some((_, site)) = &spec.site {
            dir.write("world.toml", site.world.to_toml_string()?.as_bytes())?;
        }
        let written = dir.finish()?;
        let seeds: Vec<u64> = group.iter().map(|r| r.seed).collect();
        let shard =
            args.shard.map(|s| format!(" (shard {}/{}: seeds {:?})", s.index, s.count, seeds)).unwrap_or_default();
        let (n, preset) = (seeds.len(), &plan.presets[p]);
        outln!(
            "validate: {n} seed(s) × {} worlds, preset {preset}, localiser {}, {elapsed_s:.1} s wall{shard}",
            args.worlds,
            args.localiser
        );
        out!("{}", summary.table());
        outln!("wrote {}", written.display());
        records.push(record);
    }
    if let Some(top) = top {
        let records: Vec<&ValidationRecord> = records.iter().collect();
        let c = Comparison::new(&plan.presets, &records);
        write_comparison(&top, &c, &records)?;
        top.finish()?;
        outln!(
            "wrote {} and {} (presets side by side)",
            out.join("summary.json").display(),
            out.join("report.md").display()
        );
    }
    checkpoints.remove()?;
    Ok(())
}
