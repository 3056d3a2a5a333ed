//! # mapkeeper-scenario
//!
//! The project's main job: the scenario generator (W_1 … W_N by seeded edits to movable
//! items), the initial map M_1 built by the occupancy mapper from an exploration run, the
//! closed-loop runner (simulator, a chain localiser on M_{i-1}, a baseline localiser on M_1 and
//! the map updater), and the hundred-world validation of Stefanini et al. (Sensors 2023,
//! §5.3.2) with its reports.
//!
//! ```
//! use mapkeeper_scenario::{GeneratorParams, generate_worlds};
//! use mapkeeper_sim::{Route, World};
//! let chain = generate_worlds(&World::default_warehouse(), &Route::default_warehouse(), 3, 1,
//!     &GeneratorParams::default()).unwrap();
//! assert_eq!(chain.worlds.len(), 3);
//! ```
#![warn(missing_docs)]

mod error;
pub mod figures;
pub mod generator;
pub mod mapping;
pub mod merge;
pub mod outline;
pub mod recovery;
pub mod report;
pub mod run_events;
pub mod runner;
pub mod sim_source;
pub mod validation;

pub use error::ScenarioError;
pub use generator::{Edit, GeneratorParams, StorageArea, WorldChain, default_storage_areas, generate_worlds};
pub use mapkeeper_grid::StagedDir;
pub use mapping::{InitialMap, MappingParams, build_initial_map};
pub use recovery::{RecoveryParams, RecoveryResults, RecoverySummary, run_recovery};
pub use run_events::{Kidnap, KidnapControl, KidnapRecord, LostPolicy, TimelineRecorder, TimelineSample, TrackSample};
pub use runner::{
    Clock, ErrorSample, LocStats, NoClock, RunInputs, RunnerParams, Trajectories, UpdaterCounts, WorldRun, run_world,
};
pub use sim_source::SimSource;
pub use validation::{
    Scores, SeedRecord, SeedRun, Shard, Summary, ValidationParams, ValidationRecord, WorldRow, run_seed, run_seed_in,
    summarise, summarise_records,
};
