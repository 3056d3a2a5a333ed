//! A log-odds occupancy mapper at known poses (Thrun, Burgard & Fox, *Probabilistic Robotics*,
//! §9.2, inverse sensor model without the prior term). It builds the initial map M_1 from an
//! exploration run, and is the map updater's naive baseline.
//!
//! The crate does not know about laser scans (the sensor crate depends on this one), so the API
//! is per ray: [`LogOddsMapper::integrate_ray`] lowers the log-odds of every cell the segment
//! from the sensor to the end point crosses (Amanatides–Woo, [`crate::traverse`]) by
//! `|l_free|` and raises the end cell's by `l_occ` if the beam returned there. A beam with no
//! return is passed as the point at the clearing range with `endpoint_is_hit = false`, which
//! clears every cell up to and including the end cell. Log-odds are clamped to
//! `[l_min, l_max]` after every update, so a map stays able to change.
//!
//! [`LogOddsMapper::to_grid`] thresholds the log-odds into a trinary map: occupied if the
//! occupancy probability is ≥ `occ_threshold`, free if ≤ `free_threshold`, unknown otherwise
//! (so a never-observed cell, log-odds 0 = probability 0.5, is unknown).
//!
//! ```
//! use mapkeeper_grid::mapper::{LogOddsMapper, MapperParams};
//! use mapkeeper_grid::{CellCoord, CellState, GridGeometry, Point2, Pose2};
//! let geometry = GridGeometry::new(10, 1, 1.0, Pose2::IDENTITY).unwrap();
//! let mut mapper = LogOddsMapper::new(geometry, MapperParams::default()).unwrap();
//! for _ in 0..5 {
//!     mapper.integrate_ray(Point2::new(0.5, 0.5), Point2::new(6.5, 0.5), true);
//! }
//! let map = mapper.to_grid();
//! assert_eq!(map.get(CellCoord::new(3, 0)), Some(CellState::Free));
//! assert_eq!(map.get(CellCoord::new(6, 0)), Some(CellState::Occupied));
//! assert_eq!(map.get(CellCoord::new(8, 0)), Some(CellState::Unknown));
//! ```

use crate::grid::{CellCoord, CellState, GridGeometry, OccupancyGrid};
use crate::pose::Point2;
use crate::traversal::traverse_indexed;
use mapkeeper_common::ParamError;
use serde::{Deserialize, Serialize};
use std::ops::ControlFlow;

/// Errors of the mapper.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum MapperError {
    /// A parameter is out of its range.
    #[error("mapper parameter {} = {} is invalid: {}", .0.name, .0.value, .0.requirement)]
    InvalidParam(#[from] ParamError),
}

/// Parameters of the log-odds mapper. Log-odds l = ln(p / (1 − p)) are dimensionless.
///
/// ```
/// use mapkeeper_grid::mapper::MapperParams;
/// let mut p = MapperParams::default();
/// p.l_occ = 1.2;
/// assert!(p.validate().is_ok());
/// let q: MapperParams = toml::from_str("l_free = -0.7").unwrap();
/// assert_eq!((q.l_free, q.l_occ), (-0.7, 0.85));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MapperParams {
    /// Log-odds added to the end cell of a beam that returned, > 0. Default 0.85 (p ≈ 0.70).
    pub l_occ: f64,
    /// Log-odds added to each cell a beam passed through, < 0. Default −0.4 (p ≈ 0.40).
    pub l_free: f64,
    /// Lower clamp of a cell's log-odds, < 0. Default −2.0 (p ≈ 0.12).
    pub l_min: f64,
    /// Upper clamp of a cell's log-odds, > 0. Default 3.5 (p ≈ 0.97).
    pub l_max: f64,
    /// Occupancy probability at or above which a cell is occupied, in (0.5, 1). Default 0.65
    /// (ROS map_server's `occupied_thresh`).
    pub occ_threshold: f64,
    /// Occupancy probability at or below which a cell is free, in (0, 0.5). Default 0.196
    /// (ROS map_server's `free_thresh`).
    pub free_threshold: f64,
    /// Magnitude of the log-odds given to known cells by [`LogOddsMapper::from_grid`]
    /// (occupied +prior_l, free −prior_l, unknown 0, then clamped), ≥ 0. Default 2.0
    /// (p ≈ 0.88 / 0.12): a known cell needs a few contrary observations to flip.
    pub prior_l: f64,
}

impl Default for MapperParams {
    fn default() -> Self {
        Self {
            l_occ: 0.85,
            l_free: -0.4,
            l_min: -2.0,
            l_max: 3.5,
            occ_threshold: 0.65,
            free_threshold: 0.196,
            prior_l: 2.0,
        }
    }
}

/// Log-odds of a probability.
fn logit(p: f64) -> f64 {
    (p / (1.0 - p)).ln()
}

impl MapperParams {
    /// Checks every field's range (all finite; signs as documented; thresholds on either side
    /// of 0.5).
    pub fn validate(&self) -> Result<(), MapperError> {
        let checks: [(&'static str, f64, bool, &'static str); 7] = [
            ("l_occ", self.l_occ, self.l_occ > 0.0, "must be a finite number > 0"),
            ("l_free", self.l_free, self.l_free < 0.0, "must be a finite number < 0"),
            ("l_min", self.l_min, self.l_min < 0.0, "must be a finite number < 0"),
            ("l_max", self.l_max, self.l_max > 0.0, "must be a finite number > 0"),
            (
                "occ_threshold",
                self.occ_threshold,
                self.occ_threshold > 0.5 && self.occ_threshold < 1.0,
                "must be a probability in (0.5, 1)",
            ),
            (
                "free_threshold",
                self.free_threshold,
                self.free_threshold > 0.0 && self.free_threshold < 0.5,
                "must be a probability in (0, 0.5)",
            ),
            ("prior_l", self.prior_l, self.prior_l >= 0.0, "must be a finite number >= 0"),
        ];
        for (name, value, ok, requirement) in checks {
            if !(value.is_finite() && ok) {
                return Err(ParamError::new(name, value, requirement).into());
            }
        }
        Ok(())
    }
}

/// The per-cell update amounts in the storage precision.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Increments {
    occ: f32,
    free: f32,
    min: f32,
    max: f32,
    occ_at: f32,
    free_at: f32,
}

/// A log-odds occupancy grid being built from rays.
#[derive(Clone, Debug, PartialEq)]
pub struct LogOddsMapper {
    geometry: GridGeometry,
    params: MapperParams,
    inc: Increments,
    log_odds: Vec<f32>,
}

impl LogOddsMapper {
    /// An empty map (every cell log-odds 0, i.e. unknown) over `geometry`.
    pub fn new(geometry: GridGeometry, params: MapperParams) -> Result<Self, MapperError> {
        params.validate()?;
        let inc = Increments {
            occ: params.l_occ as f32,
            free: params.l_free as f32,
            min: params.l_min as f32,
            max: params.l_max as f32,
            occ_at: logit(params.occ_threshold) as f32,
            free_at: logit(params.free_threshold) as f32,
        };
        Ok(Self { geometry, params, inc, log_odds: vec![0.0; geometry.len()] })
    }

    /// A mapper started from a trinary map: occupied cells at +`prior_l`, free cells at
    /// −`prior_l` (clamped to `[l_min, l_max]`), unknown cells at 0. With the defaults,
    /// `from_grid(m).to_grid() == m`.
    pub fn from_grid(grid: &OccupancyGrid, params: MapperParams) -> Result<Self, MapperError> {
        let mut mapper = Self::new(*grid.geometry(), params)?;
        let prior = params.prior_l as f32;
        let (lo, hi) = (mapper.inc.min, mapper.inc.max);
        for (l, &s) in mapper.log_odds.iter_mut().zip(grid.cells()) {
            *l = match s {
                CellState::Occupied => prior.clamp(lo, hi),
                CellState::Free => (-prior).clamp(lo, hi),
                CellState::Unknown => 0.0,
            };
        }
        Ok(mapper)
    }

    /// The map's geometry.
    pub fn geometry(&self) -> &GridGeometry {
        &self.geometry
    }

    /// The parameters (validated).
    pub fn params(&self) -> &MapperParams {
        &self.params
    }

    /// Every cell's log-odds, row-major from the bottom row.
    pub fn log_odds(&self) -> &[f32] {
        &self.log_odds
    }

    /// One cell's log-odds, `None` outside the grid.
    pub fn log_odds_at(&self, c: CellCoord) -> Option<f32> {
        self.geometry.index(c).map(|i| self.log_odds[i])
    }

    /// Integrates one beam from the sensor at `from` to `to` (map frame): every cell the segment
    /// crosses inside the grid gets `l_free`, except the cell containing `to`, which gets `l_occ`
    /// if `endpoint_is_hit` (and `l_free` otherwise). If `to` lies outside the grid, no cell
    /// gets `l_occ`. Non-finite points change nothing. No allocation.
    pub fn integrate_ray(&mut self, from: Point2, to: Point2, endpoint_is_hit: bool) {
        // The end cell's index, if it is inside the grid (the walk visits only cells inside it).
        let end =
            if endpoint_is_hit { self.geometry.world_to_cell(to).and_then(|c| self.geometry.index(c)) } else { None };
        let inc = self.inc;
        let cells = &mut self.log_odds;
        let _ = traverse_indexed(&self.geometry, from, to, |_, i| {
            let delta = if Some(i) == end { inc.occ } else { inc.free };
            if let Some(l) = cells.get_mut(i) {
                *l = (*l + delta).clamp(inc.min, inc.max);
            }
            ControlFlow::<()>::Continue(())
        });
    }

    /// The trinary map: occupied where the probability is ≥ `occ_threshold`, free where it is
    /// ≤ `free_threshold`, unknown elsewhere (including never-observed cells).
    pub fn to_grid(&self) -> OccupancyGrid {
        let mut grid = OccupancyGrid::filled(self.geometry, CellState::Unknown);
        for (s, &l) in grid.cells_mut().iter_mut().zip(&self.log_odds) {
            *s = self.classify(l);
        }
        grid
    }

    /// The state a log-odds value maps to.
    #[inline]
    fn classify(&self, l: f32) -> CellState {
        if l >= self.inc.occ_at {
            CellState::Occupied
        } else if l <= self.inc.free_at {
            CellState::Free
        } else {
            CellState::Unknown
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::{MetricParams, map_metrics};
    use crate::pose::Pose2;
    use crate::traversal::{RayStop, cast_ray};

    fn row_grid(n: usize) -> GridGeometry {
        GridGeometry::new(n, 1, 1.0, Pose2::IDENTITY).unwrap()
    }

    #[test]
    fn single_ray_hand_computed() {
        // 10 × 1 at 1 m: a hit at (5.5, 0.5) from (0.5, 0.5): cells 0..=4 get −0.4, cell 5 gets
        // +0.85, cells 6..=9 stay 0.
        let mut m = LogOddsMapper::new(row_grid(10), MapperParams::default()).unwrap();
        m.integrate_ray(Point2::new(0.5, 0.5), Point2::new(5.5, 0.5), true);
        let l = m.log_odds();
        assert!(l[..5].iter().all(|&x| x == -0.4f32));
        assert_eq!(l[5], 0.85f32);
        assert!(l[6..].iter().all(|&x| x == 0.0));
        // One observation: hit cell 0.85 ≥ logit(0.65) ≈ 0.619 → occupied; −0.4 > logit(0.196)
        // ≈ −1.41 → still unknown; four passes (−1.6) make it free.
        let g = m.to_grid();
        assert_eq!(g.get(CellCoord::new(5, 0)), Some(CellState::Occupied));
        assert_eq!(g.get(CellCoord::new(2, 0)), Some(CellState::Unknown));
        for _ in 0..3 {
            m.integrate_ray(Point2::new(0.5, 0.5), Point2::new(5.5, 0.5), true);
        }
        let g = m.to_grid();
        assert_eq!(g.get(CellCoord::new(2, 0)), Some(CellState::Free));
        assert_eq!(g.get(CellCoord::new(8, 0)), Some(CellState::Unknown));
    }

    #[test]
    fn no_return_clears_end_cell_and_clamps() {
        let mut m = LogOddsMapper::new(row_grid(6), MapperParams::default()).unwrap();
        for _ in 0..20 {
            m.integrate_ray(Point2::new(0.5, 0.5), Point2::new(3.5, 0.5), false);
        }
        // Cells 0..=3 clamped at l_min = −2; 4, 5 untouched.
        assert_eq!(m.log_odds(), &[-2.0, -2.0, -2.0, -2.0, 0.0, 0.0]);
        for _ in 0..20 {
            m.integrate_ray(Point2::new(0.5, 0.5), Point2::new(3.5, 0.5), true);
        }
        assert_eq!(m.log_odds_at(CellCoord::new(3, 0)), Some(3.5));
        // A hit beyond the grid raises nothing; the crossed cells are cleared.
        let mut n = LogOddsMapper::new(row_grid(3), MapperParams::default()).unwrap();
        n.integrate_ray(Point2::new(0.5, 0.5), Point2::new(7.5, 0.5), true);
        assert!(n.log_odds().iter().all(|&x| x == -0.4f32));
        // Non-finite input changes nothing.
        n.integrate_ray(Point2::new(f64::NAN, 0.5), Point2::new(2.5, 0.5), true);
        assert!(n.log_odds().iter().all(|&x| x == -0.4f32));
    }

    #[test]
    fn from_grid_round_trips_with_defaults() {
        let g = GridGeometry::new(3, 1, 1.0, Pose2::IDENTITY).unwrap();
        let map = OccupancyGrid::from_cells(g, vec![CellState::Occupied, CellState::Free, CellState::Unknown]).unwrap();
        let m = LogOddsMapper::from_grid(&map, MapperParams::default()).unwrap();
        assert_eq!(m.log_odds(), &[2.0, -2.0, 0.0]);
        assert_eq!(m.to_grid(), map);
        // A prior beyond the clamps is clamped.
        let p = MapperParams { prior_l: 10.0, ..MapperParams::default() };
        assert_eq!(LogOddsMapper::from_grid(&map, p).unwrap().log_odds(), &[3.5, -2.0, 0.0]);
    }

    #[test]
    fn validation() {
        let d = MapperParams::default();
        for p in [
            MapperParams { l_occ: 0.0, ..d },
            MapperParams { l_free: 0.1, ..d },
            MapperParams { l_min: 0.0, ..d },
            MapperParams { l_max: f64::INFINITY, ..d },
            MapperParams { occ_threshold: 0.5, ..d },
            MapperParams { free_threshold: 0.5, ..d },
            MapperParams { prior_l: -1.0, ..d },
            MapperParams { l_occ: f64::NAN, ..d },
        ] {
            assert!(matches!(LogOddsMapper::new(row_grid(2), p), Err(MapperError::InvalidParam { .. })), "{p:?}");
        }
        assert!(toml::from_str::<MapperParams>("l_hit = 1.0").is_err());
        let e = MapperParams { free_threshold: 0.7, ..d }.validate().unwrap_err();
        let MapperError::InvalidParam(p) = &e;
        assert_eq!(p, &ParamError::new("free_threshold", 0.7, "must be a probability in (0, 0.5)"));
        assert_eq!(
            e.to_string(),
            "mapper parameter free_threshold = 0.7 is invalid: must be a probability in (0, 0.5)"
        );
    }

    /// A 4 m × 3 m room (walls one cell thick) centred in a 6 m × 5 m grid at 0.05 m; outside
    /// the walls is unknown. The twin of `mapkeeper_testkit::rooms::four_by_three_in_unknown`,
    /// which a unit test of the grid cannot take: its grid is not this test build's.
    fn room() -> OccupancyGrid {
        let g = GridGeometry::new(120, 100, 0.05, Pose2::new(-1.0, -1.0, 0.0)).unwrap();
        let mut m = OccupancyGrid::filled(g, CellState::Unknown);
        // Walls on cells 20..=99 (x) and 20..=79 (y): from 0.0 m to 4.0 m and 0.0 m to 3.0 m.
        for iy in 20..=79 {
            for ix in 20..=99 {
                let wall = ix == 20 || ix == 99 || iy == 20 || iy == 79;
                m.set(CellCoord::new(ix, iy), if wall { CellState::Occupied } else { CellState::Free });
            }
        }
        m
    }

    #[test]
    fn reconstructs_a_room_from_a_few_poses() {
        let truth = room();
        let mut mapper = LogOddsMapper::new(*truth.geometry(), MapperParams::default()).unwrap();
        let beams = 720;
        for pose in [Point2::new(1.0, 1.0), Point2::new(3.0, 2.0), Point2::new(2.0, 1.5), Point2::new(3.2, 0.6)] {
            for k in 0..beams {
                let a = k as f64 * std::f64::consts::TAU / beams as f64;
                let hit = cast_ray(&truth, pose, a, 10.0, false);
                assert_eq!(hit.stop, RayStop::Occupied);
                // Just past the entry point, inside the wall cell.
                let r = hit.range_m + 1e-3;
                mapper.integrate_ray(pose, Point2::new(pose.x + r * a.cos(), pose.y + r * a.sin()), true);
            }
        }
        let map = mapper.to_grid();
        let g = truth.geometry();
        let (mut walls, mut walls_ok, mut inside, mut inside_free) = (0, 0, 0, 0);
        for i in 0..g.len() {
            let (t, s) = (truth.cells()[i], map.cells()[i]);
            match t {
                CellState::Occupied => {
                    walls += 1;
                    walls_ok += usize::from(s == CellState::Occupied);
                }
                CellState::Free => {
                    inside += 1;
                    inside_free += usize::from(s == CellState::Free);
                    assert_ne!(s, CellState::Occupied, "occupied cell inside at {:?}", g.coord(i));
                }
                // Never observed outside the walls.
                CellState::Unknown => assert_eq!(s, CellState::Unknown, "at {:?}", g.coord(i)),
            }
        }
        assert!(walls_ok as f64 >= 0.97 * walls as f64, "{walls_ok}/{walls} wall cells occupied");
        assert!(inside_free as f64 >= 0.97 * inside as f64, "{inside_free}/{inside} inside cells free");
        let m = map_metrics(&map, &truth, &MetricParams::default()).unwrap();
        assert!(m.cc > 90.0 && m.ms > 90.0 && m.opdf > 95.0, "{m:?}");
    }
}
