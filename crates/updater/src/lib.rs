//! # mapkeeper-updater
//!
//! The safe and robust map updater of Stefanini et al., "Safe and Robust Map Updating for
//! Long-Term Operations in Dynamic Environments" (Sensors 2023, §4), one module per concept of
//! the paper, in its order:
//!
//! 1. [`gating`]: update gating (process a scan after 0.05 m or 20° of motion);
//! 2. [`beam_classifier`]: 1-to-N comparison of each beam with virtual rays cast in `M_{i-1}`,
//!    D_th(z) (eq. 2-5, Appendix A.1);
//! 3. [`localisation_check`]: Update / Suspend / Lost (eq. 6-8);
//! 4. [`changed_cells`] and 5. [`unchanged_cells`]: the two evaluators (§4.3, §4.4);
//! 6. [`cell_buffers`] and [`cell_update`]: sparse rolling buffers, the flip rule and border
//!    reconstruction (§4.5, Fig. 14);
//! 7. [`pose_updating`] with [`icp`]: pose recovery when Lost (§4.6), with a fitness gate.
//!
//! All parameters are in [`UpdaterParams`] (presets `paper`, `reference`, `always-update`,
//! `no-update`, `log-odds`). The updater depends only on the grid crate and plain sensor types,
//! so any localiser, a log file or a real robot can feed it.
//!
//! ```
//! use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Pose2};
//! use mapkeeper_sensor::LaserScan;
//! use mapkeeper_updater::{MapUpdater, UpdaterParams, Verdict};
//! // A 4 m × 4 m room with walls, at 0.05 m.
//! let g = GridGeometry::new(80, 80, 0.05, Pose2::IDENTITY).unwrap();
//! let mut map = OccupancyGrid::filled(g, CellState::Free);
//! for k in 0..80 {
//!     for c in [CellCoord::new(k, 0), CellCoord::new(k, 79), CellCoord::new(0, k), CellCoord::new(79, k)] {
//!         map.set(c, CellState::Occupied);
//!     }
//! }
//! let mut updater = MapUpdater::new(map, UpdaterParams::paper()).unwrap();
//! // A 360° lidar at the centre that sees exactly the map: the wall is 1.95 m away along x.
//! let robot = Pose2::new(2.0, 2.0, 0.0);
//! let scan = LaserScan {
//!     stamp_ns: 0,
//!     lidar_id: 0,
//!     lidar_in_robot: Pose2::IDENTITY,
//!     angle_min_rad: 0.0,
//!     angle_increment_rad: std::f64::consts::FRAC_PI_2,
//!     range_min_m: 0.05,
//!     range_max_m: 30.0,
//!     ranges_m: vec![1.95; 4],
//! };
//! let report = updater.process(robot, robot, &[scan]);
//! assert_eq!(report.verdict, Some(Verdict::Update));
//! assert_eq!(report.n_dc, 0);
//! assert!(report.changed_cells.is_empty());
//! ```
#![warn(missing_docs)]

/// The modules of the paper's §4, one per block of Fig. 5 / Fig. 6.
pub mod paper {
    pub mod beam_classifier;
    pub mod cell_buffers;
    pub mod cell_update;
    pub mod changed_cells;
    pub mod gating;
    pub mod icp;
    pub mod localisation_check;
    pub mod pose_updating;
    pub mod unchanged_cells;
}

/// The project's own additions, not in the paper: each names the failure it prevents.
pub mod additions {
    pub mod free_pass;
    pub mod grazing;
    pub mod hit_index;
    pub mod log_odds_baseline;
}

mod error;
pub mod params;
mod updater;

pub use error::UpdaterError;
pub use paper::cell_update::CellChange;
pub use paper::gating::GateReason;
pub use paper::icp::Fitness;
pub use paper::localisation_check::Verdict;
pub use paper::pose_updating::{PoseRecovery, RecoveryFailure};
pub use params::{PRESET_NAMES, PoseUpdatingParams, UpdateMethod, UpdaterParams};
pub use updater::{MapUpdater, StepOutcome, StepReport, UpdaterStats};
