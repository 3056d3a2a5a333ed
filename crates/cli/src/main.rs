//! The `mapkeeper` command line: argument parsing and glue only. Each subcommand lives in its
//! own module under `cmd/`; the work is done by the library crates.
// The wall clock is read here only (progress, `bench`, `wall_time_s`); `clippy.toml` forbids it
// in the libraries.
#![allow(clippy::disallowed_methods)]

use clap::error::ErrorKind;
use clap::{CommandFactory, Parser, Subcommand};
use std::process::ExitCode;

/// `print!` to standard output that never panics: a reader that went away
/// (`mapkeeper … | head`) ends the printing, not the run, whose files are still written. Other
/// write errors are reported once on standard error.
macro_rules! out {
    ($($t:tt)*) => { crate::write_stream(false, format_args!($($t)*)) };
}

/// `println!` that never panics (see `out!`).
macro_rules! outln {
    () => { crate::write_stream(false, format_args!("\n")) };
    ($($t:tt)*) => { crate::write_stream(false, format_args!("{}\n", format_args!($($t)*))) };
}

/// `eprintln!` that never panics (see `out!`).
macro_rules! errln {
    ($($t:tt)*) => { crate::write_stream(true, format_args!("{}\n", format_args!($($t)*))) };
}

mod cmd;

/// Writes to standard output (or error), ignoring a closed pipe and reporting any other error
/// once, on standard error (the run goes on: its results are its files).
fn write_stream(to_stderr: bool, args: std::fmt::Arguments<'_>) {
    use std::io::Write as _;
    use std::sync::atomic::{AtomicBool, Ordering};
    static REPORTED: AtomicBool = AtomicBool::new(false);
    let result =
        if to_stderr { std::io::stderr().lock().write_fmt(args) } else { std::io::stdout().lock().write_fmt(args) };
    if let Err(e) = result
        && e.kind() != std::io::ErrorKind::BrokenPipe
        && !to_stderr
        && !REPORTED.swap(true, Ordering::Relaxed)
    {
        let _ = writeln!(std::io::stderr(), "mapkeeper: note: cannot write to standard output: {e}");
    }
}

/// Safe and robust lifelong map updating (Stefanini et al., Sensors 2023) with a headless 2D
/// warehouse testbed.
#[derive(Parser, Debug)]
#[command(name = "mapkeeper", version, about, long_about = None, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// The hundred-world validation of the paper (§5.3.2) on the embedded default warehouse.
    Validate(cmd::validate::Args),
    /// The recovery suite (= `experiment recovery-suite`): localisation-check demo, Table 1 with a start error, lost robot, kidnaps of the estimate.
    Recover(cmd::recover::Args),
    /// One experiment of the paper's claims into a folder of its own (recovery-suite, check-detection, table1-held-pose, kidnap-robot, real-data, sensor-realism).
    Experiment(cmd::experiment::Args),
    /// How long the localiser presets take to correct a start error (time and distance).
    Converge(cmd::converge::Args),
    /// Write a seeded scenario set (worlds, ground-truth maps, route, manifest).
    Generate(cmd::generate::Args),
    /// One world end to end: simulate, localise, update; write the updated map and trajectories.
    Run(cmd::run::Args),
    /// Combine result folders (e.g. shards of a sweep) into one summary.
    Merge(cmd::merge::Args),
    /// Compare a validation's results with a stored baseline: pass / fail for a team's CI.
    Check(cmd::check::Args),
    /// CPU time per scan of the simulator, localisers, updaters, grid traversal and the closed loop.
    Bench(cmd::bench::Args),
    /// Simulate a world and write a sensor log, the true trajectory and the ground-truth map.
    Simulate(cmd::simulate::Args),
    /// Build an occupancy map from a sensor log at the logged true poses.
    Map(cmd::map::Args),
    /// Run the particle-filter localiser over a sensor log.
    Localise(cmd::localise::Args),
    /// Convert a recorded log (ROS 2 MCAP, ROS 1 bag, CARMEN) into the project's sensor log.
    Convert(cmd::convert::Args),
    /// Run the map updater over recorded data (scans and poses or odometry) and a map.
    Update(cmd::update::Args),
    /// CC, MS and OPDF between two ROS map_server maps.
    Metrics(cmd::metrics::Args),
    /// Render a map, or the difference of two maps, as a PNG.
    Render(cmd::render::Args),
    /// Turn a ROS map (map_server YAML + PGM/PNG) into a world file with storage areas and a route.
    ImportMap(cmd::import_map::Args),
    /// Run the map updater live as a ROS 2 node (keeps Nav2's map up to date).
    Node(cmd::node::Args),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return clap_error(&e),
    };
    let result = match cli.command {
        Command::Validate(a) => cmd::validate::run(a),
        Command::Recover(a) => cmd::recover::run(a),
        Command::Experiment(a) => cmd::experiment::run(a),
        Command::Converge(a) => cmd::converge::run(a),
        Command::Generate(a) => cmd::generate::run(a),
        Command::Run(a) => cmd::run::run(a),
        Command::Merge(a) => cmd::merge::run(a),
        Command::Check(a) => match cmd::check::run(a) {
            Ok(true) => Ok(()),
            Ok(false) => return ExitCode::from(1),
            Err(e) => {
                errln!("mapkeeper: error: {}", one_line(&e));
                return ExitCode::from(2);
            }
        },
        Command::Bench(a) => cmd::bench::run(a),
        Command::Simulate(a) => cmd::simulate::run(a),
        Command::Map(a) => cmd::map::run(a),
        Command::Localise(a) => cmd::localise::run(a),
        Command::Convert(a) => cmd::convert::run(a),
        Command::Update(a) => cmd::update::run(a),
        Command::Metrics(a) => cmd::metrics::run(a),
        Command::Render(a) => cmd::render::run(a),
        Command::ImportMap(a) => cmd::import_map::run(a),
        Command::Node(a) => cmd::node::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            errln!("mapkeeper: error: {}", one_line(&e));
            ExitCode::FAILURE
        }
    }
}

/// A command-line error: help and version as clap prints them (exit 0; help for a missing
/// subcommand exit 2, as clap does), anything else as one line naming the flag, exit 2.
fn clap_error(e: &clap::Error) -> ExitCode {
    match e.kind() {
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            // Printing help can fail only on a closed stdout/stderr; nothing is left to report then.
            let _ = e.print();
            ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2))
        }
        _ => {
            let cmd = subcommand_name(std::env::args_os().skip(1));
            let see = cmd.map_or_else(|| "mapkeeper --help".to_string(), |c| format!("mapkeeper {c} --help"));
            errln!("mapkeeper: error: {} (see {see})", clap_message(&e.to_string()));
            ExitCode::from(2)
        }
    }
}

/// The subcommand named on the command line, if any (the first argument that is one).
fn subcommand_name(args: impl Iterator<Item = std::ffi::OsString>) -> Option<String> {
    let cli = Cli::command();
    let arg = args.map(|a| a.to_string_lossy().into_owned()).find(|a| !a.starts_with('-'))?;
    cli.get_subcommands().any(|c| c.get_name() == arg).then_some(arg)
}

/// Clap's rendered error on one line: its message (the first paragraph, e.g. `invalid value
/// 'NaN' for '--resolution <METRES>': …` or `the following required arguments were not
/// provided: --out <DIR>`) and its tips, without the `error: ` prefix, the usage and the help
/// hint.
fn clap_message(rendered: &str) -> String {
    let mut paragraphs = rendered.split("\n\n").map(|p| p.split_whitespace().collect::<Vec<_>>().join(" "));
    let first = paragraphs.next().unwrap_or_default();
    let mut line = first.strip_prefix("error: ").unwrap_or(&first).to_string();
    for tip in paragraphs.filter(|p| p.starts_with("tip: ")) {
        line.push_str("; ");
        line.push_str(&tip);
    }
    line
}

/// The error and its causes on one line, leaving out a cause whose text the line already holds
/// (library errors name their file and include their cause in their own message).
fn one_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line.replace('\n', " ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clap_errors_become_one_line() {
        let e = Cli::try_parse_from(["mapkeeper", "generate", "--resolution", "NaN", "--out", "x"]).unwrap_err();
        assert_eq!(
            clap_message(&e.to_string()),
            "invalid value 'NaN' for '--resolution <METRES>': must be a finite number from 0.005 m to 10 m, got NaN"
        );
        let e = Cli::try_parse_from(["mapkeeper", "generate"]).unwrap_err();
        assert_eq!(clap_message(&e.to_string()), "the following required arguments were not provided: --out <DIR>");
        let e = Cli::try_parse_from(["mapkeeper", "generate", "--forc"]).unwrap_err();
        let m = clap_message(&e.to_string());
        assert!(m.starts_with("unexpected argument '--forc' found; tip: ") && m.contains("'--force'"), "{m}");
        let args = ["generate", "--out", "x"].map(std::ffi::OsString::from);
        assert_eq!(subcommand_name(args.into_iter()), Some("generate".to_string()));
        assert_eq!(subcommand_name(["--nope"].map(std::ffi::OsString::from).into_iter()), None);
        assert_eq!(subcommand_name(["bogus"].map(std::ffi::OsString::from).into_iter()), None);
    }

    #[test]
    fn causes_already_in_the_message_are_not_repeated() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file");
        let e = anyhow::Error::new(io).context("m.yaml: No such file").context("cannot load map m.yaml");
        assert_eq!(one_line(&e), "cannot load map m.yaml: m.yaml: No such file");
        let e = anyhow::anyhow!("two\nlines");
        assert_eq!(one_line(&e), "two lines");
    }
}
