//! # mapkeeper-updater
//!
//! The safe and robust map updater of Stefanini et al., "Safe and Robust Map Updating for
//! Long-Term Operations in Dynamic Environments" (Sensors 2023, §4). The source tree shows the
//! paper: [`paper`] holds one module per block of its Fig. 5 / Fig. 6, [`additions`] the
//! project's own additions (each named after the failure it prevents), [`support`] the code
//! both share. [`MapUpdater`] wires them in the paper's order.
//!
//! | file | paper section, or why it exists |
//! |---|---|
//! | `updater.rs` | Fig. 4-6: the pipeline of one step ([`MapUpdater`]); memory accounting |
//! | `updater/lost.rs` | §4.6 on a Lost step: pose updating, then the global search and the views kept while Lost (additions) |
//! | `params.rs` | the parameter table, App. A.1 (D_th), tol(z) of §4.3.2; presets ([`UpdaterParams`]); `params/legacy.rs` reads the removal gates' names of older files |
//! | `error.rs` | the crate's error type ([`UpdaterError`]) |
//! | `paper/gating.rs` | §4.5 ("update rate that depends on both linear and angular speed") and the parameter table (0.05 m, 20°) |
//! | `paper/beam_classifier.rs` | §4.1, eq. 2-5, Fig. 7-8, App. A.1 |
//! | `paper/localisation_check.rs` | §4.2, eq. 6-8 |
//! | `paper/changed_cells.rs` | §4.3: §4.3.1 (eq. 9, Fig. 10) and §4.3.2 (Fig. 11-13) |
//! | `paper/unchanged_cells.rs` | §4.4 |
//! | `paper/cell_update.rs` | §4.5 with border reconstruction (Fig. 14) |
//! | `paper/pose_updating.rs` | §4.6 (its hypotheses, own-cloud check, correlative search and fitness gate are the project's: the paper accepts any registration) |
//! | `paper/icp.rs` | §4.6's registration T(k) ("e.g. Iterative Closest Point"), here point-to-line |
//! | `additions/removal_gates.rs` | project addition: with the pose a fraction of a cell off, removal votes from rays that graze a wall or clip a corner erode walls and free obstacle interiors |
//! | `additions/grazing.rs` | project addition: the incidence test of the removal gates (a robot driving along a wall erodes it) |
//! | `additions/free_pass.rs` | project addition: cells free in `M_{i-1}` got only "changed" votes, so new obstacles came out 2-4 cells thick |
//! | `additions/shift_check.rs` | project addition (`mapkeeper` on alarm steps, `mapkeeper-shift` on every step): the change count cannot tell a wrong pose from a stale map; a nearby pose that fits better can |
//! | `additions/registration.rs` | project addition: a yaw error of a fraction of a degree (AMCL on a stale map) is written into the map and erodes fixed walls; each step's pose is refined against `M_{i-1}` first, and a poor or ambiguous fit writes nothing |
//! | `additions/surface_evidence.rs` | project addition (issue 53): the classifier is blind within D_th of the map's structure, so `M_1`'s thick faces, items moved a little and eroded faces stayed; per-cell trust-weighted hit/pass evidence over the last part of each beam, carried across worlds |
//! | `additions/structure_memory.rs` | project addition: long-standing structure was as easy to remove as yesterday's box, and an eroded wall face never came back; a cross-world memory of young cells and scars |
//! | `additions/global_search.rs` | project addition (issue 33): pose updating registers from the predicted pose, so a robot moved without its odometry seeing it was never found; a branch and bound over the whole map and every heading |
//! | `additions/recovery_views.rs` | project addition (issue 54): each attempt judged one step's scans, so two places that look alike from here were refused for ever and one that only this step fits was taken; earlier views of the Lost stretch placed by odometry, and the candidates of a refused attempt kept |
//! | `additions/log_odds_baseline.rs` | not a fix but a comparison baseline (plain log-odds mapping), asked for by the spec |
//! | `support/beam_walk.rs` | support: [`support::beam_walk::BeamGeometry`], p_th (eq. 9), the walk over buffered cells |
//! | `support/cell_buffers.rs` | support: the rolling buffers B_c of §4 (Fig. 6) and §4.5; the memory claim of §6 |
//! | `support/step_tolerance.rs` | support: [`StepTolerance`], a step's pose-uncertainty margins as the paper's tests apply them |
//! | `support/removal_filter.rs` | support: the hook of §4.3.1's removal votes ([`support::removal_filter::RemovalFilter`]; the paper's `PassAll`, the project's removal gates) |
//! | `support/hit_index.rs` | support: the step's hit points, bucketed (the removal gates' hit clearance) |
//! | `support/votes.rs` | support: vote packing, radix sort and merge shared by the evaluators and the cells update |
//! | `support/chessboard.rs` | support: the chessboard distance transform of pose updating's score grid and the global search's pyramid |
//!
//! All parameters are in [`UpdaterParams`]: presets `paper` (§4 read fairly, nothing added),
//! `paper-strict` (§4 at its strictest), `authors` (the behaviour of the authors' ROS code),
//! `mapkeeper` (the project's additions, each switchable), `mapkeeper-no-registration`, and the
//! ablations `always-update`, `no-update`, `log-odds`. The updater depends only on the grid
//! crate, plain sensor types and the common leaf (`ParamError`), so any localiser, a log file
//! or a real robot can feed it.
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
//! // This toy scan has 4 beams; the localisation check wants 20 by default.
//! let params = UpdaterParams { min_valid_beams: 4, ..UpdaterParams::paper() };
//! let mut updater = MapUpdater::new(map, params).unwrap();
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
//!     sweep: None,
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
    pub mod global_search;
    pub mod grazing;
    pub mod log_odds_baseline;
    pub mod pose_tolerance;
    pub mod recovery_views;
    pub mod registration;
    pub mod removal_gates;
    pub mod shift_check;
    pub mod structure_memory;
    pub mod surface_evidence;
}

/// Support code shared by the modules of both: the per-beam value type and the walk along a
/// beam, and the packing and sorting of votes.
pub mod support {
    pub mod beam_walk;
    pub mod cell_buffers;
    pub mod chessboard;
    pub mod hit_index;
    pub mod removal_filter;
    pub mod step_tolerance;
    pub mod votes;
}

mod error;
pub mod params;
mod updater;

pub use additions::global_search::{GlobalSearchParams, GlobalSearchReport};
pub use additions::pose_tolerance::{PoseSigma, StepTolerance, ToleranceParams};
pub use additions::registration::{Refusal, Registration, RegistrationParams};
pub use additions::shift_check::ShiftResult;
pub use additions::structure_memory::{CellRecord, MemoryParams, StructureMemory};
pub use additions::surface_evidence::{CellEvidence, EvidenceParams};
pub use error::UpdaterError;
pub use paper::cell_update::CellChange;
pub use paper::gating::GateReason;
pub use paper::icp::Fitness;
pub use paper::localisation_check::Verdict;
pub use paper::pose_updating::{PoseRecovery, RecoveryFailure};
pub use params::RemovalParams;
pub use params::{
    FlagRule, PRESET_NAMES, PoseUpdatingParams, RevertRule, UnchangedHitRule, UpdateMethod, UpdaterParams,
};
pub use updater::{MapUpdater, RegistrationStats, StepOutcome, StepReport, UpdaterStats};
