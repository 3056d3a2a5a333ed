//! The real logs the module's tests run on (`../shared`, skipped with a note when absent).

use crate::experiments::reference::Dataset;
use mapkeeper_grid::mapper::MapperParams;
use mapkeeper_harness::jobs::map::MapLogParams;
use mapkeeper_sensor::SensorLog;

/// The first `scans` scans of a shared CARMEN log (`intel`, `aces`, `freiburg-079`) with their
/// odometry and reference, or `None` (a note printed) when `../shared` is absent.
pub fn carmen_prefix(name: &str, scans: usize, test: &str) -> Option<SensorLog> {
    let path = mapkeeper_common::shared_data::path(&format!("data/carmen/{name}-corrected.log.gz"), test)?;
    let (log, _) = mapkeeper_logs::carmen::read(&path, &mapkeeper_logs::ImportOptions::default()).unwrap();
    let all = log.scans().count();
    let d = Dataset { name: name.into(), source: path.display().to_string(), log }.first_scans(scans);
    assert_eq!(d.log.scans().count(), scans.min(all));
    assert!(d.has_reference());
    Some(d.log)
}

/// How the tests map G (the experiment's default).
pub fn mapper() -> MapLogParams {
    MapLogParams { mapper: MapperParams::default(), no_return_clear_m: 0.0, resolution_m: 0.05, margin_m: 1.0 }
}
