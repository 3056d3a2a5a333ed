//! The small hand-made maps of the tests: walled rooms, named for what they are, and the two
//! ways the tests set furniture in them (a block of cells, or everything whose centre lies in a
//! rectangle in metres). A test with a scene of its own builds it from these.
//!
//! A room is a test's own constant: a size that gives no grid (zero cells, a resolution not
//! above zero) is a mistake in the test, and the functions panic naming it.

use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Pose2};
use std::ops::Range;

/// The geometry of a `cells_w` × `cells_h`-cell grid at `res_m` with its lower-left corner at
/// `origin`, or a panic naming the bad size.
fn geometry(cells_w: usize, cells_h: usize, res_m: f64, origin: Pose2) -> GridGeometry {
    GridGeometry::new(cells_w, cells_h, res_m, origin)
        .unwrap_or_else(|e| panic!("a test room of {cells_w} x {cells_h} cells at {res_m} m: {e}"))
}

/// A `cells_w` × `cells_h`-cell grid at `res_m` with its lower-left corner at `origin`: every
/// cell free but the grid's outer ring, occupied ([`OccupancyGrid::walled`]).
pub fn walled_cells(cells_w: usize, cells_h: usize, res_m: f64, origin: Pose2) -> OccupancyGrid {
    OccupancyGrid::walled(geometry(cells_w, cells_h, res_m, origin))
}

/// A `w_m` × `h_m` room at `res_m` with one-cell walls on its border, interior free, placed at
/// the lower-left of a grid of `cells_w` × `cells_h` cells at the origin (the rest free).
pub fn walled_in(w_m: f64, h_m: f64, res_m: f64, cells_w: usize, cells_h: usize) -> OccupancyGrid {
    let mut m = OccupancyGrid::filled(geometry(cells_w, cells_h, res_m, Pose2::IDENTITY), CellState::Free);
    let (nw, nh) = ((w_m / res_m).round() as i32, (h_m / res_m).round() as i32);
    for k in 0..nw {
        m.set(CellCoord::new(k, 0), CellState::Occupied);
        m.set(CellCoord::new(k, nh - 1), CellState::Occupied);
    }
    for k in 0..nh {
        m.set(CellCoord::new(0, k), CellState::Occupied);
        m.set(CellCoord::new(nw - 1, k), CellState::Occupied);
    }
    m
}

/// A `w_m` × `h_m` room at `res_m` filling its grid, its lower-left corner at the origin:
/// one-cell walls on the border, interior free.
pub fn walled(w_m: f64, h_m: f64, res_m: f64) -> OccupancyGrid {
    walled_in(w_m, h_m, res_m, (w_m / res_m).round() as usize, (h_m / res_m).round() as usize)
}

/// A 10 m × 10 m room centred on the origin (origin at (−5, −5)), 0.1 m cells: free inside an
/// occupied border one cell thick (inner wall faces at ±4.9 m).
pub fn ten_by_ten_centred() -> OccupancyGrid {
    walled_cells(100, 100, 0.1, Pose2::new(-5.0, -5.0, 0.0))
}

/// A 4 m × 3 m room, walls one cell thick, in a 6 m × 5 m grid at 0.05 m whose lower-left corner
/// is `origin`; outside the walls is unknown. The walls are cells 20..=99 (x) and 20..=79 (y):
/// from 1.0 m to 5.0 m and 1.0 m to 4.0 m from the grid's corner.
pub fn four_by_three_in_unknown(origin: Pose2) -> OccupancyGrid {
    let mut m = OccupancyGrid::filled(geometry(120, 100, 0.05, origin), CellState::Unknown);
    for iy in 20..=79 {
        for ix in 20..=99 {
            let wall = ix == 20 || ix == 99 || iy == 20 || iy == 79;
            m.set(CellCoord::new(ix, iy), if wall { CellState::Occupied } else { CellState::Free });
        }
    }
    m
}

/// Sets the cells of columns `ix` and rows `iy` (ends excluded) to `state`; cells off the grid
/// are left alone.
pub fn fill_cells(m: &mut OccupancyGrid, ix: Range<i32>, iy: Range<i32>, state: CellState) {
    for x in ix {
        for y in iy.clone() {
            m.set(CellCoord::new(x, y), state);
        }
    }
}

/// Sets every cell whose centre lies in [x0, x1) × [y0, y1) (metres, world frame) to `state`.
pub fn fill_rect(m: &mut OccupancyGrid, x0: f64, y0: f64, x1: f64, y1: f64, state: CellState) {
    let g = *m.geometry();
    for iy in 0..g.height() as i32 {
        for ix in 0..g.width() as i32 {
            let c = g.cell_center(CellCoord::new(ix, iy));
            if c.x >= x0 && c.x < x1 && c.y >= y0 && c.y < y1 {
                m.set(CellCoord::new(ix, iy), state);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn count(m: &OccupancyGrid, state: CellState) -> usize {
        let g = m.geometry();
        (0..g.height() as i32)
            .flat_map(|iy| (0..g.width() as i32).map(move |ix| CellCoord::new(ix, iy)))
            .filter(|&c| m.get(c) == Some(state))
            .count()
    }

    #[test]
    fn a_room_filling_its_grid_is_the_walled_grid() {
        let a = walled(6.0, 4.0, 0.05);
        assert_eq!(a, walled_cells(120, 80, 0.05, Pose2::IDENTITY));
        assert_eq!(count(&a, CellState::Occupied), 2 * 120 + 2 * 78);
        // In a larger grid, the cells beyond the room stay free.
        let b = walled_in(6.0, 4.0, 0.05, 130, 90);
        assert_eq!(count(&b, CellState::Occupied), 2 * 120 + 2 * 78);
        assert_eq!(b.get(CellCoord::new(125, 85)), Some(CellState::Free));
    }

    #[test]
    fn the_named_rooms_have_the_sizes_they_say() {
        let m = ten_by_ten_centred();
        assert_eq!(m.get_world(mapkeeper_grid::Point2::new(-4.95, 0.0)), Some(CellState::Occupied));
        assert_eq!(m.get_world(mapkeeper_grid::Point2::new(4.85, 0.0)), Some(CellState::Free));
        let u = four_by_three_in_unknown(Pose2::new(-1.0, -1.0, 0.0));
        assert_eq!(count(&u, CellState::Occupied), 2 * 80 + 2 * 58);
        assert_eq!(count(&u, CellState::Free), 78 * 58);
        assert_eq!(u.get_world(mapkeeper_grid::Point2::new(-0.5, 0.0)), Some(CellState::Unknown));
    }

    #[test]
    fn furniture_by_cell_and_by_metre_agree() {
        let mut a = walled_cells(40, 40, 0.1, Pose2::IDENTITY);
        let mut b = a.clone();
        fill_cells(&mut a, 10..14, 20..23, CellState::Occupied);
        fill_rect(&mut b, 1.0, 2.0, 1.4, 2.3, CellState::Occupied);
        assert_eq!(a, b);
        // Off the grid: nothing.
        fill_cells(&mut a, -5..0, 0..3, CellState::Unknown);
        assert_eq!(a, b);
    }
}
