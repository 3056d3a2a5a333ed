//! Exact Euclidean distance transform (Felzenszwalb & Huttenlocher, 2012): for every cell, the
//! distance from its centre to the centre of the nearest site cell (by default: occupied cells).
//! The localiser's likelihood field is built on it.

use crate::grid::{CellCoord, CellState, GridGeometry, OccupancyGrid};
use crate::pose::Point2;

/// Squared distances, in cells², large enough to mean "no site" without overflow in f64 sums.
const FAR: f64 = 1e20;

/// Per-cell distance to the nearest site, metres, capped at `max_distance_m`.
#[derive(Clone, Debug, PartialEq)]
pub struct DistanceField {
    geometry: GridGeometry,
    max_distance_m: f32,
    distances_m: Vec<f32>,
}

impl DistanceField {
    /// The distance to the nearest occupied cell of `grid`, capped at `max_distance_m`
    /// (a grid with no occupied cell gives the cap everywhere).
    pub fn to_occupied(grid: &OccupancyGrid, max_distance_m: f64) -> Self {
        Self::from_sites(grid.geometry(), max_distance_m, |i| grid.cells()[i] == CellState::Occupied)
    }

    /// The distance to the nearest cell `i` (linear index) for which `is_site(i)` holds.
    pub fn from_sites(geometry: &GridGeometry, max_distance_m: f64, is_site: impl Fn(usize) -> bool) -> Self {
        let (w, h) = (geometry.width(), geometry.height());
        let mut sq: Vec<f64> = (0..w * h).map(|i| if is_site(i) { 0.0 } else { FAR }).collect();
        let n = w.max(h);
        let mut f = vec![0.0; n];
        let mut d = vec![0.0; n];
        let mut v = vec![0usize; n];
        let mut z = vec![0.0; n + 1];
        // Columns, then rows.
        for x in 0..w {
            for y in 0..h {
                f[y] = sq[y * w + x];
            }
            edt_1d(&f[..h], &mut d[..h], &mut v, &mut z);
            for y in 0..h {
                sq[y * w + x] = d[y];
            }
        }
        for y in 0..h {
            f[..w].copy_from_slice(&sq[y * w..(y + 1) * w]);
            edt_1d(&f[..w], &mut d[..w], &mut v, &mut z);
            sq[y * w..(y + 1) * w].copy_from_slice(&d[..w]);
        }
        let r = geometry.resolution_m();
        let cap = max_distance_m.max(0.0);
        let distances_m = sq.iter().map(|&s| (s.sqrt() * r).min(cap) as f32).collect();
        Self { geometry: *geometry, max_distance_m: cap as f32, distances_m }
    }

    /// The distance from each cell's centre to the nearest of `points` (map frame), exactly (not
    /// to the centre of the point's cell), capped at `max_distance_m`: a field whose zeros lie
    /// on the points, for matching against scattered points (a lidar's endpoints) without the
    /// bias of the cell lattice. Non-finite points are ignored; a point outside the grid still
    /// counts for the cells within the cap of it.
    ///
    /// ```
    /// use mapkeeper_grid::{CellCoord, DistanceField, GridGeometry, Point2, Pose2};
    /// let g = GridGeometry::new(10, 10, 0.1, Pose2::IDENTITY).unwrap();
    /// let f = DistanceField::to_points(&g, [Point2::new(0.52, 0.5)], 0.3);
    /// assert!((f.at_cell(CellCoord::new(5, 4)) - 0.05f32.hypot(0.03)).abs() < 1e-6);
    /// assert_eq!(f.at_cell(CellCoord::new(0, 0)), 0.3, "capped");
    /// ```
    pub fn to_points(geometry: &GridGeometry, points: impl IntoIterator<Item = Point2>, max_distance_m: f64) -> Self {
        let cap = if max_distance_m.is_finite() { max_distance_m.max(0.0) } else { 0.0 };
        let (w, h) = (geometry.width() as i64, geometry.height() as i64);
        let mut distances_m = vec![cap as f32; (w * h) as usize];
        let reach = (cap / geometry.resolution_m()).ceil() as i64 + 1;
        for p in points.into_iter().filter(|p| p.is_finite()) {
            let (u, v) = geometry.world_to_grid(p);
            let (cu, cv) = (crate::geometry::floor_exact(u) as i64, crate::geometry::floor_exact(v) as i64);
            if cu < -reach || cv < -reach || cu >= w + reach || cv >= h + reach {
                continue;
            }
            for j in (cv - reach).max(0)..(cv + reach + 1).min(h) {
                for i in (cu - reach).max(0)..(cu + reach + 1).min(w) {
                    let d = (((i as f64 + 0.5 - u).powi(2) + (j as f64 + 0.5 - v).powi(2)).sqrt()
                        * geometry.resolution_m()) as f32;
                    let cell = &mut distances_m[(j * w + i) as usize];
                    if d < *cell {
                        *cell = d;
                    }
                }
            }
        }
        Self { geometry: *geometry, max_distance_m: cap as f32, distances_m }
    }

    /// The geometry of the field (that of the source grid).
    pub fn geometry(&self) -> &GridGeometry {
        &self.geometry
    }

    /// The cap, metres.
    pub fn max_distance_m(&self) -> f32 {
        self.max_distance_m
    }

    /// Distances by linear index, metres.
    pub fn distances_m(&self) -> &[f32] {
        &self.distances_m
    }

    /// Distance at a cell; the cap outside the grid.
    #[inline]
    pub fn at_cell(&self, c: CellCoord) -> f32 {
        self.geometry.index(c).map_or(self.max_distance_m, |i| self.distances_m[i])
    }

    /// Distance at the cell containing a map-frame point; the cap outside the grid.
    #[inline]
    pub fn at_world(&self, p: Point2) -> f32 {
        match self.geometry.world_to_cell(p) {
            Some(c) => self.at_cell(c),
            None => self.max_distance_m,
        }
    }
}

/// One-dimensional squared distance transform of sampled function `f` (lower envelope of
/// parabolas). `v` and `z` are scratch of length ≥ n and ≥ n + 1.
fn edt_1d(f: &[f64], d: &mut [f64], v: &mut [usize], z: &mut [f64]) {
    let n = f.len();
    if n == 0 {
        return;
    }
    let mut k = 0usize;
    v[0] = 0;
    z[0] = f64::NEG_INFINITY;
    z[1] = f64::INFINITY;
    for q in 1..n {
        let fq = f[q] + (q * q) as f64;
        loop {
            let p = v[k];
            let s = (fq - (f[p] + (p * p) as f64)) / (2.0 * q as f64 - 2.0 * p as f64);
            if s <= z[k] && k > 0 {
                k -= 1;
            } else {
                k += 1;
                v[k] = q;
                z[k] = s;
                z[k + 1] = f64::INFINITY;
                break;
            }
        }
    }
    k = 0;
    for (q, out) in d.iter_mut().enumerate() {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let p = v[k];
        let dq = q as f64 - p as f64;
        *out = dq * dq + f[p];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pose::Pose2;
    use proptest::prelude::*;

    fn brute(grid: &OccupancyGrid, cap: f64) -> Vec<f32> {
        let g = grid.geometry();
        let sites: Vec<_> =
            (0..g.len()).filter(|&i| grid.cells()[i] == CellState::Occupied).map(|i| g.coord(i)).collect();
        (0..g.len())
            .map(|i| {
                let c = g.coord(i);
                let best = sites
                    .iter()
                    .map(|s| (((s.ix - c.ix).pow(2) + (s.iy - c.iy).pow(2)) as f64).sqrt())
                    .fold(f64::INFINITY, f64::min);
                (best * g.resolution_m()).min(cap) as f32
            })
            .collect()
    }

    #[test]
    fn single_site() {
        let g = GridGeometry::new(5, 4, 0.5, Pose2::IDENTITY).unwrap();
        let mut grid = OccupancyGrid::filled(g, CellState::Free);
        grid.set(CellCoord::new(1, 1), CellState::Occupied);
        let df = DistanceField::to_occupied(&grid, 10.0);
        assert_eq!(df.at_cell(CellCoord::new(1, 1)), 0.0);
        assert!((df.at_cell(CellCoord::new(4, 3)) - 0.5 * 13f32.sqrt()).abs() < 1e-6);
        assert_eq!(df.at_cell(CellCoord::new(9, 9)), 10.0);
        assert_eq!(df.at_world(Point2::new(0.6, 0.6)), 0.0);
    }

    #[test]
    fn no_site_gives_cap() {
        let g = GridGeometry::new(3, 3, 0.1, Pose2::IDENTITY).unwrap();
        let df = DistanceField::to_occupied(&OccupancyGrid::filled(g, CellState::Free), 2.0);
        assert!(df.distances_m().iter().all(|&d| d == 2.0));
    }

    proptest! {
        #[test]
        fn matches_brute_force(w in 1usize..24, h in 1usize..24, seed in any::<u64>(), density in 0.0f64..0.3) {
            let g = GridGeometry::new(w, h, 0.05, Pose2::IDENTITY).unwrap();
            let mut state = seed | 1;
            let cells = (0..w * h).map(|_| {
                state ^= state << 13; state ^= state >> 7; state ^= state << 17;
                if ((state >> 11) as f64 / (1u64 << 53) as f64) < density { CellState::Occupied } else { CellState::Free }
            }).collect();
            let grid = OccupancyGrid::from_cells(g, cells).unwrap();
            let df = DistanceField::to_occupied(&grid, 0.6);
            let want = brute(&grid, 0.6);
            for (a, b) in df.distances_m().iter().zip(&want) {
                prop_assert!((a - b).abs() < 1e-5, "{a} vs {b}");
            }
        }
    }
}
