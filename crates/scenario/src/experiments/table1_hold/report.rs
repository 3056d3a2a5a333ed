//! The files of an `experiment table1` folder: `summary.json`, `runs.csv`, `report.md` and the
//! figure `cc_by_hold.{svg,png}` (`docs/recovery.md`, "Table 1 with a held error").

use crate::experiments::table1_hold::{MeanCi, Table1HoldResults, VARIANTS};
use crate::results::PNG_SIZE_PX;
use crate::results::ResultsError;
use mapkeeper_grid::StagedDir;
use mapkeeper_plot::BarChart;
use std::fmt::Write as _;

/// The columns of `runs.csv`, in order.
pub const RUNS_CSV_COLUMNS: &[&str] = &[
    "preset",
    "condition",
    "variant",
    "trial",
    "seed",
    "tour_position_m",
    "error_m",
    "direction_rel_deg",
    "yaw_error_deg",
    "cc",
    "ms",
    "opdf",
    "static_cc",
    "static_ms",
    "static_opdf",
    "wrong_flips",
    "cells_changed",
    "alarms",
    "losts",
    "recoveries",
    "route_done",
];

/// `runs.csv`.
pub fn runs_csv(r: &Table1HoldResults) -> String {
    let mut s = RUNS_CSV_COLUMNS.join(",");
    s.push('\n');
    for x in &r.runs {
        let d = &x.draw;
        let _ = writeln!(
            s,
            "{},{},{},{},{},{:.3},{:.4},{:.2},{:.3},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{},{},{},{},{},{}",
            x.preset,
            x.condition,
            x.variant,
            d.trial,
            d.seed,
            d.tour_position_m,
            d.error_m,
            d.direction_rel_rad.to_degrees(),
            d.yaw_error_rad.to_degrees(),
            x.scores.cc,
            x.scores.ms,
            x.scores.opdf,
            x.static_scores.cc,
            x.static_scores.ms,
            x.static_scores.opdf,
            x.wrong_flips,
            x.cells_changed,
            x.suspends,
            x.losts,
            x.recoveries,
            x.route_done
        );
    }
    s
}

fn diff(m: Option<&MeanCi>) -> String {
    match m {
        Some(MeanCi { mean, ci95: Some([lo, hi]) }) => format!("{mean:+.2} [{lo:+.2}, {hi:+.2}]"),
        Some(MeanCi { mean, ci95: None }) => format!("{mean:+.2}"),
        None => "–".into(),
    }
}

/// `report.md`.
pub fn report_md(r: &Table1HoldResults) -> String {
    let s = &r.summary;
    let p = &s.params;
    let mut o = String::new();
    let _ = writeln!(o, "# Table 1 with a held pose error\n");
    let _ = writeln!(
        o,
        "Seed {}, {} trials (each its own W_2, start place and error), the whole tour of W_2 on the map of W_1 ({:?}), \
         localiser `{}`. `hold_Ts`: the pose the updater is given is held {:.2}-{:.2} m off in any direction and up to \
         ±{:.0}° for T s from the start, then right; `amcl_start`: the localiser starts {:.2} m off and corrects itself. \
         M_2 against G_2, means over trials with Student-t 95 % intervals; \"− always\" is the paired difference from \
         `always_update` in points. Nothing updated (the initial map): CC {:.2}, MS {:.2}, OPDF {:.2}. The paper's Table 1: \
         always-update CC 66.86, MS 55.11, OPDF 90.40; with the check 70.03, 61.24, 95.87. Wall time {:.1} s.\n",
        s.seed,
        p.trials,
        s.recovery.initial_map,
        s.recovery.runner.localiser,
        p.min_error_m,
        p.max_error_m,
        p.max_yaw_rad.to_degrees(),
        p.amcl_start_error_m,
        s.static_map.cc,
        s.static_map.ms,
        s.static_map.opdf,
        s.wall_time_s
    );
    for (preset, by_cond) in &s.table1 {
        let _ = writeln!(o, "## `{preset}`\n");
        let _ = writeln!(
            o,
            "| condition | variant | CC | MS | OPDF | CC − always | MS − always | OPDF − always | wrong flips | alarms |"
        );
        let _ = writeln!(o, "|---|---|---|---|---|---|---|---|---|---|");
        for (cond, by_var) in by_cond {
            for v in VARIANTS {
                let Some(c) = by_var.get(v) else { continue };
                let _ = writeln!(
                    o,
                    "| {cond} | {v} | {:.2} | {:.2} | {:.2} | {} | {} | {} | {:.0} | {:.1} |",
                    c.cc,
                    c.ms,
                    c.opdf,
                    diff(c.vs_always_update.get("cc")),
                    diff(c.vs_always_update.get("ms")),
                    diff(c.vs_always_update.get("opdf")),
                    c.wrong_flips,
                    c.alarms
                );
            }
        }
        let _ = writeln!(o);
    }
    let _ = writeln!(o, "Figure: `cc_by_hold.png` (CC of M_2/G_2 per condition and variant, first preset).");
    o.push_str(&crate::results::claims::claims_md(&crate::results::claims::table1_claims(s)));
    o
}

/// Writes the folder's files into `dir`.
pub fn write_table1_hold(dir: &StagedDir, r: &Table1HoldResults) -> Result<(), ResultsError> {
    let json = serde_json::to_string_pretty(&r.summary)
        .map_err(|e| ResultsError::Serialise { what: "summary.json".into(), message: e.to_string() })?;
    dir.write("summary.json", format!("{json}\n").as_bytes())?;
    dir.write("runs.csv", runs_csv(r).as_bytes())?;
    dir.write("report.md", report_md(r).as_bytes())?;
    let conds = r.summary.params.conditions();
    let mut chart = BarChart::new("Table 1 with a held error: CC of M_2 / G_2", "CC (%)", conds.clone());
    for (preset, by_cond) in &r.summary.table1 {
        for v in VARIANTS {
            let vals = conds.iter().map(|c| by_cond.get(c).and_then(|m| m.get(v)).map_or(0.0, |x| x.cc)).collect();
            chart = chart.with_group(format!("{preset} {v}"), vals);
        }
    }
    chart.write_svg(&dir.file("cc_by_hold.svg")?)?;
    chart.write_png(&dir.file("cc_by_hold.png")?, PNG_SIZE_PX.0, PNG_SIZE_PX.1)?;
    Ok(())
}
