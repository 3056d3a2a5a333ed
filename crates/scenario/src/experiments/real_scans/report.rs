//! The files of an `experiment real-scans` folder: `summary.json`, `report.md`, `report.html`
//! (the report with a stepper through the passes of each log), and per log `<log>/G.yaml` (the
//! map at the reference poses), `<log>/M_1.yaml` (the first edit seed's stale map),
//! `<log>/ms_<poses>.png` (MS of M_k against G per pass, every preset) and
//! `<log>/errors/<preset>_<poses>_W<kk>.png` (the errors of M_k against G, first edit seed, for
//! the stepper's preset; `docs/real-data.md`).

use super::chain::PoseSourceConfig;
use super::summary::{ChainSummary, TARGET_GAIN_RATIO, TARGET_RESTORED, TARGET_RETENTION};
use super::{LogResult, RealScansParams};
use crate::results::html::{Frame, SteppersIntro, WorldStepper, write_report_html};
use crate::results::{PNG_SIZE_PX, ResultsError};
use crate::stats::{PairedDiff, with_ci};
use mapkeeper_grid::map_io::save_map;
use mapkeeper_grid::render::render_errors;
use mapkeeper_grid::{OccupancyGrid, StagedDir};
use mapkeeper_plot::{LineChart, Series};
use serde::Serialize;
use std::fmt::Write as _;

/// The steppers' heading and what their images show.
const PASSES: SteppersIntro = SteppersIntro {
    heading: "The passes, step by step",
    text: "The errors of each pass's map M_k against G, the map at the reference poses, for the first edit seed: red \
wrongly free, orange wrongly occupied, blue missing; black, white and grey are right. W_1 is the stale map M_1. Slider, \
buttons or the arrow keys step through the passes.",
};

/// `summary.json`.
#[derive(Serialize)]
struct Summary<'a> {
    experiment: &'static str,
    worlds: usize,
    edit_seeds: &'a [u64],
    presets: &'a [String],
    pose_sources: Vec<&'a str>,
    edits: &'a super::edits::EditParams,
    mapper: &'a mapkeeper_harness::jobs::map::MapLogParams,
    targets: Targets,
    logs: &'a [LogResult],
    wall_time_s: f64,
}

#[derive(Serialize)]
struct Targets {
    retention_percent: f64,
    restored_percent: f64,
    gain_ratio: f64,
}

/// The preset whose passes the report steps through: `mapkeeper` if it ran, else the first.
pub fn stepper_preset(params: &RealScansParams) -> &str {
    params.presets.iter().find(|p| *p == "mapkeeper").unwrap_or(&params.presets[0])
}

fn file_name(s: &str) -> String {
    s.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' }).collect()
}

fn serialise_error(what: &str, e: impl std::fmt::Display) -> ResultsError {
    ResultsError::Serialise { what: what.into(), message: e.to_string() }
}

/// Writes the folder's files into `dir`.
pub fn write_real_scans(
    dir: &StagedDir,
    results: &[LogResult],
    params: &RealScansParams,
    wall_time_s: f64,
) -> Result<(), ResultsError> {
    let summary = Summary {
        experiment: "real-scans",
        worlds: params.worlds,
        edit_seeds: &params.edit_seeds,
        presets: &params.presets,
        pose_sources: params.pose_sources.iter().map(PoseSourceConfig::name).collect(),
        edits: &params.edits,
        mapper: &params.mapper,
        targets: Targets {
            retention_percent: TARGET_RETENTION,
            restored_percent: TARGET_RESTORED,
            gain_ratio: TARGET_GAIN_RATIO,
        },
        logs: results,
        wall_time_s,
    };
    let json = serde_json::to_string_pretty(&summary).map_err(|e| serialise_error("summary.json", e))?;
    dir.write("summary.json", format!("{json}\n").as_bytes())?;
    let mut steppers = Vec::new();
    for r in results {
        steppers.extend(write_log(dir, r, params)?);
    }
    let md = report_md(results, params, wall_time_s);
    dir.write("report.md", md.as_bytes())?;
    write_report_html(dir, "Real scans, known truth", &md, &steppers, PASSES)
}

/// One log's maps, figures and error images; its steppers.
fn write_log(dir: &StagedDir, r: &LogResult, params: &RealScansParams) -> Result<Vec<WorldStepper>, ResultsError> {
    let log = file_name(&r.name);
    let Some(truth) = &r.truth_map else { return Ok(Vec::new()) };
    save_map(truth, &dir.file(&format!("{log}/G.yaml"))?)?;
    let Some(m1) = &r.first_stale else { return Ok(Vec::new()) };
    save_map(m1, &dir.file(&format!("{log}/M_1.yaml"))?)?;
    for source in &params.pose_sources {
        let rows: Vec<&ChainSummary> = r.summaries.iter().filter(|s| s.poses == source.name()).collect();
        if rows.is_empty() {
            continue;
        }
        let mut chart =
            LineChart::new(format!("{}: MS of M_k against G ({})", r.name, source.name()), "world k", "MS (%)");
        chart.x_integer = true;
        for preset in &params.presets {
            let chains: Vec<_> = r.chains.iter().filter(|c| &c.preset == preset && c.poses == source.name()).collect();
            if chains.is_empty() {
                continue;
            }
            let mut points = vec![(1.0, crate::stats::mean(chains.iter().map(|c| c.m1.ms)))];
            for k in 2..=params.worlds {
                let v = crate::stats::mean(
                    chains.iter().filter_map(|c| c.per_pass.iter().find(|p| p.pass == k).map(|p| p.scores.ms)),
                );
                points.push((k as f64, v));
            }
            chart = chart.with_series(Series::new(preset.clone(), points));
        }
        let rel = format!("{log}/ms_{}.png", file_name(source.name()));
        chart.write_png(&dir.file(&rel)?, PNG_SIZE_PX.0, PNG_SIZE_PX.1)?;
    }
    let preset = stepper_preset(params);
    let mut steppers = Vec::new();
    for c in r.chains.iter().filter(|c| c.preset == preset && !c.maps.is_empty()) {
        let mut frames = Vec::new();
        let maps = std::iter::once(m1).chain(c.maps.iter());
        for (k, map) in (1..).zip(maps) {
            let rel = format!("{log}/errors/{}_{}_W{k:02}.png", file_name(&c.preset), file_name(&c.poses));
            write_errors(dir, &rel, map, truth)?;
            let s = if k == 1 { c.m1 } else { c.per_pass[k - 2].scores };
            let what = if k == 1 { "M_1, the stale map".to_string() } else { format!("M_{k}, pass {k}") };
            frames.push(Frame {
                world: k,
                caption: format!("{what} against G: CC {:.2}, MS {:.2}, OPDF {:.2}", s.cc, s.ms, s.opdf),
                image: rel,
            });
        }
        steppers.push(WorldStepper {
            id: format!("passes-{log}-{}-{}", file_name(&c.preset), file_name(&c.poses)),
            title: format!("{}, {}, poses: {} (edit seed {})", r.name, c.preset, c.poses, c.edit_seed),
            frames,
        });
    }
    Ok(steppers)
}

fn write_errors(dir: &StagedDir, rel: &str, map: &OccupancyGrid, truth: &OccupancyGrid) -> Result<(), ResultsError> {
    let image = render_errors(map, truth).map_err(|e| serialise_error(rel, e))?;
    image.write_png(&dir.file(rel)?).map_err(|e| serialise_error(rel, e))
}

fn yes_no(b: bool) -> &'static str {
    if b { "yes" } else { "**no**" }
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "–".into(), |v| format!("{v:.digits$}"))
}

fn diff(d: &PairedDiff) -> String {
    with_ci(d.mean, d.ci95, 2)
}

/// `report.md`.
pub fn report_md(results: &[LogResult], params: &RealScansParams, wall_time_s: f64) -> String {
    let mut s = String::new();
    let k = params.worlds;
    let _ = writeln!(
        s,
        "# Real scans, known truth\n\nEach log with reference poses: G = the map at the reference poses; a stale map M_1 \
made from G by seeded edits (structure M_1 lacks, boxes the place lacks, items moved: `added`, `removed`, `moved`); the log \
replayed as W_2 … W_{k}, each pass localising on M_(k-1) from the first reference pose and updating it into M_k. Every \
M_k is scored against G over the cells G observed (CC, MS, OPDF, percent); the oracle (G on those cells) scores 100. \
{} edit seeds ({}), presets {}, pose sources {}. Intervals: 95 % over the edit seeds, paired. Definitions and limits: \
`docs/real-data.md`, \"Real scans, known truth\". Wall time {wall_time_s:.1} s.\n",
        params.edit_seeds.len(),
        params.edit_seeds.iter().map(u64::to_string).collect::<Vec<_>>().join(", "),
        params.presets.join(", "),
        params.pose_sources.iter().map(PoseSourceConfig::name).collect::<Vec<_>>().join(", "),
    );
    logs_md(&mut s, results);
    targets_md(&mut s, results, k);
    for r in results {
        log_md(&mut s, r, params);
    }
    s
}

/// The logs and their stale maps.
fn logs_md(s: &mut String, results: &[LogResult]) {
    s.push_str("## The logs and their stale maps\n\n");
    s.push_str(
        "| log | scans | path (m) | G: observed / occupied cells | edits per seed | cells added / removed / moved, asked | made | floor behind |\n|---|---:|---:|---|---:|---|---|---:|\n",
    );
    for r in results {
        let n = r.stale.len().max(1) as f64;
        let mean3 = |f: &dyn Fn(&super::StaleSummary) -> (usize, usize, usize)| {
            let t = r.stale.iter().map(f).fold((0, 0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2));
            format!("{:.0} / {:.0} / {:.0}", t.0 as f64 / n, t.1 as f64 / n, t.2 as f64 / n)
        };
        let _ = writeln!(
            s,
            "| {} | {} | {:.0} | {} / {} | {:.1} | {} | {} | {:.0} |",
            r.name,
            r.scans,
            r.path_m,
            r.map_cells.1,
            r.map_cells.2,
            r.stale.iter().map(|x| x.edits as f64).sum::<f64>() / n,
            mean3(&|x| x.target_cells),
            mean3(&|x| x.made_cells),
            r.stale.iter().map(|x| x.floor_behind as f64).sum::<f64>() / n,
        );
    }
}

/// The targets' verdicts.
fn targets_md(s: &mut String, results: &[LogResult], k: usize) {
    s.push_str("\n## Targets\n\n");
    let _ = writeln!(
        s,
        "Per log, preset and pose source: pass {k} better than M_1 on CC, MS and OPDF with every interval above 0; the gain \
at least {:.0} % of the same preset's at the reference poses; no seed whose pass {k} is worse than its pass 3; retention \
≥ {TARGET_RETENTION} % in every seed; every class ≥ {TARGET_RESTORED} % restored.\n",
        100.0 * TARGET_GAIN_RATIO
    );
    s.push_str(
        "| log | preset | poses | better than M_1 | gain ≥ 90 % of the reference's | no decay | retention | every class restored |\n|---|---|---|---|---|---|---|---|\n",
    );
    for r in results {
        for c in &r.summaries {
            let v = c.verdicts;
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {} |",
                r.name,
                c.preset,
                c.poses,
                yes_no(v.better_than_m1),
                v.gain_as_reference.map_or("–", yes_no),
                yes_no(v.no_decay),
                yes_no(v.retention),
                yes_no(v.restored)
            );
        }
    }
}

/// One log's section: its scores, or what each pass changed when it has no reference.
fn log_md(s: &mut String, r: &LogResult, params: &RealScansParams) {
    let k = params.worlds;
    {
        let _ = writeln!(s, "\n## {}\n", r.name);
        if let Some(note) = &r.note {
            let _ = writeln!(s, "Note: {note}.\n");
            s.push_str("| preset | poses | pass | Update / Suspend / Lost | Lost episodes | → occupied | → free | other |\n|---|---|---:|---|---:|---:|---:|---:|\n");
            for u in &r.unscored {
                for p in &u.per_pass {
                    let _ = writeln!(
                        s,
                        "| {} | {} | {} | {} / {} / {} | {} | {} | {} | {} |",
                        u.preset,
                        u.poses,
                        p.pass,
                        p.verdicts.0,
                        p.verdicts.1,
                        p.verdicts.2,
                        p.lost_episodes,
                        p.to_occupied,
                        p.to_free,
                        p.other_changes
                    );
                }
            }
            return;
        }
        let _ = writeln!(
            s,
            "Means over the edit seeds (CC / MS / OPDF); gains are pass {k} − M_1 with their intervals; \"of reference\" is \
the gain over the same preset's at the reference poses; F_{k} is the pass's fresh map (at the reference poses it is G \
itself, by construction); restored: the share of each class's observed cells M_{k} has as G has them.\n"
        );
        s.push_str(&format!(
            "| preset | poses | M_1 | pass 2 | pass {k} | gain CC | gain MS | gain OPDF | of reference (CC / MS / OPDF) | pass {k} − pass 3 (MS) | F_{k} | pass {k} − F_{k} (MS) | retention (least) | restored added / removed / moved | pose RMSE / largest (m) | Lost |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---:|\n"
        ));
        for c in &r.summaries {
            let trio = |m: &super::summary::PerMetric<f64>| format!("{:.2} / {:.2} / {:.2}", m.cc, m.ms, m.opdf);
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.2} ({:.2}) | {} / {} / {} | {} / {} | {} |",
                c.preset,
                c.poses,
                trio(&c.m1),
                trio(&c.pass2),
                trio(&c.last),
                diff(&c.gain.cc),
                diff(&c.gain.ms),
                diff(&c.gain.opdf),
                c.gain_ratio.map_or_else(|| "–".into(), |g| format!("{:.2} / {:.2} / {:.2}", g.cc, g.ms, g.opdf)),
                diff(&c.since_pass3.ms),
                trio(&c.fresh),
                diff(&c.over_fresh.ms),
                c.retention,
                c.retention_min,
                opt(c.restored.added, 1),
                opt(c.restored.removed, 1),
                opt(c.restored.moved, 1),
                opt(c.pose_rmse_m, 3),
                opt(c.pose_max_m, 2),
                c.lost_episodes,
            );
        }
        s.push('\n');
        if let Some(k) = &r.kidnaps {
            kidnaps_md(s, k);
        }
        for source in &params.pose_sources {
            if r.summaries.iter().any(|c| c.poses == source.name()) {
                let rel = format!("{}/ms_{}.png", file_name(&r.name), file_name(source.name()));
                let _ = writeln!(s, "![MS per pass, {}, {}]({rel})\n", r.name, source.name());
            }
        }
    }
}

/// The spliced kidnaps of one log.
fn kidnaps_md(s: &mut String, k: &super::kidnap::RealKidnapResults) {
    let p = &k.params;
    let _ = writeln!(
        s,
        "### Spliced kidnaps\n\n{} cuts (the robot carried {:.1}-{:.1} m, any turn, its odometry blind), each paired with the \
unspliced log; recovered: within {} m and {}° of the reference within {} s of the cut and to the end of the window; \
wrong: a pose handed over {} m or {}° off or more; false Lost: a Lost on the unspliced window. Targets: ≥ 90 % \
recovered, ≤ 1 % wrong, ≤ 2 % false Lost.\n",
        k.cuts.len(),
        p.cuts.min_jump_m,
        p.cuts.max_jump_m,
        p.recovered_max_error_m,
        p.recovered_max_yaw_deg,
        p.recovery_window_s,
        p.wrong_min_error_m,
        p.wrong_min_yaw_deg
    );
    s.push_str("| map | localiser | preset | trials | recovered | wrong pose | false Lost | time to recover, median / p90 (s) | (scans) | how the trials ended |\n|---|---|---|---:|---:|---:|---:|---|---|---|\n");
    for x in &k.summaries {
        let ends: Vec<String> = x.ends.iter().map(|(e, n)| format!("{e} {n}")).collect();
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {:.1} % | {:.1} % | {:.1} % | {} / {} | {} / {} | {} |",
            x.map,
            x.localiser,
            x.preset,
            x.trials,
            100.0 * x.recovered_rate,
            100.0 * x.wrong_rate,
            100.0 * x.false_lost_rate,
            opt(x.median_recover_s, 1),
            opt(x.p90_recover_s, 1),
            opt(x.median_recover_scans, 0),
            opt(x.p90_recover_scans, 0),
            ends.join(", ")
        );
    }
    s.push('\n');
}
