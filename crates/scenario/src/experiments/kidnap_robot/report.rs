//! The files of an `experiment kidnap-robot` folder: `summary.json`, `trials.csv`, `report.md`
//! (`docs/recovery.md`, "Real kidnaps").

use crate::experiments::kidnap_robot::{KidnapRobotResults, KidnapRobotSummary};
use crate::results::ResultsError;
use mapkeeper_grid::StagedDir;
use std::fmt::Write as _;

/// The columns of `trials.csv`, in order.
pub const TRIALS_CSV_COLUMNS: &[&str] = &[
    "trial",
    "map",
    "world",
    "tour_position_m",
    "kidnap_s",
    "displacement_m",
    "direction_deg",
    "yaw_deg",
    "applied",
    "applied_displacement_m",
    "detected",
    "detection_delay_s",
    "recovered_pose_updating",
    "recovered_filter",
    "recovered_global_search",
    "recovery_s",
    "pose_found_s",
    "reference_final_error_m",
    "reference_held",
    "handovers_right",
    "handovers_held",
    "refused_attempts",
    "ambiguous_attempts",
    "pose_recoveries",
    "wrong_pose_recoveries",
    "final_error_m",
    "reference_lost",
    "reference_lost_right_pose",
    "reference_lost_well_localised",
    "reference_steps",
    "reference_steps_well_localised",
    "reference_cc",
    "reference_ms",
    "reference_opdf",
    "kidnap_cc",
    "kidnap_ms",
    "kidnap_opdf",
];

fn opt(v: Option<f64>) -> String {
    v.map_or_else(String::new, |x| format!("{x:.3}"))
}

/// `trials.csv`.
pub fn trials_csv(r: &KidnapRobotResults) -> String {
    let mut s = TRIALS_CSV_COLUMNS.join(",");
    s.push('\n');
    for t in &r.trials {
        let d = &t.draw;
        let _ = writeln!(
            s,
            "{},{},{},{:.3},{:.3},{:.3},{:.2},{:.2},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4}",
            d.trial,
            t.map.name(),
            d.world,
            d.tour_position_m,
            d.kidnap_s,
            d.displacement_m,
            d.direction_rad.to_degrees(),
            d.yaw_rad.to_degrees(),
            t.applied,
            opt(t.applied_displacement_m),
            t.detected,
            opt(t.detection_delay_s),
            t.recovered_pose_updating,
            t.recovered_filter,
            t.recovered_global_search,
            opt(t.recovery_s),
            opt(t.pose_found_s),
            opt(t.reference_final_error_m),
            t.reference_held.map_or_else(String::new, |b| b.to_string()),
            t.handovers_right,
            t.handovers_held,
            t.refused_attempts,
            t.ambiguous_attempts,
            t.pose_recoveries,
            t.wrong_pose_recoveries,
            opt(t.final_error_m),
            t.reference_lost,
            t.reference_lost_right_pose,
            t.reference_lost_well_localised,
            t.reference_steps,
            t.reference_steps_well_localised,
            t.reference_scores.cc,
            t.reference_scores.ms,
            t.reference_scores.opdf,
            t.kidnap_scores.cc,
            t.kidnap_scores.ms,
            t.kidnap_scores.opdf
        );
    }
    s
}

/// `report.md`: the maps side by side, then each map's table, its bins and its claims.
pub fn report_md(r: &KidnapRobotResults) -> String {
    let k = &r.kidnap_robot;
    let p = &r.params;
    let mut o = String::new();
    let _ = writeln!(o, "# Real kidnaps: the robot moved, odometry blind\n");
    let maps: Vec<&str> = p.maps.iter().map(|m| m.label()).collect();
    let _ = writeln!(
        o,
        "World `{}`, seed {}, preset `{}`, localiser `{}`, {} trials in W_{}-W_{}, each on {} (W_1's map: {}); the \
         robot is moved {:.1}-{:.1} m and up to ±{:.0}° at {:.0}-{:.0} s into a drive; recovered = the localiser's error \
         under {:.2} m and {:.1}° from some time within {:.0} s of the kidnap to the end. Wall time {:.1} s.\n",
        r.world,
        r.seed,
        k.preset,
        r.recovery.runner.localiser,
        k.trials,
        p.min_world,
        p.max_world,
        maps.join(", "),
        r.recovery.initial_map.name(),
        p.min_displacement_m,
        p.max_displacement_m,
        p.max_yaw_rad.to_degrees(),
        p.kidnap_min_s,
        p.kidnap_max_s,
        r.recovery.success.max_error_m,
        r.recovery.success.max_yaw_error_rad.to_degrees(),
        p.recovery_window_s,
        r.wall_time_s
    );
    side_by_side(&mut o, r);
    for s in &r.by_map {
        let _ = writeln!(o, "\n## On {}\n", s.map.label());
        map_section(&mut o, r, s);
    }
    o
}

fn pc(v: f64) -> String {
    format!("{:.1} %", 100.0 * v)
}

fn secs(v: Option<f64>) -> String {
    v.map_or_else(|| "–".into(), |v| format!("{v:.2} s"))
}

/// A row of the side-by-side table: its label and its value on one map.
type Row = (&'static str, fn(&KidnapRobotSummary) -> String);

/// The headline figures, one column per map.
fn side_by_side(o: &mut String, r: &KidnapRobotResults) {
    let rows: [Row; 10] = [
        ("recovered (pose updating + filter)", |s| pc(s.recovered_rate_pose_updating + s.recovered_rate_filter)),
        ("a right pose handed over within 5 s of stopping", |s| pc(s.pose_found_5s_rate)),
        ("right handovers held to the end", |s| {
            s.handover_held_rate.map_or_else(|| "–".into(), |v| format!("{} of {}", pc(v), s.handovers_right))
        }),
        ("runs without kidnap right at every tick from the kidnap's time to the end (the localiser alone)", |s| {
            pc(s.reference_held_rate)
        }),
        ("time to hand over, median / p90", |s| {
            format!("{} / {}", secs(s.median_pose_found_s), secs(s.p90_pose_found_s))
        }),
        ("time to recover, median / p90", |s| format!("{} / {}", secs(s.median_recovery_s), secs(s.p90_recovery_s))),
        ("trials with a wrong pose", |s| pc(s.wrong_recovery_rate)),
        ("runs without kidnap with a Lost: any / right / well localised", |s| {
            format!(
                "{} / {} / {}",
                pc(s.false_lost_rate),
                pc(s.false_lost_right_pose_rate),
                pc(s.false_lost_well_localised_rate)
            )
        }),
        ("map damage CC / MS / OPDF (points)", |s| {
            format!("{:.2} / {:.2} / {:.2}", s.map_damage.cc, s.map_damage.ms, s.map_damage.opdf)
        }),
        ("reference runs ending ≥ 0.2 m off", |s| pc(s.reference_off_rate)),
    ];
    let _ = write!(o, "| |");
    for s in &r.by_map {
        let _ = write!(o, " {} |", s.map.label());
    }
    let _ = writeln!(o, "\n|---|{}", "---|".repeat(r.by_map.len()));
    for (label, f) in rows {
        let _ = write!(o, "| {label} |");
        for s in &r.by_map {
            let _ = write!(o, " {} |", f(s));
        }
        o.push('\n');
    }
}

/// One map's table, bins and claims.
fn map_section(o: &mut String, r: &KidnapRobotResults, k: &KidnapRobotSummary) {
    let _ = writeln!(o, "| | |\n|---|---|");
    let _ = writeln!(o, "| trials moved (a free target found) | {} of {} |", k.applied, k.trials);
    let _ = writeln!(o, "| said Lost after the kidnap | {} |", pc(k.detected_rate));
    let _ = writeln!(o, "| recovered by pose updating | {} |", pc(k.recovered_rate_pose_updating));
    let _ = writeln!(o, "| …of which with a pose from the global search | {} |", pc(k.recovered_rate_global_search));
    let _ = writeln!(o, "| recovered by the filter alone | {} |", pc(k.recovered_rate_filter));
    let _ = writeln!(o, "| not recovered | {} |", pc(k.failed_rate));
    let _ = writeln!(o, "| trials with a wrong pose from pose updating | {} |", pc(k.wrong_recovery_rate));
    let _ = writeln!(
        o,
        "| a right pose from pose updating, at all / within 5 s of stopping | {} / {} |",
        pc(k.pose_found_rate),
        pc(k.pose_found_5s_rate)
    );
    let _ = writeln!(
        o,
        "| never a right pose: trials / of them with an ambiguous attempt (the rest fitted no place) | {} / {} |",
        k.never_found, k.never_found_ambiguous
    );
    let _ = writeln!(
        o,
        "| right handovers / held to the end | {} / {} |",
        k.handovers_right,
        k.handover_held_rate.map_or_else(|| "–".into(), pc)
    );
    let _ =
        writeln!(o, "| time to recover, median / p90 | {} / {} |", secs(k.median_recovery_s), secs(k.p90_recovery_s));
    let _ = writeln!(
        o,
        "| time to hand over (stopping to the first right pose), median / p90 | {} / {} |",
        secs(k.median_pose_found_s),
        secs(k.p90_pose_found_s)
    );
    let _ = writeln!(o, "| reference runs ending ≥ 0.2 m off (no kidnap) | {} |", pc(k.reference_off_rate));
    let _ = writeln!(
        o,
        "| recovered where the reference run ends < 0.2 m off | {} of {} |",
        pc(k.recovered_rate_reference_held),
        k.trials_reference_held
    );
    false_lost_row(o, r, k);
    let _ = writeln!(
        o,
        "| map damage CC / MS / OPDF (points, mean) | {:.2} / {:.2} / {:.2} (OPDF max {:.2}) |",
        k.map_damage.cc, k.map_damage.ms, k.map_damage.opdf, k.map_damage_opdf_max
    );
    let _ = writeln!(o, "| poses from pose updating / wrong | {} / {} |", k.pose_recoveries, k.wrong_pose_recoveries);
    let _ = writeln!(
        o,
        "\n| trials moved | recovered | wrong pose | not recovered | right pose within 5 s | right handovers held |\n\
         |---|---|---|---|---|---|"
    );
    for b in k.by_turn.iter().chain(&k.by_displacement).chain(&k.by_world) {
        let _ = writeln!(
            o,
            "| {} ({}) | {} | {} | {} | {} | {} of {} |",
            b.label,
            b.trials,
            b.recovered,
            b.wrong,
            b.trials.saturating_sub(b.recovered),
            b.handed_over_5s,
            b.handovers_held,
            b.handovers_right
        );
    }
    o.push('\n');
    o.push_str(&crate::results::claims::claims_md(&crate::results::claims::kidnap_claims(k)));
}

/// The row of the runs without kidnap that said Lost, split by how far off the localiser was.
fn false_lost_row(o: &mut String, r: &KidnapRobotResults, k: &KidnapRobotSummary) {
    let _ = writeln!(
        o,
        "| runs without kidnap with a Lost: any / while the localiser was right (< {:.2} m, < {:.0}°) / while it was \
         well localised (≤ {:.2} m, ≤ {:.0}°: false Lost) | {} / {} / {} |",
        r.recovery.success.max_error_m,
        r.recovery.success.max_yaw_error_rad.to_degrees(),
        r.params.well_localised_max_error_m,
        r.params.well_localised_max_yaw_rad.to_degrees(),
        pc(k.false_lost_rate),
        pc(k.false_lost_right_pose_rate),
        pc(k.false_lost_well_localised_rate)
    );
    let opt_pc = |v: Option<f64>| v.map_or_else(|| "–".into(), |v| format!("{:.2} %", 100.0 * v));
    let _ = writeln!(
        o,
        "| checked steps without kidnap: well localised / of these said Lost (per-step false Lost) | {} / {} |",
        opt_pc(k.reference_well_localised_share),
        opt_pc(k.false_lost_well_localised_step_rate)
    );
}

/// Writes the folder's files into `dir`.
pub fn write_kidnap_robot(dir: &StagedDir, r: &KidnapRobotResults) -> Result<(), ResultsError> {
    let json = serde_json::to_string_pretty(r)
        .map_err(|e| ResultsError::Serialise { what: "summary.json".into(), message: e.to_string() })?;
    dir.write("summary.json", format!("{json}\n").as_bytes())?;
    dir.write("trials.csv", trials_csv(r).as_bytes())?;
    dir.write("report.md", report_md(r).as_bytes())?;
    Ok(())
}
