//! Cells update (§4.5) and border reconstruction (Fig. 14).
//!
//! Votes of one step become flags by `flags` ([`FlagRule`]: in `paper` a cell crossed by many
//! beams of one scan gets one flag per time instant, not one per beam: "changed" if it got at
//! least as many "changed" as "unchanged" votes). Each flag is pushed into the cell's rolling
//! buffer. A cell flips from its `M_{i-1}` state to the other one (occupied or unknown → free,
//! free → occupied) when its buffer holds at least `change_threshold` "changed" flags (with the
//! `authors` neighbour-support rule if enabled), and flips back by `revert` ([`RevertRule`];
//! never in `paper-strict`). When a cell becomes free, its unknown 8-neighbours in
//! `M_i` are set occupied so that a partly removed obstacle keeps a closed border (Fig. 14).
//! With `border_interior_only` (on in `paper` and `mapkeeper`) only unknown cells that are an
//! obstacle's interior in `M_{i-1}` are: an unknown region enclosed by occupied cells (no free
//! 4-neighbour, not on the map's edge). Unknown space that was simply never observed (shadows
//! behind rack posts, frontiers of a mapped `M_1`) is not an obstacle; when the robot sees into
//! it, it becomes free without growing spurious borders.

use crate::UpdaterParams;
use crate::params::{FlagRule, RevertRule};
use crate::support::cell_buffers::{CellBuffers, RollingBuffer};
use crate::support::votes::Vote;
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

/// Reusable scratch of the cells update, and which unknown cells of `M_{i-1}` are obstacle
/// interiors (computed once per `M_{i-1}`).
#[derive(Clone, Debug)]
pub struct CellUpdater {
    flagged: Vec<(u32, RollingBuffer)>,
    interior: Vec<bool>,
}

/// The state a cell flips to when changed, given its state in `M_{i-1}`.
#[inline]
pub fn flipped(base: CellState) -> CellState {
    if base == CellState::Free { CellState::Occupied } else { CellState::Free }
}

impl CellUpdater {
    /// A cells update for `base` = `M_{i-1}`: finds the unknown regions enclosed by occupied
    /// cells (4-connected components of unknown cells with no free 4-neighbour that do not
    /// touch the map's edge), the only cells border reconstruction may set occupied.
    pub fn new(base: &OccupancyGrid) -> Self {
        Self { flagged: Vec::new(), interior: enclosed_unknown(base) }
    }

    /// Heap bytes of the interior mask: one `bool` per cell of `M_{i-1}` (map-sized).
    pub fn cache_bytes(&self) -> usize {
        self.interior.capacity() * size_of::<bool>()
    }

    /// Heap bytes of the per-step scratch: the cells flagged in the last step (sized by the
    /// cells touched by one step, reused).
    pub fn scratch_bytes(&self) -> usize {
        self.flagged.capacity() * size_of::<(u32, RollingBuffer)>()
    }

    /// Whether the unknown cell at `index` of `M_{i-1}` is an obstacle's interior.
    pub fn is_interior(&self, index: usize) -> bool {
        self.interior.get(index).copied().unwrap_or(false)
    }

    /// Reduces `votes` (sorted in place), pushes one flag per cell into `buffers`, applies the
    /// flip rule to `current` (`M_i`) and appends every state change to `changes`. With the
    /// memory on (`params.memory`), an occupied cell for which `established` (asked with the
    /// cell's index) holds needs `params.memory.established_removal_threshold` flags to become
    /// free (the `mapkeeper` addition's structure memory plugs in there; the paper's presets
    /// keep it off).
    pub fn apply(
        &mut self,
        votes: &mut [Vote],
        base: &OccupancyGrid,
        current: &mut OccupancyGrid,
        buffers: &mut CellBuffers,
        (params, established): (&UpdaterParams, &dyn Fn(u32) -> bool),
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
            let last = match params.flags {
                FlagRule::StepMajority => buffers.push(index, cell, n_changed >= n_unchanged, params.buffer_size),
                FlagRule::StepEachKind => {
                    let c = (n_changed > 0).then(|| buffers.push(index, cell, true, params.buffer_size)).flatten();
                    (n_unchanged > 0).then(|| buffers.push(index, cell, false, params.buffer_size)).flatten().or(c)
                }
            };
            if let Some(b) = last {
                self.flagged.push((index, b));
            }
        }
        for &(index, buffer) in &self.flagged {
            let idx = index as usize;
            let cell = g.coord(idx);
            let base_state = base.cells()[idx];
            let target = flipped(base_state);
            let now = current.cells()[idx];
            let threshold = if params.memory.enabled && base_state == CellState::Occupied && established(index) {
                params.memory.established_removal_threshold.max(params.change_threshold)
            } else {
                params.change_threshold
            };
            if now != target {
                if self.support(buffer, cell, base, buffers, params) >= threshold {
                    current.cells_mut()[idx] = target;
                    changes.push(CellChange { cell, from: now, to: target });
                    if target == CellState::Free && params.border_reconstruction {
                        for n in cell.neighbours8() {
                            if let Some(j) = g.index(n)
                                && current.cells()[j] == CellState::Unknown
                                && (!params.border_interior_only || self.is_interior(j))
                            {
                                current.cells_mut()[j] = CellState::Occupied;
                                changes.push(CellChange { cell: n, from: CellState::Unknown, to: CellState::Occupied });
                            }
                        }
                    }
                }
            } else if match params.revert {
                RevertRule::Never => false,
                RevertRule::BelowThreshold => self.support(buffer, cell, base, buffers, params) < threshold,
                RevertRule::UnchangedThreshold => buffer.unchanged() >= params.change_threshold,
            } {
                current.cells_mut()[idx] = base_state;
                changes.push(CellChange { cell, from: now, to: base_state });
            }
        }
    }
}

impl CellUpdater {
    /// The flip rule's count for `cell`: its "changed" flags, plus (with `neighbour_support`,
    /// below the threshold) the 8-neighbours with the same `M_{i-1}` state already at it.
    fn support(
        &self,
        buffer: RollingBuffer,
        cell: CellCoord,
        base: &OccupancyGrid,
        buffers: &CellBuffers,
        params: &UpdaterParams,
    ) -> u32 {
        let threshold = params.change_threshold;
        let mut support = buffer.changed();
        if params.neighbour_support && support < threshold {
            let g = base.geometry();
            let base_state = base.get(cell);
            for n in cell.neighbours8() {
                if let Some(j) = g.index(n)
                    && Some(base.cells()[j]) == base_state
                    && buffers.get(j as u32).is_some_and(|b| b.changed() >= threshold)
                {
                    support += 1;
                }
            }
        }
        support
    }
}

/// Marks the unknown cells of `map` that lie in a 4-connected unknown region with no free
/// 4-neighbour and no cell on the map's edge.
fn enclosed_unknown(map: &OccupancyGrid) -> Vec<bool> {
    let g = map.geometry();
    let (w, h) = (g.width(), g.height());
    let cells = map.cells();
    let mut interior = vec![false; cells.len()];
    let mut seen = vec![false; cells.len()];
    let mut component = Vec::new();
    let mut stack = Vec::new();
    for start in 0..cells.len() {
        if seen[start] || cells[start] != CellState::Unknown {
            continue;
        }
        component.clear();
        stack.push(start);
        seen[start] = true;
        let mut enclosed = true;
        while let Some(i) = stack.pop() {
            component.push(i);
            let (x, y) = (i % w, i / w);
            if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
                enclosed = false;
            }
            let neighbours = [
                (x > 0).then(|| i - 1),
                (x + 1 < w).then(|| i + 1),
                (y > 0).then(|| i - w),
                (y + 1 < h).then(|| i + w),
            ];
            for j in neighbours.into_iter().flatten() {
                match cells[j] {
                    CellState::Free => enclosed = false,
                    CellState::Unknown if !seen[j] => {
                        seen[j] = true;
                        stack.push(j);
                    }
                    _ => {}
                }
            }
        }
        if enclosed {
            for &i in &component {
                interior[i] = true;
            }
        }
    }
    interior
}

#[cfg(test)]
mod tests {
    use super::*;
    use mapkeeper_grid::{GridGeometry, Pose2};

    /// Regression (spurious wedges behind rack posts in the validation): border reconstruction
    /// may only grow into unknown regions enclosed by an obstacle, not into unobserved space.
    #[test]
    fn only_enclosed_unknown_regions_are_interiors() {
        // 8 × 5 map: a box outline with an unknown interior at x 1..=3, and an unknown shadow
        // at x 5..=6 that touches free space.
        let g = GridGeometry::new(8, 5, 0.1, Pose2::IDENTITY).unwrap();
        let mut m = OccupancyGrid::filled(g, CellState::Free);
        for x in 1..=3 {
            for y in 1..=3 {
                let edge = x == 1 || x == 3 || y == 1 || y == 3;
                m.set(CellCoord::new(x, y), if edge { CellState::Occupied } else { CellState::Unknown });
            }
        }
        for x in 5..=6 {
            m.set(CellCoord::new(x, 2), CellState::Unknown);
        }
        let u = CellUpdater::new(&m);
        assert!(u.is_interior(g.index(CellCoord::new(2, 2)).unwrap()));
        assert!(!u.is_interior(g.index(CellCoord::new(5, 2)).unwrap()));
        assert!(!u.is_interior(g.index(CellCoord::new(6, 2)).unwrap()));
        // Unknown on the map's edge is never an interior.
        let mut edge = OccupancyGrid::filled(g, CellState::Occupied);
        edge.set(CellCoord::new(0, 2), CellState::Unknown);
        assert!(!CellUpdater::new(&edge).is_interior(g.index(CellCoord::new(0, 2)).unwrap()));
    }
}
