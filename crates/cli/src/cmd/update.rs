//! `mapkeeper update`: runs the map updater over recorded data (a sensor log and a map), the
//! path by which a real robot's logs are processed.

use anyhow::{Context, bail};
use mapkeeper_grid::Pose2;
use mapkeeper_grid::map_io::{load_map, save_map, write_atomic};
use mapkeeper_sensor::{LaserScan, LogRecord, SensorLog, StampedPose, interpolate, read_tum};
use mapkeeper_updater::{MapUpdater, PRESET_NAMES, PoseRecovery, StepOutcome, UpdaterParams};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `mapkeeper update`.
#[derive(clap::Args, Debug)]
#[command(after_help = "Runs the safe and robust map updater (Stefanini et al. 2023) over recorded data.\n\n\
Input: a ROS map_server map (M_{i-1}) and a sensor-log folder holding log.jsonl (scans with their \
lidar mounting poses, odometry, optionally true poses). Scans from several lidars with the same \
stamp_ns are processed together as one step.\n\n\
Robot pose per step (the localiser's estimate), linearly interpolated at the scan stamp:\n  \
--poses FILE.tum   a TUM trajectory (t x y z qx qy qz qw, '#' comments), e.g. from a localiser;\n  \
--true-poses       the log's truth records;\n  \
(neither)          the log's odometry, aligned so that the first odometry pose coincides with the \
first true pose if the log has truth records, otherwise with the map frame's origin (0, 0, 0).\n\
Odometry (for the update gating and pose updating) always comes from the log's odom records; \
without any, the chosen robot pose stands in for it.\n\n\
Output in OUT: map.yaml + map.pgm (M_i) and scans.csv with one row per step: time_s, outcome \
(processed, gated, no_valid_beams), verdict (update, suspend, lost or empty), n, n_invalid, n_dc, \
cells_changed, recovery (recovered, not_recovered or empty), microseconds of the updater call.")]
pub struct Args {
    /// The map to update, ROS map_server YAML (with its PGM/PNG image).
    #[arg(long, value_name = "MAP.yaml")]
    pub map: PathBuf,
    /// Sensor-log folder containing log.jsonl.
    #[arg(long, value_name = "DIR")]
    pub log: PathBuf,
    /// Robot poses in the map from a TUM trajectory file.
    #[arg(long, value_name = "FILE.tum", conflicts_with = "true_poses")]
    pub poses: Option<PathBuf>,
    /// Use the log's true poses as the robot pose estimate.
    #[arg(long)]
    pub true_poses: bool,
    /// Parameter preset: paper (default), reference, always-update, no-update, log-odds.
    #[arg(long, value_name = "NAME", default_value = "paper")]
    pub preset: String,
    /// TOML file overriding any field of the preset (same names as UpdaterParams; tables for
    /// pose_updating and log_odds).
    #[arg(long, value_name = "FILE.toml")]
    pub params: Option<PathBuf>,
    /// Output folder (created if missing; map.yaml, map.pgm and scans.csv are replaced).
    #[arg(long, value_name = "OUT")]
    pub out: PathBuf,
}

/// Merges `over` into `base`, table by table.
fn merge(base: &mut toml::Value, over: toml::Value) {
    match (base, over) {
        (toml::Value::Table(b), toml::Value::Table(o)) => {
            for (k, v) in o {
                match b.get_mut(&k) {
                    Some(slot) => merge(slot, v),
                    None => {
                        b.insert(k, v);
                    }
                }
            }
        }
        (slot, v) => *slot = v,
    }
}

/// The preset, overridden by the TOML file if any, validated.
pub fn load_params(preset: &str, file: Option<&Path>) -> anyhow::Result<UpdaterParams> {
    let params =
        UpdaterParams::preset(preset).with_context(|| format!("--preset (known: {})", PRESET_NAMES.join(", ")))?;
    let params = match file {
        None => params,
        Some(path) => {
            let text = std::fs::read_to_string(path).with_context(|| format!("{}", path.display()))?;
            let over: toml::Value =
                toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {}", path.display(), e.to_string().trim()))?;
            let mut value = toml::Value::try_from(&params).context("serialising the preset")?;
            merge(&mut value, over);
            value
                .try_into()
                .map_err(|e: toml::de::Error| anyhow::anyhow!("{}: {}", path.display(), e.to_string().trim()))?
        }
    };
    params.validate().with_context(|| match file {
        Some(p) => format!("{}", p.display()),
        None => format!("preset {preset}"),
    })?;
    Ok(params)
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let params = load_params(&args.preset, args.params.as_deref())?;
    let map = load_map(&args.map)?;
    let log_path = args.log.join("log.jsonl");
    let log = SensorLog::read(&log_path)?;

    let mut steps: BTreeMap<u64, Vec<LaserScan>> = BTreeMap::new();
    let mut odom = Vec::new();
    let mut truth = Vec::new();
    for r in log.records {
        match r {
            LogRecord::Scan(s) => steps.entry(s.stamp_ns).or_default().push(s),
            LogRecord::Odom(o) => odom.push(StampedPose { stamp_ns: o.stamp_ns, pose: o.pose_in_odom }),
            LogRecord::Truth(t) => truth.push(StampedPose { stamp_ns: t.stamp_ns, pose: t.pose_in_map }),
        }
    }
    if steps.is_empty() {
        bail!("{}: the log has no scan records", log_path.display());
    }
    // Where the robot pose estimate comes from.
    let estimate: Vec<StampedPose> = if let Some(p) = &args.poses {
        let poses = read_tum(p)?;
        if poses.is_empty() {
            bail!("{}: no poses", p.display());
        }
        poses
    } else if args.true_poses {
        if truth.is_empty() {
            bail!("{}: --true-poses given but the log has no truth records", log_path.display());
        }
        truth.clone()
    } else {
        let Some(first_odom) = odom.first() else {
            bail!("{}: no odometry records; give --poses or --true-poses", log_path.display());
        };
        let anchor = truth.first().map_or(Pose2::IDENTITY, |t| t.pose);
        let align = anchor.compose(&first_odom.pose.inverse());
        odom.iter().map(|o| StampedPose { stamp_ns: o.stamp_ns, pose: align.compose(&o.pose) }).collect()
    };

    let mut updater = MapUpdater::new(map, params)?;
    let mut csv = String::from("time_s,outcome,verdict,n,n_invalid,n_dc,cells_changed,recovery,microseconds\n");
    for (stamp_ns, scans) in &steps {
        let Some(robot_in_map) = interpolate(&estimate, *stamp_ns) else { continue };
        let robot_in_odom = interpolate(&odom, *stamp_ns).unwrap_or(robot_in_map);
        let t0 = Instant::now();
        let r = updater.process(robot_in_map, robot_in_odom, scans);
        let us = t0.elapsed().as_secs_f64() * 1e6;
        let outcome = match r.outcome {
            StepOutcome::Processed => "processed",
            StepOutcome::Gated(_) => "gated",
            StepOutcome::NoValidBeams => "no_valid_beams",
        };
        let recovery = match &r.pose_recovery {
            Some(PoseRecovery::Recovered { .. }) => "recovered",
            Some(PoseRecovery::NotRecovered { .. }) => "not_recovered",
            None => "",
        };
        let _ = writeln!(
            csv,
            "{}.{:09},{},{},{},{},{},{},{},{:.1}",
            stamp_ns / 1_000_000_000,
            stamp_ns % 1_000_000_000,
            outcome,
            r.verdict.map_or("", |v| v.name()),
            r.n_valid,
            r.n_invalid,
            r.n_dc,
            r.changed_cells.len(),
            recovery,
            us
        );
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("{}", args.out.display()))?;
    save_map(updater.map(), &args.out.join("map.yaml"))?;
    write_atomic(&args.out.join("scans.csv"), csv.as_bytes())?;
    let s = updater.stats();
    println!(
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
        args.out.display()
    );
    Ok(())
}
