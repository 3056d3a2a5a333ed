//! From the flags to the sweep's plan: the presets' parameters, the output folders, the
//! threads, and the line that says what will run.

use super::Args;
use anyhow::Context;
use mapkeeper_scenario::{StagedDir, SweepPlan, SweepSpec};
use std::path::Path;

/// The output folders, made before anything runs: OUT itself, or for a sweep OUT (holding the
/// comparison) and `OUT/<preset>` inside it per preset, moved into place with OUT.
pub(super) fn output_dirs(
    out: &Path,
    plan: &SweepPlan,
    sweep: bool,
    force: bool,
) -> anyhow::Result<(Option<StagedDir>, Vec<StagedDir>)> {
    let top = crate::cmd::output_dir(out, force)?;
    if !sweep {
        return Ok((None, vec![top]));
    }
    let subs = plan.groups().iter().map(|&p| top.sub(&plan.presets[p])).collect::<Result<Vec<_>, _>>()?;
    Ok((Some(top), subs))
}

/// With `--mcap-worlds`: each preset's bags go to its folder's `mcap/`.
pub(super) fn plan_mcap(plan: &mut SweepPlan, dirs: &[StagedDir], worlds: &[usize]) -> anyhow::Result<()> {
    if worlds.is_empty() {
        return Ok(());
    }
    for (p, dir) in plan.groups().into_iter().zip(dirs) {
        let mcap_dir = dir.path().join("mcap");
        std::fs::create_dir_all(&mcap_dir).with_context(|| format!("{}", mcap_dir.display()))?;
        plan.params[p].mcap_worlds = worlds.to_vec();
        plan.mcap_dirs[p] = Some(mcap_dir);
    }
    Ok(())
}

/// Fewer runs than threads: a free core runs each run's simulator ahead of its estimators (the
/// same results bit for bit; docs/benchmarks.md).
pub(super) fn simulate_ahead_if_cores_free(
    plan: &mut mapkeeper_scenario::SweepPlan,
    runs: usize,
    pool: rayon::ThreadPool,
) -> rayon::ThreadPool {
    plan.options.simulate_ahead = runs < pool.current_num_threads();
    pool
}

/// The flags that override fields of every preset's parameters.
pub(super) fn apply_overrides(args: &Args, plan: &mut SweepPlan) -> anyhow::Result<()> {
    let poses = args.poses.updater_poses()?;
    let saved = args.save_maps.as_ref().map(|s| s.resolve(args.worlds)).transpose()?;
    for p in &mut plan.params {
        if let Some(saved) = &saved {
            p.saved_worlds.clone_from(saved);
        }
        p.runner.updater_poses = poses;
        if let Some(k) = args.update_every {
            p.update_every = k;
        }
        if let (Some(k), Some(f)) = (args.fresh_map_every, p.runner.fresh_map.as_mut()) {
            f.scan_stride = u32::try_from(k).context("--fresh-map-every")?;
        }
        if let Some(c) = args.route_clearance {
            p.generator.route_clearance_m = c;
        }
        p.generator.route_variants |= args.route_variants;
        if let Some(s) = args.people_pause_s {
            p.generator.people_pause_s = s;
        }
        p.validate().context("--update-every / --fresh-map-every / --route-clearance / --people-pause-s")?;
        args.sensor.apply(&mut p.runner.sim)?;
    }
    Ok(())
}

/// The sweep the flags ask for (W_1 loaded and resolved).
pub(super) fn spec_of(args: &Args) -> anyhow::Result<SweepSpec> {
    let presets = match (&args.presets, &args.preset) {
        (Some(list), _) => list.clone(),
        (None, Some(one)) => vec![one.clone()],
        (None, None) => super::args::DEFAULT_PRESETS.iter().map(ToString::to_string).collect(),
    };
    Ok(SweepSpec {
        presets,
        worlds: args.worlds,
        first_seed: args.seed,
        seeds: args.seeds as u64,
        route_length_m: args.route_length,
        shard: args.shard,
        localiser: args.localiser.clone(),
        ground_truth: args.ground_truth,
        site: args.site.load()?,
    })
}

/// What a validation is about to run and where it writes (printed before the first world, so a
/// user who typed the bare command knows what it does before the progress bar).
pub(super) fn plan_line(args: &Args, plan: &SweepPlan, out: &Path, to_run: usize, threads: usize) -> String {
    let mut seeds: Vec<u64> = plan.jobs.iter().map(|j| j.1).collect();
    seeds.sort_unstable();
    seeds.dedup();
    let seeds = match (seeds.first(), seeds.last()) {
        (Some(a), Some(b)) if b - a + 1 == seeds.len() as u64 && a != b => format!("seeds {a}-{b}"),
        _ => format!("seed(s) {}", seeds.iter().map(u64::to_string).collect::<Vec<_>>().join(", ")),
    };
    let presets: Vec<&str> = plan.groups().into_iter().map(|p| plan.presets[p].as_str()).collect();
    let poses = plan.params.first().map_or("localiser", |p| p.runner.updater_poses.name());
    format!(
        "validate: preset(s) {} × {seeds} × {} worlds (W_2-W_{}), localiser {}, updater poses {poses}, ground truth {}; \
{} job(s), {to_run} to run, on {threads} thread(s); writing {} (a killed run continues with --resume --out)",
        presets.join(", "),
        args.worlds,
        args.worlds,
        args.localiser,
        args.ground_truth.name(),
        plan.jobs.len(),
        out.display()
    )
}
