//! The real robot's upside-down lidars end to end (issue 13, item 4): the simulated S300 pair
//! mounted upside down produces mirrored scans (negative angle increment), and the closed loop
//! (localiser and updater, which only see the scans) localises and updates the map as well as
//! with the upright pair.

use mapkeeper_closed_loop::{NoClock, RunInputs, RunnerParams, WorldRun, run_world};
use mapkeeper_grid::{CellState, OccupancyGrid};
use mapkeeper_scenario::ValidationParams;
use mapkeeper_sim::{RobotFile, World, ground_truth_map};
use std::path::Path;

/// Cells whose state differs between `a` and `b` (same geometry).
fn differing(a: &OccupancyGrid, b: &OccupancyGrid) -> usize {
    a.cells().iter().zip(b.cells()).filter(|(x, y)| x != y).count()
}

fn occupied(a: &OccupancyGrid) -> usize {
    a.cells().iter().filter(|c| **c == CellState::Occupied).count()
}

#[test]
fn upside_down_lidars_localise_and_map_like_upright_ones() {
    // The map shows a world with every movable item; the robot drives one with the first three
    // gone, so the updater has something to remove.
    let full = World::default_warehouse();
    let geometry = full.default_map_geometry(0.05).unwrap();
    let prev = ground_truth_map(&full, &geometry);
    let mut world = full.clone();
    world.movable.drain(0..3);
    let truth = ground_truth_map(&world, &geometry);
    let route = ValidationParams::short_route(30.0);
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../robots/summit-xl-steel-s300.toml");
    let robot = RobotFile::load(&file).unwrap();
    assert!(robot.lidars.iter().all(|l| l.upside_down));
    let run = |upside_down: bool| -> WorldRun {
        let mut p = RunnerParams { run_baseline: false, ..RunnerParams::default() };
        if upside_down {
            robot.apply(&mut p.sim);
        }
        let inputs =
            RunInputs { world: &world, route: &route, prev_map: &prev, baseline_map: &prev, prev_memory: None };
        run_world(&inputs, &p, 7, "upside-down", &NoClock).unwrap()
    };
    let (up, down) = (run(false), run(true));
    assert!(up.route_done && down.route_done);
    for (name, r) in [("upright", &up), ("upside down", &down)] {
        assert!(r.chain.rmse_m < 0.05, "{name}: position RMSE {:.4} m", r.chain.rmse_m);
    }
    assert!(
        (up.chain.rmse_m - down.chain.rmse_m).abs() < 0.01,
        "RMSE upright {:.4} m, upside down {:.4} m",
        up.chain.rmse_m,
        down.chain.rmse_m
    );
    let before = differing(&prev, &truth);
    let (du, dd) = (differing(&up.map, &truth), differing(&down.map, &truth));
    eprintln!(
        "cells off the truth: before {before}, upright {du}, upside down {dd}; occupied {} / {}; rmse {:.4} / {:.4}",
        occupied(&up.map),
        occupied(&down.map),
        up.chain.rmse_m,
        down.chain.rmse_m
    );
    assert!(du < before && dd < before, "the updater removed something: {before} → {du} / {dd}");
    let gain = (before - du).max(before - dd) as f64;
    assert!(
        ((before - du) as f64 - (before - dd) as f64).abs() <= 0.2 * gain,
        "map gains differ: upright {} cells, upside down {} cells",
        before - du,
        before - dd
    );
}
