//! The naive baseline (a comparison row asked for by the spec, not part of the method and not
//! in the paper): plain log-odds occupancy mapping of every gated scan into `M_{i-1}` at the
//! estimated pose (no localisation check, no buffers; the classifier still runs, but its
//! verdicts are not used), with the grid crate's [`LogOddsMapper`]. It runs instead of the
//! evaluators and the cells update when `method = "log-odds"`, and shows what the paper's
//! safeguards buy.
//!
//! The mapper's log-odds array is map-sized and owned for the whole run (never reallocated per
//! scan). After each ray only the cells the ray touched are re-thresholded into `M_i`, with the
//! mapper's own thresholds, so `M_i` always equals `mapper.to_grid()` without a map-sized copy
//! per scan.

use crate::paper::cell_update::CellChange;
use mapkeeper_grid::mapper::{LogOddsMapper, MapperError, MapperParams};
use mapkeeper_grid::{CellState, OccupancyGrid, Point2, traverse};
use std::ops::ControlFlow;

/// Log-odds occupancy mapping on top of an initial map.
#[derive(Clone, Debug)]
pub struct LogOddsBaseline {
    mapper: LogOddsMapper,
    occ_at: f32,
    free_at: f32,
}

fn logit(p: f64) -> f32 {
    (p / (1.0 - p)).ln() as f32
}

impl LogOddsBaseline {
    /// Priors from `initial` (see [`LogOddsMapper::from_grid`]).
    pub fn from_grid(initial: &OccupancyGrid, params: MapperParams) -> Result<Self, MapperError> {
        Ok(Self {
            mapper: LogOddsMapper::from_grid(initial, params)?,
            occ_at: logit(params.occ_threshold),
            free_at: logit(params.free_threshold),
        })
    }

    /// Bytes of log-odds state (map-sized).
    pub fn state_bytes(&self) -> usize {
        std::mem::size_of_val(self.mapper.log_odds())
    }

    /// Integrates one ray from `from` to `to` and re-thresholds the touched cells of `map`,
    /// recording changes.
    pub fn integrate_ray(
        &mut self,
        map: &mut OccupancyGrid,
        from: Point2,
        to: Point2,
        endpoint_is_hit: bool,
        changes: &mut Vec<CellChange>,
    ) {
        self.mapper.integrate_ray(from, to, endpoint_is_hit);
        let g = *map.geometry();
        let lo = self.mapper.log_odds();
        let (occ_at, free_at) = (self.occ_at, self.free_at);
        let _ = traverse(&g, from, to, |c| {
            let i = c.iy as usize * g.width() + c.ix as usize;
            let l = lo[i];
            let s = if l >= occ_at {
                CellState::Occupied
            } else if l <= free_at {
                CellState::Free
            } else {
                CellState::Unknown
            };
            let before = map.cells()[i];
            if s != before {
                map.cells_mut()[i] = s;
                changes.push(CellChange { cell: c, from: before, to: s });
            }
            ControlFlow::<()>::Continue(())
        });
    }
}
