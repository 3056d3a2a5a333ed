//! Changed cells evaluator (§4.3) for one detected-change beam.
//!
//! - §4.3.1: cells traversed from the lidar up to p_th (eq. 9: only cells whose centre is
//!   further from p_i than the skipped final chunk, Fig. 10) that are occupied — or unknown,
//!   which counts as occupied — in `M_{i-1}` get a "changed" vote: an obstacle was removed.
//! - §4.3.2: the hit cell c(p_i) gets a "changed" vote iff every cell within tol(z_i) of p_i is
//!   free in `M_{i-1}` (Fig. 11-13): an obstacle was added. A removed obstacle leaves p_i on
//!   some other, mapped obstacle, so some cell near p_i is occupied and no vote is cast.

use crate::UpdaterParams;
use crate::additions::grazing;
use crate::additions::hit_index::HitIndex;
use crate::paper::cell_buffers::CellBuffers;
use mapkeeper_grid::{CellCoord, CellState, OccupancyGrid, Point2, RayCaster, SegmentWalk};

/// A vote of one beam on one cell during a step, packed as `index << 1 | changed`.
pub type Vote = u32;

/// Packs a vote.
#[inline]
pub fn vote(index: usize, changed: bool) -> Vote {
    ((index as u32) << 1) | changed as u32
}

/// Free cells in a row a ray must cross after a withheld vote before it votes again.
const SHADOW_CLEAR_CELLS: i32 = 3;

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
            let c = CellCoord::new(ix as i32, iy as i32);
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
    changed_votes(base, origin, hit, z, params, hits, votes, non_free_on, all_free);
}

/// [`evaluate_changed_beam`] with `M_{i-1}` behind a caster whose unknown cells block: the
/// non-free cells along the ray are found with [`RayCaster::visit_blocking`], which crosses
/// open stretches without visiting them (the same cells, the same votes).
#[allow(clippy::too_many_arguments)]
pub fn evaluate_changed_beam_cast(
    base: &RayCaster,
    origin: Point2,
    hit: Point2,
    z: f64,
    params: &UpdaterParams,
    hits: &HitIndex,
    votes: &mut Vec<Vote>,
) {
    if !base.unknown_blocks() {
        return evaluate_changed_beam(base.map(), origin, hit, z, params, hits, votes);
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
        origin,
        hit,
        z,
        params,
        hits,
        votes,
        |from, to, visit| base.visit_blocking(from, to, visit),
        all_free,
    );
}

/// The changed evaluator given a way to visit the non-free cells of `M_{i-1}` that the
/// traversal of a segment visits, in order, and [`all_free_within`] or an equivalent.
#[allow(clippy::too_many_arguments)]
fn changed_votes(
    base: &OccupancyGrid,
    origin: Point2,
    hit: Point2,
    z: f64,
    params: &UpdaterParams,
    hits: &HitIndex,
    votes: &mut Vec<Vote>,
    non_free_on: impl FnOnce(Point2, Point2, &mut dyn FnMut(CellCoord, usize)),
    all_free: impl FnOnce(Point2, f64) -> bool,
) {
    let g = base.geometry();
    let skip = params.skip_changed_m(z);
    if let Some(p_th) = threshold_point(origin, hit, z, skip) {
        let skip_sq = skip * skip;
        let min_sin = params.removal_min_incidence_rad.sin();
        let (dx, dy) = (hit.x - origin.x, hit.y - origin.y);
        let inv_len = 1.0 / dx.hypot(dy).max(1e-12);
        let max_off = params.removal_max_offset_cells * g.resolution_m();
        // The ray's incidence on the x faces and on the y faces of the cells (|sin| to the face).
        let (sin_x, sin_y) = (dx.abs() * inv_len, dy.abs() * inv_len);
        // Set when the ray crossed a non-free cell whose vote the hit clearance or the grazing
        // gate withheld; the run of non-free cells behind it gets no vote either (the ray is not
        // trusted to have passed the surface), until the ray has crossed SHADOW_CLEAR_CELLS free
        // cells in a row (a one-cell gap between two stacked boxes does not clear it). The walk
        // is 4-connected, so the free cells between two visited non-free cells number their
        // Manhattan distance minus one.
        let mut shadowed = false;
        let mut prev: Option<CellCoord> = None;
        non_free_on(origin, p_th, &mut |c, i| {
            if let Some(p) = prev
                && (c.ix - p.ix).abs() + (c.iy - p.iy).abs() > SHADOW_CLEAR_CELLS
            {
                shadowed = false;
            }
            prev = Some(c);
            if shadowed {
                return;
            }
            let centre = g.cell_center(c);
            let off = ((centre.x - origin.x) * dy - (centre.y - origin.y) * dx).abs() * inv_len;
            if centre.distance_sq(hit) > skip_sq && off <= max_off {
                // Cheapest test first (the result is their "or").
                if grazing::meets_a_free_face_grazing(base, c, sin_x, sin_y, min_sin)
                    || hits.any_within(centre)
                    || grazing::is_grazing(base, c, dx, dy, min_sin)
                {
                    shadowed = true;
                } else {
                    votes.push(vote(i, true));
                }
            }
        });
    }
    if let Some(c) = g.world_to_cell(hit)
        && let Some(i) = g.index(c)
        && all_free(hit, params.tol_m(z))
    {
        votes.push(vote(i, true));
    }
}

/// Sorts `votes` (the same order as `sort_unstable`, by an LSD radix sort with 11-bit digits:
/// two passes for maps up to 2^21 cells) and creates a buffer for every cell with a "changed"
/// vote. `scratch` is reusable memory (its contents are overwritten; after the call it may hold
/// the allocation `votes` had).
pub fn ensure_buffers(votes: &mut Vec<Vote>, scratch: &mut Vec<Vote>, width: usize, buffers: &mut CellBuffers) {
    sort_votes(votes, scratch);
    let mut last = u32::MAX;
    for &v in votes.iter() {
        if v & 1 == 1 && v != last {
            last = v;
            let i = (v >> 1) as usize;
            buffers.ensure(i as u32, CellCoord::new((i % width) as i32, (i / width) as i32));
        }
    }
}

/// Sorts `votes` ascending; the result equals `votes.sort_unstable()` (a sorted `u32` sequence is
/// unique). Long inputs go through an LSD radix sort using `scratch`.
pub fn sort_votes(votes: &mut Vec<Vote>, scratch: &mut Vec<Vote>) {
    const BITS: u32 = 11;
    const MASK: u32 = (1 << BITS) - 1;
    if votes.len() < 256 {
        votes.sort_unstable();
        return;
    }
    let max = votes.iter().copied().max().unwrap_or(0);
    let bits = u32::BITS - max.leading_zeros();
    scratch.clear();
    scratch.resize(votes.len(), 0);
    let mut shift = 0;
    while shift < bits {
        let mut start = [0u32; 1 << BITS];
        for &v in votes.iter() {
            start[((v >> shift) & MASK) as usize] += 1;
        }
        let mut sum = 0;
        for c in start.iter_mut() {
            let n = *c;
            *c = sum;
            sum += n;
        }
        for &v in votes.iter() {
            let d = ((v >> shift) & MASK) as usize;
            scratch[start[d] as usize] = v;
            start[d] += 1;
        }
        std::mem::swap(votes, scratch);
        shift += BITS;
    }
}

/// Makes `votes` sorted when `votes[..split]` already is: sorts the tail and merges it in
/// (linear in the elements moved), using `scratch` for the tail.
pub fn merge_sorted_tail(votes: &mut [Vote], split: usize, scratch: &mut Vec<Vote>) {
    let split = split.min(votes.len());
    if split == votes.len() {
        return;
    }
    votes[split..].sort_unstable();
    if split == 0 || votes[split - 1] <= votes[split] {
        return;
    }
    scratch.clear();
    scratch.extend_from_slice(&votes[split..]);
    // Merge from the back: the largest remaining element goes to the end.
    let (mut i, mut j, mut k) = (split, scratch.len(), votes.len());
    while j > 0 {
        k -= 1;
        if i > 0 && votes[i - 1] > scratch[j - 1] {
            votes[k] = votes[i - 1];
            i -= 1;
        } else {
            votes[k] = scratch[j - 1];
            j -= 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mapkeeper_grid::{CellCoord, GridGeometry, Pose2};

    #[test]
    fn vote_sorting_equals_sort_unstable() {
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let mut scratch = Vec::new();
        for (n, max) in [(0usize, 10u64), (5, 1 << 20), (300, 1 << 8), (3000, 1 << 19), (3000, 1 << 32), (700, 1 << 12)]
        {
            let v: Vec<Vote> = (0..n).map(|_| (next() % max) as Vote).collect();
            let mut want = v.clone();
            want.sort_unstable();
            let mut got = v.clone();
            sort_votes(&mut got, &mut scratch);
            assert_eq!(got, want, "n={n} max={max}");
            // Sorted prefix + unsorted tail, merged.
            for split in [0, n / 2, n.saturating_sub(7), n] {
                let mut m = v.clone();
                m[..split].sort_unstable();
                merge_sorted_tail(&mut m, split, &mut scratch);
                assert_eq!(m, want, "n={n} split={split}");
            }
        }
    }

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
            evaluate_changed_beam(&m, origin, hit, z, &params, &hits, &mut want);
            evaluate_changed_beam_cast(&caster, origin, hit, z, &params, &hits, &mut got);
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
