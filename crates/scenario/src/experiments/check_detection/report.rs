//! The files of a `experiment check-detection` folder: `summary.json`, `trials.csv`,
//! `report.md` and the figure `detection_by_error.{svg,png}` (`docs/recovery.md`, "Check
//! detection").

use crate::experiments::check_detection::{CheckDetectionResults, DetectionTrial, PresetDetection, Rate};
use crate::results::PNG_SIZE_PX;
use crate::results::ResultsError;
use mapkeeper_grid::StagedDir;
use mapkeeper_plot::BarChart;
use std::fmt::Write as _;

/// One table row of a preset: the bin, the detection and the false-alarm cells.
type Row = (String, String, String);

/// The columns of `trials.csv`, in order.
pub const TRIALS_CSV_COLUMNS: &[&str] = &[
    "preset",
    "trial",
    "world",
    "tour_position_m",
    "error_m",
    "direction_rel_deg",
    "yaw_error_deg",
    "onset_s",
    "latency_s",
    "first_alarm",
    "detected",
    "clean_steps",
    "clean_alarms",
    "bad_steps",
    "bad_alarms",
    "steps_after_onset",
];

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(String::new, |x| format!("{x:.digits$}"))
}

/// `trials.csv`.
pub fn trials_csv(trials: &[DetectionTrial]) -> String {
    let mut s = TRIALS_CSV_COLUMNS.join(",");
    s.push('\n');
    for t in trials {
        let d = &t.draw;
        let _ = writeln!(
            s,
            "{},{},{},{:.3},{:.4},{:.2},{:.3},{},{},{},{},{},{},{},{},{}",
            t.preset,
            d.trial,
            d.world,
            d.tour_position_m,
            d.error_m,
            d.direction_rel_rad.to_degrees(),
            d.yaw_error_rad.to_degrees(),
            opt(t.onset_s, 3),
            opt(t.latency_s, 3),
            t.first_alarm.map_or("", |v| v.name()),
            t.detected,
            t.clean_steps,
            t.clean_alarms,
            t.bad_steps,
            t.bad_alarms,
            t.steps_after_onset
        );
    }
    s
}

fn pct(r: &Rate) -> String {
    if r.of == 0 {
        return "–".into();
    }
    format!("{:.1} % [{:.1}, {:.1}] ({}/{})", 100.0 * r.rate, 100.0 * r.ci95[0], 100.0 * r.ci95[1], r.hits, r.of)
}

/// `report.md`.
pub fn report_md(r: &CheckDetectionResults) -> String {
    let s = &r.summary;
    let p = &s.params;
    let mut o = String::new();
    let _ = writeln!(o, "# How well the localisation check sees a bad pose\n");
    let _ = writeln!(
        o,
        "Seed {}, {} trials per preset, worlds W_2-W_{} on the stale map of W_1 ({:?}), localiser `{}`; \
         the pose the updater is given is held wrong from {:.1} s to the end ({:.1} s later) by 0-{:.2} m in any \
         direction and 0-±{:.0}°, {:.0} % of the trials with no error. Detected: Suspend or Lost within {:.1} s of \
         the onset, for injected errors ≥ {:.2} m; false alarm: Suspend or Lost on a step whose true error is ≤ \
         {:.2} m and ≤ {:.1}°. Rates with Wilson 95 % intervals. Wall time {:.1} s. Definitions: docs/recovery.md.\n",
        s.seed,
        s.trials,
        p.max_world,
        s.recovery.initial_map,
        s.recovery.runner.localiser,
        p.warmup_s,
        p.window_s,
        p.max_error_m,
        p.max_yaw_rad.to_degrees(),
        100.0 * p.zero_error_share,
        p.detect_within_s,
        p.detect_min_error_m,
        p.clean_max_error_m,
        p.clean_max_yaw_rad.to_degrees(),
        s.wall_time_s
    );
    let _ = writeln!(
        o,
        "| preset | detection | false alarms (steps) | zero-error trials with an alarm | per-step detection | along heading | across heading | median latency |"
    );
    let _ = writeln!(o, "|---|---|---|---|---|---|---|---|");
    for (name, d) in &s.check_detection {
        let _ = writeln!(
            o,
            "| {name} | {} | {} | {} | {} | {} | {} | {} |",
            pct(&d.detection),
            pct(&d.false_alarms),
            pct(&d.false_alarm_trials),
            pct(&d.per_step_detection),
            pct(&d.along_heading),
            pct(&d.across_heading),
            d.median_latency_s.map_or_else(|| "–".into(), |v| format!("{v:.2} s"))
        );
    }
    let table = |o: &mut String, title: &str, rows: &dyn Fn(&PresetDetection) -> Vec<Row>| {
        let _ = writeln!(o, "\n## {title}\n");
        let _ = write!(o, "| bin |");
        for name in s.check_detection.keys() {
            let _ = write!(o, " {name}: detected | {name}: false alarms |");
        }
        let _ = writeln!(o);
        let _ = writeln!(o, "|---|{}", "---|---|".repeat(s.check_detection.len()));
        let cols: Vec<Vec<Row>> = s.check_detection.values().map(rows).collect();
        let n = cols.first().map_or(0, Vec::len);
        for i in 0..n {
            let _ = write!(o, "| {} |", cols[0][i].0);
            for c in &cols {
                let _ = write!(o, " {} | {} |", c[i].1, c[i].2);
            }
            let _ = writeln!(o);
        }
    };
    table(&mut o, "By injected error (any alarm within the window)", &|d| {
        d.by_error.iter().map(|b| (b.bin.clone(), pct(&b.detected), pct(&b.false_alarms))).collect()
    });
    table(&mut o, "By world (errors ≥ the detection threshold)", &|d| {
        d.by_world.iter().map(|b| (b.bin.clone(), pct(&b.detected), pct(&b.false_alarms))).collect()
    });
    let _ = writeln!(
        o,
        "\nFigure: `detection_by_error.png` (share of trials with an alarm within the window, by injected error)."
    );
    o.push_str(&crate::results::claims::claims_md(&crate::results::claims::check_detection_claims(s)));
    o
}

/// Writes the folder's files into `dir`.
pub fn write_check_detection(dir: &StagedDir, r: &CheckDetectionResults) -> Result<(), ResultsError> {
    let json = serde_json::to_string_pretty(&r.summary)
        .map_err(|e| ResultsError::Serialise { what: "summary.json".into(), message: e.to_string() })?;
    dir.write("summary.json", format!("{json}\n").as_bytes())?;
    dir.write("trials.csv", trials_csv(&r.trials).as_bytes())?;
    dir.write("report.md", report_md(r).as_bytes())?;
    let cats: Vec<String> = r
        .summary
        .check_detection
        .values()
        .next()
        .map(|d| d.by_error.iter().map(|b| b.bin.clone()).collect())
        .unwrap_or_default();
    let mut chart = BarChart::new(
        "Localisation check: alarms within the window, by injected pose error",
        "trials with Suspend or Lost (%)",
        cats,
    )
    .with_y_range(0.0, 100.0);
    for (name, d) in &r.summary.check_detection {
        chart = chart.with_group(name.clone(), d.by_error.iter().map(|b| 100.0 * b.detected.rate).collect());
    }
    chart.write_svg(&dir.file("detection_by_error.svg")?)?;
    chart.write_png(&dir.file("detection_by_error.png")?, PNG_SIZE_PX.0, PNG_SIZE_PX.1)?;
    Ok(())
}
