//! The ground-truth map G of a world, rasterised exactly from its geometry.
//!
//! Rules (spec `20-simulator.md`): a cell that an obstacle's boundary passes through is
//! occupied; a cell strictly inside an obstacle, or outside the world's `interior`, is unknown;
//! every other cell is free. Agents are not part of G. Cells are half-open squares
//! `[ix, ix+1) × [iy, iy+1)` in grid units, the convention of eq. 1 (floor): a boundary point
//! exactly on a grid line belongs to the cell above / to the right of it.
//!
//! This module is written for the ground truth only and shares no code with the updater or the
//! localiser (it uses only the grid crate's geometry type).

use crate::shape::Shape;
use crate::world::World;
use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Point2};

/// Rasterises `world`'s static and movable geometry onto `geometry`.
///
/// ```
/// use mapkeeper_grid::{CellState, GridGeometry, Pose2};
/// use mapkeeper_sim::{ground_truth_map, World};
/// let world = World::default_warehouse();
/// let g = ground_truth_map(&world, &world.default_map_geometry(0.05).unwrap());
/// assert!(g.count(CellState::Occupied) > 1000);
/// ```
pub fn ground_truth_map(world: &World, geometry: &GridGeometry) -> OccupancyGrid {
    let mut grid = OccupancyGrid::filled(*geometry, CellState::Free);
    let n = geometry.len();
    // Cells outside the interior: centre outside and not crossed by the interior's boundary.
    let mut outside = vec![false; n];
    if let Some(interior) = &world.interior {
        let mut on_boundary = vec![false; n];
        rasterise_boundary(geometry, interior, |c| {
            if let Some(i) = geometry.index(c) {
                on_boundary[i] = true;
            }
        });
        for (i, out) in outside.iter_mut().enumerate() {
            *out = !on_boundary[i] && !interior.contains(geometry.cell_center(geometry.coord(i)));
        }
        for (cell, &out) in grid.cells_mut().iter_mut().zip(&outside) {
            if out {
                *cell = CellState::Unknown;
            }
        }
    }
    let obstacles = world.obstacles();
    for (_, shape) in &obstacles {
        fill_interior(geometry, shape, |c| {
            grid.set(c, CellState::Unknown);
        });
    }
    for (_, shape) in &obstacles {
        rasterise_boundary(geometry, shape, |c| {
            if let Some(i) = geometry.index(c)
                && !outside[i]
            {
                grid.cells_mut()[i] = CellState::Occupied;
            }
        });
    }
    grid
}

/// Calls `f` for every cell (possibly outside the grid's range is filtered) whose centre lies
/// inside `shape`.
fn fill_interior(geometry: &GridGeometry, shape: &Shape, mut f: impl FnMut(CellCoord)) {
    let Some((c0, c1, r0, r1)) = cell_range(geometry, shape) else { return };
    for iy in r0..=r1 {
        for ix in c0..=c1 {
            let c = CellCoord::new(ix, iy);
            if shape.contains(geometry.cell_center(c)) {
                f(c);
            }
        }
    }
}

/// Inclusive cell ranges `(col0, col1, row0, row1)` of a shape's bounds, clipped to the grid.
fn cell_range(geometry: &GridGeometry, shape: &Shape) -> Option<(i32, i32, i32, i32)> {
    let b = shape.bounds();
    let corners = [b.min, Point2::new(b.max.x, b.min.y), b.max, Point2::new(b.min.x, b.max.y)];
    let (mut u0, mut u1, mut v0, mut v1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for p in corners {
        let (u, v) = geometry.world_to_grid(p);
        u0 = u0.min(u);
        u1 = u1.max(u);
        v0 = v0.min(v);
        v1 = v1.max(v);
    }
    clip_range(geometry, u0, u1, v0, v1)
}

fn clip_range(geometry: &GridGeometry, u0: f64, u1: f64, v0: f64, v1: f64) -> Option<(i32, i32, i32, i32)> {
    let (w, h) = (geometry.width() as f64, geometry.height() as f64);
    if !(u0.is_finite() && u1.is_finite() && v0.is_finite() && v1.is_finite())
        || u1 < 0.0
        || v1 < 0.0
        || u0 >= w
        || v0 >= h
    {
        return None;
    }
    let c0 = u0.floor().max(0.0) as i32;
    let c1 = u1.floor().min(w - 1.0) as i32;
    let r0 = v0.floor().max(0.0) as i32;
    let r1 = v1.floor().min(h - 1.0) as i32;
    Some((c0, c1, r0, r1))
}

/// Calls `f` for every grid cell (inside the grid) that the boundary of `shape` passes through.
/// A cell may be reported more than once.
pub(crate) fn rasterise_boundary(geometry: &GridGeometry, shape: &Shape, mut f: impl FnMut(CellCoord)) {
    match shape {
        Shape::Circle { center, radius } => {
            let (cu, cv) = geometry.world_to_grid(Point2::new(center[0], center[1]));
            let r = radius / geometry.resolution_m();
            rasterise_circle(geometry, cu, cv, r, &mut f);
        }
        _ => {
            let v = shape.vertices().unwrap_or_default();
            let n = v.len();
            for i in 0..n {
                let a = geometry.world_to_grid(v[i]);
                let b = geometry.world_to_grid(v[(i + 1) % n]);
                rasterise_segment(geometry, a, b, &mut f);
            }
        }
    }
}

/// Every cell a segment in grid units passes through, column by column.
fn rasterise_segment(geometry: &GridGeometry, a: (f64, f64), b: (f64, f64), f: &mut impl FnMut(CellCoord)) {
    let (a, b) = if a.0 <= b.0 { (a, b) } else { (b, a) };
    let Some((c0, c1, _, _)) = clip_range(geometry, a.0, b.0, a.1.min(b.1), a.1.max(b.1)) else { return };
    let h = geometry.height() as f64;
    let du = b.0 - a.0;
    for ix in c0..=c1 {
        let (lo, hi) = ((ix as f64).max(a.0), (ix as f64 + 1.0).min(b.0));
        let (va, vb) = if du > 0.0 {
            let t0 = (lo - a.0) / du;
            let t1 = (hi - a.0) / du;
            (a.1 + t0 * (b.1 - a.1), a.1 + t1 * (b.1 - a.1))
        } else {
            (a.1, b.1)
        };
        let (vlo, vhi) = (va.min(vb), va.max(vb));
        if vhi < 0.0 || vlo >= h {
            continue;
        }
        let r0 = vlo.floor().max(0.0) as i32;
        let r1 = vhi.floor().min(h - 1.0) as i32;
        for iy in r0..=r1 {
            f(CellCoord::new(ix, iy));
        }
    }
}

/// Every cell a circle (centre `(cu, cv)`, radius `r`, grid units) passes through.
fn rasterise_circle(geometry: &GridGeometry, cu: f64, cv: f64, r: f64, f: &mut impl FnMut(CellCoord)) {
    let Some((c0, c1, _, _)) = clip_range(geometry, cu - r, cu + r, cv - r, cv + r) else { return };
    let h = geometry.height() as f64;
    let half_chord = |x: f64| (r * r - (x - cu) * (x - cu)).max(0.0).sqrt();
    for ix in c0..=c1 {
        let (lo, hi) = ((ix as f64).max(cu - r), (ix as f64 + 1.0).min(cu + r));
        if lo > hi {
            continue;
        }
        // Extremes of the half-chord over [lo, hi]: largest nearest the centre line.
        let s_max = half_chord(cu.clamp(lo, hi));
        let s_min = half_chord(lo).min(half_chord(hi));
        for (vlo, vhi) in [(cv + s_min, cv + s_max), (cv - s_max, cv - s_min)] {
            if vhi < 0.0 || vlo >= h {
                continue;
            }
            let r0 = vlo.floor().max(0.0) as i32;
            let r1 = vhi.floor().min(h - 1.0) as i32;
            for iy in r0..=r1 {
                f(CellCoord::new(ix, iy));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::{MovableItem, MovableKind, StartPose, WORLD_FORMAT, WORLD_VERSION};
    use mapkeeper_grid::Pose2;

    fn world_with(shapes: Vec<Shape>, interior: Option<Shape>) -> World {
        World {
            format: WORLD_FORMAT.into(),
            version: WORLD_VERSION,
            name: "t".into(),
            description: String::new(),
            robot_start: StartPose { x: 0.05, y: 0.05, yaw_deg: 0.0 },
            interior,
            walls: vec![],
            columns: vec![],
            racks: vec![],
            movable: shapes
                .into_iter()
                .enumerate()
                .map(|(i, shape)| MovableItem { id: format!("m{i}"), kind: MovableKind::Box, shape })
                .collect(),
            agents: vec![],
            storage_areas: vec![],
            route: None,
        }
    }

    #[test]
    fn single_box_cell_counts() {
        // 10 × 10 cells of 0.1 m. Box x ∈ [0.37, 0.67], y ∈ [0.37, 0.57]: boundary columns 3..=6,
        // rows 3..=5 → a ring of 4 × 3 − 2 × 1 = 10 occupied cells, the 2 cells inside unknown,
        // the other 88 free.
        let g = GridGeometry::new(10, 10, 0.1, Pose2::IDENTITY).unwrap();
        let w = world_with(vec![Shape::rect(Point2::new(0.52, 0.47), [0.3, 0.2], 0.0)], None);
        let m = ground_truth_map(&w, &g);
        assert_eq!(m.count(CellState::Occupied), 10);
        assert_eq!(m.count(CellState::Unknown), 2);
        assert_eq!(m.count(CellState::Free), 88);
        assert_eq!(m.get(CellCoord::new(4, 4)), Some(CellState::Unknown));
        assert_eq!(m.get(CellCoord::new(3, 3)), Some(CellState::Occupied));
        assert_eq!(m.get(CellCoord::new(7, 4)), Some(CellState::Free));
    }

    #[test]
    fn rotated_box_same_counts_at_ninety_degrees() {
        let g = GridGeometry::new(10, 10, 0.1, Pose2::IDENTITY).unwrap();
        // The box above turned by 90°: 0.2 wide, 0.3 tall about (0.47, 0.52).
        let w = world_with(vec![Shape::rect(Point2::new(0.47, 0.52), [0.3, 0.2], 90.0)], None);
        let m = ground_truth_map(&w, &g);
        assert_eq!((m.count(CellState::Occupied), m.count(CellState::Unknown)), (10, 2));
    }

    #[test]
    fn circle_ring() {
        // Radius 0.26 m about (0.5, 0.5) on 0.1 m cells: the 4 centre cells (centres 0.07 m from
        // the centre) are inside, ring cells occupied; the corner cells of the 6 × 6 block
        // (nearest point 0.2·√2 = 0.283 m > 0.26) are free.
        let g = GridGeometry::new(10, 10, 0.1, Pose2::IDENTITY).unwrap();
        let w = world_with(vec![Shape::circle(Point2::new(0.5, 0.5), 0.26)], None);
        let m = ground_truth_map(&w, &g);
        assert_eq!(m.get(CellCoord::new(4, 4)), Some(CellState::Unknown));
        assert_eq!(m.get(CellCoord::new(2, 2)), Some(CellState::Free));
        assert_eq!(m.get(CellCoord::new(2, 4)), Some(CellState::Occupied));
        assert_eq!(m.get(CellCoord::new(7, 5)), Some(CellState::Occupied));
        // Inside cells: centre within 0.26 m and not on the boundary.
        assert_eq!(m.count(CellState::Unknown), 4 + 8);
    }

    #[test]
    fn outside_interior_is_unknown() {
        // Interior x, y ∈ [0.15, 0.85]: boundary cells 1 and 8 on each side; outside ring unknown.
        let g = GridGeometry::new(10, 10, 0.1, Pose2::IDENTITY).unwrap();
        let interior = Shape::rect(Point2::new(0.5, 0.5), [0.7, 0.7], 0.0);
        let wall = Shape::rect(Point2::new(0.5, 0.9), [0.9, 0.1], 0.0); // y ∈ [0.85, 0.95]
        let m = ground_truth_map(&world_with(vec![wall], Some(interior)), &g);
        assert_eq!(m.get(CellCoord::new(0, 5)), Some(CellState::Unknown));
        assert_eq!(m.get(CellCoord::new(5, 8)), Some(CellState::Occupied)); // wall's inner face
        assert_eq!(m.get(CellCoord::new(5, 9)), Some(CellState::Unknown)); // its outer face is outside
        assert_eq!(m.get(CellCoord::new(5, 5)), Some(CellState::Free));
        // The interior boundary itself is not an obstacle: free where no wall stands.
        assert_eq!(m.get(CellCoord::new(1, 5)), Some(CellState::Free));
    }
}
