//! Real kidnaps from the shared CARMEN logs (issue 52, item 4): for each log, G is the map at
//! the reference poses (real-data's mapper parameters) and a stale map is G with a seeded edit
//! (boxes put on free cells near the path, patches of wall erased); `run_real_kidnap` on both,
//! for `paper`, `authors` and `mapkeeper`, prints the summaries, every trial, and the wall time
//! per trial (with `--jobs 1`, the CPU time of one trial).
//!
//! ```sh
//! cargo run --release -p mapkeeper-scenario --example real_kidnap -- \
//!     [--cuts 20] [--seeds 1] [--seed 52] [--jobs 1] [--logs intel,aces,freiburg-079] [--localiser mapkeeper-real]
//! ```
//!
//! `--debug CUT:MAP:PRESET` (e.g. `--logs intel --debug 3:truth:paper`) prints that trial's spliced
//! run step by step instead: the updater's rows with the estimate's error, and pose updating's
//! attempts.
#![allow(clippy::disallowed_methods)] // an example times itself; the libraries read no clock

use mapkeeper_common::stream_rng;
use mapkeeper_grid::mapper::MapperParams;
use mapkeeper_grid::{CellState, OccupancyGrid, Point2};
use mapkeeper_harness::jobs::map::{MapLogParams, map_log};
use mapkeeper_harness::{LogSource, ReplayOptions};
use mapkeeper_scenario::experiments::real_scans::kidnap::{
    RealKidnapParams, RealKidnapResults, run_real_kidnap, trial_seed,
};
use mapkeeper_scenario::experiments::real_scans::splice::{REFERENCE_GAP_NS, referenced_scans};
use mapkeeper_scenario::experiments::reference::Dataset;
use rand::RngExt;
use std::time::Instant;

/// G with `boxes` squares of 0.3-0.6 m put on free cells within 3 m of the reference path
/// (objects since removed) and `holes` 1 m squares of occupied cells made free (objects since
/// added): a stale map of the place, seeded.
fn stale(g: &OccupancyGrid, log: &mapkeeper_sensor::SensorLog, seed: u64, boxes: usize, holes: usize) -> OccupancyGrid {
    let mut m = g.clone();
    let mut rng = stream_rng(seed, "real-kidnap-example/stale");
    let path = referenced_scans(log);
    let geo = *g.geometry();
    let res = geo.resolution_m();
    let square = |m: &mut OccupancyGrid, c: Point2, half: f64, from: CellState, to: CellState| {
        let n = (half / res).ceil() as i64;
        for dy in -n..=n {
            for dx in -n..=n {
                let p = Point2::new(c.x + dx as f64 * res, c.y + dy as f64 * res);
                if let Some(cell) = geo.world_to_cell(p)
                    && m.get(cell) == Some(from)
                {
                    m.set(cell, to);
                }
            }
        }
    };
    let mut put = 0;
    for _ in 0..boxes * 100 {
        if put == boxes || path.is_empty() {
            break;
        }
        let at = path[rng.random_range(0..path.len())].pose;
        let (r, a) = (rng.random_range(1.0..3.0), rng.random_range(-std::f64::consts::PI..std::f64::consts::PI));
        let c = Point2::new(at.x + r * a.cos(), at.y + r * a.sin());
        if m.get_world(c) == Some(CellState::Free) {
            square(&mut m, c, rng.random_range(0.15..0.3), CellState::Free, CellState::Occupied);
            put += 1;
        }
    }
    let occupied: Vec<usize> = (0..m.cells().len()).filter(|&i| g.cells()[i] == CellState::Occupied).collect();
    for _ in 0..holes.min(occupied.len()) {
        let c = geo.cell_center(geo.coord(occupied[rng.random_range(0..occupied.len())]));
        square(&mut m, c, 0.5, CellState::Occupied, CellState::Free);
    }
    m
}

/// `--debug CUT:MAP:PRESET`: one trial's spliced run, step by step (the updater's rows with the
/// estimate's error), and its pose-updating attempts.
fn debug(dataset: &Dataset, maps: &[(&str, &OccupancyGrid)], p: &RealKidnapParams, seed: u64, spec: &str) {
    use mapkeeper_harness::jobs::update::{PoseInput, update_log};
    use mapkeeper_harness::{DEFAULT_SYNC_WINDOW_NS, NoClock, OdometryAt};
    let f: Vec<&str> = spec.split(':').collect();
    let (Some(cut), Some(map), Some(preset)) = (f.first().and_then(|c| c.parse::<usize>().ok()), f.get(1), f.get(2))
    else {
        panic!("--debug CUT:MAP:PRESET, got {spec}")
    };
    let draws =
        mapkeeper_scenario::experiments::real_scans::splice::draw_cuts(&dataset.log, &dataset.name, &p.cuts, seed)
            .unwrap_or_else(|e| panic!("{e}"));
    let d = draws[cut];
    let reference: Vec<mapkeeper_sensor::StampedPose> = dataset
        .log
        .truth()
        .map(|t| mapkeeper_sensor::StampedPose { stamp_ns: t.stamp_ns, pose: t.pose_in_map })
        .collect();
    let init = mapkeeper_sensor::interpolate(&reference, d.window_start_ns).unwrap_or_else(|| panic!("no reference"));
    let spliced = d.spliced(&dataset.log).unwrap_or_else(|e| panic!("{e}"));
    let sref: Vec<mapkeeper_sensor::StampedPose> =
        spliced.truth().map(|t| mapkeeper_sensor::StampedPose { stamp_ns: t.stamp_ns, pose: t.pose_in_map }).collect();
    let options = ReplayOptions {
        odometry_at: OdometryAt::Interpolated,
        sync_window_ns: DEFAULT_SYNC_WINDOW_NS,
        ..ReplayOptions::default()
    };
    let m = maps.iter().find(|(n, _)| n == map).map(|(_, m)| (*m).clone()).unwrap_or_else(|| panic!("no map {map}"));
    let input = PoseInput::Localise {
        params: Box::new(mapkeeper_localiser::FilterParams::preset(&p.localisers[0]).unwrap_or_else(|e| panic!("{e}"))),
        seed: trial_seed(seed, cut, 0),
        init: Some(init),
    };
    let up = mapkeeper_updater::UpdaterParams::preset(preset).unwrap_or_else(|e| panic!("{e}"));
    let run = update_log(LogSource::new(spliced, "debug", options), m, up, input, &NoClock, &mut [])
        .unwrap_or_else(|e| panic!("{e}"));
    println!("cut {cut}: {d:?}");
    println!(
        "steps: time_s,outcome,verdict,n,n_invalid,n_dc,cells_changed,recovery,us | error_m yaw_deg (estimate vs reference)"
    );
    for (row, e) in run.steps_csv.lines().skip(1).zip(&run.poses) {
        let r = mapkeeper_sensor::interpolate(&sref, e.stamp_ns).unwrap_or_else(|| panic!("no reference"));
        let mark = if e.stamp_ns > d.cut.start_ns { "after" } else { "before" };
        println!(
            "{row} | {:.3} {:.1} {mark}",
            e.pose.distance(&r),
            mapkeeper_grid::angle_diff(e.pose.yaw, r.yaw).to_degrees()
        );
    }
    println!("recoveries:\n{}", run.recoveries_csv);
    println!("lost: {:?}", run.lost_episodes);
}

fn arg<T: std::str::FromStr>(args: &[String], name: &str, default: T) -> T {
    args.iter().position(|a| a == name).and_then(|k| args.get(k + 1)).and_then(|v| v.parse().ok()).unwrap_or(default)
}

/// The log `name` of `../shared` with G and the stale map; `None` (with a note) if absent.
fn load(name: &str, seed: u64) -> Option<(Dataset, OccupancyGrid, OccupancyGrid)> {
    let rel = format!("data/carmen/{name}-corrected.log.gz");
    let path = mapkeeper_common::shared_data::path(&rel, "the real_kidnap example")?;
    let imported = mapkeeper_logs::read_log(&path, None, &mapkeeper_logs::ImportOptions::default())
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    let dataset = Dataset { name: name.to_string(), source: path.display().to_string(), log: imported.log };
    let mapper =
        MapLogParams { mapper: MapperParams::default(), no_return_clear_m: 0.0, resolution_m: 0.05, margin_m: 1.0 };
    let options = ReplayOptions { max_truth_gap_ns: REFERENCE_GAP_NS, ..ReplayOptions::default() };
    let g = map_log(LogSource::new(dataset.log.clone(), name, options), None, &mapper)
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .map;
    let m1 = stale(&g, &dataset.log, seed, 30, 30);
    Some((dataset, g, m1))
}

/// One table row per summary.
fn print_summaries(name: &str, r: &RealKidnapResults) {
    for s in &r.summaries {
        let pct = |x: f64| format!("{:.0} %", 100.0 * x);
        let opt = |x: Option<f64>| x.map_or("–".into(), |v| format!("{v:.1}"));
        println!(
            "| {name} | {} | {} | {} | {} | {} | {} | {} | {} ({}) | {} | {} | {} / {} | {} / {} | {:?} | {:?} |",
            s.map,
            s.preset,
            s.trials,
            pct(s.recovered_rate),
            pct(s.recovered_by_pose_updating_rate),
            pct(s.detected_rate),
            pct(s.wrong_rate),
            s.pose_recoveries,
            s.wrong_poses,
            pct(s.false_lost_rate),
            pct(s.unspliced_off_rate),
            opt(s.median_recover_s),
            opt(s.p90_recover_s),
            opt(s.median_recover_scans),
            opt(s.p90_recover_scans),
            s.ends,
            s.refusals
        );
    }
}

/// The cuts and one line per trial.
fn trial_lines(r: &RealKidnapResults) -> String {
    let mut out = String::new();
    for d in &r.cuts {
        out.push_str(&format!(
            "  cut {}: {:.1}-{:.1} s, jump {:.2} m turn {:.0}°, window {} + {} scans\n",
            d.index,
            d.cut.start_ns as f64 * 1e-9,
            d.cut.end_ns as f64 * 1e-9,
            d.jump_m,
            d.turn_rad.to_degrees(),
            d.scans_before,
            d.scans_after
        ));
    }
    let round = |x: Option<f64>, k: f64| x.map(|v| (v * k).round() / k);
    for t in &r.trials {
        out.push_str(&format!(
            "  cut {} {} {}: {} ({:?} s, {:?} scans; first error {:.2} m, final {:.2} m / {:.1}°), Lost {} \
(after the cut: {:?} s), poses {} wrong {}, refusals {:?}, steps after the cut {:?}; unspliced Lost {} (error then \
{:?}), max error {:.2} m\n",
            t.cut,
            t.map,
            t.preset,
            t.end.name(),
            round(t.recovery.recover_s, 100.0),
            t.recovery.recover_scans,
            t.recovery.first_error_m.unwrap_or(f64::NAN),
            t.recovery.final_error_m.unwrap_or(f64::NAN),
            t.recovery.final_yaw_error_deg.unwrap_or(f64::NAN),
            t.lost_episodes,
            round(t.lost_delay_s, 100.0),
            t.pose_recoveries,
            t.wrong_poses,
            t.refusals,
            t.steps_after_cut,
            t.unspliced_lost_episodes,
            round(t.unspliced_first_lost_error_m, 1000.0),
            t.unspliced_max_error_m
        ));
    }
    out
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = arg(&args, "--seed", 52);
    let jobs: usize = arg(&args, "--jobs", 1);
    let logs: String = arg(&args, "--logs", "intel,aces,freiburg-079".to_string());
    let pool = rayon::ThreadPoolBuilder::new().num_threads(jobs).build().unwrap_or_else(|e| panic!("{e}"));
    let mut p = RealKidnapParams {
        seeds_per_cut: arg(&args, "--seeds", 1),
        localisers: vec![arg(&args, "--localiser", "mapkeeper-real".to_string())],
        ..RealKidnapParams::default()
    };
    p.cuts.count = arg(&args, "--cuts", 20);
    println!(
        "| log | map | preset | trials | recovered | by pose updating | Lost after the cut | wrong | poses (wrong) | false Lost | unspliced off ≥ 0.3 m | recover median / p90 s | scans | ends | refusals |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut details = String::new();
    for name in logs.split(',') {
        let t0 = Instant::now();
        let Some((dataset, g, m1)) = load(name, seed) else { continue };
        let prep = t0.elapsed().as_secs_f64();
        let maps = [("stale", &m1), ("truth", &g)];
        if let Some(spec) = args.iter().position(|a| a == "--debug").and_then(|k| args.get(k + 1)) {
            debug(&dataset, &maps, &p, seed, spec);
            continue;
        }
        let t1 = Instant::now();
        let r = pool
            .install(|| run_real_kidnap(&dataset, &maps, &p, seed, &|| {}))
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let wall = t1.elapsed().as_secs_f64();
        print_summaries(name, &r);
        let steps: usize = r.trials.iter().map(|t| t.steps + t.unspliced_steps).sum();
        details.push_str(&format!(
            "\n{name}: read + map {prep:.1} s; {} trials in {wall:.1} s on {jobs} thread(s): {:.3} s per trial \
(spliced + unspliced run), {:.1} ms per step\n",
            r.trials.len(),
            wall / r.trials.len().max(1) as f64,
            1e3 * wall / steps.max(1) as f64
        ));
        details.push_str(&trial_lines(&r));
    }
    println!("{details}");
}
