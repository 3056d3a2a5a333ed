//! What `mapkeeper run` writes: the trajectories and `run.json` of a closed-loop run; `run --log`, the chain on a recorded log.

use super::Args;
use mapkeeper_closed_loop::RunnerParams;
use mapkeeper_scenario::stats::median;
use mapkeeper_sensor::tum::format_tum;

/// Writes the trajectories and `run.json` of a closed-loop run.
pub(super) fn write_outputs(
    dir: &mapkeeper_grid::StagedDir,
    args: &Args,
    world_path: &std::path::Path,
    params: &RunnerParams,
    r: &mapkeeper_closed_loop::WorldRun,
    wall: f64,
) -> anyhow::Result<()> {
    if let Some(t) = &r.trajectories {
        dir.write("true.tum", format_tum(&t.truth).as_bytes())?;
        dir.write("chain.tum", format_tum(&t.chain).as_bytes())?;
        dir.write("baseline.tum", format_tum(&t.baseline).as_bytes())?;
    }
    let median = median(r.scan_times_us.iter().map(|&t| f64::from(t)).collect()).unwrap_or(0.0);
    let mut json = serde_json::json!({
        "seed": args.seed,
        "preset": args.preset,
        "localiser": params.localiser,
        "filter": params.filter,
        "world": world_path.display().to_string(),
        "map": args.map.display().to_string(),
        "chain": r.chain,
        "baseline": r.baseline,
        "updater": r.updater,
        "median_scan_us": median,
        "cells_changed": r.cells_changed,
        "collisions": r.collisions,
        "sim_time_s": r.sim_time_s,
        "distance_m": r.distance_m,
        "route_done": r.route_done,
        "wall_time_s": wall,
    });
    if let Some(e) = &r.given_pose {
        json["updater_poses"] = serde_json::to_value(params.updater_poses)?;
        json["updater_pose_error"] = serde_json::to_value(e)?;
    }
    dir.write("run.json", format!("{}\n", serde_json::to_string_pretty(&json)?).as_bytes())?;
    Ok(())
}

/// `run --log`: the chain on a recorded log, as `update --localise`.
pub(super) fn run_log(args: &Args, log: &std::path::Path) -> anyhow::Result<()> {
    let input =
        crate::cmd::log_input::LogInput { time: args.time.clone(), ..crate::cmd::log_input::LogInput::path(log) };
    crate::cmd::update::run(crate::cmd::update::Args {
        map: args.map.clone(),
        input,
        poses: None,
        true_poses: false,
        localise: true,
        localiser: args.localiser.clone(),
        localiser_params: None,
        seed: args.seed,
        preset: args.preset.clone(),
        params: args.params.clone(),
        sync_window_s: 0.05,
        output: args.output.clone(),
        mcap: args.mcap.clone(),
        no_deskew: false,
        timing: args.timing,
    })
}
