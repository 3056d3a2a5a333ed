//! Grid traversal throughput at 0.05 m on two maps of the warehouse the paper simulated:
//!
//! - `synthetic`: 280 × 418 cells, the walls, a long rack outline and 14 box outlines (few
//!   obstacles, so rays are long: ~150 cells on average);
//! - `aws`: the real ROS map of the AWS small warehouse (286 × 423 cells), whose racks are rows
//!   of posts, as a 2D lidar sees them; read from `../shared/maps/aws-small-warehouse/` beside
//!   the checkout (team reference data, never committed) and skipped with a note when absent.
//!
//! Rays are cast from four poses in the aisles in 1082 directions (a dual-S300 scan's worth) to
//! the first occupied or unknown cell, 30 m range, as the updater and the mapper cast them.
//! `cargo bench -p mapkeeper-grid --bench traversal`; read the throughput in rays/s (target ≥ 10 M
//! rays/s on one core) and, for maps whose rays differ in length, in cells/s.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mapkeeper_grid::map_io;
use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Point2, Pose2, RayCaster, cast_ray, traverse};
use std::hint::black_box;
use std::ops::ControlFlow;

/// Walls around a 14 × 20.9 m warehouse, a long rack outline and 14 box outlines.
fn warehouse() -> OccupancyGrid {
    let g = GridGeometry::new(280, 418, 0.05, Pose2::new(-7.0, -10.45, 0.0)).expect("valid geometry");
    let mut m = OccupancyGrid::filled(g, CellState::Free);
    let mut outline = |x0: f64, y0: f64, x1: f64, y1: f64| {
        let (a, b) = (
            g.world_to_cell(Point2::new(x0, y0)).expect("finite"),
            g.world_to_cell(Point2::new(x1, y1)).expect("finite"),
        );
        for ix in a.ix..=b.ix {
            for iy in a.iy..=b.iy {
                if ix == a.ix || ix == b.ix || iy == a.iy || iy == b.iy {
                    m.set(CellCoord::new(ix, iy), CellState::Occupied);
                }
            }
        }
    };
    outline(-6.99, -10.44, 6.99, 10.44);
    outline(-6.85, -10.0, -4.75, 8.0);
    for (i, &(x, y)) in
        [(3.3, 3.8), (5.5, 3.8), (5.4, 6.1), (3.2, 6.1), (-1.6, 2.3), (-1.2, 9.4), (5.7, 8.6)].iter().enumerate()
    {
        outline(x - 0.85, y - 0.9, x + 0.85, y + 0.9);
        let yy = -1.0 - 1.8 * i as f64;
        outline(4.0, yy - 0.4, 5.9, yy + 0.4);
    }
    m
}

fn rays() -> Vec<(Point2, f64)> {
    let origins = [Point2::new(1.0, 0.0), Point2::new(-3.0, -5.0), Point2::new(1.5, 7.5), Point2::new(2.0, -8.0)];
    let mut v = Vec::new();
    for o in origins {
        for k in 0..1082 {
            v.push((o, k as f64 * std::f64::consts::TAU / 1082.0));
        }
    }
    v
}

/// The AWS map from `../shared`, or `None` (after a note) when `../shared` is absent.
fn aws_map() -> Option<OccupancyGrid> {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/maps/aws-small-warehouse/map.yaml");
    if !path.is_file() {
        eprintln!("skipping: ../shared not found (no {}); benchmarking the synthetic map only", path.display());
        return None;
    }
    Some(map_io::load_map(&path).expect("the AWS warehouse map in ../shared loads"))
}

fn bench(c: &mut Criterion) {
    bench_map(c, "synthetic", &warehouse());
    if let Some(map) = aws_map() {
        bench_map(c, "aws", &map);
    }
}

fn bench_map(c: &mut Criterion, name: &str, map: &OccupancyGrid) {
    let map = map.clone();
    let rays = rays();
    for &(o, _) in rays.iter().step_by(1082) {
        assert_eq!(map.get_world(o), Some(CellState::Free), "{name}: ray origin {o:?} is not in free space");
    }
    let mut group = c.benchmark_group(format!("traversal_{name}"));
    group.throughput(Throughput::Elements(rays.len() as u64));
    group.bench_function("cast_ray_to_first_occupied_30m", |b| {
        b.iter(|| {
            let mut sum = 0.0;
            for &(o, a) in &rays {
                sum += cast_ray(&map, o, a, 30.0, true).range_m;
            }
            black_box(sum)
        })
    });
    // The same rays through the clearance-accelerated caster (same answers, fewer steps).
    let caster = RayCaster::new(&map, true);
    group.bench_function("ray_caster_to_first_occupied_30m", |b| {
        b.iter(|| {
            let mut sum = 0.0;
            for &(o, a) in &rays {
                sum += caster.cast(o, a, 30.0).range_m;
            }
            black_box(sum)
        })
    });
    // The raw walk, for reference: every cell along the segment to the hit found above.
    let ends: Vec<(Point2, Point2)> = rays
        .iter()
        .map(|&(o, a)| {
            let r = cast_ray(&map, o, a, 30.0, true).range_m;
            (o, Point2::new(o.x + r * a.cos(), o.y + r * a.sin()))
        })
        .collect();
    group.finish();
    // The same walks counted in cells, to compare maps whose rays differ in length.
    let cells: usize = ends
        .iter()
        .map(|&(a, e)| {
            let mut n = 0usize;
            let _ = traverse(map.geometry(), a, e, |_| {
                n += 1;
                ControlFlow::<()>::Continue(())
            });
            n
        })
        .sum();
    eprintln!(
        "traversal_{name}: {} rays, {:.1} cells per ray on average",
        ends.len(),
        cells as f64 / ends.len() as f64
    );
    let mut group = c.benchmark_group(format!("traversal_cells_{name}"));
    group.throughput(Throughput::Elements(cells as u64));
    group.bench_function("traverse_segments", |b| {
        b.iter(|| {
            let mut n = 0usize;
            for &(a, e) in &ends {
                let _ = traverse(map.geometry(), a, e, |c| {
                    n += c.ix as usize & 1;
                    ControlFlow::<()>::Continue(())
                });
            }
            black_box(n)
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
