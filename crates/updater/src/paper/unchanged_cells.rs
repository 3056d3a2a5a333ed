//! Unchanged cells evaluator (§4.4) for one beam without detected change: cells traversed up
//! to p_th (final chunk max(0.02·z, min) skipped) get an "unchanged" vote; for the hit cell, if
//! it is free in `M_{i-1}` the occupied (or unknown) cells adjacent to it get the vote,
//! otherwise the hit cell itself does.
//!
//! Only cells that already hold a buffer are voted on: an "unchanged" flag in a cell without a
//! buffer would create a buffer without a "changed" flag, which is dropped at once
//! (see [`crate::paper::cell_buffers`]).

use crate::UpdaterParams;
use crate::paper::cell_buffers::{CellBuffers, TileProbe};
use crate::paper::changed_cells::{Vote, threshold_point, vote};
use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Point2, SegmentWalk};

/// Margin, in units of the walked segment, kept before a tile's exit when a walk crosses a tile
/// without buffers: above the rounding of the walk's boundary parameters (at most 2⁻⁵² per
/// step over at most 2²¹ steps, about 5e-10).
const TILE_EXIT_MARGIN: f64 = 1e-9;

/// Appends the unchanged evaluator's votes for one beam to `votes`. `first_buffer_m`: no cell
/// closer than this to `origin` along the beam holds a buffer (0 if unknown; see
/// [`crate::paper::beam_classifier::Beam::near_buffer_m`]), so the walk starts about there.
#[allow(clippy::too_many_arguments)]
pub fn evaluate_unchanged_beam(
    base: &OccupancyGrid,
    origin: Point2,
    hit: Point2,
    z: f64,
    params: &UpdaterParams,
    first_buffer_m: f64,
    probe: &mut TileProbe<'_>,
    votes: &mut Vec<Vote>,
) {
    let g = base.geometry();
    let skip = params.skip_unchanged_m(z);
    let skip_sq = skip * skip;
    buffered_cells_before_chunk(g, origin, hit, z, skip, first_buffer_m, probe, |c, i| {
        if g.cell_center(c).distance_sq(hit) > skip_sq {
            votes.push(vote(i, false));
        }
    });
    let Some(c) = g.world_to_cell(hit) else { return };
    match base.get(c) {
        Some(CellState::Free) => {
            for n in c.neighbours8() {
                if let Some(i) = g.index(n)
                    && base.cells()[i] != CellState::Free
                    && probe.contains(n)
                {
                    votes.push(vote(i, false));
                }
            }
        }
        Some(_) => {
            if let Some(i) = g.index(c)
                && probe.contains(c)
            {
                votes.push(vote(i, false));
            }
        }
        None => {}
    }
}

/// Calls `visit(cell, index)` for every cell that holds a buffer, in the order the traversal
/// from `origin` towards `hit` visits them, up to p_th (`skip_m` before `hit`, range `z`).
/// `first_buffer_m`: no cell closer than this to `origin` along the beam holds a buffer (0 if
/// unknown; see [`crate::paper::beam_classifier::Beam::walk_from_m`]), so the walk starts about there;
/// tiles without buffers are crossed without visiting their cells. The same cells as a plain
/// cell-by-cell walk filtered by the probe (tests in this module and in `free_pass`).
#[allow(clippy::too_many_arguments)]
pub(crate) fn buffered_cells_before_chunk(
    g: &GridGeometry,
    origin: Point2,
    hit: Point2,
    z: f64,
    skip_m: f64,
    first_buffer_m: f64,
    probe: &mut TileProbe<'_>,
    mut visit: impl FnMut(CellCoord, usize),
) {
    let r = g.resolution_m();
    // Every cell the walk visits has a point within rounding of the segment, at most z − skip
    // from the origin; a cell first entered less than `first_buffer_m − r` along it is closer
    // than `first_buffer_m` (one cell of margin, far above the rounding).
    if first_buffer_m > z - skip_m + r {
        return;
    }
    let Some(p_th) = threshold_point(origin, hit, z, skip_m) else { return };
    let Some(mut walk) = SegmentWalk::start(g, origin, p_th) else { return };
    let tile = CellBuffers::TILE_CELLS;
    if first_buffer_m > r {
        walk.skip_before(walk.param_at((first_buffer_m - r) / r));
    }
    loop {
        let c = walk.cell();
        match probe.tile(c) {
            Some(mask) => {
                if mask.contains(c) {
                    visit(c, walk.index());
                }
            }
            None => {
                // No buffer in this tile: cross it without visiting its cells. Only boundaries
                // strictly inside the tile are crossed (TILE_EXIT_MARGIN exceeds the walk's
                // rounding), so no cell outside it is passed over.
                let (x0, y0) = ((c.ix & !(tile - 1)) as f64, (c.iy & !(tile - 1)) as f64);
                let exit = walk.param_leaving((x0, y0), (x0 + tile as f64, y0 + tile as f64));
                walk.skip_before(exit - TILE_EXIT_MARGIN);
            }
        }
        if !walk.advance() {
            break;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::paper::cell_buffers::CellBuffers;
    use mapkeeper_grid::{CellCoord, GridGeometry, Pose2, traverse};
    use std::ops::ControlFlow;

    /// The evaluator as specified, walking every cell: the tile skipping must give the same votes.
    fn reference(
        base: &OccupancyGrid,
        origin: Point2,
        hit: Point2,
        z: f64,
        params: &UpdaterParams,
        buffers: &CellBuffers,
    ) -> Vec<Vote> {
        let g = base.geometry();
        let mut votes = Vec::new();
        let skip = params.skip_unchanged_m(z);
        if let Some(p_th) = threshold_point(origin, hit, z, skip) {
            let _ = traverse(g, origin, p_th, |c| {
                if buffers.probe().contains(c) && g.cell_center(c).distance_sq(hit) > skip * skip {
                    votes.push(vote(g.index(c).unwrap(), false));
                }
                ControlFlow::<()>::Continue(())
            });
        }
        // The hit-cell rule is shared code; compare the traversal part only.
        votes
    }

    #[test]
    fn tile_skipping_gives_the_votes_of_a_full_walk() {
        for yaw in [0.0, 0.4] {
            let g = GridGeometry::new(200, 160, 0.05, Pose2::new(0.3, -0.2, yaw)).unwrap();
            let base = OccupancyGrid::filled(g, CellState::Free);
            // Clusters of buffered cells in a few tiles, one of them on a tile corner.
            let mut state = 0x2545_f491_4f6c_dd1du64;
            let mut next = move || {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                state
            };
            let mut buffers = CellBuffers::new();
            for (cx, cy) in [(40, 40), (100, 70), (150, 130), (64, 112), (170, 30)] {
                for _ in 0..60 {
                    let c = CellCoord::new(cx + (next() % 14) as i32 - 7, cy + (next() % 14) as i32 - 7);
                    if let Some(i) = g.index(c) {
                        buffers.ensure(i as u32, c);
                    }
                }
            }
            let params = UpdaterParams::paper();
            let mut n_votes = 0;
            for k in 0..2000 {
                let origin = g.grid_to_world(5.0 + (k % 11) as f64 * 17.9, 5.0 + (k % 7) as f64 * 22.3);
                let a = k as f64 * 0.37 + yaw;
                let z = 0.5 + (k % 17) as f64 * 0.6;
                let hit = Point2::new(origin.x + z * a.cos(), origin.y + z * a.sin());
                let mut got = Vec::new();
                evaluate_unchanged_beam(&base, origin, hit, z, &params, 0.0, &mut buffers.probe(), &mut got);
                // The hit cell is free here and has no non-free neighbour: only traversal votes.
                let want = reference(&base, origin, hit, z, &params, &buffers);
                assert_eq!(got, want, "ray {k}");
                n_votes += got.len();
                // Starting the walk at the first buffered cell's distance changes nothing.
                if let Some(&first) = want.first() {
                    let c = g.coord((first >> 1) as usize);
                    let (u, v) = g.world_to_grid(origin);
                    let du = (c.ix as f64 - u).max(u - c.ix as f64 - 1.0).max(0.0);
                    let dv = (c.iy as f64 - v).max(v - c.iy as f64 - 1.0).max(0.0);
                    let nearest_m = du.hypot(dv) * g.resolution_m();
                    let mut from = Vec::new();
                    evaluate_unchanged_beam(&base, origin, hit, z, &params, nearest_m, &mut buffers.probe(), &mut from);
                    assert_eq!(from, want, "ray {k} from {nearest_m} m");
                }
            }
            assert!(n_votes > 500, "the rays must cross buffered cells ({n_votes} votes)");
        }
    }
}
