//! `mapkeeper localise`: the particle-filter localiser over a recorded sensor log.

use anyhow::Context;
use mapkeeper_grid::{Pose2, angle_diff, map_io, write_atomic};
use mapkeeper_localiser::{Covariance3, FilterParams, Localiser, UpdateOutcome};
use mapkeeper_sensor::{LaserScan, OdometryReading, SensorLog, StampedPose, interpolate, write_tum_with_comment};
use std::path::{Path, PathBuf};

/// Initial covariance for `--init` and truth initialisation: AMCL's defaults, σ = 0.5 m in x
/// and y and π/12 rad in yaw.
const INIT_COVARIANCE: Covariance3 =
    [[0.25, 0.0, 0.0], [0.0, 0.25, 0.0], [0.0, 0.0, (std::f64::consts::PI / 12.0) * (std::f64::consts::PI / 12.0)]];

/// Arguments of `mapkeeper localise`.
#[derive(clap::Args, Debug)]
#[command(
    long_about = "Run the particle-filter localiser (likelihood field, KLD sampling, multi-lidar; \
docs/localiser.md) over a recorded sensor log and a map.\n\n\
Scans with the same stamp_ns (one per lidar) form one filter update, driven by the latest odometry \
reading at or before that time; updates before the first odometry reading are skipped. The filter \
starts at --init with AMCL's default covariance (σ 0.5 m, 0.5 m, π/12 rad); without --init, at the \
log's true pose at the first scan's time (same covariance) if the log has truth records, otherwise \
globally (particles uniform over the map's free space).\n\n\
Writes OUT/estimate.tum (one line per update: `t x y z qx qy qz qw`, t in seconds with 9 decimals \
on the log's clock, z = 0, yaw as a quaternion about z; a first `#` line records the seed and \
inputs) and OUT/covariance.csv (time_s, trace of the 3×3 (x, y, yaw) covariance, its largest \
eigenvalue lambda_max, particles, ess), each written atomically. With truth records it prints the \
position and yaw RMSE of the estimates against the truth interpolated at their times.",
    after_help = "Examples:\n  mapkeeper localise --log run1 --map run1/map.yaml --out run1/loc\n  \
mapkeeper localise --log run1 --map m0.yaml --out loc --init 0.5,-2.0,1.57 --params amcl.toml --seed 3"
)]
pub struct Args {
    /// Folder holding the sensor log `log.jsonl`.
    #[arg(long, value_name = "DIR")]
    pub log: PathBuf,
    /// The map to localise on (ROS map_server YAML).
    #[arg(long, value_name = "MAP.yaml")]
    pub map: PathBuf,
    /// Output folder (created if missing).
    #[arg(long, value_name = "OUT")]
    pub out: PathBuf,
    /// Initial pose in the map frame: x (m), y (m), yaw (rad), comma-separated.
    #[arg(long, value_name = "X,Y,YAW", value_parser = parse_pose, allow_hyphen_values = true)]
    pub init: Option<Pose2>,
    /// TOML file overriding any FilterParams field (unknown keys are errors), e.g.
    /// `max_particles = 2000` or `[motion]` `alpha3 = 0.1`.
    #[arg(long, value_name = "FILE.toml")]
    pub params: Option<PathBuf>,
    /// Seed of the filter's random stream (same seed ⇒ identical output).
    #[arg(long, value_name = "S", default_value_t = 0)]
    pub seed: u64,
    /// Overwrite existing output files.
    #[arg(long)]
    pub force: bool,
}

/// Parses `x,y,yaw`.
fn parse_pose(s: &str) -> Result<Pose2, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!("expected x,y,yaw (three comma-separated numbers), got '{s}'"));
    }
    let mut v = [0.0; 3];
    for (slot, p) in v.iter_mut().zip(&parts) {
        *slot = p.parse::<f64>().map_err(|e| format!("'{p}' is not a number: {e}"))?;
        if !slot.is_finite() {
            return Err(format!("'{p}' is not finite"));
        }
    }
    Ok(Pose2::new(v[0], v[1], v[2]))
}

/// Reads a parameter file: TOML over the defaults, then validated.
fn load_params(path: &Path) -> anyhow::Result<FilterParams> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let params: FilterParams = toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    params.validate().with_context(|| format!("{}", path.display()))?;
    Ok(params)
}

/// `ns` as seconds with 9 decimals, exactly.
fn seconds(ns: u64) -> String {
    format!("{}.{:09}", ns / 1_000_000_000, ns % 1_000_000_000)
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let params = match &args.params {
        Some(p) => load_params(p)?,
        None => FilterParams::default(),
    };
    let log_path = args.log.join("log.jsonl");
    let log = SensorLog::read(&log_path)?;
    let map = map_io::load_map(&args.map).with_context(|| format!("cannot load map {}", args.map.display()))?;

    let tum_path = args.out.join("estimate.tum");
    let csv_path = args.out.join("covariance.csv");
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    for p in [&tum_path, &csv_path] {
        if p.exists() && !args.force {
            anyhow::bail!("{} exists; use --force to overwrite", p.display());
        }
    }

    // Records by type, each in time order (the log guarantees non-decreasing stamps per type;
    // the stable sort only protects against interleaving).
    let mut odom: Vec<OdometryReading> = log.odometry().copied().collect();
    odom.sort_by_key(|o| o.stamp_ns);
    let mut truth: Vec<StampedPose> =
        log.truth().map(|t| StampedPose { stamp_ns: t.stamp_ns, pose: t.pose_in_map }).collect();
    truth.sort_by_key(|t| t.stamp_ns);
    let mut scans: Vec<&LaserScan> = log.scans().collect();
    scans.sort_by_key(|s| s.stamp_ns);
    if scans.is_empty() {
        anyhow::bail!("{}: the log has no scans", log_path.display());
    }

    let mut filter = Localiser::new(&map, params, args.seed).context("cannot build the localiser")?;
    let init = match (args.init, scans.first()) {
        (Some(p), _) => Some((p, "--init")),
        (None, Some(s)) => interpolate(&truth, s.stamp_ns).map(|p| (p, "truth")),
        (None, None) => None,
    };
    let init_text = match init {
        Some((pose, source)) => {
            filter.init_pose(pose, INIT_COVARIANCE).context("cannot initialise the localiser")?;
            format!("{source} ({}, {}, {})", pose.x, pose.y, pose.yaw)
        }
        None => "global".to_owned(),
    };

    let comment = format!(
        "mapkeeper localise: seed {}, log {}, map {}, init {init_text}",
        args.seed,
        log_path.display(),
        args.map.display()
    );
    let mut estimates: Vec<StampedPose> = Vec::with_capacity(scans.len());
    let mut csv = String::from("time_s,trace,lambda_max,particles,ess\n");
    let (mut updates, mut sensor_updates, mut degenerate, mut no_odom, mut no_beams) = (0, 0, 0, 0, 0);
    let (mut sq_pos, mut sq_yaw, mut n_err) = (0.0, 0.0, 0usize);
    let mut group: Vec<LaserScan> = Vec::new();
    let mut i = 0;
    while i < scans.len() {
        let t = scans[i].stamp_ns;
        group.clear();
        while i < scans.len() && scans[i].stamp_ns == t {
            group.push(scans[i].clone());
            i += 1;
        }
        let k = odom.partition_point(|o| o.stamp_ns <= t);
        let Some(reading) = k.checked_sub(1).and_then(|j| odom.get(j)) else {
            no_odom += 1;
            continue;
        };
        let r = filter.update(reading.pose_in_odom, &group);
        updates += 1;
        match r.outcome {
            UpdateOutcome::Updated => sensor_updates += 1,
            UpdateOutcome::Degenerate { .. } => {
                sensor_updates += 1;
                degenerate += 1;
            }
            UpdateOutcome::NoUsableBeams => no_beams += 1,
            UpdateOutcome::Gated | UpdateOutcome::InvalidOdometry => {}
        }
        let e = r.estimate;
        let p = e.pose_in_map;
        estimates.push(StampedPose { stamp_ns: t, pose: p });
        let trace = e.covariance[0][0] + e.covariance[1][1] + e.covariance[2][2];
        csv.push_str(&format!("{},{trace:.9e},{:.9e},{},{:.3}\n", seconds(t), e.lambda_max(), r.particles, r.ess));
        if let Some(tp) = interpolate(&truth, t) {
            sq_pos += p.distance(&tp).powi(2);
            sq_yaw += angle_diff(p.yaw, tp.yaw).powi(2);
            n_err += 1;
        }
    }
    write_tum_with_comment(&tum_path, &comment, &estimates)?;
    write_atomic(&csv_path, csv.as_bytes()).with_context(|| format!("cannot write {}", csv_path.display()))?;

    println!(
        "{updates} updates ({sensor_updates} sensor updates, {degenerate} degenerate and recovered, {no_beams} without usable beams); \
{no_odom} scan times before the first odometry skipped; init {init_text}; seed {}",
        args.seed
    );
    if n_err > 0 {
        let n = n_err as f64;
        println!(
            "position RMSE {:.4} m, yaw RMSE {:.3} deg over {n_err} estimates",
            (sq_pos / n).sqrt(),
            (sq_yaw / n).sqrt().to_degrees()
        );
    }
    println!("wrote {} and {}", tum_path.display(), csv_path.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_poses() {
        assert_eq!(parse_pose("1, -2.5,0.3"), Ok(Pose2::new(1.0, -2.5, 0.3)));
        assert!(parse_pose("1,2").is_err());
        assert!(parse_pose("1,x,3").is_err());
        assert!(parse_pose("1,NaN,3").is_err());
    }

    #[test]
    fn seconds_are_exact() {
        assert_eq!(seconds(0), "0.000000000");
        assert_eq!(seconds(12_000_000_345), "12.000000345");
    }

    #[test]
    fn parameter_files_override_and_are_checked() {
        let dir = std::env::temp_dir().join(format!("mapkeeper-localise-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = dir.join("good.toml");
        std::fs::write(&good, "max_particles = 800\nkinematics = \"differential\"\n[motion]\nalpha3 = 0.1\n").unwrap();
        let p = load_params(&good).unwrap();
        assert_eq!((p.max_particles, p.motion.alpha3, p.min_particles), (800, 0.1, 500));
        let unknown = dir.join("unknown.toml");
        std::fs::write(&unknown, "max_particle = 800\n").unwrap();
        let e = format!("{:#}", load_params(&unknown).unwrap_err());
        assert!(e.contains("unknown.toml") && e.contains("max_particle"), "{e}");
        let invalid = dir.join("invalid.toml");
        std::fs::write(&invalid, "sigma_hit_m = -1.0\n").unwrap();
        let e = format!("{:#}", load_params(&invalid).unwrap_err());
        assert!(e.contains("invalid.toml") && e.contains("sigma_hit_m"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
