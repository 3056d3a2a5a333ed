//! Changed cells evaluator (§4.3) for one detected-change beam.
//!
//! - §4.3.1: cells traversed from the lidar up to p_th (eq. 9: only cells whose centre is
//!   further from p_i than the skipped final chunk, Fig. 10) that are occupied — or unknown,
//!   which counts as occupied — in `M_{i-1}` get a "changed" vote: an obstacle was removed.
//! - §4.3.2: the hit cell c(p_i) gets a "changed" vote iff every cell within tol(z_i) of p_i is
//!   free in `M_{i-1}` (Fig. 11-13): an obstacle was added. A removed obstacle leaves p_i on
//!   some other, mapped obstacle, so some cell near p_i is occupied and no vote is cast.
//!
//! The removal vote of §4.3.1 passes through a [`RemovalFilter`] (the paper's: [`PassAll`];
//! the project's gates plug in there: hit clearance, grazing incidence, ray core, shadow, off in
//! the `paper` and `authors` presets). The non-free cells along the ray are found by
//! [`RayCaster::visit_blocking`] (open stretches crossed without visiting them), and the tol
//! test is answered by the caster's clearance where it decides; both give the plain walk's
//! votes (test below).

use crate::UpdaterParams;
use crate::support::beam_walk::BeamGeometry;
#[cfg(doc)]
use crate::support::removal_filter::PassAll;
use crate::support::removal_filter::RemovalFilter;
use crate::support::step_tolerance::StepTolerance;
use crate::support::votes::{Vote, vote};
use mapkeeper_grid::geometry::floor_exact;
use mapkeeper_grid::{CellCoord, CellState, OccupancyGrid, Point2, RayCaster, SegmentWalk};

/// Whether every cell that has a point closer than `radius_m` to `p` is free in `grid`
/// (cells outside the grid are unknown, hence not free).
pub fn all_free_within(grid: &OccupancyGrid, p: Point2, radius_m: f64) -> bool {
    let g = grid.geometry();
    let (u, v) = g.world_to_grid(p);
    let r = radius_m / g.resolution_m();
    if !(u.is_finite() && v.is_finite() && r.is_finite()) {
        return false;
    }
    let (x0, x1) = (floor_exact(u - r) as i64, floor_exact(u + r) as i64);
    let (y0, y1) = (floor_exact(v - r) as i64, floor_exact(v + r) as i64);
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
            let c = CellCoord::new(ix as i32, iy as i32);
            if grid.get(c) != Some(CellState::Free) {
                return false;
            }
        }
    }
    true
}

/// Appends the changed evaluator's votes for one detected-change `beam` to `votes`. The caller
/// makes sure every voted cell has a buffer before the unchanged evaluator runs
/// ([`crate::support::votes::ensure_buffers`]). `filter` makes the ray's removal filter (called
/// only when the ray has cells to vote; [`PassAll`]: the paper's). `tol`: the step's pose
/// uncertainty ([`StepTolerance::NONE`]: the paper's fixed tolerances).
pub fn evaluate_changed_beam<F: RemovalFilter>(
    base: &OccupancyGrid,
    beam: &BeamGeometry,
    (params, tol): (&UpdaterParams, &StepTolerance),
    filter: impl FnOnce(&BeamGeometry) -> F,
    votes: &mut Vec<Vote>,
) {
    let g = base.geometry();
    let cells = base.cells();
    let all_free = |p, radius| all_free_within(base, p, radius);
    let non_free_on = |from: Point2, to: Point2, visit: &mut dyn FnMut(CellCoord, usize)| {
        if let Some(mut walk) = SegmentWalk::start(g, from, to) {
            loop {
                if cells[walk.index()] != CellState::Free {
                    visit(walk.cell(), walk.index());
                }
                if !walk.advance() {
                    break;
                }
            }
        }
    };
    changed_votes(base, beam, (params, tol), filter, votes, non_free_on, all_free);
}

/// [`evaluate_changed_beam`] with `M_{i-1}` behind a caster whose unknown cells block: the
/// non-free cells along the ray are found with [`RayCaster::visit_blocking`], which crosses
/// open stretches without visiting them (the same cells, the same votes).
pub fn evaluate_changed_beam_cast<F: RemovalFilter>(
    base: &RayCaster,
    beam: &BeamGeometry,
    (params, tol): (&UpdaterParams, &StepTolerance),
    filter: impl FnOnce(&BeamGeometry) -> F,
    votes: &mut Vec<Vote>,
) {
    if !base.unknown_blocks() {
        return evaluate_changed_beam(base.map(), beam, (params, tol), filter, votes);
    }
    let all_free = |p, radius| {
        // Exact shortcuts: p's own cell blocks (it is always among the cells looked at), or
        // no blocking cell and no border within the radius (plus a margin far above the
        // rounding of the distances compared).
        let free = base.free_radius_m(p);
        if free == f64::NEG_INFINITY {
            false
        } else if free > radius * (1.0 + 1e-9) + 1e-9 {
            true
        } else {
            all_free_within(base.map(), p, radius)
        }
    };
    changed_votes(
        base.map(),
        beam,
        (params, tol),
        filter,
        votes,
        |from, to, visit| base.visit_blocking(from, to, visit),
        all_free,
    );
}

/// The changed evaluator given a way to visit the non-free cells of `M_{i-1}` that the
/// traversal of a segment visits, in order, and [`all_free_within`] or an equivalent.
fn changed_votes<F: RemovalFilter>(
    base: &OccupancyGrid,
    beam: &BeamGeometry,
    (params, tol): (&UpdaterParams, &StepTolerance),
    filter: impl FnOnce(&BeamGeometry) -> F,
    votes: &mut Vec<Vote>,
    non_free_on: impl FnOnce(Point2, Point2, &mut dyn FnMut(CellCoord, usize)),
    all_free: impl FnOnce(Point2, f64) -> bool,
) {
    let g = base.geometry();
    let (hit, z) = (beam.hit, beam.range_m);
    let skip = params.skip_changed_m(z);
    // §4.3.1: removed obstacle, the non-free cells up to p_th (eq. 9), through the filter.
    if let Some(p_th) = beam.threshold_point(skip) {
        let skip_sq = skip * skip;
        let mut gates = filter(beam);
        let inv_z = 1.0 / z.max(1e-12);
        let dir = ((hit.x - beam.origin.x) * inv_z, (hit.y - beam.origin.y) * inv_z);
        non_free_on(beam.origin, p_th, &mut |c, i| {
            if gates.in_shadow(c) {
                return;
            }
            let centre = g.cell_center(c);
            if centre.distance_sq(hit) > skip_sq
                && gates.passes(c, centre)
                && tol.band_is_non_free(base, beam.origin, dir, centre)
            {
                votes.push(vote(i, true));
            }
        });
    }
    // §4.3.2: added obstacle, c(p_i) if everything within tol(z) of p_i is free (plus where the
    // pose's uncertainty may have put p_i).
    if let Some(c) = g.world_to_cell(hit)
        && let Some(i) = g.index(c)
        && all_free(hit, params.tol_m(z) + tol.lateral_m(z))
    {
        votes.push(vote(i, true));
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
