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
pub mod experiments;
pub mod recording;
pub mod results;
pub mod sim_source;
pub mod stats;
pub mod worlds;

pub use error::ScenarioError;
pub use experiments::ExperimentError;
pub use experiments::pose_oracle::{PoseNoise, UpdaterPoses};
pub use experiments::recovery::{RecoveryParams, RecoveryResults, RecoverySummary, run_recovery};
pub use experiments::run_events::{
    Kidnap, KidnapControl, KidnapRecord, LostCounts, LostEnd, LostEpisode, LostPolicy, TimelineRecorder,
    TimelineSample, TrackSample,
};
pub use experiments::runner::{
    Clock, ErrorSample, LocStats, NoClock, RunInputs, RunOptions, RunnerParams, Trajectories, UpdaterCounts, WorldRun,
    run_world, run_world_with,
};
pub use experiments::validation::sweep::{SweepPlan, SweepSpec};
pub use experiments::validation::{
    GroundTruth, Scores, SeedRecord, SeedRun, Shard, Summary, ValidationParams, ValidationRecord, WorldRow, run_seed,
    run_seed_in, summarise, summarise_records,
};
pub use mapkeeper_grid::StagedDir;
pub use results::ResultsError;
pub use sim_source::{AheadSource, SimSource, Simulated};
pub use worlds::WorldsError;
pub use worlds::generator::{Edit, GeneratorParams, StorageArea, WorldChain, default_storage_areas, generate_worlds};
pub use worlds::mapping::{InitialMap, MappingParams, build_initial_map};
pub use worlds::site::{Site, SiteParams};
