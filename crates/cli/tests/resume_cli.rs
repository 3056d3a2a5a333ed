//! `validate --resume` (issue 15): a sweep killed after some (preset, seed) jobs, re-run with
//! --resume, runs only the rest and writes the same files as an uninterrupted run; damaged or
//! foreign checkpoints are refused with the file named.
#![allow(clippy::unwrap_used)]

mod common;

use common::{files, mapkeeper, s, scratch};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::Duration;

fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

/// A sweep of 2 presets × 2 seeds of short worlds, one job at a time (`--route-length 12` in
/// `extra` replaces the 10 m).
fn sweep(out: &Path, extra: &[&str]) -> Vec<String> {
    let route = if extra.contains(&"12") { "12" } else { "10" };
    let extra: Vec<&str> = extra.iter().copied().filter(|&a| a != "--route-length" && a != "12").collect();
    let mut a: Vec<String> = [
        "validate",
        "--presets",
        "paper,mapkeeper",
        "--localiser",
        "mapkeeper",
        "--seeds",
        "2",
        "--worlds",
        "3",
        "--route-length",
        route,
        "--jobs",
        "1",
        "--no-timing",
        "--out",
    ]
    .iter()
    .map(ToString::to_string)
    .collect();
    a.push(s(out).to_string());
    a.extend(extra.iter().map(ToString::to_string));
    a
}

/// The sweep into `out` as a child process, both its outputs made by `stdio`.
fn spawn(out: &Path, stdio: fn() -> Stdio) -> Child {
    spawn_args(sweep(out, &[]), stdio)
}

fn spawn_args(args: Vec<String>, stdio: fn() -> Stdio) -> Child {
    Command::new(env!("CARGO_BIN_EXE_mapkeeper")).args(args).stdout(stdio()).stderr(stdio()).spawn().unwrap()
}

/// The same arguments with the updater timed (no `--no-timing`).
fn timed(args: Vec<String>) -> Vec<String> {
    args.into_iter().filter(|a| a != "--no-timing").collect()
}

/// Runs `args` as a child and kills it (SIGKILL) as soon as its first job's checkpoint is
/// written in `jobs`; returns that checkpoint's path.
fn kill_after_first_job(args: Vec<String>, jobs: &Path) -> PathBuf {
    let mut child = spawn_args(args, Stdio::null);
    let first = jobs.join("paper-s11.json");
    while !first.exists() {
        assert!(child.try_wait().unwrap().is_none(), "the run ended before it could be killed");
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    first
}

fn run(args: &[String]) -> Output {
    mapkeeper(&args.iter().map(String::as_str).collect::<Vec<_>>())
}

#[test]
fn a_killed_sweep_resumes_with_the_same_outputs() {
    let dir = scratch("resume", "sweep");
    let full = dir.join("full");
    let o = run(&sweep(&full, &[]));
    assert!(o.status.success(), "{}", text(&o));
    assert!(!dir.join(".full.jobs").exists(), "a finished run leaves no checkpoints");

    // Killed (SIGKILL) as soon as its first job is written.
    let part = dir.join("part");
    let jobs = dir.join(".part.jobs");
    let first = kill_after_first_job(sweep(&part, &[]), &jobs);
    assert!(!part.exists(), "a killed run leaves no output folder");
    let kept = dir.join("kept.json");
    std::fs::copy(&first, &kept).unwrap();

    let o = run(&sweep(&part, &["--resume"]));
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let done = t.lines().find(|l| l.contains("job(s) already done")).unwrap_or_else(|| panic!("{t}"));
    assert!(done.ends_with("of 4 job(s) already done") && !done.contains(": 0 of"), "{done}");
    assert!(t.contains(".part.partial: removed the incomplete folder"), "{t}");
    assert_eq!(files(&part), files(&full), "the resumed sweep differs from the uninterrupted one");
    assert!(!jobs.exists(), "the checkpoints are removed once the run is complete");

    // Complete: nothing to run; other flags on a complete folder are refused.
    let o = run(&sweep(&part, &["--resume"]));
    assert!(o.status.success() && text(&o).contains("is complete (--resume): nothing to run"), "{}", text(&o));
    let o = run(&sweep(&part, &["--resume", "--route-length", "12"]));
    assert!(!o.status.success() && text(&o).contains("holds a run with other parameters"), "{}", text(&o));
    assert_eq!(files(&part), files(&full));

    // A checkpoint of another run (other parameters) is refused, naming the file.
    let other = dir.join("other");
    std::fs::create_dir_all(dir.join(".other.jobs")).unwrap();
    std::fs::copy(&kept, dir.join(".other.jobs/paper-s11.json")).unwrap();
    let o = run(&sweep(&other, &["--resume", "--route-length", "12"]));
    let t = text(&o);
    assert!(!o.status.success(), "{t}");
    assert!(t.contains(".other.jobs/paper-s11.json") && t.contains("a run with other parameters"), "{t}");
    assert!(!other.exists());

    // A damaged checkpoint is refused, naming the file and what to do.
    std::fs::write(dir.join(".other.jobs/paper-s11.json"), "{\"format\": 1, \"fingerpr").unwrap();
    let o = run(&sweep(&other, &["--resume"]));
    let t = text(&o);
    assert!(!o.status.success() && t.contains("paper-s11.json: unreadable") && t.contains("remove it"), "{t}");

    // Without --resume a new run discards them, says so, and runs every job.
    std::fs::copy(&kept, dir.join(".other.jobs/paper-s11.json")).unwrap();
    let o = run(&sweep(&other, &[]));
    let t = text(&o);
    assert!(o.status.success() && t.contains("discarded 1 finished job(s) of an interrupted run"), "{t}");
    assert_eq!(files(&other), files(&full));
    assert!(!dir.join(".other.jobs").exists());

    // Timing is not in a checkpoint's fingerprint. A timed job resumed with --no-timing has
    // its times dropped: the outputs are the untimed run's, with no time in them.
    let mixed = dir.join("mixed");
    kill_after_first_job(timed(sweep(&mixed, &[])), &dir.join(".mixed.jobs"));
    let o = run(&sweep(&mixed, &["--resume"]));
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(files(&mixed), files(&full), "a timed job resumed with --no-timing left times in the outputs");
    // A complete untimed folder resumed with timing, and the reverse, are refused.
    let o = run(&timed(sweep(&mixed, &["--resume"])));
    let t = text(&o);
    assert!(!o.status.success() && t.contains("holds an untimed run") && t.contains("runs.json"), "{t}");
    // An untimed job resumed with timing is run again, with a note, so that every job has times.
    let retimed = dir.join("retimed");
    kill_after_first_job(sweep(&retimed, &[]), &dir.join(".retimed.jobs"));
    let o = run(&timed(sweep(&retimed, &["--resume"])));
    let t = text(&o);
    assert!(o.status.success() && t.contains("were run with --no-timing: run again, for their times"), "{t}");
    assert!(t.contains(": 0 of 4 job(s) already done"), "{t}");
    let o = run(&sweep(&retimed, &["--resume"]));
    let t = text(&o);
    assert!(!o.status.success() && t.contains("holds a timed run, and these flags ask for --no-timing"), "{t}");

    // --resume needs --out and does not go with --force.
    let o = mapkeeper(&["validate", "--resume"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let o = run(&sweep(&other, &["--resume", "--force"]));
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

/// `mapkeeper validate … | head -1`: the reader is gone when the run prints its tables; the run
/// still succeeds and writes its folder, and nothing panics.
#[test]
fn a_closed_standard_output_does_not_lose_the_run() {
    let dir = scratch("resume", "pipe");
    let out = dir.join("out");
    let mut child = spawn(&out, Stdio::piped);
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    for f in ["summary.json", "report.md", "paper/summary.json", "mapkeeper/runs.json"] {
        assert!(out.join(f).is_file(), "{f} missing: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Ctrl-C (SIGINT) stops a run as a kill does: no output folder, the finished jobs kept for
/// `--resume`, which completes the run. The progress lines say how long is left.
#[test]
fn ctrl_c_leaves_the_folder_as_a_killed_run_does() {
    use std::os::unix::process::ExitStatusExt as _;
    let dir = scratch("resume", "ctrl-c");
    let part = dir.join("part");
    let mut child = spawn(&part, Stdio::piped);
    let first = dir.join(".part.jobs").join("paper-s11.json");
    while !first.exists() {
        assert!(child.try_wait().unwrap().is_none(), "the run ended before it could be interrupted");
        std::thread::sleep(Duration::from_millis(2));
    }
    let pid = child.id().to_string();
    assert!(Command::new("kill").args(["-INT", &pid]).status().unwrap().success());
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.signal(), Some(2), "not ended by SIGINT: {}", text(&o));
    assert!(!part.exists(), "an interrupted run leaves no output folder");
    assert!(first.is_file(), "the finished job is kept");
    // Before the first world: what it runs, and an estimate with where it comes from.
    let t = text(&o);
    assert!(t.contains("validate: about ") && t.contains("left (from the reference machine's costs)"), "{t}");
    assert!(t.contains("Ctrl-C stops it as a kill does (--resume continues)"), "{t}");

    let o = run(&sweep(&part, &["--resume"]));
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains(".part.partial: removed the incomplete folder"), "{t}");
    let done = t.lines().find(|l| l.contains("job(s) already done")).unwrap_or_else(|| panic!("{t}"));
    assert!(!done.contains(": 0 of"), "{done}");
    // The lines printed as worlds finish: done/total and the time left from this run's worlds,
    // the share done rising.
    let lines: Vec<(u64, u64)> = t
        .lines()
        .filter(|l| l.contains(" worlds after ") && l.ends_with("left (from this run's world times)"))
        .map(|l| {
            let frac = l.trim_start_matches("validate: ").split(' ').next().unwrap();
            let (a, b) = frac.split_once('/').unwrap();
            (a.parse().unwrap(), b.parse().unwrap())
        })
        .collect();
    assert!(lines.len() >= 3, "{t}");
    assert!(lines.windows(2).all(|w| w[0].0 < w[1].0 && w[0].1 == w[1].1 && w[1].0 < w[1].1), "{lines:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// An absurd but accepted run (10,000 worlds × 100 seeds × 2 presets) says before its first
/// world that it would take weeks, and Ctrl-C then leaves nothing that looks complete.
#[test]
fn an_absurd_run_says_how_long_before_it_starts_and_stops_on_ctrl_c() {
    use std::io::{BufRead as _, BufReader};
    let dir = scratch("resume", "absurd");
    let out = dir.join("big");
    let mut child = Command::new(env!("CARGO_BIN_EXE_mapkeeper"))
        .args(["validate", "--worlds", "10000", "--seeds", "100", "--no-timing", "--out", s(&out)])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let stdout = child.stdout.take().unwrap();
    let estimate = BufReader::new(stdout)
        .lines()
        .map(Result::unwrap)
        .find(|l| l.contains(" left (from the reference machine's costs)"))
        .unwrap();
    let pid = child.id().to_string();
    assert!(Command::new("kill").args(["-INT", &pid]).status().unwrap().success());
    child.wait().unwrap();
    // 2 million worlds at seconds each on 2 threads: weeks.
    let days: u64 = estimate
        .split("about ")
        .nth(1)
        .and_then(|r| r.split(" days").next())
        .and_then(|d| d.parse().ok())
        .unwrap_or_else(|| panic!("not in days: {estimate}"));
    assert!(days > 14, "{estimate}");
    assert!(!out.exists(), "an interrupted run leaves no output folder");
    let _ = std::fs::remove_dir_all(&dir);
}
