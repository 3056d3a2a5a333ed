//! Reading validation folders back and merging them (`mapkeeper merge`): shards of one sweep
//! (`validate --shard k/N`), or runs of different seeds with the same parameters, become one
//! folder whose summary, tables, report and figures are exactly those of a single run over all
//! their seeds.
//!
//! The source of truth of a folder is its `runs.json` ([`ValidationRecord`]); `summary.json`
//! must agree with it, and each seed's `seed-S/` folder (maps, trajectories) must be present,
//! as it is copied into the merged folder. Folders are refused, with the folder and the problem
//! named ([`MergeProblem`]), when a file is missing or unreadable, when their tool version,
//! format, world count, preset, any other parameter or timing mode differ, when a seed
//! appears twice, or when the counts the summary adds up would not fit in `u64`.

use crate::experiments::validation::report::write_results;
use crate::experiments::validation::{RUNS_FORMAT, RUNS_FORMAT_VERSION, SeedRecord, Summary, ValidationRecord};
use crate::results::MergeProblem;
use crate::results::ResultsError;
use mapkeeper_grid::StagedDir;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn problem(dir: &Path, problem: MergeProblem) -> ResultsError {
    ResultsError::Merge { dir: dir.to_path_buf(), problem }
}

/// Reads `dir/file` as text; a missing file is [`MergeProblem::MissingFile`].
fn read_text(dir: &Path, file: &str) -> Result<String, ResultsError> {
    let p = dir.join(file);
    std::fs::read_to_string(&p).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            problem(dir, MergeProblem::MissingFile(file.into()))
        } else {
            ResultsError::Io { path: p, source: e }
        }
    })
}

fn bad_json(dir: &Path, file: &str, e: &serde_json::Error) -> ResultsError {
    problem(dir, MergeProblem::BadJson { file: file.into(), message: e.to_string() })
}

/// Reads and checks a validation folder: `runs.json` (format, version, rows and edits complete
/// for every seed, parameters valid, no seed twice), `summary.json` (equal to the summary
/// recomputed from `runs.json`, but for the tool name) and a `seed-S/` folder per seed.
pub fn load_result_dir(dir: &Path) -> Result<ValidationRecord, ResultsError> {
    if !dir.is_dir() {
        return Err(problem(dir, if dir.exists() { MergeProblem::NotAFolder } else { MergeProblem::NoSuchFolder }));
    }
    let record = parse_runs_json(dir, &read_text(dir, "runs.json")?)?;
    check_summary_json(dir, &record, &read_text(dir, "summary.json")?)?;
    for s in &record.seeds {
        let sub = format!("seed-{}", s.seed);
        if !dir.join(&sub).is_dir() {
            return Err(problem(dir, MergeProblem::MissingFile(format!("{sub}/"))));
        }
    }
    Ok(record)
}

/// The text of a folder's `runs.json`, parsed and checked as [`load_result_dir`] does (format,
/// version, rows and edits complete for every seed, parameters valid, no seed twice); `dir`
/// only names the folder in the errors (no file is read: the fuzz target `merge_json` calls
/// this).
pub fn parse_runs_json(dir: &Path, text: &str) -> Result<ValidationRecord, ResultsError> {
    let value: serde_json::Value = serde_json::from_str(text).map_err(|e| bad_json(dir, "runs.json", &e))?;
    let format = value.get("format").and_then(serde_json::Value::as_str).unwrap_or_default();
    if format != RUNS_FORMAT {
        return Err(problem(dir, MergeProblem::WrongFormat(format!("format is '{format}', expected '{RUNS_FORMAT}'"))));
    }
    let version = value.get("format_version").and_then(serde_json::Value::as_u64);
    if version != Some(u64::from(RUNS_FORMAT_VERSION)) {
        return Err(problem(
            dir,
            MergeProblem::WrongFormat(format!(
                "format_version is {}, this build reads {RUNS_FORMAT_VERSION}",
                version.map_or_else(|| "missing".to_owned(), |v| v.to_string())
            )),
        ));
    }
    let record: ValidationRecord = serde_json::from_str(text).map_err(|e| bad_json(dir, "runs.json", &e))?;
    check_record(dir, &record)?;
    Ok(record)
}

/// Checks the text of a folder's `summary.json` against `record` (its `runs.json`, checked by
/// [`parse_runs_json`]): equal to the summary recomputed from it, but for the tool name. A
/// summary written before `interval_units` (which gave one seed no interval) is compared with
/// the summary as those versions made it. `dir` only names the folder in the errors.
pub fn check_summary_json(dir: &Path, record: &ValidationRecord, text: &str) -> Result<(), ResultsError> {
    let summary: Summary = serde_json::from_str(text).map_err(|e| bad_json(dir, "summary.json", &e))?;
    let mut recomputed = Summary { tool: summary.tool.clone(), ..record.summary() };
    let has_units = serde_json::from_str::<serde_json::Value>(text).is_ok_and(|v| v.get("interval_units").is_some());
    if !has_units {
        recomputed = recomputed.without_one_seed_intervals();
    }
    if recomputed != summary {
        return Err(problem(
            dir,
            MergeProblem::Inconsistent("summary.json does not match the summary of runs.json".into()),
        ));
    }
    Ok(())
}

/// What the summary adds up over all seeds (`summarise_records`): the scan-time histogram's
/// counts and the integer counters of every world row, each by name.
fn seed_counts(s: &SeedRecord) -> impl Iterator<Item = (&'static str, u64)> + '_ {
    let histogram = s.scan_time_histogram_us.iter().map(|&(_, c)| ("scan_time_histogram_us", c));
    let rows = s.rows.iter().flat_map(|w| {
        let (u, l) = (&w.updater, &w.lost);
        [
            ("updater.processed", u.processed),
            ("updater.beams", u.beams),
            ("updater.update", u.update),
            ("updater.suspend", u.suspend),
            ("updater.lost", u.lost),
            ("updater.recovered", u.recovered),
            ("updater.cell_changes", u.cell_changes),
            ("collisions", w.collisions),
            ("lost.episodes", l.episodes),
            ("lost.attempts", l.attempts),
            ("lost.recoveries", l.recoveries),
            ("lost.cleared", l.cleared),
            ("lost.give_ups", l.give_ups),
            ("lost.stopped_ns", l.stopped_ns),
        ]
    });
    histogram.chain(rows)
}

/// Running totals of [`seed_counts`], added with overflow checks: a folder (or a merge) whose
/// totals do not fit in `u64` is refused instead of making the summary overflow (the fuzz
/// target `merge_json` found a histogram with two counts of 2^64 − 1 doing so).
#[derive(Default)]
struct Totals(BTreeMap<&'static str, u64>);

impl Totals {
    fn add(&mut self, s: &SeedRecord) -> Result<(), MergeProblem> {
        for (counter, v) in seed_counts(s) {
            let t = self.0.entry(counter).or_default();
            *t = t.checked_add(v).ok_or(MergeProblem::CountsOverflow { counter, seed: s.seed })?;
        }
        Ok(())
    }
}

/// Every seed has rows for W_2 … W_N in order and N edit lists; parameters are valid; no seed
/// twice; the totals of the summary fit.
fn check_record(dir: &Path, r: &ValidationRecord) -> Result<(), ResultsError> {
    let inconsistent = |m: String| problem(dir, MergeProblem::Inconsistent(format!("runs.json: {m}")));
    r.params.validate().map_err(|e| inconsistent(e.to_string()))?;
    if r.seeds.is_empty() {
        return Err(inconsistent("no seed".into()));
    }
    let n = r.params.worlds;
    let mut seen = BTreeMap::new();
    let mut totals = Totals::default();
    for s in &r.seeds {
        if seen.insert(s.seed, ()).is_some() {
            return Err(problem(dir, MergeProblem::DuplicateSeed { seed: s.seed, first: dir.to_path_buf() }));
        }
        let ok_rows =
            s.rows.len() == n - 1 && s.rows.iter().enumerate().all(|(k, w)| w.world == k + 2 && w.seed == s.seed);
        if !ok_rows {
            return Err(inconsistent(format!("seed {}: the rows are not W_2 … W_{n} of this seed", s.seed)));
        }
        if s.edits.len() != n {
            return Err(inconsistent(format!("seed {}: {} edit lists for {n} worlds", s.seed, s.edits.len())));
        }
        if s.scan_time_histogram_us.windows(2).any(|w| w[0].0 >= w[1].0)
            || s.scan_time_histogram_us.iter().any(|&(_, c)| c == 0)
        {
            return Err(inconsistent(format!(
                "seed {}: scan_time_histogram_us needs increasing times and counts ≥ 1",
                s.seed
            )));
        }
        totals.add(s).map_err(|p| problem(dir, p))?;
    }
    Ok(())
}

/// The first place where two JSON values differ, as a dotted path ("" if they are equal).
fn first_difference(a: &serde_json::Value, b: &serde_json::Value, path: &str) -> Option<String> {
    use serde_json::Value;
    let join = |k: &str| if path.is_empty() { k.to_owned() } else { format!("{path}.{k}") };
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            for (k, va) in x {
                match y.get(k) {
                    Some(vb) => {
                        if let Some(d) = first_difference(va, vb, &join(k)) {
                            return Some(d);
                        }
                    }
                    None => return Some(join(k)),
                }
            }
            y.keys().find(|k| !x.contains_key(*k)).map(|k| join(k))
        }
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => {
            x.iter().zip(y).enumerate().find_map(|(i, (va, vb))| first_difference(va, vb, &format!("{path}[{i}]")))
        }
        _ => (a != b).then(|| path.to_owned()),
    }
}

/// Merges checked records (each with its folder, for the errors): same tool, parameters and
/// timing mode, no seed twice. The result holds all seeds in seed order, the summed wall time
/// and no shard.
pub fn merge_records(inputs: &[(PathBuf, ValidationRecord)]) -> Result<ValidationRecord, ResultsError> {
    let Some((_, first)) = inputs.first() else {
        return Err(problem(Path::new(""), MergeProblem::NoInput));
    };
    let first_params = serde_json::to_value(&first.params)
        .map_err(|e| ResultsError::Serialise { what: "params".into(), message: e.to_string() })?;
    let mut owner: BTreeMap<u64, &Path> = BTreeMap::new();
    let mut totals = Totals::default();
    let mut seeds = Vec::new();
    let mut wall_time_s = 0.0;
    for (dir, r) in inputs {
        if r.tool != first.tool {
            return Err(problem(dir, MergeProblem::ToolMismatch { expected: first.tool.clone(), got: r.tool.clone() }));
        }
        if r.params.worlds != first.params.worlds {
            return Err(problem(
                dir,
                MergeProblem::WorldsMismatch { expected: first.params.worlds, got: r.params.worlds },
            ));
        }
        if r.params.preset != first.params.preset {
            return Err(problem(
                dir,
                MergeProblem::PresetMismatch { expected: first.params.preset.clone(), got: r.params.preset.clone() },
            ));
        }
        if r.params != first.params {
            let p = serde_json::to_value(&r.params)
                .map_err(|e| ResultsError::Serialise { what: "params".into(), message: e.to_string() })?;
            let field = first_difference(&first_params, &p, "").unwrap_or_default();
            return Err(problem(dir, MergeProblem::ParamsMismatch { field }));
        }
        if r.timing != first.timing {
            return Err(problem(dir, MergeProblem::TimingMismatch));
        }
        for s in &r.seeds {
            if let Some(other) = owner.insert(s.seed, dir) {
                return Err(problem(dir, MergeProblem::DuplicateSeed { seed: s.seed, first: other.to_path_buf() }));
            }
            totals.add(s).map_err(|p| problem(dir, p))?;
            seeds.push(s.clone());
        }
        wall_time_s += r.wall_time_s;
    }
    seeds.sort_by_key(|s| s.seed);
    Ok(ValidationRecord { wall_time_s, shard: None, seeds, ..first.clone() })
}

/// Copies the regular files under `from` to `rel` inside `out`, recursively.
fn copy_tree(from: &Path, out: &StagedDir, rel: &str) -> Result<(), ResultsError> {
    let mut entries: Vec<_> = std::fs::read_dir(from)
        .map_err(ResultsError::io(from))?
        .collect::<Result<_, _>>()
        .map_err(ResultsError::io(from))?;
    entries.sort_by_key(std::fs::DirEntry::file_name);
    for e in entries {
        let name = e.file_name().to_string_lossy().into_owned();
        let path = e.path();
        let sub = format!("{rel}/{name}");
        let kind = e.file_type().map_err(ResultsError::io(&path))?;
        if kind.is_dir() {
            copy_tree(&path, out, &sub)?;
        } else if kind.is_file() {
            let target = out.file(&sub)?;
            std::fs::copy(&path, &target).map_err(ResultsError::io(&path))?;
        }
    }
    Ok(())
}

/// Reads, checks and merges the folders `dirs` into the folder `out` (being written; the caller
/// finishes it, so nothing appears unless every input passed its checks): `runs.json`,
/// `summary.json`, `worlds.csv`, `edits.json`, `report.md` and the figures recomputed from the
/// merged record, and every seed's `seed-S/` folder copied. Returns the merged record and its
/// summary.
pub fn merge_dirs(dirs: &[PathBuf], staged: &StagedDir) -> Result<(ValidationRecord, Summary), ResultsError> {
    let inputs = dirs.iter().map(|d| Ok((d.clone(), load_result_dir(d)?))).collect::<Result<Vec<_>, ResultsError>>()?;
    let merged = merge_records(&inputs)?;
    // The seeds' folders first: report.html embeds their images.
    for (dir, r) in &inputs {
        for s in &r.seeds {
            let sub = format!("seed-{}", s.seed);
            copy_tree(&dir.join(&sub), staged, &sub)?;
        }
    }
    let summary = write_results(staged, &merged)?;
    Ok((merged, summary))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn first_difference_names_the_field() {
        let a = json!({"worlds": 3, "runner": {"updater": {"n_b": 5, "k": [1, 2]}}});
        let b = json!({"worlds": 3, "runner": {"updater": {"n_b": 6, "k": [1, 2]}}});
        assert_eq!(first_difference(&a, &b, ""), Some("runner.updater.n_b".into()));
        let c = json!({"worlds": 3, "runner": {"updater": {"n_b": 5, "k": [1, 3]}}});
        assert_eq!(first_difference(&a, &c, ""), Some("runner.updater.k[1]".into()));
        assert_eq!(first_difference(&a, &a, ""), None);
        let d = json!({"worlds": 3});
        assert_eq!(first_difference(&a, &d, ""), Some("runner".into()));
    }
}
