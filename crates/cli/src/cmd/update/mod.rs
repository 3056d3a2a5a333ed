//! `mapkeeper update`: runs the map updater over recorded data (a sensor log and a map), the
//! path by which a real robot's logs are processed.

mod inputs;

pub use inputs::load_updater_params;
use inputs::{MAX_SYNC_WINDOW_S, pose_input, replay_options};

use anyhow::Context;
use mapkeeper_grid::map_io::{load_map, save_map};
use mapkeeper_harness::jobs::update::update_log;
use mapkeeper_harness::mcap_out::McapRecorder;
use mapkeeper_harness::{LogSource, Observer};
use mapkeeper_sensor::write_tum;
use std::path::PathBuf;

/// Arguments of `mapkeeper update`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Runs the safe and robust map updater (Stefanini et al. 2023) over recorded data.\n\n\
Input: a ROS map_server map (M_{i-1}) and a recorded log (--log: a folder holding log.jsonl, a ROS 2 \
MCAP bag, a ROS 1 bag or a CARMEN log; scans with their lidar mounting poses, odometry, optionally true \
poses; docs/real-data.md). Scans from several lidars are processed \
together as one step when their stamps lie within --sync-window-s of the step's first scan (at most one \
scan per lidar: a second scan of a lidar starts a new step; 0 = only equal stamps); the step's stamp is \
its latest scan's.\n\n\
Robot pose per step (the localiser's estimate), linearly interpolated at the scan stamp:\n  \
--poses FILE.tum   a TUM trajectory (t x y z qx qy qz qw, '#' comments), e.g. from a localiser;\n  \
--true-poses       the log's truth records;\n  \
--localise         the chain localiser (--localiser) run over the log on the map being updated \
(from the log's first true pose, else globally), its estimate written to OUT/poses.tum; a pose that \
pose updating recovers after a Lost verdict is handed back to it (and to the updater), the episodes \
written to OUT/lost.csv;\n  \
(none of these)    the log's odometry, aligned so that the first odometry pose coincides with the \
first true pose if the log has truth records, otherwise with the map frame's origin (0, 0, 0).\n\
Odometry (for the update gating and pose updating) always comes from the log's odom records; \
without any, the chosen robot pose stands in for it.\n\n\
Output in OUT (written atomically; an existing non-empty folder is refused without --force): \
map.yaml + map.pgm (M_i), scans.csv with one row per step: time_s, outcome (processed, gated, \
no_valid_beams), verdict (update, suspend, lost or empty), n, n_invalid, n_dc, cells_changed, recovery \
(recovered, not_recovered or empty), microseconds of the updater call; recovered.tum, the poses \
pose updating returned (TUM, possibly empty); and recoveries.csv, one row per attempt of pose updating: \
time_s, verdict (lost), result (recovered or refused), x_m, y_m, yaw_rad (the recovered pose; empty when \
refused), reason (why it was refused; empty when recovered).")]
pub struct Args {
    /// The map to update, ROS map_server YAML (with its PGM/PNG image).
    #[arg(long, value_name = "MAP.yaml")]
    pub map: PathBuf,
    /// The recorded log and how to read it.
    #[command(flatten)]
    pub input: super::log_input::LogInput,
    /// Robot poses in the map from a TUM trajectory file.
    #[arg(long, value_name = "FILE.tum", conflicts_with = "true_poses")]
    pub poses: Option<PathBuf>,
    /// Use the log's true poses as the robot pose estimate.
    #[arg(long, conflicts_with = "localise")]
    pub true_poses: bool,
    /// Run the chain localiser (--localiser, on the map being updated) over the log and give the
    /// updater its estimate: the paper's loop on recorded data. Writes OUT/poses.tum.
    #[arg(long, conflicts_with = "poses")]
    pub localise: bool,
    /// With --localise: the localiser preset, auto (mapkeeper-real for an imported bag or
    /// CARMEN log, mapkeeper for this project's own log.jsonl), mapkeeper, mapkeeper-real, amcl
    /// or amcl-joint.
    #[arg(long, value_name = "NAME", default_value = "auto", requires = "localise")]
    pub localiser: String,
    /// With --localise: TOML overriding any FilterParams field of the localiser preset.
    #[arg(long, value_name = "FILE.toml", requires = "localise")]
    pub localiser_params: Option<PathBuf>,
    /// With --localise: the localiser's seed (any whole number from 0 to 2^64 − 1).
    #[arg(long, value_name = "S", default_value_t = 0, value_parser = super::seed, allow_hyphen_values = true)]
    pub seed: u64,
    /// Parameter preset: mapkeeper (default: the recommended one), paper (§4 read fairly),
    /// paper-strict, authors, mapkeeper-evidence (issue 53's surface evidence), mapkeeper-no-registration, mapkeeper-shift, always-update,
    /// no-update, log-odds (docs/updater.md).
    #[arg(long, value_name = "NAME", default_value = "mapkeeper")]
    pub preset: String,
    /// TOML file overriding any field of the preset (same names as UpdaterParams; tables for
    /// pose_updating and log_odds).
    #[arg(long, value_name = "FILE.toml")]
    pub params: Option<PathBuf>,
    /// Scans of different lidars within this many seconds of a step's first scan form one step
    /// (0 to 10 s, far longer than any lidar's scan period; 0 = only scans with equal stamps).
    #[arg(long, value_name = "SECONDS", default_value_t = 0.05, value_parser = super::real_in(0.0, MAX_SYNC_WINDOW_S, "s"), allow_hyphen_values = true)]
    pub sync_window_s: f64,
    #[command(flatten)]
    pub output: super::shared_args::RequiredOutputArgs,
    #[command(flatten)]
    pub timing: super::shared_args::TimingArg,
    /// Also write the run as a ROS 2 MCAP bag (scans, odometry, /tf, the poses given, the
    /// verdict per scan, the map as it changes; docs/real-data.md) for Foxglove or ros2 bag.
    #[arg(long, value_name = "FILE.mcap")]
    pub mcap: Option<PathBuf>,
    /// Give the estimators the scans as recorded: without it, scans with a known beam timing
    /// (a bag's time_increment) are deskewed by the odometry over their sweep first.
    #[arg(long)]
    pub no_deskew: bool,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let options = replay_options(&args)?;
    let params = load_updater_params(&args.preset, args.params.as_deref())?;
    let map = load_map(&args.map)?;
    super::log_input::check_localiser(&args.localiser)?;
    let (log, log_path, imported) = args.input.read_with_origin()?;
    if args.localise {
        super::log_input::require_odometry(&log, &log_path)?;
    }
    let source = LogSource::new(log, log_path.display().to_string(), options);
    let poses = pose_input(&args, imported)?;
    let dir = super::output_dir(&args.output.out, args.output.force)?;
    let mut recorder = args.mcap.as_deref().map(McapRecorder::create).transpose()?;
    let mut observers: Vec<&mut dyn Observer> = recorder.iter_mut().map(|r| r as &mut dyn Observer).collect();
    let r = update_log(source, map, params, poses, args.timing.clock(&super::Wall::start()), &mut observers)
        .context("map update")?;
    let mcap = recorder.map(|rec| rec.finish(Some(&r.map))).transpose()?;
    save_map(&r.map, &dir.file("map.yaml")?)?;
    dir.write("scans.csv", r.steps_csv.as_bytes())?;
    write_tum(&dir.file("recovered.tum")?, &r.recovered_poses)?;
    dir.write("recoveries.csv", r.recoveries_csv.as_bytes())?;
    if args.localise {
        write_tum(&dir.file("poses.tum")?, &r.poses)?;
        dir.write("lost.csv", mapkeeper_harness::lost::episodes_csv(&r.lost_episodes).as_bytes())?;
    }
    let out = dir.finish()?;
    let s = r.stats;
    outln!(
        "{} steps: {} processed, {} gated, {} without valid beams; verdicts update/suspend/lost {}/{}/{}; \
         {} cell changes; recoveries {} ok / {} refused; wrote {}",
        s.steps,
        s.processed,
        s.gated,
        s.skipped_no_valid_beam,
        s.updates,
        s.suspends,
        s.losts,
        s.cell_changes,
        s.recoveries,
        s.failed_recoveries,
        out.display()
    );
    if args.localise {
        outln!("lost handling: {}", r.lost);
    }
    if let Some(p) = mcap {
        outln!("wrote {}", p.display());
    }
    Ok(())
}
