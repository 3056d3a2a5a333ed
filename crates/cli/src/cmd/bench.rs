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

use anyhow::Context;
use mapkeeper_grid::{OccupancyGrid, Pose2, RayCaster};
use mapkeeper_harness::{SensorFrame, SensorSource};
use mapkeeper_localiser::{Covariance3, FilterParams, LOCALISER_PRESETS, Localiser};
use mapkeeper_scenario::{NoClock, RunInputs, SimSource, ValidationParams, build_initial_map, generate_worlds};
use mapkeeper_sim::{Route, Simulator, World, ground_truth_map};
use mapkeeper_updater::{MapUpdater, PRESET_NAMES, StepOutcome, UpdaterParams};
use serde::Serialize;
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `mapkeeper bench`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Prints a table: per row the median CPU time over the repeats, the spread (min-max), \
the ratio of the median to the reference's median (a fixed sort-and-arithmetic workload timed in \
every repeat, so ratios compare across machines and loads) and the throughput. CPU time is the \
calling thread's (CLOCK_THREAD_CPUTIME_ID); the closed loop's rows \
use the process's CPU time (CLOCK_PROCESS_CPUTIME_ID) (its baseline localiser runs on a thread of its own) and give the real-time \
factor (simulated seconds per CPU second and per wall second). A second table says what each localiser did on \
the scene (frames, sensor updates, particles after an update, beams per update, CPU per update), to compare \
with ROS amcl's behaviour.")]
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

/// One recorded step of the scene.
struct SceneStep {
    frame: SensorFrame,
    truth: Pose2,
}

/// The fixed scene every row runs on.
struct Scene {
    w2: World,
    route: Route,
    map: OccupancyGrid,
    steps: Vec<SceneStep>,
    params: ValidationParams,
}

/// One row of the table.
#[derive(Debug, Serialize)]
struct Row {
    /// What is timed.
    what: String,
    /// The unit `median`, `min` and `max` are in.
    unit: &'static str,
    median: f64,
    min: f64,
    max: f64,
    /// `median` over the reference's median time (both per repeat).
    ratio_to_reference: f64,
    /// Throughput, in `throughput_unit`.
    throughput: f64,
    throughput_unit: &'static str,
}

/// CPU seconds of the calling thread (`CLOCK_THREAD_CPUTIME_ID`: exact, not the scheduler's
/// tick-stale /proc figure).
fn thread_cpu_s() -> f64 {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::ThreadCPUTime);
    t.tv_sec as f64 + t.tv_nsec as f64 / 1e9
}

/// CPU seconds of the whole process, every thread (`CLOCK_PROCESS_CPUTIME_ID`).
fn process_cpu_s() -> f64 {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::ProcessCPUTime);
    t.tv_sec as f64 + t.tv_nsec as f64 / 1e9
}

/// Times `f` on the calling thread's CPU clock; returns (seconds, what `f` returned).
fn timed<T>(f: impl FnOnce() -> T) -> (f64, T) {
    let t0 = thread_cpu_s();
    let out = f();
    (thread_cpu_s() - t0, out)
}

/// The reference: a fixed workload of integer sorting and dependent floating-point arithmetic,
/// independent of the project's code, so that its time tracks the machine and its load only.
fn reference_workload() -> f64 {
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut v: Vec<u64> = (0..1 << 17)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        })
        .collect();
    v.sort_unstable();
    let mut acc = 0.0f64;
    for (i, &k) in v.iter().enumerate().step_by(4) {
        acc = (acc + (k >> 40) as f64).sqrt() + (i as f64).sin();
    }
    black_box(acc)
}

fn build_scene(seed: u64, steps: usize) -> anyhow::Result<Scene> {
    let params = ValidationParams::new(2, "paper")?;
    let w1 = World::default_warehouse();
    let chain = generate_worlds(&w1, &params.route, 2, seed, &params.generator)?;
    let geometry = w1.default_map_geometry(params.resolution_m)?;
    let map = ground_truth_map(&w1, &geometry);
    let (w2, route) = (chain.worlds[1].clone(), chain.routes[1].clone());
    let (_, recorded) = simulate(&w2, &route, &params, seed, steps)?;
    anyhow::ensure!(
        recorded.len() == steps,
        "the scene's route ends after {} steps; use --steps ≤ that",
        recorded.len()
    );
    Ok(Scene { w2, route, map, steps: recorded, params })
}

/// Drives `route` in `world` for `steps` lidar steps; (simulated seconds, the steps).
fn simulate(
    world: &World,
    route: &Route,
    params: &ValidationParams,
    seed: u64,
    steps: usize,
) -> anyhow::Result<(f64, Vec<SceneStep>)> {
    let mut sim = Simulator::new(world, params.runner.sim.clone(), seed)?;
    sim.set_route(route.points());
    let mut source = SimSource::new(sim, params.runner.max_sim_time_s);
    let mut out = Vec::with_capacity(steps);
    while out.len() < steps {
        let Some(step) = source.next_step()? else { break };
        let truth = step.truth.map_or(Pose2::new(0.0, 0.0, 0.0), |t| t.pose_in_map);
        out.push(SceneStep { frame: step.frame, truth });
    }
    Ok((source.sim_time_s(), out))
}

/// What a localiser preset did over the scene: the same in every repeat (same scene, same seed).
#[derive(Clone, Debug, Default)]
struct FilterWork {
    /// Frames handed to the filter (those with odometry).
    frames: usize,
    /// Particle count after each sensor update.
    particles: Vec<usize>,
    /// Beams used by each sensor update.
    beams: Vec<usize>,
}

fn run_localiser(scene: &Scene, name: &str, seed: u64) -> anyhow::Result<FilterWork> {
    let mut loc = Localiser::new(&scene.map, FilterParams::preset(name)?, seed)?;
    let first = scene.steps.first().context("empty scene")?;
    let cov: Covariance3 = [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.003]];
    loc.init_pose(first.truth, cov)?;
    let mut work = FilterWork::default();
    for s in &scene.steps {
        if let Some(odo) = s.frame.odometry {
            work.frames += 1;
            let r = loc.update(odo, &s.frame.scans);
            if r.sensor_update {
                work.particles.push(r.particles);
                work.beams.push(r.beams);
            }
        }
    }
    Ok(work)
}

fn run_updater(scene: &Scene, name: &str) -> anyhow::Result<usize> {
    let mut up = MapUpdater::new(scene.map.clone(), UpdaterParams::preset(name)?)?;
    let mut processed = 0;
    for s in &scene.steps {
        let report = up.process(s.truth, s.frame.odometry.unwrap_or(s.truth), &s.frame.scans);
        processed += usize::from(report.outcome == StepOutcome::Processed);
    }
    Ok(processed)
}

/// Pose recovery at every 40th step of the scene with the robot 5 m ahead of and turned half a
/// turn from where the estimate and the prediction say (a kidnap the local search cannot reach):
/// each step is Lost, the local search fails and the global search runs. Returns the attempts;
/// fails if the global search did not run or found no right pose on most of them.
fn run_global_recovery(scene: &Scene, up: &mut MapUpdater) -> anyhow::Result<usize> {
    let (mut attempts, mut searched, mut right) = (0, 0, 0);
    for s in scene.steps.iter().step_by(40) {
        let wrong = s.truth.compose(&Pose2::new(5.0, 0.0, std::f64::consts::PI));
        let odom = s.frame.odometry.unwrap_or(s.truth);
        up.reset_reference_pose(wrong, odom);
        let r = up.process(wrong, odom, &s.frame.scans);
        let Some(recovery) = r.pose_recovery else { continue };
        attempts += 1;
        searched += usize::from(r.global_search.is_some());
        if let mapkeeper_updater::PoseRecovery::Recovered { pose_in_map, .. } = recovery {
            right += usize::from(pose_in_map.distance(&s.truth) < 0.2);
        }
    }
    anyhow::ensure!(
        searched * 2 > attempts && right * 2 > attempts,
        "global recovery bench: {attempts} attempts, {searched} global searches, {right} right poses"
    );
    Ok(attempts)
}

/// Rays from every 10th true pose of the scene in 1,082 directions, 30 m, to the first occupied
/// or unknown cell; returns (rays, the sum of the ranges, to keep the work).
fn run_traversal(caster: &RayCaster, scene: &Scene) -> (usize, f64) {
    let mut rays = 0;
    let mut sum = 0.0;
    for s in scene.steps.iter().step_by(10) {
        for k in 0..1082 {
            let angle = k as f64 * std::f64::consts::TAU / 1082.0;
            sum += caster.cast(s.truth.position(), angle, 30.0).range_m;
            rays += 1;
        }
    }
    (rays, black_box(sum))
}

/// One closed-loop world with the default validation's runner for `preset`; (process CPU
/// seconds, wall seconds, simulated seconds).
fn run_loop(scene: &Scene, m1: &OccupancyGrid, preset: &str, seed: u64) -> anyhow::Result<(f64, f64, f64)> {
    let mut params = ValidationParams::new(2, preset)?;
    params.runner.set_localiser("amcl")?;
    let inputs = RunInputs { world: &scene.w2, route: &scene.route, prev_map: m1, baseline_map: m1, prev_memory: None };
    let start = Instant::now();
    let c0 = process_cpu_s();
    let run = mapkeeper_scenario::run_world(&inputs, &params.runner, seed, "bench", &NoClock)?;
    Ok((process_cpu_s() - c0, start.elapsed().as_secs_f64(), run.sim_time_s))
}

/// The rows being measured: (name, unit, throughput unit, scale of the unit in seconds,
/// samples).
struct Table {
    reference: Vec<f64>,
    rows: Vec<RowSpec>,
    /// Per localiser preset (in `LOCALISER_PRESETS` order), what it did on the scene.
    filters: Vec<FilterWork>,
}

struct RowSpec {
    name: String,
    unit: &'static str,
    throughput_unit: &'static str,
    /// Seconds per `unit`'s unit (1e-3 for ms, 1e-9 for ns).
    scale_s: f64,
    /// Per repeat: seconds per item.
    per_item_s: Vec<f64>,
    /// Per repeat: the throughput.
    throughput: Vec<f64>,
}

impl Table {
    fn add(&mut self, name: String, unit: &'static str, throughput_unit: &'static str, scale_s: f64) -> usize {
        self.rows.push(RowSpec {
            name,
            unit,
            throughput_unit,
            scale_s,
            per_item_s: Vec::new(),
            throughput: Vec::new(),
        });
        self.rows.len() - 1
    }

    fn push(&mut self, key: usize, per_item_s: f64, throughput: f64) {
        self.rows[key].per_item_s.push(per_item_s);
        self.rows[key].throughput.push(throughput);
    }
}

/// The median of a row's samples (0 for none; every row has one per repeat).
fn median(v: &[f64]) -> f64 {
    mapkeeper_scenario::stats::median(v.to_vec()).unwrap_or(0.0)
}

/// The rows of the table, in order.
struct Keys {
    sim: usize,
    localisers: Vec<usize>,
    updaters: Vec<usize>,
    traversal: usize,
    global: usize,
    /// (CPU row, wall row) per closed-loop preset.
    loops: Vec<(usize, usize)>,
}

/// The closed loop's presets: the default validation's.
const LOOP_PRESETS: [&str; 2] = ["paper", "mapkeeper"];

fn table_rows(table: &mut Table, with_loop: bool) -> Keys {
    let sim = table.add("simulator: one lidar step (physics, agents, both lidars)".into(), "ms", "steps/s", 1e-3);
    let localisers = LOCALISER_PRESETS
        .iter()
        .map(|n| table.add(format!("localiser `{n}`: one frame (both lidars)"), "ms", "frames/s", 1e-3))
        .collect();
    let updaters = PRESET_NAMES
        .iter()
        .map(|n| table.add(format!("updater `{n}`: one processed dual-S300 step"), "ms", "steps/s", 1e-3))
        .collect();
    let traversal = table.add("grid traversal: `RayCaster::cast`, W_1 truth, 30 m".into(), "ns/ray", "M rays/s", 1e-9);
    let global = table.add(
        "pose recovery when Lost, `mapkeeper`, kidnapped 5 m + half a turn: one attempt (local, then global search)"
            .into(),
        "ms",
        "attempts/s",
        1e-3,
    );
    let loops = if with_loop {
        LOOP_PRESETS
            .iter()
            .map(|n| {
                let cpu =
                    table.add(format!("closed loop `{n}` + amcl, one world: CPU per step"), "ms", "× real time", 1e-3);
                let wall =
                    table.add(format!("closed loop `{n}` + amcl, one world: wall per step"), "ms", "× real time", 1e-3);
                (cpu, wall)
            })
            .collect()
    } else {
        Vec::new()
    };
    Keys { sim, localisers, updaters, traversal, global, loops }
}

/// One repeat of every component row (not the loop).
fn measure_components(
    scene: &Scene,
    caster: &RayCaster,
    seed: u64,
    table: &mut Table,
    keys: &Keys,
) -> anyhow::Result<()> {
    let n = scene.steps.len();
    let (t, recorded) = timed(|| simulate(&scene.w2, &scene.route, &scene.params, seed, n));
    recorded?;
    table.push(keys.sim, t / n as f64, n as f64 / t);
    for (i, (&key, name)) in keys.localisers.iter().zip(LOCALISER_PRESETS).enumerate() {
        let (t, work) = timed(|| run_localiser(scene, name, seed));
        table.filters[i] = work?;
        table.push(key, t / n as f64, n as f64 / t);
    }
    for (&key, name) in keys.updaters.iter().zip(PRESET_NAMES) {
        let (t, processed) = timed(|| run_updater(scene, name));
        let processed = processed?.max(1);
        table.push(key, t / processed as f64, processed as f64 / t);
    }
    let (t, (rays, _)) = timed(|| run_traversal(caster, scene));
    table.push(keys.traversal, t / rays as f64, rays as f64 / t / 1e6);
    let mut up = MapUpdater::new(scene.map.clone(), UpdaterParams::mapkeeper())?;
    let (t, attempts) = timed(|| run_global_recovery(scene, &mut up));
    let attempts = attempts?.max(1);
    table.push(keys.global, t / attempts as f64, attempts as f64 / t);
    Ok(())
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
    let keys = table_rows(&mut table, m1.is_some());
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

fn print_table(rows: &[Row], table: &Table, repeats: usize, steps: usize) {
    let reference = median(&table.reference);
    outln!(
        "mapkeeper bench: {steps}-step scene, {repeats} repeat(s); reference workload median {:.2} ms CPU\n",
        reference * 1e3
    );
    outln!("| what | median | min-max | × reference | throughput |");
    outln!("|---|---|---|---|---|");
    for r in rows {
        outln!(
            "| {} | {:.4} {} | {:.4}-{:.4} | {} | {:.1} {} |",
            r.what,
            r.median,
            r.unit,
            r.min,
            r.max,
            significant(r.ratio_to_reference),
            r.throughput,
            r.throughput_unit
        );
    }
}

/// What each localiser did on the scene, beside ROS amcl's own behaviour: how many frames led to
/// a sensor update (`update_min_d` / `update_min_a`), how many particles it carried after one
/// (KLD sampling after convergence) and how many beams it weighted, and the CPU per update.
fn print_filter_work(rows: &[Row], keys: &Keys, filters: &[FilterWork], steps: usize) {
    outln!("\nWhat each localiser did on the scene (the same in every repeat):\n");
    outln!(
        "| localiser | frames | sensor updates | particles after an update: median / max | beams per update: median | CPU per update |"
    );
    outln!("|---|---|---|---|---|---|");
    for ((&key, name), w) in keys.localisers.iter().zip(LOCALISER_PRESETS).zip(filters) {
        let updates = w.particles.len();
        let per_update = match rows.get(key) {
            Some(r) if updates > 0 => format!("{:.3} ms", r.median * steps as f64 / updates as f64),
            _ => "-".into(),
        };
        outln!(
            "| `{name}` | {} | {updates} | {} / {} | {} | {per_update} |",
            w.frames,
            median_count(&w.particles),
            w.particles.iter().max().copied().unwrap_or(0),
            median_count(&w.beams),
        );
    }
}

/// The median of counts (the lower middle of an even count; 0 when empty).
fn median_count(v: &[usize]) -> usize {
    let mut v = v.to_vec();
    v.sort_unstable();
    v.get(v.len().saturating_sub(1) / 2).copied().unwrap_or(0)
}

/// Four significant digits, in scientific notation below 0.001.
fn significant(v: f64) -> String {
    if v != 0.0 && v.abs() < 1e-3 { format!("{v:.3e}") } else { format!("{v:.4}") }
}
