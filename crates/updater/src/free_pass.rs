//! Free-pass votes (a project addition, not in the paper): a detected-change beam also says
//! that the cells it crossed were free. The paper's changed evaluator votes only on cells that
//! `M_{i-1}` holds occupied or unknown (§4.3.1); the cells it holds free get no vote from such
//! a beam. Without this rule, a cell free in `M_{i-1}` that the range noise and the pose error
//! put a hit into now and then collects nothing but "changed" flags and, given time, flips —
//! new obstacles come out two to four cells thick, the spurious cells mostly in front of
//! their faces. With it, every step in which more beams crossed the cell than ended in it
//! pushes an "unchanged" flag, as an occupancy mapper would count a miss.
//!
//! The votes follow the unchanged evaluator's geometry (§4.4): cells up to p_th, the final
//! chunk of `skip_unchanged_m(z)` skipped, and only cells that already hold a buffer.

use crate::UpdaterParams;
use crate::cell_buffers::TileProbe;
use crate::changed_cells::{Vote, threshold_point, vote};
use mapkeeper_grid::{CellState, OccupancyGrid, Point2, traverse};
use std::ops::ControlFlow;

/// Appends "unchanged" votes for the cells free in `base` that the detected-change beam from
/// `origin` to `hit` (range `z`) crossed before its final chunk, where a buffer exists.
pub fn evaluate_free_pass(
    base: &OccupancyGrid,
    origin: Point2,
    hit: Point2,
    z: f64,
    params: &UpdaterParams,
    probe: &mut TileProbe<'_>,
    votes: &mut Vec<Vote>,
) {
    let g = base.geometry();
    let cells = base.cells();
    let skip = params.skip_unchanged_m(z);
    let Some(p_th) = threshold_point(origin, hit, z, skip) else { return };
    let skip_sq = skip * skip;
    let _ = traverse(g, origin, p_th, |c| {
        let i = c.iy as usize * g.width() + c.ix as usize;
        if cells[i] == CellState::Free && probe.contains(c) && g.cell_center(c).distance_sq(hit) > skip_sq {
            votes.push(vote(i, false));
        }
        ControlFlow::<()>::Continue(())
    });
}
