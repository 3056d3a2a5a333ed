//! Localiser speed on a map of the default warehouse's size (280 × 418 cells at 0.05 m) with
//! walls and box outlines (unknown interiors):
//!
//! - `likelihood_field/beam_evaluations`: scoring 1000 particles × 60 beams (two lidars × 30);
//!   read the throughput in elements/s = beam evaluations per second on one core
//!   (target ≥ 30 M/s).
//! - `update/particles/N`: one full filter update (motion, weighting of 60 beams, KLD resampling
//!   pinned at N particles, clustering) for several N; the particle count at which one update
//!   takes 10 ms is interpolated from these medians.
//!
//! `cargo bench -p mapkeeper-localiser --bench localiser`

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Pose2, cast_ray};
use mapkeeper_localiser::{BeamSet, FilterParams, LikelihoodField, Localiser, ParticleFrames};
use mapkeeper_sensor::LaserScan;
use std::f64::consts::PI;
use std::hint::black_box;

fn warehouse() -> OccupancyGrid {
    let Ok(geometry) = GridGeometry::new(280, 418, 0.05, Pose2::new(-7.0, -10.45, 0.0)) else {
        unreachable!("fixed geometry is valid")
    };
    let (w, h) = (geometry.width() as i32, geometry.height() as i32);
    let mut m = OccupancyGrid::filled(geometry, CellState::Unknown);
    for iy in 0..h {
        for ix in 0..w {
            let wall = ix == 0 || iy == 0 || ix == w - 1 || iy == h - 1;
            m.set(CellCoord::new(ix, iy), if wall { CellState::Occupied } else { CellState::Free });
        }
    }
    for row in 0..6 {
        for col in 0..3 {
            let (x0, y0) = (30 + col * 80, 30 + row * 62);
            for iy in y0..y0 + 18 {
                for ix in x0..x0 + 40 {
                    let edge = iy == y0 || iy == y0 + 17 || ix == x0 || ix == x0 + 39;
                    m.set(CellCoord::new(ix, iy), if edge { CellState::Occupied } else { CellState::Unknown });
                }
            }
        }
    }
    m
}

/// Two S300-like lidars (541 beams, 270°) at the Summit-XL's mounts, scanning from `robot`.
fn scans(map: &OccupancyGrid, robot: &Pose2) -> Vec<LaserScan> {
    let mounts = [Pose2::new(0.2865, -0.2089, -PI / 4.0), Pose2::new(-0.2865, 0.2089, 3.0 * PI / 4.0)];
    let inc = 0.5f64.to_radians();
    mounts
        .iter()
        .enumerate()
        .map(|(id, mount)| {
            let lidar = robot.compose(mount);
            let ranges_m = (0..541)
                .map(|i| {
                    cast_ray(map, lidar.position(), lidar.yaw - 0.75 * PI + i as f64 * inc, 30.0, true).range_m as f32
                })
                .collect();
            LaserScan {
                stamp_ns: 0,
                lidar_id: id as u32,
                lidar_in_robot: *mount,
                angle_min_rad: -0.75 * PI,
                angle_increment_rad: inc,
                range_min_m: 0.1,
                range_max_m: 29.9,
                ranges_m,
                sweep: None,
            }
        })
        .collect()
}

/// Deterministic pseudo-random poses in the aisles (xorshift).
fn poses(n: usize) -> Vec<Pose2> {
    let mut s = 0x2545_F491_4F6C_DD1Du64;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n).map(|_| Pose2::new(-5.5 + 0.2 * next(), -9.0 + 18.0 * next(), PI * (2.0 * next() - 1.0))).collect()
}

fn beam_evaluations(c: &mut Criterion) {
    let map = warehouse();
    let params = FilterParams::default();
    let field = LikelihoodField::new(&map, &params);
    let robot = Pose2::new(-5.45, 0.3, 0.4);
    let mut beams = BeamSet::new();
    for s in scans(&map, &robot) {
        beams.add_scan(&s, params.max_beams, params.laser_max_range_m, params.beam_selection);
    }
    let particles = poses(1000);
    let mut g = c.benchmark_group("likelihood_field");
    g.throughput(Throughput::Elements((particles.len() * beams.len()) as u64));
    g.bench_function("beam_evaluations", |b| {
        b.iter(|| {
            let mut total = 0.0;
            for p in &particles {
                total += field.log_likelihood(black_box(p), &beams);
            }
            black_box(total)
        })
    });
    // The filter's way: all particles beam by beam (the same values bit for bit).
    let (mut frames, mut out) = (ParticleFrames::new(), Vec::new());
    g.bench_function("beam_evaluations_batch", |b| {
        b.iter(|| {
            field.log_likelihoods(black_box(&particles), &beams, &mut frames, &mut out);
            black_box(out.iter().sum::<f64>())
        })
    });
    g.finish();
}

fn full_update(c: &mut Criterion) {
    let map = warehouse();
    let robot = Pose2::new(-5.45, 0.3, 0.4);
    let scans = scans(&map, &robot);
    let mut g = c.benchmark_group("update/particles");
    g.sample_size(20);
    for n in [1000usize, 2000, 5000, 10_000, 15_000] {
        let params = FilterParams {
            min_particles: n,
            max_particles: n,
            update_min_d_m: 0.0,
            update_min_a_rad: 0.0,
            ..FilterParams::default()
        };
        let Ok(mut f) = Localiser::new(&map, params, 1) else { unreachable!("valid parameters") };
        let _ = f.init_pose(robot, [[0.04, 0.0, 0.0], [0.0, 0.04, 0.0], [0.0, 0.0, 0.01]]);
        let mut odom = Pose2::IDENTITY;
        let step = Pose2::new(0.01, 0.0, 0.001);
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| {
                odom = odom.compose(&step);
                black_box(f.update(odom, &scans))
            })
        });
    }
    g.finish();
}

criterion_group!(benches, beam_evaluations, full_update);
criterion_main!(benches);
