//! Changed cells evaluator (§4.3) for one detected-change beam.
//!
//! - §4.3.1: cells traversed from the lidar up to p_th (eq. 9: only cells whose centre is
//!   further from p_i than the skipped final chunk, Fig. 10) that are occupied — or unknown,
//!   which counts as occupied — in `M_{i-1}` get a "changed" vote: an obstacle was removed.
//! - §4.3.2: the hit cell c(p_i) gets a "changed" vote iff every cell within tol(z_i) of p_i is
//!   free in `M_{i-1}` (Fig. 11-13): an obstacle was added. A removed obstacle leaves p_i on
//!   some other, mapped obstacle, so some cell near p_i is occupied and no vote is cast.

use crate::UpdaterParams;
use crate::cell_buffers::CellBuffers;
use crate::grazing;
use crate::hit_index::HitIndex;
use mapkeeper_grid::{CellState, OccupancyGrid, Point2, traverse};
use std::ops::ControlFlow;

/// A vote of one beam on one cell during a step, packed as `index << 1 | changed`.
pub type Vote = u32;

/// Packs a vote.
#[inline]
pub fn vote(index: usize, changed: bool) -> Vote {
    ((index as u32) << 1) | changed as u32
}

/// Free cells in a row a ray must cross after a withheld vote before it votes again.
const SHADOW_CLEAR_CELLS: u32 = 3;

/// The point p_th at `skip_m` before `hit` on the segment from `origin` (None if the whole
/// beam is shorter than the chunk).
#[inline]
pub fn threshold_point(origin: Point2, hit: Point2, z: f64, skip_m: f64) -> Option<Point2> {
    if z.is_nan() || z <= skip_m {
        return None;
    }
    let f = (z - skip_m) / z;
    Some(Point2::new(origin.x + f * (hit.x - origin.x), origin.y + f * (hit.y - origin.y)))
}

/// Whether every cell that has a point closer than `radius_m` to `p` is free in `grid`
/// (cells outside the grid are unknown, hence not free).
pub fn all_free_within(grid: &OccupancyGrid, p: Point2, radius_m: f64) -> bool {
    let g = grid.geometry();
    let (u, v) = g.world_to_grid(p);
    let r = radius_m / g.resolution_m();
    if !(u.is_finite() && v.is_finite() && r.is_finite()) {
        return false;
    }
    let (x0, x1) = ((u - r).floor() as i64, (u + r).floor() as i64);
    let (y0, y1) = ((v - r).floor() as i64, (v + r).floor() as i64);
    let r2 = r * r;
    for iy in y0..=y1 {
        let dy = if v < iy as f64 {
            iy as f64 - v
        } else if v > iy as f64 + 1.0 {
            v - iy as f64 - 1.0
        } else {
            0.0
        };
        for ix in x0..=x1 {
            let dx = if u < ix as f64 {
                ix as f64 - u
            } else if u > ix as f64 + 1.0 {
                u - ix as f64 - 1.0
            } else {
                0.0
            };
            if dx * dx + dy * dy >= r2
                && !(ix as f64 <= u && u < ix as f64 + 1.0 && iy as f64 <= v && v < iy as f64 + 1.0)
            {
                continue;
            }
            let c = mapkeeper_grid::CellCoord::new(ix as i32, iy as i32);
            if grid.get(c) != Some(CellState::Free) {
                return false;
            }
        }
    }
    true
}

/// Appends the changed evaluator's votes for one detected-change beam to `votes`. The caller
/// makes sure every voted cell has a buffer before the unchanged evaluator runs
/// ([`ensure_buffers`]). `hits` holds the step's measured hit points for the hit clearance
/// (`UpdaterParams::removal_hit_clearance_m`; an empty index disables it).
pub fn evaluate_changed_beam(
    base: &OccupancyGrid,
    origin: Point2,
    hit: Point2,
    z: f64,
    params: &UpdaterParams,
    hits: &HitIndex,
    votes: &mut Vec<Vote>,
) {
    let g = base.geometry();
    let cells = base.cells();
    let skip = params.skip_changed_m(z);
    if let Some(p_th) = threshold_point(origin, hit, z, skip) {
        let skip_sq = skip * skip;
        let min_sin = params.removal_min_incidence_rad.sin();
        let (dx, dy) = (hit.x - origin.x, hit.y - origin.y);
        // Set when the ray crossed a non-free cell whose vote the hit clearance or the grazing
        // gate withheld; the run of non-free cells behind it gets no vote either (the ray is not
        // trusted to have passed the surface), until the ray has crossed SHADOW_CLEAR_CELLS free
        // cells in a row (a one-cell gap between two stacked boxes does not clear it).
        let mut shadowed = false;
        let mut free_run = 0u32;
        let inv_len = 1.0 / dx.hypot(dy).max(1e-12);
        let max_off = params.removal_max_offset_cells * g.resolution_m();
        // The ray's incidence on the x faces and on the y faces of the cells (|sin| to the face).
        let (sin_x, sin_y) = (dx.abs() * inv_len, dy.abs() * inv_len);
        let _ = traverse(g, origin, p_th, |c| {
            let i = c.iy as usize * g.width() + c.ix as usize;
            if cells[i] == CellState::Free {
                free_run += 1;
                if free_run >= SHADOW_CLEAR_CELLS {
                    shadowed = false;
                }
                return ControlFlow::Continue(());
            }
            free_run = 0;
            if !shadowed {
                let centre = g.cell_center(c);
                let off = ((centre.x - origin.x) * dy - (centre.y - origin.y) * dx).abs() * inv_len;
                if centre.distance_sq(hit) > skip_sq && off <= max_off {
                    if hits.any_within(centre)
                        || grazing::meets_a_free_face_grazing(base, c, sin_x, sin_y, min_sin)
                        || grazing::is_grazing(base, c, dx, dy, min_sin)
                    {
                        shadowed = true;
                    } else {
                        votes.push(vote(i, true));
                    }
                }
            }
            ControlFlow::<()>::Continue(())
        });
    }
    if let Some(c) = g.world_to_cell(hit)
        && let Some(i) = g.index(c)
        && all_free_within(base, hit, params.tol_m(z))
    {
        votes.push(vote(i, true));
    }
}

/// Sorts `votes` and creates a buffer for every cell with a "changed" vote.
pub fn ensure_buffers(votes: &mut [Vote], width: usize, buffers: &mut CellBuffers) {
    votes.sort_unstable();
    let mut last = u32::MAX;
    for &v in votes.iter() {
        if v & 1 == 1 && v != last {
            last = v;
            let i = (v >> 1) as usize;
            buffers.ensure(i as u32, mapkeeper_grid::CellCoord::new((i % width) as i32, (i / width) as i32));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mapkeeper_grid::{CellCoord, GridGeometry, Pose2};

    #[test]
    fn tol_neighbourhood() {
        let g = GridGeometry::new(10, 10, 0.1, Pose2::IDENTITY).unwrap();
        let mut m = OccupancyGrid::filled(g, CellState::Free);
        m.set(CellCoord::new(5, 5), CellState::Occupied);
        // Point in cell (3,5) centre: 0.15 m from the occupied cell's left face.
        let p = g.cell_center(CellCoord::new(3, 5));
        assert!(all_free_within(&m, p, 0.15));
        assert!(!all_free_within(&m, p, 0.151));
        // Near the border of the grid: outside is not free.
        assert!(!all_free_within(&m, Point2::new(0.05, 0.5), 0.1));
    }
}
