//! The side-by-side comparison of a sweep over presets (`validate --presets a,b,…`): one table
//! beside the presets' own folders, `OUT/summary.json` and `OUT/report.md`, with one row per
//! preset (over all its seeds) and, when there are several seeds, one per preset and seed.
//! Everything is recomputed from the presets' records, so the comparison of merged shards is
//! that of the unsharded sweep.

use crate::experiments::validation::erosion::{ChangeClassSummary, RetentionSummary};
use crate::experiments::validation::merge::{load_result_dir, merge_dirs};
use crate::experiments::validation::saved_worlds::world_steppers;
use crate::experiments::validation::{MapQuality, SeedRecord, ValidationRecord, WorldRow, summarise_records};
use crate::results::MergeProblem;
use crate::results::ResultsError;
use crate::results::html::{Part, SteppersIntro, page_html};
use crate::stats::with_ci;
use crate::stats::{IntervalUnits, PairedDiff, batch_means_half_width, chain_units, mean, paired_diff};
use mapkeeper_closed_loop::controls::{LostCounts, VerdictCounts};
use mapkeeper_closed_loop::pose_oracle::UpdaterPoses;
use mapkeeper_grid::StagedDir;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Value of the comparison's `format` field (what tells a sweep folder from a preset's).
pub const COMPARISON_FORMAT: &str = "mapkeeper-validation-comparison";

/// Localisation error means of one row, metres.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LocMeans {
    /// The baseline localiser on M_1: mean over worlds of the per-world mean error.
    pub on_m1_m: f64,
    /// The chain localiser on M_{i-1}.
    pub on_prev_m: f64,
}

/// One row of the comparison: a preset over all its seeds (`seed` = `None`) or over one seed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ComparisonRow {
    /// The updater preset.
    pub preset: String,
    /// The seed of this row, `None` for all the preset's seeds.
    pub seed: Option<u64>,
    /// The seeds this row covers.
    pub seeds: Vec<u64>,
    /// World rows (W_2 … W_N of each seed).
    pub worlds: usize,
    /// Map quality: per metric, the means of M_1/G_i and M_i/G_i, the last world's (M_1/G_N
    /// and M_N/G_N) and the share of worlds where M_i beats M_1.
    pub map_quality: MapQuality,
    /// Localisation error means on M_1 and on M_{i-1}.
    pub localisation_error: LocMeans,
    /// Share of worlds where the chain localiser's mean error is below the baseline's.
    pub localisation_better_fraction: f64,
    /// Verdict counts.
    pub verdicts: VerdictCounts,
    /// The reaction to Lost.
    pub lost_handling: LostCounts,
    /// Structure retention of M_i (exactly the preset summary's; absent for records written
    /// before it was measured).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub retention: Option<RetentionSummary>,
    /// The change classes M_i got right (likewise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub change_classes: Option<ChangeClassSummary>,
}

/// A mean difference over seeds with its 95 % interval (over the seeds, or with one seed over
/// batches of its worlds: [`PresetDiff::interval_units`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DiffCi {
    /// Mean over the common seeds of the per-seed difference.
    pub mean: f64,
    /// 95 % Student-t interval, `[lo, hi]`.
    pub ci95: Option<[f64; 2]>,
}

impl From<PairedDiff> for DiffCi {
    fn from(d: PairedDiff) -> Self {
        DiffCi { mean: d.mean, ci95: d.ci95 }
    }
}

/// Preset `a` against preset `b` over the seeds both ran: per seed, the mean over worlds of
/// `a`'s M_i/G_i minus `b`'s (percentage points; positive: `a`'s updated maps are better), and
/// of the chain localiser's mean error (metres; negative: `a` localises better).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PresetDiff {
    /// The first preset.
    pub a: String,
    /// The preset it is compared with.
    pub b: String,
    /// The seeds both ran (the paired units).
    pub seeds: Vec<u64>,
    /// The units of the intervals: the seeds, or with one seed batches of the worlds both
    /// presets ran in it (the differences paired world by world).
    #[serde(default)]
    pub interval_units: IntervalUnits,
    /// CC of M_i/G_i, a − b.
    pub cc: DiffCi,
    /// MS of M_i/G_i, a − b.
    pub ms: DiffCi,
    /// OPDF of M_i/G_i, a − b.
    pub opdf: DiffCi,
    /// Chain localiser mean error on M_{i-1}, a − b, metres.
    pub error_m: DiffCi,
}

fn preset_diff(a: &ValidationRecord, b: &ValidationRecord) -> PresetDiff {
    let common: Vec<(&SeedRecord, &SeedRecord)> = a
        .seeds
        .iter()
        .filter_map(|sa| b.seeds.iter().find(|sb| sb.seed == sa.seed).map(|sb| (sa, sb)))
        .filter(|(sa, sb)| !sa.rows.is_empty() && !sb.rows.is_empty())
        .collect();
    // With one common seed, the worlds both ran, paired world by world, give the interval.
    let one_seed_worlds: Option<Vec<(&WorldRow, &WorldRow)>> = match common.as_slice() {
        [(sa, sb)] => Some(
            sa.rows.iter().filter_map(|wa| sb.rows.iter().find(|wb| wb.world == wa.world).map(|wb| (wa, wb))).collect(),
        ),
        _ => None,
    };
    let interval_units = chain_units(one_seed_worlds.as_ref().map(Vec::len).as_slice());
    let per_seed = |f: &dyn Fn(&WorldRow) -> f64| -> DiffCi {
        let d: Vec<f64> =
            common.iter().map(|(sa, sb)| mean(sa.rows.iter().map(f)) - mean(sb.rows.iter().map(f))).collect();
        let mut diff = paired_diff(&d);
        if let Some(worlds) = &one_seed_worlds {
            // The mean stays the difference of the two means; the interval is the batch means'
            // of the world-by-world differences, around it.
            let by_world: Vec<f64> = worlds.iter().map(|(wa, wb)| f(wa) - f(wb)).collect();
            if let Some(half) = batch_means_half_width(&by_world) {
                diff.ci95 = Some([diff.mean - half, diff.mean + half]);
            }
        }
        diff.into()
    };
    let (cc, ms, opdf, error_m) = (
        per_seed(&|w| w.updated_map.cc),
        per_seed(&|w| w.updated_map.ms),
        per_seed(&|w| w.updated_map.opdf),
        per_seed(&|w| w.loc_updated.mean_error_m),
    );
    PresetDiff {
        a: a.params.preset.clone(),
        b: b.params.preset.clone(),
        seeds: common.iter().map(|(sa, _)| sa.seed).collect(),
        interval_units,
        cc,
        ms,
        opdf,
        error_m,
    }
}

/// `summary.json` of a sweep folder.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Comparison {
    /// Always [`COMPARISON_FORMAT`].
    pub format: String,
    /// Producer and version.
    pub tool: String,
    /// Worlds N per seed.
    pub worlds: usize,
    /// Every preset of the sweep, in sweep order (also those with no job in this folder's shard).
    pub presets: Vec<String>,
    /// The rows, preset by preset in sweep order: the preset over all its seeds, then (with
    /// several seeds) one row per seed in seed order.
    pub rows: Vec<ComparisonRow>,
    /// Every pair of presets (in sweep order, each against the ones before it), paired over
    /// their common seeds: e.g. `paper` − `always-update` is what the localisation check adds.
    #[serde(default)]
    pub preset_diffs: Vec<PresetDiff>,
    /// Where the updater's pose came from (every preset alike), when not the chain localiser.
    #[serde(default, skip_serializing_if = "UpdaterPoses::is_localiser")]
    pub updater_poses: UpdaterPoses,
}

fn row(preset: &str, seed: Option<u64>, record: &ValidationRecord, seeds: &[SeedRecord]) -> ComparisonRow {
    let s = summarise_records(&record.params, seeds, 0.0);
    ComparisonRow {
        preset: preset.to_owned(),
        seed,
        seeds: s.seeds.clone(),
        worlds: s.rows,
        map_quality: s.map_quality,
        localisation_error: LocMeans {
            on_m1_m: s.localisation.static_map.mean_error_m,
            on_prev_m: s.localisation.updated_map.mean_error_m,
        },
        localisation_better_fraction: s.localisation.updated_better_fraction,
        verdicts: VerdictCounts { update: s.updater.update, suspend: s.updater.suspend, lost: s.updater.lost },
        lost_handling: s.lost_handling,
        retention: s.retention,
        change_classes: s.change_classes,
    }
}

impl Comparison {
    /// The comparison of `records` (one per preset that has runs here, in sweep order; each
    /// named by its preset) of a sweep over `presets`.
    pub fn new(presets: &[String], records: &[&ValidationRecord]) -> Self {
        let mut rows = Vec::new();
        for r in records {
            let preset = &r.params.preset;
            rows.push(row(preset, None, r, &r.seeds));
            if r.seeds.len() > 1 {
                for s in &r.seeds {
                    rows.push(row(preset, Some(s.seed), r, std::slice::from_ref(s)));
                }
            }
        }
        let mut preset_diffs = Vec::new();
        for (j, b) in records.iter().enumerate() {
            for a in &records[j + 1..] {
                preset_diffs.push(preset_diff(a, b));
            }
        }
        Comparison {
            format: COMPARISON_FORMAT.into(),
            tool: format!("mapkeeper-scenario {}", env!("CARGO_PKG_VERSION")),
            worlds: records.first().map_or(0, |r| r.params.worlds),
            presets: presets.to_vec(),
            rows,
            preset_diffs,
            updater_poses: records.first().map(|r| r.params.runner.updater_poses).unwrap_or_default(),
        }
    }

    /// `summary.json` text.
    pub fn json(&self) -> Result<String, ResultsError> {
        serde_json::to_string_pretty(self)
            .map(|mut s| {
                s.push('\n');
                s
            })
            .map_err(|e| ResultsError::Serialise { what: "summary.json".into(), message: e.to_string() })
    }

    /// `report.md`: the comparison table.
    pub fn report_md(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# Validation sweep: presets side by side\n");
        let _ = writeln!(
            s,
            "{} worlds per seed; presets {}. Each preset's own folder (`<preset>/report.md`) has its full report. \
             Map quality: mean over worlds of M_1/G_i → M_i/G_i, the last world's M_N/G_N, and the share of worlds \
             where M_i beats M_1. Localisation: mean error (m) on M_1 and on M_{{i-1}}. Lost handling: episodes, \
             attempts of pose updating, recoveries / cleared / give-ups, time stopped.\n",
            self.worlds,
            self.presets.iter().map(|p| format!("`{p}`")).collect::<Vec<_>>().join(", ")
        );
        if !self.updater_poses.is_localiser() {
            let _ = writeln!(s, "Pose source of the updater: {}.\n", self.updater_poses.describe());
        }
        let _ = writeln!(
            s,
            "| preset | seed | worlds | CC M_1 → M_i (M_N) | CC better | MS M_1 → M_i (M_N) | MS better | OPDF M_1 → M_i (M_N) | \
             OPDF better | err on M_1 (m) | err on M_i-1 (m) | Update / Suspend / Lost | Lost episodes | attempts | \
             recovered / cleared / gave up | stopped (s) |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
        for r in &self.rows {
            let q = &r.map_quality;
            let m = |m: &crate::experiments::validation::MetricSummary| {
                format!(
                    "{:.2} → {:.2} ({:.2}) | {:.0} %",
                    m.static_mean,
                    m.updated_mean,
                    m.updated_last,
                    100.0 * m.updated_better_fraction
                )
            };
            let (v, l) = (&r.verdicts, &r.lost_handling);
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {:.4} | {:.4} | {} / {} / {} | {} | {} | {} / {} / {} | {:.1} |",
                r.preset,
                r.seed.map_or_else(|| "all".to_owned(), |x| x.to_string()),
                r.worlds,
                m(&q.cc),
                m(&q.ms),
                m(&q.opdf),
                r.localisation_error.on_m1_m,
                r.localisation_error.on_prev_m,
                v.update,
                v.suspend,
                v.lost,
                l.episodes,
                l.attempts,
                l.recoveries,
                l.cleared,
                l.give_ups,
                l.stopped_s()
            );
        }
        self.erosion_md(&mut s);
        self.preset_diffs_md(&mut s);
        s
    }
}

impl Comparison {
    /// The presets-against-each-other table of `report_md` (none with one preset).
    fn preset_diffs_md(&self, s: &mut String) {
        if !self.preset_diffs.is_empty() {
            let _ = writeln!(
                s,
                "\n## Presets against each other\n\nPer seed, the mean over worlds of preset a's M_i/G_i minus preset b's \
             (points; positive: a's maps are better) and of the chain localiser's mean error (m; negative: a \
             localises better), averaged over the seeds both ran, with the paired 95 % Student-t interval over \
             those seeds. With one seed (marked \"1, worlds\"), the interval is over {} batches of consecutive worlds \
             of the world-by-world differences: how precisely this seed's chain of worlds pins the difference, not \
             how much another seed's would differ (docs/evaluation.md, \"Intervals\"); none with fewer than {} \
             updated worlds.\n",
                crate::stats::WORLD_BATCHES,
                crate::stats::WORLD_BATCHES * crate::stats::MIN_WORLDS_PER_BATCH
            );
            let _ = writeln!(s, "| a − b | seeds | CC | MS | OPDF | error on M_i-1 (m) |");
            let _ = writeln!(s, "|---|---|---|---|---|---|");
            for d in &self.preset_diffs {
                let _ = writeln!(
                    s,
                    "| {} − {} | {} | {} | {} | {} | {} |",
                    d.a,
                    d.b,
                    match d.interval_units {
                        IntervalUnits::Seeds => d.seeds.len().to_string(),
                        IntervalUnits::WorldBatches => format!("{}, worlds", d.seeds.len()),
                    },
                    with_ci(d.cc.mean, d.cc.ci95, 2),
                    with_ci(d.ms.mean, d.ms.ci95, 2),
                    with_ci(d.opdf.mean, d.opdf.ci95, 2),
                    with_ci(d.error_m.mean, d.error_m.ci95, 4)
                );
            }
        }
    }

    /// The structure retention and change-class table of `report_md` (rows that have them).
    fn erosion_md(&self, s: &mut String) {
        let rows: Vec<&ComparisonRow> = self.rows.iter().filter(|r| r.retention.is_some()).collect();
        if rows.is_empty() {
            return;
        }
        let _ = writeln!(
            s,
            "\n## Structure retention and change classes\n\nAgainst the exact G_i (`docs/metrics.md`): the share of the \
             fixed structure of M_1 that M_i keeps, at W_2, at W_N and on average (target at W_N ≥ 99 %), and the \
             shares of the cells the route observes where M_1 and G_i disagree that M_i got right, by class: added, \
             removed and moved items, and M_1's initial errors (mean over the worlds where the class has cells; — \
             for none).\n"
        );
        let _ = writeln!(
            s,
            "| preset | seed | retention W_2 | retention W_N | retention mean | target | added right | removed right | \
             moved right | initial errors fixed |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|");
        let pct = |v: Option<f64>| v.map_or_else(|| "—".to_owned(), |v| format!("{v:.2}"));
        for r in rows {
            let (Some(t), c) = (&r.retention, r.change_classes.unwrap_or_default()) else { continue };
            let _ = writeln!(
                s,
                "| {} | {} | {:.2} | {:.2} | {:.2} | {} | {} | {} | {} | {} |",
                r.preset,
                r.seed.map_or_else(|| "all".to_owned(), |x| x.to_string()),
                t.updated_w2,
                t.updated_last,
                t.updated_mean,
                if t.target_met { "met" } else { "not met" },
                pct(c.added.updated_mean),
                pct(c.removed.updated_mean),
                pct(c.moved.updated_mean),
                pct(c.initial_errors.updated_mean)
            );
        }
    }
}

/// The top-level files of a sweep folder.
pub const COMPARISON_FILES: [&str; 2] = ["summary.json", "report.md"];

/// Writes `summary.json`, `report.md` and `report.html` of a sweep folder `out` (being written; its per-preset
/// folders are [`StagedDir::sub`] folders of it, so the sweep appears whole or not at all).
pub fn write_comparison(out: &StagedDir, c: &Comparison, records: &[&ValidationRecord]) -> Result<(), ResultsError> {
    let md = c.report_md();
    for (f, text) in [(COMPARISON_FILES[0], c.json()?), (COMPARISON_FILES[1], md.clone())] {
        out.write(f, text.as_bytes())?;
    }
    write_sweep_html(out, &md, records)
}

/// `OUT/report.html`: the comparison, then the report of each preset this folder holds (read
/// from `OUT/<preset>/report.md`, written before; a shard holds some of the sweep's presets)
/// with its world steppers, on one page.
fn write_sweep_html(out: &StagedDir, md: &str, records: &[&ValidationRecord]) -> Result<(), ResultsError> {
    let mut texts = Vec::with_capacity(records.len());
    for r in records {
        let p = &r.params.preset;
        let file = out.path().join(p).join("report.md");
        let text = std::fs::read_to_string(&file).map_err(ResultsError::io(&file))?;
        // Its title says which preset it is (the table of contents lists the presets).
        texts.push(match text.strip_prefix("# ") {
            Some(rest) => format!("# Preset `{p}`: {rest}"),
            None => text,
        });
    }
    let intro = SteppersIntro::SAVED_WORLDS;
    let mut parts = vec![Part {
        id: String::new(),
        markdown: md,
        base: String::new(),
        steppers: Vec::new(),
        steppers_intro: intro,
    }];
    for (text, r) in texts.iter().zip(records) {
        let p = &r.params.preset;
        let steppers = world_steppers(r);
        parts.push(Part {
            id: format!("{p}-"),
            markdown: text,
            base: format!("{p}/"),
            steppers,
            steppers_intro: intro,
        });
    }
    let page = page_html("Validation sweep", &parts, out.path())?;
    out.write("report.html", page.as_bytes())?;
    Ok(())
}

/// Whether `dir` is a sweep folder (its `summary.json` is a [`Comparison`]).
pub fn is_sweep_dir(dir: &Path) -> bool {
    std::fs::read_to_string(dir.join("summary.json"))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .is_some_and(|v| v.get("format").and_then(serde_json::Value::as_str) == Some(COMPARISON_FORMAT))
}

fn read_comparison(dir: &Path) -> Result<Comparison, ResultsError> {
    let bad = |problem| ResultsError::Merge { dir: dir.to_path_buf(), problem };
    let p = dir.join("summary.json");
    let text = std::fs::read_to_string(&p).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => bad(MergeProblem::MissingFile("summary.json".into())),
        _ => ResultsError::Io { path: p.clone(), source: e },
    })?;
    let c: Comparison = serde_json::from_str(&text)
        .map_err(|e| bad(MergeProblem::BadJson { file: "summary.json".into(), message: e.to_string() }))?;
    // Preset names become folder names under the merge's output: a plain name only, never a
    // path (`../x` would write outside it).
    let plain = |p: &str| {
        !p.is_empty() && p != "." && p != ".." && p.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
    };
    if let Some(p) = c.presets.iter().find(|p| !plain(p)) {
        let escaped: String = p.escape_default().collect();
        return Err(bad(MergeProblem::Inconsistent(format!(
            "summary.json: preset name '{escaped}' is not a plain name (letters, digits, '-', '_')"
        ))));
    }
    Ok(c)
}

/// Merges sweep folders (`validate --presets … --shard k/N`, or sweeps of other seeds) into the
/// sweep folder `out` (being written; the caller finishes it): each preset's folders are merged
/// into `out/<preset>` as by [`merge_dirs`], then the comparison is recomputed over the merged
/// presets. The sweeps must list the same presets in the same order. Returns the comparison.
pub fn merge_sweeps(dirs: &[PathBuf], out: &StagedDir) -> Result<Comparison, ResultsError> {
    let Some(first) = dirs.first() else {
        return Err(ResultsError::Merge { dir: PathBuf::new(), problem: MergeProblem::NoInput });
    };
    let presets = read_comparison(first)?.presets;
    for d in &dirs[1..] {
        let other = read_comparison(d)?.presets;
        if other != presets {
            let problem =
                MergeProblem::Inconsistent(format!("a sweep over presets {other:?}, the first folder {presets:?}"));
            return Err(ResultsError::Merge { dir: d.clone(), problem });
        }
    }
    let has = |d: &PathBuf, p: &String| d.join(p).join("runs.json").is_file();
    let groups: Vec<(&String, Vec<PathBuf>)> = presets
        .iter()
        .map(|p| (p, dirs.iter().filter(|d| has(d, p)).cloned().collect::<Vec<_>>()))
        .filter(|(_, ds)| !ds.is_empty())
        .collect();
    // Check every input before writing anything.
    for (p, ds) in &groups {
        for d in ds {
            load_result_dir(&d.join(p))?;
        }
    }
    let mut records = Vec::with_capacity(groups.len());
    for (p, ds) in &groups {
        let ds: Vec<PathBuf> = ds.iter().map(|d| d.join(p)).collect();
        let sub = out.sub(p)?;
        records.push(merge_dirs(&ds, &sub)?.0);
        sub.finish()?;
    }
    let c = Comparison::new(&presets, &records.iter().collect::<Vec<_>>());
    write_comparison(out, &c, &records.iter().collect::<Vec<_>>())?;
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sweep_whose_preset_names_are_paths_is_refused() {
        let dir = std::env::temp_dir().join(format!("mapkeeper-comparison-names-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        for (name, ok) in
            [("paper", true), ("always-update", true), ("../x", false), ("a/b", false), ("..", false), ("", false)]
        {
            let c = Comparison {
                format: COMPARISON_FORMAT.into(),
                tool: "t".into(),
                worlds: 2,
                presets: vec![name.into()],
                rows: Vec::new(),
                preset_diffs: Vec::new(),
                updater_poses: UpdaterPoses::Localiser,
            };
            std::fs::write(dir.join("summary.json"), c.json().unwrap()).unwrap();
            let got = read_comparison(&dir);
            assert_eq!(got.is_ok(), ok, "{name:?}: {got:?}");
            if !ok {
                assert!(got.unwrap_err().to_string().contains("not a plain name"));
            }
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
