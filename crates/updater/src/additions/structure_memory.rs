//! Memory that can heal (a `mapkeeper` addition, issue 27 item 2): what a cell has been across
//! worlds, not only within a run.
//!
//! The paper's rolling buffers remember the last N_b flags of a run; `M_i` is the only thing
//! handed to the next world. Two failures follow under a real localiser's pose error:
//! - **Long-standing structure is as easy to remove as a box put down yesterday.** A wall that
//!   has been in every map since the survey needs the same `change_threshold` flags to go as a
//!   cell added in the last run. Rule: an *established* occupied cell (occupied in `M_1`, or
//!   occupied for `established_after_worlds` worlds since it was added) needs
//!   `established_removal_threshold` "changed" flags to become free.
//! - **Erosion is a ratchet.** A wall face cell freed by a pose error becomes free in the next
//!   prior; a beam that ends on it again agrees with the map within D_th (the wall behind is one
//!   cell further), so it is "unchanged" and nothing ever adds the cell back (an added cell needs
//!   every cell within tol(z) free, and the wall behind is not). Rule: a removed established cell
//!   leaves a *scar* for `scar_worlds` worlds; a beam without detected change whose hit point
//!   falls in a scarred cell votes it "changed" (occupied again), and the buffers decide as for
//!   any change.
//!
//! Memory is bounded per touched cell, as the buffers are: one record (cell index and one byte)
//! for each cell added within the last `established_after_worlds` worlds (*young*) and each
//! scar; nothing for the cells that never changed. Records are kept sorted by cell index, so the
//! memory is deterministic and serialisable.

use mapkeeper_common::ParamError;
use mapkeeper_grid::{CellState, OccupancyGrid};
use serde::{Deserialize, Serialize};

/// Parameters of the cross-world memory (`UpdaterParams::memory`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MemoryParams {
    /// Use the memory (the rules of the module docs). Default `false` (`mapkeeper` `true`).
    pub enabled: bool,
    /// An added cell is established once it has been occupied in this many successive maps.
    /// Default 3.
    pub established_after_worlds: u32,
    /// "Changed" flags an established occupied cell needs to become free (between
    /// `change_threshold` and `buffer_size`). Default 9.
    pub established_removal_threshold: u32,
    /// A removed established cell is remembered (and may heal) for this many worlds.
    /// Default 30.
    pub scar_worlds: u32,
}

impl Default for MemoryParams {
    fn default() -> Self {
        Self { enabled: false, established_after_worlds: 3, established_removal_threshold: 9, scar_worlds: 30 }
    }
}

impl MemoryParams {
    /// Checks the fields (against the buffer's size and threshold when enabled); the first bad
    /// one is named with its dotted name (`memory.…`).
    pub fn validate(&self, buffer_size: u32, change_threshold: u32) -> Result<(), ParamError> {
        if !(1..=255).contains(&self.established_after_worlds) {
            let worlds = self.established_after_worlds;
            return Err(ParamError::new("memory.established_after_worlds", worlds, "must lie in 1..=255"));
        }
        if !(1..=255).contains(&self.scar_worlds) {
            return Err(ParamError::new("memory.scar_worlds", self.scar_worlds, "must lie in 1..=255"));
        }
        if !(1..=32).contains(&self.established_removal_threshold)
            || (self.enabled && !(change_threshold..=buffer_size).contains(&self.established_removal_threshold))
        {
            return Err(ParamError::new(
                "memory.established_removal_threshold",
                self.established_removal_threshold,
                format!(
                    "must lie in 1..=32 and, with the memory enabled, in change_threshold..=buffer_size \
                     ({change_threshold}..={buffer_size})"
                ),
            ));
        }
        Ok(())
    }
}

/// The weighted flags of one cell: ended in it (`hit`) and crossed it (`pass`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CellEvidence {
    /// Weighted "ended here" flags.
    pub hit: f32,
    /// Weighted "crossed" flags.
    pub pass: f32,
}

impl CellEvidence {
    /// Total weight.
    pub fn weight(&self) -> f32 {
        self.hit + self.pass
    }

    /// Hit share (0 with no weight).
    pub fn share(&self) -> f32 {
        let w = self.weight();
        if w > 0.0 { self.hit / w } else { 0.0 }
    }
}

/// What the memory holds for one cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CellRecord {
    /// Occupied, added `worlds` maps ago (not yet established).
    Young {
        /// Successive maps it has been occupied in.
        worlds: u8,
    },
    /// An established cell removed; it may heal for `worlds_left` more worlds.
    Scar {
        /// Worlds left.
        worlds_left: u8,
    },
}

/// The cross-world memory of one map: records of young and scarred cells, sorted by index.
/// The default (empty) memory says every occupied cell is established (a surveyed `M_1`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StructureMemory {
    records: Vec<(u32, CellRecord)>,
    /// The surface evidence of the cells in question (`additions/surface_evidence.rs`), sorted
    /// by cell index; empty (and not written) when that addition is off.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    evidence: Vec<(u32, CellEvidence)>,
}

impl StructureMemory {
    /// The record of the cell at linear index `index`.
    #[inline]
    pub fn get(&self, index: u32) -> Option<CellRecord> {
        self.records.binary_search_by_key(&index, |r| r.0).ok().map(|k| self.records[k].1)
    }

    /// Whether the cell at `index`, occupied in the prior, is established (no young record).
    #[inline]
    pub fn is_established(&self, index: u32) -> bool {
        !matches!(self.get(index), Some(CellRecord::Young { .. }))
    }

    /// Whether the cell at `index` carries a scar.
    #[inline]
    pub fn is_scar(&self, index: u32) -> bool {
        matches!(self.get(index), Some(CellRecord::Scar { .. }))
    }

    /// Number of records.
    pub fn len(&self) -> usize {
        self.records.len()
    }

    /// Whether there is no record.
    pub fn is_empty(&self) -> bool {
        self.records.is_empty() && self.evidence.is_empty()
    }

    /// The records, sorted by cell index.
    pub fn records(&self) -> &[(u32, CellRecord)] {
        &self.records
    }

    /// Heap bytes of the records.
    pub fn state_bytes(&self) -> usize {
        self.records.capacity() * size_of::<(u32, CellRecord)>()
            + self.evidence.capacity() * size_of::<(u32, CellEvidence)>()
    }

    /// The surface evidence carried with the map, sorted by cell index.
    pub fn evidence(&self) -> &[(u32, CellEvidence)] {
        &self.evidence
    }

    /// The same memory with `evidence` (sorted by cell index) as its surface evidence.
    pub fn with_evidence(mut self, evidence: Vec<(u32, CellEvidence)>) -> Self {
        self.evidence = evidence;
        self
    }

    /// The same memory without its young and scar records (the structure rules off).
    pub fn without_records(mut self) -> Self {
        self.records = Vec::new();
        self
    }

    /// The largest cell index recorded, if any (to check the memory fits a map).
    pub fn max_index(&self) -> Option<u32> {
        self.records.last().map(|r| r.0).max(self.evidence.last().map(|r| r.0))
    }

    /// The memory handed to the next world: `prior` = `M_{i-1}` (the map this memory belongs
    /// to), `updated` = `M_i`. Young cells that stayed occupied age (and become established,
    /// dropping their record); young cells removed are forgotten; an established cell removed
    /// gets a scar; a scar that is occupied again is established again; scars age out; a cell
    /// that became occupied is young.
    pub fn next(&self, prior: &OccupancyGrid, updated: &OccupancyGrid, p: &MemoryParams) -> StructureMemory {
        let mut out = Vec::with_capacity(self.records.len());
        let mut old = self.records.iter().peekable();
        for (i, (&b, &u)) in prior.cells().iter().zip(updated.cells()).enumerate() {
            let i = i as u32;
            let rec = match old.peek() {
                Some(&&(k, r)) if k == i => {
                    old.next();
                    Some(r)
                }
                _ => None,
            };
            let occupied = u == CellState::Occupied;
            let next = match rec {
                Some(CellRecord::Young { worlds }) if occupied => {
                    let w = u32::from(worlds) + 1;
                    (w < p.established_after_worlds).then(|| CellRecord::Young { worlds: w.min(255) as u8 })
                }
                Some(CellRecord::Young { .. }) => None,
                Some(CellRecord::Scar { .. }) if occupied => None,
                Some(CellRecord::Scar { worlds_left }) => {
                    (worlds_left > 1).then(|| CellRecord::Scar { worlds_left: worlds_left - 1 })
                }
                None if b == CellState::Occupied && u == CellState::Free => {
                    Some(CellRecord::Scar { worlds_left: p.scar_worlds.min(255) as u8 })
                }
                None if b != CellState::Occupied && occupied => {
                    (p.established_after_worlds > 1).then_some(CellRecord::Young { worlds: 1 })
                }
                None => None,
            };
            if let Some(r) = next {
                out.push((i, r));
            }
        }
        out.shrink_to_fit();
        StructureMemory { records: out, evidence: Vec::new() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mapkeeper_grid::{CellCoord, GridGeometry, Pose2};

    fn grid(cells: &[CellState]) -> OccupancyGrid {
        let g = GridGeometry::new(cells.len(), 1, 0.05, Pose2::IDENTITY).unwrap();
        OccupancyGrid::from_cells(g, cells.to_vec()).unwrap()
    }

    #[test]
    fn young_cells_age_into_structure_and_removed_structure_scars() {
        use CellState::{Free as F, Occupied as O, Unknown as U};
        let p = MemoryParams { enabled: true, established_after_worlds: 3, scar_worlds: 2, ..MemoryParams::default() };
        // 0: wall kept; 1: wall removed; 2: added; 3: unknown → occupied; 4: free kept.
        let m1 = grid(&[O, O, F, U, F]);
        let m2 = grid(&[O, F, O, O, F]);
        let mem = StructureMemory::default().next(&m1, &m2, &p);
        assert_eq!(
            mem.records(),
            &[
                (1, CellRecord::Scar { worlds_left: 2 }),
                (2, CellRecord::Young { worlds: 1 }),
                (3, CellRecord::Young { worlds: 1 })
            ]
        );
        assert!(mem.is_established(0) && !mem.is_established(2) && mem.is_scar(1));
        // Next world: 2 stays (ages), 3 is removed again (forgotten, no scar), 1 stays free.
        let m3 = grid(&[O, F, O, F, F]);
        let mem = mem.next(&m2, &m3, &p);
        assert_eq!(mem.records(), &[(1, CellRecord::Scar { worlds_left: 1 }), (2, CellRecord::Young { worlds: 2 })]);
        // Third: 2 is established (record dropped), the scar of 1 ages out.
        let mem = mem.next(&m3, &m3, &p);
        assert!(mem.is_empty(), "{mem:?}");
    }

    #[test]
    fn a_healed_scar_is_structure_again() {
        use CellState::{Free as F, Occupied as O};
        let p = MemoryParams { enabled: true, ..MemoryParams::default() };
        let mem = StructureMemory::default().next(&grid(&[O, O]), &grid(&[O, F]), &p);
        assert!(mem.is_scar(1));
        let mem = mem.next(&grid(&[O, F]), &grid(&[O, O]), &p);
        assert!(mem.is_empty() && mem.is_established(1));
    }

    #[test]
    fn memory_grows_with_touched_cells_only() {
        let p = MemoryParams { enabled: true, ..MemoryParams::default() };
        let g = GridGeometry::new(400, 400, 0.05, Pose2::IDENTITY).unwrap();
        let m = OccupancyGrid::filled(g, CellState::Occupied);
        let mut n = m.clone();
        for x in 0..5 {
            n.set(CellCoord::new(x, 7), CellState::Free);
        }
        let mem = StructureMemory::default().next(&m, &n, &p);
        assert_eq!(mem.len(), 5);
        assert!(mem.state_bytes() <= 5 * size_of::<(u32, CellRecord)>());
    }

    #[test]
    fn validate_names_the_field() {
        let p = MemoryParams { enabled: true, established_removal_threshold: 11, ..MemoryParams::default() };
        assert_eq!(p.validate(10, 7).unwrap_err().name, "memory.established_removal_threshold");
        // Off, the relation to the buffer is not checked (a preset with N_b = 7 stays valid).
        assert!(MemoryParams { enabled: false, ..p }.validate(7, 7).is_ok());
        let p = MemoryParams { scar_worlds: 0, ..p };
        assert_eq!(p.validate(10, 7).unwrap_err(), ParamError::new("memory.scar_worlds", 0, "must lie in 1..=255"));
        assert!(MemoryParams::default().validate(10, 7).is_ok());
    }
}
