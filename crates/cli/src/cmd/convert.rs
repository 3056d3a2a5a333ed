//! `mapkeeper convert`: a recorded log (ROS 2 MCAP bag, ROS 1 bag, CARMEN log, or the project's
//! own log) into the project's JSON Lines sensor log, with what the import found.

use super::log_input::LogInput;
use mapkeeper_sensor::{StampedPose, write_tum_with_comment};

/// Arguments of `mapkeeper convert`.
#[derive(clap::Args, Debug)]
#[command(
    long_about = "Convert a recorded log into the project's sensor log (docs/sensor-log.md).\n\n\
Reads --log (a ROS 2 MCAP bag or bag folder, a ROS 1 bag, a CARMEN log, or a mapkeeper log; detected \
from the content, --log-format to override) and writes OUT/log.jsonl (every stamp relative to the \
log's first, which import.json records as epoch_ns), OUT/import.json (the lidars with their mounts, \
the odometry and reference sources, every topic with its type and message count, timestamps that \
stepped back) and, when the log has reference poses, OUT/reference.tum (TUM, for evo; times in seconds \
on the log's clock, relative to epoch_ns).",
    after_help = "Examples:\n  mapkeeper convert --log robot.bag --out runs/robot\n  \
mapkeeper convert --log bag_folder --scan-topic /front/scan --scan-topic /rear/scan --odom-topic /wheel/odom --out runs/r\n  \
mapkeeper convert --log intel-corrected.log.gz --out runs/intel"
)]
pub struct Args {
    /// The recorded log and how to read it.
    #[command(flatten)]
    pub input: LogInput,
    #[command(flatten)]
    pub output: super::shared_args::RequiredOutputArgs,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let imported = args.input.read_imported()?;
    let dir = super::output_dir(&args.output.out, args.output.force)?;
    imported.log.write(&dir.file("log.jsonl")?)?;
    let report = match &imported.report {
        Some(r) => serde_json::to_value(r)?,
        None => {
            serde_json::json!({ "source": imported.path.display().to_string(), "format": "jsonl", "note": "already a mapkeeper sensor log" })
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
    }
    let scans = imported.log.scans().count();
    let odom = imported.log.odometry().count();
    outln!(
        "wrote {}/log.jsonl ({scans} scans, {odom} odometry readings, {} reference poses) and import.json{}",
        out.display(),
        truth.len(),
        if truth.is_empty() { "" } else { " and reference.tum" }
    );
    Ok(())
}
