//! A measured beam as the evaluators see it ([`BeamGeometry`], with p_th of eq. 9), and the walk
//! along it that visits only cells holding a buffer. Shared by the unchanged cells evaluator
//! (§4.4), the changed cells evaluator (§4.3) and the free-pass votes (a project addition).

use crate::support::cell_buffers::{CellBuffers, TileProbe};
use mapkeeper_grid::{CellCoord, GridGeometry, Point2, SegmentWalk};

/// One measured beam: the segment from its lidar's position to the hit point p_i, and its
/// range z_i. Borrowed per beam by the evaluators.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeamGeometry {
    /// Where the ray starts: the lidar's position in the map.
    pub origin: Point2,
    /// The measured hit point p_i (eq. 2), map frame.
    pub hit: Point2,
    /// The measured range z_i, metres.
    pub range_m: f64,
}

impl BeamGeometry {
    /// The beam from `origin` to `hit`, measured at range `range_m`.
    pub fn new(origin: Point2, hit: Point2, range_m: f64) -> Self {
        Self { origin, hit, range_m }
    }

    /// p_th (eq. 9): the point `skip_m` before the hit on the segment (None if the whole beam is
    /// shorter than the chunk).
    #[inline]
    pub fn threshold_point(&self, skip_m: f64) -> Option<Point2> {
        let (origin, hit, z) = (self.origin, self.hit, self.range_m);
        if z.is_nan() || z <= skip_m {
            return None;
        }
        let f = (z - skip_m) / z;
        Some(Point2::new(origin.x + f * (hit.x - origin.x), origin.y + f * (hit.y - origin.y)))
    }
}

/// Margin, in units of the walked segment, kept before a tile's exit when a walk crosses a tile
/// without buffers: above the rounding of the walk's boundary parameters (at most 2⁻⁵² per
/// step over at most 2²¹ steps, about 5e-10).
const TILE_EXIT_MARGIN: f64 = 1e-9;

/// Calls `visit(cell, index)` for every cell that holds a buffer, in the order the traversal
/// from the beam's origin towards its hit point visits them, up to p_th (`skip_m` before the
/// hit). `first_buffer_m`: no cell closer than this to the origin along the beam holds a buffer (0 if
/// unknown; see `Beam::walk_from_m` of the beam classifier), so the walk starts about there;
/// tiles without buffers are crossed without visiting their cells. The same cells as a plain
/// cell-by-cell walk filtered by the probe (tests in `paper::unchanged_cells` and `additions::free_pass`).
pub fn buffered_cells_before_chunk(
    g: &GridGeometry,
    beam: &BeamGeometry,
    skip_m: f64,
    first_buffer_m: f64,
    probe: &mut TileProbe<'_>,
    mut visit: impl FnMut(CellCoord, usize),
) {
    let r = g.resolution_m();
    // Every cell the walk visits has a point within rounding of the segment, at most z − skip
    // from the origin; a cell first entered less than `first_buffer_m − r` along it is closer
    // than `first_buffer_m` (one cell of margin, far above the rounding).
    if first_buffer_m > beam.range_m - skip_m + r {
        return;
    }
    let Some(p_th) = beam.threshold_point(skip_m) else { return };
    let Some(mut walk) = SegmentWalk::start(g, beam.origin, p_th) else { return };
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
