//! Worlds carry their scenario (issue 13): a world written here without storage areas or a
//! route gets both derived, validates end to end, and refuses a route it cannot drive; a world
//! imported from a map written here (and the real AWS map from `../shared` when present) too.
#![allow(clippy::unwrap_used)]

use mapkeeper_closed_loop::worlds::site::check_route;
use mapkeeper_closed_loop::{NoClock, Site, SiteParams, generate_worlds};
use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Pose2};
use mapkeeper_scenario::{ValidationParams, ValidationRun, run_seed};
use mapkeeper_sim::{Route, World};

/// A 10 m × 7 m room with a column and two boxes, one person; no storage areas, no route.
const ROOM: &str = r#"
format = "mapkeeper-world"
version = 1
name = "test-room"
robot_start = { x = -3.5, y = -2.3, yaw_deg = 0.0 }
interior = { type = "rect", center = [0.0, 0.0], size = [10.0, 7.0] }
[[walls]]
id = "north"
shape = { type = "rect", center = [0.0, 3.6], size = [10.4, 0.2] }
[[walls]]
id = "south"
shape = { type = "rect", center = [0.0, -3.6], size = [10.4, 0.2] }
[[walls]]
id = "east"
shape = { type = "rect", center = [5.1, 0.0], size = [0.2, 7.0] }
[[walls]]
id = "west"
shape = { type = "rect", center = [-5.1, 0.0], size = [0.2, 7.0] }
[[columns]]
id = "column"
shape = { type = "rect", center = [0.0, 0.0], size = [0.6, 0.6] }
[[movable]]
id = "box-1"
kind = "box"
shape = { type = "rect", center = [2.5, 1.0], size = [0.8, 0.8] }
[[movable]]
id = "box-2"
kind = "box"
shape = { type = "rect", center = [-2.5, 1.5], size = [0.6, 0.9], yaw_deg = 20.0 }
[[agents]]
id = "person-1"
kind = "person"
footprint = { type = "circle", radius = 0.25 }
speed_mps = 0.8
motion = { type = "loop", waypoints = [[4.3, -2.8], [4.3, 2.8]] }
"#;

fn params_for(name: &str, site: &Site, worlds: usize) -> ValidationParams {
    let mut p = ValidationParams::new(worlds, "mapkeeper").unwrap();
    p.use_site(name, site);
    p
}

#[test]
fn a_world_without_scenario_gets_one_and_validates() {
    let world = World::from_toml_str(ROOM, "room.toml").unwrap();
    let sp = SiteParams::default();
    let site = Site::resolve(&world, None, "room.toml", &sp).unwrap();
    assert!(site.planned_route && site.derived_areas);
    assert!(!site.storage.is_empty(), "no storage area derived in the room");
    // The patrol is a closed tour from the start that keeps its clearance.
    let pts = site.route.points();
    let start = world.robot_start.pose().position();
    assert!(pts[0].distance(start) < 1e-9 && pts[pts.len() - 1].distance(start) < 1e-9);
    assert!(site.route.length_m() > 15.0, "{} m", site.route.length_m());
    check_route(&world, &site.route, "room.toml", "route.waypoints", sp.route_clearance_m).unwrap();
    // It covers the room: every point of floor (a 0.5 m lattice, 0.65 m from the walls and the
    // column) outside the storage areas is within 3 m of the route.
    for k in 0..(17 * 11) {
        let q = mapkeeper_grid::Point2::new(-4.0 + 0.5 * (k % 17) as f64, -2.5 + 0.5 * (k / 17) as f64);
        let in_area = site.world.storage_areas.iter().any(|a| a.shape.distance_to(q) < 1.1);
        if in_area || q.x.abs().max(q.y.abs()) < 0.95 {
            continue;
        }
        let d = pts.windows(2).map(|w| mapkeeper_sim::point_segment_distance(q, w[0], w[1])).fold(f64::MAX, f64::min);
        assert!(d < 3.0, "({}, {}) is {d:.2} m from the patrol {:?}", q.x, q.y, site.route.waypoints);
    }
    // The same world and seed plan the same route; another seed may shift it.
    assert_eq!(Site::resolve(&world, None, "room.toml", &sp).unwrap(), site);
    // Storage areas lie inside the room, away from the route.
    for a in &site.world.storage_areas {
        let b = a.shape.bounds();
        assert!(b.min.x >= -5.0 && b.max.x <= 5.0 && b.min.y >= -3.5 && b.max.y <= 3.5, "{a:?}");
    }
    // The resolved world carries both and round-trips.
    let text = site.world.to_toml_string().unwrap();
    assert!(text.contains("[[storage_areas]]") && text.contains("[route]"));
    assert_eq!(World::from_toml_str(&text, "back").unwrap(), site.world);
    // Generated worlds keep edits off the route and the person's lane; the chain validates.
    let chain = generate_worlds(&site.world, &site.route, 4, 3, &params_for("room", &site, 4).generator).unwrap();
    assert!(chain.edits[1..].iter().all(|e| !e.is_empty()));
    for w in &chain.worlds {
        check_route(w, &site.route, &w.name, "route.waypoints", sp.route_clearance_m).unwrap();
    }
    let given = ValidationRun { w1: Some(&site.world), ..ValidationRun::timed_by(&NoClock) };
    let run = run_seed(&params_for("room", &site, 3), 1, &given, &|_| {}).unwrap();
    assert_eq!(run.rows.len(), 2);
    for r in &run.rows {
        assert!(r.route_done, "W{} route not done", r.world);
        assert_eq!(r.collisions, 0, "W{}", r.world);
        assert!(r.updated_map.cc > 0.0 && r.static_map.cc > 0.0);
    }
}

#[test]
fn a_route_the_robot_cannot_drive_is_refused_by_place() {
    let mut world = World::from_toml_str(ROOM, "room.toml").unwrap();
    let sp = SiteParams::default();
    // Through the column: the second leg.
    let through = Route::new(&[
        mapkeeper_grid::Point2::new(-3.5, -2.3),
        mapkeeper_grid::Point2::new(-3.0, 0.0),
        mapkeeper_grid::Point2::new(3.0, 0.0),
    ]);
    let e = Site::resolve(&world, Some(&through), "room.toml", &sp).unwrap_err().to_string();
    assert!(
        e.contains("room.toml: route.waypoints[1] [-3, 0] → route.waypoints[2] [3, 0] is blocked by column \"column\""),
        "{e}"
    );
    // Too narrow: 0.3 m past box-1's side.
    let narrow = Route::new(&[
        mapkeeper_grid::Point2::new(-3.5, -2.3),
        mapkeeper_grid::Point2::new(3.2, -2.3),
        mapkeeper_grid::Point2::new(3.2, 1.0),
    ]);
    let e = Site::resolve(&world, Some(&narrow), "room.toml", &sp).unwrap_err().to_string();
    assert!(
        e.contains(
            "route.waypoints[1] [3.2, -2.3] → route.waypoints[2] [3.2, 1] passes 0.30 m from movable item \"box-1\""
        ),
        "{e}"
    );
    // The first leg starts at the robot.
    let first = Route::new(&[mapkeeper_grid::Point2::new(-3.2, 1.5)]);
    let e = Site::resolve(&world, Some(&first), "room.toml", &sp).unwrap_err().to_string();
    assert!(e.contains("route.waypoints[0] [-3.2, 1.5] (the leg from robot_start [-3.5, -2.3])"), "{e}");
    assert!(e.contains("movable item \"box-2\""), "{e}");
    // Out of the room.
    let out = Route::new(&[mapkeeper_grid::Point2::new(-3.5, -2.3), mapkeeper_grid::Point2::new(7.0, 0.0)]);
    let e = Site::resolve(&world, Some(&out), "room.toml", &sp).unwrap_err().to_string();
    assert!(e.contains("route.waypoints[1] [7, 0] lies outside the interior"), "{e}");
    // A start boxed in: no route can be planned.
    world.robot_start = mapkeeper_sim::StartPose { x: 0.0, y: 0.5, yaw_deg: 0.0 };
    let e = Site::resolve(&world, None, "room.toml", &sp).unwrap_err().to_string();
    assert!(e.contains("robot_start [0, 0.5]: no route can be planned"), "{e}");
}

/// An L-shaped corridor map at 0.05 m, each arm `arm` cells wide: free inside, walls two cells
/// thick, unknown outside. The grid is 12 m × 10 m.
fn l_map(arm: i32) -> OccupancyGrid {
    let g = GridGeometry::new(240, 200, 0.05, Pose2::new(-1.0, -1.0, 0.0)).unwrap();
    let mut m = OccupancyGrid::filled(g, CellState::Unknown);
    let inside = |c: i32, r: i32| {
        ((10..230).contains(&c) && (10..10 + arm).contains(&r))
            || ((10..10 + arm).contains(&c) && (10..190).contains(&r))
    };
    for r in 0..200 {
        for c in 0..240 {
            let near = (-2..=2).any(|dc| (-2..=2).any(|dr| inside(c + dc, r + dr)));
            let s = if inside(c, r) {
                CellState::Free
            } else if near {
                CellState::Occupied
            } else {
                continue;
            };
            m.set(CellCoord::new(c, r), s);
        }
    }
    m
}

fn validate_imported(world: &World, origin: &str, route_m: Option<f64>) {
    let sp = SiteParams::default();
    let site = Site::resolve(world, None, origin, &sp).unwrap();
    site.require_storage(origin, &sp).unwrap();
    println!("{origin}: start {:?}, route {:?}, areas {:?}", world.robot_start, site.route.waypoints, site.storage);
    let mut p = params_for(origin, &site, 2);
    if let Some(len) = route_m {
        p.route = ValidationParams::truncated_route(&p.route, len);
    }
    let run = run_seed(&p, 2, &ValidationRun { w1: Some(&site.world), ..ValidationRun::timed_by(&NoClock) }, &|_| {})
        .unwrap();
    let row = &run.rows[0];
    println!(
        "{origin}: route {:.1} m, M_1/G_2 CC {:.2}, M_2/G_2 CC {:.2}, collisions {}",
        p.route.length_m(),
        row.static_map.cc,
        row.updated_map.cc,
        row.collisions
    );
    assert!(row.route_done, "{origin}: route not done");
    assert!(
        row.distance_m > 0.8 * p.route.length_m().min(route_m.unwrap_or(f64::MAX)),
        "{origin}: drove {} m",
        row.distance_m
    );
    assert!(row.static_map.cc > 20.0 && row.updated_map.cc > 20.0, "{origin}: {row:?}");
}

#[test]
fn a_world_imported_from_a_map_validates() {
    // Arms 4.5 m wide: room for storage beside the patrol.
    let world = World::from_ros_map(&l_map(90), "l-corridor");
    assert!(world.walls.len() < 40, "{} walls", world.walls.len());
    validate_imported(&world, "l-corridor", None);
}

#[test]
fn a_corridor_too_narrow_to_patrol_is_refused() {
    // Arms 1.2 m wide: the robot's start has less than the planner's 0.65 m clearance.
    let world = World::from_ros_map(&l_map(24), "narrow");
    let e = Site::resolve(&world, None, "narrow.toml", &SiteParams::default()).unwrap_err().to_string();
    assert!(e.contains("narrow.toml: robot_start ["), "{e}");
    assert!(e.contains("no route can be planned, the start has less than 0.65 m clearance"), "{e}");
}

#[test]
fn the_real_aws_map_imports_and_validates() {
    let Some(yaml) = mapkeeper_common::shared_data::path(
        "maps/aws-small-warehouse/map.yaml",
        "the_real_aws_map_imports_and_validates",
    ) else {
        return;
    };
    let grid = mapkeeper_grid::map_io::load_map(&yaml).unwrap();
    let world = World::from_ros_map(&grid, "aws-real");
    validate_imported(&world, "aws-real", Some(25.0));
}

/// The parameters name a world (`use_site`) but the run is given none: refused before anything
/// runs, rather than the site's routes driven in the default warehouse.
#[test]
fn a_world_named_by_the_parameters_must_be_given() {
    let mut p = ValidationParams::new(2, "paper").unwrap();
    p.world = Some("room".into());
    let e = run_seed(&p, 1, &ValidationRun::timed_by(&NoClock), &|_| {}).unwrap_err();
    assert!(e.to_string().contains("parameters name the world"), "{e}");
}
