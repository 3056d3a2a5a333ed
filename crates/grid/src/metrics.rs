//! Map-quality metrics of the paper's §5.1: cross-correlation (CC), map score (MS) and the
//! occupied picture-distance function (OPDF), all in percent. Definitions, open choices and
//! degenerate cases are in `docs/metrics.md`; in short:
//!
//! - every cell has the value m = 1 occupied, 0 free, [`MetricParams::unknown_value`] unknown;
//! - **CC** = 100 · (⟨MM~⟩ − ⟨M⟩⟨M~⟩) / (σ(M) σ(M~)) over all ν cells, in [−100, 100];
//! - **MS** = 100 · (1 − (1/ν′) Σ (m − m~)²) over the ν′ cells occupied in at least one map,
//!   in [0, 100];
//! - **OPDF_as(M, M~)** = 100 · (1 − Σ dᵢ / (ν_M r)) over the ν_M occupied cells of M, with
//!   dᵢ = min(r, L1 distance in cells to the nearest occupied cell of M~) and r = √(w² + h²) for
//!   the search window [`MetricParams::opdf_window_m`] expressed in cells; **OPDF** is the mean
//!   of both directions; all in [0, 100].
//!
//! Degenerate inputs have defined values (never NaN, never a panic):
//!
//! | case | value |
//! |---|---|
//! | σ(M) = 0 or σ(M~) = 0 (a constant map) | CC = 100 if the two maps have the same value in every cell, else 0 |
//! | ν′ = 0 (no occupied cell in either map) | MS = 100 |
//! | ν_M = 0 (M has no occupied cell) | OPDF_as(M, M~) = 100 if M~ has none either, else 0 |
//!
//! Manhattan distances come from an exact two-pass L1 distance transform (O(ν), no search).
//!
//! Beside them, [`erosion`] counts cells where these averages hide losses: the share of fixed
//! structure a map keeps (structure retention) and the share of each class of changed cells
//! (added, removed, moved) it got right.
//!
//! ```
//! use mapkeeper_grid::metrics::{map_metrics, MetricParams};
//! use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Pose2};
//! let geometry = GridGeometry::new(40, 40, 0.05, Pose2::IDENTITY).unwrap();
//! let mut a = OccupancyGrid::filled(geometry, CellState::Free);
//! for i in 0..40 {
//!     a.set(CellCoord::new(i, 10), CellState::Occupied);
//! }
//! let m = map_metrics(&a, &a, &MetricParams::default()).unwrap();
//! assert_eq!((m.cc, m.ms, m.opdf), (100.0, 100.0, 100.0));
//! ```

use crate::GridError;
use crate::grid::{CellState, GridGeometry, OccupancyGrid};
use mapkeeper_common::ParamError;
use serde::{Deserialize, Serialize};

pub mod erosion;

/// Errors of the metrics.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum MetricsError {
    /// The two maps do not share a geometry ([`GridError::GeometryMismatch`]).
    #[error(transparent)]
    Grid(#[from] GridError),
    /// A parameter is out of its range.
    #[error("metric parameter {} = {} is invalid: {}", .0.name, .0.value, .0.requirement)]
    InvalidParam(#[from] ParamError),
}

/// Parameters of the map metrics: the choices the paper leaves open.
///
/// ```
/// use mapkeeper_grid::metrics::MetricParams;
/// let mut p = MetricParams::default();
/// assert_eq!(p.unknown_value, 0.5);
/// p.opdf_window_m = (2.0, 2.0);
/// assert!(p.validate().is_ok());
/// let q: MetricParams = serde_json::from_str(r#"{"unknown_value": 0.3}"#).unwrap();
/// assert_eq!(q.opdf_window_m, (1.0, 1.0));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MetricParams {
    /// Occupancy value given to unknown cells in CC and MS, in [0, 1]. Default 0.5 (the
    /// occupancy probability of an unobserved cell).
    pub unknown_value: f64,
    /// OPDF search window (width, height), metres; each side finite and > 0. Converted to cells
    /// with the map's resolution (not rounded), r = √(w² + h²) cells. Default (1.0, 1.0), i.e.
    /// 20 × 20 cells and r ≈ 28.28 cells at 0.05 m.
    pub opdf_window_m: (f64, f64),
}

impl Default for MetricParams {
    fn default() -> Self {
        Self { unknown_value: 0.5, opdf_window_m: (1.0, 1.0) }
    }
}

impl MetricParams {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), MetricsError> {
        let u = self.unknown_value;
        if !(u.is_finite() && (0.0..=1.0).contains(&u)) {
            return Err(ParamError::new("unknown_value", u, "must be a number in [0, 1]").into());
        }
        for (name, v) in [("opdf_window_m.0", self.opdf_window_m.0), ("opdf_window_m.1", self.opdf_window_m.1)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ParamError::new(name, v, "must be a finite positive length, metres").into());
            }
        }
        Ok(())
    }

    /// The OPDF search radius r = √(w² + h²) in cells for a grid of `resolution_m` metres per cell.
    pub fn opdf_radius_cells(&self, resolution_m: f64) -> f64 {
        let w = self.opdf_window_m.0 / resolution_m;
        let h = self.opdf_window_m.1 / resolution_m;
        w.hypot(h)
    }
}

/// The metrics of a pair of maps (M = `a`, M~ = `b`), percent, with the counts behind them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MapMetrics {
    /// Cross-correlation × 100, in [−100, 100]; symmetric.
    pub cc: f64,
    /// Map score, in [0, 100]; symmetric.
    pub ms: f64,
    /// OPDF = (opdf_ab + opdf_ba) / 2, in [0, 100]; symmetric.
    pub opdf: f64,
    /// OPDF_as(a, b): occupied cells of `a` measured against `b`, in [0, 100].
    pub opdf_ab: f64,
    /// OPDF_as(b, a), in [0, 100].
    pub opdf_ba: f64,
    /// ν: cells in each map.
    pub cells: usize,
    /// ν′: cells occupied in at least one map (the cells MS is taken over).
    pub union_occupied: usize,
    /// ν_M of `a`: its occupied cells.
    pub occupied_a: usize,
    /// ν_M of `b`.
    pub occupied_b: usize,
    /// The OPDF search radius r used, cells.
    pub opdf_radius_cells: f64,
    /// True if CC came from the zero-variance rule rather than the formula.
    pub cc_degenerate: bool,
}

/// CC, MS and OPDF of two maps on the same geometry.
///
/// Errors: [`GridError::GeometryMismatch`] (wrapped) if the geometries differ (see
/// [`GridGeometry::same_as`]; use [`resample_onto`] first), and
/// [`MetricsError::InvalidParam`] for parameters that fail [`MetricParams::validate`].
pub fn map_metrics(a: &OccupancyGrid, b: &OccupancyGrid, params: &MetricParams) -> Result<MapMetrics, MetricsError> {
    metrics_over(a, b, None, params)
}

/// [`map_metrics`] over the cells where `mask` is true only (`mask` has one entry per cell, in
/// the grids' row-major order, e.g. from [`interior_mask`]): ν is the number of masked cells,
/// CC and MS are taken over them, and OPDF measures the masked occupied cells of each map
/// against the masked occupied cells of the other. An all-true mask gives [`map_metrics`].
///
/// Errors: those of [`map_metrics`], and [`GridError::GeometryMismatch`] (wrapped) if `mask`
/// does not have one entry per cell.
///
/// ```
/// use mapkeeper_grid::metrics::{map_metrics_in, MetricParams};
/// use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Pose2};
/// let g = GridGeometry::new(4, 1, 1.0, Pose2::IDENTITY).unwrap();
/// let mut a = OccupancyGrid::filled(g, CellState::Free);
/// a.set(CellCoord::new(0, 0), CellState::Occupied);
/// let mut b = a.clone();
/// b.set(CellCoord::new(3, 0), CellState::Occupied);
/// // Cell 3, where the maps differ, is outside the mask: they agree on the rest.
/// let m = map_metrics_in(&a, &b, &[true, true, true, false], &MetricParams::default()).unwrap();
/// assert_eq!((m.cc, m.ms, m.opdf, m.cells), (100.0, 100.0, 100.0, 3));
/// ```
pub fn map_metrics_in(
    a: &OccupancyGrid,
    b: &OccupancyGrid,
    mask: &[bool],
    params: &MetricParams,
) -> Result<MapMetrics, MetricsError> {
    metrics_over(a, b, Some(mask), params)
}

/// The cells inside the map's outer walls: every cell but those reachable from the grid's border
/// through cells that are not occupied (4-connected flood fill). Walls and everything they
/// enclose (items, their unknown insides) are interior; the floor outside an outer wall, and all
/// of a map with no closed outer wall, is not.
///
/// ```
/// use mapkeeper_grid::metrics::interior_mask;
/// use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Pose2};
/// let g = GridGeometry::new(5, 5, 1.0, Pose2::IDENTITY).unwrap();
/// let mut m = OccupancyGrid::filled(g, CellState::Free);
/// for i in 1..4 {
///     for (x, y) in [(i, 1), (i, 3), (1, i), (3, i)] {
///         m.set(CellCoord::new(x, y), CellState::Occupied);
///     }
/// }
/// let inside = interior_mask(&m);
/// assert_eq!(inside.iter().filter(|&&b| b).count(), 9); // the 3 × 3 ring and its centre
/// assert!(inside[2 * 5 + 2] && !inside[0]);
/// ```
pub fn interior_mask(map: &OccupancyGrid) -> Vec<bool> {
    let (w, h) = (map.geometry().width(), map.geometry().height());
    let cells = map.cells();
    let mut outside = vec![false; cells.len()];
    let mut stack = Vec::new();
    let push = |i: usize, outside: &mut Vec<bool>, stack: &mut Vec<usize>| {
        if !outside[i] && cells[i] != CellState::Occupied {
            outside[i] = true;
            stack.push(i);
        }
    };
    for x in 0..w {
        push(x, &mut outside, &mut stack);
        push((h - 1) * w + x, &mut outside, &mut stack);
    }
    for y in 0..h {
        push(y * w, &mut outside, &mut stack);
        push(y * w + w - 1, &mut outside, &mut stack);
    }
    while let Some(i) = stack.pop() {
        let (x, y) = (i % w, i / w);
        if x > 0 {
            push(i - 1, &mut outside, &mut stack);
        }
        if x + 1 < w {
            push(i + 1, &mut outside, &mut stack);
        }
        if y > 0 {
            push(i - w, &mut outside, &mut stack);
        }
        if y + 1 < h {
            push(i + w, &mut outside, &mut stack);
        }
    }
    outside.into_iter().map(|o| !o).collect()
}

fn metrics_over(
    a: &OccupancyGrid,
    b: &OccupancyGrid,
    mask: Option<&[bool]>,
    params: &MetricParams,
) -> Result<MapMetrics, MetricsError> {
    params.validate()?;
    if !a.geometry().same_as(b.geometry()) || mask.is_some_and(|m| m.len() != a.cells().len()) {
        return Err(GridError::GeometryMismatch.into());
    }
    let counts = JointCounts::of(a.cells(), b.cells(), mask);
    let (cc, cc_degenerate) = counts.cross_correlation(params.unknown_value);
    let ms = counts.map_score(params.unknown_value);
    let geometry = a.geometry();
    let r = params.opdf_radius_cells(geometry.resolution_m());
    let mut scratch = vec![0u32; geometry.len()];
    let opdf_ab = opdf_as(a, b, mask, r, &mut scratch);
    let opdf_ba = opdf_as(b, a, mask, r, &mut scratch);
    Ok(MapMetrics {
        cc,
        ms,
        opdf: 0.5 * (opdf_ab + opdf_ba),
        opdf_ab,
        opdf_ba,
        cells: counts.total as usize,
        union_occupied: counts.union_occupied(),
        occupied_a: counts.occupied_a(),
        occupied_b: counts.occupied_b(),
        opdf_radius_cells: r,
        cc_degenerate,
    })
}

/// `src` resampled onto `target`: each target cell takes the state of the `src` cell containing
/// its centre (nearest cell centre for equal resolutions; nearest-neighbour in general), and
/// [`CellState::Unknown`] where that centre falls outside `src`.
///
/// ```
/// use mapkeeper_grid::metrics::resample_onto;
/// use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Pose2};
/// let src_geometry = GridGeometry::new(2, 2, 1.0, Pose2::IDENTITY).unwrap();
/// let mut src = OccupancyGrid::filled(src_geometry, CellState::Free);
/// src.set(CellCoord::new(1, 1), CellState::Occupied);
/// // Twice as fine, shifted by one coarse cell to the left: the left half is outside `src`.
/// let target = GridGeometry::new(4, 4, 0.5, Pose2::new(-1.0, 0.0, 0.0)).unwrap();
/// let out = resample_onto(&src, &target);
/// assert_eq!(out.get(CellCoord::new(0, 0)), Some(CellState::Unknown));
/// assert_eq!(out.get(CellCoord::new(2, 0)), Some(CellState::Free));
/// assert_eq!(out.get(CellCoord::new(3, 3)), Some(CellState::Free));
/// assert_eq!(out.get(CellCoord::new(2, 2)), Some(CellState::Free)); // src (0, 1)
/// ```
pub fn resample_onto(src: &OccupancyGrid, target: &GridGeometry) -> OccupancyGrid {
    let cells = (0..target.len())
        .map(|i| {
            let centre = target.cell_center(target.coord(i));
            src.geometry().world_to_cell(centre).map_or(CellState::Unknown, |c| src.get_or_unknown(c))
        })
        .collect();
    // The cell vector has exactly target.len() entries.
    OccupancyGrid::from_cells(*target, cells).unwrap_or_else(|_| OccupancyGrid::filled(*target, CellState::Unknown))
}

/// Index of a state in the 3 × 3 joint table.
#[inline]
fn slot(s: CellState) -> usize {
    match s {
        CellState::Free => 0,
        CellState::Occupied => 1,
        CellState::Unknown => 2,
    }
}

/// States by slot.
const STATES: [CellState; 3] = [CellState::Free, CellState::Occupied, CellState::Unknown];

/// How many cells have each pair of states (a, b): exact integer counts, from which CC and MS
/// follow without accumulating rounding over ν cells.
struct JointCounts {
    n: [[u64; 3]; 3],
    total: u64,
}

impl JointCounts {
    fn of(a: &[CellState], b: &[CellState], mask: Option<&[bool]>) -> Self {
        let mut n = [[0u64; 3]; 3];
        match mask {
            None => {
                for (&x, &y) in a.iter().zip(b) {
                    n[slot(x)][slot(y)] += 1;
                }
            }
            Some(mask) => {
                for ((&x, &y), _) in a.iter().zip(b).zip(mask).filter(|(_, m)| **m) {
                    n[slot(x)][slot(y)] += 1;
                }
            }
        }
        let total = n.iter().flatten().sum();
        Self { n, total }
    }

    fn marginal_a(&self, i: usize) -> u64 {
        self.n[i].iter().sum()
    }

    fn marginal_b(&self, j: usize) -> u64 {
        (0..3).map(|i| self.n[i][j]).sum()
    }

    fn occupied_a(&self) -> usize {
        self.marginal_a(1) as usize
    }

    fn occupied_b(&self) -> usize {
        self.marginal_b(1) as usize
    }

    fn union_occupied(&self) -> usize {
        (self.marginal_a(1) + self.marginal_b(1) - self.n[1][1]) as usize
    }

    /// (CC, degenerate?). Centred sums over the 3 × 3 table (no E[x²] − E[x]² cancellation).
    fn cross_correlation(&self, unknown_value: f64) -> (f64, bool) {
        let v = STATES.map(|s| s.value(unknown_value));
        let nu = self.total.max(1) as f64;
        let mean_a = (0..3).map(|i| self.marginal_a(i) as f64 * v[i]).sum::<f64>() / nu;
        let mean_b = (0..3).map(|j| self.marginal_b(j) as f64 * v[j]).sum::<f64>() / nu;
        let var_a = (0..3).map(|i| self.marginal_a(i) as f64 * (v[i] - mean_a).powi(2)).sum::<f64>() / nu;
        let var_b = (0..3).map(|j| self.marginal_b(j) as f64 * (v[j] - mean_b).powi(2)).sum::<f64>() / nu;
        let mut cov = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                cov += self.n[i][j] as f64 * (v[i] - mean_a) * (v[j] - mean_b);
            }
        }
        cov /= nu;
        if self.values_identical(unknown_value) {
            // Pearson correlation of a vector with itself (or with a map of equal values) is 1:
            // returned exactly rather than as cov / (σ·σ) with its rounding.
            let degenerate = self.distinct_values(unknown_value, true) <= 1;
            return (100.0, degenerate);
        }
        let constant_a = self.distinct_values(unknown_value, true) <= 1;
        let constant_b = self.distinct_values(unknown_value, false) <= 1;
        let denom = var_a.sqrt() * var_b.sqrt();
        if constant_a || constant_b || denom.is_nan() || denom <= 0.0 {
            // Identical maps were handled above.
            return (0.0, true);
        }
        let cc = 100.0 * cov / denom;
        if cc.is_finite() { (cc.clamp(-100.0, 100.0), false) } else { (0.0, true) }
    }

    /// Number of distinct cell values present in map a (`of_a`) or b.
    fn distinct_values(&self, unknown_value: f64, of_a: bool) -> usize {
        let mut seen: Vec<f64> = Vec::with_capacity(3);
        for (k, s) in STATES.iter().enumerate() {
            let count = if of_a { self.marginal_a(k) } else { self.marginal_b(k) };
            let value = s.value(unknown_value);
            if count > 0 && !seen.contains(&value) {
                seen.push(value);
            }
        }
        seen.len()
    }

    /// Whether every cell has the same value in both maps.
    fn values_identical(&self, unknown_value: f64) -> bool {
        (0..3).all(|i| {
            (0..3).all(|j| self.n[i][j] == 0 || STATES[i].value(unknown_value) == STATES[j].value(unknown_value))
        })
    }

    /// MS; 100 when no cell is occupied in either map.
    fn map_score(&self, unknown_value: f64) -> f64 {
        let union = self.union_occupied();
        if union == 0 {
            return 100.0;
        }
        let v = STATES.map(|s| s.value(unknown_value));
        let mut sum = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                if i == 1 || j == 1 {
                    sum += self.n[i][j] as f64 * (v[i] - v[j]).powi(2);
                }
            }
        }
        (100.0 * (1.0 - sum / union as f64)).clamp(0.0, 100.0)
    }
}

/// Distance value meaning "no occupied cell reachable" (large, but far from overflowing when 1
/// is added).
const FAR: u32 = u32::MAX / 2;

/// Exact L1 (Manhattan) distance transform in cells to the nearest occupied cell of `grid`,
/// written into `out` (length ν; [`FAR`] where the grid has no occupied cell). Only occupied
/// cells inside `mask` (if any) count as sites. The 4-neighbour chamfer mask is exact for L1;
/// its passes are run per axis (columns, then rows), O(ν).
fn manhattan_to_occupied(grid: &OccupancyGrid, mask: Option<&[bool]>, out: &mut [u32]) {
    let (w, h) = (grid.geometry().width(), grid.geometry().height());
    for (i, (d, &s)) in out.iter_mut().zip(grid.cells()).enumerate() {
        let site = s == CellState::Occupied && mask.is_none_or(|m| m[i]);
        *d = if site { 0 } else { FAR };
    }
    // L1 is separable: first the distance to the nearest site in the same column (a sweep up,
    // then down, whole rows at a time), then along each row (a sweep right, then left).
    for y in 1..h {
        let (below, rest) = out.split_at_mut(y * w);
        let (below, row) = (&below[(y - 1) * w..], &mut rest[..w]);
        for (d, &b) in row.iter_mut().zip(below) {
            *d = (*d).min(b.saturating_add(1));
        }
    }
    for y in (0..h.saturating_sub(1)).rev() {
        let (head, above) = out.split_at_mut((y + 1) * w);
        let (row, above) = (&mut head[y * w..], &above[..w]);
        for (d, &a) in row.iter_mut().zip(above) {
            *d = (*d).min(a.saturating_add(1));
        }
    }
    for row in out.chunks_exact_mut(w) {
        for x in 1..w {
            row[x] = row[x].min(row[x - 1].saturating_add(1));
        }
        for x in (0..w.saturating_sub(1)).rev() {
            row[x] = row[x].min(row[x + 1].saturating_add(1));
        }
    }
    for d in out.iter_mut() {
        *d = (*d).min(FAR);
    }
}

/// Occupied cells of `m` inside `mask` (all of them without a mask).
fn occupied_in(m: &OccupancyGrid, mask: Option<&[bool]>) -> usize {
    match mask {
        None => m.count(CellState::Occupied),
        Some(mask) => m.cells().iter().zip(mask).filter(|&(&s, &k)| k && s == CellState::Occupied).count(),
    }
}

/// OPDF_as(m, other) with search radius `r` cells over the cells in `mask` (all without one);
/// `scratch` has length ν.
fn opdf_as(m: &OccupancyGrid, other: &OccupancyGrid, mask: Option<&[bool]>, r: f64, scratch: &mut [u32]) -> f64 {
    let occupied_m = occupied_in(m, mask);
    if occupied_m == 0 {
        return if occupied_in(other, mask) == 0 { 100.0 } else { 0.0 };
    }
    manhattan_to_occupied(other, mask, scratch);
    // Distances below r summed exactly as integers, the capped ones counted.
    let (mut below, mut capped) = (0u64, 0u64);
    for (i, (&s, &d)) in m.cells().iter().zip(scratch.iter()).enumerate() {
        if s == CellState::Occupied && mask.is_none_or(|k| k[i]) {
            if (d as f64) < r {
                below += u64::from(d);
            } else {
                capped += 1;
            }
        }
    }
    let sum = below as f64 + capped as f64 * r;
    let value = 100.0 * (1.0 - sum / (occupied_m as f64 * r));
    if value.is_finite() { value.clamp(0.0, 100.0) } else { 0.0 }
}

#[cfg(test)]
mod tests;
