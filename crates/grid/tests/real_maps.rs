//! Real map_server files load: the AWS small-warehouse map as PNG, as a GIMP-written PGM with a
//! header comment, and as the map_saver original (`# CREATOR` comment).

use mapkeeper_grid::{CellState, map_io};
use std::path::PathBuf;

fn maps_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/maps/aws-small-warehouse")
}

#[test]
fn aws_warehouse_png() {
    let m = map_io::load_map(&maps_dir().join("map.yaml")).expect("loads");
    let g = m.geometry();
    assert_eq!((g.width(), g.height()), (286, 423));
    assert_eq!(g.resolution_m(), 0.05);
    assert_eq!((g.origin().x, g.origin().y), (-7.0, -10.5));
    // A real warehouse: mostly free inside, a closed wall, unknown outside and inside stacks.
    let (free, occ, unk) = (m.count(CellState::Free), m.count(CellState::Occupied), m.count(CellState::Unknown));
    assert!(free > 60_000 && occ > 2_000 && unk > 10_000, "free {free} occupied {occ} unknown {unk}");
    // The warehouse centre is free space; the inside of the box stack at (3.3, 3.8) is unknown.
    assert_eq!(m.get_world(mapkeeper_grid::Point2::new(1.0, 0.0)), Some(CellState::Free));
    assert_eq!(m.get_world(mapkeeper_grid::Point2::new(3.3, 3.8)), Some(CellState::Unknown));
}

#[test]
fn aws_warehouse_pgm_variants() {
    let gimp = map_io::load_map(&maps_dir().join("map_rotated_pgm.yaml")).expect("GIMP PGM loads");
    assert_eq!((gimp.geometry().width(), gimp.geometry().height()), (423, 286));
    let saver = map_io::load_map(&maps_dir().join("map_unrotated.yaml")).expect("map_saver PGM loads");
    assert_eq!((saver.geometry().width(), saver.geometry().height()), (640, 384));
    for m in [&gimp, &saver] {
        assert!(m.count(CellState::Occupied) > 2_000);
        assert!(m.count(CellState::Free) > 60_000);
    }
}

#[test]
fn save_and_reload_is_identical() {
    let m = map_io::load_map(&maps_dir().join("map.yaml")).expect("loads");
    let dir = std::env::temp_dir().join(format!("mapkeeper-real-maps-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    map_io::save_map(&m, &dir.join("copy.yaml")).expect("saves");
    assert_eq!(map_io::load_map(&dir.join("copy.yaml")).expect("reloads"), m);
}
