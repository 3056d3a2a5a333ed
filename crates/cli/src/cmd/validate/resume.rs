//! `--resume`: the jobs a killed run finished, and whether OUT already holds this run.

use super::Args;
use anyhow::Context;
use mapkeeper_scenario::SweepPlan;
use mapkeeper_scenario::experiments::validation::checkpoint::Checkpoints;
use std::path::Path;

/// The jobs a killed run had finished (with --resume; in job order, `None`: to run), or none,
/// discarding what an interrupted run left (without --resume). Timing is not part of a job's
/// fingerprint, so the run's timing is made to match this one's: with `timing` off, the
/// finished jobs' times are dropped (the outputs are then an untimed run's); with it on, a
/// job finished without times is run again (its outputs would otherwise have no times).
pub(super) fn finished_jobs(
    plan: &SweepPlan,
    checkpoints: &Checkpoints,
    out: &Path,
    resume: bool,
    timing: bool,
) -> anyhow::Result<Vec<Option<mapkeeper_scenario::SeedRun>>> {
    if resume {
        let mut done = plan.load_checkpoints(checkpoints)?;
        let mut untimed = 0;
        for slot in &mut done {
            match slot {
                Some(run) if !timing => run.drop_timing(),
                Some(run) if run.lacks_times() => {
                    untimed += 1;
                    *slot = None;
                }
                _ => {}
            }
        }
        let n = done.iter().flatten().count();
        outln!("validate: resuming {}: {n} of {} job(s) already done", out.display(), done.len());
        if untimed > 0 {
            outln!("validate: {untimed} finished job(s) were run with --no-timing: run again, for their times");
        }
        return Ok(done);
    }
    let n = checkpoints.count();
    if n > 0 {
        errln!(
            "mapkeeper: note: {}: discarded {n} finished job(s) of an interrupted run (--resume keeps them)",
            checkpoints.dir().display()
        );
    }
    checkpoints.remove()?;
    Ok(vec![None; plan.jobs.len()])
}

/// Whether OUT holds the finished outputs of this very run (each preset's summary.json with
/// the same parameters, and for a sweep the comparison): `validate --resume` then has nothing
/// to do. An OUT that holds another run's results is an error.
pub(super) fn is_complete(out: &Path, plan: &SweepPlan, sweep: bool, args: &Args) -> anyhow::Result<bool> {
    if !out.join("summary.json").is_file() {
        return Ok(false);
    }
    for p in plan.groups() {
        let dir = if sweep { out.join(&plan.presets[p]) } else { out.to_path_buf() };
        let file = dir.join("summary.json");
        let text = std::fs::read_to_string(&file).with_context(|| format!("--resume: {}", file.display()))?;
        let json: serde_json::Value =
            serde_json::from_str(&text).with_context(|| format!("--resume: {}", file.display()))?;
        // As the run writes them: with the bags it was asked for.
        let mut params = plan.params[p].clone();
        params.mcap_worlds.clone_from(&args.mcap_worlds);
        // Read as parameters, not compared as text: a folder written before a field's layout
        // changed (the flat `removal_*` names, read as the `removal` section) is the same run.
        let held: Option<mapkeeper_scenario::ValidationParams> =
            json.get("params").and_then(|v| serde_json::from_value(v.clone()).ok());
        let want_shard = serde_json::to_value(args.shard)?;
        if held.as_ref() != Some(&params) || json.get("shard").unwrap_or(&serde_json::Value::Null) != &want_shard {
            anyhow::bail!(
                "--resume: {} holds a run with other parameters or another shard than these flags (use another --out)",
                file.display()
            );
        }
        // Timing is not a parameter: runs.json says whether the folder's run was timed.
        let runs = dir.join("runs.json");
        let text = std::fs::read_to_string(&runs).with_context(|| format!("--resume: {}", runs.display()))?;
        let record: serde_json::Value =
            serde_json::from_str(&text).with_context(|| format!("--resume: {}", runs.display()))?;
        let timed = record.get("timing").and_then(serde_json::Value::as_bool);
        if timed != Some(!args.timing.no_timing) {
            let (was, asked) =
                if args.timing.no_timing { ("a timed", "--no-timing") } else { ("an untimed", "timing") };
            anyhow::bail!(
                "--resume: {} holds {was} run, and these flags ask for {asked} (use another --out)",
                runs.display()
            );
        }
    }
    Ok(true)
}
