//! Degenerate maps through the grid crate's public API: a one-cell map, and maps that are all
//! unknown, all occupied or all free. Each gives a clear error or the documented behaviour of
//! `docs/reliability.md` ("Degenerate worlds and maps"), never a panic, a NaN or a hang.

use mapkeeper_grid::metrics::{MetricParams, map_metrics, resample_onto};
use mapkeeper_grid::{
    CellCoord, CellState, DistanceField, GridGeometry, OccupancyGrid, Point2, Pose2, RayCaster, RayStop, cast_ray,
    map_io,
};

fn filled(w: usize, h: usize, state: CellState) -> OccupancyGrid {
    OccupancyGrid::filled(GridGeometry::new(w, h, 0.05, Pose2::IDENTITY).expect("geometry"), state)
}

#[test]
fn zero_size_geometry_is_an_error() {
    assert!(GridGeometry::new(0, 1, 0.05, Pose2::IDENTITY).is_err());
    assert!(GridGeometry::new(1, 0, 0.05, Pose2::IDENTITY).is_err());
}

#[test]
fn one_cell_map_casts_measures_and_round_trips() {
    for state in [CellState::Free, CellState::Occupied, CellState::Unknown] {
        let m = filled(1, 1, state);
        // A ray from the cell's centre stops at once (occupied/unknown: range 0 in the cell) or
        // leaves the map through the cell's east side, 0.025 m away along x: at 0.025 / cos 0.3
        // (≈ 0.026 m; the north side is further, 0.025 / sin 0.3 ≈ 0.085 m).
        let (range, stop, cell) = match state {
            CellState::Free => (0.025 / 0.3f64.cos(), RayStop::LeftGrid, None),
            CellState::Occupied => (0.0, RayStop::Occupied, Some(CellCoord::new(0, 0))),
            CellState::Unknown => (0.0, RayStop::Unknown, Some(CellCoord::new(0, 0))),
        };
        let hit = cast_ray(&m, Point2::new(0.025, 0.025), 0.3, 10.0, true);
        assert_eq!((hit.stop, hit.cell), (stop, cell), "{state:?}: {hit:?}");
        assert!((hit.range_m - range).abs() < 1e-9, "{state:?}: {hit:?}, expected range {range}");
        let caster = RayCaster::new(&m, true);
        let fast = caster.cast(Point2::new(0.025, 0.025), 0.3, 10.0);
        assert_eq!(fast.stop, hit.stop, "{state:?}");
        assert!((fast.range_m - range).abs() < 1e-9, "{state:?}: {fast:?}, expected range {range}");
        // A ray from outside the map does not panic either.
        let outside = caster.cast(Point2::new(-5.0, -5.0), 0.0, 10.0);
        assert!(outside.range_m.is_finite());
        // The distance field is finite (capped) everywhere.
        let df = DistanceField::to_occupied(&m, 1.0);
        assert!(df.at_cell(CellCoord::new(0, 0)).is_finite());
        // Metrics of a map with itself are defined.
        let q = map_metrics(&m, &m, &MetricParams::default()).expect("same geometry");
        for v in [q.cc, q.ms, q.opdf] {
            assert!(v.is_finite(), "{state:?}: {q:?}");
        }
        // Save and reload.
        let dir = std::env::temp_dir().join(format!("mapkeeper-one-cell-{state:?}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        map_io::save_map(&m, &dir.join("one.yaml")).expect("saves");
        assert_eq!(map_io::load_map(&dir.join("one.yaml")).expect("reloads"), m);
        // Resampling a one-cell map onto a bigger grid: outside is unknown.
        let big = resample_onto(&m, &GridGeometry::new(4, 4, 0.05, Pose2::new(-0.05, -0.05, 0.0)).expect("geometry"));
        assert_eq!(big.get(CellCoord::new(1, 1)), Some(state));
        assert_eq!(big.get(CellCoord::new(3, 3)), Some(CellState::Unknown));
    }
}

#[test]
fn uniform_maps_have_defined_metrics_and_rays() {
    let (unknown, occupied, free) =
        (filled(40, 30, CellState::Unknown), filled(40, 30, CellState::Occupied), filled(40, 30, CellState::Free));
    for (a, b) in
        [(&unknown, &unknown), (&occupied, &occupied), (&free, &free), (&unknown, &occupied), (&free, &occupied)]
    {
        let q = map_metrics(a, b, &MetricParams::default()).expect("same geometry");
        for v in [q.cc, q.ms, q.opdf, q.opdf_ab, q.opdf_ba] {
            assert!(v.is_finite(), "{q:?}");
        }
        // Constant maps have zero variance: CC comes from the zero-variance rule.
        assert!(q.cc_degenerate, "{q:?}");
    }
    // All free: a ray runs to its range (or the map's edge) without a hit.
    let hit = cast_ray(&free, Point2::new(1.0, 0.75), 0.0, 0.5, true);
    assert_eq!(hit.stop, RayStop::MaxRange);
    // All occupied / unknown: every ray stops in the cell it starts in.
    for m in [&occupied, &unknown] {
        let hit = RayCaster::new(m, true).cast(Point2::new(1.0, 0.75), 1.0, 30.0);
        assert!(hit.range_m < 0.1, "{hit:?}");
    }
    // A distance field with no occupied cell is the cap everywhere.
    let df = DistanceField::to_occupied(&free, 2.0);
    assert!(df.distances_m().iter().all(|&d| d.is_finite() && d >= 1.99));
}
