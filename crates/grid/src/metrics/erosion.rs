//! Metrics that see erosion: **structure retention** and **per-change-class scores**.
//!
//! CC, MS and OPDF average over the whole map, so a map that loses a wall face a few cells at a
//! time barely moves them (OPDF forgives a missing cell whose neighbour is still there). These
//! two count cells instead. Definitions and the choices behind them are in `docs/metrics.md`
//! ("Structure retention and change classes"); in short, with M_1 the initial map and G the
//! ground truth:
//!
//! - **structure** S_i ([`StructureMask`]): the cells occupied in M_1 and in every ground truth
//!   G_1 … G_i so far — the fixed structure M_1 got right;
//! - **retention** of a map M ([`retention`]) = |{c ∈ S_i : M(c) occupied}| / |S_i|;
//! - **change classes** ([`ChangeCells`]): the counted cells (e.g. those a route observes)
//!   where M_1 and G_i disagree, one free and the other occupied, by what explains them
//!   ([`ChangeClass::of`], given the footprints of the items the world's edits added, removed
//!   and moved, [`EditFootprints`]): *added* (free in M_1, occupied in G_i, on an added item),
//!   *removed* (occupied in M_1, free in G_i, where a removed item stood), *moved* (either, on
//!   a moved item's old or new footprint) and *initial errors* (no edit explains them: M_1's
//!   own disagreements with the truth). Without footprints, added and removed go by the
//!   states alone. A map gets a cell right when it has G_i's state there.
//!
//! Shares are [`CellShare`]s (`right` of `cells`); an empty set has no percentage.
//!
//! ```
//! use mapkeeper_grid::metrics::erosion::{ChangeCells, EditFootprints, StructureMask};
//! use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Pose2};
//! let g = GridGeometry::new(4, 1, 1.0, Pose2::IDENTITY).unwrap();
//! let mut m1 = OccupancyGrid::filled(g, CellState::Free);
//! m1.set(CellCoord::new(0, 0), CellState::Occupied); // a wall
//! m1.set(CellCoord::new(1, 0), CellState::Occupied); // a box, later taken away
//! let mut truth = m1.clone();
//! truth.set(CellCoord::new(1, 0), CellState::Free);
//! truth.set(CellCoord::new(3, 0), CellState::Occupied); // a new box
//! let structure = StructureMask::new(&m1, &truth).unwrap();
//! assert_eq!(structure.count(), 1);
//! // A map that lost the wall and saw the new box, but kept the old one.
//! let mut m = m1.clone();
//! m.set(CellCoord::new(0, 0), CellState::Free);
//! m.set(CellCoord::new(3, 0), CellState::Occupied);
//! assert_eq!(structure.retention(&m).unwrap().percent(), Some(0.0));
//! let change = ChangeCells::new(&m1, &truth, &[true; 4], None).unwrap();
//! let s = change.score(&m).unwrap();
//! assert_eq!((s.added.right, s.added.cells), (1, 1));
//! assert_eq!((s.removed.right, s.removed.cells), (0, 1));
//! assert_eq!(s.moved.percent(), None);
//! // Told where the edits added and removed items, the same cells; had no edit removed the
//! // box of cell 1, that cell would be an initial error of M_1.
//! let edits = EditFootprints {
//!     added: vec![false, false, false, true],
//!     removed: vec![false, true, false, false],
//!     moved: vec![false; 4],
//! };
//! let s = ChangeCells::new(&m1, &truth, &[true; 4], Some(&edits)).unwrap().score(&m).unwrap();
//! assert_eq!((s.added.cells, s.removed.cells, s.initial_errors.cells), (1, 1, 0));
//! ```

use super::MetricsError;
use crate::GridError;
use crate::grid::{CellState, GridGeometry, OccupancyGrid};
use serde::{Deserialize, Serialize};

/// `right` of `cells`: how many cells of a set a map has in the wanted state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CellShare {
    /// Cells of the set the map has right.
    pub right: u64,
    /// Cells in the set.
    pub cells: u64,
}

impl CellShare {
    /// 100 · right / cells, percent; `None` for an empty set (nothing to get right or wrong:
    /// the caller decides what that means).
    pub fn percent(self) -> Option<f64> {
        (self.cells > 0).then(|| 100.0 * self.right as f64 / self.cells as f64)
    }
}

/// A mask must have one entry per cell of `map`.
fn check_mask(map: &OccupancyGrid, mask: &[bool]) -> Result<(), MetricsError> {
    if mask.len() == map.cells().len() { Ok(()) } else { Err(GridError::GeometryMismatch.into()) }
}

/// Two maps must share a geometry.
fn check_same(a: &OccupancyGrid, b: &OccupancyGrid) -> Result<(), MetricsError> {
    if a.geometry().same_as(b.geometry()) { Ok(()) } else { Err(GridError::GeometryMismatch.into()) }
}

/// Retention of `map` over the cells where `structure` is true: those it has occupied, of all
/// of them. `structure` has one entry per cell, row-major.
///
/// Errors: [`GridError::GeometryMismatch`] (wrapped) if `structure` does not have one entry per
/// cell of `map`.
///
/// ```
/// use mapkeeper_grid::metrics::erosion::retention;
/// use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Pose2};
/// let g = GridGeometry::new(3, 1, 1.0, Pose2::IDENTITY).unwrap();
/// let mut m = OccupancyGrid::filled(g, CellState::Occupied);
/// m.set(CellCoord::new(1, 0), CellState::Unknown);
/// let s = retention(&m, &[true, true, false]).unwrap();
/// assert_eq!((s.right, s.cells, s.percent()), (1, 2, Some(50.0)));
/// ```
pub fn retention(map: &OccupancyGrid, structure: &[bool]) -> Result<CellShare, MetricsError> {
    check_mask(map, structure)?;
    let mut share = CellShare::default();
    for (&c, &s) in map.cells().iter().zip(structure) {
        if s {
            share.cells += 1;
            share.right += u64::from(c == CellState::Occupied);
        }
    }
    Ok(share)
}

/// The running structure mask S_i: cells occupied in the initial map M_1 and in every ground
/// truth given so far (a running AND).
#[derive(Clone, Debug, PartialEq)]
pub struct StructureMask {
    geometry: GridGeometry,
    cells: Vec<bool>,
}

impl StructureMask {
    /// S_1: the cells occupied in both `initial` (M_1) and `truth` (G_1).
    ///
    /// Errors: [`GridError::GeometryMismatch`] (wrapped) if the maps' geometries differ.
    pub fn new(initial: &OccupancyGrid, truth: &OccupancyGrid) -> Result<Self, MetricsError> {
        check_same(initial, truth)?;
        let occupied = |c: &CellState| *c == CellState::Occupied;
        let cells = initial.cells().iter().zip(truth.cells()).map(|(a, b)| occupied(a) && occupied(b)).collect();
        Ok(StructureMask { geometry: *initial.geometry(), cells })
    }

    /// S_i = S_{i-1} ∩ {cells occupied in `truth`} (G_i): structure the world has lost leaves
    /// the mask for good.
    ///
    /// Errors: [`GridError::GeometryMismatch`] (wrapped) if `truth` has another geometry.
    pub fn keep_occupied_in(&mut self, truth: &OccupancyGrid) -> Result<(), MetricsError> {
        if !self.geometry.same_as(truth.geometry()) {
            return Err(GridError::GeometryMismatch.into());
        }
        for (s, &c) in self.cells.iter_mut().zip(truth.cells()) {
            *s = *s && c == CellState::Occupied;
        }
        Ok(())
    }

    /// The mask, one entry per cell, row-major.
    pub fn cells(&self) -> &[bool] {
        &self.cells
    }

    /// |S_i|.
    pub fn count(&self) -> u64 {
        self.cells.iter().map(|&s| u64::from(s)).sum()
    }

    /// [`retention`] of `map` over this mask.
    ///
    /// Errors: [`GridError::GeometryMismatch`] (wrapped) if `map` has another geometry.
    pub fn retention(&self, map: &OccupancyGrid) -> Result<CellShare, MetricsError> {
        if !self.geometry.same_as(map.geometry()) {
            return Err(GridError::GeometryMismatch.into());
        }
        retention(map, &self.cells)
    }
}

/// The class of a cell whose state differs between the initial map and the truth.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ChangeClass {
    /// Free in the initial map, occupied in the truth: an item put down.
    Added,
    /// Occupied in the initial map, free in the truth: an item taken away.
    Removed,
    /// Either, on an item that moved (or turned).
    Moved,
    /// Either, where no edit explains it: the initial map's own disagreement with the truth.
    InitialError,
}

/// Which edits' footprints cover a cell ([`EditFootprints::at`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EditsAt {
    /// An item added since the initial map covers it (where it is now).
    pub added: bool,
    /// An item removed since covered it (where it was).
    pub removed: bool,
    /// An item moved or turned since covers it (where it was or where it is now).
    pub moved: bool,
}

impl ChangeClass {
    /// The class of a cell in state `initial` in M_1 and `truth` in G_i, given the edits whose
    /// footprints cover it; `None` when it is in no class (the states agree, or either is
    /// unknown: the truth has no claim there, or M_1 made none). Without `edits` (no item
    /// information) a cell is added or removed by its states alone, as if every change were an
    /// edit's. With them: moved if a moved item covers it; added if free → occupied on an
    /// added item; removed if occupied → free where a removed item stood; else an initial
    /// error.
    ///
    /// ```
    /// use mapkeeper_grid::CellState::{Free, Occupied, Unknown};
    /// use mapkeeper_grid::metrics::erosion::{ChangeClass, EditsAt};
    /// assert_eq!(ChangeClass::of(Free, Occupied, None), Some(ChangeClass::Added));
    /// let moved = EditsAt { moved: true, ..EditsAt::default() };
    /// assert_eq!(ChangeClass::of(Occupied, Free, Some(moved)), Some(ChangeClass::Moved));
    /// let nothing = EditsAt::default();
    /// assert_eq!(ChangeClass::of(Occupied, Free, Some(nothing)), Some(ChangeClass::InitialError));
    /// assert_eq!(ChangeClass::of(Unknown, Occupied, None), None);
    /// ```
    pub fn of(initial: CellState, truth: CellState, edits: Option<EditsAt>) -> Option<ChangeClass> {
        let put_down = match (initial, truth) {
            (CellState::Free, CellState::Occupied) => true,
            (CellState::Occupied, CellState::Free) => false,
            _ => return None,
        };
        Some(match edits {
            None if put_down => ChangeClass::Added,
            None => ChangeClass::Removed,
            Some(e) if e.moved => ChangeClass::Moved,
            Some(e) if put_down && e.added => ChangeClass::Added,
            Some(e) if !put_down && e.removed => ChangeClass::Removed,
            Some(_) => ChangeClass::InitialError,
        })
    }

    fn slot(self) -> usize {
        match self {
            ChangeClass::Added => 0,
            ChangeClass::Removed => 1,
            ChangeClass::Moved => 2,
            ChangeClass::InitialError => 3,
        }
    }
}

/// The footprints of the world's edits since the initial map, one entry per cell each,
/// row-major (e.g. the items' rasterised outlines and insides, grown by a cell with
/// [`grow_by_one_cell`] to take in the initial map's one-cell scatter).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct EditFootprints {
    /// Items added since: where they are now.
    pub added: Vec<bool>,
    /// Items removed since: where they were.
    pub removed: Vec<bool>,
    /// Items moved or turned since: where they were and where they are now.
    pub moved: Vec<bool>,
}

impl EditFootprints {
    /// The edits covering cell `i` (none beyond the masks' ends).
    pub fn at(&self, i: usize) -> EditsAt {
        let get = |m: &[bool]| m.get(i).copied().unwrap_or(false);
        EditsAt { added: get(&self.added), removed: get(&self.removed), moved: get(&self.moved) }
    }

    fn fits(&self, cells: usize) -> bool {
        [&self.added, &self.removed, &self.moved].iter().all(|m| m.len() == cells)
    }
}

/// The share a map got right of each change class.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ClassShares {
    /// Added cells the map has occupied.
    pub added: CellShare,
    /// Removed cells the map has free.
    pub removed: CellShare,
    /// Moved cells the map has in the truth's state.
    pub moved: CellShare,
    /// Initial errors the map has in the truth's state (fixed).
    pub initial_errors: CellShare,
}

/// The changed cells of one world, by class: computed once from M_1 and G_i, then used to
/// score any number of maps ([`ChangeCells::score`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ChangeCells {
    geometry: GridGeometry,
    /// Per class (in [`ChangeClass`] order), each cell's index and its state in the truth.
    classes: [Vec<(usize, CellState)>; 4],
}

impl ChangeCells {
    /// The changed cells of `initial` (M_1) against `truth` (G_i) among the cells where
    /// `counted` is true, classed by [`ChangeClass::of`] with the footprints of the edits
    /// (`None`: no item information). Masks have one entry per cell, row-major.
    ///
    /// Errors: [`GridError::GeometryMismatch`] (wrapped) if the maps' geometries differ or a
    /// mask does not have one entry per cell.
    pub fn new(
        initial: &OccupancyGrid,
        truth: &OccupancyGrid,
        counted: &[bool],
        edits: Option<&EditFootprints>,
    ) -> Result<Self, MetricsError> {
        check_same(initial, truth)?;
        check_mask(initial, counted)?;
        if edits.is_some_and(|e| !e.fits(counted.len())) {
            return Err(GridError::GeometryMismatch.into());
        }
        let mut classes: [Vec<(usize, CellState)>; 4] = Default::default();
        let pairs = initial.cells().iter().zip(truth.cells()).zip(counted).enumerate();
        for (i, ((&a, &t), &count)) in pairs {
            if !count {
                continue;
            }
            if let Some(class) = ChangeClass::of(a, t, edits.map(|e| e.at(i))) {
                classes[class.slot()].push((i, t));
            }
        }
        Ok(ChangeCells { geometry: *initial.geometry(), classes })
    }

    /// Cells of `class`.
    pub fn cells(&self, class: ChangeClass) -> u64 {
        self.classes[class.slot()].len() as u64
    }

    /// How many cells of each class `map` has in the truth's state.
    ///
    /// Errors: [`GridError::GeometryMismatch`] (wrapped) if `map` has another geometry.
    pub fn score(&self, map: &OccupancyGrid) -> Result<ClassShares, MetricsError> {
        if !self.geometry.same_as(map.geometry()) {
            return Err(GridError::GeometryMismatch.into());
        }
        let cells = map.cells();
        let share = |class: ChangeClass| {
            let list = &self.classes[class.slot()];
            let right = list.iter().filter(|&&(i, want)| cells[i] == want).count();
            CellShare { right: right as u64, cells: list.len() as u64 }
        };
        Ok(ClassShares {
            added: share(ChangeClass::Added),
            removed: share(ChangeClass::Removed),
            moved: share(ChangeClass::Moved),
            initial_errors: share(ChangeClass::InitialError),
        })
    }
}

/// `mask` grown by one cell in the 8-neighbourhood (a cell is set if it or any neighbour is):
/// e.g. an item's rasterised footprint widened to take in a map's one-cell scatter around it.
///
/// Errors: [`GridError::GeometryMismatch`] (wrapped) if `mask` does not have one entry per cell
/// of `geometry`.
///
/// ```
/// use mapkeeper_grid::metrics::erosion::grow_by_one_cell;
/// use mapkeeper_grid::{GridGeometry, Pose2};
/// let g = GridGeometry::new(4, 3, 1.0, Pose2::IDENTITY).unwrap();
/// let mut m = vec![false; 12];
/// m[4] = true; // (0, 1)
/// let grown = grow_by_one_cell(&m, &g).unwrap();
/// assert_eq!(grown.iter().filter(|&&b| b).count(), 6); // columns 0-1, rows 0-2
/// ```
pub fn grow_by_one_cell(mask: &[bool], geometry: &GridGeometry) -> Result<Vec<bool>, MetricsError> {
    let (w, h) = (geometry.width(), geometry.height());
    if mask.len() != w * h {
        return Err(GridError::GeometryMismatch.into());
    }
    let mut out = vec![false; mask.len()];
    for (i, _) in mask.iter().enumerate().filter(|&(_, &m)| m) {
        let (x, y) = (i % w, i / w);
        for ny in y.saturating_sub(1)..=(y + 1).min(h - 1) {
            for nx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                out[ny * w + nx] = true;
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pose::Pose2;

    const F: CellState = CellState::Free;
    const O: CellState = CellState::Occupied;
    const U: CellState = CellState::Unknown;

    use super::super::tests::grid;

    /// A mask from rows written top row first, `1` set.
    fn mask(rows_top_first: &[&[u8]]) -> Vec<bool> {
        rows_top_first.iter().rev().flat_map(|r| r.iter().map(|&b| b == 1)).collect()
    }

    #[test]
    fn share_percent_and_empty_set() {
        assert_eq!(CellShare { right: 3, cells: 4 }.percent(), Some(75.0));
        assert_eq!(CellShare { right: 0, cells: 0 }.percent(), None);
        assert_eq!(CellShare { right: 0, cells: 5 }.percent(), Some(0.0));
    }

    #[test]
    fn structure_is_a_running_and_of_the_truths() {
        // M_1 has 4 occupied cells; G_1 agrees on 3 of them (the fourth, bottom right, is free
        // in the truth: a mapping error of M_1, never structure).
        let m1 = grid(&[&[O, O, F], &[F, F, F], &[O, F, O]]);
        let g1 = grid(&[&[O, O, F], &[F, F, F], &[O, F, F]]);
        let mut s = StructureMask::new(&m1, &g1).expect("same geometry");
        assert_eq!(s.count(), 3);
        // G_2 loses the top-left cell: it leaves S for good, even if G_3 has it again.
        let g2 = grid(&[&[F, O, F], &[F, F, F], &[O, F, F]]);
        s.keep_occupied_in(&g2).expect("same geometry");
        assert_eq!(s.count(), 2);
        s.keep_occupied_in(&g1).expect("same geometry");
        assert_eq!(s.cells(), mask(&[&[0, 1, 0], &[0, 0, 0], &[1, 0, 0]]).as_slice());
        // A map that lost one of the two, the other unknown: 0 %; one kept: 50 %.
        let m = grid(&[&[O, U, O], &[O, O, O], &[F, O, O]]);
        assert_eq!(s.retention(&m).expect("same geometry"), CellShare { right: 0, cells: 2 });
        let m = grid(&[&[F, O, F], &[F, F, F], &[F, F, F]]);
        assert_eq!(s.retention(&m).expect("same geometry").percent(), Some(50.0));
        // M_1 keeps all of its own structure by definition.
        assert_eq!(s.retention(&m1).expect("same geometry").percent(), Some(100.0));
    }

    #[test]
    fn classes_count_only_the_counted_cells() {
        let m1 = grid(&[&[O, O, F, F], &[F, U, O, F]]);
        let truth = grid(&[&[F, O, O, O], &[O, O, F, U]]);
        // Changed: (0,1) removed, (2,1) added, (3,1) added, (0,0) added, (2,0) removed;
        // (1,0) is unknown in M_1 and (3,0) unknown in the truth: no class.
        let all = vec![true; 8];
        let c = ChangeCells::new(&m1, &truth, &all, None).expect("same geometry");
        assert_eq!(
            (c.cells(ChangeClass::Added), c.cells(ChangeClass::Removed), c.cells(ChangeClass::Moved)),
            (3, 2, 0)
        );
        assert_eq!(c.cells(ChangeClass::InitialError), 0, "without footprints every change is an edit's");
        // The route sees only the top row.
        let top = mask(&[&[1, 1, 1, 1], &[0, 0, 0, 0]]);
        let c = ChangeCells::new(&m1, &truth, &top, None).expect("same geometry");
        assert_eq!((c.cells(ChangeClass::Added), c.cells(ChangeClass::Removed)), (2, 1));
        // Unknown is never right: the map must say occupied (added) or free (removed).
        let unsure = grid(&[&[U, U, U, U], &[U, U, U, U]]);
        let s = c.score(&unsure).expect("same geometry");
        assert_eq!((s.added.right, s.removed.right), (0, 0));
    }

    #[test]
    fn footprints_class_the_changes_by_edit_and_leave_the_rest_to_m1() {
        let m1 = grid(&[&[O, O, F, F], &[F, U, O, F]]);
        let truth = grid(&[&[F, O, O, O], &[O, O, F, U]]);
        // An item moved from (0,1) to (3,1); one was put down on (2,1) and (3,1) (the move
        // wins there); one was taken away from (2,0) and (0,0). (0,0) turned occupied on the
        // removed item's spot: no edit explains it, an initial error.
        let edits = EditFootprints {
            added: mask(&[&[0, 0, 1, 1], &[0, 0, 0, 0]]),
            removed: mask(&[&[0, 0, 0, 0], &[1, 0, 1, 0]]),
            moved: mask(&[&[1, 0, 0, 1], &[0, 0, 0, 0]]),
        };
        let c = ChangeCells::new(&m1, &truth, &[true; 8], Some(&edits)).expect("same geometry");
        let counts = |c: &ChangeCells| {
            [ChangeClass::Added, ChangeClass::Removed, ChangeClass::Moved, ChangeClass::InitialError]
                .map(|k| c.cells(k))
        };
        assert_eq!(counts(&c), [1, 1, 2, 1]);
        // The truth itself gets every class right; M_1 none.
        let s = c.score(&truth).expect("same geometry");
        let one = CellShare { right: 1, cells: 1 };
        assert_eq!(
            s,
            ClassShares { added: one, removed: one, moved: CellShare { right: 2, cells: 2 }, initial_errors: one }
        );
        let s = c.score(&m1).expect("same geometry");
        assert_eq!((s.added.right, s.removed.right, s.moved.right, s.initial_errors.right), (0, 0, 0, 0));
        // A map that fixed the initial error and saw the move's new place only.
        let m = grid(&[&[O, O, F, O], &[O, U, O, F]]);
        let s = c.score(&m).expect("same geometry");
        assert_eq!((s.added.right, s.removed.right, s.moved.right, s.initial_errors.right), (0, 0, 1, 1));
        assert_eq!(s.moved.percent(), Some(50.0));
        // Footprints of another size are refused.
        let short = EditFootprints { added: vec![false; 7], ..edits };
        assert!(ChangeCells::new(&m1, &truth, &[true; 8], Some(&short)).is_err());
        assert_eq!(short.at(7), EditsAt { added: false, removed: false, moved: true }, "nothing beyond the end");
    }

    #[test]
    fn mismatched_geometries_and_masks_are_errors_not_panics() {
        let a = grid(&[&[O, F]]);
        let b = grid(&[&[O, F, F]]);
        assert!(StructureMask::new(&a, &b).is_err());
        assert!(retention(&a, &[true]).is_err());
        assert!(ChangeCells::new(&a, &a, &[true], None).is_err());
        let one = EditFootprints { added: vec![true], removed: vec![true], moved: vec![true] };
        assert!(ChangeCells::new(&a, &a, &[true, true], Some(&one)).is_err());
        let s = StructureMask::new(&a, &a).expect("same geometry");
        assert!(s.retention(&b).is_err());
        let mut s2 = s.clone();
        assert!(s2.keep_occupied_in(&b).is_err());
        let c = ChangeCells::new(&a, &a, &[true, true], None).expect("same geometry");
        assert!(c.score(&b).is_err());
        assert!(grow_by_one_cell(&[true], a.geometry()).is_err());
    }

    #[test]
    fn growing_a_mask_by_one_cell_stops_at_the_border() {
        let g = GridGeometry::new(5, 4, 1.0, Pose2::IDENTITY).expect("geometry");
        let m = mask(&[&[0, 0, 0, 0, 1], &[0, 0, 0, 0, 0], &[0, 0, 1, 0, 0], &[0, 0, 0, 0, 0]]);
        let want = mask(&[&[0, 0, 0, 1, 1], &[0, 1, 1, 1, 1], &[0, 1, 1, 1, 0], &[0, 1, 1, 1, 0]]);
        assert_eq!(grow_by_one_cell(&m, &g).expect("one entry per cell"), want);
        assert_eq!(grow_by_one_cell(&[false; 20], &g).expect("one entry per cell"), vec![false; 20]);
    }
}
