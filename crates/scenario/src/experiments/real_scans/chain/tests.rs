use super::*;
use crate::experiments::real_scans::edits::{EditParams, stale_map};
use crate::experiments::real_scans::test_logs::{carmen_prefix, mapper};
use mapkeeper_grid::Point2;

/// G, the reference path and a stale map of the first `scans` scans of Intel.
fn intel(scans: usize, test: &str) -> Option<(SensorLog, OccupancyGrid, StaleMap)> {
    intel_with(scans, &EditParams::default(), test)
}

/// [`intel`] with the given edits.
fn intel_with(scans: usize, edits: &EditParams, test: &str) -> Option<(SensorLog, OccupancyGrid, StaleMap)> {
    let log = carmen_prefix("intel", scans, test)?;
    let source = LogSource::new(log.clone(), "intel", map_options());
    let path: Vec<Point2> = source.truth().iter().map(|t| t.pose.position()).collect();
    let g = map_log(source, None, &mapper()).unwrap().map;
    let stale = stale_map(&g, &path, edits, 5).unwrap();
    Some((log, g, stale))
}

/// The chains' setup for Intel and edit seed 5.
fn setup<'a>(log: &'a SensorLog, g: &'a OccupancyGrid, stale: &'a StaleMap, m: &'a MapLogParams) -> ChainSetup<'a> {
    ChainSetup { name: "intel", log, truth_map: g, stale, edit_seed: 5, mapper: m, metrics: MetricParams::default() }
}

#[test]
fn passes_at_the_reference_poses_move_the_map_towards_g_and_keep_its_structure() {
    let Some((log, g, stale)) = intel(250, "passes_at_the_reference_poses_move_the_map_towards_g") else { return };
    let m = mapper();
    let setup = setup(&log, &g, &stale, &m);
    let r = run_chain(&setup, "mapkeeper", &PoseSourceConfig::Reference, 3, 1, true).unwrap();
    assert_eq!(r.per_pass.len(), 3);
    assert_eq!(r.maps.len(), 3);
    assert_eq!(r.per_pass.iter().map(|p| p.pass).collect::<Vec<_>>(), vec![2, 3, 4]);
    // The stale map is worse than G, the oracle is G on the scored cells.
    assert!(r.m1.cc < 100.0 && r.m1.ms < 100.0);
    assert_eq!((r.oracle.cc, r.oracle.ms, r.oracle.opdf), (100.0, 100.0, 100.0));
    // At the reference poses the fresh map is G itself (G is the map at those poses).
    assert_eq!(r.per_pass[0].fresh, r.oracle);
    let last = r.last;
    assert!(last.cc > r.m1.cc && last.ms > r.m1.ms && last.opdf > r.m1.opdf, "{:?} against M_1 {:?}", last, r.m1);
    // Each class partly restored, structure kept, nothing estimated.
    let p = r.per_pass.last().unwrap();
    for share in [p.restored.added, p.restored.removed, p.restored.moved] {
        assert!(share.unwrap() > 0.0, "{:?}", p.restored);
    }
    assert!(p.retention >= 99.0, "retention {}", p.retention);
    assert!(p.pose_error.is_none());
    assert!(r.per_pass[0].cells_changed > 0);
}

#[test]
fn the_localisers_poses_are_scored_against_the_reference() {
    // A lightly edited map: this test is about how the poses are scored, not about how far the
    // localiser holds on a stale map (the experiment measures that: on the first 120 scans of
    // Intel, the default edits' M_1 of seed 5 loses `mapkeeper-real`, 14.8 m RMSE; this one
    // leaves it off by more than 0.5 m on 13 % of the scans, 0.70 m RMSE, median 2 cm).
    let light = EditParams { added_share: 0.05, removed_share: 0.05, moved_share: 0.05, ..EditParams::default() };
    let Some((log, g, stale)) = intel_with(120, &light, "the_localisers_poses_are_scored_against_the_reference") else {
        return;
    };
    let m = mapper();
    let setup = setup(&log, &g, &stale, &m);
    let poses =
        PoseSourceConfig::Localiser { name: "mapkeeper-real".into(), params: Box::new(FilterParams::mapkeeper_real()) };
    let a = run_chain(&setup, "mapkeeper", &poses, 2, 9, false).unwrap();
    let b = run_chain(&setup, "mapkeeper", &poses, 2, 9, false).unwrap();
    assert!(a.maps.is_empty());
    let e = a.per_pass[0].pose_error.as_ref().unwrap();
    assert!(e.estimates > 100 && e.median_m < 0.05 && e.rmse_m.is_finite(), "{e:?}");
    // The fresh map at the estimate is not G.
    assert!(a.per_pass[0].fresh.ms < 100.0);
    // Deterministic.
    assert_eq!(a.per_pass, b.per_pass);
}

#[test]
fn the_oracle_takes_g_where_g_observed() {
    use mapkeeper_grid::{CellCoord, GridGeometry, Pose2};
    let geometry = GridGeometry::new(3, 1, 1.0, Pose2::IDENTITY).unwrap();
    let g =
        OccupancyGrid::from_cells(geometry, vec![CellState::Free, CellState::Unknown, CellState::Occupied]).unwrap();
    let mut m = OccupancyGrid::filled(geometry, CellState::Occupied);
    m.set(CellCoord::new(2, 0), CellState::Free);
    let o = oracle_map(&m, &g);
    assert_eq!(o.cells(), &[CellState::Free, CellState::Occupied, CellState::Occupied]);
    assert_eq!(observed_cells(&g), vec![true, false, true]);
}
