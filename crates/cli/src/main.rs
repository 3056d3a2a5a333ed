//! The `mapkeeper` command line: argument parsing and glue only. Each subcommand lives in its
//! own module under `cmd/`; the work is done by the library crates.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod cmd;

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
    /// The robustness experiments: localisation-check demo, Table 1, lost robot, kidnap suite.
    Recover(cmd::recover::Args),
    /// How long the localiser presets take to correct a start error (time and distance).
    Converge(cmd::converge::Args),
    /// Write a seeded scenario set (worlds, ground-truth maps, route, manifest).
    Generate(cmd::generate::Args),
    /// One world end to end: simulate, localise, update; write the updated map and trajectories.
    Run(cmd::run::Args),
    /// Combine result folders (e.g. shards of a sweep) into one summary.
    Merge(cmd::merge::Args),
    /// Simulate a world and write a sensor log, the true trajectory and the ground-truth map.
    Simulate(cmd::simulate::Args),
    /// Build an occupancy map from a sensor log at the logged true poses.
    Map(cmd::map::Args),
    /// Run the particle-filter localiser over a sensor log.
    Localise(cmd::localise::Args),
    /// Run the map updater over recorded data (scans and poses or odometry) and a map.
    Update(cmd::update::Args),
    /// CC, MS and OPDF between two ROS map_server maps.
    Metrics(cmd::metrics::Args),
    /// Render a map, or the difference of two maps, as a PNG.
    Render(cmd::render::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Validate(a) => cmd::validate::run(a),
        Command::Recover(a) => cmd::recover::run(a),
        Command::Converge(a) => cmd::converge::run(a),
        Command::Generate(a) => cmd::generate::run(a),
        Command::Run(a) => cmd::run::run(a),
        Command::Merge(a) => cmd::merge::run(a),
        Command::Simulate(a) => cmd::simulate::run(a),
        Command::Map(a) => cmd::map::run(a),
        Command::Localise(a) => cmd::localise::run(a),
        Command::Update(a) => cmd::update::run(a),
        Command::Metrics(a) => cmd::metrics::run(a),
        Command::Render(a) => cmd::render::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("mapkeeper: error: {}", one_line(&e));
            ExitCode::FAILURE
        }
    }
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
    fn causes_already_in_the_message_are_not_repeated() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file");
        let e = anyhow::Error::new(io).context("m.yaml: No such file").context("cannot load map m.yaml");
        assert_eq!(one_line(&e), "cannot load map m.yaml: m.yaml: No such file");
        let e = anyhow::anyhow!("two\nlines");
        assert_eq!(one_line(&e), "two lines");
    }
}
