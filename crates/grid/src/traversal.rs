//! Grid traversal (Amanatides & Woo, 1987): the cells a segment passes through, in order, and
//! ray casting to the first blocking cell.
//!
//! Both work on continuous grid coordinates, so the origin's yaw is honoured. Nothing is
//! allocated per ray; the visitor is a closure that can stop the walk early.

use crate::grid::{CellCoord, CellState, GridGeometry, OccupancyGrid};
use crate::pose::Point2;
use std::ops::ControlFlow;

/// Clips the segment `a + t·(b − a)`, `t ∈ [0, 1]`, to the rectangle `[0, w] × [0, h]`
/// (Liang–Barsky). Returns the clipped parameter interval, or `None` if it misses.
fn clip(a: (f64, f64), b: (f64, f64), w: f64, h: f64) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    let d = (b.0 - a.0, b.1 - a.1);
    for (p, q) in [(-d.0, a.0), (d.0, w - a.0), (-d.1, a.1), (d.1, h - a.1)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    (t0 <= t1).then_some((t0, t1))
}

/// Visits, in order from `from` to `to`, every grid cell the segment passes through, clipped to
/// the grid. The visitor returns [`ControlFlow::Break`] to stop. Where the segment passes exactly
/// through a cell corner, the cell across the x boundary is visited before the one across y
/// (one of the two cells the segment only touches is included, as in Amanatides–Woo).
///
/// Returns `Break` if the visitor stopped the walk, `Continue` otherwise (including when the
/// segment misses the grid or an end point is not finite).
///
/// ```
/// use mapkeeper_grid::{traverse, CellCoord, GridGeometry, Point2, Pose2};
/// use std::ops::ControlFlow;
/// let g = GridGeometry::new(10, 10, 1.0, Pose2::IDENTITY).unwrap();
/// let mut cells = Vec::new();
/// let _ = traverse(&g, Point2::new(0.5, 0.5), Point2::new(3.5, 1.5), |c| {
///     cells.push(c);
///     ControlFlow::<()>::Continue(())
/// });
/// assert_eq!(cells.first(), Some(&CellCoord::new(0, 0)));
/// assert_eq!(cells.last(), Some(&CellCoord::new(3, 1)));
/// assert_eq!(cells.len(), 5);
/// ```
#[inline]
pub fn traverse<B, F>(geometry: &GridGeometry, from: Point2, to: Point2, mut visit: F) -> ControlFlow<B>
where
    F: FnMut(CellCoord) -> ControlFlow<B>,
{
    traverse_indexed(geometry, from, to, |c, _| visit(c))
}

/// [`traverse`], also passing each cell's linear index (row-major from the bottom row).
#[inline]
pub fn traverse_indexed<B, F>(geometry: &GridGeometry, from: Point2, to: Point2, mut visit: F) -> ControlFlow<B>
where
    F: FnMut(CellCoord, usize) -> ControlFlow<B>,
{
    let Some(mut walk) = SegmentWalk::start(geometry, from, to) else {
        return ControlFlow::Continue(());
    };
    loop {
        visit(CellCoord::new(walk.ix as i32, walk.iy as i32), walk.index)?;
        if !walk.advance() {
            return ControlFlow::Continue(());
        }
    }
}

/// The state of one Amanatides–Woo walk over a segment clipped to the grid: the cells of
/// [`traverse_indexed`], for callers that want to drive the loop themselves.
///
/// ```
/// use mapkeeper_grid::{traverse, CellCoord, GridGeometry, Point2, Pose2, SegmentWalk};
/// use std::ops::ControlFlow;
/// let g = GridGeometry::new(10, 10, 1.0, Pose2::IDENTITY).unwrap();
/// let (a, b) = (Point2::new(0.5, 0.5), Point2::new(3.5, 1.5));
/// let mut walked = Vec::new();
/// if let Some(mut w) = SegmentWalk::start(&g, a, b) {
///     loop {
///         walked.push(w.cell());
///         assert_eq!(w.index(), g.index(w.cell()).unwrap());
///         if !w.advance() {
///             break;
///         }
///     }
/// }
/// let mut visited = Vec::new();
/// let _ = traverse(&g, a, b, |c| {
///     visited.push(c);
///     ControlFlow::<()>::Continue(())
/// });
/// assert_eq!(walked, visited);
/// ```
#[derive(Clone, Debug)]
pub struct SegmentWalk {
    ix: i64,
    iy: i64,
    index: usize,
    step_x: i64,
    step_y: i64,
    stride_y: isize,
    /// Parametric distance (in units of the whole segment) to the next x / y boundary; infinite
    /// once that axis has reached its end cell.
    t_max_x: f64,
    t_max_y: f64,
    t_delta_x: f64,
    t_delta_y: f64,
    remaining_x: i64,
    remaining_y: i64,
    /// Parameter at which the segment leaves the grid (1 if it ends inside).
    t_exit: f64,
    /// Where the walk starts (the segment's first point in the grid), grid coordinates: the
    /// parameters above count from here, in units of `d`.
    s: (f64, f64),
    /// Parameter of `s` along the whole segment (0 if it starts inside the grid).
    t0: f64,
    /// The whole segment, grid coordinates.
    d: (f64, f64),
}

impl SegmentWalk {
    /// The walk from `from` to `to` (map frame), positioned on its first cell; `None` if the
    /// segment misses the grid or an end point is not finite.
    #[inline]
    pub fn start(geometry: &GridGeometry, from: Point2, to: Point2) -> Option<SegmentWalk> {
        let a = geometry.world_to_grid(from);
        let b = geometry.world_to_grid(to);
        if !(a.0.is_finite() && a.1.is_finite() && b.0.is_finite() && b.1.is_finite()) {
            return None;
        }
        let (w, h) = (geometry.width(), geometry.height());
        let (t0, t1) = clip(a, b, w as f64, h as f64)?;
        let d = (b.0 - a.0, b.1 - a.1);
        let s = (a.0 + t0 * d.0, a.1 + t0 * d.1);
        let e = (a.0 + t1 * d.0, a.1 + t1 * d.1);
        let cell_of = |u: f64, n: usize| floor_i64(u).clamp(0, n as i64 - 1);
        let (ix, iy) = (cell_of(s.0, w), cell_of(s.1, h));
        let (ex, ey) = (cell_of(e.0, w), cell_of(e.1, h));
        // Exactly |ex − ix| + |ey − iy| steps reach the end cell; the step choice follows the
        // boundaries, but an axis that has reached its end cell never moves again (this guards
        // rounding at the ends, so the walk never leaves the grid).
        let (remaining_x, remaining_y) = ((ex - ix).abs(), (ey - iy).abs());
        let boundary = |p: f64, i: i64, d: f64, remaining: i64| {
            if remaining == 0 || d == 0.0 {
                (f64::INFINITY, f64::INFINITY)
            } else {
                let next = if d > 0.0 { i as f64 + 1.0 } else { i as f64 };
                ((next - p) / d, 1.0 / d.abs())
            }
        };
        let (t_max_x, t_delta_x) = boundary(s.0, ix, d.0, remaining_x);
        let (t_max_y, t_delta_y) = boundary(s.1, iy, d.1, remaining_y);
        let step_y = (ey - iy).signum();
        Some(SegmentWalk {
            ix,
            iy,
            index: (iy * w as i64 + ix) as usize,
            step_x: (ex - ix).signum(),
            step_y,
            stride_y: (step_y * w as i64) as isize,
            t_max_x,
            t_max_y,
            t_delta_x,
            t_delta_y,
            remaining_x,
            remaining_y,
            t_exit: t1,
            s,
            t0,
            d,
        })
    }

    /// The current cell.
    #[inline(always)]
    pub fn cell(&self) -> CellCoord {
        CellCoord::new(self.ix as i32, self.iy as i32)
    }

    /// The current cell's linear index (row-major from the bottom row).
    #[inline(always)]
    pub fn index(&self) -> usize {
        self.index
    }

    /// The parameter at which the walk leaves the current cell (in units of the whole segment,
    /// counted from where the walk entered the grid); +∞ on the last cell.
    #[inline(always)]
    pub fn exit_param(&self) -> f64 {
        self.t_max_x.min(self.t_max_y)
    }

    /// The parameter step that covers one cell side of travel along the segment (+∞ for a
    /// segment of zero length).
    #[inline]
    pub fn param_per_cell(&self) -> f64 {
        1.0 / (self.d.0 * self.d.0 + self.d.1 * self.d.1).sqrt()
    }

    /// The walk's parameter of the point `cells` cell sides along the segment from its `from`
    /// end (negative before the walk's first cell).
    #[inline]
    pub fn param_at(&self, cells: f64) -> f64 {
        cells * self.param_per_cell() - self.t0
    }

    /// The parameter at which the segment's line, going forward, leaves the axis-aligned square
    /// `[lo.0, hi.0] × [lo.1, hi.1]` (grid coordinates); +∞ along an axis it does not move on.
    #[inline]
    pub fn param_leaving(&self, lo: (f64, f64), hi: (f64, f64)) -> f64 {
        let axis = |s: f64, d: f64, lo: f64, hi: f64| {
            if d > 0.0 {
                (hi - s) / d
            } else if d < 0.0 {
                (lo - s) / d
            } else {
                f64::INFINITY
            }
        };
        axis(self.s.0, self.d.0, lo.0, hi.0).min(axis(self.s.1, self.d.1, lo.1, hi.1))
    }

    /// Crosses, without visiting the cells in between, every cell boundary whose parameter (as
    /// the walk computes it) is below `t`: the walk is then on the cell that
    /// [`SegmentWalk::advance`] would have reached after crossing exactly those boundaries, in
    /// the same state, so that the cells visited afterwards are the same as without the skip.
    ///
    /// The walk crosses boundaries in increasing order of their parameters (x first on a tie),
    /// and each axis's parameters are the same running sums whatever the interleaving, so
    /// crossing all of them below `t` on each axis separately gives the state the walk has
    /// after its last crossing below `t`. Only the cells entered at a parameter below `t` are
    /// passed over.
    #[inline]
    pub fn skip_before(&mut self, t: f64) {
        let (n, next) = skip_axis(self.t_max_x, self.t_delta_x, t, self.remaining_x);
        if n > 0 {
            self.remaining_x -= n;
            self.t_max_x = if self.remaining_x == 0 { f64::INFINITY } else { next };
            self.ix += n * self.step_x;
            self.index = self.index.wrapping_add_signed((n * self.step_x) as isize);
        }
        let (n, next) = skip_axis(self.t_max_y, self.t_delta_y, t, self.remaining_y);
        if n > 0 {
            self.remaining_y -= n;
            self.t_max_y = if self.remaining_y == 0 { f64::INFINITY } else { next };
            self.iy += n * self.step_y;
            self.index = self.index.wrapping_add_signed(n as isize * self.stride_y);
        }
    }

    /// Moves to the next cell; false when the end cell has been visited (the walk then stays
    /// on it).
    #[inline(always)]
    pub fn advance(&mut self) -> bool {
        if self.remaining_x + self.remaining_y == 0 {
            return false;
        }
        if self.t_max_x <= self.t_max_y {
            self.ix += self.step_x;
            self.index = self.index.wrapping_add_signed(self.step_x as isize);
            self.remaining_x -= 1;
            self.t_max_x = if self.remaining_x == 0 { f64::INFINITY } else { self.t_max_x + self.t_delta_x };
        } else {
            self.iy += self.step_y;
            self.index = self.index.wrapping_add_signed(self.stride_y);
            self.remaining_y -= 1;
            self.t_max_y = if self.remaining_y == 0 { f64::INFINITY } else { self.t_max_y + self.t_delta_y };
        }
        true
    }
}

/// The running sum `s, s + d, (s + d) + d, …` of one axis of a walk (each addition rounded):
/// how many of its terms, from `s` on and at most `limit`, are below `t`, and the term after
/// them. A plain loop: the skips are a few cells long, where shortcuts through the binade
/// structure of the sums cost more than they save (measured).
#[inline(always)]
fn skip_axis(mut s: f64, d: f64, t: f64, limit: i64) -> (i64, f64) {
    let mut n = 0i64;
    while n < limit && s < t {
        s += d;
        n += 1;
    }
    (n, s)
}

/// `x.floor() as i64` for finite `x` within the i64 range, without a libm call (the baseline
/// x86-64 target has no rounding instruction, so `floor` is a function call in hot loops).
#[inline(always)]
pub(crate) fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    t - ((t as f64) > x) as i64
}

/// Why a [`cast_ray`] stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayStop {
    /// Reached an occupied cell.
    Occupied,
    /// Reached an unknown cell.
    Unknown,
    /// Left the grid (everything beyond is unknown).
    LeftGrid,
    /// Travelled the whole maximum range through free cells.
    MaxRange,
}

/// The result of a [`cast_ray`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    /// Distance from the ray's origin to where it stopped, metres: the entry point of the
    /// blocking cell, the grid's border, or the maximum range.
    pub range_m: f64,
    /// The blocking cell (for [`RayStop::Occupied`] and [`RayStop::Unknown`]).
    pub cell: Option<CellCoord>,
    /// Why the ray stopped.
    pub stop: RayStop,
}

/// Casts a ray from `origin` along `angle` (radians, map frame) for at most `max_range_m`,
/// stopping at the first cell that is occupied or, if `unknown_blocks`, unknown. A ray that
/// starts in a blocking cell has range 0. A ray that starts outside the grid is cast through it
/// as if the outside were transparent until it enters.
pub fn cast_ray(grid: &OccupancyGrid, origin: Point2, angle: f64, max_range_m: f64, unknown_blocks: bool) -> RayHit {
    let geometry = grid.geometry();
    let (s, c) = angle.sin_cos();
    let end = Point2::new(origin.x + c * max_range_m, origin.y + s * max_range_m);
    let Some(mut walk) = SegmentWalk::start(geometry, origin, end) else {
        return RayHit { range_m: max_range_m, cell: None, stop: RayStop::LeftGrid };
    };
    let cells = grid.cells();
    loop {
        let stop = match cells.get(walk.index) {
            Some(CellState::Free) => None,
            Some(CellState::Occupied) => Some(RayStop::Occupied),
            Some(CellState::Unknown) if unknown_blocks => Some(RayStop::Unknown),
            Some(CellState::Unknown) => None,
            None => break,
        };
        if let Some(stop) = stop {
            let cell = CellCoord::new(walk.ix as i32, walk.iy as i32);
            return RayHit { range_m: entry_distance(geometry, origin, angle, cell), cell: Some(cell), stop };
        }
        if !walk.advance() {
            break;
        }
    }
    if walk.t_exit < 1.0 {
        RayHit { range_m: walk.t_exit * max_range_m, cell: None, stop: RayStop::LeftGrid }
    } else {
        RayHit { range_m: max_range_m, cell: None, stop: RayStop::MaxRange }
    }
}

/// Where the ray enters the cell's square (slab method), metres from its origin, clamped at 0.
pub(crate) fn entry_distance(geometry: &GridGeometry, origin: Point2, angle: f64, cell: CellCoord) -> f64 {
    let (u, v) = geometry.world_to_grid(origin);
    let yaw = angle - geometry.origin().yaw;
    let (dy, dx) = yaw.sin_cos();
    entry_distance_grid(u, v, dx, dy, cell, geometry.resolution_m())
}

/// [`entry_distance`] from the origin in grid coordinates `(u, v)` and the direction's cosine
/// and sine relative to the grid's axes.
#[inline]
pub(crate) fn entry_distance_grid(u: f64, v: f64, dx: f64, dy: f64, cell: CellCoord, resolution_m: f64) -> f64 {
    let mut t_in = 0.0f64;
    for (p, d, lo) in [(u, dx, cell.ix as f64), (v, dy, cell.iy as f64)] {
        if d.abs() < 1e-300 {
            continue;
        }
        let ta = (lo - p) / d;
        let tb = (lo + 1.0 - p) / d;
        t_in = t_in.max(ta.min(tb));
    }
    t_in * resolution_m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pose::Pose2;
    use proptest::prelude::*;

    fn collect(g: &GridGeometry, a: Point2, b: Point2) -> Vec<CellCoord> {
        let mut v = Vec::new();
        let _ = traverse(g, a, b, |c| {
            v.push(c);
            ControlFlow::<()>::Continue(())
        });
        v
    }

    /// Brute force: cells whose open square the segment crosses with positive length, ordered by
    /// the parameter at which the segment enters them.
    fn brute(g: &GridGeometry, a: Point2, b: Point2) -> Vec<CellCoord> {
        let pa = g.world_to_grid(a);
        let pb = g.world_to_grid(b);
        let mut hits = Vec::new();
        for ix in 0..g.width() as i32 {
            for iy in 0..g.height() as i32 {
                // Clip the segment to the cell square.
                // Shrunk square: a segment along a cell border crosses no interior.
                let e = 1e-9;
                if let Some((t0, t1)) = clip(
                    (pa.0 - ix as f64 - e, pa.1 - iy as f64 - e),
                    (pb.0 - ix as f64 - e, pb.1 - iy as f64 - e),
                    1.0 - 2.0 * e,
                    1.0 - 2.0 * e,
                ) {
                    let len = (t1 - t0) * ((pb.0 - pa.0).hypot(pb.1 - pa.1));
                    if len > 1e-9 {
                        hits.push((t0, CellCoord::new(ix, iy)));
                    }
                }
            }
        }
        hits.sort_by(|x, y| x.0.total_cmp(&y.0));
        hits.into_iter().map(|(_, c)| c).collect()
    }

    fn touches(g: &GridGeometry, a: Point2, b: Point2, c: CellCoord) -> bool {
        let pa = g.world_to_grid(a);
        let pb = g.world_to_grid(b);
        let e = 1e-9;
        clip(
            (pa.0 - c.ix as f64 + e, pa.1 - c.iy as f64 + e),
            (pb.0 - c.ix as f64 + e, pb.1 - c.iy as f64 + e),
            1.0 + 2.0 * e,
            1.0 + 2.0 * e,
        )
        .is_some()
    }

    fn check_against_brute(g: &GridGeometry, a: Point2, b: Point2) {
        let got = collect(g, a, b);
        let want = brute(g, a, b);
        // 4-connected path.
        for w in got.windows(2) {
            let d = (w[0].ix - w[1].ix).abs() + (w[0].iy - w[1].iy).abs();
            assert_eq!(d, 1, "not 4-connected: {got:?}");
        }
        // Every crossed cell is visited, in order; any extra cell is at least touched.
        let mut it = got.iter();
        for c in &want {
            assert!(it.any(|x| x == c), "missing or out of order {c:?}: got {got:?} want {want:?}");
        }
        for c in &got {
            assert!(g.contains(*c));
            assert!(want.contains(c) || touches(g, a, b, *c), "{c:?} not on the segment");
        }
        // No duplicates.
        let mut sorted = got.clone();
        sorted.sort();
        sorted.dedup();
        assert_eq!(sorted.len(), got.len());
    }

    #[test]
    fn horizontal_vertical_and_diagonal() {
        let g = GridGeometry::new(8, 8, 1.0, Pose2::IDENTITY).unwrap();
        let row: Vec<_> = (1..=6).map(|i| CellCoord::new(i, 2)).collect();
        assert_eq!(collect(&g, Point2::new(1.5, 2.5), Point2::new(6.5, 2.5)), row);
        let col: Vec<_> = (1..=6).rev().map(|i| CellCoord::new(3, i)).collect();
        assert_eq!(collect(&g, Point2::new(3.2, 6.9), Point2::new(3.2, 1.1)), col);
        // Exact diagonal through corners: x is stepped first at every tie.
        let diag = collect(&g, Point2::new(0.0, 0.0), Point2::new(3.0, 3.0));
        assert_eq!(diag.first(), Some(&CellCoord::new(0, 0)));
        assert_eq!(diag.len(), 7); // (0,0) (1,0) (1,1) (2,1) (2,2) (3,2) (3,3): ends at floor(3,3)
        check_against_brute(&g, Point2::new(0.0, 0.0), Point2::new(3.0, 3.0));
    }

    #[test]
    fn clipped_to_grid_and_degenerate() {
        let g = GridGeometry::new(4, 4, 1.0, Pose2::IDENTITY).unwrap();
        assert_eq!(
            collect(&g, Point2::new(-3.0, 1.5), Point2::new(10.0, 1.5)),
            (0..4).map(|i| CellCoord::new(i, 1)).collect::<Vec<_>>()
        );
        assert!(collect(&g, Point2::new(-3.0, 5.5), Point2::new(10.0, 5.5)).is_empty());
        assert_eq!(collect(&g, Point2::new(2.5, 2.5), Point2::new(2.5, 2.5)), vec![CellCoord::new(2, 2)]);
        assert!(collect(&g, Point2::new(f64::NAN, 2.5), Point2::new(2.5, 2.5)).is_empty());
        // Along the grid's top border (v = h exactly) the last row is used.
        assert_eq!(collect(&g, Point2::new(0.5, 4.0), Point2::new(1.5, 4.0)).len(), 2);
    }

    #[test]
    fn floor_without_libm() {
        for x in [-2.5, -2.0, -1e-12, 0.0, 1e-12, 0.999_999, 1.0, 3.7, -0.5, 1e15 + 0.5] {
            assert_eq!(floor_i64(x), x.floor() as i64, "{x}");
        }
    }

    #[test]
    fn early_stop() {
        let g = GridGeometry::new(10, 1, 1.0, Pose2::IDENTITY).unwrap();
        let mut n = 0;
        let r = traverse(&g, Point2::new(0.5, 0.5), Point2::new(9.5, 0.5), |c| {
            n += 1;
            if c.ix == 3 { ControlFlow::Break(c) } else { ControlFlow::Continue(()) }
        });
        assert_eq!(r, ControlFlow::Break(CellCoord::new(3, 0)));
        assert_eq!(n, 4);
    }

    #[test]
    fn cast_ray_hits_wall_at_entry() {
        let g = GridGeometry::new(20, 5, 0.1, Pose2::IDENTITY).unwrap();
        let mut grid = OccupancyGrid::filled(g, CellState::Free);
        for iy in 0..5 {
            grid.set(CellCoord::new(15, iy), CellState::Occupied);
        }
        let hit = cast_ray(&grid, Point2::new(0.25, 0.25), 0.0, 10.0, true);
        assert_eq!(hit.stop, RayStop::Occupied);
        assert_eq!(hit.cell, Some(CellCoord::new(15, 2)));
        assert!((hit.range_m - 1.25).abs() < 1e-9, "{}", hit.range_m);
        // Short of the wall: max range.
        let short = cast_ray(&grid, Point2::new(0.25, 0.25), 0.0, 1.0, true);
        assert_eq!(short.stop, RayStop::MaxRange);
        assert_eq!(short.range_m, 1.0);
        // Backwards: leaves the grid at x = 0.
        let out = cast_ray(&grid, Point2::new(0.25, 0.25), std::f64::consts::PI, 10.0, true);
        assert_eq!(out.stop, RayStop::LeftGrid);
        assert!((out.range_m - 0.25).abs() < 1e-9, "{}", out.range_m);
        // Unknown cells block only when asked.
        grid.set(CellCoord::new(10, 2), CellState::Unknown);
        assert_eq!(cast_ray(&grid, Point2::new(0.25, 0.25), 0.0, 10.0, true).stop, RayStop::Unknown);
        assert_eq!(cast_ray(&grid, Point2::new(0.25, 0.25), 0.0, 10.0, false).stop, RayStop::Occupied);
        // Starting inside a blocking cell.
        assert_eq!(cast_ray(&grid, Point2::new(1.55, 0.25), 0.0, 10.0, true).range_m, 0.0);
    }

    #[test]
    fn cast_ray_rotated_grid() {
        let yaw = 0.4;
        let g = GridGeometry::new(30, 30, 0.1, Pose2::new(2.0, -1.0, yaw)).unwrap();
        let mut grid = OccupancyGrid::filled(g, CellState::Free);
        for iy in 0..30 {
            grid.set(CellCoord::new(20, iy), CellState::Occupied);
        }
        // From the centre of cell (5, 10) along the grid's own x axis.
        let o = g.cell_center(CellCoord::new(5, 10));
        let hit = cast_ray(&grid, o, yaw, 10.0, true);
        assert_eq!(hit.cell, Some(CellCoord::new(20, 10)));
        assert!((hit.range_m - 1.45).abs() < 1e-9, "{}", hit.range_m);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        #[test]
        fn matches_brute_force(ax in -2.0f64..14.0, ay in -2.0f64..10.0, bx in -2.0f64..14.0, by in -2.0f64..10.0,
                               yaw in -3.2f64..3.2, rotate in any::<bool>()) {
            let origin = if rotate { Pose2::new(0.3, -0.2, yaw) } else { Pose2::new(-0.5, 0.25, 0.0) };
            let g = GridGeometry::new(12, 8, 1.0, origin).unwrap();
            check_against_brute(&g, Point2::new(ax, ay), Point2::new(bx, by));
        }

        #[test]
        fn skipping_keeps_the_rest_of_the_walk(ax in -2.0f64..14.0, ay in -2.0f64..10.0, bx in -2.0f64..14.0,
                                               by in -2.0f64..10.0, skips in proptest::collection::vec(0.0f64..0.5, 1..4),
                                               lattice in any::<bool>()) {
            // Lattice end points make exact ties (a segment through cell corners).
            let (a, b) = if lattice {
                (Point2::new(ax.round(), ay.round()), Point2::new(bx.round(), by.round()))
            } else {
                (Point2::new(ax, ay), Point2::new(bx, by))
            };
            let origin = if lattice { Pose2::IDENTITY } else { Pose2::new(-0.5, 0.25, 0.0) };
            let g = GridGeometry::new(12, 8, 1.0, origin).unwrap();
            // Reference: every cell with the parameter at which it was entered.
            let mut full = Vec::new();
            if let Some(mut w) = SegmentWalk::start(&g, a, b) {
                let mut entered = f64::NEG_INFINITY;
                loop {
                    full.push((w.cell(), w.index(), entered));
                    entered = w.exit_param();
                    if !w.advance() {
                        break;
                    }
                }
            }
            let mut got = Vec::new();
            if let Some(mut w) = SegmentWalk::start(&g, a, b) {
                let mut pending = skips.clone();
                loop {
                    got.push((w.cell(), w.index()));
                    if let Some(dt) = pending.pop() {
                        let t = w.exit_param() + dt;
                        w.skip_before(t);
                        // Now on the last cell entered below t: the walk goes on from it.
                        let last = full.iter().rposition(|&(_, _, e)| e < t).unwrap();
                        prop_assert_eq!((w.cell(), w.index()), (full[last].0, full[last].1));
                        if got.last() != Some(&(w.cell(), w.index())) {
                            got.push((w.cell(), w.index()));
                        }
                    }
                    if !w.advance() {
                        break;
                    }
                }
            }
            // What was visited is the full walk with some stretches left out, in order, ending
            // at the same cell.
            let mut it = full.iter();
            for c in &got {
                prop_assert!(it.any(|f| (f.0, f.1) == *c), "{:?} not in order in {:?}", c, full);
            }
            prop_assert_eq!(got.last().map(|c| c.0), full.last().map(|f| f.0));
        }

        #[test]
        fn lattice_points_and_axis_aligned(ax in -1i32..13, ay in -1i32..9, bx in -1i32..13, by in -1i32..9,
                                          half in any::<bool>()) {
            let g = GridGeometry::new(12, 8, 1.0, Pose2::IDENTITY).unwrap();
            let o = if half { 0.5 } else { 0.0 };
            check_against_brute(&g, Point2::new(ax as f64 + o, ay as f64), Point2::new(bx as f64, by as f64 + o));
        }
    }
}
