//! Cells update (§4.5) and border reconstruction (Fig. 14).
//!
//! Votes of one step are reduced to one flag per cell (a cell crossed by many beams of one scan
//! gets one flag per time instant, not one per beam: "changed" if it got at least as many
//! "changed" as "unchanged" votes). Each flag is pushed into the cell's rolling buffer. A cell
//! flips from its `M_{i-1}` state to the other one (occupied or unknown → free, free →
//! occupied) when its buffer holds at least `change_threshold` "changed" flags (with the
//! `reference` neighbour-support rule if enabled), and flips back when it holds at least
//! `change_threshold` "unchanged" flags. When a cell becomes free, its unknown 8-neighbours in
//! `M_i` are set occupied so that a partly removed obstacle keeps a closed border.

use crate::UpdaterParams;
use crate::cell_buffers::{CellBuffers, RollingBuffer};
use crate::changed_cells::Vote;
use mapkeeper_grid::{CellCoord, CellState, OccupancyGrid};
use serde::{Deserialize, Serialize};

/// A cell of `M_i` whose state changed during a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct CellChange {
    /// The cell.
    pub cell: CellCoord,
    /// State before the step.
    pub from: CellState,
    /// State after.
    pub to: CellState,
}

/// Reusable scratch of the cells update.
#[derive(Clone, Debug, Default)]
pub struct CellUpdater {
    flagged: Vec<(u32, RollingBuffer)>,
}

/// The state a cell flips to when changed, given its state in `M_{i-1}`.
#[inline]
pub fn flipped(base: CellState) -> CellState {
    if base == CellState::Free { CellState::Occupied } else { CellState::Free }
}

impl CellUpdater {
    /// Reduces `votes` (sorted in place), pushes one flag per cell into `buffers`, applies the
    /// flip rule to `current` (`M_i`) and appends every state change to `changes`.
    pub fn apply(
        &mut self,
        votes: &mut [Vote],
        base: &OccupancyGrid,
        current: &mut OccupancyGrid,
        buffers: &mut CellBuffers,
        params: &UpdaterParams,
        changes: &mut Vec<CellChange>,
    ) {
        votes.sort_unstable();
        self.flagged.clear();
        let g = *base.geometry();
        let mut i = 0;
        while i < votes.len() {
            let index = votes[i] >> 1;
            let (mut n_changed, mut n_unchanged) = (0u32, 0u32);
            while i < votes.len() && votes[i] >> 1 == index {
                if votes[i] & 1 == 1 {
                    n_changed += 1;
                } else {
                    n_unchanged += 1;
                }
                i += 1;
            }
            let cell = g.coord(index as usize);
            if let Some(b) = buffers.push(index, cell, n_changed >= n_unchanged, params.buffer_size) {
                self.flagged.push((index, b));
            }
        }
        let threshold = params.change_threshold;
        for &(index, buffer) in &self.flagged {
            let idx = index as usize;
            let cell = g.coord(idx);
            let base_state = base.cells()[idx];
            let target = flipped(base_state);
            let now = current.cells()[idx];
            if now != target {
                let mut support = buffer.changed();
                if params.neighbour_support && support < threshold {
                    for n in cell.neighbours8() {
                        if let Some(j) = g.index(n)
                            && base.cells()[j] == base_state
                            && buffers.get(j as u32).is_some_and(|b| b.changed() >= threshold)
                        {
                            support += 1;
                        }
                    }
                }
                if support >= threshold {
                    current.cells_mut()[idx] = target;
                    changes.push(CellChange { cell, from: now, to: target });
                    if target == CellState::Free && params.border_reconstruction {
                        for n in cell.neighbours8() {
                            if let Some(j) = g.index(n)
                                && current.cells()[j] == CellState::Unknown
                            {
                                current.cells_mut()[j] = CellState::Occupied;
                                changes.push(CellChange { cell: n, from: CellState::Unknown, to: CellState::Occupied });
                            }
                        }
                    }
                }
            } else if buffer.unchanged() >= threshold {
                current.cells_mut()[idx] = base_state;
                changes.push(CellChange { cell, from: now, to: base_state });
            }
        }
    }
}
