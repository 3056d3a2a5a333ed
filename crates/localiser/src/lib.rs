//! # mapkeeper-localiser
//!
//! An AMCL-grade Monte Carlo localiser (Fox et al. 1999; Thrun, Burgard & Fox 2005) on an
//! occupancy grid, without AMCL's known faults:
//!
//! - odometry motion models for omnidirectional and differential/skid-steer bases with the
//!   *corrected* variance forms ([`motion_model`]);
//! - the likelihood-field sensor model on the exact distance transform, precomputed once per map
//!   as a per-cell `ln p` table ([`LikelihoodField`]);
//! - any number of lidars used natively, each scan carrying its own `lidar_in_robot`;
//! - KLD-sampling adaptive particle count with O(N) systematic resampling, optional
//!   augmented-MCL recovery, update gating, pose and global (re-)initialisation, map replacement;
//! - one seeded `ChaCha8Rng` owned by the filter: the same seed gives bit-identical estimates;
//! - parameters validated once with typed errors; degenerate weights reported and recovered
//!   explicitly ([`UpdateOutcome::Degenerate`]), never a panic.
//!
//! It depends on the grid and the plain sensor types only, never on the simulator.
//!
//! ```
//! use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Pose2, cast_ray};
//! use mapkeeper_localiser::{FilterParams, Localiser, UpdateOutcome};
//! use mapkeeper_sensor::LaserScan;
//!
//! // A 4 m × 3 m room with walls on the border and a pillar.
//! let g = GridGeometry::new(80, 60, 0.05, Pose2::IDENTITY).unwrap();
//! let mut map = OccupancyGrid::filled(g, CellState::Free);
//! for i in 0..80 { map.set(CellCoord::new(i, 0), CellState::Occupied); map.set(CellCoord::new(i, 59), CellState::Occupied); }
//! for j in 0..60 { map.set(CellCoord::new(0, j), CellState::Occupied); map.set(CellCoord::new(79, j), CellState::Occupied); }
//! for i in 50..54 { for j in 20..24 { map.set(CellCoord::new(i, j), CellState::Occupied); } }
//!
//! // A 360° scan synthesised from the true pose.
//! let truth = Pose2::new(1.2, 1.4, 0.3);
//! let n = 180;
//! let inc = 2.0 * std::f64::consts::PI / n as f64;
//! let ranges_m = (0..n)
//!     .map(|i| cast_ray(&map, truth.position(), truth.yaw - std::f64::consts::PI + i as f64 * inc, 10.0, true).range_m as f32)
//!     .collect();
//! let scan = LaserScan { stamp_ns: 0, lidar_id: 0, lidar_in_robot: Pose2::IDENTITY,
//!     angle_min_rad: -std::f64::consts::PI, angle_increment_rad: inc, range_min_m: 0.05, range_max_m: 10.0, ranges_m, sweep: None };
//!
//! let mut params = FilterParams::default();
//! params.min_particles = 200;
//! params.max_particles = 1000;
//! params.update_min_d_m = 0.0; // update on every call, even standing still
//! let mut filter = Localiser::new(&map, params, 7).unwrap();
//! let cov = [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.01]];
//! filter.init_pose(Pose2::new(1.35, 1.3, 0.25), cov).unwrap();
//! for _ in 0..5 {
//!     let report = filter.update(Pose2::IDENTITY, std::slice::from_ref(&scan));
//!     assert_eq!(report.outcome, UpdateOutcome::Updated);
//! }
//! assert!(filter.estimate().pose_in_map.distance(&truth) < 0.05);
//! ```
#![warn(missing_docs)]

mod cluster;
mod filter;
mod kld;
mod likelihood_field;
pub mod motion_model;
mod params;
mod resample;
mod scan_match;

pub use cluster::{ClusterScratch, ClusterStats, best_cluster};
pub use filter::{Covariance3, Degeneracy, Estimate, FilterState, Localiser, Recovery, UpdateOutcome, UpdateReport};
pub use kld::{BinKey, Bins, count_bins, kld_bound};
pub use likelihood_field::{BeamSet, LikelihoodField, ParticleFrames, beam_likelihood, beam_log_likelihood, beam_term};
pub use params::{
    BeamCombination, BeamSelection, EstimateFrom, FilterParams, Kinematics, LOCALISER_PRESETS, LidarUpdates,
    MAX_PARTICLES_LIMIT, MotionParams, Resampler, UnknownCells, UpdateGate,
};
pub use resample::{multinomial_draw, systematic_resample};
pub use scan_match::{COARSE_YAW_STEP_RAD, Match, ScanMatchParams, ScanMatcher, Window};

use mapkeeper_common::ParamError;
use mapkeeper_grid::Pose2;

/// Everything that can go wrong when building or (re-)initialising a [`Localiser`].
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum LocaliserError {
    /// A parameter is out of its range (nothing is reset silently); its name is the field,
    /// e.g. `sigma_hit_m` or `motion.alpha1`.
    #[error("parameter {} = {} is invalid: {}", .0.name, .0.value, .0.requirement)]
    InvalidParameter(#[from] ParamError),
    /// `min_particles` exceeds `max_particles`.
    #[error("min_particles ({min}) must not exceed max_particles ({max})")]
    ParticleRange {
        /// Minimum given.
        min: usize,
        /// Maximum given.
        max: usize,
    },
    /// Augmented-MCL recovery needs both alphas zero (off) or `0 < slow < fast`.
    #[error("recovery alphas must both be 0 (off) or satisfy 0 < slow < fast <= 1, got slow {slow}, fast {fast}")]
    RecoveryAlphas {
        /// `recovery_alpha_slow`.
        slow: f64,
        /// `recovery_alpha_fast`.
        fast: f64,
    },
    /// An initial pose that is not finite.
    #[error("initial pose must be finite, got {0:?}")]
    NonFinitePose(Pose2),
    /// An initial covariance that cannot be sampled from.
    #[error("initial covariance {0}")]
    BadCovariance(&'static str),
    /// A localiser preset name that does not exist.
    #[error("unknown localiser preset '{name}' (known: {known})")]
    UnknownPreset {
        /// The name given.
        name: String,
        /// The known names, comma-separated.
        known: String,
    },
    /// Global initialisation on a map without free cells.
    #[error("the map has no free cell to spread particles over")]
    NoFreeSpace,
}
