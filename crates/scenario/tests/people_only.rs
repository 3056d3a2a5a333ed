//! The paper's claim about dynamic obstacles (§4.5): people walking about, in a world that did
//! not change, leave the map as it was. The runs use the world's own ground truth G as M_{i-1}
//! (so every change is a spurious one), the default route, and people only (the other robot
//! removed). The claim holds for `mapkeeper` (a few dozen cells change), not for the paper's
//! method: on seed 1 `paper-strict` changes thousands of cells and `paper` nearly a thousand
//! (pinned below as a negative result).
#![allow(clippy::unwrap_used)]

use mapkeeper_closed_loop::{NoClock, RunInputs, RunnerParams, run_world};
use mapkeeper_grid::CellState;
use mapkeeper_sim::{AgentKind, Motion, Route, World, ground_truth_map};

/// Runs the default route among people only, on the world's ground truth; returns (cells
/// changed, free cells that became occupied).
fn run(preset: &str, pauses: bool, seed: u64) -> (usize, usize) {
    let mut world = World::default_warehouse();
    world.agents.retain(|a| a.kind == AgentKind::Person);
    assert!(world.agents.len() >= 4);
    if !pauses {
        for a in &mut world.agents {
            if let Motion::RandomWalk { max_pause_s, .. } = &mut a.motion {
                *max_pause_s = 0.0;
            }
        }
    }
    let geometry = world.default_map_geometry(0.05).unwrap();
    let g = ground_truth_map(&world, &geometry);
    let route = Route::default_warehouse();
    let updater = mapkeeper_updater::UpdaterParams::preset(preset).unwrap();
    let params = RunnerParams { run_baseline: false, updater, ..RunnerParams::default() };
    let inputs = RunInputs { world: &world, route: &route, prev_map: &g, baseline_map: &g, prev_memory: None };
    let r = run_world(&inputs, &params, seed, "people-only", &NoClock).unwrap();
    assert!(r.route_done, "seed {seed}");
    assert_eq!(r.collisions, 0, "seed {seed}");
    let changed: Vec<usize> = (0..g.cells().len()).filter(|&i| g.cells()[i] != r.map.cells()[i]).collect();
    let new_occupied =
        changed.iter().filter(|&&i| g.cells()[i] == CellState::Free && r.map.cells()[i] == CellState::Occupied).count();
    (changed.len(), new_occupied)
}

/// People who do not pause at their waypoints still stop for the robot (up to 3 s, then turn
/// back) right in its view; apart from such a waiting person nothing enters the map. The cells
/// that change otherwise are obstacle cells that rays skimming a box side at long range (with
/// the localiser's yaw error) still reach.
#[test]
fn walking_people_leave_little_trace() {
    for seed in [1u64, 2] {
        let (changed, new_occupied) = run("mapkeeper", false, seed);
        eprintln!("mapkeeper, seed {seed}, no pauses: {changed} cells changed, {new_occupied} free -> occupied");
        assert!(new_occupied <= 20, "seed {seed}: {new_occupied} free cells became occupied");
        assert!(changed <= 60, "seed {seed}: {changed} cells changed");
    }
}

/// People who stand still for up to 4 s in the robot's view are semi-static obstacles by the
/// paper's rule (7 "changed" flags of the last 10): they enter the map and leave it only if the
/// robot sees the spot free again. Pinned so that a change in that behaviour is noticed.
#[test]
fn people_standing_still_in_view_can_enter_the_map() {
    let (changed, new_occupied) = run("mapkeeper", true, 1);
    eprintln!("mapkeeper, seed 1, with pauses: {changed} cells changed, {new_occupied} free -> occupied");
    assert!(new_occupied > 0 && new_occupied <= 40, "{new_occupied}");
    assert!(changed <= 90, "{changed}");
}

/// A negative result, pinned: `paper-strict` (no removal gates, no free-pass votes, border
/// reconstruction into every unknown neighbour, no revert) changes the map of an unchanged world
/// in thousands of cells: rays grazing walls at a few centimetres of pose error erode them, and
/// each freed cell turns its never-observed unknown neighbours occupied. `paper` (the fair
/// reading: sliding window, > 7, chunk floor, wider virtual rays, interior borders) does less
/// damage but still several hundred cells: the erosion by grazing rays is in the method, not in
/// the reading.
#[test]
fn paper_as_written_damages_an_unchanged_world() {
    let (strict, _) = run("paper-strict", false, 1);
    eprintln!("paper-strict, seed 1, no pauses: {strict} cells changed");
    assert!(strict > 1000, "{strict}");
    let (fair, new_occupied) = run("paper", false, 1);
    eprintln!("paper, seed 1, no pauses: {fair} cells changed, {new_occupied} free -> occupied");
    assert!(fair > 500 && fair < strict, "{fair} (paper-strict {strict})");
}
