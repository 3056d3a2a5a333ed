//! Ground truth as a mapper sees it: the cells of the exact raster G_i that noise-free lidars at
//! true poses along a route observe (their beams cross them or stop in them), everything else
//! unknown. This is the `observed` ground truth of `validate --ground-truth` (the paper's G_i
//! were SLAM Toolbox maps of an exploration run, which never contain the back of a wall) and the
//! "what the route observes" of the best achievable map.
//!
//! The beams are cast on the exact raster, not in the physics simulator: with no noise and true
//! poses, a mapper's cell states are those of the raster wherever a beam reaches, so the
//! observed map is the raster masked by visibility. Poses are taken every
//! [`OBSERVATION_STEP_M`] along the route, heading along each leg (two corner lidars of 270°
//! each see all round, so the heading matters little).

use mapkeeper_grid::{CellState, OccupancyGrid, Point2, Pose2, traverse_indexed};
use mapkeeper_sim::{LidarParams, Route};
use std::ops::ControlFlow;

/// Spacing of the observation poses along a route, metres.
pub const OBSERVATION_STEP_M: f64 = 0.5;

/// Poses along `route`, one every `step_m` metres of each leg (and its last point), each heading
/// along its leg. A route of one point gives that point facing +x.
pub fn route_poses(route: &Route, step_m: f64) -> Vec<Pose2> {
    let pts = route.points();
    let mut poses = Vec::new();
    for leg in pts.windows(2) {
        let (a, b) = (leg[0], leg[1]);
        let len = a.distance(b);
        let yaw = f64::atan2(b.y - a.y, b.x - a.x);
        let n = (len / step_m).ceil().max(1.0) as usize;
        for k in 0..n {
            let t = k as f64 / n as f64;
            poses.push(Pose2::new(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y), yaw));
        }
    }
    if let Some(&last) = pts.last() {
        let yaw = poses.last().map_or(0.0, |p| p.yaw);
        poses.push(Pose2::new(last.x, last.y, yaw));
    }
    poses
}

/// Which cells of `exact` the `lidars` observe from the robot at each of `poses`: every cell a
/// beam crosses up to its range limit, and the cell it stops in (the first cell that is not
/// free). A lidar whose origin is not in a free cell (an item of this world stands on that
/// point of the route) sees nothing from there: the robot could not be there. One entry per
/// cell, row-major.
pub fn visible_cells(exact: &OccupancyGrid, poses: &[Pose2], lidars: &[LidarParams]) -> Vec<bool> {
    let geometry = *exact.geometry();
    let cells = exact.cells();
    let mut seen = vec![false; cells.len()];
    for robot in poses {
        for lidar in lidars {
            let origin = robot.compose(&lidar.lidar_in_robot);
            if exact.get_world(origin.position()) != Some(CellState::Free) {
                continue;
            }
            for k in 0..lidar.beams {
                // (Upright: summed in this order, as ever, so the cells stay bit for bit the same.)
                let angle = if lidar.upside_down {
                    origin.yaw + lidar.beam_direction_rad(k)
                } else {
                    origin.yaw + lidar.angle_min_rad + k as f64 * lidar.angle_increment_rad
                };
                let (s, c) = angle.sin_cos();
                let r = lidar.range_max_m;
                let end = Point2::new(origin.x + c * r, origin.y + s * r);
                let _ = traverse_indexed(&geometry, origin.position(), end, |_, i| {
                    seen[i] = true;
                    if cells[i] == CellState::Free { ControlFlow::Continue(()) } else { ControlFlow::Break(()) }
                });
            }
        }
    }
    seen
}

/// `exact` with every cell outside `seen` made unknown.
pub fn restrict_to(exact: &OccupancyGrid, seen: &[bool]) -> OccupancyGrid {
    let mut out = exact.clone();
    for (cell, &s) in out.cells_mut().iter_mut().zip(seen) {
        if !s {
            *cell = CellState::Unknown;
        }
    }
    out
}

/// The observed ground truth: `exact` restricted to what `lidars` see from `route`.
pub fn observed_ground_truth(exact: &OccupancyGrid, route: &Route, lidars: &[LidarParams]) -> OccupancyGrid {
    restrict_to(exact, &visible_cells(exact, &route_poses(route, OBSERVATION_STEP_M), lidars))
}

#[cfg(test)]
mod tests {
    use super::*;
    use mapkeeper_grid::{CellCoord, GridGeometry};

    /// A 6 × 4 m room with one-cell walls at 0.1 m and a solid 1 × 1 m block in the middle.
    fn room() -> OccupancyGrid {
        let g = GridGeometry::new(60, 40, 0.1, Pose2::IDENTITY).unwrap();
        let mut m = OccupancyGrid::walled(g);
        for iy in 15..25 {
            for ix in 25..35 {
                m.set(CellCoord::new(ix, iy), CellState::Occupied);
            }
        }
        m
    }

    fn lidar() -> LidarParams {
        let mut l = LidarParams::sick_s300(Pose2::IDENTITY);
        l.angle_min_rad = -std::f64::consts::PI;
        l.angle_increment_rad = 0.25f64.to_radians();
        l.beams = 1440;
        l
    }

    #[test]
    fn a_lidar_sees_the_near_faces_but_not_the_back_of_walls_or_the_block_behind_itself() {
        let exact = room();
        let route = Route::new(&[Point2::new(1.0, 2.0)]);
        let g = observed_ground_truth(&exact, &route, &[lidar()]);
        let at = |x: f64, y: f64| g.get_world(Point2::new(x, y)).unwrap();
        assert_eq!(at(0.05, 2.0), CellState::Occupied, "the wall facing the robot");
        assert_eq!(at(2.55, 2.0), CellState::Occupied, "the block's near face");
        assert_eq!(at(2.95, 2.0), CellState::Unknown, "the block's inside");
        assert_eq!(at(4.0, 2.0), CellState::Unknown, "the floor in the block's shadow");
        assert_eq!(at(4.0, 0.5), CellState::Free, "the floor beside it");
        assert_eq!(at(5.95, 0.2), CellState::Occupied, "the far wall, seen past the block");
        // Nothing is invented: every known cell has the raster's state.
        for (o, e) in g.cells().iter().zip(exact.cells()) {
            assert!(*o == CellState::Unknown || o == e);
        }
        // Driving round the block shows its other faces and its shadow, never its inside.
        let round =
            Route::new(&[Point2::new(1.0, 2.0), Point2::new(1.0, 0.6), Point2::new(5.0, 0.6), Point2::new(5.0, 2.0)]);
        let g = observed_ground_truth(&exact, &round, &[lidar()]);
        let at = |x: f64, y: f64| g.get_world(Point2::new(x, y)).unwrap();
        assert_eq!(at(3.45, 2.0), CellState::Occupied);
        assert_eq!(at(4.0, 2.0), CellState::Free);
        assert_eq!(at(2.95, 2.0), CellState::Unknown);
    }

    #[test]
    fn a_pose_inside_an_item_sees_nothing() {
        let exact = room();
        let inside = Route::new(&[Point2::new(3.0, 2.0)]);
        let seen = visible_cells(&exact, &route_poses(&inside, 0.5), &[lidar()]);
        assert!(seen.iter().all(|&s| !s));
    }

    #[test]
    fn route_poses_are_spaced_along_each_leg_and_end_at_the_last_point() {
        let route = Route::new(&[Point2::new(0.0, 0.0), Point2::new(1.0, 0.0), Point2::new(1.0, 2.0)]);
        let p = route_poses(&route, 0.5);
        assert_eq!(p.len(), 2 + 4 + 1);
        assert_eq!((p[1].x, p[1].y, p[1].yaw), (0.5, 0.0, 0.0));
        assert!((p[2].yaw - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!((p[6].x, p[6].y), (1.0, 2.0));
        assert_eq!(route_poses(&Route::new(&[Point2::new(3.0, 1.0)]), 0.5), vec![Pose2::new(3.0, 1.0, 0.0)]);
    }
}
