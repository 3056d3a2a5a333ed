//! Ray casting accelerated by a clearance field: exactly the answers of [`cast_ray`], faster
//! on a fixed map.
//!
//! For a map that does not change while it is queried (the updater's `M_{i-1}`), each cell
//! stores its clearance: the distance from its centre to the centre of the nearest blocking
//! cell. Inside a cell of clearance `c`, no point of any blocking cell lies closer than
//! `c − r√2` (each point is within `r√2/2` of its cell's centre), so the walk may jump that far
//! along the ray without passing through, or touching, a blocking cell; near obstacles it walks
//! cell by cell as [`cast_ray`] does. Open aisles are crossed in a few jumps instead of a cell at
//! a time.

use crate::distance::DistanceField;
use crate::grid::{CellCoord, CellState, GridGeometry, OccupancyGrid};
use crate::pose::Point2;
use crate::traversal::{RayHit, RayStop, SegmentWalk, cast_ray, entry_distance_grid, floor_i64};

/// Jumps shorter than this many cells are not worth restarting the walk for (6 rather than 12:
/// +7 % rays per second on both maps of the traversal bench, the same hits).
const MIN_JUMP_CELLS: f64 = 6.0;

/// A ray direction prepared for one [`RayCaster`]: the map-frame angle with its sine and
/// cosine (for end points), and the sine and cosine relative to the grid's axes (for the walk).
/// On a grid without rotation both pairs are the same one `sin_cos`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayDir {
    angle: f64,
    sin: f64,
    cos: f64,
    grid_sin: f64,
    grid_cos: f64,
    grid_yaw: f64,
}

impl RayDir {
    /// The map-frame angle, radians.
    #[inline]
    pub fn angle(&self) -> f64 {
        self.angle
    }

    /// `angle.sin()`, bit for bit.
    #[inline]
    pub fn sin(&self) -> f64 {
        self.sin
    }

    /// `angle.cos()`, bit for bit.
    #[inline]
    pub fn cos(&self) -> f64 {
        self.cos
    }
}

/// Discs of free space around points of rays cast from one origin, kept from one ray to the
/// next: the rays of one scan are close, so most of one ray's discs also cover the next
/// (scratch for [`RayCaster::stops_between`]; reset it for every new origin).
#[derive(Clone, Debug, Default)]
pub struct FreeDiscs {
    origin: Point2,
    /// The origin in grid coordinates, once known (for the geometry it was computed in).
    origin_grid: Option<(GridGeometry, (f64, f64))>,
    /// (centre u, centre v, radius, squared distance of the centre from the origin), grid
    /// coordinates and cells, in the order of the last ray they covered.
    discs: Vec<(f64, f64, f64, f64)>,
    next: Vec<(f64, f64, f64, f64)>,
}

impl FreeDiscs {
    /// Empty scratch.
    pub fn new() -> Self {
        Self::default()
    }

    /// Forgets the discs and sets the origin of the rays to come.
    pub fn reset(&mut self, origin: Point2) {
        self.origin = origin;
        self.origin_grid = None;
        self.discs.clear();
    }

    /// The origin in `g`'s grid coordinates (computed once per origin and geometry).
    fn origin_grid(&mut self, g: &GridGeometry) -> (f64, f64) {
        match self.origin_grid {
            Some((cached, uv)) if cached == *g => uv,
            _ => {
                let uv = g.world_to_grid(self.origin);
                self.origin_grid = Some((*g, uv));
                self.discs.clear();
                uv
            }
        }
    }

    /// Bytes of reusable scratch.
    pub fn scratch_bytes(&self) -> usize {
        (self.discs.capacity() + self.next.capacity()) * size_of::<(f64, f64, f64, f64)>()
    }
}

/// A ray caster over one fixed map.
///
/// ```
/// use mapkeeper_grid::{cast_ray, CellCoord, CellState, GridGeometry, OccupancyGrid, Point2, Pose2, RayCaster};
/// let geometry = GridGeometry::new(200, 50, 0.05, Pose2::IDENTITY).unwrap();
/// let mut map = OccupancyGrid::filled(geometry, CellState::Free);
/// for iy in 0..50 {
///     map.set(CellCoord::new(180, iy), CellState::Occupied);
/// }
/// let caster = RayCaster::new(&map, true);
/// let fast = caster.cast(Point2::new(0.3, 1.2), 0.01, 20.0);
/// assert_eq!(fast, cast_ray(&map, Point2::new(0.3, 1.2), 0.01, 20.0, true));
/// assert_eq!(fast.cell.map(|c| c.ix), Some(180));
/// // With a prepared direction (its sine and cosine are reusable for end points).
/// let dir = caster.direction(0.01);
/// assert_eq!(caster.cast_dir(Point2::new(0.3, 1.2), &dir, 20.0), fast);
/// ```
#[derive(Clone, Debug)]
pub struct RayCaster {
    map: OccupancyGrid,
    unknown_blocks: bool,
    /// Per cell: clearance minus the `r√2` margin, metres (≤ 0 next to obstacles);
    /// `-∞` for a blocking cell, so that one load answers both "blocks?" and "how far?".
    safe_jump_m: Vec<f32>,
    min_jump_m: f64,
    /// How far inside a blocking cell, in cells, a point must be for [`RayCaster::blocked_at`]:
    /// 1e-6 plus what the `f32` rounding of the longest jump could add to it (a jump's landing
    /// point may lie that much closer to a blocking cell than the clearance promises).
    edge_cells: f64,
}

/// Metres along the ray (from parameter 0 at `p0`, `d` cells per metre) to the far boundary
/// of cell `i` on one axis; infinite for a ray parallel to that axis.
#[inline]
fn boundary(i: i64, p0: f64, d: f64) -> f64 {
    if d > 0.0 {
        (i as f64 + 1.0 - p0) / d
    } else if d < 0.0 {
        (i as f64 - p0) / d
    } else {
        f64::INFINITY
    }
}

/// Why a ray stopped in a blocking cell.
#[inline]
fn blocking_stop(state: CellState) -> RayStop {
    if state == CellState::Occupied { RayStop::Occupied } else { RayStop::Unknown }
}

impl RayCaster {
    /// Prepares a caster for `map` (copied); `unknown_blocks` as in [`cast_ray`]. Costs one
    /// distance transform.
    pub fn new(map: &OccupancyGrid, unknown_blocks: bool) -> Self {
        let g = *map.geometry();
        let r = g.resolution_m();
        let cells = map.cells();
        let blocking = |s: CellState| s == CellState::Occupied || (unknown_blocks && s == CellState::Unknown);
        // Far enough to cross the whole map in one jump.
        let (w, h) = g.extent_m();
        let field = DistanceField::from_sites(&g, w.hypot(h) + r, |i| blocking(cells[i]));
        // Margin: r√2 for the two half-diagonals, plus a hair for rounding.
        let margin = r * std::f64::consts::SQRT_2 + 1e-6 * r;
        let safe_jump_m: Vec<f32> = field
            .distances_m()
            .iter()
            .zip(cells)
            .map(|(&d, &s)| if blocking(s) { f32::NEG_INFINITY } else { (d as f64 - margin) as f32 })
            .collect();
        let longest_jump = safe_jump_m.iter().fold(0.0f64, |m: f64, &j: &f32| m.max(j as f64));
        let edge_cells = 1e-6 + longest_jump * F32_SLACK / r;
        Self { map: map.clone(), unknown_blocks, safe_jump_m, min_jump_m: MIN_JUMP_CELLS * r, edge_cells }
    }

    /// The map the caster answers for.
    pub fn map(&self) -> &OccupancyGrid {
        &self.map
    }

    /// Whether unknown cells stop rays.
    pub fn unknown_blocks(&self) -> bool {
        self.unknown_blocks
    }

    /// The direction `angle` (radians, map frame) prepared for [`RayCaster::cast_dir`]: one
    /// `sin_cos` on an unrotated grid, two otherwise.
    #[inline]
    pub fn direction(&self, angle: f64) -> RayDir {
        let (sin, cos) = angle.sin_cos();
        let grid_yaw = self.map.geometry().origin().yaw;
        // `angle - 0.0` is `angle` bit for bit (also for -0.0), so the grid-relative pair is
        // the same one; only +0.0 is tested, to keep that argument trivially true.
        let (grid_sin, grid_cos) = if grid_yaw.to_bits() == 0 { (sin, cos) } else { (angle - grid_yaw).sin_cos() };
        RayDir { angle, sin, cos, grid_sin, grid_cos, grid_yaw }
    }

    /// Casts a ray: the same answer as `cast_ray(map, origin, angle, max_range_m, unknown_blocks)`
    /// (ranges equal to within rounding, 1e-9 m).
    pub fn cast(&self, origin: Point2, angle: f64, max_range_m: f64) -> RayHit {
        self.cast_dir(origin, &self.direction(angle), max_range_m)
    }

    /// [`RayCaster::cast`] along a prepared direction (bit for bit the same answer).
    #[inline]
    pub fn cast_dir(&self, origin: Point2, dir: &RayDir, max_range_m: f64) -> RayHit {
        let angle = dir.angle;
        if !(max_range_m.is_finite() && max_range_m > 0.0 && origin.is_finite() && angle.is_finite()) {
            return cast_ray(&self.map, origin, angle, max_range_m, self.unknown_blocks);
        }
        let geometry = self.map.geometry();
        if dir.grid_yaw.to_bits() != geometry.origin().yaw.to_bits() {
            // Prepared for another grid.
            return self.cast(origin, angle, max_range_m);
        }
        let (w, h) = (geometry.width() as i64, geometry.height() as i64);
        let r = geometry.resolution_m();
        // The ray in grid coordinates, parametrised by metres from its origin.
        let (u0, v0) = geometry.world_to_grid(origin);
        let (gs, gc) = (dir.grid_sin, dir.grid_cos);
        let (du, dv) = (gc / r, gs / r);
        let Some((t_in, t_out)) = clip_metres(u0, v0, du, dv, w as f64, h as f64, max_range_m) else {
            return RayHit { range_m: max_range_m, cell: None, stop: RayStop::LeftGrid };
        };
        let finish = || {
            if t_out < max_range_m {
                RayHit { range_m: t_out, cell: None, stop: RayStop::LeftGrid }
            } else {
                RayHit { range_m: max_range_m, cell: None, stop: RayStop::MaxRange }
            }
        };
        let (step_x, step_y) = (if du > 0.0 { 1 } else { -1 }, if dv > 0.0 { 1 } else { -1 });
        let (t_delta_x, t_delta_y) = (
            if du != 0.0 { 1.0 / du.abs() } else { f64::INFINITY },
            if dv != 0.0 { 1.0 / dv.abs() } else { f64::INFINITY },
        );
        let safe_jump = &self.safe_jump_m[..];
        // Enter the grid at t_in; after a jump, re-enter at the landing point.
        let mut t_entry = t_in;
        loop {
            let (u, v) = (u0 + t_entry * du, v0 + t_entry * dv);
            let mut ix = floor_i64(u).clamp(0, w - 1);
            let mut iy = floor_i64(v).clamp(0, h - 1);
            let mut t_max_x = boundary(ix, u0, du);
            let mut t_max_y = boundary(iy, v0, dv);
            let mut index = (iy * w + ix) as usize;
            loop {
                let jump = safe_jump[index];
                if jump == f32::NEG_INFINITY {
                    let cell = CellCoord::new(ix as i32, iy as i32);
                    let stop = blocking_stop(self.map.cells()[index]);
                    // entry_distance(geometry, origin, angle, cell), from the values it would
                    // recompute: world_to_grid(origin) and the grid-relative sine and cosine.
                    return RayHit { range_m: entry_distance_grid(u0, v0, gc, gs, cell, r), cell: Some(cell), stop };
                }
                let jump = jump as f64;
                if jump >= self.min_jump_m {
                    t_entry += jump;
                    if t_entry >= t_out {
                        return finish();
                    }
                    break;
                }
                if t_max_x <= t_max_y {
                    if t_max_x >= t_out {
                        return finish();
                    }
                    t_entry = t_max_x;
                    ix += step_x;
                    if ix < 0 || ix >= w {
                        return finish();
                    }
                    index = (index as i64 + step_x) as usize;
                    t_max_x += t_delta_x;
                } else {
                    if t_max_y >= t_out {
                        return finish();
                    }
                    t_entry = t_max_y;
                    iy += step_y;
                    if iy < 0 || iy >= h {
                        return finish();
                    }
                    index = (index as i64 + step_y * w) as usize;
                    t_max_y += t_delta_y;
                }
            }
        }
    }
}

impl RayCaster {
    /// A lower bound on how far `p` is from the nearest blocking cell and from the grid's
    /// border, metres: every point closer than this to `p` lies inside the grid and outside
    /// every blocking cell. From the clearance of `p`'s cell (minus its `f32` rounding); `-∞`
    /// when `p`'s cell blocks, `p` is outside the grid or not finite.
    pub fn free_radius_m(&self, p: Point2) -> f64 {
        let (u, v) = self.map.geometry().world_to_grid(p);
        self.free_radius_grid(u, v)
    }

    /// Whether it is certain, without casting, that [`RayCaster::cast_dir`]`(origin, dir,
    /// max_range)` with `max_range ≥ hi_m` stops at a blocking cell entered between `lo_m` and
    /// `hi_m` (to within 1e-9 m), `origin` being the one `discs` was reset to. `false` means
    /// only "not certain" (then cast).
    ///
    /// Two parts: (1) discs of free space ([`RayCaster::free_radius_m`], kept in `discs` from
    /// ray to ray) cover the ray from the origin to `lo_m`, so the cast meets no blocking cell
    /// and no border before `lo_m`; (2) a point of the ray between `lo_m` and `hi_m` — tried at
    /// `probe_m`, half a cell and a cell either side — is inside a blocking cell
    /// ([`RayCaster::blocked_at`]), so the cast has stopped by there.
    pub fn stops_between(&self, discs: &mut FreeDiscs, dir: &RayDir, lo_m: f64, hi_m: f64, probe_m: f64) -> bool {
        let g = self.map.geometry();
        if !(lo_m <= hi_m && lo_m.is_finite() && hi_m.is_finite()) || dir.grid_yaw.to_bits() != g.origin().yaw.to_bits()
        {
            return false;
        }
        let r = g.resolution_m();
        // The ray in grid coordinates: (u0, v0) + t·(du, dv), t in metres (the walk's own
        // parametrisation), computed once for the probes and the discs.
        let (u0, v0) = discs.origin_grid(g);
        let (du, dv) = (dir.grid_cos / r, dir.grid_sin / r);
        let found = [0.0, -0.5, 0.5, -1.0, 1.0].iter().any(|k| {
            let s = probe_m + k * r;
            s >= lo_m && s <= hi_m && s >= 0.0 && self.blocked_grid(u0 + s * du, v0 + s * dv)
        });
        if !found {
            return false;
        }
        // Discs in grid coordinates, radii in cells; the ray's unit direction there.
        let (ex, ey) = (dir.grid_cos, dir.grid_sin);
        let (lo, per_m) = (lo_m / r, 1.0 / r);
        let FreeDiscs { discs: old, next, .. } = discs;
        next.clear();
        // Covered from the origin up to `c` cells along the ray.
        let mut c = 0.0f64;
        let mut i = 0;
        for _ in 0..CHAIN_STEPS {
            if c >= lo {
                std::mem::swap(old, next);
                return true;
            }
            // The kept discs, in order: skip those missing the ray or behind `c`, use one that
            // covers `c`.
            let mut covered = false;
            while i < old.len() {
                let (pu, pv, f, d2) = old[i];
                let tc = (pu - u0) * ex + (pv - v0) * ey;
                let h2 = f * f - (d2 - tc * tc);
                let h = if h2 > 0.0 { h2.sqrt() * (1.0 - DISC_SLACK) } else { -1.0 };
                if h <= 0.0 || tc + h <= c {
                    i += 1;
                    continue;
                }
                if tc - h <= c {
                    c = tc + h;
                    next.push(old[i]);
                    i += 1;
                    covered = true;
                }
                break;
            }
            if covered {
                continue;
            }
            // A new disc at the first point not covered.
            let (pu, pv) = (u0 + c * ex, v0 + c * ey);
            let f = self.free_radius_grid(pu, pv) * per_m * (1.0 - DISC_SLACK);
            if f.is_nan() || f < CHAIN_MIN_STEP_CELLS {
                return false;
            }
            next.push((pu, pv, f, (pu - u0) * (pu - u0) + (pv - v0) * (pv - v0)));
            c += f;
        }
        false
    }

    /// [`RayCaster::free_radius_m`] at grid coordinates `(u, v)`.
    #[inline]
    fn free_radius_grid(&self, u: f64, v: f64) -> f64 {
        let g = self.map.geometry();
        let (w, h) = (g.width() as f64, g.height() as f64);
        if !(u >= 0.0 && v >= 0.0 && u < w && v < h) {
            return f64::NEG_INFINITY;
        }
        // 0 ≤ u < w ≤ 2^20 (so for v): truncation to i32 is the floor.
        let jump = self.safe_jump_m[(v as i32) as usize * g.width() + (u as i32) as usize];
        if jump == f32::NEG_INFINITY {
            return f64::NEG_INFINITY;
        }
        let r = g.resolution_m();
        let j = jump as f64;
        let free = j - (if j < 0.0 { -j } else { j } + r) * F32_SLACK;
        let mut b = u;
        for x in [w - u, v, h - v] {
            if x < b {
                b = x;
            }
        }
        let border = b * r * (1.0 - F32_SLACK);
        if border < free { border } else { free }
    }

    /// Whether grid point `(u, v)` lies inside a blocking cell, away from its sides (by
    /// `edge_cells`).
    #[inline]
    fn blocked_grid(&self, u: f64, v: f64) -> bool {
        let g = self.map.geometry();
        if !(u >= 0.0 && v >= 0.0 && u < g.width() as f64 && v < g.height() as f64) {
            return false;
        }
        let (ix, iy) = (u as i32, v as i32); // the floors: 0 ≤ u < w ≤ 2^20, so for v
        let (fu, fv) = (u - ix as f64, v - iy as f64);
        let edge = self.edge_cells;
        fu > edge
            && fu < 1.0 - edge
            && fv > edge
            && fv < 1.0 - edge
            && self.safe_jump_m[iy as usize * g.width() + ix as usize] == f32::NEG_INFINITY
    }

    /// Whether the point `s_m` along the ray from `origin` along `dir` lies inside a blocking
    /// cell, away from its sides (by 1e-6 of a cell plus 2⁻²⁰ of the longest jump, above the
    /// rounding of the ray and of the jumps' `f32` clearances): then
    /// [`RayCaster::cast_dir`]`(origin, dir, max_range)` with `max_range ≥ s_m` certainly stops
    /// at a blocking cell entered at most `s_m` from the origin (its walk visits every cell
    /// whose inside the ray crosses; its jumps only cross free space).
    pub fn blocked_at(&self, origin: Point2, dir: &RayDir, s_m: f64) -> bool {
        let g = self.map.geometry();
        if dir.grid_yaw.to_bits() != g.origin().yaw.to_bits() || s_m.is_nan() || s_m < 0.0 {
            return false;
        }
        let r = g.resolution_m();
        let (u0, v0) = g.world_to_grid(origin);
        // The walk's own parametrisation of the ray.
        self.blocked_grid(u0 + s_m * (dir.grid_cos / r), v0 + s_m * (dir.grid_sin / r))
    }

    /// Visits, in order, exactly the blocking cells (occupied, or unknown if unknown cells
    /// block) that [`traverse_indexed`](crate::traverse_indexed)`(geometry, from, to, ..)`
    /// visits, with each one's linear index. Open stretches are crossed with
    /// [`SegmentWalk::skip_before`]: from a cell whose clearance allows a jump of `j`, every
    /// boundary less than `j` beyond the cell's exit is crossed at once (no blocking cell is
    /// that close; the jump is shortened by 2⁻²⁰ of itself plus a cell for the clearances'
    /// `f32` rounding, and the caster's `1e-6` cell margin covers the walk's own rounding).
    pub fn visit_blocking(&self, from: Point2, to: Point2, mut visit: impl FnMut(CellCoord, usize)) {
        let geometry = self.map.geometry();
        let Some(mut walk) = SegmentWalk::start(geometry, from, to) else {
            return;
        };
        let r = geometry.resolution_m();
        let min_skip_m = MIN_SKIP_CELLS * r;
        // Parameter per metre of travel.
        let per_m = walk.param_per_cell() / r;
        let safe_jump = &self.safe_jump_m[..];
        loop {
            let jump = safe_jump[walk.index()];
            if jump == f32::NEG_INFINITY {
                visit(walk.cell(), walk.index());
            } else if jump as f64 >= min_skip_m {
                let j = jump as f64;
                let j = j - (j + r) * F32_SLACK;
                walk.skip_before(walk.exit_param() + j * per_m);
            }
            if !walk.advance() {
                return;
            }
        }
    }
}

/// [`RayCaster::visit_blocking`] skips only from cells whose safe jump is at least this many
/// cells (shorter skips cost more than they save).
const MIN_SKIP_CELLS: f64 = 3.0;

/// Most discs for one ray in [`RayCaster::stops_between`].
const CHAIN_STEPS: usize = 48;

/// Smallest new disc there, cells.
const CHAIN_MIN_STEP_CELLS: f64 = 0.5;

/// Relative slack on disc radii and chords there (far above the rounding of their arithmetic).
const DISC_SLACK: f64 = 1e-9;

/// Relative slack for a clearance stored as `f32` (2⁻²⁰, eight times its rounding).
const F32_SLACK: f64 = 1.0 / (1u64 << 20) as f64;

/// Clips the ray `(u0, v0) + t·(du, dv)`, `t ∈ [0, max_t]`, to `[0, w] × [0, h]`.
fn clip_metres(u0: f64, v0: f64, du: f64, dv: f64, w: f64, h: f64, max_t: f64) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, max_t);
    for (p0, d, hi) in [(u0, du, w), (v0, dv, h)] {
        if d == 0.0 {
            if p0 < 0.0 || p0 > hi {
                return None;
            }
        } else {
            let (a, b) = ((0.0 - p0) / d, (hi - p0) / d);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
    }
    (t0 <= t1).then_some((t0, t1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GridGeometry;
    use crate::pose::Pose2;
    use proptest::prelude::*;

    fn random_map(seed: u64, density: f64, yaw: f64) -> OccupancyGrid {
        let g = GridGeometry::new(60, 45, 0.05, Pose2::new(-1.0, -0.5, yaw)).unwrap();
        let mut state = seed | 1;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut m = OccupancyGrid::filled(g, CellState::Free);
        // A few blocks and scattered cells.
        for _ in 0..6 {
            let (x0, y0) = ((next() * 55.0) as i32, (next() * 40.0) as i32);
            let state = if next() < 0.3 { CellState::Unknown } else { CellState::Occupied };
            for ix in x0..x0 + 4 {
                for iy in y0..y0 + 3 {
                    m.set(CellCoord::new(ix, iy), state);
                }
            }
        }
        for i in 0..g.len() {
            if next() < density {
                m.cells_mut()[i] = CellState::Occupied;
            }
        }
        m
    }

    fn same(a: &RayHit, b: &RayHit) -> bool {
        a.stop == b.stop && a.cell == b.cell && (a.range_m - b.range_m).abs() < 1e-9
    }

    #[test]
    fn stops_between_certifies_plain_cases() {
        // A wall across a free room: rays towards it are certified within a window around the
        // wall, not outside it.
        let g = GridGeometry::new(200, 100, 0.05, Pose2::IDENTITY).unwrap();
        let mut map = OccupancyGrid::filled(g, CellState::Free);
        for iy in 0..100 {
            map.set(CellCoord::new(150, iy), CellState::Occupied);
        }
        let c = RayCaster::new(&map, true);
        let o = Point2::new(1.0, 2.5);
        let mut discs = FreeDiscs::new();
        discs.reset(o);
        let mut certified = 0;
        for k in -40..=40 {
            let dir = c.direction(k as f64 * 0.01);
            let z = c.cast_dir(o, &dir, 20.0).range_m + 0.005;
            if c.stops_between(&mut discs, &dir, z - 0.2, z + 0.2, z) {
                certified += 1;
            }
            assert!(!c.stops_between(&mut discs, &dir, z - 0.2, z - 0.1, z), "window before the wall");
            assert!(!c.stops_between(&mut discs, &dir, z + 0.1, z + 0.2, z + 0.1), "window behind the wall");
        }
        assert!(certified >= 70, "{certified} of 81 rays certified");
    }

    #[test]
    fn blocked_at_inside_a_wall_only() {
        let g = GridGeometry::new(200, 100, 0.05, Pose2::IDENTITY).unwrap();
        let mut map = OccupancyGrid::filled(g, CellState::Free);
        for ix in 150..160 {
            for iy in 0..100 {
                map.set(CellCoord::new(ix, iy), CellState::Occupied);
            }
        }
        let c = RayCaster::new(&map, true);
        let o = Point2::new(1.0, 2.5);
        let dir = c.direction(0.1);
        let wall = c.cast_dir(o, &dir, 20.0).range_m;
        assert!(c.blocked_at(o, &dir, wall + 0.13));
        assert!(!c.blocked_at(o, &dir, wall - 0.01));
        assert!(!c.blocked_at(o, &dir, 0.5));
    }

    #[test]
    fn empty_and_full_maps() {
        let g = GridGeometry::new(100, 100, 0.1, Pose2::IDENTITY).unwrap();
        let free = OccupancyGrid::filled(g, CellState::Free);
        let c = RayCaster::new(&free, true);
        for (o, a, r) in
            [(Point2::new(5.0, 5.0), 0.3, 3.0), (Point2::new(5.0, 5.0), 2.0, 30.0), (Point2::new(-3.0, 5.0), 0.0, 30.0)]
        {
            assert!(
                same(&c.cast(o, a, r), &cast_ray(&free, o, a, r, true)),
                "{:?} vs {:?}",
                c.cast(o, a, r),
                cast_ray(&free, o, a, r, true)
            );
        }
        let full = OccupancyGrid::filled(g, CellState::Unknown);
        let c = RayCaster::new(&full, true);
        assert_eq!(c.cast(Point2::new(5.0, 5.0), 1.0, 10.0).range_m, 0.0);
        let c = RayCaster::new(&full, false);
        assert_eq!(c.cast(Point2::new(5.0, 5.0), 0.0, 10.0).stop, RayStop::LeftGrid);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]
        #[test]
        fn blocked_points_stop_the_cast(seed in any::<u64>(), density in 0.0f64..0.02, rotate in any::<bool>(),
                                        ox in -0.5f64..2.5, oy in -0.5f64..1.8, unknown_blocks in any::<bool>()) {
            let map = random_map(seed, density, if rotate { 0.3 } else { 0.0 });
            let caster = RayCaster::new(&map, unknown_blocks);
            let o = Point2::new(ox, oy);
            for k in 0..64 {
                let dir = caster.direction(k as f64 * std::f64::consts::TAU / 64.0 + 0.003);
                for j in 0..40 {
                    let s = j as f64 * 0.037;
                    if caster.blocked_at(o, &dir, s) {
                        let hit = caster.cast_dir(o, &dir, s + 0.5);
                        prop_assert!(matches!(hit.stop, RayStop::Occupied | RayStop::Unknown), "{hit:?}");
                        prop_assert!(hit.range_m <= s + 1e-9, "stopped at {} after {s}", hit.range_m);
                    }
                }
            }
        }

        #[test]
        fn certified_stops_are_where_the_cast_stops(seed in any::<u64>(), density in 0.0f64..0.004, rotate in any::<bool>(),
                                                   ox in -0.5f64..2.5, oy in -0.5f64..1.8, unknown_blocks in any::<bool>(),
                                                   width in 0.0f64..0.4) {
            let map = random_map(seed, density, if rotate { 0.3 } else { 0.0 });
            let caster = RayCaster::new(&map, unknown_blocks);
            let o = Point2::new(ox, oy);
            let mut discs = FreeDiscs::new();
            discs.reset(o);
            for k in 0..128 {
                let a = k as f64 * std::f64::consts::TAU / 128.0 + 0.003;
                let dir = caster.direction(a);
                let full = caster.cast_dir(o, &dir, 10.0);
                // Windows around the true stop (mostly certifiable) and shifted ones.
                for (centre, probe) in [(full.range_m, full.range_m + 0.01), (full.range_m - 0.1, full.range_m), (full.range_m + 0.1, full.range_m + 0.1)] {
                    let (lo, hi) = (centre - width, centre + width);
                    if caster.stops_between(&mut discs, &dir, lo, hi, probe) {
                        let hit = caster.cast_dir(o, &dir, hi.max(0.0) + 0.5);
                        prop_assert!(matches!(hit.stop, RayStop::Occupied | RayStop::Unknown), "{hit:?}");
                        prop_assert!(hit.range_m >= lo - 1e-9 && hit.range_m <= hi + 1e-9, "{} not in [{lo}, {hi}]", hit.range_m);
                    }
                }
            }
        }

        #[test]
        fn free_radius_is_free(seed in any::<u64>(), density in 0.0f64..0.005, rotate in any::<bool>(),
                               px in -1.5f64..2.5, py in -1.0f64..2.0, unknown_blocks in any::<bool>()) {
            let map = random_map(seed, density, if rotate { 0.3 } else { 0.0 });
            let caster = RayCaster::new(&map, unknown_blocks);
            let g = map.geometry();
            let p = Point2::new(px, py);
            let radius = caster.free_radius_m(p);
            // Brute force: the nearest point of any blocking cell, and the border.
            let (u, v) = g.world_to_grid(p);
            let r = g.resolution_m();
            let mut nearest = (u.min(g.width() as f64 - u).min(v).min(g.height() as f64 - v) * r).max(0.0);
            if u < 0.0 || v < 0.0 || u >= g.width() as f64 || v >= g.height() as f64 {
                nearest = 0.0;
            }
            for iy in 0..g.height() {
                for ix in 0..g.width() {
                    let s = map.cells()[iy * g.width() + ix];
                    if s == CellState::Occupied || (unknown_blocks && s == CellState::Unknown) {
                        let dx = (ix as f64 - u).max(u - ix as f64 - 1.0).max(0.0);
                        let dy = (iy as f64 - v).max(v - iy as f64 - 1.0).max(0.0);
                        nearest = nearest.min(dx.hypot(dy) * r);
                    }
                }
            }
            prop_assert!(radius <= nearest, "free radius {} > nearest {}", radius, nearest);
            if nearest > 2.0 * r {
                // Not uselessly small: at most the two half-diagonals below.
                prop_assert!(radius > nearest - 1.5 * r, "free radius {} for nearest {}", radius, nearest);
            }
        }

        #[test]
        fn visits_the_blocking_cells_traverse_visits(seed in any::<u64>(), density in 0.0f64..0.01, rotate in any::<bool>(),
                                                    ax in -1.5f64..2.5, ay in -1.0f64..2.0, unknown_blocks in any::<bool>(),
                                                    len in 0.0f64..5.0, a in 0.0f64..std::f64::consts::TAU) {
            let map = random_map(seed, density, if rotate { 0.3 } else { 0.0 });
            let caster = RayCaster::new(&map, unknown_blocks);
            let from = Point2::new(ax, ay);
            let to = Point2::new(ax + len * a.cos(), ay + len * a.sin());
            let mut want = Vec::new();
            let _ = crate::traverse_indexed(map.geometry(), from, to, |c, i| {
                let s = map.cells()[i];
                if s == CellState::Occupied || (unknown_blocks && s == CellState::Unknown) {
                    want.push((c, i));
                }
                std::ops::ControlFlow::<()>::Continue(())
            });
            let mut got = Vec::new();
            caster.visit_blocking(from, to, |c, i| got.push((c, i)));
            prop_assert_eq!(got, want);
        }

        #[test]
        fn same_answers_as_cast_ray(seed in any::<u64>(), density in 0.0f64..0.01, rotate in any::<bool>(),
                                    ox in -1.5f64..2.5, oy in -1.0f64..2.0, unknown_blocks in any::<bool>(),
                                    max_range in 0.01f64..6.0) {
            let map = random_map(seed, density, if rotate { 0.3 } else { 0.0 });
            let caster = RayCaster::new(&map, unknown_blocks);
            for k in 0..64 {
                let a = k as f64 * std::f64::consts::TAU / 64.0 + 0.001;
                let o = Point2::new(ox, oy);
                let fast = caster.cast(o, a, max_range);
                let slow = cast_ray(&map, o, a, max_range, unknown_blocks);
                prop_assert!(same(&fast, &slow), "ray {k}: {fast:?} vs {slow:?}");
                let dir = caster.direction(a);
                prop_assert_eq!(caster.cast_dir(o, &dir, max_range), fast);
                prop_assert_eq!((dir.sin(), dir.cos()), a.sin_cos());
            }
        }
    }
}
