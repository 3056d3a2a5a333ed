//! The files of a validation folder and of a scenario set.
//!
//! Validation folder: `runs.json` (the machine-readable record everything else is computed
//! from), `summary.json`, `worlds.csv`, `report.md`, `edits.json`, `plots/` (the paper's
//! Fig. 24-27, SVG and PNG, [`crate::experiments::validation::figures`]), `report.html` (the report as one
//! self-contained page, [`crate::results::html`]), and per seed `seed-S/maps/{M,G}_iii.{yaml,pgm}`
//! and `E_iii.png` (M_1, G_1 and the saved worlds, [`crate::experiments::validation::saved_worlds`]) and
//! `seed-S/trajectories/W_iii_{true,chain,baseline}.tum`.
//!
//! Scenario set (`generate`): `manifest.json`, `route.toml`, `worlds/W_iii.toml`,
//! `ground_truth/G_iii.{yaml,pgm}`. Same seed ⇒ byte-identical files.

use crate::experiments::validation::figures::write_figures;
use crate::experiments::validation::markdown::{per_world_md, report_md_with_figures};
use crate::experiments::validation::{Scores, SeedRecord, SeedRun, Summary, ValidationRecord, WorldRow};
use crate::results::ResultsError;
use mapkeeper_closed_loop::worlds::generator::WorldChain;
use mapkeeper_grid::GridGeometry;
use mapkeeper_grid::StagedDir;
use mapkeeper_grid::map_io::save_map;
use mapkeeper_sim::{Route, ground_truth_map};
use serde::Serialize;

/// The columns of `worlds.csv`, in order.
pub const WORLDS_CSV_COLUMNS: &[&str] = &[
    "seed",
    "world",
    "edits",
    "movable_items",
    "cc_static",
    "ms_static",
    "opdf_static",
    "cc_updated",
    "ms_updated",
    "opdf_updated",
    "cc_best",
    "ms_best",
    "opdf_best",
    "cc_fresh",
    "ms_fresh",
    "opdf_fresh",
    "cc_static_other_gt",
    "ms_static_other_gt",
    "opdf_static_other_gt",
    "cc_updated_other_gt",
    "ms_updated_other_gt",
    "opdf_updated_other_gt",
    "cc_best_other_gt",
    "ms_best_other_gt",
    "opdf_best_other_gt",
    "cc_fresh_other_gt",
    "ms_fresh_other_gt",
    "opdf_fresh_other_gt",
    "err_mean_static_m",
    "err_max_static_m",
    "rmse_static_m",
    "trace_mean_static",
    "trace_std_static",
    "lambda_max_mean_static",
    "lambda_max_std_static",
    "err_mean_updated_m",
    "err_max_updated_m",
    "rmse_updated_m",
    "trace_mean_updated",
    "trace_std_updated",
    "lambda_max_mean_updated",
    "lambda_max_std_updated",
    "processed_scans",
    "verdict_update",
    "verdict_suspend",
    "verdict_lost",
    "recovered",
    "cells_changed",
    "cell_changes",
    "max_state_bytes",
    "median_scan_us",
    "collisions",
    "sim_time_s",
    "distance_m",
    "route_done",
    "lost_episodes",
    "recovery_attempts",
    "lost_recoveries",
    "lost_cleared",
    "lost_give_ups",
    "lost_stopped_s",
    "structure_cells",
    "retention_updated",
    "retention_best",
    "retention_fresh",
    "added_cells",
    "added_updated",
    "added_best",
    "added_fresh",
    "removed_cells",
    "removed_updated",
    "removed_best",
    "removed_fresh",
    "moved_cells",
    "moved_updated",
    "moved_best",
    "moved_fresh",
    "initial_errors_cells",
    "initial_errors_updated",
    "initial_errors_best",
    "initial_errors_fresh",
];

/// The structure retention and change-class columns of a row (empty in rows of records
/// written before they were measured, and where a class has no cell).
fn erosion_columns(w: &WorldRow) -> Vec<String> {
    let f = |v: f64| format!("{v:.6}");
    let opt = |v: Option<f64>| v.map_or_else(String::new, f);
    let mut cols = match &w.retention {
        Some(r) => vec![r.structure_cells.to_string(), f(r.updated_map), f(r.best_map), f(r.fresh_map)],
        None => vec![String::new(); 4],
    };
    match &w.change_classes {
        Some(c) => {
            for k in [&c.added, &c.removed, &c.moved, &c.initial_errors] {
                cols.extend([k.cells.to_string(), opt(k.updated_map), opt(k.best_map), opt(k.fresh_map)]);
            }
        }
        None => cols.extend(vec![String::new(); 16]),
    }
    cols
}

fn csv_row(w: &WorldRow) -> String {
    let f = |v: f64| format!("{v:.6}");
    let (s, u) = (&w.loc_static, &w.loc_updated);
    let three = |x: &Scores| [f(x.cc), f(x.ms), f(x.opdf)];
    let o = &w.other_ground_truth;
    let mut cols: Vec<String> =
        vec![w.seed.to_string(), w.world.to_string(), w.edits.to_string(), w.movable_items.to_string()];
    for x in [
        &w.static_map,
        &w.updated_map,
        &w.best_map,
        &w.fresh_map,
        &o.static_map,
        &o.updated_map,
        &o.best_map,
        &o.fresh_map,
    ] {
        cols.extend(three(x));
    }
    cols.extend([
        f(s.mean_error_m),
        f(s.max_error_m),
        f(s.rmse_m),
        f(s.mean_trace),
        f(s.std_trace),
        f(s.mean_lambda_max),
        f(s.std_lambda_max),
        f(u.mean_error_m),
        f(u.max_error_m),
        f(u.rmse_m),
        f(u.mean_trace),
        f(u.std_trace),
        f(u.mean_lambda_max),
        f(u.std_lambda_max),
        w.updater.processed.to_string(),
        w.updater.update.to_string(),
        w.updater.suspend.to_string(),
        w.updater.lost.to_string(),
        w.updater.recovered.to_string(),
        w.cells_changed.to_string(),
        w.updater.cell_changes.to_string(),
        w.updater.max_state_bytes.to_string(),
        format!("{:.1}", w.median_scan_us),
        w.collisions.to_string(),
        format!("{:.3}", w.sim_time_s),
        format!("{:.3}", w.distance_m),
        w.route_done.to_string(),
        w.lost.episodes.to_string(),
        w.lost.attempts.to_string(),
        w.lost.recoveries.to_string(),
        w.lost.cleared.to_string(),
        w.lost.give_ups.to_string(),
        format!("{:.3}", w.lost.stopped_s()),
    ]);
    cols.extend(erosion_columns(w));
    cols.join(",")
}

/// `worlds.csv`: one row per world and seed, seeds in the given order.
pub fn worlds_csv(runs: &[SeedRecord]) -> String {
    let mut s = WORLDS_CSV_COLUMNS.join(",");
    s.push('\n');
    for r in runs {
        for w in &r.rows {
            s.push_str(&csv_row(w));
            s.push('\n');
        }
    }
    s
}

fn json<T: Serialize>(what: &str, v: &T) -> Result<String, ResultsError> {
    serde_json::to_string_pretty(v)
        .map(|mut s| {
            s.push('\n');
            s
        })
        .map_err(|e| ResultsError::Serialise { what: what.into(), message: e.to_string() })
}

/// `summary.json` text.
pub fn summary_json(summary: &Summary) -> Result<String, ResultsError> {
    json("summary.json", summary)
}

/// `runs.json` text.
pub fn runs_json(record: &ValidationRecord) -> Result<String, ResultsError> {
    json("runs.json", record)
}

/// Writes everything of a validation folder that is computed from its record: `runs.json`,
/// `summary.json`, `worlds.csv`, `edits.json`, the figures in `plots/`, `report.md` and
/// `report.html` (which embeds the saved worlds' error images: write them first). Returns the
/// summary.
pub fn write_results(dir: &StagedDir, record: &ValidationRecord) -> Result<Summary, ResultsError> {
    let summary = record.summary();
    dir.write("runs.json", runs_json(record)?.as_bytes())?;
    dir.write("summary.json", summary_json(&summary)?.as_bytes())?;
    dir.write("worlds.csv", worlds_csv(&record.seeds).as_bytes())?;
    let edits: Vec<_> = record.seeds.iter().map(|r| (r.seed, &r.edits)).collect();
    dir.write("edits.json", json("edits.json", &edits)?.as_bytes())?;
    let figures = write_figures(dir, record)?;
    let mut report = report_md_with_figures(&summary, &figures);
    report.push_str(&per_world_md(record));
    report.push_str(&crate::experiments::validation::saved_worlds::saved_worlds_md(record));
    dir.write("report.md", report.as_bytes())?;
    crate::results::html::write_report_html(
        dir,
        "Validation report",
        &report,
        &crate::experiments::validation::saved_worlds::world_steppers(record),
        crate::results::html::SteppersIntro::SAVED_WORLDS,
    )?;
    Ok(summary)
}

/// Writes the whole validation folder into `dir`: each seed's saved worlds and trajectories
/// ([`crate::experiments::validation::saved_worlds`]), then [`write_results`] for `record` (made from `runs`;
/// `report.html` embeds the images written first). Returns the summary.
pub fn write_validation(dir: &StagedDir, runs: &[SeedRun], record: &ValidationRecord) -> Result<Summary, ResultsError> {
    crate::experiments::validation::saved_worlds::write_saved_worlds(dir, runs)?;
    write_results(dir, record)
}

/// The manifest of a scenario set.
#[derive(Clone, Debug, Serialize)]
pub struct Manifest {
    /// Always "mapkeeper-scenario-set".
    pub format: String,
    /// Producer and version.
    pub tool: String,
    /// The seed.
    pub seed: u64,
    /// Number of worlds.
    pub worlds: usize,
    /// Map resolution, metres.
    pub resolution_m: f64,
    /// The route file.
    pub route: String,
    /// One entry per world.
    pub files: Vec<ManifestWorld>,
}

/// A world's files in the manifest.
#[derive(Clone, Debug, Serialize)]
pub struct ManifestWorld {
    /// i.
    pub index: usize,
    /// The world file.
    pub world: String,
    /// The ground-truth map YAML (its PGM beside it).
    pub ground_truth: String,
    /// The edits that made it from the previous world.
    pub edits: Vec<mapkeeper_closed_loop::worlds::generator::Edit>,
    /// The route driven in it, when it is not `route.toml` (route variants).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub route: Option<String>,
}

/// Writes a scenario set into `dir`.
pub fn write_scenario_set(
    dir: &StagedDir,
    chain: &WorldChain,
    route: &Route,
    seed: u64,
    geometry: &GridGeometry,
) -> Result<Manifest, ResultsError> {
    dir.write("route.toml", route.to_toml_string()?.as_bytes())?;
    let mut files = Vec::with_capacity(chain.worlds.len());
    for (k, w) in chain.worlds.iter().enumerate() {
        let i = k + 1;
        let wf = format!("worlds/W_{i:03}.toml");
        let gf = format!("ground_truth/G_{i:03}.yaml");
        dir.write(&wf, w.to_toml_string()?.as_bytes())?;
        save_map(&ground_truth_map(w, geometry), &dir.file(&gf)?)?;
        let own_route = chain.routes.get(k).filter(|r| *r != route);
        let route_file = match own_route {
            Some(r) => {
                let rf = format!("routes/R_{i:03}.toml");
                dir.write(&rf, r.to_toml_string()?.as_bytes())?;
                Some(rf)
            }
            None => None,
        };
        files.push(ManifestWorld {
            index: i,
            world: wf,
            ground_truth: gf,
            edits: chain.edits[k].clone(),
            route: route_file,
        });
    }
    let manifest = Manifest {
        format: "mapkeeper-scenario-set".into(),
        tool: format!("mapkeeper-scenario {}", env!("CARGO_PKG_VERSION")),
        seed,
        worlds: chain.worlds.len(),
        resolution_m: geometry.resolution_m(),
        route: "route.toml".into(),
        files,
    };
    dir.write("manifest.json", json("manifest.json", &manifest)?.as_bytes())?;
    Ok(manifest)
}
