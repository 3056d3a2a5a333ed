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
//! chunk of `skip_unchanged_m(z)` skipped, and only cells that already hold a buffer. The
//! beam's own hit cell c(p_i) never gets one: the changed evaluator may vote it "changed" (an
//! added obstacle, §4.3.2), and on a short beam the final chunk is shorter than the distance
//! from p_i to its cell's centre, so the walk would otherwise vote it both ways.

use crate::UpdaterParams;
use crate::support::beam_walk::{BeamGeometry, buffered_cells_before_chunk};
use crate::support::cell_buffers::TileProbe;
use crate::support::votes::{Vote, vote};
use mapkeeper_grid::{CellState, OccupancyGrid};

/// Appends "unchanged" votes for the cells free in `base` that the detected-change `beam`
/// crossed before its final chunk, where a buffer exists (the same signature as
/// [`crate::paper::unchanged_cells::evaluate_unchanged_beam`]). `first_buffer_m`: no cell
/// closer than this to the beam's origin along the beam holds a buffer (see
/// [`crate::paper::beam_classifier::Beam::walk_from_m`]); the walk starts about there and crosses tiles
/// without buffers without visiting their cells (the same votes as a cell-by-cell walk).
pub fn evaluate_free_pass(
    base: &OccupancyGrid,
    beam: &BeamGeometry,
    params: &UpdaterParams,
    first_buffer_m: f64,
    probe: &mut TileProbe<'_>,
    votes: &mut Vec<Vote>,
) {
    let g = base.geometry();
    let cells = base.cells();
    let skip = params.skip_unchanged_m(beam.range_m);
    let skip_sq = skip * skip;
    let hit_cell = g.world_to_cell(beam.hit);
    buffered_cells_before_chunk(g, beam, skip, first_buffer_m, probe, |c, i| {
        if cells[i] == CellState::Free && g.cell_center(c).distance_sq(beam.hit) > skip_sq && Some(c) != hit_cell {
            votes.push(vote(i, false));
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::support::cell_buffers::CellBuffers;
    use mapkeeper_grid::{CellCoord, GridGeometry, Point2, Pose2, traverse};
    use std::ops::ControlFlow;

    /// The skipping walk gives exactly the votes of a plain cell-by-cell walk.
    #[test]
    fn same_votes_as_a_plain_walk() {
        let g = GridGeometry::new(120, 90, 0.05, Pose2::new(-1.0, 0.5, 0.0)).unwrap();
        let mut m = OccupancyGrid::filled(g, CellState::Free);
        for k in 0..90 {
            m.set(CellCoord::new(60, k), if k % 7 == 0 { CellState::Free } else { CellState::Occupied });
        }
        let mut buffers = CellBuffers::new();
        for k in 0..400u32 {
            let c = CellCoord::new(((k * 37) % 120) as i32, ((k * 53) % 90) as i32);
            buffers.ensure(g.index(c).unwrap() as u32, c);
        }
        let params = UpdaterParams::paper();
        for k in 0..360 {
            let origin = g.grid_to_world(5.0 + (k % 11) as f64 * 9.7, 3.0 + (k % 13) as f64 * 6.3);
            let a = k as f64 * 1.0f64.to_radians() + 0.0013;
            let z = 0.5 + (k % 9) as f64 * 0.6;
            let hit = Point2::new(origin.x + z * a.cos(), origin.y + z * a.sin());
            let mut got = Vec::new();
            evaluate_free_pass(&m, &BeamGeometry::new(origin, hit, z), &params, 0.0, &mut buffers.probe(), &mut got);
            let mut want = Vec::new();
            let skip = params.skip_unchanged_m(z);
            if let Some(p_th) = BeamGeometry::new(origin, hit, z).threshold_point(skip) {
                let mut probe = buffers.probe();
                let _ = traverse(&g, origin, p_th, |c| {
                    let i = g.index(c).unwrap();
                    if m.cells()[i] == CellState::Free
                        && probe.contains(c)
                        && g.cell_center(c).distance_sq(hit) > skip * skip
                        && Some(c) != g.world_to_cell(hit)
                    {
                        want.push(vote(i, false));
                    }
                    ControlFlow::<()>::Continue(())
                });
            }
            assert_eq!(got, want, "ray {k}");
        }
    }
}
