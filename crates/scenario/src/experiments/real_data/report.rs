//! The files of an `experiment real-data` folder: `summary.json`, `report.md`, and per log
//! `<name>/map.yaml` (the map at the reference poses), `reference.tum`, `estimate_<config>.tum`,
//! `errors_<config>.csv`, `odometry_vs_reference.csv` and `changes_<preset>_<poses>.png` (the
//! updater's changes to the log's own map; `docs/real-data.md`).

use crate::experiments::real_data::{
    DISAGREEMENT_M, DatasetResult, LOST_M, LocaliserConfig, RealDataParams, TARGET_MAX_M, TARGET_RMSE_M,
};
use crate::results::ResultsError;
use mapkeeper_grid::StagedDir;
use mapkeeper_grid::map_io::save_map;
use mapkeeper_grid::render::render_diff;
use mapkeeper_sensor::write_tum_with_comment;
use serde::Serialize;
use std::fmt::Write as _;

/// `summary.json`.
#[derive(Serialize)]
struct Summary<'a> {
    experiment: &'static str,
    seeds: &'a [u64],
    targets: Targets,
    localisers: Vec<ConfigSummary<'a>>,
    mapper: &'a mapkeeper_harness::jobs::map::MapLogParams,
    updater_presets: &'a [String],
    datasets: &'a [DatasetResult],
    wall_time_s: f64,
}

#[derive(Serialize)]
struct Targets {
    rmse_m: f64,
    max_m: f64,
    lost_m: f64,
    disagreement_m: f64,
}

#[derive(Serialize)]
struct ConfigSummary<'a> {
    name: &'a str,
    description: &'a str,
    params: &'a mapkeeper_localiser::FilterParams,
}

fn file_name(s: &str) -> String {
    s.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' }).collect()
}

/// Writes the folder's files into `dir`.
pub fn write_real_data(
    dir: &StagedDir,
    results: &[DatasetResult],
    params: &RealDataParams,
    wall_time_s: f64,
) -> Result<(), ResultsError> {
    let summary = Summary {
        experiment: "real-data",
        seeds: &params.seeds,
        targets: Targets { rmse_m: TARGET_RMSE_M, max_m: TARGET_MAX_M, lost_m: LOST_M, disagreement_m: DISAGREEMENT_M },
        localisers: params
            .localisers
            .iter()
            .map(|c| ConfigSummary { name: &c.name, description: &c.description, params: &c.params })
            .collect(),
        mapper: &params.mapper,
        updater_presets: &params.updater_presets,
        datasets: results,
        wall_time_s,
    };
    let json = serde_json::to_string_pretty(&summary)
        .map_err(|e| ResultsError::Serialise { what: "summary.json".into(), message: e.to_string() })?;
    dir.write("summary.json", format!("{json}\n").as_bytes())?;
    for d in results {
        write_dataset(dir, d)?;
    }
    dir.write("report.md", report(results, &params.localisers, &params.seeds, wall_time_s).as_bytes())?;
    Ok(())
}

fn write_dataset(dir: &StagedDir, d: &DatasetResult) -> Result<(), ResultsError> {
    let sub = file_name(&d.name);
    let file = |rel: &str| dir.file(&format!("{sub}/{rel}"));
    if let Some(map) = &d.map {
        save_map(map, &file("map.yaml")?)?;
    }
    write_tum_with_comment(
        &file("reference.tum")?,
        &format!("reference poses of {} at its scans", d.source),
        &d.reference,
    )?;
    for l in &d.localisers {
        let name = file_name(&l.localiser);
        let comment = format!("mapkeeper experiment real-data: localiser {} on {}", l.localiser, d.source);
        write_tum_with_comment(&file(&format!("estimate_{name}.tum"))?, &comment, &l.estimates)?;
        let mut csv = String::from("time_s,position_error_m,yaw_error_deg\n");
        for (t, e, y) in &l.series {
            let _ = writeln!(csv, "{t:.6},{e:.4},{y:.3}");
        }
        dir.write(&format!("{sub}/errors_{name}.csv"), csv.as_bytes())?;
    }
    let mut csv = String::from("time_s,odometry_minus_reference_m\n");
    for (t, e) in &d.disagreement.series {
        let _ = writeln!(csv, "{t:.6},{e:.4}");
    }
    dir.write(&format!("{sub}/odometry_vs_reference.csv"), csv.as_bytes())?;
    if let Some(before) = &d.map {
        for u in &d.updaters {
            if let Some(after) = &u.map {
                let img = render_diff(before, after).map_err(|e| ResultsError::Serialise {
                    what: format!("{sub}: changes of {}", u.preset),
                    message: e.to_string(),
                })?;
                let path = file(&format!("changes_{}_{}.png", file_name(&u.preset), file_name(&u.poses)))?;
                img.write_png(&path).map_err(|e| ResultsError::Serialise {
                    what: path.display().to_string(),
                    message: e.to_string(),
                })?;
            }
        }
    }
    Ok(())
}

/// `report.md`.
pub fn report(results: &[DatasetResult], configs: &[LocaliserConfig], seeds: &[u64], wall_time_s: f64) -> String {
    let mut s = String::from("# Real data: localisation against the reference, the updater on the log's own map\n\n");
    let _ = writeln!(
        s,
        "{} log(s), localiser seeds {seeds:?} (each configuration runs once per seed), {wall_time_s:.1} s wall. Each log's map is built at its reference poses; the \
localiser starts at the first reference pose with AMCL's initial covariance and follows the raw odometry. Targets: \
position RMSE ≤ {TARGET_RMSE_M} m and largest error ≤ {TARGET_MAX_M} m. Definitions: docs/real-data.md.\n",
        results.len()
    );
    s.push_str("Localiser configurations:\n\n");
    for c in configs {
        let _ = writeln!(s, "- `{}`: {}", c.name, c.description);
    }
    s.push_str("\nMean over the seeds, with the range of the seeds' values:\n\n| log | scans | path (m) | localiser | RMSE (m) | max (m) | median (m) | yaw RMSE (°) | lost > 0.5 m | seeds meeting both targets |\n|---|---:|---:|---|---|---|---:|---:|---:|---:|\n");
    for d in results {
        for l in &d.localisers {
            let range = |f: &dyn Fn(&crate::experiments::real_data::ErrorStats) -> f64, digits: usize| {
                let v: Vec<f64> = l.by_seed.iter().map(f).collect();
                let (lo, hi) = (v.iter().copied().fold(f64::INFINITY, f64::min), v.iter().copied().fold(0.0, f64::max));
                let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
                format!("{mean:.digits$} [{lo:.digits$}, {hi:.digits$}]")
            };
            let mean = |f: &dyn Fn(&crate::experiments::real_data::ErrorStats) -> f64| {
                l.by_seed.iter().map(f).sum::<f64>() / l.by_seed.len().max(1) as f64
            };
            let _ = writeln!(
                s,
                "| {} | {} | {:.0} | {} | {} | {} | {:.4} | {:.2} | {:.1} % | {} of {} |",
                d.name,
                d.scans,
                d.path_m,
                l.localiser,
                range(&|e| e.rmse_m, 4),
                range(&|e| e.max_m, 3),
                mean(&|e| e.median_m),
                mean(&|e| e.yaw_rmse_deg),
                100.0 * mean(&|e| e.lost_share),
                l.seeds_meeting_targets,
                l.by_seed.len()
            );
        }
    }
    s.push_str(
        "\nWhere the odometry contradicts the reference (steps between consecutive scans whose odometry and \
reference increments differ by more than ",
    );
    let _ = writeln!(
        s,
        "{DISAGREEMENT_M} m):\n\n| log | steps | contradicting | longest run | it starts at |\n|---|---:|---:|---:|---:|"
    );
    for d in results {
        let g = &d.disagreement;
        let _ = writeln!(
            s,
            "| {} | {} | {} ({:.1} %) | {} steps | {:.1} s |",
            d.name,
            g.steps,
            g.contradicting,
            100.0 * g.contradicting as f64 / g.steps.max(1) as f64,
            g.longest_run,
            g.longest_run_start_s
        );
    }
    fit_table(&mut s, results);
    updater_table(&mut s, results);
    s
}

fn fit_table(s: &mut String, results: &[DatasetResult]) {
    s.push_str(
        "\nHow well each reference agrees with the map built from it (each scan matched against the map from its \
reference pose by the scan matcher of `mapkeeper-real`; the distance the accepted matches move is a floor for any \
map-based localiser scored against this reference):\n\n| log | scans | matches accepted | median (m) | RMS (m) | p95 (m) | \
yaw RMS (°) |\n|---|---:|---:|---:|---:|---:|---:|\n",
    );
    for d in results {
        let f = &d.reference_fit;
        let _ = writeln!(
            s,
            "| {} | {} | {} ({:.1} %) | {:.4} | {:.4} | {:.4} | {:.2} |",
            d.name,
            f.scans,
            f.accepted,
            100.0 * f.accepted as f64 / f.scans.max(1) as f64,
            f.median_m,
            f.rms_m,
            f.p95_m,
            f.yaw_rms_deg
        );
    }
}

fn updater_table(s: &mut String, results: &[DatasetResult]) {
    s.push_str("\nThe updater over each log on the log's own map (changes are transient: people, doors, or poses that \
disagree with the map; with the localiser's poses, how many of its changes the reference-pose run made too):\n\n\
| log | preset | poses | processed | Update | Suspend | Lost | cells → occupied | cells → free | other | same as with the reference |\n\
|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for d in results {
        for u in &d.updaters {
            let same = u.same_as_reference.map_or_else(
                || "–".to_string(),
                |k| {
                    let all = u.to_occupied + u.to_free + u.other_changes;
                    format!("{k} of {all}")
                },
            );
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {same} |",
                d.name,
                u.preset,
                u.poses,
                u.processed,
                u.updates,
                u.suspends,
                u.losts,
                u.to_occupied,
                u.to_free,
                u.other_changes
            );
        }
    }
}
