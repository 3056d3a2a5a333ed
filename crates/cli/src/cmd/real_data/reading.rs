//! The logs `experiment real-data` reads: its reading flags and one dataset per log.

use crate::cmd::log_input::{LogInput, TimeFlags};
use mapkeeper_scenario::experiments::real_data::Dataset;
use std::path::Path;

/// The reading flags of [`LogInput`] without `--log` (real-data takes several logs).
#[derive(clap::Args, Debug, Clone)]
pub struct ReadingFlags {
    /// A topic of reference poses (bags; CARMEN corrected logs carry theirs).
    #[arg(long, value_name = "TOPIC")]
    pub truth_topic: Option<String>,
    /// A lidar's scan topic (repeat for several).
    #[arg(long = "scan-topic", value_name = "TOPIC")]
    pub scan_topics: Vec<String>,
    /// The odometry topic.
    #[arg(long, value_name = "TOPIC")]
    pub odom_topic: Option<String>,
    #[command(flatten)]
    pub time: TimeFlags,
}

pub(super) fn read(path: &Path, flags: &ReadingFlags) -> anyhow::Result<Dataset> {
    let input = LogInput {
        scan_topics: flags.scan_topics.clone(),
        odom_topic: flags.odom_topic.clone(),
        truth_topic: flags.truth_topic.clone(),
        time: flags.time.clone(),
        ..LogInput::path(path)
    };
    let (log, read_path) = input.read()?;
    let stem = path.file_name().map_or_else(|| "log".into(), |s| s.to_string_lossy().into_owned());
    let name = stem.split('.').next().unwrap_or("log").trim_end_matches("-corrected").to_string();
    Ok(Dataset { name, source: read_path.display().to_string(), log })
}
