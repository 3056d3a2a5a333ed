//! Unchanged cells evaluator (§4.4) for one beam without detected change: cells traversed up
//! to p_th (final chunk max(0.02·z, min) skipped) get an "unchanged" vote; for the hit cell, if
//! it is free in `M_{i-1}` the occupied (or unknown) cells adjacent to it get the vote,
//! otherwise the hit cell itself does.
//!
//! Only cells that already hold a buffer are voted on: an "unchanged" flag in a cell without a
//! buffer would create a buffer without a "changed" flag, which is dropped at once
//! (see [`crate::cell_buffers`]).

use crate::UpdaterParams;
use crate::cell_buffers::TileProbe;
use crate::changed_cells::{Vote, threshold_point, vote};
use mapkeeper_grid::{CellState, OccupancyGrid, Point2, traverse};
use std::ops::ControlFlow;

/// Appends the unchanged evaluator's votes for one beam to `votes`.
pub fn evaluate_unchanged_beam(
    base: &OccupancyGrid,
    origin: Point2,
    hit: Point2,
    z: f64,
    params: &UpdaterParams,
    probe: &mut TileProbe<'_>,
    votes: &mut Vec<Vote>,
) {
    let g = base.geometry();
    let skip = params.skip_unchanged_m(z);
    if let Some(p_th) = threshold_point(origin, hit, z, skip) {
        let skip_sq = skip * skip;
        let _ = traverse(g, origin, p_th, |c| {
            if probe.contains(c) && g.cell_center(c).distance_sq(hit) > skip_sq {
                votes.push(vote(c.iy as usize * g.width() + c.ix as usize, false));
            }
            ControlFlow::<()>::Continue(())
        });
    }
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
