//! Real map_server files load: the AWS small-warehouse map as PNG, as a GIMP-written PGM with a
//! header comment, and as the map_saver original (`# CREATOR` comment).
//!
//! The map is team reference data, read from `../shared/maps/aws-small-warehouse/` beside the
//! checkout and never committed; every test here skips with a note when `../shared` is absent.

use mapkeeper_grid::{CellState, map_io};
use std::path::{Path, PathBuf};

/// The AWS map folder in `../shared`, or `None` (after printing a note) when it is absent.
fn maps_dir() -> Option<PathBuf> {
    mapkeeper_common::shared_data::path("maps/aws-small-warehouse/map.yaml", "the real-map tests")
        .and_then(|yaml| yaml.parent().map(Path::to_path_buf))
}

/// A scratch folder for YAML files written by a test.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mapkeeper-real-maps-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// A map_server YAML in `dir` naming `image` by absolute path (the PGMs in `../shared` have no
/// YAML of their own).
fn yaml_for(dir: &Path, name: &str, image: &Path, origin: &str) -> PathBuf {
    let yaml = dir.join(name);
    let text = format!(
        "image: \"{}\"\nresolution: 0.05\norigin: {origin}\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n",
        image.display()
    );
    std::fs::write(&yaml, text).expect("writes the YAML");
    yaml
}

#[test]
fn aws_warehouse_png() {
    let Some(dir) = maps_dir() else { return };
    let m = map_io::load_map(&dir.join("map.yaml")).expect("loads");
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
    let Some(dir) = maps_dir() else { return };
    let tmp = scratch("pgm");
    // The GIMP-written PGM (a comment line in its header), the same map as map.yaml.
    let gimp_yaml = yaml_for(&tmp, "map_rotated_pgm.yaml", &dir.join("map_rotated.pgm"), "[-7.0, -10.5, 0.0]");
    let gimp = map_io::load_map(&gimp_yaml).expect("GIMP PGM loads");
    assert_eq!((gimp.geometry().width(), gimp.geometry().height()), (423, 286));
    // The unrotated map_saver original (`# CREATOR` line); its origin is a placeholder.
    let saver_yaml = yaml_for(&tmp, "map_unrotated.yaml", &dir.join("map.pgm"), "[-10.5, -7.0, 0.0]");
    let saver = map_io::load_map(&saver_yaml).expect("map_saver PGM loads");
    assert_eq!((saver.geometry().width(), saver.geometry().height()), (640, 384));
    for m in [&gimp, &saver] {
        assert!(m.count(CellState::Occupied) > 2_000);
        assert!(m.count(CellState::Free) > 60_000);
    }
}

#[test]
fn save_and_reload_is_identical() {
    let Some(dir) = maps_dir() else { return };
    let m = map_io::load_map(&dir.join("map.yaml")).expect("loads");
    let tmp = scratch("save");
    map_io::save_map(&m, &tmp.join("copy.yaml")).expect("saves");
    assert_eq!(map_io::load_map(&tmp.join("copy.yaml")).expect("reloads"), m);
}
