//! Degenerate worlds through the simulator's public API: an empty world, a robot that starts
//! inside an obstacle, and a route through a wall. Each gives a clear error or the documented
//! behaviour of `docs/reliability.md` ("Degenerate worlds and maps"), never a panic or a hang:
//! every loop here is bounded by a tick budget.

use mapkeeper_grid::{CellState, Point2};
use mapkeeper_sim::{ObstacleRef, SimParams, Simulator, World, ground_truth_map};

const HEADER: &str = "format = \"mapkeeper-world\"\nversion = 1\nname = \"degenerate\"\n";

fn world(body: &str) -> World {
    World::from_toml_str(&format!("{HEADER}{body}"), "degenerate.toml").unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn empty_world_simulates_with_no_returns() {
    // Nothing but a start pose: no interior, walls, items or agents.
    let w = world("robot_start = { x = 0.0, y = 0.0 }\n");
    let geometry = w.default_map_geometry(0.05).expect("a small grid round the start");
    assert!(geometry.width() >= 8 && geometry.height() >= 8, "{geometry:?}");
    let g = ground_truth_map(&w, &geometry);
    assert_eq!(g.count(CellState::Occupied), 0);
    let mut sim = Simulator::new(&w, SimParams::default(), 1).expect("an empty world is simulated");
    let mut scans = 0;
    for _ in 0..50 {
        let out = sim.step();
        assert!(out.route_done, "no route: done from the start");
        for s in &out.scans {
            // No obstacle: every beam is "no return" (invalid) but for the noise model's rare
            // spurious returns; the scan itself is valid.
            assert!(s.validate().is_ok());
            assert!(s.valid_count() * 50 < s.len(), "{} valid of {}", s.valid_count(), s.len());
            scans += 1;
        }
    }
    assert!(scans > 0);
    assert_eq!(sim.true_pose().position(), Point2::new(0.0, 0.0), "nothing moves the robot");
}

#[test]
fn robot_start_inside_a_box_is_refused_naming_the_box() {
    // A 2 m box centred on the start pose: refused when the world is read, so no simulator is
    // ever built with the robot inside a collider.
    let text = concat!(
        "robot_start = { x = 0.0, y = 0.0 }\n",
        "[[movable]]\nid = \"box\"\nkind = \"box\"\nshape = { type = \"rect\", center = [0.0, 0.0], size = [2.0, 2.0] }\n",
    );
    let e = World::from_toml_str(&format!("{HEADER}{text}"), "degenerate.toml").expect_err("start inside a box");
    let m = e.to_string();
    assert!(m.starts_with("degenerate.toml: robot_start: ") && m.contains("movable item \"box\""), "{m}");
    // Just outside the box is fine.
    world(&text.replace("x = 0.0, y = 0.0", "x = 1.5, y = 0.0"));
}

#[test]
fn route_through_a_wall_stops_at_the_wall() {
    // A wall across the route at x = 2 m; the route goes from the start to x = 4 m.
    let w = world(concat!(
        "robot_start = { x = 0.0, y = 0.0 }\n",
        "[[walls]]\nid = \"wall\"\nshape = { type = \"rect\", center = [2.0, 0.0], size = [0.2, 10.0] }\n",
    ));
    let params = SimParams::default();
    // The wall's near face is at x = 2.0 - 0.2 / 2; the robot heads along +x, so its front
    // is half its length ahead of its centre, and at the wall its centre sits at
    // face - half-length (1.525 m for the default 0.75 m body).
    let wall_face = 2.0 - 0.2 / 2.0;
    let at_wall = wall_face - params.robot.length_m / 2.0;
    let mut sim = Simulator::new(&w, params, 1).expect("builds");
    sim.set_route(vec![Point2::new(4.0, 0.0)]);
    let mut wall_contact = false;
    let mut done = false;
    // 60 simulated seconds: far more than the 4 m would take at the robot's speed.
    for _ in 0..3_000 {
        let out = sim.step();
        wall_contact |= out.collisions.iter().any(|c| c.started && c.other == ObstacleRef::Wall("wall".into()));
        done |= out.route_done;
        assert!(out.truth.pose_in_map.is_finite());
    }
    let x = sim.true_pose().x;
    eprintln!("route through a wall: wall contact {wall_contact}, final x {x:.3} m (wall at {at_wall:.3} m)");
    assert!(x < 2.0, "the robot went through the wall: x = {x}");
    assert!(wall_contact, "the robot never touched the wall (final x = {x})");
    // It drove up to the wall and stays pressed against it: not stopped short, not inside.
    assert!((at_wall - 0.1..=at_wall + 0.02).contains(&x), "final x = {x}, the wall stops the robot at {at_wall}");
    assert!(!done, "a route through a wall is never reported done");
}
