//! World files: the default world, every file in `worlds/`, the bad-world corpus, map import and
//! the ground truth of the default warehouse against the real map.

use mapkeeper_grid::{CellState, DistanceField};
use mapkeeper_sim::{World, ground_truth_map};
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[test]
fn default_world_loads_validates_and_round_trips() {
    let w = World::default_warehouse();
    assert_eq!(w.name, "aws-small-warehouse");
    assert_eq!(w.racks.len(), 7);
    assert_eq!(w.movable.len(), 15);
    assert!((4..=5).contains(&w.agents.len()));
    let text = w.to_toml_string().unwrap();
    let back = World::from_toml_str(&text, "round-trip").unwrap();
    assert_eq!(back, w);
    assert_eq!(back.to_toml_string().unwrap(), text, "serialisation is deterministic");
}

#[test]
fn every_file_in_worlds_loads() {
    let mut n = 0;
    for entry in std::fs::read_dir(repo().join("worlds")).unwrap() {
        let p = entry.unwrap().path();
        if p.extension().is_some_and(|e| e == "toml") {
            World::load(&p).unwrap_or_else(|e| panic!("{e}"));
            n += 1;
        }
    }
    assert!(n >= 1);
}

#[test]
fn bad_worlds_are_refused_with_a_clear_message() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/bad_worlds");
    let mut files: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
    files.sort();
    assert!(files.len() >= 10);
    for p in files {
        let text = std::fs::read_to_string(&p).unwrap();
        let expect =
            text.lines().next().and_then(|l| l.strip_prefix("# expect: ")).expect("first line '# expect: ...'");
        let err = World::load(&p).expect_err(&format!("{} should be refused", p.display())).to_string();
        assert!(err.starts_with(&p.display().to_string()), "{err}");
        assert!(err.contains(expect), "{}: expected '{expect}' in: {err}", p.display());
        assert!(!err.contains('\n'), "one-line message: {err}");
    }
}

#[test]
fn missing_file_names_the_file() {
    let e = World::load(Path::new("/nonexistent/world.toml")).unwrap_err().to_string();
    assert!(e.contains("/nonexistent/world.toml"), "{e}");
}

/// The real AWS map from `../shared` beside the checkout (team reference data, never committed),
/// or `None` after printing a note when `../shared` is absent.
fn real_map() -> Option<mapkeeper_grid::OccupancyGrid> {
    let yaml = mapkeeper_common::shared_data::path("maps/aws-small-warehouse/map.yaml", "the real-map world tests")?;
    Some(mapkeeper_grid::map_io::load_map(&yaml).expect("the real map loads"))
}

#[test]
fn imported_real_map_uses_merged_rectangles() {
    let Some(map) = real_map() else { return };
    let occupied = map.count(CellState::Occupied);
    let world = World::from_occupancy_grid(&map);
    let colliders = world.walls.len();
    println!("aws-small-warehouse map.yaml: {occupied} occupied cells -> {colliders} rectangle colliders");
    assert!(colliders * 2 < occupied, "{colliders} rectangles for {occupied} cells");
    world.validate("imported").unwrap();
    // Every occupied cell of the map is an obstacle (occupied or interior) in the imported world's G.
    let g = ground_truth_map(&world, map.geometry());
    for (i, (&a, &b)) in map.cells().iter().zip(g.cells()).enumerate() {
        if a == CellState::Occupied {
            assert_ne!(b, CellState::Free, "cell {i}");
        }
    }
    // And the robot starts in free space.
    let start = world.robot_start.pose().position();
    assert_eq!(map.get_world(start), Some(CellState::Free));
}

#[test]
fn default_ground_truth_resembles_the_real_map() {
    // Most occupied cells of the real map lie near an occupied cell of our G (the real map has
    // extra clutter and some offset; racks and stacks must line up).
    let Some(map) = real_map() else { return };
    let world = World::default_warehouse();
    let g = ground_truth_map(&world, map.geometry());
    let df = DistanceField::to_occupied(&g, 2.0);
    let geo = map.geometry();
    let (mut near, mut total) = (0usize, 0usize);
    for (i, &s) in map.cells().iter().enumerate() {
        if s == CellState::Occupied {
            total += 1;
            if df.at_cell(geo.coord(i)) <= 0.25 {
                near += 1;
            }
        }
    }
    let frac = near as f64 / total as f64;
    println!("real-map occupied cells within 0.25 m of G's: {near}/{total} = {frac:.3}");
    assert!(frac > 0.7, "{frac}");
    let geometry = world.default_map_geometry(0.05).unwrap();
    assert!(geometry.width() >= 280 && geometry.height() >= 419);
}

#[test]
fn the_default_warehouse_carries_its_route_and_storage_areas() {
    let w = World::default_warehouse();
    assert_eq!(World::embedded("warehouse"), Some(w.clone()));
    let route = w.route.as_ref().expect("the default warehouse carries its route");
    assert_eq!(route.waypoints, mapkeeper_sim::Route::default_warehouse().waypoints);
    assert_eq!(route.exploration, mapkeeper_sim::Route::exploration_warehouse().waypoints);
    let ids: Vec<&str> = w.storage_areas.iter().map(|a| a.id.as_str()).collect();
    assert_eq!(ids, ["east-yard", "centre-north", "centre-south"]);
    assert!(World::embedded("nowhere").is_none());
}

#[test]
fn the_lab_is_the_papers_room() {
    let lab = World::embedded("lab").expect("embedded");
    // About 80 m² of floor; a 10.5 m × 8.55 m map at 0.05 m (the paper's Table 2 maps).
    let area = lab.interior.as_ref().expect("interior").area();
    assert!((75.0..=85.0).contains(&area), "{area} m²");
    let g = lab.default_map_geometry(0.05).unwrap();
    assert_eq!((g.width(), g.height()), (210, 171), "10.5 m × 8.55 m");
    assert!(lab.route.is_some() && lab.storage_areas.len() >= 2 && !lab.movable.is_empty());
    assert_eq!(World::named_or_load(Path::new("lab")).unwrap(), lab);
    // Any other name is a file.
    let e = World::named_or_load(Path::new("no-such-world.toml")).unwrap_err().to_string();
    assert!(e.starts_with("no-such-world.toml: "), "{e}");
}
