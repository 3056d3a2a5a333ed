//! Map metrics (CC + MS + OPDF together) on two 280 × 418 maps at 0.05 m, the size of the
//! AWS small-warehouse map: `cargo bench -p mapkeeper-grid --bench metrics`.

use criterion::{Criterion, criterion_group, criterion_main};
use mapkeeper_grid::metrics::{MetricParams, map_metrics};
use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Pose2};
use std::hint::black_box;

/// A warehouse-like map: unknown outside a walled room, shelves as occupied rectangles, and
/// `shift` cells of displacement for the shelves so the two maps differ.
fn warehouse(geometry: GridGeometry, shift: i32, extra_boxes: bool) -> OccupancyGrid {
    let (w, h) = (geometry.width() as i32, geometry.height() as i32);
    let mut m = OccupancyGrid::filled(geometry, CellState::Unknown);
    for iy in 10..h - 10 {
        for ix in 10..w - 10 {
            let wall = ix == 10 || iy == 10 || ix == w - 11 || iy == h - 11;
            m.set(CellCoord::new(ix, iy), if wall { CellState::Occupied } else { CellState::Free });
        }
    }
    for row in 0..6 {
        for col in 0..3 {
            let x0 = 40 + col * 70 + shift;
            let y0 = 40 + row * 60;
            for iy in y0..y0 + 12 {
                for ix in x0..x0 + 40 {
                    let edge = iy == y0 || iy == y0 + 11 || ix == x0 || ix == x0 + 39;
                    m.set(CellCoord::new(ix, iy), if edge { CellState::Occupied } else { CellState::Unknown });
                }
            }
        }
    }
    if extra_boxes {
        for k in 0..25 {
            let (x0, y0) = (30 + (k * 37) % 200, 30 + (k * 53) % 350);
            for iy in y0..y0 + 8 {
                for ix in x0..x0 + 8 {
                    m.set(CellCoord::new(ix, iy), CellState::Occupied);
                }
            }
        }
    }
    m
}

fn bench(c: &mut Criterion) {
    let geometry = GridGeometry::new(280, 418, 0.05, Pose2::new(-7.0, -10.5, 0.0)).expect("valid geometry");
    let a = warehouse(geometry, 0, false);
    let b = warehouse(geometry, 3, true);
    let params = MetricParams::default();
    c.bench_function("map_metrics 280x418 (cc+ms+opdf)", |bencher| {
        bencher.iter(|| map_metrics(black_box(&a), black_box(&b), &params).expect("same geometry"))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
