//! # mapkeeper-grid
//!
//! The occupancy grid and everything that works on it without physics: coordinates (paper
//! eq. 1), grid traversal (Amanatides–Woo) and ray casting, the exact Euclidean distance
//! transform, ROS map_server I/O, the map-quality metrics (CC, MS, OPDF; structure retention
//! and change-class scores), a log-odds occupancy mapper, and rendering; plus small shared
//! pieces of plane geometry: points sorted into square buckets ([`buckets::PointBuckets`]) and
//! the even-odd point-in-polygon test ([`geometry::polygon_contains`]).
//!
//! This crate never depends on the simulator, rapier or parry (checked by `.ci/run`).
//!
//! ```
//! use mapkeeper_grid::{cast_ray, CellCoord, CellState, GridGeometry, OccupancyGrid, Point2, Pose2};
//! // A 2 m × 1 m room at 0.05 m with a wall at x = 1.5 m.
//! let geometry = GridGeometry::new(40, 20, 0.05, Pose2::IDENTITY).unwrap();
//! let mut map = OccupancyGrid::filled(geometry, CellState::Free);
//! for iy in 0..20 {
//!     map.set(CellCoord::new(30, iy), CellState::Occupied);
//! }
//! let hit = cast_ray(&map, Point2::new(0.5, 0.5), 0.0, 5.0, true);
//! assert!((hit.range_m - 1.0).abs() < 1e-9);
//! ```
#![warn(missing_docs)]

mod atomic;
pub mod buckets;
mod distance;
pub mod geometry;
mod grid;
pub mod map_io;
pub mod mapper;
pub mod metrics;
mod pose;
mod ray_caster;
pub mod render;
mod traversal;

pub use atomic::{AtomicFile, Leftover, OutputError, StagedDir, check_output_file, hidden_sibling, write_atomic};
pub use distance::DistanceField;
pub use grid::{CellCoord, CellState, ChangeKind, GridGeometry, MAX_CELLS, MAX_SIDE, OccupancyGrid};
pub use pose::{Point2, Pose2, PreparedPose, angle_diff, wrap_angle};
pub use ray_caster::{FreeDiscs, RayCaster, RayDir};
pub use traversal::{RayHit, RayStop, SegmentWalk, cast_ray, traverse, traverse_indexed};

/// Errors about grids themselves (file errors have their own type).
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum GridError {
    /// A grid needs at least one cell.
    #[error("grid has no cells ({width} × {height})")]
    EmptyGrid {
        /// Columns asked for.
        width: usize,
        /// Rows asked for.
        height: usize,
    },
    /// The grid is larger than this crate accepts.
    #[error("grid of {width} × {height} cells is larger than the limit of {max_cells} cells")]
    TooLarge {
        /// Columns asked for.
        width: usize,
        /// Rows asked for.
        height: usize,
        /// The limit.
        max_cells: usize,
    },
    /// Resolution must be finite and positive.
    #[error("resolution must be a finite positive number of metres per cell, got {0}")]
    BadResolution(f64),
    /// Origin must be finite.
    #[error("origin must be finite, got {0:?}")]
    BadOrigin(Pose2),
    /// Cell vector does not match the geometry.
    #[error("expected {expected} cells, got {got}")]
    CellCount {
        /// Cells the geometry has.
        expected: usize,
        /// Cells given.
        got: usize,
    },
    /// Two grids that must share geometry do not.
    #[error("the two grids differ in size, resolution or origin")]
    GeometryMismatch,
}
