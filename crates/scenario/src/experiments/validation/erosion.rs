//! Metrics that see erosion in the validation: **structure retention** and **per-change-class
//! scores** of M_i, M*_i and F_i, per world ([`Retention`], [`ChangeClasses`], scored by
//! `ErosionJudge`) and over worlds and seeds ([`RetentionSummary`], [`ChangeClassSummary`], computed by
//! `summary.rs`).
//!
//! Both are taken against the **exact** G_i whatever `--ground-truth` says (the observed G_i is
//! unknown wherever the exploration route does not look, which would hide exactly the faces an
//! updater erodes). The pure cell counting is `mapkeeper_grid::metrics::erosion`; this module
//! adds what needs the simulator's worlds: which items the edits added, removed and moved
//! between W_1 and W_i (by id: the edits' net effect), and their footprints. Definitions and
//! choices: `docs/metrics.md`, "Structure retention and change classes".

use crate::experiments::ExperimentError;
use mapkeeper_grid::metrics::MetricsError;
use mapkeeper_grid::metrics::erosion::{
    CellShare, ChangeCells, ClassShares, EditFootprints, StructureMask, grow_by_one_cell,
};
use mapkeeper_grid::{CellState, GridGeometry, OccupancyGrid};
use mapkeeper_sim::{MovableItem, Shape, World, ground_truth_map};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The project's target for the structure retention of the last world's map M_N, percent (the
/// paper states none: an updater should not erode what never changed).
pub const RETENTION_TARGET_PCT: f64 = 99.0;

/// Structure retention of one world: the share of S_i (cells occupied in M_1 and in every exact
/// G_1 … G_i) each map has occupied, percent; 100 when S_i is empty (no structure to lose).
/// M_1 keeps all of S_i by definition, so it is not reported.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Retention {
    /// |S_i|, cells.
    pub structure_cells: u64,
    /// M_i.
    pub updated_map: f64,
    /// M*_i, the best achievable map (100 by construction: it starts from M_1 and only takes
    /// G_i's states, where S_i is occupied).
    pub best_map: f64,
    /// F_i, the fresh map (keeps only the structure its run sees).
    pub fresh_map: f64,
}

/// One change class of one world: its cells and the share each map got right, percent
/// (`None` when the class has no cell).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ClassScores {
    /// Cells in the class (among those the route observes in W_i).
    pub cells: u64,
    /// M_i.
    pub updated_map: Option<f64>,
    /// M*_i (100 whenever there are cells: it has G_i's state in every cell the route sees).
    pub best_map: Option<f64>,
    /// F_i.
    pub fresh_map: Option<f64>,
}

/// The cells the route observes in W_i where M_1 and the exact G_i disagree (one free, the
/// other occupied), by what explains them. "On an item" is within a cell of its footprint
/// (outline and inside).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ChangeClasses {
    /// Free in M_1, occupied in G_i, on an item of W_i that W_1 did not have: right if occupied.
    pub added: ClassScores,
    /// Occupied in M_1, free in G_i, where an item of W_1 that W_i does not have stood: right
    /// if free.
    pub removed: ClassScores,
    /// Either, on an item both worlds have with another outline (moved or turned), where it
    /// was or where it is: right if in G_i's state.
    pub moved: ClassScores,
    /// Either, where no edit explains it: M_1's own disagreement with the exact raster (its
    /// mapping errors, and wall faces a boundary crosses that beams see as free); right if in
    /// G_i's state (the map fixed it).
    pub initial_errors: ClassScores,
}

/// Scores retention and change classes world after world: keeps the running structure mask
/// S_i and W_1's movable items.
pub(crate) struct ErosionJudge {
    structure: StructureMask,
    /// W_1's movable items by id.
    items_w1: BTreeMap<String, MovableItem>,
    /// W_1 stripped of everything (no walls, interior, items or agents): the edited items'
    /// footprints are rasterised in it.
    blank: World,
}

impl ErosionJudge {
    /// S_1 from M_1 and the exact G_1 of `w1`.
    pub(crate) fn new(w1: &World, m1: &OccupancyGrid, g1: &OccupancyGrid) -> Result<Self, ExperimentError> {
        let mut blank = w1.clone();
        blank.interior = None;
        blank.walls.clear();
        blank.columns.clear();
        blank.racks.clear();
        blank.movable.clear();
        blank.agents.clear();
        blank.storage_areas.clear();
        blank.route = None;
        if !blank.obstacles().is_empty() {
            // A kind of obstacle this code does not know would be rasterised into every footprint.
            return Err(ExperimentError::Invalid("erosion: W_1 stripped of its obstacles still has some".into()));
        }
        Ok(ErosionJudge {
            structure: StructureMask::new(m1, g1)?,
            items_w1: w1.movable.iter().map(|m| (m.id.clone(), m.clone())).collect(),
            blank,
        })
    }

    /// The cells within one cell of `items`' footprints (outline and inside) on `geometry`.
    fn footprint(&mut self, items: Vec<MovableItem>, geometry: &GridGeometry) -> Result<Vec<bool>, MetricsError> {
        if items.is_empty() {
            return Ok(vec![false; geometry.len()]);
        }
        self.blank.movable = items;
        let raster = ground_truth_map(&self.blank, geometry);
        self.blank.movable.clear();
        let covered: Vec<bool> = raster.cells().iter().map(|&c| c != CellState::Free).collect();
        grow_by_one_cell(&covered, geometry)
    }

    /// The footprints of the edits that made `wi` from W_1, by item id: items only `wi` has
    /// (added, where they are), items only W_1 has (removed, where they were), and items both
    /// have with another outline (moved, both places).
    fn edit_footprints(&mut self, wi: &World, geometry: &GridGeometry) -> Result<EditFootprints, MetricsError> {
        let now: BTreeMap<&str, &MovableItem> = wi.movable.iter().map(|m| (m.id.as_str(), m)).collect();
        let added = wi.movable.iter().filter(|m| !self.items_w1.contains_key(&m.id)).cloned().collect();
        let removed = self.items_w1.values().filter(|m| !now.contains_key(m.id.as_str())).cloned().collect();
        let moved = self
            .items_w1
            .values()
            .filter_map(|old| {
                now.get(old.id.as_str()).filter(|m| !same_outline(&old.shape, &m.shape)).map(|m| [old, *m])
            })
            .flatten()
            .cloned()
            .collect();
        Ok(EditFootprints {
            added: self.footprint(added, geometry)?,
            removed: self.footprint(removed, geometry)?,
            moved: self.footprint(moved, geometry)?,
        })
    }

    /// Advances S_{i-1} to S_i with the exact G_i `gi` of `wi` and scores `maps` = [M_i, M*_i,
    /// F_i]: retention over S_i, and the change classes of M_1 against `gi` over the cells
    /// where `seen` (what the route observes in W_i) is true.
    pub(crate) fn world(
        &mut self,
        wi: &World,
        gi: &OccupancyGrid,
        seen: &[bool],
        m1: &OccupancyGrid,
        maps: [&OccupancyGrid; 3],
    ) -> Result<(Retention, ChangeClasses), MetricsError> {
        self.structure.keep_occupied_in(gi)?;
        let kept = |m: &OccupancyGrid| self.structure.retention(m).map(|s| s.percent().unwrap_or(100.0));
        let retention = Retention {
            structure_cells: self.structure.count(),
            updated_map: kept(maps[0])?,
            best_map: kept(maps[1])?,
            fresh_map: kept(maps[2])?,
        };
        let edits = self.edit_footprints(wi, gi.geometry())?;
        let change = ChangeCells::new(m1, gi, seen, Some(&edits))?;
        let [u, b, f] = [change.score(maps[0])?, change.score(maps[1])?, change.score(maps[2])?];
        let class = |pick: fn(&ClassShares) -> CellShare| ClassScores {
            cells: pick(&u).cells,
            updated_map: pick(&u).percent(),
            best_map: pick(&b).percent(),
            fresh_map: pick(&f).percent(),
        };
        let classes = ChangeClasses {
            added: class(|s| s.added),
            removed: class(|s| s.removed),
            moved: class(|s| s.moved),
            initial_errors: class(|s| s.initial_errors),
        };
        Ok((retention, classes))
    }
}

/// Whether two outlines are the same (a rectangle turned by 180°, a square by 90°: the same
/// vertices in another order, to a micrometre).
fn same_outline(a: &Shape, b: &Shape) -> bool {
    if a == b {
        return true;
    }
    match (a.vertices(), b.vertices()) {
        (Some(va), Some(vb)) => va.len() == vb.len() && va.iter().all(|p| vb.iter().any(|q| p.distance(*q) < 1e-6)),
        _ => false,
    }
}

/// Structure retention over worlds and seeds (percent).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RetentionSummary {
    /// World rows that have the figures (rows of records written before they were measured
    /// have none and are left out).
    pub rows: usize,
    /// Mean |S_i| over those rows, cells.
    pub structure_cells_mean: f64,
    /// M_2's retention, mean over seeds (the first updated map).
    pub updated_w2: f64,
    /// M_N's retention, mean over seeds (the last world: where erosion has accumulated).
    pub updated_last: f64,
    /// The lowest M_N retention of any seed.
    pub updated_last_min: f64,
    /// M_i's retention, mean over all rows.
    pub updated_mean: f64,
    /// M*_i's, mean over all rows (100).
    pub best_mean: f64,
    /// F_i's, mean over all rows.
    pub fresh_mean: f64,
    /// The target for `updated_last`, [`RETENTION_TARGET_PCT`].
    pub target_last: f64,
    /// Whether `updated_last` ≥ `target_last`.
    pub target_met: bool,
}

/// One change class over worlds and seeds: shares are means over the world rows in which the
/// class has cells (percent; `null` when it has none in any).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ClassSummary {
    /// World rows in which the class has cells.
    pub rows: usize,
    /// Mean cells of the class per world row (over every row with the figures).
    pub cells_mean: f64,
    /// M_i's share right.
    pub updated_mean: Option<f64>,
    /// M*_i's (100).
    pub best_mean: Option<f64>,
    /// F_i's.
    pub fresh_mean: Option<f64>,
    /// M_N's share right, mean over the seeds whose W_N has cells of the class.
    pub updated_last: Option<f64>,
}

/// The change classes over worlds and seeds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ChangeClassSummary {
    /// World rows that have the figures.
    pub rows: usize,
    /// Added cells.
    pub added: ClassSummary,
    /// Removed cells.
    pub removed: ClassSummary,
    /// Cells of moved items.
    pub moved: ClassSummary,
    /// Initial errors (M_1's disagreements no edit explains).
    pub initial_errors: ClassSummary,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiments::validation::ValidationRecord;
    use crate::experiments::validation::summary::{change_class_summary, retention_summary};

    const F: CellState = CellState::Free;
    const O: CellState = CellState::Occupied;
    const U: CellState = CellState::Unknown;

    /// A 6 × 6 grid at 1 m per cell from rows written top row (y = 5) first.
    fn grid(rows_top_first: [[CellState; 6]; 6]) -> OccupancyGrid {
        let g = GridGeometry::new(6, 6, 1.0, mapkeeper_grid::Pose2::IDENTITY).expect("geometry");
        let cells = rows_top_first.iter().rev().flat_map(|r| r.iter().copied()).collect();
        OccupancyGrid::from_cells(g, cells).expect("36 cells")
    }

    /// A world with the given movable boxes (id, centre), each 0.4 m a side: its outline lies
    /// inside the one cell holding its centre.
    fn world(boxes: &[(&str, [f64; 2])]) -> World {
        let mut text = String::from(
            "format = \"mapkeeper-world\"\nversion = 1\nname = \"six\"\nrobot_start = { x = 3.5, y = 3.5, yaw_deg = 0.0 }\n",
        );
        for (id, [x, y]) in boxes {
            text.push_str(&format!(
                "[[movable]]\nid = \"{id}\"\nkind = \"box\"\nshape = {{ type = \"rect\", center = [{x}, {y}], size = [0.4, 0.4] }}\n"
            ));
        }
        toml::from_str(&text).expect("a world")
    }

    /// Worked on paper (cells (x, y), y up; each item lies in one cell, its footprint grown by
    /// a cell is the 3 × 3 block around it). The top row is a wall. W_1 → W_2: the box moves
    /// from (0, 0) to (5, 0), "gone" is taken away from (5, 3), "new" is put down on (2, 2).
    /// M_1 never saw the wall's cell (5, 5) nor (3, 0), and has two ghost cells, (1, 4) and
    /// (0, 3).
    ///
    /// S_1 = occupied in M_1 and G_1 = wall (0..4, 5), box (0, 0), gone (5, 3): 7 cells;
    /// S_2 = S_1 ∩ occupied in G_2 = the five wall cells.
    ///
    /// The route sees every cell but (0, 3), (0, 4) and (0, 5). Changed there between M_1 and
    /// G_2: (0, 0) O → F and (5, 0) F → O on the box's two places: moved, 2 cells; (2, 2) F → O
    /// on "new": added, 1; (5, 3) O → F where "gone" stood: removed, 1; the ghost (1, 4) O → F
    /// near no edit: an initial error, 1. (0, 3) is not seen; (5, 5) and (3, 0) are unknown in
    /// M_1: no class.
    ///
    /// M_2 eroded the wall at (2, 5) (free) and (3, 5) (unknown), saw the box's new place but
    /// kept the old one, kept "gone", missed "new" and cleared the ghost (1, 4): retention
    /// 3/5 = 60 %; added 0/1, removed 0/1, moved 1/2 = 50 %, initial errors 1/1. M*_2 (M_1 with
    /// every seen cell set to G_2): 100 % of everything. F_2 sees the middle only: the wall
    /// from (2, 5) to (4, 5), 3/5 = 60 %; added 1/1, removed 0/1 ((5, 3) unknown), moved 0/2,
    /// initial errors 1/1.
    #[test]
    fn retention_and_change_classes_on_a_six_by_six_world_worked_by_hand() {
        let w1 = world(&[("box", [0.5, 0.5]), ("gone", [5.5, 3.5])]);
        let w2 = world(&[("box", [5.5, 0.5]), ("new", [2.5, 2.5])]);
        let m1 = grid([
            [O, O, O, O, O, U],
            [F, O, F, F, F, F],
            [O, F, F, F, F, O],
            [F, F, F, F, F, F],
            [F, F, F, F, F, F],
            [O, F, F, U, F, F],
        ]);
        let g1 = grid([
            [O, O, O, O, O, O],
            [F, F, F, F, F, F],
            [F, F, F, F, F, O],
            [F, F, F, F, F, F],
            [F, F, F, F, F, F],
            [O, F, F, F, F, F],
        ]);
        let g2 = grid([
            [O, O, O, O, O, O],
            [F, F, F, F, F, F],
            [F, F, F, F, F, F],
            [F, F, O, F, F, F],
            [F, F, F, F, F, F],
            [F, F, F, F, F, O],
        ]);
        let m2 = grid([
            [O, O, F, U, O, O],
            [F, F, F, F, F, F],
            [O, F, F, F, F, O],
            [F, F, F, F, F, F],
            [F, F, F, F, F, F],
            [O, F, F, U, F, O],
        ]);
        let best = grid([
            [O, O, O, O, O, O],
            [F, F, F, F, F, F],
            [O, F, F, F, F, F],
            [F, F, O, F, F, F],
            [F, F, F, F, F, F],
            [F, F, F, F, F, O],
        ]);
        let fresh = grid([
            [U, U, O, O, O, U],
            [U, F, F, F, F, U],
            [U, F, F, F, F, U],
            [U, F, O, F, F, U],
            [U, F, F, F, F, U],
            [U, U, U, U, U, U],
        ]);
        let hidden = [(0, 3), (0, 4), (0, 5)];
        let seen: Vec<bool> = (0..36).map(|i| !hidden.contains(&(i % 6, i / 6))).collect();
        let mut judge = ErosionJudge::new(&w1, &m1, &g1).expect("same geometry");
        assert_eq!(judge.structure.count(), 7);
        let (r, c) = judge.world(&w2, &g2, &seen, &m1, [&m2, &best, &fresh]).expect("same geometry");
        assert_eq!(r, Retention { structure_cells: 5, updated_map: 60.0, best_map: 100.0, fresh_map: 60.0 });
        let scores = |cells, u: f64, b: f64, f: f64| ClassScores {
            cells,
            updated_map: Some(u),
            best_map: Some(b),
            fresh_map: Some(f),
        };
        assert_eq!(c.added, scores(1, 0.0, 100.0, 100.0));
        assert_eq!(c.removed, scores(1, 0.0, 100.0, 0.0));
        assert_eq!(c.moved, scores(2, 50.0, 100.0, 0.0));
        assert_eq!(c.initial_errors, scores(1, 100.0, 100.0, 100.0));

        // Had W_2's file kept the box where it was (G_2 as above), no edit would explain the
        // box's two cells: initial errors, with the ghost.
        let mut judge = ErosionJudge::new(&w1, &m1, &g1).expect("same geometry");
        let w2_unmoved = world(&[("box", [0.5, 0.5]), ("new", [2.5, 2.5])]);
        let (_, c) = judge.world(&w2_unmoved, &g2, &seen, &m1, [&m2, &best, &fresh]).expect("same geometry");
        let counts = [c.added.cells, c.removed.cells, c.moved.cells, c.initial_errors.cells];
        assert_eq!(counts, [1, 1, 0, 3]);
        assert_eq!(c.initial_errors.updated_map, Some(100.0 * 2.0 / 3.0));
        assert_eq!(c.moved, ClassScores::default());
    }

    #[test]
    fn an_outline_turned_onto_itself_has_not_moved() {
        let at = |size: [f64; 2], yaw: f64| Shape::rect(mapkeeper_grid::Point2::new(1.0, 2.0), size, yaw);
        assert!(same_outline(&at([1.2, 0.8], 0.0), &at([1.2, 0.8], 180.0)));
        assert!(same_outline(&at([1.0, 1.0], 0.0), &at([1.0, 1.0], 90.0)));
        assert!(!same_outline(&at([1.2, 0.8], 0.0), &at([1.2, 0.8], 90.0)));
        assert!(!same_outline(&at([1.2, 0.8], 0.0), &at([1.2, 0.8], 30.0)));
        let circle = |r: f64| Shape::circle(mapkeeper_grid::Point2::new(1.0, 2.0), r);
        assert!(same_outline(&circle(0.3), &circle(0.3)) && !same_outline(&circle(0.3), &circle(0.4)));
    }

    /// The record of `tests/data/validation_run` (written before these metrics): one seed, W_2.
    fn old_record() -> ValidationRecord {
        let text = include_str!("../../../../../tests/data/validation_run/runs.json");
        serde_json::from_str(text).expect("runs.json of format 2 still loads")
    }

    #[test]
    fn records_without_the_figures_summarise_to_none() {
        let r = old_record();
        assert!(r.seeds[0].rows.iter().all(|w| w.retention.is_none() && w.change_classes.is_none()));
        assert_eq!(retention_summary(&r.seeds), None);
        assert_eq!(change_class_summary(&r.seeds), None);
        let s = r.summary();
        assert!(s.retention.is_none() && s.change_classes.is_none());
        let json = serde_json::to_string(&s).expect("json");
        assert!(!json.contains("retention") && !json.contains("change_classes"), "absent, not null");
    }

    #[test]
    fn the_summary_takes_w2_the_last_world_and_the_mean_over_seeds() {
        let base = old_record().seeds.remove(0);
        let row = |world: usize, kept: f64, added: u64| {
            let mut w = base.rows[0].clone();
            w.world = world;
            w.retention = Some(Retention { structure_cells: 100, updated_map: kept, best_map: 100.0, fresh_map: 50.0 });
            let some = |v: f64| (added > 0).then_some(v);
            let added =
                ClassScores { cells: added, updated_map: some(kept - 20.0), best_map: some(100.0), fresh_map: None };
            w.change_classes = Some(ChangeClasses { added, ..ChangeClasses::default() });
            w
        };
        let mut a = base.clone();
        a.rows = vec![row(2, 100.0, 4), row(3, 99.0, 0), row(4, 97.0, 2)];
        let mut b = base.clone();
        b.seed = 2;
        b.rows = vec![row(2, 99.5, 0), row(3, 99.5, 6), row(4, 99.5, 0)];
        let s = retention_summary(&[a.clone(), b.clone()]).expect("figures");
        assert_eq!(s.rows, 6);
        assert_eq!(s.updated_w2, (100.0 + 99.5) / 2.0);
        assert_eq!(s.updated_last, (97.0 + 99.5) / 2.0);
        assert_eq!(s.updated_last_min, 97.0);
        assert_eq!(s.updated_mean, (100.0 + 99.0 + 97.0 + 3.0 * 99.5) / 6.0);
        assert_eq!((s.best_mean, s.fresh_mean, s.structure_cells_mean), (100.0, 50.0, 100.0));
        assert!(!s.target_met, "98.25 % < 99 %");
        let c = change_class_summary(&[a, b]).expect("figures");
        assert_eq!((c.rows, c.added.rows), (6, 3));
        assert_eq!(c.added.cells_mean, 12.0 / 6.0);
        // Over the three rows with added cells: 80, 77 and 79.5 %.
        assert_eq!(c.added.updated_mean, Some((80.0 + 77.0 + 79.5) / 3.0));
        assert_eq!(c.added.best_mean, Some(100.0));
        assert_eq!(c.added.fresh_mean, None);
        // W_N has added cells in seed 1 only.
        assert_eq!(c.added.updated_last, Some(77.0));
        assert_eq!(c.moved, ClassSummary::default());
    }
}
