//! Crash safety of the commands that write result folders (`validate`, a `validate` sweep,
//! `generate`, `recover`, `run`): each is killed (SIGKILL) at seeded points — after a delay, or
//! once its staging folder holds k files — and then:
//!
//! - the output folder either does not exist or is complete (the same files as an uninterrupted
//!   run; byte for byte where the command is deterministic);
//! - the next run into the same place reports what the killed run left (`mapkeeper: note: …
//!   interrupted run …`), removes it, and writes the complete folder; nothing hidden is left
//!   beside it;
//! - while a run is writing a folder, a second run into the same place is refused and names the
//!   writer's pid.
// Helpers outside `#[test]` functions unwrap too: a failure is a test failure.
#![allow(clippy::unwrap_used)]
#![allow(clippy::disallowed_methods)] // waits with deadlines: a test harness, not library code

mod common;

use common::{SHORT_RECOVER, files, s, scratch, validate_args};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn count_files(dir: &Path) -> usize {
    std::fs::read_dir(dir)
        .map_or(0, |d| d.flatten().map(|e| if e.path().is_dir() { count_files(&e.path()) } else { 1 }).sum())
}

/// The hidden staging folder and lock beside `out`.
fn hidden(out: &Path) -> [PathBuf; 2] {
    let name = out.file_name().unwrap().to_string_lossy();
    let parent = out.parent().unwrap();
    [parent.join(format!(".{name}.partial")), parent.join(format!(".{name}.partial.lock"))]
}

fn command(args: &[String]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_mapkeeper"));
    c.args(args).stdout(Stdio::null()).stderr(Stdio::piped());
    c
}

fn run_to_end(args: &[String]) -> Output {
    command(args).output().unwrap()
}

/// When to kill a run.
#[derive(Debug, Clone, Copy)]
enum KillAt {
    /// After this long.
    After(Duration),
    /// As soon as the staging folder holds this many files.
    Files(usize),
}

/// Runs `args` and kills it at `at`; returns whether it was killed (false: it ended first).
fn run_and_kill(args: &[String], out: &Path, at: KillAt) -> bool {
    let mut child = command(args).stderr(Stdio::null()).spawn().unwrap();
    let start = Instant::now();
    let [staging, _] = hidden(out);
    loop {
        if child.try_wait().unwrap().is_some() {
            return false;
        }
        let due = match at {
            KillAt::After(d) => start.elapsed() >= d,
            KillAt::Files(k) => count_files(&staging) >= k,
        };
        if due {
            child.kill().unwrap();
            let status = child.wait().unwrap();
            return !status.success();
        }
        assert!(start.elapsed() < Duration::from_secs(300), "{args:?} did not end");
        std::thread::sleep(Duration::from_millis(1));
    }
}

/// A small seeded generator for the kill points (SplitMix64).
struct Points(u64);

impl Points {
    fn next_unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// One command's crash-safety check: `make(out)` gives its arguments for output folder `out`;
/// `exact` whether two runs give the same bytes (otherwise only the same files).
fn check_command(name: &str, make: &dyn Fn(&Path) -> Vec<String>, exact: bool, seed: u64) {
    let dir = scratch("crash", name);
    let reference_out = dir.join("reference");
    let start = Instant::now();
    let o = run_to_end(&make(&reference_out));
    assert!(o.status.success(), "{name}: {}", String::from_utf8_lossy(&o.stderr));
    let took = start.elapsed();
    let reference = files(&reference_out);
    assert!(!reference.is_empty());
    let same = |got: &BTreeMap<String, Vec<u8>>| {
        if exact { got == &reference } else { got.keys().eq(reference.keys()) }
    };
    let out = dir.join("out");
    let mut points = Points(seed);
    let mut killed_with_leftover = 0;
    for trial in 0..4 {
        let at = if trial % 2 == 0 {
            KillAt::After(took.mul_f64(0.05 + 0.9 * points.next_unit()))
        } else {
            KillAt::Files(1 + (points.next_unit() * reference.len() as f64) as usize)
        };
        let _ = std::fs::remove_dir_all(&out);
        let killed = run_and_kill(&make(&out), &out, at);
        // The folder is absent or complete, never half-written.
        if out.exists() {
            assert!(same(&files(&out)), "{name} trial {trial} ({at:?}): {} exists but is incomplete", out.display());
        }
        let left = hidden(&out).iter().any(|p| p.exists());
        assert!(killed || !left, "{name} trial {trial}: ended normally but left {:?}", hidden(&out));
        if out.exists() {
            continue;
        }
        killed_with_leftover += usize::from(left);
        let o = run_to_end(&make(&out));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{name} trial {trial}: re-run failed: {err}");
        if left {
            assert!(
                err.contains("mapkeeper: note:") && err.contains("interrupted run"),
                "{name} trial {trial}: the leftover was not reported: {err}"
            );
        }
        assert!(same(&files(&out)), "{name} trial {trial}: the re-run's folder differs from the reference");
        for h in hidden(&out) {
            assert!(!h.exists(), "{name} trial {trial}: {} left after a complete run", h.display());
        }
    }
    assert!(killed_with_leftover > 0, "{name}: no trial killed the run while it was writing (the test tested nothing)");
    let _ = std::fs::remove_dir_all(&dir);
}

fn strings(args: &[&str]) -> Vec<String> {
    args.iter().map(ToString::to_string).collect()
}

#[test]
fn killed_validate_runs_leave_nothing_that_looks_complete() {
    let make = |out: &Path| {
        validate_args(&[
            "validate",
            "--worlds",
            "3",
            "--route-length",
            "6",
            "--no-timing",
            "--jobs",
            "1",
            "--out",
            s(out),
        ])
    };
    check_command("validate", &make, true, 11);
}

#[test]
fn killed_validate_sweeps_appear_whole_or_not_at_all() {
    let make = |out: &Path| {
        validate_args(&[
            "validate",
            "--worlds",
            "2",
            "--route-length",
            "6",
            "--no-timing",
            "--presets",
            "paper,no-update",
            "--out",
            s(out),
        ])
    };
    check_command("sweep", &make, true, 12);
}

#[test]
fn killed_generate_runs_leave_nothing_that_looks_complete() {
    let make = |out: &Path| strings(&["generate", "--worlds", "12", "--seed", "4", "--out", s(out)]);
    check_command("generate", &make, true, 13);
}

#[test]
fn killed_recover_and_run_leave_nothing_that_looks_complete() {
    let dir = scratch("crash", "inputs");
    let params = dir.join("short.toml");
    std::fs::write(&params, SHORT_RECOVER).unwrap();
    let make = |out: &Path| {
        strings(&["recover", "--trials", "1", "--seed", "2", "--no-best-case", "--params", s(&params), "--out", s(out)])
    };
    check_command("recover", &make, false, 14);

    let set = dir.join("set");
    let o = run_to_end(&strings(&["generate", "--worlds", "2", "--seed", "3", "--out", s(&set)]));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (world, map, route) =
        (set.join("worlds/W_002.toml"), set.join("ground_truth/G_001.yaml"), set.join("route.toml"));
    let make =
        |out: &Path| strings(&["run", "--world", s(&world), "--map", s(&map), "--route", s(&route), "--out", s(out)]);
    check_command("run", &make, false, 15);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_folder_being_written_is_refused_to_a_second_run() {
    let dir = scratch("crash", "concurrent");
    let out = dir.join("out");
    let args = validate_args(&[
        "validate",
        "--worlds",
        "3",
        "--route-length",
        "6",
        "--no-timing",
        "--jobs",
        "1",
        "--out",
        s(&out),
    ]);
    let mut first = command(&args).spawn().unwrap();
    let [_, lock] = hidden(&out);
    let start = Instant::now();
    while !lock.exists() {
        assert!(first.try_wait().unwrap().is_none(), "the first run ended before its lock was seen");
        assert!(start.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(1));
    }
    let second = run_to_end(&[args.clone(), strings(&["--force"])].concat());
    let err = String::from_utf8_lossy(&second.stderr);
    let first_still_running = first.try_wait().unwrap().is_none();
    if second.status.success() {
        // Only if the first run had finished in between (then --force replaced its folder).
        assert!(!first_still_running, "a second run wrote the folder the first was writing: {err}");
    } else {
        assert!(err.contains(&format!("another run (pid {})", first.id())), "{err}");
        assert_eq!(err.lines().count(), 1, "{err}");
    }
    let first = first.wait_with_output().unwrap();
    assert!(first.status.success(), "the first run failed: {}", String::from_utf8_lossy(&first.stderr));
    assert!(out.join("summary.json").is_file());
    let _ = std::fs::remove_dir_all(&dir);
}
