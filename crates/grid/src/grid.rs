//! The occupancy grid: geometry (size, resolution, origin), cell states and coordinates
//! (paper eq. 1, with the origin's yaw honoured as ROS map_server does).

use crate::GridError;
use crate::pose::{Point2, Pose2};
use serde::{Deserialize, Serialize};

/// The largest grid accepted, in cells (256 M cells, 256 MiB of states). Anything larger is
/// refused before allocating, so a corrupt header cannot exhaust memory.
pub const MAX_CELLS: usize = 1 << 28;

/// The largest side accepted, in cells.
pub const MAX_SIDE: usize = 1 << 20;

/// The state of one cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[repr(u8)]
pub enum CellState {
    /// Known free (traversable) space.
    Free = 0,
    /// Known occupied space.
    Occupied = 1,
    /// Never observed (or the interior of an obstacle).
    Unknown = 2,
}

/// How a cell changed from one state to another: the one rule behind map diffs (rendered, in
/// the MCAP changes layer and in the updater's step counts).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChangeKind {
    /// The same state.
    Same,
    /// Became occupied.
    Added,
    /// Was occupied, is no longer.
    Removed,
    /// Between free and unknown.
    Other,
}

impl ChangeKind {
    /// The change from `a` to `b`.
    pub fn of(a: CellState, b: CellState) -> ChangeKind {
        match (a, b) {
            _ if a == b => ChangeKind::Same,
            (_, CellState::Occupied) => ChangeKind::Added,
            (CellState::Occupied, _) => ChangeKind::Removed,
            _ => ChangeKind::Other,
        }
    }
}

impl CellState {
    /// The occupancy value used by the map metrics: 1 occupied, 0 free, `unknown_value` unknown.
    pub fn value(self, unknown_value: f64) -> f64 {
        match self {
            CellState::Free => 0.0,
            CellState::Occupied => 1.0,
            CellState::Unknown => unknown_value,
        }
    }
}

/// Integer cell coordinates `(ix, iy)`: column and row, row 0 at the bottom (paper Fig. 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct CellCoord {
    /// Column, counted from the origin along the map's x axis.
    pub ix: i32,
    /// Row, counted from the origin along the map's y axis.
    pub iy: i32,
}

impl CellCoord {
    /// A cell from its column and row.
    pub const fn new(ix: i32, iy: i32) -> Self {
        Self { ix, iy }
    }

    /// The 8-neighbourhood of this cell (may lie outside any grid).
    pub fn neighbours8(self) -> [CellCoord; 8] {
        let CellCoord { ix, iy } = self;
        [
            CellCoord::new(ix - 1, iy - 1),
            CellCoord::new(ix, iy - 1),
            CellCoord::new(ix + 1, iy - 1),
            CellCoord::new(ix - 1, iy),
            CellCoord::new(ix + 1, iy),
            CellCoord::new(ix - 1, iy + 1),
            CellCoord::new(ix, iy + 1),
            CellCoord::new(ix + 1, iy + 1),
        ]
    }
}

/// Where a grid lies in the world: its size in cells, the side of a cell, and the pose of the
/// lower-left corner of cell (0, 0) in the map frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridGeometry {
    width: usize,
    height: usize,
    resolution_m: f64,
    origin: Pose2,
    // Cached rotation of the origin.
    cos_yaw: f64,
    sin_yaw: f64,
}

impl GridGeometry {
    /// A validated geometry: sides ≥ 1 and ≤ [`MAX_SIDE`], at most [`MAX_CELLS`] cells, a finite
    /// positive resolution (metres per cell) and a finite origin.
    pub fn new(width: usize, height: usize, resolution_m: f64, origin: Pose2) -> Result<Self, GridError> {
        if width == 0 || height == 0 {
            return Err(GridError::EmptyGrid { width, height });
        }
        if width > MAX_SIDE || height > MAX_SIDE || width.saturating_mul(height) > MAX_CELLS {
            return Err(GridError::TooLarge { width, height, max_cells: MAX_CELLS });
        }
        if !(resolution_m.is_finite() && resolution_m > 0.0) {
            return Err(GridError::BadResolution(resolution_m));
        }
        if !origin.is_finite() {
            return Err(GridError::BadOrigin(origin));
        }
        let (sin_yaw, cos_yaw) = origin.yaw.sin_cos();
        Ok(Self { width, height, resolution_m, origin, cos_yaw, sin_yaw })
    }

    /// Number of columns.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Number of rows.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.width * self.height
    }

    /// Always false: a valid geometry has at least one cell.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Side of a cell, metres.
    pub fn resolution_m(&self) -> f64 {
        self.resolution_m
    }

    /// Pose of the lower-left corner of cell (0, 0) in the map frame.
    pub fn origin(&self) -> Pose2 {
        self.origin
    }

    /// Whether two geometries describe the same cells (size, resolution and origin equal to
    /// within 1e-9 m / rad).
    pub fn same_as(&self, other: &GridGeometry) -> bool {
        self.width == other.width
            && self.height == other.height
            && (self.resolution_m - other.resolution_m).abs() <= 1e-9
            && (self.origin.x - other.origin.x).abs() <= 1e-9
            && (self.origin.y - other.origin.y).abs() <= 1e-9
            && (self.origin.yaw - other.origin.yaw).abs() <= 1e-9
    }

    /// Continuous grid coordinates `(u, v)` of a map-frame point, in cells (eq. 1 before the floor).
    #[inline]
    pub fn world_to_grid(&self, p: Point2) -> (f64, f64) {
        let dx = p.x - self.origin.x;
        let dy = p.y - self.origin.y;
        let u = (self.cos_yaw * dx + self.sin_yaw * dy) / self.resolution_m;
        let v = (-self.sin_yaw * dx + self.cos_yaw * dy) / self.resolution_m;
        (u, v)
    }

    /// Map-frame point of continuous grid coordinates `(u, v)`.
    #[inline]
    pub fn grid_to_world(&self, u: f64, v: f64) -> Point2 {
        let gx = u * self.resolution_m;
        let gy = v * self.resolution_m;
        Point2::new(
            self.origin.x + self.cos_yaw * gx - self.sin_yaw * gy,
            self.origin.y + self.sin_yaw * gx + self.cos_yaw * gy,
        )
    }

    /// The cell containing a map-frame point (eq. 1 with floor); it may lie outside the grid.
    /// Non-finite points map to `None`.
    #[inline]
    pub fn world_to_cell(&self, p: Point2) -> Option<CellCoord> {
        let (u, v) = self.world_to_grid(p);
        let (fu, fv) = (crate::geometry::floor_exact(u), crate::geometry::floor_exact(v));
        if !(fu.is_finite() && fv.is_finite()) || fu.abs() > i32::MAX as f64 || fv.abs() > i32::MAX as f64 {
            return None;
        }
        Some(CellCoord::new(fu as i32, fv as i32))
    }

    /// The map-frame centre of a cell.
    #[inline]
    pub fn cell_center(&self, c: CellCoord) -> Point2 {
        self.grid_to_world(c.ix as f64 + 0.5, c.iy as f64 + 0.5)
    }

    /// Whether a cell lies inside the grid.
    #[inline]
    pub fn contains(&self, c: CellCoord) -> bool {
        c.ix >= 0 && c.iy >= 0 && (c.ix as usize) < self.width && (c.iy as usize) < self.height
    }

    /// Linear index (row-major from the bottom row) of a cell inside the grid.
    #[inline]
    pub fn index(&self, c: CellCoord) -> Option<usize> {
        self.contains(c).then(|| c.iy as usize * self.width + c.ix as usize)
    }

    /// The cell of a linear index.
    #[inline]
    pub fn coord(&self, index: usize) -> CellCoord {
        CellCoord::new((index % self.width) as i32, (index / self.width) as i32)
    }

    /// Size of the covered area, metres (width, height).
    pub fn extent_m(&self) -> (f64, f64) {
        (self.width as f64 * self.resolution_m, self.height as f64 * self.resolution_m)
    }
}

/// A 2D occupancy grid with trinary cells.
///
/// ```
/// use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Point2, Pose2};
/// let geometry = GridGeometry::new(4, 3, 0.5, Pose2::new(-1.0, -1.0, 0.0)).unwrap();
/// let mut grid = OccupancyGrid::filled(geometry, CellState::Free);
/// grid.set(CellCoord::new(2, 1), CellState::Occupied);
/// let c = grid.geometry().world_to_cell(Point2::new(0.2, -0.3)).unwrap();
/// assert_eq!(c, CellCoord::new(2, 1));
/// assert_eq!(grid.get(c), Some(CellState::Occupied));
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(into = "GridRecord", try_from = "GridRecord")]
pub struct OccupancyGrid {
    geometry: GridGeometry,
    cells: Vec<CellState>,
}

/// How an [`OccupancyGrid`] is serialised (checkpoints of long runs): its geometry and its
/// cells run-length encoded, row-major from the bottom row, as runs of a count and a letter
/// (`f` free, `o` occupied, `u` unknown): `"120u3o7f"`. Read back through
/// [`GridGeometry::new`] and [`OccupancyGrid::from_cells`], so a damaged record is refused,
/// never a panic.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct GridRecord {
    width: usize,
    height: usize,
    resolution_m: f64,
    origin: Pose2,
    cells: String,
}

fn cell_letter(c: CellState) -> char {
    match c {
        CellState::Free => 'f',
        CellState::Occupied => 'o',
        CellState::Unknown => 'u',
    }
}

impl From<OccupancyGrid> for GridRecord {
    fn from(g: OccupancyGrid) -> Self {
        use std::fmt::Write as _;
        let mut cells = String::new();
        for run in g.cells.chunk_by(|a, b| a == b) {
            let _ = write!(cells, "{}{}", run.len(), cell_letter(run[0]));
        }
        let geo = g.geometry;
        GridRecord { width: geo.width, height: geo.height, resolution_m: geo.resolution_m, origin: geo.origin, cells }
    }
}

impl TryFrom<GridRecord> for OccupancyGrid {
    type Error = String;

    fn try_from(r: GridRecord) -> Result<Self, String> {
        let geometry = GridGeometry::new(r.width, r.height, r.resolution_m, r.origin).map_err(|e| e.to_string())?;
        let mut cells = Vec::with_capacity(geometry.len());
        let mut count: usize = 0;
        for (i, b) in r.cells.bytes().enumerate() {
            let state = match b {
                b'0'..=b'9' => {
                    count = count
                        .checked_mul(10)
                        .and_then(|c| c.checked_add(usize::from(b - b'0')))
                        .filter(|&c| c <= geometry.len())
                        .ok_or_else(|| {
                            format!("cells: the run ending at character {} is longer than the grid", i + 1)
                        })?;
                    continue;
                }
                b'f' => CellState::Free,
                b'o' => CellState::Occupied,
                b'u' => CellState::Unknown,
                _ => return Err(format!("cells: character {} is {:?}, not a digit, f, o or u", i + 1, char::from(b))),
            };
            if count == 0 || cells.len() + count > geometry.len() {
                return Err(format!("cells: run at character {} is empty or goes past the grid's end", i + 1));
            }
            cells.resize(cells.len() + count, state);
            count = 0;
        }
        if count != 0 {
            return Err("cells: ends in a count without its letter".into());
        }
        OccupancyGrid::from_cells(geometry, cells).map_err(|e| e.to_string())
    }
}

impl OccupancyGrid {
    /// A grid with every cell in `state`.
    pub fn filled(geometry: GridGeometry, state: CellState) -> Self {
        Self { cells: vec![state; geometry.len()], geometry }
    }

    /// A room: every cell free but the grid's outer ring (first and last row and column),
    /// occupied. The walls of a test scene or a synthetic map; furniture is set on top.
    pub fn walled(geometry: GridGeometry) -> Self {
        let mut m = Self::filled(geometry, CellState::Free);
        let (w, h) = (geometry.width(), geometry.height());
        for (i, c) in m.cells.iter_mut().enumerate() {
            let (x, y) = (i % w, i / w);
            if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
                *c = CellState::Occupied;
            }
        }
        m
    }

    /// A grid from its cells, row-major from the bottom row.
    pub fn from_cells(geometry: GridGeometry, cells: Vec<CellState>) -> Result<Self, GridError> {
        if cells.len() != geometry.len() {
            return Err(GridError::CellCount { expected: geometry.len(), got: cells.len() });
        }
        Ok(Self { geometry, cells })
    }

    /// The grid's geometry.
    pub fn geometry(&self) -> &GridGeometry {
        &self.geometry
    }

    /// All cells, row-major from the bottom row.
    pub fn cells(&self) -> &[CellState] {
        &self.cells
    }

    /// All cells, mutable, row-major from the bottom row.
    pub fn cells_mut(&mut self) -> &mut [CellState] {
        &mut self.cells
    }

    /// The state of a cell, `None` outside the grid.
    #[inline]
    pub fn get(&self, c: CellCoord) -> Option<CellState> {
        self.geometry.index(c).map(|i| self.cells[i])
    }

    /// The state of a cell, `Unknown` outside the grid.
    #[inline]
    pub fn get_or_unknown(&self, c: CellCoord) -> CellState {
        self.get(c).unwrap_or(CellState::Unknown)
    }

    /// The state of the cell containing a map-frame point, `None` outside the grid.
    pub fn get_world(&self, p: Point2) -> Option<CellState> {
        self.geometry.world_to_cell(p).and_then(|c| self.get(c))
    }

    /// Sets a cell; returns false (and changes nothing) outside the grid.
    #[inline]
    pub fn set(&mut self, c: CellCoord, state: CellState) -> bool {
        match self.geometry.index(c) {
            Some(i) => {
                self.cells[i] = state;
                true
            }
            None => false,
        }
    }

    /// Number of cells in `state`.
    pub fn count(&self, state: CellState) -> usize {
        self.cells.iter().filter(|&&s| s == state).count()
    }

    /// Cells of `self` and `other` that differ, in index order (both grids must share geometry).
    pub fn diff(&self, other: &OccupancyGrid) -> Result<Vec<(CellCoord, CellState, CellState)>, GridError> {
        if !self.geometry.same_as(&other.geometry) {
            return Err(GridError::GeometryMismatch);
        }
        Ok(self
            .cells
            .iter()
            .zip(&other.cells)
            .enumerate()
            .filter(|(_, (a, b))| a != b)
            .map(|(i, (a, b))| (self.geometry.coord(i), *a, *b))
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_walled_grid_is_free_inside_its_occupied_ring() {
        let g = GridGeometry::new(5, 4, 0.1, Pose2::IDENTITY).unwrap_or_else(|e| panic!("{e}"));
        let m = OccupancyGrid::walled(g);
        let rows: Vec<String> = (0..4)
            .map(|y| {
                (0..5)
                    .map(|x| if m.get(CellCoord::new(x, y)) == Some(CellState::Occupied) { '#' } else { '.' })
                    .collect()
            })
            .collect();
        assert_eq!(rows, ["#####", "#...#", "#...#", "#####"]);
    }

    #[test]
    fn a_grid_round_trips_through_json_and_damaged_records_are_refused() {
        let geo = GridGeometry::new(3, 2, 0.05, Pose2::new(-1.25, 0.5, 0.3)).unwrap();
        let cells = vec![
            CellState::Free,
            CellState::Occupied,
            CellState::Unknown,
            CellState::Occupied,
            CellState::Free,
            CellState::Unknown,
        ];
        let g = OccupancyGrid::from_cells(geo, cells).unwrap();
        let text = serde_json::to_string(&g).unwrap();
        assert!(text.contains(r#""cells":"1f1o1u1o1f1u""#), "{text}");
        assert_eq!(serde_json::from_str::<OccupancyGrid>(&text).unwrap(), g);
        let runs =
            OccupancyGrid::filled(GridGeometry::new(400, 300, 0.05, Pose2::default()).unwrap(), CellState::Unknown);
        let t = serde_json::to_string(&runs).unwrap();
        assert!(t.contains(r#""cells":"120000u""#), "{t}");
        assert_eq!(serde_json::from_str::<OccupancyGrid>(&t).unwrap(), runs);
        let damaged = |from: &str, to: &str| {
            serde_json::from_str::<OccupancyGrid>(&text.replace(from, to)).unwrap_err().to_string()
        };
        assert!(damaged("1f1o1u1o1f1u", "1f1o1x1o1f1u").contains("character 6"));
        assert!(damaged("1f1o1u1o1f1u", "1f1o1u1o").contains("6 cells"), "{}", damaged("1f1o1u1o1f1u", "1f1o1u1o"));
        assert!(damaged("1f1o1u1o1f1u", "1f1o1u1o1f2u").contains("past the grid's end"));
        assert!(damaged("1f1o1u1o1f1u", "1f1o1u1o1f0u1u").contains("empty"));
        assert!(damaged("1f1o1u1o1f1u", "1f1o1u1o1f1").contains("without its letter"));
        assert!(damaged("1f1o1u1o1f1u", "99999999999999999999999f").contains("longer than the grid"));
        assert!(damaged(r#""width":3"#, r#""width":0"#).contains("no cells"));
    }

    #[test]
    fn eq1_floor_with_offset_origin() {
        let g = GridGeometry::new(10, 10, 0.05, Pose2::new(-7.0, -10.5, 0.0)).unwrap();
        assert_eq!(g.world_to_cell(Point2::new(-7.0, -10.5)), Some(CellCoord::new(0, 0)));
        assert_eq!(g.world_to_cell(Point2::new(-6.9999, -10.4501)), Some(CellCoord::new(0, 0)));
        assert_eq!(g.world_to_cell(Point2::new(-7.0001, -10.5)), Some(CellCoord::new(-1, 0)));
        let c = g.cell_center(CellCoord::new(3, 4));
        assert!((c.x - (-7.0 + 0.175)).abs() < 1e-12 && (c.y - (-10.5 + 0.225)).abs() < 1e-12);
    }

    #[test]
    fn rotated_origin_round_trips() {
        let g = GridGeometry::new(20, 10, 0.1, Pose2::new(1.0, 2.0, 0.7)).unwrap();
        for ix in 0..20 {
            for iy in 0..10 {
                let c = CellCoord::new(ix, iy);
                assert_eq!(g.world_to_cell(g.cell_center(c)), Some(c));
            }
        }
        // One cell along the rotated x axis.
        let p = g.grid_to_world(1.0, 0.0);
        assert!((p.x - (1.0 + 0.1 * 0.7f64.cos())).abs() < 1e-12);
        assert!((p.y - (2.0 + 0.1 * 0.7f64.sin())).abs() < 1e-12);
    }

    #[test]
    fn refuses_bad_geometry() {
        assert!(matches!(GridGeometry::new(0, 5, 0.05, Pose2::IDENTITY), Err(GridError::EmptyGrid { .. })));
        assert!(matches!(GridGeometry::new(100_000, 100_000, 0.05, Pose2::IDENTITY), Err(GridError::TooLarge { .. })));
        assert!(matches!(GridGeometry::new(5, 5, 0.0, Pose2::IDENTITY), Err(GridError::BadResolution(_))));
        assert!(matches!(GridGeometry::new(5, 5, -1.0, Pose2::IDENTITY), Err(GridError::BadResolution(_))));
        assert!(matches!(GridGeometry::new(5, 5, 0.05, Pose2::new(f64::NAN, 0.0, 0.0)), Err(GridError::BadOrigin(_))));
        assert_eq!(
            GridGeometry::new(5, 5, 0.05, Pose2::IDENTITY).unwrap().world_to_cell(Point2::new(f64::NAN, 0.0)),
            None
        );
    }

    #[test]
    fn checked_access_and_diff() {
        let g = GridGeometry::new(3, 2, 1.0, Pose2::IDENTITY).unwrap();
        let mut a = OccupancyGrid::filled(g, CellState::Free);
        assert_eq!(a.get(CellCoord::new(3, 0)), None);
        assert_eq!(a.get(CellCoord::new(-1, 0)), None);
        assert!(!a.set(CellCoord::new(0, 2), CellState::Occupied));
        let b = a.clone();
        assert!(a.set(CellCoord::new(2, 1), CellState::Occupied));
        let d = a.diff(&b).unwrap();
        assert_eq!(d, vec![(CellCoord::new(2, 1), CellState::Occupied, CellState::Free)]);
        assert_eq!(a.count(CellState::Occupied), 1);
        assert!(OccupancyGrid::from_cells(g, vec![CellState::Free; 5]).is_err());
    }
}
