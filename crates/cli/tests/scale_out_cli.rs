//! The local scale-out recipe `docs/scale-out/local-shards.sh`: a sweep run as shards through
//! `xargs -P` and merged equals the unsharded sweep file for file, and a re-run after a killed
//! shard runs only that shard. The Slurm array task `docs/scale-out/slurm-array.sh`, run as
//! Slurm runs each task (the scheduler itself is run by `docs/scale-out/slurm-single-node.sh`,
//! outside the tests), shards and merges the same way.
#![allow(clippy::unwrap_used)]

mod common;

use common::{files, s, scratch};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/scale-out/local-shards.sh")
}

fn recipe(args: &[&str]) -> Output {
    Command::new("bash").arg(script()).args(args).env("MAPKEEPER", env!("CARGO_BIN_EXE_mapkeeper")).output().unwrap()
}

fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

const SWEEP: [&str; 13] = [
    "--presets",
    "paper,no-update",
    "--localiser",
    "mapkeeper",
    "--seed",
    "1",
    "--seeds",
    "2",
    "--worlds",
    "2",
    "--route-length",
    "6",
    "--no-timing",
];

/// The sweep run whole into `dir/whole`, the folder the merged shards must equal.
fn unsharded(dir: &Path) -> PathBuf {
    let whole = dir.join("whole");
    let mut args = vec!["validate"];
    args.extend(SWEEP);
    args.extend(["--out", s(&whole)]);
    let o = Command::new(env!("CARGO_BIN_EXE_mapkeeper")).args(&args).output().unwrap();
    assert!(o.status.success(), "{}", text(&o));
    whole
}

#[test]
fn shards_through_xargs_merge_into_the_unsharded_sweep_and_resume_skips_complete_shards() {
    let dir = scratch("scale-out", "sweep");
    let whole = unsharded(&dir);

    // Four jobs (preset × seed) in three shards, two processes at a time.
    let out = dir.join("sharded");
    let mut args = vec!["3", "2", s(&out)];
    args.extend(SWEEP);
    let o = recipe(&args);
    assert!(o.status.success(), "{}", text(&o));
    assert!(!text(&o).contains("skipped"), "{}", text(&o));
    assert_eq!(files(&out.join("all")), files(&whole), "merged shards differ from the unsharded sweep");

    // Shard 2 killed while writing: only its staging folder (a half-written file) and lock file
    // are left. The re-run runs shard 2 alone, reporting and removing the leftover.
    let kept = files(&out.join("shards/1"));
    std::fs::remove_dir_all(out.join("shards/2")).unwrap();
    let staging = out.join("shards/.2.partial");
    std::fs::create_dir_all(staging.join("paper")).unwrap();
    std::fs::write(staging.join("paper/runs.json"), "{\"format\": \"mapkeeper-vali").unwrap();
    std::fs::write(out.join("shards/.2.partial.lock"), "").unwrap();
    let o = recipe(&args);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("shard 1/3: complete, skipped") && t.contains("shard 3/3: complete, skipped"), "{t}");
    assert!(!t.contains("shard 2/3: complete"), "{t}");
    assert!(t.contains(".2.partial: removed the incomplete folder"), "{t}");
    assert!(!staging.exists() && !out.join("shards/.2.partial.lock").exists());
    assert_eq!(files(&out.join("shards/1")), kept);
    assert_eq!(files(&out.join("all")), files(&whole), "the resumed sweep differs from the unsharded one");

    // The same OUT with other arguments would mix two sweeps: refused, nothing run.
    let mut other = vec!["3", "2", s(&out)];
    other.extend(SWEEP);
    other.extend(["--seeds", "3"]);
    let o = recipe(&other);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("holds shards of another sweep"), "{}", text(&o));
    assert_eq!(files(&out.join("all")), files(&whole));

    // --force would defeat the resume: refused.
    let mut forced = vec!["3", "2", s(&out)];
    forced.extend(SWEEP);
    forced.push("--force");
    let o = recipe(&forced);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("drop --force"), "{}", text(&o));

    // Bad counts are refused with the usage.
    for bad in [["x", "2"], ["3", ""], ["0", "1"], ["2", "-1"]] {
        let o = recipe(&[bad[0], bad[1], s(&dir.join("bad"))]);
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        assert!(!dir.join("bad").exists());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Runs `docs/scale-out/slurm-array.sh` with the environment Slurm gives array task `task`.
fn slurm_task(task: Option<&str>, out: &Path) -> Output {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/scale-out/slurm-array.sh");
    let mut c = Command::new("bash");
    c.arg(script)
        .env("MAPKEEPER", env!("CARGO_BIN_EXE_mapkeeper"))
        .env("OUT", out)
        .env("SHARDS", "2")
        .env("VALIDATE_ARGS", SWEEP.join(" "))
        .env("SLURM_CPUS_PER_TASK", "1")
        .env_remove("SLURM_ARRAY_TASK_ID");
    if let Some(k) = task {
        c.env("SLURM_ARRAY_TASK_ID", k);
    }
    c.output().unwrap()
}

#[test]
fn slurm_array_tasks_shard_the_sweep_and_a_resubmitted_task_skips_its_complete_shard() {
    let dir = scratch("scale-out", "slurm");
    let whole = unsharded(&dir);

    let out = dir.join("sweep");
    for k in ["1", "2"] {
        let o = slurm_task(Some(k), &out);
        assert!(o.status.success(), "{}", text(&o));
        assert!(text(&o).contains(&format!("shard {k}/2")), "{}", text(&o));
    }
    // The dependent merge job's command.
    let (a, b) = (out.join("shards/1"), out.join("shards/2"));
    let o = Command::new(env!("CARGO_BIN_EXE_mapkeeper"))
        .args(["merge", s(&a), s(&b), "--out", s(&out.join("all")), "--force"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(files(&out.join("all")), files(&whole), "merged Slurm shards differ from the unsharded sweep");

    // A re-submitted task whose shard is complete exits at once, leaving it as it is.
    let kept = files(&a);
    let o = slurm_task(Some("1"), &out);
    assert!(o.status.success() && text(&o).contains("shard 1/2: complete, skipped"), "{}", text(&o));
    assert_eq!(files(&a), kept);

    // Outside an array job: refused, nothing written.
    let o = slurm_task(None, &dir.join("none"));
    assert!(!o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("run as an array job"), "{}", text(&o));
    assert!(!dir.join("none").exists());
    let _ = std::fs::remove_dir_all(&dir);
}
