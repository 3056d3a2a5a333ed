//! The hundred-world validation (paper §5.3.2) for one seed, and the summary over seeds.
//!
//! For a seed: generate W_1 … W_N; build M_1 in W_1 (exploration run) and report M_1/G_1; then
//! for i = 2 … N run the closed loop in W_i with the chain localiser and the updater on M_{i-1}
//! and the baseline localiser on M_1, and score M_1/G_i (static) and M_i/G_i (updated) with
//! CC, MS and OPDF, and M_i, M*_i and F_i by structure retention and change class
//! ([`crate::experiments::validation::erosion`]). The chain of worlds is sequential; seeds are independent,
//! so the caller may run them in parallel and merge them in seed order ([`summarise`]).

pub mod check;
pub mod checkpoint;
pub mod comparison;
pub mod erosion;
pub mod eta;
pub mod figures;
pub mod markdown;
pub mod merge;
pub mod params;
pub mod record;
pub mod report;
pub mod run;
pub mod saved_worlds;
pub mod sensor_realism;
pub mod summary;
pub mod sweep;

pub use crate::experiments::scores::Scores;
pub use crate::stats::histogram_median;
pub use params::{GroundTruth, Shard, ValidationParams};
pub use record::{
    GroundTruthScores, RUNS_FORMAT, RUNS_FORMAT_VERSION, SavedWorld, SeedRecord, SeedRun, ValidationRecord, WorldRow,
    scan_time_histogram,
};
pub use run::{ValidationRun, mcap_name, run_seed};
pub use summary::{
    BestAchievable, BestSummary, ByGroundTruth, GroundTruthQuality, HeavyChange, LocSummary, Localisation, MapQuality,
    MetricSummary, Summary, UpdaterSummary, interval_units, summarise, summarise_records,
};
