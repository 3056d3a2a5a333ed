//! The files of a `recover` folder: `summary.json`, `kidnap_trials.csv`, `table1.csv`,
//! `lost_robot.csv`, `demo_timeline.csv` and `report.md` (`docs/recovery.md`).

use crate::experiments::recovery::{KidnapSummary, KidnapTrial, LostRun, RecoveryResults, RecoverySummary, Table1Run};
use crate::results::ResultsError;
use mapkeeper_closed_loop::controls::TimelineSample;
use mapkeeper_grid::StagedDir;
use std::fmt::Write as _;

/// The columns of `kidnap_trials.csv`, in order.
pub const KIDNAP_CSV_COLUMNS: &[&str] = &[
    "case",
    "trial",
    "world",
    "tour_position_m",
    "kidnap_s",
    "displacement_m",
    "direction_deg",
    "yaw_deg",
    "applied",
    "lost_before",
    "detected",
    "detection_delay_s",
    "recovered",
    "recovery_s",
    "pose_recoveries",
    "wrong_pose_recoveries",
    "failed_pose_recoveries",
    "final_error_m",
    "final_yaw_error_deg",
    "reference_lost",
    "reference_final_error_m",
    "opdf_kidnap",
    "opdf_reference",
    "map_damage_opdf",
    "opdf_vs_reference",
    "cells_differing",
];

fn opt(v: Option<f64>) -> String {
    v.map_or_else(String::new, |x| format!("{x:.3}"))
}

fn kidnap_row(t: &KidnapTrial) -> String {
    let d = &t.draw;
    [
        t.case.name().to_string(),
        t.trial.to_string(),
        d.world.to_string(),
        format!("{:.3}", d.tour_position_m),
        format!("{:.3}", d.kidnap_s),
        format!("{:.4}", d.displacement_m),
        format!("{:.2}", d.direction_rad.to_degrees()),
        format!("{:.2}", d.yaw_rad.to_degrees()),
        t.applied.to_string(),
        t.lost_before.to_string(),
        t.detected.to_string(),
        opt(t.detection_delay_s),
        t.recovered.to_string(),
        opt(t.recovery_s),
        t.recoveries.to_string(),
        t.wrong_recoveries.to_string(),
        t.failed_recoveries.to_string(),
        opt(t.final_error_m),
        opt(t.final_yaw_error_rad.map(f64::to_degrees)),
        t.reference_lost.to_string(),
        opt(t.reference_final_error_m),
        format!("{:.4}", t.opdf_kidnap),
        format!("{:.4}", t.opdf_reference),
        format!("{:.4}", t.map_damage_opdf),
        format!("{:.4}", t.opdf_vs_reference),
        t.cells_differing.to_string(),
    ]
    .join(",")
}

/// `kidnap_trials.csv`: one row per trial and map case.
pub fn kidnap_csv(trials: &[KidnapTrial]) -> String {
    let mut s = KIDNAP_CSV_COLUMNS.join(",");
    s.push('\n');
    for t in trials {
        s.push_str(&kidnap_row(t));
        s.push('\n');
    }
    s
}

/// `table1.csv`: one row per run.
pub fn table1_csv(runs: &[Table1Run]) -> String {
    let mut s = String::from(
        "run,direction_deg,cc_always_update,ms_always_update,opdf_always_update,cc_check,ms_check,opdf_check,\
         check_update,check_suspend,check_lost,cells_changed_always_update,cells_changed_check\n",
    );
    for r in runs {
        let _ = writeln!(
            s,
            "{},{:.2},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{},{},{},{},{}",
            r.run,
            r.direction_rad.to_degrees(),
            r.always_update.cc,
            r.always_update.ms,
            r.always_update.opdf,
            r.check.cc,
            r.check.ms,
            r.check.opdf,
            r.check_verdicts.update,
            r.check_verdicts.suspend,
            r.check_verdicts.lost,
            r.always_update_cells_changed,
            r.check_cells_changed
        );
    }
    s
}

/// `lost_robot.csv`: one row per run.
pub fn lost_csv(runs: &[LostRun]) -> String {
    let mut s = String::from(
        "run,direction_deg,detected,first_lost_s,pose_recoveries,failed_pose_recoveries,worst_recovery_error_m,\
         recovered_s,final_error_m,cc_with_error,ms_with_error,opdf_with_error,cc_without_error,ms_without_error,\
         opdf_without_error,cc_always_update,ms_always_update,opdf_always_update,opdf_vs_without_error,\
         cells_differing,not_corrupted\n",
    );
    for r in runs {
        let _ = writeln!(
            s,
            "{},{:.2},{},{},{},{},{},{},{},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{},{}",
            r.run,
            r.direction_rad.to_degrees(),
            r.detected,
            opt(r.first_lost_s),
            r.recoveries,
            r.failed_recoveries,
            opt(r.worst_recovery_error_m),
            opt(r.recovered_s),
            opt(r.final_error_m),
            r.with_error.cc,
            r.with_error.ms,
            r.with_error.opdf,
            r.without_error.cc,
            r.without_error.ms,
            r.without_error.opdf,
            r.always_update_with_error.cc,
            r.always_update_with_error.ms,
            r.always_update_with_error.opdf,
            r.opdf_vs_without_error,
            r.cells_differing,
            r.not_corrupted
        );
    }
    s
}

/// `demo_timeline.csv`: one row per processed step of the demo.
pub fn timeline_csv(tl: &[TimelineSample]) -> String {
    let mut s = String::from("t_s,verdict,n_valid,n_dc,error_m,yaw_error_deg,pose_recovered\n");
    for x in tl {
        let _ = writeln!(
            s,
            "{:.3},{},{},{},{:.4},{:.3},{}",
            x.t_s,
            x.verdict.name(),
            x.n_valid,
            x.n_dc,
            x.error_m,
            x.yaw_error_rad.to_degrees(),
            x.recovered.map_or_else(String::new, |b| b.to_string())
        );
    }
    s
}

/// `summary.json` text.
pub fn summary_json(summary: &RecoverySummary) -> Result<String, ResultsError> {
    serde_json::to_string_pretty(summary)
        .map(|mut s| {
            s.push('\n');
            s
        })
        .map_err(|e| ResultsError::Serialise { what: "summary.json".into(), message: e.to_string() })
}

fn opt_s(v: Option<f64>) -> String {
    v.map_or_else(|| "—".to_string(), |x| format!("{x:.1} s"))
}

fn pct(v: f64) -> String {
    format!("{:.1} %", 100.0 * v)
}

fn kidnap_section(s: &mut String, k: &KidnapSummary, title: &str) {
    let _ = writeln!(s, "### {title}\n");
    let _ = writeln!(s, "| figure | value |");
    let _ = writeln!(s, "|---|---|");
    for (name, v) in [
        ("trials", k.trials.to_string()),
        ("detected (Lost after the kidnap)", pct(k.detected_rate)),
        ("recovered (< criterion within the window, held)", pct(k.recovered_rate)),
        (
            "recovered, displacement ≤ 1.5 m",
            format!("{} of {} trials", pct(k.recovered_rate_le_1_5m), k.trials_le_1_5m),
        ),
        ("false Lost (runs without kidnap)", pct(k.false_lost_rate)),
        ("median / p90 time to recover", format!("{} / {}", opt_s(k.median_recovery_s), opt_s(k.p90_recovery_s))),
        ("map damage: OPDF drop vs the run without kidnap (mean / max)", {
            format!("{:.3} / {:.3} points", k.map_damage_opdf, k.map_damage_opdf_max)
        }),
        ("trials with a damage above 1 point", k.damaged_trials.to_string()),
        ("OPDF between the maps with and without kidnap (mean)", format!("{:.2} %", k.opdf_vs_reference)),
        (
            "poses returned by pose updating / wrong ones accepted",
            format!("{} / {}", k.pose_recoveries, k.wrong_pose_recoveries),
        ),
    ] {
        let _ = writeln!(s, "| {name} | {v} |");
    }
    let _ = writeln!(s, "\n| displacement (m) | trials | detected | recovered | median time to recover |");
    let _ = writeln!(s, "|---|---|---|---|---|");
    for b in &k.by_bin {
        let _ = writeln!(
            s,
            "| {:.1}-{:.1} | {} | {} | {} | {} |",
            b.from_m,
            b.to_m,
            b.trials,
            pct(b.detected_rate),
            pct(b.recovered_rate),
            opt_s(b.median_recovery_s)
        );
    }
    s.push('\n');
}

/// `report.md`: the results beside the paper.
pub fn report_md(r: &RecoveryResults) -> String {
    let sm = &r.summary;
    let p = &sm.params;
    let mut s = String::new();
    let _ = writeln!(s, "# Robustness experiments and pose-recovery stress suite\n");
    let _ = writeln!(
        s,
        "Seed {}, {} kidnap trials per map case, localiser `{}`, wall time {:.1} s ({}). Definitions: \
         `docs/recovery.md`. Recovered = the chain localiser's error below {:.2} m and {:.1}° from some time on, held to the end of \
         the run ({:.1} s at least).\n",
        sm.seed,
        p.kidnap.trials,
        p.runner.localiser,
        sm.wall_time_s,
        sm.tool,
        p.success.max_error_m,
        p.success.max_yaw_error_rad.to_degrees(),
        p.success.hold_s
    );
    let d = &sm.demo;
    let _ = writeln!(s, "## Localisation-check demo (§5.3.1, Fig. 16)\n");
    let _ = writeln!(
        s,
        "W_{} on M_1, estimate {:.2} m to the right of the true start, {:.0} s. Verdicts: Update {}, Suspend {}, \
         Lost {}. First Suspend {}, first Lost {}, first Update {} (localiser error then {}); Update share after \
         the first Update {:.1} %; final error {}. **Suspended, then updated: {}** (paper: suspended until \
         the localiser converged after ~20 s, then updated).\n",
        d.world,
        d.start_error_m,
        d.duration_s,
        d.verdicts.update,
        d.verdicts.suspend,
        d.verdicts.lost,
        opt_s(d.first_suspend_s),
        opt_s(d.first_lost_s),
        opt_s(d.first_update_s),
        d.error_at_first_update_m.map_or_else(|| "—".into(), |e| format!("{e:.3} m")),
        100.0 * d.update_share_after_first_update,
        d.final_error_m.map_or_else(|| "—".into(), |e| format!("{e:.3} m")),
        if d.suspended_then_updated { "yes" } else { "no" }
    );
    let _ = writeln!(s, "| verdict | from | to | steps |");
    let _ = writeln!(s, "|---|---|---|---|");
    for seg in d.segments.iter().take(12) {
        let _ = writeln!(s, "| {} | {:.2} s | {:.2} s | {} |", seg.verdict.name(), seg.from_s, seg.to_s, seg.steps);
    }
    if d.segments.len() > 12 {
        let _ = writeln!(s, "| … {} more segments (`demo_timeline.csv`) | | | |", d.segments.len() - 12);
    }
    table1_section(&mut s, sm);
    lost_and_kidnap_sections(&mut s, sm);
    s
}

fn table1_section(s: &mut String, sm: &RecoverySummary) {
    let t = &sm.table1;
    let _ = writeln!(s, "\n## Table 1 analog (§5.3.1, Fig. 17-20)\n");
    let _ = writeln!(
        s,
        "W_{} on M_1, start error {:.2} m in {} seeded directions, maps M_2 against G_2 (means; runs in \
         `table1.csv`). M_1/G_2: CC {:.2}, MS {:.2}, OPDF {:.2}.\n",
        t.world, t.start_error_m, t.runs, t.static_map.cc, t.static_map.ms, t.static_map.opdf
    );
    let _ =
        writeln!(s, "| metric | always-update | with the check | runs where the check is better | paper (old → new) |");
    let _ = writeln!(s, "|---|---|---|---|---|");
    for (name, a, c, f, pa, pc) in [
        (
            "CC (%)",
            t.always_update.cc,
            t.check.cc,
            t.check_better_fraction.cc,
            t.paper_always_update.cc,
            t.paper_check.cc,
        ),
        (
            "MS (%)",
            t.always_update.ms,
            t.check.ms,
            t.check_better_fraction.ms,
            t.paper_always_update.ms,
            t.paper_check.ms,
        ),
        (
            "OPDF (%)",
            t.always_update.opdf,
            t.check.opdf,
            t.check_better_fraction.opdf,
            t.paper_always_update.opdf,
            t.paper_check.opdf,
        ),
    ] {
        let _ = writeln!(s, "| {name} | {a:.2} | {c:.2} | {} | {pa:.2} → {pc:.2} |", pct(f));
    }
    let _ = writeln!(
        s,
        "\n**Direction of Table 1 reproduced (check better on CC, MS and OPDF): {}.**\n",
        if t.direction_reproduced { "yes" } else { "no" }
    );
}

fn lost_and_kidnap_sections(s: &mut String, sm: &RecoverySummary) {
    let p = &sm.params;
    let l = &sm.lost_robot;
    let _ = writeln!(s, "## Lost robot (§5.4, Fig. 28)\n");
    let _ = writeln!(
        s,
        "W_{} on M_1, start error {:.2} m in {} seeded directions. Lost detected in {}, recovered in {} ({} with a \
         pose from pose updating), median time to recover {}, wrong poses accepted {}. Mean OPDF between M_2 with \
         and without the error {:.2} %.\n",
        l.world,
        l.start_error_m,
        l.runs,
        l.detected,
        l.recovered,
        l.recovered_by_pose_updating,
        opt_s(l.median_recovery_s),
        l.wrong_recoveries,
        l.opdf_vs_without_error
    );
    let _ = writeln!(s, "| M_2/G_2 (means) | CC | MS | OPDF |");
    let _ = writeln!(s, "|---|---|---|---|");
    for (name, v) in [
        ("without error", &l.without_error),
        ("1.5 m error, with the check and pose updating", &l.with_error),
        ("1.5 m error, always-update", &l.always_update_with_error),
    ] {
        let _ = writeln!(s, "| {name} | {:.2} | {:.2} | {:.2} |", v.cc, v.ms, v.opdf);
    }
    let _ = writeln!(
        s,
        "\n**Map not corrupted (every run within {:.1} points of the run without error on CC, MS, OPDF): {}.**\n",
        p.lost.corruption_tolerance_pct,
        if l.not_corrupted { "yes" } else { "no" }
    );
    let _ = writeln!(s, "## Kidnap stress suite (§5.4.1, Fig. 29-30)\n");
    let k = &p.kidnap;
    let _ = writeln!(
        s,
        "Each trial starts at a random point of the default tour in W_k (k in 2..={}), drives for {:.0}-{:.0} s, \
         then the chain localiser's estimate is displaced by {:.1}-{:.1} m and up to ±{:.0}° (cloud σ {:.2} m / \
         {:.1}°); the robot keeps driving; the run ends {:.0} s + {:.0} s later. Map damage compares the final \
         map with the same run without the kidnap (OPDF against G_k).\n",
        k.stale_max_world,
        k.kidnap_min_s,
        k.kidnap_max_s,
        k.min_displacement_m,
        k.max_displacement_m,
        k.max_yaw_rad.to_degrees(),
        k.sigma_xy_m,
        k.sigma_yaw_rad.to_degrees(),
        k.recovery_window_s,
        p.success.hold_s
    );
    kidnap_section(s, &sm.kidnap, "Stale map (M_1 in W_k, Fig. 30)");
    if let Some(b) = &sm.kidnap_best_case {
        kidnap_section(s, b, "Best case (map = G_k of the current world, Fig. 29)");
    }
    let _ = writeln!(
        s,
        "The paper shows one kidnap per case (Fig. 29, Fig. 30), recovered, with the map not corrupted; it gives \
         no rates."
    );
}

/// Writes the whole `recover` folder into `dir`.
pub fn write_recovery(dir: &StagedDir, r: &RecoveryResults) -> Result<(), ResultsError> {
    dir.write("summary.json", summary_json(&r.summary)?.as_bytes())?;
    dir.write("kidnap_trials.csv", kidnap_csv(&r.trials).as_bytes())?;
    dir.write("table1.csv", table1_csv(&r.table1_runs).as_bytes())?;
    dir.write("lost_robot.csv", lost_csv(&r.lost_runs).as_bytes())?;
    dir.write("demo_timeline.csv", timeline_csv(&r.demo_timeline).as_bytes())?;
    dir.write("report.md", report_md(r).as_bytes())?;
    Ok(())
}
