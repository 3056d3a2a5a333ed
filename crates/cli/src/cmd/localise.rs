//! `mapkeeper localise`: the particle-filter localiser over a recorded sensor log.

use super::log_input::{check_localiser, resolve_localiser};
use super::{load_params, parse_pose};
use anyhow::Context;
use mapkeeper_grid::{Pose2, map_io};
use mapkeeper_harness::jobs::localise::localise_log;
use mapkeeper_harness::mcap_out::McapRecorder;
use mapkeeper_harness::{LogSource, Observer, ReplayOptions};
use mapkeeper_localiser::FilterParams;
use mapkeeper_sensor::write_tum_with_comment;
use std::path::PathBuf;

/// Arguments of `mapkeeper localise`.
#[derive(clap::Args, Debug)]
#[command(
    long_about = "Run the particle-filter localiser (likelihood field, KLD sampling, multi-lidar; \
docs/localiser.md) over a recorded log (a folder holding log.jsonl, a ROS 2 MCAP bag, a ROS 1 bag or a CARMEN log; \
docs/real-data.md) and a map.\n\n\
Scans with the same stamp_ns (one per lidar) form one filter update, driven by the latest odometry \
reading at or before that time; updates before the first odometry reading are skipped. The filter \
starts at --init with the preset's initial covariance (initial_cov_*: AMCL's default, σ 0.5 m, 0.5 m, \
π/12 rad, in both presets); without --init, at the log's true pose at the first scan's time (same covariance) if the log has truth records, otherwise \
globally (particles uniform over the map's free space).\n\n\
Writes OUT/estimate.tum (one line per update: `t x y z qx qy qz qw`, t in seconds with 9 decimals \
on the log's clock, z = 0, yaw as a quaternion about z; a first `#` line records the seed and \
inputs) and OUT/covariance.csv (time_s, trace of the 3×3 (x, y, yaw) covariance, its largest \
eigenvalue lambda_max, particles, ess) and OUT/params.json (the localiser preset, the seed and every \
filter parameter used), each written atomically. With truth records it prints the \
position and yaw RMSE of the estimates against the truth interpolated at their times.",
    after_help = "Examples:\n  mapkeeper localise --log run1 --map run1/map.yaml --out run1/loc\n  \
mapkeeper localise --log run1 --map m0.yaml --out loc --init 0.5,-2.0,1.57 --params amcl.toml --seed 3"
)]
pub struct Args {
    /// The recorded log and how to read it.
    #[command(flatten)]
    pub input: super::log_input::LogInput,
    /// The map to localise on (ROS map_server YAML).
    #[arg(long, value_name = "MAP.yaml")]
    pub map: PathBuf,
    #[command(flatten)]
    pub output: super::shared_args::RequiredOutputArgs,
    /// Initial pose in the map frame: x (m), y (m), yaw (rad), comma-separated; |x|, |y| ≤ 1e6 m,
    /// |yaw| ≤ 6.3 rad (a turn: a larger yaw is most likely in degrees).
    #[arg(long, value_name = "X,Y,YAW", value_parser = parse_pose, allow_hyphen_values = true)]
    pub init: Option<Pose2>,
    /// Localiser preset: auto (mapkeeper-real for an imported bag or CARMEN log, mapkeeper for
    /// this project's own log.jsonl), mapkeeper, mapkeeper-real, amcl or amcl-joint
    /// (docs/localiser.md). --params overrides its fields.
    #[arg(long, value_name = "NAME", default_value = "auto")]
    pub localiser: String,
    /// TOML file overriding any FilterParams field of the preset (unknown keys are errors), e.g.
    /// `max_particles = 2000` or `[motion]` `alpha3 = 0.1`.
    #[arg(long, value_name = "FILE.toml")]
    pub params: Option<PathBuf>,
    /// Seed of the filter's random stream (same seed ⇒ identical output; any whole number from
    /// 0 to 2^64 − 1).
    #[arg(long, value_name = "S", default_value_t = 0, value_parser = super::seed, allow_hyphen_values = true)]
    pub seed: u64,
    /// Also write the run as a ROS 2 MCAP bag (scans, odometry, /tf, truth, estimate, particle
    /// cloud; docs/real-data.md) for Foxglove or ros2 bag.
    #[arg(long, value_name = "FILE.mcap")]
    pub mcap: Option<PathBuf>,
    /// Give the estimators the scans as recorded: without it, scans with a known beam timing
    /// (a bag's time_increment) are deskewed by the odometry over their sweep first.
    #[arg(long)]
    pub no_deskew: bool,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    check_localiser(&args.localiser)?;
    let (log, log_path, imported) = args.input.read_with_origin()?;
    super::log_input::require_odometry(&log, &log_path)?;
    let localiser = resolve_localiser(&args.localiser, imported).to_string();
    let preset = FilterParams::preset(&localiser).context("--localiser")?;
    let params = load_params(preset, args.params.as_deref(), FilterParams::validate)?;
    let options = ReplayOptions { deskew: !args.no_deskew, ..ReplayOptions::default() };
    let source = LogSource::new(log, log_path.display().to_string(), options);
    let map = map_io::load_map(&args.map).with_context(|| format!("cannot load map {}", args.map.display()))?;
    let dir = super::output_dir(&args.output.out, args.output.force)?;

    let mut recorder = args.mcap.as_deref().map(McapRecorder::create).transpose()?;
    let mut observers: Vec<&mut dyn Observer> = recorder.iter_mut().map(|r| r as &mut dyn Observer).collect();
    let (r, init) = localise_log(source, &map, params, args.init, args.seed, &mut observers).context("localisation")?;
    let mcap = recorder.map(|r| r.finish(None)).transpose()?;
    let comment = format!(
        "mapkeeper localise: localiser {localiser}, seed {}, log {}, map {}, init {init}",
        args.seed,
        log_path.display(),
        args.map.display()
    );
    write_tum_with_comment(&dir.file("estimate.tum")?, &comment, &r.estimates)?;
    dir.write("covariance.csv", r.covariance_csv.as_bytes())?;
    let record = serde_json::json!({ "localiser": localiser, "seed": args.seed, "filter": params });
    dir.write("params.json", format!("{}\n", serde_json::to_string_pretty(&record)?).as_bytes())?;
    let out = dir.finish()?;
    outln!(
        "{} updates ({} sensor updates, {} degenerate and recovered, {} without usable beams); \
{} scan times before the first odometry skipped; init {init}; localiser {localiser}; seed {}",
        r.updates,
        r.sensor_updates,
        r.degenerate,
        r.no_beams,
        r.no_odometry,
        args.seed
    );
    if let Some((pos, yaw, n)) = r.rmse {
        outln!("position RMSE {pos:.4} m, yaw RMSE {:.3} deg over {n} estimates", yaw.to_degrees());
    }
    outln!("wrote {0}/estimate.tum, {0}/covariance.csv and {0}/params.json", out.display());
    if let Some(p) = mcap {
        outln!("wrote {}", p.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameter_files_override_and_are_checked() {
        let dir = std::env::temp_dir().join(format!("mapkeeper-localise-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let load = |p: &std::path::Path| load_params(FilterParams::default(), Some(p), FilterParams::validate);
        let good = dir.join("good.toml");
        std::fs::write(&good, "max_particles = 800\nkinematics = \"differential\"\n[motion]\nalpha3 = 0.1\n").unwrap();
        let p = load(&good).unwrap();
        assert_eq!((p.max_particles, p.motion.alpha3, p.min_particles), (800, 0.1, 500));
        let unknown = dir.join("unknown.toml");
        std::fs::write(&unknown, "max_particle = 800\n").unwrap();
        let e = format!("{:#}", load(&unknown).unwrap_err());
        assert!(e.contains("unknown.toml") && e.contains("max_particle"), "{e}");
        let invalid = dir.join("invalid.toml");
        std::fs::write(&invalid, "sigma_hit_m = -1.0\n").unwrap();
        let e = format!("{:#}", load(&invalid).unwrap_err());
        assert!(e.contains("invalid.toml") && e.contains("sigma_hit_m"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
