//! # mapkeeper-closed-loop
//!
//! The simulated closed loop every experiment runs, apart from the experiments themselves
//! (those and their reports are `mapkeeper-scenario`):
//!
//! - the worlds: the seeded evolution W_1 … W_N of a warehouse by edits to movable items
//!   ([`worlds::generator`]), the initial map M_1 built by the occupancy mapper from an
//!   exploration run ([`worlds::mapping`]) and a site read from a real map ([`worlds::site`]);
//! - the simulator as a sensor source of the harness ([`sim_source`]), and a simulated run
//!   written as a log ([`recording`]);
//! - the loop of one world ([`runner`]: the simulator, a chain localiser on M_{i-1}, a baseline
//!   localiser on M_1 and the map updater, through the harness's session), the experiments'
//!   controls and observers ([`controls`]: kidnaps, Lost handling, timelines) and the pose
//!   source of the updater ([`pose_oracle`]);
//! - what the robustness experiments share ([`setup`]: their worlds and maps, places on the
//!   tour, when a pose counts as recovered) and the one trial runner ([`trials`]).
//!
//! ```
//! use mapkeeper_closed_loop::{GeneratorParams, generate_worlds};
//! use mapkeeper_sim::{Route, World};
//! let chain = generate_worlds(&World::default_warehouse(), &Route::default_warehouse(), 3, 1,
//!     &GeneratorParams::default()).unwrap();
//! assert_eq!(chain.worlds.len(), 3);
//! ```
#![warn(missing_docs)]

pub mod controls;
mod error;
pub mod pose_oracle;
pub mod recording;
pub mod runner;
pub mod setup;
pub mod sim_source;
pub mod trials;
pub mod worlds;

pub use controls::{
    Kidnap, KidnapControl, KidnapRecord, LostCounts, LostEnd, LostEpisode, LostPolicy, TimelineRecorder,
    TimelineSample, TrackSample,
};
pub use error::{ExperimentError, check_route, check_turn};
pub use pose_oracle::{PoseNoise, UpdaterPoses};
pub use runner::{
    Checked, Clock, ErrorSample, Execution, LocStats, NoClock, RunInputs, RunOptions, RunnerParams, Trajectories,
    UpdaterCounts, WorldRun, run_world, run_world_with,
};
pub use setup::params::RecoveryParams;
pub use sim_source::{AheadSource, SimSource, Simulated};
pub use worlds::WorldsError;
pub use worlds::generator::{Edit, GeneratorParams, StorageArea, WorldChain, default_storage_areas, generate_worlds};
pub use worlds::mapping::{InitialMap, MappingParams, build_initial_map};
pub use worlds::site::{Site, SiteParams};
