//! `generate --logs`: each world's drive written as a sensor log.

use anyhow::Context;
use mapkeeper_closed_loop::recording::{DriveSpec, record_drive};
use mapkeeper_sensor::SensorLog;
use mapkeeper_sim::{Route, World};

/// One simulated drive of `route` in each world, written as `logs/W_<k>.<format>`, and
/// `logs/logs.json`; the worlds are driven in parallel, each from its own seed.
pub(super) fn write_logs(
    dir: &mapkeeper_grid::StagedDir,
    worlds: &[World],
    routes: &[Route],
    seed: u64,
    format: &str,
    jobs: Option<usize>,
) -> anyhow::Result<()> {
    use rayon::prelude::*;
    let params = mapkeeper_sim::SimParams::default();
    let pool = crate::cmd::thread_pool(jobs)?;
    let bar = pool.install(|| crate::cmd::progress_bar("generate --logs", worlds.len() as u64, "drives", dir.target()));
    let rows: Vec<serde_json::Value> = pool.install(|| {
        worlds
            .par_iter()
            .enumerate()
            .map(|(i, world)| -> anyhow::Result<serde_json::Value> {
                let name = format!("W_{:03}", i + 1);
                let drive_seed = mapkeeper_sim::seeds::stream_seed(seed, &format!("drive/{name}"));
                let spec = DriveSpec {
                    world,
                    route: Some(&routes[i]),
                    params: &params,
                    seed: drive_seed,
                    seconds: 900.0,
                    stop_at_route_end: true,
                    tool: "mapkeeper generate --logs",
                };
                let jsonl = dir.file(&format!("logs/{name}.jsonl"))?;
                let d = record_drive(&spec, &jsonl, &|_| {})?;
                let file = if format == "mcap" {
                    let mcap = dir.file(&format!("logs/{name}.mcap"))?;
                    mapkeeper_logs::write_log_mcap(&SensorLog::read(&jsonl)?, &mcap)?;
                    std::fs::remove_file(&jsonl).with_context(|| format!("{}", jsonl.display()))?;
                    format!("logs/{name}.mcap")
                } else {
                    format!("logs/{name}.jsonl")
                };
                bar.inc(1);
                Ok(serde_json::json!({
                    "world": name,
                    "file": file,
                    "seed": drive_seed,
                    "scans": d.scans,
                    "distance_m": d.distance_m,
                    "simulated_s": d.simulated_s,
                    "route_done": d.route_done,
                    "collisions": d.collisions.iter().filter(|c| c.started).count(),
                }))
            })
            .collect::<anyhow::Result<Vec<_>>>()
    })?;
    bar.finish_and_clear();
    let index = serde_json::json!({ "format": format, "seed": seed, "logs": rows });
    dir.write("logs/logs.json", format!("{}\n", serde_json::to_string_pretty(&index)?).as_bytes())?;
    Ok(())
}
