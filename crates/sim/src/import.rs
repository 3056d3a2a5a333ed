//! Import a ROS map (an occupancy grid) as a world: occupied cells become static rectangles,
//! merged greedily into maximal rectangles (row runs first, then equal runs of consecutive rows).

use crate::shape::Shape;
use crate::world::{StartPose, StaticItem, WORLD_FORMAT, WORLD_VERSION, World};
use mapkeeper_grid::{CellCoord, CellState, DistanceField, OccupancyGrid};
use std::collections::BTreeMap;

/// A rectangle of cells: columns `c0..=c1`, rows `r0..=r1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CellRect {
    /// First column.
    pub c0: usize,
    /// Last column.
    pub c1: usize,
    /// First row.
    pub r0: usize,
    /// Last row.
    pub r1: usize,
}

/// Covers the occupied cells of `grid` with disjoint rectangles: each row's runs of occupied
/// cells are merged with an identical run in the row below when there is one. Returned in the
/// order they are closed (deterministic).
pub fn merge_occupied(grid: &OccupancyGrid) -> Vec<CellRect> {
    let g = grid.geometry();
    let (w, h) = (g.width(), g.height());
    let mut open: BTreeMap<(usize, usize), usize> = BTreeMap::new(); // (c0, c1) → r0
    let mut done = Vec::new();
    for r in 0..h {
        let row = &grid.cells()[r * w..(r + 1) * w];
        let mut runs = Vec::new();
        let mut c = 0;
        while c < w {
            if row[c] == CellState::Occupied {
                let start = c;
                while c < w && row[c] == CellState::Occupied {
                    c += 1;
                }
                runs.push((start, c - 1));
            } else {
                c += 1;
            }
        }
        let mut next = BTreeMap::new();
        for run in runs {
            let r0 = open.remove(&run).unwrap_or(r);
            next.insert(run, r0);
        }
        for ((c0, c1), r0) in std::mem::replace(&mut open, next) {
            done.push(CellRect { c0, c1, r0, r1: r - 1 });
        }
    }
    for ((c0, c1), r0) in open {
        done.push(CellRect { c0, c1, r0, r1: h - 1 });
    }
    done
}

impl World {
    /// A world whose static walls are the occupied cells of `grid` (merged into rectangles; see
    /// [`merge_occupied`]). No interior, movable items or agents; the robot starts at the free
    /// cell farthest from any obstacle (ties: lowest index), facing +x.
    pub fn from_occupancy_grid(grid: &OccupancyGrid) -> World {
        let g = grid.geometry();
        let res = g.resolution_m();
        let yaw_deg = g.origin().yaw.to_degrees();
        let walls = merge_occupied(grid)
            .into_iter()
            .enumerate()
            .map(|(i, r)| {
                let u = (r.c0 + r.c1 + 1) as f64 / 2.0;
                let v = (r.r0 + r.r1 + 1) as f64 / 2.0;
                let c = g.grid_to_world(u, v);
                let size = [(r.c1 + 1 - r.c0) as f64 * res, (r.r1 + 1 - r.r0) as f64 * res];
                StaticItem { id: format!("cells-{i}"), shape: Shape::rect(c, size, yaw_deg) }
            })
            .collect();
        let field = DistanceField::to_occupied(grid, 5.0);
        let mut best: Option<(f64, usize)> = None;
        for (i, &s) in grid.cells().iter().enumerate() {
            if s == CellState::Free {
                let d = f64::from(field.at_cell(g.coord(i)));
                if best.is_none_or(|(bd, _)| d > bd) {
                    best = Some((d, i));
                }
            }
        }
        let start = best.map_or_else(|| g.cell_center(CellCoord::new(0, 0)), |(_, i)| g.cell_center(g.coord(i)));
        World {
            format: WORLD_FORMAT.into(),
            version: WORLD_VERSION,
            name: "imported-map".into(),
            description: format!("imported from a {} × {} occupancy grid at {res} m", g.width(), g.height()),
            robot_start: StartPose { x: start.x, y: start.y, yaw_deg: 0.0 },
            interior: None,
            walls,
            columns: vec![],
            racks: vec![],
            movable: vec![],
            agents: vec![],
            storage_areas: vec![],
            route: None,
        }
    }
}

/// `grid` with its free space sealed: every unknown cell next to a free cell (8-neighbours),
/// and every free cell on the grid's border, becomes occupied, so that a world made of it
/// ([`World::from_occupancy_grid`]) keeps the robot, the planner and the lidars inside what
/// the map saw. Counts the cells sealed.
pub fn seal_free_space(grid: &OccupancyGrid) -> (OccupancyGrid, usize) {
    let g = grid.geometry();
    let (w, h) = (g.width() as i32, g.height() as i32);
    let mut out = grid.clone();
    let mut sealed = 0;
    for (i, &s) in grid.cells().iter().enumerate() {
        let c = g.coord(i);
        let seal = match s {
            CellState::Unknown => c.neighbours8().iter().any(|&n| grid.get(n) == Some(CellState::Free)),
            CellState::Free => c.ix == 0 || c.iy == 0 || c.ix == w - 1 || c.iy == h - 1,
            CellState::Occupied => false,
        };
        if seal {
            out.cells_mut()[i] = CellState::Occupied;
            sealed += 1;
        }
    }
    (out, sealed)
}

impl World {
    /// A world of a real ROS map (`mapkeeper import-map`): its free space sealed
    /// ([`seal_free_space`]), the occupied cells merged into walls, named `name`.
    pub fn from_ros_map(grid: &OccupancyGrid, name: &str) -> World {
        let (sealed, n) = seal_free_space(grid);
        let mut w = World::from_occupancy_grid(&sealed);
        w.name = name.to_string();
        let g = grid.geometry();
        w.description = format!(
            "imported from a {} × {} map at {} m: {} occupied cells, {n} cells sealing the free space, as {} walls",
            g.width(),
            g.height(),
            g.resolution_m(),
            grid.count(CellState::Occupied),
            w.walls.len()
        );
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::truth::ground_truth_map;
    use mapkeeper_grid::{GridGeometry, Pose2};

    #[test]
    fn l_shape_merges_into_two_rectangles() {
        let g = GridGeometry::new(6, 5, 0.5, Pose2::new(-1.0, -1.0, 0.0)).unwrap();
        let mut m = OccupancyGrid::filled(g, CellState::Free);
        // Columns 1..=3 in rows 0..=1, column 1 in rows 2..=3.
        for r in 0..2 {
            for c in 1..4 {
                m.set(CellCoord::new(c, r), CellState::Occupied);
            }
        }
        for r in 2..4 {
            m.set(CellCoord::new(1, r), CellState::Occupied);
        }
        let rects = merge_occupied(&m);
        assert_eq!(rects.len(), 2);
        assert!(rects.contains(&CellRect { c0: 1, c1: 3, r0: 0, r1: 1 }));
        assert!(rects.contains(&CellRect { c0: 1, c1: 1, r0: 2, r1: 3 }));
        let w = World::from_occupancy_grid(&m);
        assert_eq!(w.walls.len(), 2);
        assert!(w.validate("test").is_ok());
        // The rectangles cover exactly the occupied cells: every occupied cell's centre is inside one.
        for (i, &s) in m.cells().iter().enumerate() {
            let p = g.cell_center(g.coord(i));
            let covered = w.walls.iter().any(|it| it.shape.contains(p));
            assert_eq!(covered, s == CellState::Occupied, "cell {i}");
        }
        // The ground truth of the imported world has its obstacles where the map's are.
        let gt = ground_truth_map(&w, &g);
        assert_eq!(gt.get(CellCoord::new(5, 4)), Some(CellState::Free));
        assert_ne!(gt.get(CellCoord::new(1, 3)), Some(CellState::Free));
    }

    #[test]
    fn sealing_closes_the_free_space() {
        // A free 3 × 3 block in unknown, in a 7 × 7 grid: its 16 unknown neighbours are sealed.
        let g = GridGeometry::new(7, 7, 0.5, Pose2::new(0.0, 0.0, 0.0)).unwrap();
        let mut m = OccupancyGrid::filled(g, CellState::Unknown);
        for r in 2..5 {
            for c in 2..5 {
                m.set(CellCoord::new(c, r), CellState::Free);
            }
        }
        let (s, n) = seal_free_space(&m);
        assert_eq!(n, 16);
        assert_eq!(s.count(CellState::Free), 9);
        assert_eq!(s.get(CellCoord::new(1, 1)), Some(CellState::Occupied));
        assert_eq!(s.get(CellCoord::new(0, 0)), Some(CellState::Unknown));
        let w = World::from_ros_map(&m, "block");
        assert_eq!(w.name, "block");
        assert!((w.robot_start.x - 1.75).abs() < 1e-9 && (w.robot_start.y - 1.75).abs() < 1e-9);
    }
}
