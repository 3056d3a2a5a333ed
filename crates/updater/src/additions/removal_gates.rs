//! The robust removal vote (project additions, not in the paper): gates on the "changed"
//! (removed) vote that the changed cells evaluator (§4.3.1) gives each non-free cell of
//! `M_{i-1}` a detected-change ray crosses before p_th.
//!
//! With the pose a fraction of a cell off (a localiser's usual 2-4 cm), rays that graze a wall
//! cross its edge cells far from where they end, rays that clip an obstacle's corner run inside
//! it, and a robot driving along a wall erodes it. The gates (each off in `paper` and `authors`,
//! which leaves §4.3.1 as written; on in `mapkeeper`):
//!
//! - **hit clearance** (`removal.hit_clearance_m`, [`crate::support::hit_index`]): no vote for
//!   a cell whose centre lies within the clearance of a hit of the same step;
//! - **grazing incidence** (`removal.min_incidence_rad`, [`crate::additions::grazing`]): no vote
//!   when the ray meets the cell's wall, or a free face of the cell, flatter than the minimum;
//! - **ray core** (`removal.max_offset_cells`): no vote for a cell the ray passes further than
//!   this from the centre of (it only clips a corner);
//! - **shadow** (`removal.shadow`): after a vote withheld by the first two, the rest of that run
//!   of non-free cells gets no vote either (the ray is not trusted to have passed the surface),
//!   until the ray has crossed [`SHADOW_CLEAR_CELLS`] free cells in a row (a one-cell gap
//!   between two stacked boxes does not clear it).
//!
//! Their parameters are the `removal` section of the updater's parameters
//! ([`RemovalParams`], `crate::params::removal`).
//! `tests/additions.rs` shows the failure each gate prevents.

use crate::additions::grazing;
use crate::params::RemovalParams;
use crate::support::beam_walk::BeamGeometry;
use crate::support::hit_index::HitIndex;
use crate::support::removal_filter::RemovalFilter;
use mapkeeper_grid::{CellCoord, OccupancyGrid, Point2};

/// Free cells in a row a ray must cross after a withheld vote before it votes again.
pub const SHADOW_CLEAR_CELLS: i32 = 3;

/// The gates for one detected-change ray, fed the ray's non-free cells in walk order.
pub struct RemovalGates<'a> {
    base: &'a OccupancyGrid,
    hits: &'a HitIndex,
    origin: Point2,
    /// The ray's direction (hit − origin) and the inverse of its length.
    dx: f64,
    dy: f64,
    inv_len: f64,
    /// The ray's direction in the grid frame (the map's origin may carry a yaw), for the
    /// grazing gate, which compares it with cell faces and wall lines of the grid.
    gx: f64,
    gy: f64,
    /// The ray's incidence on the x faces and on the y faces of the cells (|sin| to the face,
    /// grid frame).
    sin_x: f64,
    sin_y: f64,
    /// Sine of the minimum incidence (0: the grazing gate is off).
    min_sin: f64,
    /// Largest offset of a voted cell's centre from the ray, metres.
    max_off_m: f64,
    /// Whether a withheld vote shadows the rest of its run of non-free cells.
    shadow: bool,
    /// Set by a withheld vote, cleared by a gap of more than `SHADOW_CLEAR_CELLS` free cells.
    shadowed: bool,
    /// The previous non-free cell visited.
    prev: Option<CellCoord>,
}

impl<'a> RemovalGates<'a> {
    /// The gates of `removal` (the `removal` section of the updater's parameters) for `beam`
    /// over `base` = `M_{i-1}`; `hits` holds the step's measured hit points (an empty index
    /// disables the hit clearance).
    pub fn new(base: &'a OccupancyGrid, removal: &RemovalParams, hits: &'a HitIndex, beam: &BeamGeometry) -> Self {
        let (origin, hit) = (beam.origin, beam.hit);
        let (dx, dy) = (hit.x - origin.x, hit.y - origin.y);
        let inv_len = 1.0 / dx.hypot(dy).max(1e-12);
        // World frame → grid frame: rotate by minus the yaw of the map's origin.
        let (s, c) = base.geometry().origin().yaw.sin_cos();
        let (gx, gy) = (c * dx + s * dy, -s * dx + c * dy);
        Self {
            base,
            hits,
            origin,
            dx,
            dy,
            inv_len,
            gx,
            gy,
            sin_x: gx.abs() * inv_len,
            sin_y: gy.abs() * inv_len,
            min_sin: removal.min_incidence_rad.sin(),
            max_off_m: removal.max_offset_cells * base.geometry().resolution_m(),
            shadow: removal.shadow,
            shadowed: false,
            prev: None,
        }
    }

    /// Takes the next non-free cell `c` the ray visits and says whether it lies in the shadow
    /// of a withheld vote. The walk is 4-connected, so the free cells between two visited
    /// non-free cells number their Manhattan distance minus one.
    #[inline]
    pub fn in_shadow(&mut self, c: CellCoord) -> bool {
        if let Some(p) = self.prev
            && (c.ix - p.ix).abs() + (c.iy - p.iy).abs() > SHADOW_CLEAR_CELLS
        {
            self.shadowed = false;
        }
        self.prev = Some(c);
        self.shadowed
    }

    /// Whether the ray passes within the core offset of `centre` (a cell's centre).
    #[inline]
    pub fn near_core(&self, centre: Point2) -> bool {
        let off = ((centre.x - self.origin.x) * self.dy - (centre.y - self.origin.y) * self.dx).abs() * self.inv_len;
        off <= self.max_off_m
    }

    /// Whether the grazing gate or the hit clearance withholds the vote of cell `c` (centre
    /// `centre`); a withheld vote starts a shadow.
    #[inline]
    pub fn withholds(&mut self, c: CellCoord, centre: Point2) -> bool {
        // Cheapest test first (the result is their "or").
        let withheld = grazing::meets_a_free_face_grazing(self.base, c, self.sin_x, self.sin_y, self.min_sin)
            || self.hits.any_within(centre)
            || grazing::is_grazing(self.base, c, self.gx, self.gy, self.min_sin);
        if withheld && self.shadow {
            self.shadowed = true;
        }
        withheld
    }
}

impl RemovalFilter for RemovalGates<'_> {
    #[inline]
    fn in_shadow(&mut self, c: CellCoord) -> bool {
        RemovalGates::in_shadow(self, c)
    }

    /// The core offset first, then the grazing gate and the hit clearance.
    #[inline]
    fn passes(&mut self, c: CellCoord, centre: Point2) -> bool {
        self.near_core(centre) && !self.withholds(c, centre)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::UpdaterParams;
    use crate::paper::changed_cells::{evaluate_changed_beam, evaluate_changed_beam_cast};
    use crate::support::step_tolerance::StepTolerance;
    use mapkeeper_common::ParamError;
    use mapkeeper_grid::{CellState, GridGeometry, Pose2, RayCaster};

    #[test]
    fn validate_names_the_field_its_value_and_the_requirement() {
        assert!(RemovalParams::default().validate().is_ok() && RemovalParams::mapkeeper().validate().is_ok());
        let e = RemovalParams { max_offset_cells: 0.0, ..RemovalParams::default() }.validate().unwrap_err();
        assert_eq!(e, ParamError::new("removal.max_offset_cells", 0, "must be > 0"));
        let e = RemovalParams { hit_clearance_m: f64::NAN, ..RemovalParams::mapkeeper() }.validate().unwrap_err();
        assert_eq!(e.to_string(), "removal.hit_clearance_m must be finite and >= 0, got NaN");
    }

    /// The changed evaluator's two walks (the plain one and the caster's, which skips open
    /// stretches) give the same votes through the gates.
    #[test]
    fn gated_caster_walk_gives_the_votes_of_a_gated_full_walk() {
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
            params.removal.hit_clearance_m,
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
            evaluate_changed_beam(
                &m,
                &beam,
                (&params, &tol),
                |b| RemovalGates::new(&m, &params.removal, &hits, b),
                &mut want,
            );
            evaluate_changed_beam_cast(
                &caster,
                &beam,
                (&params, &tol),
                |b| RemovalGates::new(&m, &params.removal, &hits, b),
                &mut got,
            );
            assert_eq!(got, want, "ray {k}");
            n_votes += want.len();
        }
        assert!(n_votes > 1000, "the rays must cross obstacles ({n_votes} votes)");
    }
}
