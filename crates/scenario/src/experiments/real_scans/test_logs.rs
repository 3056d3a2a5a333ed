//! The real logs the module's tests run on (`../shared`, skipped with a note when absent).

use mapkeeper_grid::mapper::MapperParams;
use mapkeeper_harness::jobs::map::MapLogParams;
use mapkeeper_sensor::{LogRecord, SensorLog};

/// The first `scans` scans of a shared CARMEN log (`intel`, `aces`, `freiburg-079`) with their
/// odometry and reference, or `None` (a note printed) when `../shared` is absent.
pub fn carmen_prefix(name: &str, scans: usize, test: &str) -> Option<SensorLog> {
    let path = mapkeeper_common::shared_data::path(&format!("data/carmen/{name}-corrected.log.gz"), test)?;
    let (mut log, _) = mapkeeper_logs::carmen::read(&path, &mapkeeper_logs::ImportOptions::default()).unwrap();
    let end = log.scans().nth(scans).map_or(u64::MAX, |s| s.stamp_ns);
    log.records.retain(|r| match r {
        LogRecord::Scan(s) => s.stamp_ns < end,
        LogRecord::Odom(o) => o.stamp_ns < end,
        LogRecord::Truth(t) => t.stamp_ns < end,
    });
    Some(log)
}

/// How the tests map G (the experiment's default).
pub fn mapper() -> MapLogParams {
    MapLogParams { mapper: MapperParams::default(), no_return_clear_m: 0.0, resolution_m: 0.05, margin_m: 1.0 }
}
