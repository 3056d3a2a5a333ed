//! Unchanged cells evaluator (§4.4) for one beam without detected change: cells traversed up
//! to p_th (final chunk max(0.02·z, min) skipped) get an "unchanged" vote (with
//! `unchanged_ray_free_only`, only those free in `M_{i-1}`); for the hit cell, if it is free in
//! `M_{i-1}` the occupied (or unknown) cells adjacent to it get the vote, otherwise the hit cell
//! itself does (`unchanged_hit = "adjacent8"`); the authors' code instead votes the hit cell
//! and its 4-neighbours, each if non-free (`"cross4"`).
//!
//! Only cells that already hold a buffer are voted on: an "unchanged" flag in a cell without a
//! buffer would create a buffer without a "changed" flag, which is dropped at once
//! (see [`crate::support::cell_buffers`]). The walk along the beam starts near the first tile
//! holding a buffer and crosses tiles without buffers at once
//! ([`crate::support::beam_walk::buffered_cells_before_chunk`]); the votes are those of a plain
//! cell-by-cell walk (test below).

use crate::UpdaterParams;
use crate::params::UnchangedHitRule;
use crate::support::beam_walk::{BeamGeometry, buffered_cells_before_chunk};
use crate::support::cell_buffers::TileProbe;
use crate::support::votes::{Vote, vote};
use mapkeeper_grid::{CellCoord, CellState, OccupancyGrid};

/// Appends the unchanged evaluator's votes for one `beam` to `votes`. `first_buffer_m`: no cell
/// closer than this to the beam's origin along the beam holds a buffer (0 if unknown; see
/// [`crate::paper::beam_classifier::Beam::walk_from_m`]), so the walk starts about there.
pub fn evaluate_unchanged_beam(
    base: &OccupancyGrid,
    beam: &BeamGeometry,
    params: &UpdaterParams,
    first_buffer_m: f64,
    probe: &mut TileProbe<'_>,
    votes: &mut Vec<Vote>,
) {
    let g = base.geometry();
    let hit = beam.hit;
    let skip = params.skip_unchanged_m(beam.range_m);
    let skip_sq = skip * skip;
    let free_only = params.unchanged_ray_free_only;
    buffered_cells_before_chunk(g, beam, skip, first_buffer_m, probe, |c, i| {
        if g.cell_center(c).distance_sq(hit) > skip_sq && (!free_only || base.cells()[i] == CellState::Free) {
            votes.push(vote(i, false));
        }
    });
    let Some(c) = g.world_to_cell(hit) else { return };
    if params.unchanged_hit == UnchangedHitRule::Cross4 {
        for n in [
            c,
            CellCoord::new(c.ix + 1, c.iy),
            CellCoord::new(c.ix - 1, c.iy),
            CellCoord::new(c.ix, c.iy + 1),
            CellCoord::new(c.ix, c.iy - 1),
        ] {
            if let Some(i) = g.index(n)
                && base.cells()[i] != CellState::Free
                && probe.contains(n)
            {
                votes.push(vote(i, false));
            }
        }
        return;
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::support::cell_buffers::CellBuffers;
    use mapkeeper_grid::{CellCoord, GridGeometry, Point2, Pose2, traverse};
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
        if let Some(p_th) = BeamGeometry::new(origin, hit, z).threshold_point(skip) {
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
                evaluate_unchanged_beam(
                    &base,
                    &BeamGeometry::new(origin, hit, z),
                    &params,
                    0.0,
                    &mut buffers.probe(),
                    &mut got,
                );
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
                    evaluate_unchanged_beam(
                        &base,
                        &BeamGeometry::new(origin, hit, z),
                        &params,
                        nearest_m,
                        &mut buffers.probe(),
                        &mut from,
                    );
                    assert_eq!(from, want, "ray {k} from {nearest_m} m");
                }
            }
            assert!(n_votes > 500, "the rays must cross buffered cells ({n_votes} votes)");
        }
    }
}
