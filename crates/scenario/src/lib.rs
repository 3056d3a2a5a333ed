//! # mapkeeper-scenario
//!
//! The experiments and their reports, each run on the simulated closed loop of
//! `mapkeeper-closed-loop` (or, for real logs, on the harness's log source): the hundred-world
//! validation of Stefanini et al. (Sensors 2023, §5.3.2) with its figures, HTML report, merge,
//! preset comparison and CI check; the recovery suite, check detection, Table 1 with a held
//! pose, kidnaps of the robot, real logs with reference poses, the localisers' convergence and
//! the sensor-realism sweep; the statistics the reports give ([`stats`]) and the claims the
//! reports check ([`results::claims`]).
#![warn(missing_docs)]

mod error;
pub mod experiments;
pub mod results;
pub mod stats;

pub use error::ScenarioError;
pub use experiments::ExperimentError;
pub use experiments::recovery::{RecoveryParams, RecoveryResults, RecoverySummary, run_recovery};
pub use experiments::validation::sweep::{SweepPlan, SweepSpec};
pub use experiments::validation::{
    GroundTruth, Scores, SeedRecord, SeedRun, Shard, Summary, ValidationParams, ValidationRecord, ValidationRun,
    WorldRow, run_seed, summarise, summarise_records,
};
pub use mapkeeper_grid::StagedDir;
pub use results::ResultsError;
