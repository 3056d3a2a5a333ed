//! Changed cells evaluator (§4.3) for one detected-change beam.
//!
//! - §4.3.1: cells traversed from the lidar up to p_th (eq. 9: only cells whose centre is
//!   further from p_i than the skipped final chunk, Fig. 10) that are occupied — or unknown,
//!   which counts as occupied — in `M_{i-1}` get a "changed" vote: an obstacle was removed.
//! - §4.3.2: the hit cell c(p_i) gets a "changed" vote iff every cell within tol(z_i) of p_i is
//!   free in `M_{i-1}` (Fig. 11-13): an obstacle was added. A removed obstacle leaves p_i on
//!   some other, mapped obstacle, so some cell near p_i is occupied and no vote is cast.
//!
//! The removal vote of §4.3.1 passes through the project's gates
//! ([`crate::additions::removal_gates`]: hit clearance, grazing incidence, ray core, shadow),
//! which are off in the `paper` and `authors` presets. The non-free cells along the ray are found by
//! [`RayCaster::visit_blocking`] (open stretches crossed without visiting them), and the tol
//! test is answered by the caster's clearance where it decides; both give the plain walk's
//! votes (test below).

use crate::UpdaterParams;
use crate::additions::hit_index::HitIndex;
use crate::additions::pose_tolerance::StepTolerance;
use crate::additions::removal_gates::RemovalGates;
use crate::support::beam_walk::BeamGeometry;
use crate::support::votes::{Vote, vote};
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
/// ([`crate::support::votes::ensure_buffers`]). `hits` holds the step's measured hit points for the hit clearance
/// (`UpdaterParams::removal_hit_clearance_m`; an empty index disables it). `tol`: the step's
/// pose uncertainty ([`StepTolerance::NONE`]: the paper's fixed tolerances).
pub fn evaluate_changed_beam(
    base: &OccupancyGrid,
    beam: &BeamGeometry,
    (params, tol): (&UpdaterParams, &StepTolerance),
    hits: &HitIndex,
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
    changed_votes(base, beam, (params, tol), hits, votes, non_free_on, all_free);
}

/// [`evaluate_changed_beam`] with `M_{i-1}` behind a caster whose unknown cells block: the
/// non-free cells along the ray are found with [`RayCaster::visit_blocking`], which crosses
/// open stretches without visiting them (the same cells, the same votes).
pub fn evaluate_changed_beam_cast(
    base: &RayCaster,
    beam: &BeamGeometry,
    (params, tol): (&UpdaterParams, &StepTolerance),
    hits: &HitIndex,
    votes: &mut Vec<Vote>,
) {
    if !base.unknown_blocks() {
        return evaluate_changed_beam(base.map(), beam, (params, tol), hits, votes);
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
        hits,
        votes,
        |from, to, visit| base.visit_blocking(from, to, visit),
        all_free,
    );
}

/// The changed evaluator given a way to visit the non-free cells of `M_{i-1}` that the
/// traversal of a segment visits, in order, and [`all_free_within`] or an equivalent.
fn changed_votes(
    base: &OccupancyGrid,
    beam: &BeamGeometry,
    (params, tol): (&UpdaterParams, &StepTolerance),
    hits: &HitIndex,
    votes: &mut Vec<Vote>,
    non_free_on: impl FnOnce(Point2, Point2, &mut dyn FnMut(CellCoord, usize)),
    all_free: impl FnOnce(Point2, f64) -> bool,
) {
    let g = base.geometry();
    let (hit, z) = (beam.hit, beam.range_m);
    let skip = params.skip_changed_m(z);
    // §4.3.1: removed obstacle, the non-free cells up to p_th (eq. 9), through the gates.
    if let Some(p_th) = beam.threshold_point(skip) {
        let skip_sq = skip * skip;
        let mut gates = RemovalGates::new(base, params, hits, beam);
        let inv_z = 1.0 / z.max(1e-12);
        let dir = ((hit.x - beam.origin.x) * inv_z, (hit.y - beam.origin.y) * inv_z);
        non_free_on(beam.origin, p_th, &mut |c, i| {
            if gates.in_shadow(c) {
                return;
            }
            let centre = g.cell_center(c);
            if centre.distance_sq(hit) > skip_sq
                && gates.near_core(centre)
                && !gates.withholds(c, centre)
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
    fn caster_walk_gives_the_votes_of_a_full_walk() {
        // A room with box outlines (occupied border, unknown inside) and scattered cells.
        let g = GridGeometry::new(240, 180, 0.05, Pose2::new(-1.0, 0.5, 0.2)).unwrap();
        let mut m = OccupancyGrid::filled(g, CellState::Free);
        for k in 0..240 {
            m.set(CellCoord::new(k, 0), CellState::Occupied);
            m.set(CellCoord::new(k, 179), CellState::Occupied);
        }
        for (x0, y0) in [(40, 30), (150, 100), (90, 140), (200, 20)] {
            for ix in x0..x0 + 24 {
                for iy in y0..y0 + 20 {
                    let edge = ix == x0 || iy == y0 || ix == x0 + 23 || iy == y0 + 19;
                    m.set(CellCoord::new(ix, iy), if edge { CellState::Occupied } else { CellState::Unknown });
                }
            }
        }
        for k in 0..60 {
            m.set(CellCoord::new((k * 37) % 240, (k * 53) % 180), CellState::Occupied);
        }
        let caster = RayCaster::new(&m, true);
        let params = UpdaterParams::paper();
        let mut n_votes = 0;
        // A hit index holding some of the rays' end points: the gates run on both paths.
        let mut hits = HitIndex::new();
        hits.rebuild(
            params.removal_hit_clearance_m,
            (0..720).step_by(3).map(|k| {
                let origin = g.grid_to_world(20.0 + (k % 7) as f64 * 25.3, 10.0 + (k % 5) as f64 * 31.7);
                let a = k as f64 * 0.5f64.to_radians() + 0.001;
                let z = 1.0 + (k % 13) as f64;
                Point2::new(origin.x + z * a.cos(), origin.y + z * a.sin())
            }),
        );
        for k in 0..720 {
            let origin = g.grid_to_world(20.0 + (k % 7) as f64 * 25.3, 10.0 + (k % 5) as f64 * 31.7);
            let a = k as f64 * 0.5f64.to_radians() + 0.001;
            let z = 1.0 + (k % 13) as f64;
            let hit = Point2::new(origin.x + z * a.cos(), origin.y + z * a.sin());
            let (mut want, mut got) = (Vec::new(), Vec::new());
            let beam = BeamGeometry::new(origin, hit, z);
            let tol = StepTolerance::NONE;
            evaluate_changed_beam(&m, &beam, (&params, &tol), &hits, &mut want);
            evaluate_changed_beam_cast(&caster, &beam, (&params, &tol), &hits, &mut got);
            assert_eq!(got, want, "ray {k}");
            n_votes += want.len();
        }
        assert!(n_votes > 1000, "the rays must cross obstacles ({n_votes} votes)");
    }

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
