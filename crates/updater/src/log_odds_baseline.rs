//! The naive baseline: plain log-odds occupancy mapping of every gated scan into `M_{i-1}` at
//! the estimated pose (no localisation check, no buffers, no 1-to-N comparison). It shows what
//! the paper's safeguards buy.
//!
//! A minimal private mapper is used (one `f32` of log-odds per cell, owned for the whole run,
//! never reallocated per scan): the cells of `M_i` are re-thresholded only where a ray touched
//! them, so reading out the map costs nothing per scan. Its state is map-sized by construction,
//! unlike the paper's method.

use crate::cell_update::CellChange;
use crate::params::LogOddsParams;
use mapkeeper_grid::{CellState, OccupancyGrid, Point2, traverse};
use std::ops::ControlFlow;

/// Log-odds occupancy mapping on top of an initial map.
#[derive(Clone, Debug)]
pub struct LogOddsBaseline {
    log_odds: Vec<f32>,
    params: LogOddsParams,
}

impl LogOddsBaseline {
    /// Priors from `initial`: occupied and free cells start at the configured prior log-odds,
    /// unknown cells at 0.
    pub fn from_grid(initial: &OccupancyGrid, params: LogOddsParams) -> Self {
        let log_odds = initial
            .cells()
            .iter()
            .map(|s| match s {
                CellState::Occupied => params.prior_occupied_log_odds,
                CellState::Free => params.prior_free_log_odds,
                CellState::Unknown => 0.0,
            })
            .collect();
        Self { log_odds, params }
    }

    /// Bytes of log-odds state (map-sized).
    pub fn state_bytes(&self) -> usize {
        self.log_odds.len() * size_of::<f32>()
    }

    fn state_of(&self, l: f32) -> CellState {
        if l >= self.params.occupied_threshold {
            CellState::Occupied
        } else if l <= self.params.free_threshold {
            CellState::Free
        } else {
            CellState::Unknown
        }
    }

    /// Integrates one ray from `from` to `to` (misses along it, a hit in the last cell if
    /// `endpoint_is_hit`) and re-thresholds the touched cells of `map`, recording changes.
    pub fn integrate_ray(
        &mut self,
        map: &mut OccupancyGrid,
        from: Point2,
        to: Point2,
        endpoint_is_hit: bool,
        changes: &mut Vec<CellChange>,
    ) {
        let g = *map.geometry();
        let end = g.world_to_cell(to);
        let clamp = self.params.clamp_log_odds;
        let (hit, miss) = (self.params.hit_log_odds, self.params.miss_log_odds);
        let _ = traverse(&g, from, to, |c| {
            let i = c.iy as usize * g.width() + c.ix as usize;
            let delta = if endpoint_is_hit && Some(c) == end { hit } else { miss };
            let l = (self.log_odds[i] + delta).clamp(-clamp, clamp);
            self.log_odds[i] = l;
            let s = self.state_of(l);
            let before = map.cells()[i];
            if s != before {
                map.cells_mut()[i] = s;
                changes.push(CellChange { cell: c, from: before, to: s });
            }
            ControlFlow::<()>::Continue(())
        });
    }
}
