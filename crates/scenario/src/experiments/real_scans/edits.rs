//! A stale map of a real place (issue 52, item 1): seeded edits of G, the map at a log's
//! reference poses, that make M_1 the way the warehouse's worlds change between W_1 and W_50.
//!
//! Every edit is one of the change classes of the validation's metrics
//! ([`ChangeClass`]), named for what the place has done since the stale map was made:
//!
//! - **added** (the place has something M_1 lacks): a piece of G's observed structure, a
//!   connected run of occupied cells [`EditParams::segment_m`] long, is free in M_1. The real
//!   scans hit it where the stale map has floor;
//! - **removed** (M_1 has something the place lacks): a box [`EditParams::box_m`] on a side, at
//!   a seeded angle, drawn filled into observed free floor of G. The real scans cross it;
//! - **moved** (both): a piece of structure as for *added*, free in M_1, and the same cells
//!   shifted by [`EditParams::move_m`] drawn occupied into observed free floor (where M_1 saw
//!   the item before it moved).
//!
//! Only cells G observed are scored and edited in a class (free or occupied in G); of G's
//! unknown cells, only those just behind a piece of structure M_1 lacks are touched, made
//! free floor ([`EditParams::floor_behind_m`] says why), and no score counts them. A
//! box or a moved item's old place lies on observed free floor at least
//! [`EditParams::path_clearance_m`] from the reference path with a one-cell gap to anything
//! occupied, and edits do not overlap (one-cell gap). Every cell where M_1 differs from G is
//! in exactly one edit's footprint, so every one has a class ([`EditFootprints`]).
//!
//! The amounts are shares of G's observed occupied cells ([`EditParams::added_share`] …),
//! measured on the warehouse: W_50 against W_1 (`validate --preset mapkeeper --worlds 50 --seed
//! 1`, worlds 41-50, the observed cells of each class over G's occupied cells, see
//! `docs/real-data.md`). Edits are drawn until each class reaches its share or
//! [`EditParams::attempts`] placements have failed; what was reached is in [`StaleMap`].

use crate::experiments::ExperimentError;
use mapkeeper_common::{ParamError, stream_rng};
use mapkeeper_grid::DistanceField;
use mapkeeper_grid::metrics::erosion::{ChangeClass, EditFootprints};
use mapkeeper_grid::{CellCoord, CellState, OccupancyGrid, Point2};
use rand::RngExt;
use rand::rngs::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// Places tried for a moved piece's old place before the draw counts as failed.
const MOVE_TRIES: usize = 30;

/// How the stale map is made.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EditParams {
    /// Cells of the *added* class (structure M_1 lacks), as a share of G's observed occupied
    /// cells. Default 0.13 (the warehouse, W_50 against W_1).
    pub added_share: f64,
    /// Cells of the *removed* class (boxes M_1 has and the place lacks), as a share of G's
    /// observed occupied cells. Default 0.46 (the warehouse, W_50 against W_1: most of W_1's
    /// stacks have gone or moved by then).
    pub removed_share: f64,
    /// Cells of the *moved* class (both footprints), as a share of G's observed occupied cells.
    /// Default 0.10 (the warehouse, W_50 against W_1).
    pub moved_share: f64,
    /// Length range of a piece of structure, metres (the 0.3-3 m). Default (0.3, 3.0).
    pub segment_m: (f64, f64),
    /// Side range of a box, metres (the 0.3-1.2 m). Default (0.3, 1.2).
    pub box_m: (f64, f64),
    /// Distance range of a move, metres. Default (0.5, 3.0).
    pub move_m: (f64, f64),
    /// Smallest distance from a box or a moved item's old place to the reference path (the
    /// polyline of the reference poses), metres: the robot drove there, so nothing stood there.
    /// Default 0.6 (a 0.6 m wide robot's half width plus 0.3 m).
    pub path_clearance_m: f64,
    /// Smallest distance from a piece of structure taken out of M_1 to the reference path,
    /// metres. Default 0.2.
    pub structure_clearance_m: f64,
    /// The floor the stale map shows behind a piece of structure it lacks, metres: the cells
    /// of G within this distance of the piece that G never observed (the space behind a wall
    /// face) are free in M_1, as a survey made before the piece stood there saw them. Without
    /// it the piece could not be seen missing: in a map built from one side, a wall face has
    /// unknown cells right behind it, the stale map's ray through the gap stops there, where the
    /// real beam hits, and an updater that counts unknown cells as blocking (the paper's beam
    /// classifier does, §4.1) finds no change. These cells are unknown in G, so no score counts
    /// them. 0: G's unknown cells are never touched (and such pieces go unseen). Default 0.6
    /// (above the paper's change distance D_th at any range the logs' lidars reach).
    pub floor_behind_m: f64,
    /// Placements tried per class before it stops short of its share. Default 4000.
    pub attempts: u32,
}

impl Default for EditParams {
    fn default() -> Self {
        Self {
            added_share: 0.13,
            removed_share: 0.46,
            moved_share: 0.10,
            segment_m: (0.3, 3.0),
            box_m: (0.3, 1.2),
            move_m: (0.5, 3.0),
            path_clearance_m: 0.6,
            structure_clearance_m: 0.2,
            floor_behind_m: 0.6,
            attempts: 4000,
        }
    }
}

impl EditParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ParamError> {
        for (name, v) in [
            ("added_share", self.added_share),
            ("removed_share", self.removed_share),
            ("moved_share", self.moved_share),
        ] {
            if !(v.is_finite() && (0.0..=2.0).contains(&v)) {
                return Err(ParamError::new(name, v, "must be a share in [0, 2] of G's occupied cells"));
            }
        }
        for (name, (a, b)) in [("segment_m", self.segment_m), ("box_m", self.box_m), ("move_m", self.move_m)] {
            if !(a.is_finite() && b.is_finite() && a > 0.0 && a <= b && b <= 100.0) {
                return Err(ParamError::rule(name, format!("({a}, {b}) must be a range 0 < low ≤ high ≤ 100 m")));
            }
        }
        for (name, v) in [
            ("path_clearance_m", self.path_clearance_m),
            ("structure_clearance_m", self.structure_clearance_m),
            ("floor_behind_m", self.floor_behind_m),
        ] {
            if !(v.is_finite() && (0.0..=10.0).contains(&v)) {
                return Err(ParamError::new(name, v, "must be a distance in [0, 10] m"));
            }
        }
        if self.attempts == 0 || self.attempts > 1_000_000 {
            return Err(ParamError::new("attempts", self.attempts, "must be 1 to 1000000"));
        }
        Ok(())
    }
}

/// One edit: its class and the cells it changed (M_1's state there differs from G's).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Edit {
    /// What the place did since M_1: `added`, `removed` or `moved`.
    pub class: &'static str,
    /// Where it is, metres (the footprint's first cell; for a move, its place in G).
    pub at: (f64, f64),
    /// Cells occupied in G and free in M_1.
    pub cells_missing: usize,
    /// Cells free in G and occupied in M_1.
    pub cells_phantom: usize,
    /// Cells unknown in G and free in M_1: the floor behind a piece M_1 lacks
    /// ([`EditParams::floor_behind_m`]; never scored).
    pub floor_behind: usize,
}

/// The stale map M_1 of a real place, with every edit and the footprints of each class.
#[derive(Clone, Debug)]
pub struct StaleMap {
    /// M_1.
    pub map: OccupancyGrid,
    /// The edits, in the order they were made.
    pub edits: Vec<Edit>,
    /// The cells of each class (the validation's [`EditFootprints`]): added and removed
    /// footprints and both places of moved items.
    pub footprints: EditFootprints,
    /// Cells per class the shares asked for: (added, removed, moved).
    pub target_cells: (usize, usize, usize),
    /// Cells per class made: (added, removed, moved).
    pub made_cells: (usize, usize, usize),
}

/// The class of an edit's cells.
fn class_name(c: ChangeClass) -> &'static str {
    match c {
        ChangeClass::Added => "added",
        ChangeClass::Removed => "removed",
        ChangeClass::Moved => "moved",
        ChangeClass::InitialError => "initial-error",
    }
}

/// Makes M_1 from `truth` (G), the reference path `path` (positions in G's frame, in order)
/// and `seed`. The same inputs give the same M_1.
///
/// Errors: invalid parameters; a path with no position inside G.
pub fn stale_map(
    truth: &OccupancyGrid,
    path: &[Point2],
    params: &EditParams,
    seed: u64,
) -> Result<StaleMap, ExperimentError> {
    params.validate().map_err(ExperimentError::InvalidParam)?;
    let g = *truth.geometry();
    if !path.iter().any(|p| g.world_to_cell(*p).is_some_and(|c| g.contains(c))) {
        return Err(ExperimentError::Invalid("stale map: no reference pose lies inside the map".into()));
    }
    let path_distance = path_distance(truth, path, params.path_clearance_m.max(params.structure_clearance_m) + 1.0);
    let occupied = truth.count(CellState::Occupied);
    let target = |share: f64| (share * occupied as f64).round() as usize;
    let mut e = Editor {
        truth,
        map: truth.clone(),
        taken: vec![false; g.len()],
        path_distance,
        occupied_cells: cells_in(truth, CellState::Occupied),
        free_cells: cells_in(truth, CellState::Free),
        params,
        rng: stream_rng(seed, "real-scans/edits"),
        edits: Vec::new(),
        footprints: EditFootprints {
            added: vec![false; g.len()],
            removed: vec![false; g.len()],
            moved: vec![false; g.len()],
        },
    };
    let targets = (target(params.added_share), target(params.removed_share), target(params.moved_share));
    let mut made = (0, 0, 0);
    let mut failures = [0u32; 3];
    // Round robin over the classes still short of their share, so that none is starved by
    // another taking the best places first.
    loop {
        let mut progressed = false;
        for (k, class) in [ChangeClass::Added, ChangeClass::Removed, ChangeClass::Moved].into_iter().enumerate() {
            let (want, have) = match k {
                0 => (targets.0, &mut made.0),
                1 => (targets.1, &mut made.1),
                _ => (targets.2, &mut made.2),
            };
            if *have >= want || failures[k] >= params.attempts {
                continue;
            }
            progressed = true;
            match e.try_edit(class) {
                Some(cells) => *have += cells,
                None => failures[k] += 1,
            }
        }
        if !progressed {
            break;
        }
    }
    Ok(StaleMap { map: e.map, edits: e.edits, footprints: e.footprints, target_cells: targets, made_cells: made })
}

/// The indices of `map`'s cells in `state`.
fn cells_in(map: &OccupancyGrid, state: CellState) -> Vec<usize> {
    map.cells().iter().enumerate().filter(|(_, c)| **c == state).map(|(i, _)| i).collect()
}

/// The distance of every cell to the reference path (segments between consecutive positions),
/// metres, capped at `cap_m`.
fn path_distance(truth: &OccupancyGrid, path: &[Point2], cap_m: f64) -> DistanceField {
    let g = truth.geometry();
    let mut on_path = vec![false; g.len()];
    let step = g.resolution_m() * 0.5;
    let mut mark = |p: Point2| {
        if let Some(i) = g.world_to_cell(p).and_then(|c| g.index(c)) {
            on_path[i] = true;
        }
    };
    for w in path.windows(2) {
        let n = (w[0].distance(w[1]) / step).ceil().min(1e6) as usize;
        for k in 0..=n {
            let t = k as f64 / n.max(1) as f64;
            mark(Point2::new(w[0].x + t * (w[1].x - w[0].x), w[0].y + t * (w[1].y - w[0].y)));
        }
    }
    if let Some(&p) = path.first() {
        mark(p);
    }
    DistanceField::from_sites(g, cap_m, |i| on_path[i])
}

struct Editor<'a> {
    truth: &'a OccupancyGrid,
    map: OccupancyGrid,
    /// Cells in or next to an edit's footprint: no other edit may use them.
    taken: Vec<bool>,
    path_distance: DistanceField,
    /// G's occupied cells and free cells (indices), where pieces and boxes are drawn.
    occupied_cells: Vec<usize>,
    free_cells: Vec<usize>,
    params: &'a EditParams,
    rng: ChaCha8Rng,
    edits: Vec<Edit>,
    footprints: EditFootprints,
}

impl Editor<'_> {
    fn index(&self, c: CellCoord) -> Option<usize> {
        self.truth.geometry().index(c)
    }

    /// One edit of `class`; the cells it changed, or `None` if this draw found no place.
    fn try_edit(&mut self, class: ChangeClass) -> Option<usize> {
        match class {
            ChangeClass::Added => {
                let piece = self.draw_structure()?;
                let n = piece.len();
                self.commit(class, &piece, &[]);
                Some(n)
            }
            ChangeClass::Removed => {
                let (a, b) = self.params.box_m;
                let (sx, sy) = (self.rng.random_range(a..=b), self.rng.random_range(a..=b));
                let yaw = self.rng.random_range(0.0..std::f64::consts::PI);
                let centre = self.random_cell(CellState::Free)?;
                let cells = self.box_cells(centre, sx, sy, yaw);
                if !self.fits_on_floor(&cells) {
                    return None;
                }
                let n = cells.len();
                self.commit(class, &[], &cells);
                Some(n)
            }
            ChangeClass::Moved | ChangeClass::InitialError => {
                let piece = self.draw_structure()?;
                let (a, b) = self.params.move_m;
                let r = self.truth.geometry().resolution_m();
                // A piece is hard to fit whole on free floor: several places are tried for it.
                for _ in 0..MOVE_TRIES {
                    let d = self.rng.random_range(a..=b) / r;
                    let heading = self.rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
                    let (dx, dy) = ((d * heading.cos()).round() as i32, (d * heading.sin()).round() as i32);
                    let old: Vec<CellCoord> = piece.iter().map(|c| CellCoord::new(c.ix + dx, c.iy + dy)).collect();
                    if self.fits_on_floor(&old) {
                        let n = piece.len() + old.len();
                        self.commit(class, &piece, &old);
                        return Some(n);
                    }
                }
                None
            }
        }
    }

    /// A cell drawn from those in `state` in G (`None` if there is none).
    fn random_cell(&mut self, state: CellState) -> Option<CellCoord> {
        let list = if state == CellState::Occupied { &self.occupied_cells } else { &self.free_cells };
        if list.is_empty() {
            return None;
        }
        let i = list[self.rng.random_range(0..list.len())];
        Some(self.truth.geometry().coord(i))
    }

    /// A connected run of G's occupied cells around a seeded occupied cell, about
    /// `segment_m` long (breadth-first over 8-neighbours to half the length either way), none
    /// taken and none nearer the path than `structure_clearance_m`.
    fn draw_structure(&mut self) -> Option<Vec<CellCoord>> {
        let seed_cell = self.random_cell(CellState::Occupied)?;
        let ok = |e: &Self, c: CellCoord| {
            e.index(c).is_some_and(|i| {
                e.truth.cells()[i] == CellState::Occupied
                    && !e.taken[i]
                    && f64::from(e.path_distance.distances_m()[i]) >= e.params.structure_clearance_m
            })
        };
        if !ok(self, seed_cell) {
            return None;
        }
        let (a, b) = self.params.segment_m;
        let length = self.rng.random_range(a..=b);
        let depth = (0.5 * length / self.truth.geometry().resolution_m()).round().max(1.0) as u32;
        let mut piece = vec![seed_cell];
        let mut seen = std::collections::HashSet::from([seed_cell]);
        let mut queue = VecDeque::from([(seed_cell, 0u32)]);
        while let Some((c, d)) = queue.pop_front() {
            if d >= depth {
                continue;
            }
            for n in c.neighbours8() {
                if ok(self, n) && seen.insert(n) {
                    piece.push(n);
                    queue.push_back((n, d + 1));
                }
            }
        }
        Some(piece)
    }

    /// The cells of a `sx` × `sy` m box centred on `centre`'s centre, turned by `yaw`.
    fn box_cells(&self, centre: CellCoord, sx: f64, sy: f64, yaw: f64) -> Vec<CellCoord> {
        let g = self.truth.geometry();
        let r = g.resolution_m();
        let c = g.cell_center(centre);
        let half = 0.5 * sx.hypot(sy);
        let reach = (half / r).ceil() as i32 + 1;
        let (cos, sin) = (yaw.cos(), yaw.sin());
        let mut cells = Vec::new();
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                let cell = CellCoord::new(centre.ix + dx, centre.iy + dy);
                let p = g.cell_center(cell);
                let (x, y) = (p.x - c.x, p.y - c.y);
                let (u, v) = (cos * x + sin * y, -sin * x + cos * y);
                if u.abs() <= 0.5 * sx && v.abs() <= 0.5 * sy {
                    cells.push(cell);
                }
            }
        }
        cells
    }

    /// Whether `cells` and the ring of cells around them are all observed free floor of G,
    /// untaken, and every cell at least `path_clearance_m` from the path.
    fn fits_on_floor(&self, cells: &[CellCoord]) -> bool {
        !cells.is_empty()
            && cells.iter().all(|&c| {
                let Some(i) = self.index(c) else { return false };
                f64::from(self.path_distance.distances_m()[i]) >= self.params.path_clearance_m
                    && std::iter::once(c).chain(c.neighbours8()).all(|n| {
                        self.index(n).is_some_and(|j| self.truth.cells()[j] == CellState::Free && !self.taken[j])
                    })
            })
    }

    /// Writes an edit: `missing` cells (occupied in G) free in M_1, `phantom` cells (free in G)
    /// occupied in M_1; marks them and their ring taken and records the footprint.
    fn commit(&mut self, class: ChangeClass, missing: &[CellCoord], phantom: &[CellCoord]) {
        // Before the edit's own ring is taken: the floor right behind the piece belongs to it.
        let behind = self.floor_behind(missing);
        let footprint = match class {
            ChangeClass::Added => &mut self.footprints.added,
            ChangeClass::Removed => &mut self.footprints.removed,
            _ => &mut self.footprints.moved,
        };
        let g = *self.truth.geometry();
        for (cells, state) in [(missing, CellState::Free), (phantom, CellState::Occupied)] {
            for &c in cells {
                self.map.set(c, state);
                if let Some(i) = g.index(c) {
                    footprint[i] = true;
                }
                for n in std::iter::once(c).chain(c.neighbours8()) {
                    if let Some(j) = g.index(n) {
                        self.taken[j] = true;
                    }
                }
            }
        }
        for &i in &behind {
            self.map.cells_mut()[i] = CellState::Free;
            self.taken[i] = true;
        }
        let first = missing.first().or(phantom.first()).map_or(Point2::new(0.0, 0.0), |&c| g.cell_center(c));
        self.edits.push(Edit {
            class: class_name(class),
            at: (first.x, first.y),
            cells_missing: missing.len(),
            cells_phantom: phantom.len(),
            floor_behind: behind.len(),
        });
    }

    /// The cells G never observed within `floor_behind_m` of `piece`, not taken by another
    /// edit (their indices).
    fn floor_behind(&self, piece: &[CellCoord]) -> Vec<usize> {
        let g = self.truth.geometry();
        let reach = (self.params.floor_behind_m / g.resolution_m()).floor() as i32;
        let reach_sq = (self.params.floor_behind_m / g.resolution_m()).powi(2);
        let mut cells = std::collections::BTreeSet::new();
        for c in piece {
            for dy in -reach..=reach {
                for dx in -reach..=reach {
                    if f64::from(dx * dx + dy * dy) > reach_sq {
                        continue;
                    }
                    let n = CellCoord::new(c.ix + dx, c.iy + dy);
                    if let Some(j) =
                        g.index(n).filter(|&j| self.truth.cells()[j] == CellState::Unknown && !self.taken[j])
                    {
                        cells.insert(j);
                    }
                }
            }
        }
        cells.into_iter().collect()
    }
}

#[cfg(test)]
mod tests;
