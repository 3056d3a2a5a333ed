//! `mapkeeper convert`: a recorded log (ROS 2 MCAP bag, ROS 1 bag, CARMEN log, or the project's
//! own log) into the project's JSON Lines sensor log, with what the import found.

use super::log_input::LogInput;
use mapkeeper_harness::jobs::odometry_drift::odometry_drift;
use mapkeeper_harness::jobs::scan_odometry::{self, ScanOdometryParams};
use mapkeeper_logs::{ImportOptions, ImportReport, Imported, OdometryFrom, ScanOdometrySummary, read_log};
use mapkeeper_sensor::{SensorLog, StampedPose, write_tum_with_comment};

/// The stretches of reference path over which the odometry's drift is printed, metres.
const DRIFT_STRETCHES_M: [f64; 2] = [1.0, 10.0];

/// Arguments of `mapkeeper convert`.
#[derive(clap::Args, Debug)]
#[command(
    long_about = "Convert a recorded log into the project's sensor log (docs/sensor-log.md).\n\n\
Reads --log (a ROS 2 MCAP bag or bag folder, a ROS 1 bag, a CARMEN log, or a mapkeeper log; detected \
from the content, --log-format to override) and writes OUT/log.jsonl (every stamp relative to the \
log's first, which import.json records as epoch_ns), OUT/import.json (the lidars with their mounts, \
the odometry and reference sources, every topic with its type and message count, timestamps that \
stepped back) and, when the log has reference poses, OUT/reference.tum (TUM, for evo; times in seconds \
on the log's clock, relative to epoch_ns), and prints how far the odometry drifts from them per metre \
(over stretches of 1 m and 10 m of their path).\n\n\
A log with laser scans and no odometry (no odometry topic, no odom → base transforms) is refused \
unless --odometry-from-scans is given: then the odometry is made by matching each scan against a local \
map of the recent scans (docs/real-data.md, \"Logs with scans only\"), and import.json's scan_odometry \
says how many matches were refused.",
    after_help = "Examples:\n  mapkeeper convert --log robot.bag --out runs/robot\n  \
mapkeeper convert --log bag_folder --scan-topic /front/scan --scan-topic /rear/scan --odom-topic /wheel/odom --out runs/r\n  \
mapkeeper convert --log intel-corrected.log.gz --out runs/intel\n  \
mapkeeper convert --log scans_only.bag --base-frame laser --odometry-from-scans --out runs/scans"
)]
pub struct Args {
    /// The recorded log and how to read it.
    #[command(flatten)]
    pub input: LogInput,
    /// Make the odometry by matching the scans (each against a local map of the recent scans,
    /// from the last step's motion; a refused match keeps that prediction), for a log that has
    /// scans and no odometry. A log with odometry has it replaced (a note says so). import.json's
    /// scan_odometry counts the matches and the refusals (docs/real-data.md, "Logs with scans
    /// only").
    #[arg(long, conflicts_with_all = ["odom_topic", "odom_from_tf"])]
    pub odometry_from_scans: bool,
    #[command(flatten)]
    pub output: super::shared_args::RequiredOutputArgs,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut imported = if args.odometry_from_scans {
        let options = ImportOptions { odometry: OdometryFrom::Scans, ..args.input.options() };
        read_log(&args.input.log, args.input.log_format, &options)?
    } else {
        args.input.read_imported()?
    };
    let made = args.odometry_from_scans.then(|| odometry_from_scans(&mut imported));
    let dir = super::output_dir(&args.output.out, args.output.force)?;
    imported.log.write(&dir.file("log.jsonl")?)?;
    let report = match &imported.report {
        Some(r) => serde_json::to_value(r)?,
        None => {
            let mut r = serde_json::json!({ "source": imported.path.display().to_string(), "format": "jsonl", "note": "already a mapkeeper sensor log" });
            if let Some((summary, replaced)) = &made {
                r["odometry_source"] = ImportReport::SCAN_ODOMETRY_SOURCE.into();
                r["odometry_messages"] = summary.steps.into();
                r["scan_odometry"] = serde_json::to_value(summary)?;
                if *replaced > 0 {
                    r["note"] = format!("a mapkeeper sensor log; its own {replaced} odometry readings replaced").into();
                }
            }
            r
        }
    };
    dir.write("import.json", format!("{}\n", serde_json::to_string_pretty(&report)?).as_bytes())?;
    let truth: Vec<StampedPose> =
        imported.log.truth().map(|t| StampedPose { stamp_ns: t.stamp_ns, pose: t.pose_in_map }).collect();
    if !truth.is_empty() {
        let comment = format!("mapkeeper convert: reference poses of {}", imported.path.display());
        write_tum_with_comment(&dir.file("reference.tum")?, &comment, &truth)?;
    }
    let out = dir.finish()?;
    if let Some(r) = &imported.report {
        for line in r.lines() {
            outln!("{line}");
        }
    } else if let Some((summary, replaced)) = &made {
        outln!(
            "{}: {}{}",
            imported.path.display(),
            summary.line(),
            if *replaced > 0 { format!(" (its own {replaced} odometry readings replaced)") } else { String::new() }
        );
    }
    let odometry: Vec<StampedPose> =
        imported.log.odometry().map(|o| StampedPose { stamp_ns: o.stamp_ns, pose: o.pose_in_odom }).collect();
    for stretch_m in DRIFT_STRETCHES_M {
        if let Some(d) = odometry_drift(&odometry, &truth, stretch_m) {
            outln!("odometry against the reference poses: {d}");
        }
    }
    let scans = imported.log.scans().count();
    let odom = odometry.len();
    outln!(
        "wrote {}/log.jsonl ({scans} scans, {odom} odometry readings, {} reference poses) and import.json{}",
        out.display(),
        truth.len(),
        if truth.is_empty() { "" } else { " and reference.tum" }
    );
    Ok(())
}

/// Makes the odometry of `imported` from its scans (replacing any it has) and records it in its
/// report and its log's header; returns how it went and how many readings were replaced.
fn odometry_from_scans(imported: &mut Imported) -> (ScanOdometrySummary, usize) {
    let params = ScanOdometryParams::default();
    let made = scan_odometry::odometry_from_scans(&imported.log, &params);
    let replaced = imported.log.odometry().count();
    let header = imported.log.header.clone();
    let log = std::mem::replace(&mut imported.log, SensorLog { header, records: Vec::new() });
    imported.log = scan_odometry::with_odometry(log, &made);
    match &mut imported.report {
        Some(r) => {
            r.set_scan_odometry(made.summary.clone());
            imported.log.header = r.log_header();
        }
        None => {
            let meta = &mut imported.log.header.meta;
            meta.insert("odometry_source".into(), ImportReport::SCAN_ODOMETRY_SOURCE.into());
            if let Ok(v) = serde_json::to_value(&made.summary) {
                meta.insert("scan_odometry".into(), v);
            }
        }
    }
    (made.summary, replaced)
}
