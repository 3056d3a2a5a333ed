//! Long-run soak: a million processed dual scans (two corner lidars, 541 beams each) through
//! the map updater and the localiser on a synthetic scene, printing resident memory (VmRSS
//! from /proc/self/status) at intervals. Linux only; no simulator involved.
//!
//! The scene is a hand-built 14 × 20.9 m warehouse at 0.05 m with twelve box outlines (the map
//! `M_{i-1}`); the current world has five of them gone and five new ones, and every 20 laps the
//! world switches between that and the map's own layout, so the updater keeps adding and
//! removing cells for the whole run. The robot drives a 6 cm-per-step loop round the aisles;
//! scans are cast in the current world with the grid crate's ray caster once per lap and world,
//! then perturbed with fresh Gaussian noise (σ 1 cm) at every step. The localiser tracks from the
//! start pose on odometry equal to the truth and gets the updated map every 5,000 processed
//! steps; its estimate is the pose given to the updater.
//!
//! Run: `cargo run --release -p mapkeeper-localiser --example soak [-- --scans N --every K
//! --preset NAME]` (default N = 1,000,000 processed dual scans, a memory line every K = 50,000,
//! updater preset `mapkeeper`; any preset name of `UpdaterParams::preset`, e.g. `paper`). The first
//! line (0 processed) is the RSS before the scene is built; `wall_s` is elapsed wall time.
#![allow(clippy::disallowed_methods)] // an example times itself; the libraries read no clock
#![allow(missing_docs, clippy::unwrap_used)]

use mapkeeper_grid::{CellState, OccupancyGrid, Pose2, RayCaster, RayStop};
use mapkeeper_localiser::{FilterParams, Localiser};
use mapkeeper_sensor::LaserScan;
use mapkeeper_testkit::rooms::{fill_rect, walled_cells};
use mapkeeper_updater::{MapUpdater, StepOutcome, UpdaterParams};
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Resident set size, kB, from /proc/self/status.
fn vm_rss_kb() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let line = status.lines().find(|l| l.starts_with("VmRSS:")).unwrap();
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

/// A 14 × 20.9 m room with one-cell walls, free inside: 280 × 418 cells at 0.05 m.
fn room() -> OccupancyGrid {
    walled_cells(280, 418, 0.05, Pose2::IDENTITY)
}

fn box_positions() -> Vec<(f64, f64)> {
    (0..12).map(|k| (2.5 + (k % 3) as f64 * 3.6, 2.5 + (k / 3) as f64 * 4.5)).collect()
}

/// (map M_{i-1} with 12 box outlines, changed world: 5 gone, 5 new, 7 kept).
fn scene() -> (OccupancyGrid, OccupancyGrid) {
    let (mut map, mut world) = (room(), room());
    for (k, &(x, y)) in box_positions().iter().enumerate() {
        fill_rect(&mut map, x, y, x + 1.2, y + 1.0, CellState::Occupied);
        fill_rect(&mut map, x + 0.05, y + 0.05, x + 1.15, y + 0.95, CellState::Unknown);
        if k % 2 == 1 || k == 0 {
            fill_rect(&mut world, x, y, x + 1.2, y + 1.0, CellState::Occupied);
        } else {
            fill_rect(&mut world, x + 1.4, y + 1.7, x + 1.9, y + 2.2, CellState::Occupied);
        }
    }
    (map, world)
}

/// One closed loop round the aisles (x = 1.2 m and x = 12.8 m, y = 1.2 m and y = 19.7 m), 6 cm
/// a step, turning on the spot at the corners (10° a step).
fn lap() -> Vec<Pose2> {
    let corners = [(1.2, 1.2), (1.2, 19.7), (12.8, 19.7), (12.8, 1.2)];
    let mut poses = Vec::new();
    for k in 0..4 {
        let (x0, y0) = corners[k];
        let (x1, y1) = corners[(k + 1) % 4];
        let yaw = f64::atan2(y1 - y0, x1 - x0);
        if let Some(last) = poses.last().copied() {
            let last: Pose2 = last;
            let turn = mapkeeper_grid::angle_diff(yaw, last.yaw);
            let n = (turn.abs() / 10f64.to_radians()).ceil() as usize;
            for i in 1..n {
                poses.push(Pose2::new(x0, y0, mapkeeper_grid::wrap_angle(last.yaw + turn * i as f64 / n as f64)));
            }
        }
        let len = f64::hypot(x1 - x0, y1 - y0);
        let n = (len / 0.06).round() as usize;
        for i in 0..n {
            let t = i as f64 / n as f64;
            poses.push(Pose2::new(x0 + t * (x1 - x0), y0 + t * (y1 - y0), yaw));
        }
    }
    poses
}

/// The two SICK S300 mounts of the Summit-XL Steel (front-right, rear-left corners).
fn mounts() -> [Pose2; 2] {
    [Pose2::new(0.2865, -0.2089, -45f64.to_radians()), Pose2::new(-0.2865, 0.2089, 135f64.to_radians())]
}

/// The dual scan at `robot` in `world` (noise-free ranges; +inf for no return).
fn dual_scan(caster: &RayCaster, robot: Pose2) -> [LaserScan; 2] {
    let inc = 0.5f64.to_radians();
    let half = 135f64.to_radians();
    mounts().map(|m| {
        let lidar = robot.compose(&m);
        let ranges_m = (0..541)
            .map(|i| {
                let hit = caster.cast(lidar.position(), lidar.yaw - half + i as f64 * inc, 30.0);
                match hit.stop {
                    RayStop::Occupied | RayStop::Unknown => (hit.range_m + 0.005) as f32,
                    _ => f32::INFINITY,
                }
            })
            .collect();
        LaserScan {
            stamp_ns: 0,
            lidar_id: if m.x > 0.0 { 0 } else { 1 },
            lidar_in_robot: m,
            angle_min_rad: -half,
            angle_increment_rad: inc,
            range_min_m: 0.05,
            range_max_m: 30.0,
            ranges_m,
            sweep: None,
        }
    })
}

/// (N processed dual scans, memory line every K, updater preset) from the command line.
fn args() -> (u64, u64, String) {
    let mut target: u64 = 1_000_000;
    let mut every: u64 = 50_000;
    let mut preset = String::from("mapkeeper");
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--scans" => target = args.next().and_then(|n| n.parse().ok()).expect("--scans N"),
            "--every" => every = args.next().and_then(|n| n.parse().ok()).expect("--every K"),
            "--preset" => preset = args.next().expect("--preset NAME"),
            other => panic!("unknown argument {other}; usage: soak [--scans N] [--every K] [--preset NAME]"),
        }
    }
    (target, every, preset)
}

fn main() {
    let (target, every, preset) = args();
    let params = UpdaterParams::preset(&preset).unwrap_or_else(|e| panic!("--preset {preset}: {e}"));
    let rss_start = vm_rss_kb();
    let (map, changed) = scene();
    let poses = lap();
    // Scans of one lap in each world layout (the changed world, then the map's own layout).
    let laps: Vec<Vec<[LaserScan; 2]>> = [&changed, &map]
        .iter()
        .map(|w| {
            let caster = RayCaster::new(w, true);
            poses.iter().map(|p| dual_scan(&caster, *p)).collect()
        })
        .collect();

    let filter = FilterParams { min_particles: 200, max_particles: 1000, ..FilterParams::default() };
    let mut loc = Localiser::new(&map, filter, 7).unwrap();
    loc.init_pose(poses[0], [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.002]]).unwrap();
    let mut up = MapUpdater::new(map.clone(), params).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let noise = Normal::new(0.0f32, 0.01).unwrap();
    let mut scans: Vec<LaserScan> = laps[0][0].to_vec();

    println!(
        "soak: {target} processed dual scans, updater preset {preset}, lap of {} poses; map {} cells",
        poses.len(),
        map.cells().len()
    );
    let wall = std::time::Instant::now();
    println!(
        "{:>10} {:>10} {:>9} {:>12} {:>10} {:>9} {:>9} {:>7}",
        "processed", "calls", "rss_kB", "updater_B", "buffered", "changes", "pos_err_m", "wall_s"
    );
    println!("{:>10} {:>10} {:>9} {:>12} {:>10} {:>9} {:>9} {:>7}", 0, 0, rss_start, 0, 0, 0, "-", 0);
    let (mut calls, mut processed, mut max_err) = (0u64, 0u64, 0.0f64);
    let mut stamp_ns = 0u64;
    while processed < target {
        let lap_no = calls / poses.len() as u64;
        let k = (calls % poses.len() as u64) as usize;
        let world = ((lap_no / 20) % 2) as usize;
        let truth = poses[k];
        stamp_ns += 80_000_000;
        for (s, clean) in scans.iter_mut().zip(&laps[world][k]) {
            s.stamp_ns = stamp_ns;
            s.ranges_m.clear();
            s.ranges_m
                .extend(clean.ranges_m.iter().map(|&r| if r.is_finite() { r + noise.sample(&mut rng) } else { r }));
        }
        // Odometry equals the truth (the odometry frame is the map frame).
        let report = loc.update(truth, &scans);
        let estimate = report.estimate.pose_in_map;
        max_err = max_err.max(estimate.position().distance(truth.position()));
        let step = up.process(estimate, truth, &scans);
        calls += 1;
        if step.outcome == StepOutcome::Processed {
            processed += 1;
            if processed % 5_000 == 0 {
                loc.set_map(up.map());
            }
            if processed % every == 0 || processed == target {
                let st = up.stats();
                println!(
                    "{processed:>10} {calls:>10} {:>9} {:>12} {:>10} {:>9} {max_err:>9.3} {:>7.0}",
                    vm_rss_kb(),
                    up.state_bytes(),
                    up.buffered_cells(),
                    st.cell_changes,
                    wall.elapsed().as_secs_f64()
                );
                max_err = 0.0;
            }
        }
    }
    let st = up.stats();
    println!(
        "done: {} calls, {} processed, {} gated, updates {} / suspends {} / losts {}, {} cell changes",
        st.steps, st.processed, st.gated, st.updates, st.suspends, st.losts, st.cell_changes
    );
}
