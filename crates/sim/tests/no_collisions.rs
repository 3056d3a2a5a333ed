//! The robot and the agents keep clear of each other: over many seeded runs of the default
//! route among the default warehouse's people and robot, no contact and no deadlock.
#![allow(clippy::unwrap_used)]

use mapkeeper_sim::{Route, SimParams, Simulator, World};

#[test]
fn default_route_two_hundred_seeds_no_contact_no_deadlock() {
    let world = World::default_warehouse();
    let route = Route::default_warehouse();
    let mut params = SimParams::default();
    // Geometry and agents only: the lidars are not needed here.
    params.lidars.clear();
    let max_ticks = (150.0e9 / params.tick_ns as f64) as u64;
    for seed in 0..200u64 {
        let mut sim = Simulator::new(&world, params.clone(), seed).unwrap();
        sim.set_route(route.points());
        let mut done = false;
        while sim.tick() < max_ticks {
            let out = sim.step();
            assert!(
                out.collisions.is_empty(),
                "seed {seed}: contact at {:.2} s: {:?}, robot at {:?}",
                out.stamp_ns as f64 * 1e-9,
                out.collisions,
                out.truth.pose_in_map
            );
            if out.route_done {
                done = true;
                break;
            }
        }
        assert!(done, "seed {seed}: route not done in 150 s (robot at {:?})", sim.true_pose());
    }
}
