//! Every flag checked (issue 16): walks the commands of `mapkeeper --help`, the value-taking
//! flags of each `mapkeeper <cmd> --help`, and requires each to be classified below. Every
//! numeric flag gets NaN, infinities, negative, zero, huge and malformed values: each must be
//! refused at once with one line on stderr (`mapkeeper: error: …` naming the flag), nothing on
//! stdout, a non-zero exit and no output folder. Values the table accepts are not run (they
//! would start real work); they are only checked to pass parsing (a later unknown flag is
//! then the error).
#![allow(clippy::unwrap_used, clippy::too_many_lines)]
#![allow(clippy::disallowed_methods)] // timeouts and unique scratch names: a test harness, not library code

mod common;

use common::help_commands as commands;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// What a flag's value is.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    /// A whole number (count, seed, scale).
    Count,
    /// A real number.
    Real,
    /// `x,y,yaw`.
    Pose,
    /// `k/N`.
    Shard,
    /// `A-B` or `S1,S2,…`.
    SeedList,
    /// Comma-separated reals.
    RealList,
    /// A file or folder.
    Path,
    /// A preset name.
    Name,
    /// Comma-separated preset names.
    Names,
}

/// One value-taking flag: its command, its long name, its kind, the values of [`BAD`] it
/// legitimately accepts and why.
struct Flag {
    cmd: &'static str,
    flag: &'static str,
    kind: Kind,
    accepts: &'static [&'static str],
    why: &'static str,
}

const fn num(cmd: &'static str, flag: &'static str, kind: Kind) -> Flag {
    Flag { cmd, flag, kind, accepts: &[], why: "" }
}

const fn ok(
    cmd: &'static str,
    flag: &'static str,
    kind: Kind,
    accepts: &'static [&'static str],
    why: &'static str,
) -> Flag {
    Flag { cmd, flag, kind, accepts, why }
}

const fn other(cmd: &'static str, flag: &'static str, kind: Kind) -> Flag {
    Flag { cmd, flag, kind, accepts: &[], why: "" }
}

/// Seeds: every whole number from 0 to 2^64 − 1 names a valid random stream.
const SEED_OK: &[&str] = &["0", "99999999999"];
const SEED_WHY: &str = "every u64 is a valid seed";

use Kind::*;

/// Every value-taking flag of every command.
const FLAGS: &[Flag] = &[
    num("validate", "--worlds", Count),
    ok("validate", "--seed", Count, SEED_OK, SEED_WHY),
    num("validate", "--seeds", Count),
    other("validate", "--preset", Name),
    other("validate", "--updater-params", Path),
    other("validate", "--presets", Names),
    other("validate", "--localiser", Name),
    other("validate", "--ground-truth", Name),
    other("validate", "--out", Path),
    num("validate", "--jobs", Count),
    num("validate", "--route-length", Real),
    num("validate", "--shard", Shard),
    num("validate", "--update-every", Count),
    num("validate", "--fresh-map-every", Count),
    ok("validate", "--route-clearance", Real, &["0"], "edits may touch the route (0 m clearance)"),
    num("experiment check-detection", "--trials", Count),
    ok("experiment check-detection", "--seed", Count, SEED_OK, SEED_WHY),
    other("experiment check-detection", "--presets", Names),
    num("experiment check-detection", "--max-world", Count),
    other("experiment check-detection", "--localiser", Name),
    other("experiment check-detection", "--params", Path),
    other("experiment check-detection", "--out", Path),
    num("experiment check-detection", "--jobs", Count),
    num("experiment table1-held-pose", "--trials", Count),
    ok("experiment table1-held-pose", "--seed", Count, SEED_OK, SEED_WHY),
    other("experiment table1-held-pose", "--presets", Names),
    other("experiment table1-held-pose", "--localiser", Name),
    other("experiment table1-held-pose", "--params", Path),
    other("experiment table1-held-pose", "--out", Path),
    num("experiment table1-held-pose", "--jobs", Count),
    num("experiment kidnap-robot", "--trials", Count),
    ok("experiment kidnap-robot", "--seed", Count, SEED_OK, SEED_WHY),
    other("experiment kidnap-robot", "--preset", Name),
    other("experiment kidnap-robot", "--localiser", Name),
    other("experiment kidnap-robot", "--maps", Names),
    other("experiment kidnap-robot", "--params", Path),
    other("experiment kidnap-robot", "--out", Path),
    num("experiment kidnap-robot", "--jobs", Count),
    ok("recover", "--trials", Count, &["0"], "0 trials runs the demo, Table 1 and the lost robot only"),
    ok(
        "experiment recovery-suite",
        "--trials",
        Count,
        &["0"],
        "0 trials runs the demo, Table 1 and the lost robot only",
    ),
    ok("recover", "--seed", Count, SEED_OK, SEED_WHY),
    ok("experiment recovery-suite", "--seed", Count, SEED_OK, SEED_WHY),
    other("recover", "--out", Path),
    other("experiment recovery-suite", "--out", Path),
    num("recover", "--jobs", Count),
    num("experiment recovery-suite", "--jobs", Count),
    other("recover", "--localiser", Name),
    other("experiment recovery-suite", "--localiser", Name),
    other("recover", "--params", Path),
    other("experiment recovery-suite", "--params", Path),
    other("converge", "--localisers", Names),
    ok("converge", "--seeds", SeedList, &["0", "99999999999", "1,2"], "one seed (any u64) or a list of two"),
    ok("converge", "--errors", RealList, &["0", "1,2"], "start error 0 m is the reference case; a list of two"),
    num("converge", "--threshold", Real),
    ok("converge", "--hold", Real, &["0"], "hold 0 s: converged at the first scan below the threshold"),
    num("converge", "--max-time", Real),
    num("converge", "--route-length", Real),
    other("converge", "--params", Path),
    other("converge", "--out", Path),
    num("converge", "--jobs", Count),
    num("generate", "--worlds", Count),
    ok("generate", "--seed", Count, SEED_OK, SEED_WHY),
    other("generate", "--out", Path),
    num("generate", "--resolution", Real),
    other("run", "--world", Path),
    other("run", "--map", Path),
    other("run", "--baseline-map", Path),
    other("run", "--route", Path),
    other("run", "--preset", Name),
    other("run", "--params", Path),
    other("run", "--localiser", Name),
    ok("run", "--seed", Count, SEED_OK, SEED_WHY),
    ok("run", "--start-error", Real, &["0"], "start error 0 m: the localisers start at the true pose"),
    other("run", "--out", Path),
    other("merge", "--out", Path),
    other("check", "--baseline", Path),
    other("check", "--write-baseline", Path),
    num("bench", "--repeats", Count),
    num("bench", "--steps", Count),
    ok("bench", "--seed", Count, SEED_OK, SEED_WHY),
    other("bench", "--json", Path),
    other("simulate", "--world", Path),
    other("simulate", "--route", Path),
    num("simulate", "--seconds", Real),
    ok("simulate", "--seed", Count, SEED_OK, SEED_WHY),
    other("simulate", "--params", Path),
    other("simulate", "--out", Path),
    other("simulate", "--mcap", Path),
    other("convert", "--log", Path),
    other("convert", "--log-format", Name),
    other("convert", "--scan-topic", Name),
    other("convert", "--odom-topic", Name),
    other("convert", "--base-frame", Name),
    other("convert", "--odom-frame", Name),
    other("convert", "--truth-topic", Name),
    other("convert", "--stamp", Name),
    other("convert", "--carmen-kind", Name),
    other("convert", "--out", Path),
    other("experiment real-data", "--log", Path),
    other("experiment real-data", "--truth-topic", Name),
    other("experiment real-data", "--scan-topic", Name),
    other("experiment real-data", "--odom-topic", Name),
    other("experiment real-data", "--params", Path),
    other("experiment real-data", "--presets", Names),
    ok("experiment real-data", "--seed", Count, SEED_OK, SEED_WHY),
    num("experiment real-data", "--seeds", Count),
    num("experiment real-data", "--jobs", Count),
    other("experiment real-data", "--out", Path),
    other("experiment real-scans", "--log", Path),
    other("experiment real-scans", "--truth-topic", Name),
    other("experiment real-scans", "--scan-topic", Name),
    other("experiment real-scans", "--odom-topic", Name),
    other("experiment real-scans", "--map", Path),
    num("experiment real-scans", "--worlds", Count),
    ok("experiment real-scans", "--seed", Count, SEED_OK, SEED_WHY),
    num("experiment real-scans", "--seeds", Count),
    other("experiment real-scans", "--presets", Names),
    other("experiment real-scans", "--poses", Names),
    other("experiment real-scans", "--edit-params", Path),
    num("experiment real-scans", "--first-scans", Count),
    ok("experiment real-scans", "--kidnap-cuts", Count, &["0"], "0 runs no spliced kidnap"),
    other("experiment real-scans", "--kidnap-localisers", Names),
    num("experiment real-scans", "--jobs", Count),
    other("experiment real-scans", "--out", Path),
    other("experiment real-scans", "--time-source", Name),
    num("experiment real-scans", "--rate", Real),
    num("experiment real-scans", "--keep-every", Count),
    num("experiment real-scans", "--every-m", Real),
    other("map", "--log", Path),
    other("map", "--log-format", Name),
    other("map", "--scan-topic", Name),
    other("map", "--odom-topic", Name),
    other("map", "--base-frame", Name),
    other("map", "--odom-frame", Name),
    other("map", "--truth-topic", Name),
    other("map", "--stamp", Name),
    other("map", "--carmen-kind", Name),
    other("map", "--out", Path),
    num("map", "--resolution", Real),
    other("map", "--like", Path),
    other("map", "--params", Path),
    ok("map", "--no-return-clear-m", Real, &["0"], "0 m disables clearing along beams without a return"),
    ok("map", "--margin-m", Real, &["0"], "0 m: the map fits the observed area exactly"),
    ok("map", "--max-pose-gap-s", Real, &["0"], "0 s: only truth records at a scan's exact stamp"),
    other("localise", "--log", Path),
    other("localise", "--log-format", Name),
    other("localise", "--scan-topic", Name),
    other("localise", "--odom-topic", Name),
    other("localise", "--base-frame", Name),
    other("localise", "--odom-frame", Name),
    other("localise", "--truth-topic", Name),
    other("localise", "--stamp", Name),
    other("localise", "--carmen-kind", Name),
    other("localise", "--mcap", Path),
    other("localise", "--map", Path),
    other("localise", "--out", Path),
    num("localise", "--init", Pose),
    other("localise", "--localiser", Name),
    other("localise", "--params", Path),
    ok("localise", "--seed", Count, SEED_OK, SEED_WHY),
    other("update", "--map", Path),
    other("update", "--log", Path),
    other("update", "--log-format", Name),
    other("update", "--scan-topic", Name),
    other("update", "--odom-topic", Name),
    other("update", "--base-frame", Name),
    other("update", "--odom-frame", Name),
    other("update", "--truth-topic", Name),
    other("update", "--stamp", Name),
    other("update", "--carmen-kind", Name),
    other("update", "--mcap", Path),
    other("update", "--localiser", Name),
    other("update", "--localiser-params", Path),
    ok("update", "--seed", Count, SEED_OK, SEED_WHY),
    other("run", "--log", Path),
    other("run", "--mcap", Path),
    other("convert", "--time-source", Name),
    num("convert", "--rate", Real),
    num("convert", "--keep-every", Count),
    num("convert", "--every-m", Real),
    other("map", "--time-source", Name),
    num("map", "--rate", Real),
    num("map", "--keep-every", Count),
    num("map", "--every-m", Real),
    other("localise", "--time-source", Name),
    num("localise", "--rate", Real),
    num("localise", "--keep-every", Count),
    num("localise", "--every-m", Real),
    other("update", "--time-source", Name),
    num("update", "--rate", Real),
    num("update", "--keep-every", Count),
    num("update", "--every-m", Real),
    other("run", "--time-source", Name),
    num("run", "--rate", Real),
    num("run", "--keep-every", Count),
    num("run", "--every-m", Real),
    other("experiment real-data", "--time-source", Name),
    num("experiment real-data", "--rate", Real),
    num("experiment real-data", "--keep-every", Count),
    num("experiment real-data", "--every-m", Real),
    other("localise", "--scan-frame", Name),
    other("update", "--scan-frame", Name),
    other("map", "--scan-frame", Name),
    other("convert", "--scan-frame", Name),
    other("generate", "--logs", Name),
    num("validate", "--mcap-worlds", Count),
    num("validate", "--save-maps", Count),
    ok("validate", "--people-pause-s", Real, &["0"], "0 s: people never stop (the paper's setting)"),
    ok("generate", "--people-pause-s", Real, &["0"], "0 s: people never stop (the paper's setting)"),
    num("generate", "--jobs", Count),
    other("update", "--poses", Path),
    other("update", "--preset", Name),
    other("update", "--params", Path),
    ok("update", "--sync-window-s", Real, &["0"], "window 0 s: only scans with equal stamps form a step"),
    other("update", "--out", Path),
    ok("metrics", "--unknown-value", Real, &["0"], "unknown cells counted as free"),
    num("metrics", "--opdf-window-m", Real),
    other("node", "--params", Path),
    num("node", "--seconds", Real),
    other("node", "--figures", Path),
    other("node", "--replay", Path),
    other("render", "--out", Path),
    other("render", "--diff", Path),
    num("render", "--scale", Count),
    other("validate", "--robot", Path),
    other("validate", "--sensor-profile", Name),
    other("validate", "--sensor-effects", Names),
    other("simulate", "--robot", Path),
    other("simulate", "--sensor-profile", Name),
    other("simulate", "--sensor-effects", Names),
    other("run", "--robot", Path),
    other("run", "--sensor-profile", Name),
    other("run", "--sensor-effects", Names),
    other("validate", "--world", Path),
    other("validate", "--route", Path),
    other("generate", "--world", Path),
    other("generate", "--route", Path),
    other("recover", "--world", Path),
    other("experiment recovery-suite", "--world", Path),
    other("recover", "--route", Path),
    other("experiment recovery-suite", "--route", Path),
    other("experiment check-detection", "--world", Path),
    other("experiment check-detection", "--route", Path),
    other("experiment table1-held-pose", "--world", Path),
    other("experiment table1-held-pose", "--route", Path),
    other("experiment kidnap-robot", "--world", Path),
    other("experiment kidnap-robot", "--route", Path),
    other("import-map", "--out", Path),
    other("import-map", "--name", Name),
    ok("import-map", "--route-seed", Count, SEED_OK, SEED_WHY),
    num("experiment sensor-realism", "--worlds", Count),
    num("experiment sensor-realism", "--seeds", Count),
    ok("experiment sensor-realism", "--seed", Count, SEED_OK, SEED_WHY),
    other("experiment sensor-realism", "--preset", Name),
    num("experiment sensor-realism", "--route-length", Real),
    other("experiment sensor-realism", "--configs", Names),
    other("experiment sensor-realism", "--world", Path),
    other("experiment sensor-realism", "--route", Path),
    other("experiment sensor-realism", "--robot", Path),
    other("experiment sensor-realism", "--localiser", Name),
    other("experiment sensor-realism", "--params", Path),
    other("experiment sensor-realism", "--out", Path),
    num("experiment sensor-realism", "--jobs", Count),
    other("validate", "--poses", Name),
    ok("validate", "--pose-noise-xy-m", Real, &["0"], "σ 0 m: no position noise"),
    ok("validate", "--pose-noise-yaw-deg", Real, &["0"], "σ 0°: no white yaw noise"),
    ok("validate", "--pose-bias-yaw-deg", Real, &["0"], "σ 0°: no yaw bias"),
    num("validate", "--pose-bias-tau-s", Real),
    other("run", "--poses", Name),
    ok("run", "--pose-noise-xy-m", Real, &["0"], "σ 0 m: no position noise"),
    ok("run", "--pose-noise-yaw-deg", Real, &["0"], "σ 0°: no white yaw noise"),
    ok("run", "--pose-bias-yaw-deg", Real, &["0"], "σ 0°: no yaw bias"),
    num("run", "--pose-bias-tau-s", Real),
];

/// The bad values every scalar numeric flag gets (list flags accept "1,2").
const BAD: &[&str] =
    &["NaN", "nan", "inf", "-inf", "-1", "-0.5", "0", "1e308", "18446744073709551616", "99999999999", "abc", "", "1,2"];

/// Further bad values by kind: bad elements of poses, lists and shards, fractions of counts.
fn extra(kind: Kind) -> &'static [&'static str] {
    match kind {
        Count => &["2.5", "1e3", "+-1", " "],
        Real => &["-1e308", "-1e-300", "0x10", "1.5.2", "1_000"],
        Pose => &[
            "NaN,0,0",
            "0,nan,0",
            "0,0,inf",
            "-inf,0,0",
            "1e308,0,0",
            "0,99999999999,0",
            "0,0,90",
            "0,0,-7",
            "0,abc,0",
            "0,,0",
            "0,0,",
            "0,0,0,0",
            "18446744073709551616,0,0",
        ],
        Shard => {
            &["0/2", "3/2", "1/0", "-1/2", "1/-2", "1/18446744073709551616", "1/NaN", "a/b", "1.5/2", "1/2/3", "/"]
        }
        SeedList => &[
            "1,abc",
            "1,NaN",
            "1,-1",
            "1,,2",
            "1,",
            "1,1",
            "3-1",
            "1-",
            "-5",
            "0-18446744073709551615",
            "1-99999999999",
            "1,18446744073709551616",
            "1.5",
        ],
        RealList => {
            &["1,NaN", "0.5,inf", "0.5,-inf", "0.5,-1", "0.5,1e308", "0.5,", ",0.5", "0.5,abc", "0.5,99999999999"]
        }
        Path | Name | Names => &[],
    }
}

/// A scratch folder unique to this run (nothing is written in it by refused commands).
fn base() -> PathBuf {
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap().as_nanos();
    std::env::temp_dir().join(format!("mapkeeper-flags-cli-{}-{nanos}", std::process::id()))
}

/// The command's required arguments filled with harmless placeholders (paths that do not
/// exist: a flag's error must come before any file is read). `out` is the output path.
fn placeholders(cmd: &str, base: &Path, out: &Path) -> Vec<String> {
    let p = |name: &str| base.join(name).to_str().unwrap().to_string();
    let o = out.to_str().unwrap().to_string();
    let v: Vec<String> = match cmd {
        "validate"
        | "recover"
        | "experiment recovery-suite"
        | "converge"
        | "generate"
        | "simulate"
        | "experiment check-detection"
        | "experiment table1-held-pose"
        | "experiment kidnap-robot"
        | "experiment real-data"
        | "experiment real-scans"
        | "experiment sensor-realism" => vec!["--out".into(), o],
        "convert" => vec!["--log".into(), p("log"), "--out".into(), o],
        "run" => vec!["--world".into(), p("w.toml"), "--map".into(), p("m.yaml"), "--out".into(), o],
        "merge" => vec![p("dir"), "--out".into(), o],
        "check" => vec![p("dir"), "--write-baseline".into(), o],
        "bench" => vec!["--json".into(), o],
        "map" => vec!["--log".into(), p("log"), "--out".into(), o],
        "localise" | "update" => vec!["--log".into(), p("log"), "--map".into(), p("m.yaml"), "--out".into(), o],
        "metrics" => vec![p("a.yaml"), p("b.yaml")],
        "render" => vec![p("m.yaml"), "-o".into(), o],
        "import-map" => vec![p("m.yaml"), "--out".into(), o],
        "node" => vec!["--params".into(), p("node.yaml")],
        _ => panic!("command {cmd} has no placeholders in flags_cli.rs: add them"),
    };
    v
}

/// The result of one run: exit code (None if killed or by signal), stdout, stderr.
struct Ran {
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

/// Runs the binary, killing it (and failing) if it takes longer than 20 s.
fn run(args: &[String]) -> Ran {
    let mut child = Command::new(env!("CARGO_BIN_EXE_mapkeeper"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if start.elapsed() > Duration::from_secs(20) {
            child.kill().ok();
            child.wait().ok();
            panic!("mapkeeper {args:?} still running after 20 s (killed)");
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    // The outputs of a parse error are a few hundred bytes: they fit the pipes' buffers.
    let o = child.wait_with_output().unwrap();
    Ran {
        code: o.status.code(),
        stdout: String::from_utf8_lossy(&o.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&o.stderr).into_owned(),
    }
}

/// `mapkeeper [cmd] --help` on stdout.
fn help(cmd: Option<&str>) -> String {
    let mut args: Vec<String> = cmd.map(|c| c.split(' ').map(str::to_string).collect()).unwrap_or_default();
    args.push("--help".into());
    let r = run(&args);
    assert_eq!(r.code, Some(0), "{args:?}: {}", r.stderr);
    r.stdout
}

/// The value-taking flags of a command's help: option lines `  -o, --out <OUT.png>` or
/// `      --worlds <N>` of the Options section.
fn value_flags(help: &str) -> Vec<String> {
    let section = help.split("Options:\n").nth(1).expect("an Options: section");
    let mut flags = Vec::new();
    for line in section.lines() {
        if !line.is_empty() && !line.starts_with(' ') {
            break; // after_help text
        }
        let indent = line.len() - line.trim_start().len();
        let t = line.trim_start();
        if indent > 6 || !t.starts_with('-') {
            continue; // a description line
        }
        let mut words = t.split_whitespace().skip_while(|w| !w.starts_with("--"));
        if let (Some(flag), Some(value)) = (words.next(), words.next())
            && value.starts_with('<')
        {
            flags.push(flag.to_string());
        }
    }
    flags
}

/// Checks one refused value: one line naming the flag, non-zero exit, empty stdout, no output.
fn check_refused(flag: &str, args: &[String], out: &Path) {
    let r = run(args);
    let shown = format!("mapkeeper {}", args.join(" "));
    assert!(r.code.is_some_and(|c| c != 0), "{shown}: exit {:?}, stderr {}", r.code, r.stderr);
    assert!(r.stdout.is_empty(), "{shown}: stdout {:?}", r.stdout);
    let lines: Vec<&str> = r.stderr.lines().collect();
    assert!(
        lines.len() == 1 && r.stderr.ends_with('\n') && lines[0].starts_with("mapkeeper: error: "),
        "{shown}: stderr is not one error line: {:?}",
        r.stderr
    );
    assert!(lines[0].contains(flag), "{shown}: the error does not name {flag}: {}", lines[0]);
    assert!(!out.exists(), "{shown}: {} was created", out.display());
}

/// An accepted value passes parsing: a later unknown flag is the error.
fn check_parses(flag: &str, args: &[String], out: &Path) {
    let mut args = args.to_vec();
    args.push("--no-such-flag".into());
    let r = run(&args);
    let shown = format!("mapkeeper {}", args.join(" "));
    assert_eq!(r.code, Some(2), "{shown}: {}", r.stderr);
    assert!(
        r.stderr.lines().count() == 1 && r.stderr.contains("unexpected argument '--no-such-flag'"),
        "{shown}: {flag}'s value was not accepted: {}",
        r.stderr
    );
    assert!(!out.exists(), "{shown}: {} was created", out.display());
}

#[test]
fn every_numeric_flag_refuses_nan_infinite_negative_zero_huge_and_malformed_values() {
    let started = Instant::now();
    let base = base();
    let out = base.join("out");
    let table: BTreeMap<(&str, &str), &Flag> = FLAGS.iter().map(|f| ((f.cmd, f.flag), f)).collect();
    assert_eq!(table.len(), FLAGS.len(), "a flag is classified twice");
    for f in FLAGS {
        assert!(f.accepts.is_empty() || !f.why.is_empty(), "{} {}: accepted values need a reason", f.cmd, f.flag);
        assert!(f.accepts.iter().all(|a| BAD.contains(a)), "{} {}: accepts lists a value not tested", f.cmd, f.flag);
    }
    let top = commands(&help(None));
    assert!(top.len() >= 12 && top.iter().any(|c| c == "validate"), "{top:?}");
    // A command with subcommands of its own (`experiment`) is walked one level down.
    let mut cmds = Vec::new();
    for c in top {
        let h = help(Some(&c));
        if h.contains("Commands:\n") {
            cmds.extend(commands(&h).into_iter().map(|sub| format!("{c} {sub}")));
        } else {
            cmds.push(c);
        }
    }
    assert!(cmds.iter().any(|c| c == "experiment table1-held-pose"), "{cmds:?}");
    assert!(cmds.iter().any(|c| c == "experiment recovery-suite"), "{cmds:?}");
    let mut seen = BTreeSet::new();
    let (mut refused, mut accepted) = (0, 0);
    for cmd in &cmds {
        let flags = value_flags(&help(Some(cmd)));
        for flag in &flags {
            let Some(f) = table.get(&(cmd.as_str(), flag.as_str())) else {
                panic!("mapkeeper {cmd} {flag} is not classified in FLAGS (flags_cli.rs): add it with its kind");
            };
            seen.insert((f.cmd, f.flag));
            if matches!(f.kind, Path | Name | Names) {
                continue;
            }
            let scalar_bad = BAD.iter().copied();
            for value in scalar_bad.chain(extra(f.kind).iter().copied()) {
                for joined in [false, true] {
                    let mut args: Vec<String> = cmd.split(' ').map(str::to_string).collect();
                    args.extend(placeholders(cmd, &base, &out));
                    if joined {
                        args.push(format!("{flag}={value}"));
                    } else {
                        args.extend([flag.clone(), value.to_string()]);
                    }
                    if f.accepts.contains(&value) {
                        check_parses(flag, &args, &out);
                        accepted += 1;
                    } else {
                        check_refused(flag, &args, &out);
                        refused += 1;
                    }
                }
            }
        }
    }
    let stale: Vec<_> = table.keys().filter(|k| !seen.contains(*k)).collect();
    assert!(stale.is_empty(), "classified flags that no command's help lists: {stale:?}");
    assert!(!base.exists(), "{} was created", base.display());
    assert!(refused > 500, "only {refused} refused cases");
    eprintln!("{refused} refused and {accepted} accepted cases in {:.1} s", started.elapsed().as_secs_f64());
}

/// Clap's own errors are one line too; help and version still print in full with exit 0.
#[test]
fn clap_errors_are_one_line_and_help_is_not() {
    let base = base();
    let out = base.join("out");
    let o = out.to_str().unwrap().to_string();
    for (args, want) in [
        (vec!["generate".to_string()], "--out <DIR>"),
        (vec!["generate".into(), "--out".into(), o.clone(), "--forc".into()], "'--force'"),
        (vec!["generate".into(), "--out".into(), o.clone(), "--worlds".into()], "--worlds"),
        (vec!["nope".into()], "'nope'"),
        (vec!["run".into(), "--out".into(), o.clone()], "--world <NAME|FILE>"),
        (vec!["--versio".into()], "--version"),
    ] {
        let r = run(&args);
        assert_eq!(r.code, Some(2), "{args:?}");
        assert!(r.stdout.is_empty(), "{args:?}");
        let line = r.stderr.trim_end_matches('\n');
        assert!(
            !line.contains('\n') && line.starts_with("mapkeeper: error: ") && line.contains(want),
            "{args:?}: {line}"
        );
        assert!(line.ends_with("--help)"), "{args:?}: {line}");
    }
    for args in [vec!["--help"], vec!["--version"], vec!["generate", "--help"], vec!["render", "-h"]] {
        let args: Vec<String> = args.into_iter().map(str::to_string).collect();
        let r = run(&args);
        assert_eq!(r.code, Some(0), "{args:?}: {}", r.stderr);
        assert!(!r.stdout.is_empty() && r.stderr.is_empty(), "{args:?}");
    }
    let r = run(&[]);
    assert!(r.code == Some(2) && r.stderr.contains("Usage:"), "no subcommand: help on stderr, exit 2");
    assert!(!base.exists());
}
