//! The flags of `mapkeeper validate` and their defaults.

use super::save_maps::SaveMaps;
use mapkeeper_scenario::{GroundTruth, Shard};
use std::path::PathBuf;

/// Arguments of `mapkeeper validate`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Default: the paper's setting on one hold-out seed: presets paper and \
mapkeeper side by side (a sweep, below), the amcl localiser, seed 11, a hundred worlds (about 3.5 min on \
two cores: 200 s measured). With one seed, each 95 % interval is over 10 batches of consecutive worlds \
(how precisely this seed's chain pins its mean); --seeds 3 gives the interval over seeds (the second \
release's default, seeds 11-13: about 11 min). --preset P runs one preset into OUT itself.\n\n\
For each seed: generate W_1 … W_N; build M_1 in W_1 with the log-odds mapper; in each \
W_i (i ≥ 2) drive the route with a chain localiser on M_{i-1} (feeding the updater, which makes M_i; \
--poses true or true+noise feeds it the true pose instead, with or without noise) and a baseline localiser on M_1; score M_1/G_i and M_i/G_i with CC, MS, OPDF.\n\n\
Output in OUT (default results/validate-s<SEED>-<N>w-<counter>): runs.json, summary.json, worlds.csv, \
report.md, report.html (the report as one self-contained page, with a world stepper), edits.json, plots/ \
(Fig. 24-27, SVG and PNG), seed-S/maps (M_i, G_i and E_i, the errors of M_i against G_i as a PNG, of W_1 and \
the saved worlds: W_2, W_50, W_100, W_N, or --save-maps), seed-S/trajectories (TUM: true, chain, baseline), and with --world \
world.toml (the world as resolved: its storage areas and route, read, derived or planned). Results are identical whatever --jobs; only \
wall_time_s and median_scan_us vary (not with --no-timing).\n\n\
Sharding: --shard k/N runs the k-th of N contiguous slices of the seeds; `mapkeeper merge` combines the \
shards' folders into the folder of the whole run.\n\n\
Sweeps over presets: --presets a,b,… makes the job list (preset × seed), preset by preset; each preset's \
results go to OUT/<preset>/ (a folder as above), and --shard slices that job list. OUT/summary.json and \
OUT/report.md compare the presets side by side: one row per preset (and per preset and seed with several \
seeds) with the map-quality means (M_1/G_i, M_i/G_i, M_N/G_N), the share of worlds where M_i beats M_1, the \
localisation error means on M_1 and M_{i-1}, the verdict counts and the Lost handling (episodes, attempts, \
recoveries, give-ups, time stopped). Merge sharded sweeps whole (mapkeeper merge s1 s2 s3 --out all: preset \
by preset, then the comparison) or preset by preset (mapkeeper merge s1/paper s2/paper --out all/paper).")]
pub struct Args {
    /// Number of worlds N, 2 to 10000 (100 × the paper's hundred worlds: many hours per seed).
    #[arg(long, value_name = "N", default_value_t = 100, value_parser = crate::cmd::count_in(2, crate::cmd::MAX_WORLDS), allow_hyphen_values = true)]
    pub worlds: usize,
    /// First run seed (any whole number from 0 to 2^64 − 1). The default, 11, is the first
    /// hold-out seed: seeds 1-3 tuned the `mapkeeper` preset and are never the reported ones.
    #[arg(long, value_name = "S", default_value_t = DEFAULT_SEED, value_parser = crate::cmd::seed, allow_hyphen_values = true)]
    pub seed: u64,
    /// Number of seeds (seed, seed+1, …), run in parallel; 1 to 100000 (each seed is a whole
    /// validation). One seed gives 95 % intervals over batches of its worlds (with 20 updated
    /// worlds or more); 2 or more the paired intervals over seeds, 3 or more of a useful width
    /// (t(0.975, 1) = 12.7). The default, 1, keeps the main job near 3.5 minutes on two cores.
    #[arg(long, value_name = "K", default_value_t = 1, value_parser = crate::cmd::count_in(1, crate::cmd::MAX_SEEDS), allow_hyphen_values = true)]
    pub seeds: usize,
    /// One updater preset: paper, paper-strict, authors, mapkeeper, mapkeeper-evidence, mapkeeper-no-registration, mapkeeper-shift,
    /// always-update, no-update, log-odds (results
    /// in OUT itself). Without --preset or --presets: the sweep paper,mapkeeper.
    #[arg(long)]
    pub preset: Option<String>,
    /// TOML file overriding any field of the updater preset(s) (unknown keys are errors), e.g.
    /// `removal.hit_clearance_m = 0.1`; recorded in summary.json with the preset's name.
    #[arg(long, value_name = "FILE")]
    pub updater_params: Option<PathBuf>,
    /// A sweep over several presets (comma-separated, e.g. paper,always-update): jobs are
    /// (preset × seed); each preset's results go to `OUT/<preset>/` [default: paper,mapkeeper].
    #[arg(long, value_name = "P1,P2,…", conflicts_with = "preset", value_delimiter = ',')]
    pub presets: Option<Vec<String>>,
    /// Localiser preset of the chain and baseline localisers: mapkeeper, mapkeeper-real, amcl or amcl-joint
    /// (docs/localiser.md); recorded in summary.json and report.md. The default, amcl, is the
    /// filter the paper ran.
    #[arg(long, value_name = "NAME", default_value = "amcl")]
    pub localiser: String,
    /// Ground truth of the map metrics: `exact` (the raster of all geometry, whole grid) or
    /// `observed` (what a noise-free mapper sees from the exploration route in W_i, over the
    /// interior of the outer walls; the paper's G_i were such SLAM maps). The other variant and
    /// the best achievable map are reported beside it.
    #[arg(long, value_name = "exact|observed", default_value = "exact", value_parser = str::parse::<GroundTruth>)]
    pub ground_truth: GroundTruth,
    #[command(flatten)]
    pub site: crate::cmd::shared_args::WorldArgs,
    #[command(flatten)]
    pub output: crate::cmd::shared_args::OutputArgs,
    #[command(flatten)]
    pub threads: crate::cmd::shared_args::JobsArg,
    /// Resume a killed run (needs --out): every finished (preset, seed) job is kept in
    /// `.NAME.jobs/` beside OUT until the run completes; with --resume those jobs are read back
    /// rather than run again (the outputs are the same), and an OUT already complete is left as
    /// it is. Without --resume a new run discards them.
    #[arg(long, requires = "out", conflicts_with = "force")]
    pub resume: bool,
    /// Drive only the first this-many metres of the route (quick checks); > 0 and ≤ 10000 m
    /// (the default tour is 72 m: longer values drive all of it).
    #[arg(long, value_name = "METRES", value_parser = crate::cmd::route_length, allow_hyphen_values = true)]
    pub route_length: Option<f64>,
    /// Update the map only in every k-th world (W_2, W_{2+k}, …; the robot drives the others
    /// with the updater off), 1 to 10000 [default: 1]: k worlds of change meet the check at once.
    /// summary.json gains `heavy_change` (Suspend and Lost shares, stuck worlds).
    #[arg(long, value_name = "K", value_parser = crate::cmd::count_in(1, 10_000), allow_hyphen_values = true)]
    pub update_every: Option<usize>,
    /// Integrate the fresh map F_i (each world remapped from its run alone, the comparator of
    /// updating) from every k-th processed step, 1 to 10000 [default: M_1's stride, 2]: larger k
    /// costs less and maps from fewer scans. The report says the rate it used.
    #[arg(long, value_name = "K", value_parser = crate::cmd::count_in(1, 10_000), allow_hyphen_values = true)]
    pub fresh_map_every: Option<usize>,
    /// Smallest distance from an edited item to the route, metres (the generator's
    /// `route_clearance_m`, default 0.98: the robot's width plus 0.3 m); smaller values put
    /// edits near the route.
    #[arg(long, value_name = "METRES", value_parser = crate::cmd::real_in(0.0, 100.0, "m"), allow_hyphen_values = true)]
    pub route_clearance: Option<f64>,
    /// Harder worlds: from W_2 on, each world's tour starts at a seeded waypoint and is driven
    /// either way, the robot starting there (the paper: one route, one start).
    #[arg(long)]
    pub route_variants: bool,
    /// Harder worlds: from W_2 on, people stop and stand at each waypoint for a seeded time up to
    /// this many seconds, 0 to 600 (the paper: people keep walking).
    #[arg(long, value_name = "SECONDS", value_parser = crate::cmd::real_in(0.0, 600.0, "s"), allow_hyphen_values = true)]
    pub people_pause_s: Option<f64>,
    /// Worlds whose drive is also written as a ROS 2 MCAP bag (scans, odometry, /tf, truth,
    /// estimate, particles, verdicts, the map as it changes; docs/real-data.md), comma-separated
    /// world numbers from 2 to --worlds: `OUT[/PRESET]/mcap/PRESET-sSEED-WNNN.mcap`.
    #[arg(long, value_name = "I,J", value_delimiter = ',', value_parser = crate::cmd::count_in(2, crate::cmd::MAX_WORLDS), allow_hyphen_values = true)]
    pub mcap_worlds: Vec<usize>,
    /// Worlds whose maps are kept: `all`, or comma-separated world numbers from 2 to --worlds
    /// [default: 2,50,100 and the last]. Each keeps M_i, G_i, the error image E_i and the
    /// trajectories in seed-S/; report.md lists them and report.html steps through them.
    #[arg(long, value_name = "all|I,J", value_parser = str::parse::<SaveMaps>, allow_hyphen_values = true)]
    pub save_maps: Option<SaveMaps>,
    #[command(flatten)]
    pub timing: crate::cmd::shared_args::TimingArg,
    /// Run only the k-th of N slices of the seeds (1 ≤ k ≤ N ≤ --seeds); merge the shards'
    /// folders with `mapkeeper merge`.
    #[arg(long, value_name = "k/N", value_parser = str::parse::<Shard>, allow_hyphen_values = true)]
    pub shard: Option<Shard>,
    /// Robot file and sensor realism (recorded in summary.json's parameters when not the
    /// defaults).
    #[command(flatten)]
    pub sensor: crate::cmd::sensor::SensorArgs,
    /// The updater's pose source (recorded in summary.json's parameters and in report.md when
    /// not the chain localiser).
    #[command(flatten)]
    pub poses: crate::cmd::poses::PoseArgs,
}

/// First seed of the default run (after the tuning seeds 1-3 of the algorithms issue).
pub(super) const DEFAULT_SEED: u64 = 11;

/// Presets of the default run: the paper as written beside this project's preset.
pub(super) const DEFAULT_PRESETS: [&str; 2] = ["paper", "mapkeeper"];

pub(super) fn default_out(seed: u64, worlds: usize, shard: Option<Shard>) -> PathBuf {
    let part = shard.map(|s| format!("-shard{}of{}", s.index, s.count)).unwrap_or_default();
    crate::cmd::numbered_out(&format!("validate-s{seed}-{worlds}w{part}"))
}
