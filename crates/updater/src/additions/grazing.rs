//! The grazing gate of the removal vote (a project addition, not in the paper).
//!
//! A ray that runs almost parallel to a wall of `M_{i-1}` crosses the wall's edge cells
//! whenever the pose is a fraction of a cell off, far from the point where it finally hits;
//! the paper's changed evaluator (§4.3.1) would vote those edge cells "removed", and a robot
//! driving along a wall erodes it. The gate estimates the wall's direction at a candidate
//! cell from the boundary cells of `M_{i-1}` around it (non-free cells with a free
//! 4-neighbour, in a 5 × 5 window): when they line up (the larger principal axis at least
//! four times the smaller) and the ray meets that line at less than the minimum incidence, the
//! cell gets no vote from this ray ([`is_grazing`]). Corners and isolated cells have no line;
//! for them, [`meets_a_free_face_grazing`] withholds the vote when the ray meets one of the
//! cell's free faces that flat (a ray skimming a corner cell's side). Cells inside obstacles
//! (no free 4-neighbour) are never gated. A removed obstacle is still crossed at steep angles
//! by other rays of the run. Used by [`crate::additions::removal_gates`].

use mapkeeper_grid::{CellCoord, CellState, OccupancyGrid};

/// Half side of the window, cells.
const HALF: i32 = 2;
/// Smallest ratio of principal second moments for a line-like boundary.
const LINE_RATIO: f64 = 4.0;

fn non_free(map: &OccupancyGrid, c: CellCoord) -> bool {
    matches!(map.get(c), Some(CellState::Occupied | CellState::Unknown))
}

fn is_boundary(map: &OccupancyGrid, c: CellCoord) -> bool {
    non_free(map, c)
        && [(1, 0), (-1, 0), (0, 1), (0, -1)]
            .iter()
            .any(|&(dx, dy)| map.get(CellCoord::new(c.ix + dx, c.iy + dy)) == Some(CellState::Free))
}

/// Whether a ray with direction (`dx`, `dy`) (any length) meets the boundary of `map` at
/// `cell` at less than `min_sin` (the sine of the minimum incidence angle): the removal vote
/// is then withheld.
pub fn is_grazing(map: &OccupancyGrid, cell: CellCoord, dx: f64, dy: f64, min_sin: f64) -> bool {
    if min_sin <= 0.0 || !is_boundary(map, cell) {
        return false;
    }
    let (mut n, mut sx, mut sy, mut sxx, mut syy, mut sxy) = (0.0f64, 0.0, 0.0, 0.0, 0.0, 0.0);
    for oy in -HALF..=HALF {
        for ox in -HALF..=HALF {
            let c = CellCoord::new(cell.ix + ox, cell.iy + oy);
            if is_boundary(map, c) {
                let (x, y) = (f64::from(ox), f64::from(oy));
                n += 1.0;
                sx += x;
                sy += y;
                sxx += x * x;
                syy += y * y;
                sxy += x * y;
            }
        }
    }
    if n < 3.0 {
        return false;
    }
    let (mx, my) = (sx / n, sy / n);
    let (cxx, cyy, cxy) = (sxx / n - mx * mx, syy / n - my * my, sxy / n - mx * my);
    let tr = cxx + cyy;
    let disc = ((cxx - cyy) * (cxx - cyy) / 4.0 + cxy * cxy).sqrt();
    let (l1, l2) = (tr / 2.0 + disc, tr / 2.0 - disc);
    if l1.is_nan() || l1 <= 0.0 || l1 < LINE_RATIO * l2.max(0.0) {
        return false;
    }
    // Major axis direction.
    let angle = 0.5 * (2.0 * cxy).atan2(cxx - cyy);
    let (wx, wy) = (angle.cos(), angle.sin());
    let norm = (dx * dx + dy * dy).sqrt();
    if norm.is_nan() || norm <= 0.0 {
        return false;
    }
    // |sin| of the angle between the ray and the wall line.
    let cross = (wx * dy - wy * dx).abs() / norm;
    cross < min_sin
}

/// Whether `cell` (non-free) has a free 4-neighbour across a face that a ray with incidence
/// `sin_x` on x faces and `sin_y` on y faces (|sin| of the angle between the ray and the face)
/// meets at less than `min_sin`. This catches what the line fit cannot: a ray skimming one face
/// of an obstacle's corner cell, entering the obstacle through the corner.
pub fn meets_a_free_face_grazing(map: &OccupancyGrid, cell: CellCoord, sin_x: f64, sin_y: f64, min_sin: f64) -> bool {
    if min_sin <= 0.0 {
        return false;
    }
    let free = |dx: i32, dy: i32| map.get(CellCoord::new(cell.ix + dx, cell.iy + dy)) == Some(CellState::Free);
    (sin_x < min_sin && (free(1, 0) || free(-1, 0))) || (sin_y < min_sin && (free(0, 1) || free(0, -1)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use mapkeeper_grid::{GridGeometry, Pose2};

    fn wall_map() -> OccupancyGrid {
        // A horizontal wall along row 10, obstacle (unknown) below it.
        let g = GridGeometry::new(40, 30, 0.05, Pose2::IDENTITY).unwrap();
        let mut m = OccupancyGrid::filled(g, CellState::Free);
        for x in 0..40 {
            m.set(CellCoord::new(x, 10), CellState::Occupied);
            for y in 0..10 {
                m.set(CellCoord::new(x, y), CellState::Unknown);
            }
        }
        m
    }

    #[test]
    fn rays_along_a_wall_are_grazing_rays_across_it_are_not() {
        let m = wall_map();
        let s = 20f64.to_radians().sin();
        let c = CellCoord::new(20, 10);
        assert!(is_grazing(&m, c, 1.0, 0.0, s));
        assert!(is_grazing(&m, c, -1.0, 0.1, s));
        assert!(!is_grazing(&m, c, 0.0, -1.0, s));
        assert!(!is_grazing(&m, c, 1.0, -1.0, s));
        // Disabled, inside the obstacle, or a free cell: never gated.
        assert!(!is_grazing(&m, c, 1.0, 0.0, 0.0));
        assert!(!is_grazing(&m, CellCoord::new(20, 5), 1.0, 0.0, s));
        assert!(!is_grazing(&m, CellCoord::new(20, 15), 1.0, 0.0, s));
    }

    #[test]
    fn a_ray_skimming_one_face_of_a_corner_cell_is_grazing() {
        let g = GridGeometry::new(20, 20, 0.05, Pose2::IDENTITY).unwrap();
        let mut m = OccupancyGrid::filled(g, CellState::Free);
        // Box [5, 10) × [5, 10): corner cell (9, 5) has free neighbours at +x and -y.
        for y in 5..10 {
            for x in 5..10 {
                m.set(CellCoord::new(x, y), CellState::Unknown);
            }
        }
        let s = 20f64.to_radians().sin();
        let c = CellCoord::new(9, 5);
        // Going up (+y) almost along the right face: grazing on the x face.
        assert!(meets_a_free_face_grazing(&m, c, 0.04, 0.999, s));
        // Diagonal through the corner: steep on both faces.
        assert!(!meets_a_free_face_grazing(&m, c, 0.707, 0.707, s));
        // An interior cell has no free face.
        assert!(!meets_a_free_face_grazing(&m, CellCoord::new(7, 7), 0.04, 0.999, s));
        assert!(!meets_a_free_face_grazing(&m, c, 0.04, 0.999, 0.0));
    }

    #[test]
    fn corners_and_isolated_cells_are_not_gated() {
        let g = GridGeometry::new(20, 20, 0.05, Pose2::IDENTITY).unwrap();
        let mut m = OccupancyGrid::filled(g, CellState::Free);
        m.set(CellCoord::new(10, 10), CellState::Occupied);
        assert!(!is_grazing(&m, CellCoord::new(10, 10), 1.0, 0.0, 0.5));
        // An L corner.
        for k in 0..6 {
            m.set(CellCoord::new(10 + k, 10), CellState::Occupied);
            m.set(CellCoord::new(10, 10 + k), CellState::Occupied);
        }
        assert!(!is_grazing(&m, CellCoord::new(10, 10), 1.0, 1.0, 0.3));
    }
}
