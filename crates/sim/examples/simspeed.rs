//! Throughput in CPU time (user + system of this process, from /proc/self/stat), for a busy
//! machine where criterion's wall-clock medians are inflated by other processes.
//!
//! Run: `cargo run --release -p mapkeeper-sim --example simspeed` (Linux only).

use mapkeeper_sim::{Route, SimParams, Simulator, World};

/// CPU seconds used by this process so far (Linux /proc; 0 elsewhere).
fn cpu_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|s| s.parse::<f64>().ok()).unwrap_or(0.0);
    // Fields 14 and 15 (utime, stime) are at 11 and 12 after the command name; 100 ticks/s.
    (ticks(11) + ticks(12)) / 100.0
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let world = World::default_warehouse();
    let mut sim = Simulator::new(&world, SimParams::default(), 1)?;
    let n = 3000;
    let t0 = cpu_s();
    let mut sum = 0.0f64;
    for _ in 0..n {
        for s in sim.scan_now() {
            sum += f64::from(s.ranges_m[270].min(100.0));
        }
    }
    let dt = cpu_s() - t0;
    println!(
        "dual S300 scans: {n} in {dt:.2} CPU s = {:.0} dual scans/s = {:.2} M rays/s (checksum {sum:.1})",
        n as f64 / dt,
        n as f64 * 1082.0 / dt / 1e6
    );
    let mut sim = Simulator::new(&world, SimParams::default(), 2)?;
    let route = Route::default_warehouse().points();
    sim.set_route(route.clone());
    let seconds = 120;
    let t0 = cpu_s();
    for _ in 0..seconds * 50 {
        if sim.step().route_done {
            sim.set_route(route.clone());
        }
    }
    let dt = cpu_s() - t0;
    println!(
        "simulation with both lidars: {seconds} simulated s in {dt:.2} CPU s = {:.0} × real time",
        seconds as f64 / dt
    );
    let params = SimParams { lidars: vec![], ..SimParams::default() };
    let mut sim = Simulator::new(&world, params, 3)?;
    sim.set_route(route.clone());
    let t0 = cpu_s();
    for _ in 0..seconds * 50 {
        if sim.step().route_done {
            sim.set_route(route.clone());
        }
    }
    let dt = cpu_s() - t0;
    println!(
        "physics + follower + agents only: {seconds} simulated s in {dt:.2} CPU s = {:.0} µs per step",
        dt / (seconds as f64 * 50.0) * 1e6
    );
    Ok(())
}
