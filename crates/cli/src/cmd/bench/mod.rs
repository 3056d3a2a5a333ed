//! `mapkeeper bench`: CPU time per scan of every part of the closed loop on fixed scenes, as
//! medians over repeats and as ratios to a fixed reference workload timed in the same run
//! (docs/benchmarks.md). Timing lives here, in the command line; the libraries never read a
//! clock.
//!
//! The scene: W_2 of the default chain (seed `--seed`) on the embedded warehouse, its first
//! `--steps` lidar steps recorded once from the simulator (scans, odometry, true poses); the map
//! every estimator is given is the exact ground truth of W_1 (so the updater sees W_2's edits as
//! changes). Each repeat times, in this order: the reference, the simulator producing the steps,
//! each localiser preset over the steps, each updater preset over the steps at the true poses,
//! grid traversal from the route, and (unless `--no-loop`) the closed loop of one whole world per
//! updater preset of the default validation.

pub(crate) mod clock;
mod print;
mod rows;
mod scene;
mod table;

// The parts share their items through this module (each part reads `use super::*`).
use anyhow::Context;
use clock::*;
use mapkeeper_closed_loop::{NoClock, RunInputs, SimSource, build_initial_map, generate_worlds};
use mapkeeper_grid::mapper::LogOddsMapper;
use mapkeeper_grid::{OccupancyGrid, Pose2, RayCaster};
use mapkeeper_harness::jobs::map::{BeamCounts, integrate_scan};
use mapkeeper_harness::{SensorFrame, SensorSource};
use mapkeeper_localiser::{Covariance3, FilterParams, LOCALISER_PRESETS, Localiser};
use mapkeeper_scenario::ValidationParams;
use mapkeeper_sim::{Route, Simulator, World, ground_truth_map};
use mapkeeper_updater::{MapUpdater, PRESET_NAMES, StepOutcome, UpdaterParams};
use print::*;
use rows::*;
use scene::*;
use serde::Serialize;
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;
use table::*;

/// Arguments of `mapkeeper bench`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Prints a table: per row the median CPU time over the repeats, the spread (min-max), \
the ratio of the median to the reference's median (a fixed sort-and-arithmetic workload timed in \
every repeat, so ratios compare across machines and loads) and the throughput. CPU time is the \
calling thread's (CLOCK_THREAD_CPUTIME_ID); the closed loop's rows \
use the process's CPU time (CLOCK_PROCESS_CPUTIME_ID) (its baseline localiser runs on a thread of its own) and give the real-time \
factor (simulated seconds per CPU second and per wall second). A second table says what each localiser did on \
the scene (frames, sensor updates, particles after an update, beams per update; the CPU per update as the \
row's CPU over the updates and as the median update's own, and per weighted particle and beam), to compare \
with ROS amcl's behaviour and with each other.")]
pub struct Args {
    /// Repeats of every measurement, 1 to 1000; medians are over these.
    #[arg(long, value_name = "N", default_value_t = 5, value_parser = super::count_in(1, 1000), allow_hyphen_values = true)]
    pub repeats: usize,
    /// Lidar steps of the recorded scene (12.5 per simulated second), 10 to 100000.
    #[arg(long, value_name = "N", default_value_t = 400, value_parser = super::count_in(10, 100_000), allow_hyphen_values = true)]
    pub steps: usize,
    /// Seed of the scene: the world chain, the simulator, the filters (any whole number from 0
    /// to 2^64 − 1).
    #[arg(long, value_name = "S", default_value_t = 11, value_parser = super::seed, allow_hyphen_values = true)]
    pub seed: u64,
    /// Skip the closed-loop rows (a whole world per preset per repeat: the slow part).
    #[arg(long)]
    pub no_loop: bool,
    /// Also write the table as JSON to this file (written whole or not at all; an existing
    /// file is refused before anything is measured, unless --force).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Replace an existing --json file.
    #[arg(long)]
    pub force: bool,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(path) = &args.json {
        mapkeeper_grid::check_output_file(path, args.force).context("--json")?;
    }
    errln!("bench: recording the scene ({} steps, seed {})", args.steps, args.seed);
    let scene = build_scene(args.seed, args.steps)?;
    let m1 = if args.no_loop {
        None
    } else {
        let p = &scene.params;
        let w1 = World::default_warehouse();
        let geometry = w1.default_map_geometry(p.resolution_m)?;
        Some(build_initial_map(&w1, &p.exploration_route, &geometry, &p.runner.sim, &p.mapping, args.seed)?.map)
    };
    let mut table = Table {
        reference: Vec::new(),
        rows: Vec::new(),
        filters: vec![FilterWork::default(); LOCALISER_PRESETS.len()],
    };
    let fresh = scene.params.runner.fresh_map.context("the validation's runner makes no fresh map")?;
    let keys = table_rows(&mut table, m1.is_some(), fresh.scan_stride);
    let caster = RayCaster::new(&scene.map, true);
    for r in 0..args.repeats {
        errln!("bench: repeat {} of {}", r + 1, args.repeats);
        table.reference.push(timed(reference_workload).0);
        measure_components(&scene, &caster, args.seed, &mut table, &keys)?;
        if let Some(m1) = &m1 {
            for (&(cpu_row, wall_row), preset) in keys.loops.iter().zip(LOOP_PRESETS) {
                let (cpu, wall, sim_s) = run_loop(&scene, m1, preset, args.seed)?;
                let steps = sim_s * 12.5;
                table.push(cpu_row, cpu / steps, sim_s / cpu);
                table.push(wall_row, wall / steps, sim_s / wall);
            }
        }
    }
    let rows = finish(&table);
    print_table(&rows, &table, args.repeats, args.steps);
    print_filter_work(&rows, &keys, &table.filters, scene.steps.len());
    if let Some(path) = &args.json {
        let json = serde_json::to_string_pretty(&rows).context("bench table")?;
        mapkeeper_grid::write_atomic(path, (json + "\n").as_bytes())
            .with_context(|| format!("--json {}", path.display()))?;
    }
    Ok(())
}

fn finish(table: &Table) -> Vec<Row> {
    let reference = median(&table.reference);
    table
        .rows
        .iter()
        .map(|r| {
            let per = median(&r.per_item_s);
            let lo = r.per_item_s.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = r.per_item_s.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            Row {
                what: r.name.clone(),
                unit: r.unit,
                median: per / r.scale_s,
                min: lo / r.scale_s,
                max: hi / r.scale_s,
                ratio_to_reference: if reference > 0.0 { per / reference } else { 0.0 },
                throughput: median(&r.throughput),
                throughput_unit: r.throughput_unit,
            }
        })
        .collect()
}
