//! What the real-log experiments share: a recorded log ([`Dataset`]), a localiser's error against a log's reference poses
//! ([`error_stats`], [`ErrorStats`], with the targets of issue 14) and how a log is mapped at
//! its reference poses ([`MAP_POSE_GAP_NS`]). Used by `real_data` (the localiser and the
//! updater on a log's own map) and `real_scans` (the updater judged against the map at the
//! reference poses).

use crate::stats::{median, percentile};
use mapkeeper_grid::angle_diff;
use mapkeeper_sensor::{LogRecord, SensorLog, StampedPose, interpolate};
use serde::Serialize;

/// One recorded log.
#[derive(Clone, Debug)]
pub struct Dataset {
    /// Its name in tables (the file's stem).
    pub name: String,
    /// Where it came from.
    pub source: String,
    /// The log (with truth records: the reference poses).
    pub log: SensorLog,
}

impl Dataset {
    /// The log cut after its first `scans` scans: every record stamped before the scan that
    /// would be the next (a short run of a long log; all of it if it has no more scans).
    pub fn first_scans(mut self, scans: usize) -> Self {
        let mut stamps: Vec<u64> = self.log.scans().map(|s| s.stamp_ns).collect();
        stamps.sort_unstable();
        if let Some(&end) = stamps.get(scans) {
            self.log.records.retain(|r| record_stamp(r) < end);
        }
        self
    }

    /// Whether the log has reference poses (truth records).
    pub fn has_reference(&self) -> bool {
        self.log.records.iter().any(|r| matches!(r, LogRecord::Truth(_)))
    }
}

fn record_stamp(r: &LogRecord) -> u64 {
    match r {
        LogRecord::Scan(s) => s.stamp_ns,
        LogRecord::Odom(o) => o.stamp_ns,
        LogRecord::Truth(t) => t.stamp_ns,
    }
}

/// Position RMSE target, metres (issue 14).
pub const TARGET_RMSE_M: f64 = 0.05;
/// Largest-error target, metres (issue 14).
pub const TARGET_MAX_M: f64 = 0.25;
/// An estimate farther than this from the reference counts as lost, metres.
pub const LOST_M: f64 = 0.5;
/// Largest time from a scan to a reference pose used to map it, nanoseconds.
pub const MAP_POSE_GAP_NS: u64 = 100_000_000;

/// The estimate's error against the reference.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ErrorStats {
    /// Estimates scored.
    pub estimates: usize,
    /// Position RMSE, metres.
    pub rmse_m: f64,
    /// Largest position error, metres.
    pub max_m: f64,
    /// Median position error, metres.
    pub median_m: f64,
    /// 95th percentile of the position error, metres.
    pub p95_m: f64,
    /// Yaw RMSE, degrees.
    pub yaw_rmse_deg: f64,
    /// Share of estimates farther than [`LOST_M`].
    pub lost_share: f64,
    /// Whether both targets ([`TARGET_RMSE_M`], [`TARGET_MAX_M`]) are met.
    pub targets_met: bool,
}

/// The estimate's error against the reference interpolated at each estimate, and the series.
pub fn error_stats(estimates: &[StampedPose], truth: &[StampedPose]) -> (ErrorStats, Vec<(f64, f64, f64)>) {
    let series: Vec<(f64, f64, f64)> = estimates
        .iter()
        .filter_map(|e| {
            interpolate(truth, e.stamp_ns).map(|t| {
                (e.stamp_ns as f64 * 1e-9, e.pose.distance(&t), angle_diff(e.pose.yaw, t.yaw).abs().to_degrees())
            })
        })
        .collect();
    let n = series.len().max(1) as f64;
    let pos: Vec<f64> = series.iter().map(|s| s.1).collect();
    let rmse_m = (pos.iter().map(|e| e * e).sum::<f64>() / n).sqrt();
    let max_m = pos.iter().copied().fold(0.0, f64::max);
    let stats = ErrorStats {
        estimates: series.len(),
        rmse_m,
        max_m,
        median_m: median(pos.clone()).unwrap_or(0.0),
        p95_m: percentile(pos.clone(), 0.95).unwrap_or(0.0),
        yaw_rmse_deg: (series.iter().map(|s| s.2 * s.2).sum::<f64>() / n).sqrt(),
        lost_share: pos.iter().filter(|&&e| e > LOST_M).count() as f64 / n,
        targets_met: !series.is_empty() && rmse_m <= TARGET_RMSE_M && max_m <= TARGET_MAX_M,
    };
    (stats, series)
}
