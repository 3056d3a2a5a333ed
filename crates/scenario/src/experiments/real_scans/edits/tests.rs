use super::*;
use mapkeeper_grid::{GridGeometry, Pose2};

/// A 16 × 10 m room (0.05 m cells): outer walls, a wall across half of it, and unknown beyond a
/// band outside the walls; free inside. The path runs along y = 5 m.
fn room() -> (OccupancyGrid, Vec<Point2>) {
    let g = GridGeometry::new(340, 220, 0.05, Pose2::new(-0.5, -0.5, 0.0)).unwrap();
    let mut m = OccupancyGrid::filled(g, CellState::Unknown);
    for iy in 0..220 {
        for ix in 0..340 {
            let p = g.cell_center(CellCoord::new(ix, iy));
            let inside = (0.0..=16.0).contains(&p.x) && (0.0..=10.0).contains(&p.y);
            let wall = inside
                && (p.x < 0.1 || p.x > 15.9 || p.y < 0.1 || p.y > 9.9 || ((7.9..8.1).contains(&p.x) && p.y > 6.0));
            let state = if wall {
                CellState::Occupied
            } else if inside {
                CellState::Free
            } else {
                CellState::Unknown
            };
            m.set(CellCoord::new(ix, iy), state);
        }
    }
    let path = (0..=30).map(|k| Point2::new(1.0 + 0.45 * k as f64, 5.0)).collect();
    (m, path)
}

#[test]
fn every_difference_is_an_edit_of_a_class_on_observed_cells_off_the_path() {
    let (g, path) = room();
    let p = EditParams::default();
    let s = stale_map(&g, &path, &p, 7).unwrap();
    assert!(s.edits.iter().any(|e| e.class == "added"));
    assert!(s.edits.iter().any(|e| e.class == "removed"));
    assert!(s.edits.iter().any(|e| e.class == "moved"));
    let geometry = *g.geometry();
    let near_path = path_distance(&g, &path, 5.0);
    let (mut differing, mut behind) = (0, 0);
    for (i, (&a, &b)) in s.map.cells().iter().zip(g.cells()).enumerate() {
        if a == b {
            continue;
        }
        // G's unknown cells are only ever made free floor behind a piece of structure M_1 lacks.
        if b == CellState::Unknown {
            assert_eq!(a, CellState::Free);
            behind += 1;
            continue;
        }
        differing += 1;
        // Observed cells: only free ↔ occupied.
        assert!(matches!((a, b), (CellState::Free, CellState::Occupied) | (CellState::Occupied, CellState::Free)));
        // Each in exactly one class.
        let at = s.footprints.at(i);
        assert_eq!(u8::from(at.added) + u8::from(at.removed) + u8::from(at.moved), 1, "cell {:?}", geometry.coord(i));
        let class = ChangeClass::of(a, b, Some(at)).unwrap();
        assert_ne!(class, ChangeClass::InitialError);
        // A phantom (occupied in M_1, free in G) stands off the path.
        if a == CellState::Occupied {
            assert!(f64::from(near_path.distances_m()[i]) >= p.path_clearance_m - 1e-9);
        }
    }
    assert_eq!(behind, s.edits.iter().map(|e| e.floor_behind).sum::<usize>());
    assert!(s.edits.iter().filter(|e| e.class == "removed").all(|e| e.floor_behind == 0));
    assert!(behind > 0, "the room's walls have unknown space behind them");
    let made = s.made_cells.0 + s.made_cells.1 + s.made_cells.2;
    assert_eq!(differing, made);
    let total_missing: usize = s.edits.iter().map(|e| e.cells_missing + e.cells_phantom).sum();
    assert_eq!(total_missing, made);
    // The room has room for every share.
    assert!(s.made_cells.0 >= s.target_cells.0 && s.made_cells.1 >= s.target_cells.1, "{s:?}", s = s.made_cells);
}

#[test]
fn the_same_seed_gives_the_same_map_and_another_seed_another() {
    let (g, path) = room();
    let p = EditParams::default();
    let a = stale_map(&g, &path, &p, 3).unwrap();
    let b = stale_map(&g, &path, &p, 3).unwrap();
    let c = stale_map(&g, &path, &p, 4).unwrap();
    assert_eq!(a.map, b.map);
    assert_eq!(a.edits, b.edits);
    assert_ne!(a.map, c.map);
}

#[test]
fn pieces_and_boxes_keep_their_sizes() {
    let (g, path) = room();
    let p = EditParams::default();
    let s = stale_map(&g, &path, &p, 11).unwrap();
    let cell_area = 0.05 * 0.05;
    for e in &s.edits {
        match e.class {
            // A box 0.3-1.2 m a side: 0.09-1.44 m² (rasterised, a little either way).
            "removed" => {
                let area = e.cells_phantom as f64 * cell_area;
                assert!((0.06..=1.6).contains(&area), "box of {area} m²");
                assert_eq!(e.cells_missing, 0);
            }
            // A move takes the same cells somewhere else.
            "moved" => assert_eq!(e.cells_missing, e.cells_phantom),
            _ => assert_eq!(e.cells_phantom, 0),
        }
    }
}

#[test]
fn zero_shares_leave_g_as_it_is_and_bad_parameters_are_named() {
    let (g, path) = room();
    let p = EditParams { added_share: 0.0, removed_share: 0.0, moved_share: 0.0, ..EditParams::default() };
    let s = stale_map(&g, &path, &p, 1).unwrap();
    assert_eq!(s.map, g);
    assert!(s.edits.is_empty());
    // Without floor behind, G's unknown cells are untouched.
    let p = EditParams { floor_behind_m: 0.0, ..EditParams::default() };
    let s = stale_map(&g, &path, &p, 1).unwrap();
    assert!(s.map.cells().iter().zip(g.cells()).all(|(a, b)| (*a == CellState::Unknown) == (*b == CellState::Unknown)));
    assert!(s.edits.iter().all(|e| e.floor_behind == 0) && !s.edits.is_empty());
    let bad = EditParams { box_m: (1.0, 0.5), ..EditParams::default() };
    let e = stale_map(&g, &path, &bad, 1).unwrap_err().to_string();
    assert!(e.contains("box_m"), "{e}");
    let bad = EditParams { removed_share: f64::NAN, ..EditParams::default() };
    assert!(stale_map(&g, &path, &bad, 1).unwrap_err().to_string().contains("removed_share"));
    let e = stale_map(&g, &[Point2::new(500.0, 500.0)], &EditParams::default(), 1).unwrap_err().to_string();
    assert!(e.contains("no reference pose"), "{e}");
}
