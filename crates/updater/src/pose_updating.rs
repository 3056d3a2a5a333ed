//! Pose updating (§4.6). When the localisation check says Lost, the expected point cloud
//! P_exp is ray-cast from the current `M_i` at the predicted pose (the last pose that passed
//! the check, moved on by odometry since), and the current scans' points P(k) are registered to
//! it with ICP from several initial hypotheses. The best fit must pass a fitness gate (inlier
//! ratio, RMSE) and must not be ambiguous; otherwise the answer is "not recovered" — never a
//! wrong pose silently.

use crate::icp::{Fitness, PointGrid, fitness, icp_from};
use crate::params::PoseUpdatingParams;
use mapkeeper_grid::{OccupancyGrid, Point2, Pose2, RayStop, angle_diff, cast_ray};
use mapkeeper_sensor::{BeamValidity, LaserScan};

/// ICP iterations every hypothesis gets before the best ones are refined.
const COARSE_ITERATIONS: u32 = 8;
/// Hypotheses iterated to convergence (and compared for ambiguity).
const REFINED_HYPOTHESES: usize = 6;

/// Best first: more inliers, then lower RMSE, then hypothesis order (stable sort).
fn sort_candidates(c: &mut [(Pose2, Fitness, f64, bool)]) {
    c.sort_by(|a, b| b.1.inlier_ratio.total_cmp(&a.1.inlier_ratio).then(a.1.rmse_m.total_cmp(&b.1.rmse_m)));
}

/// Result of pose updating.
#[derive(Clone, Debug, PartialEq)]
pub enum PoseRecovery {
    /// A pose that passed the fitness gate.
    Recovered {
        /// The robot's pose in the map.
        pose_in_map: Pose2,
        /// Covariance of (x, y, yaw), m² / m·rad / rad²: RMSE² · (Σ JᵀJ)⁻¹ over the inliers.
        covariance: [[f64; 3]; 3],
        /// Fit quality of the accepted pose.
        fitness: Fitness,
    },
    /// No trustworthy pose.
    NotRecovered {
        /// Why.
        reason: RecoveryFailure,
    },
}

/// Why pose updating gave up.
#[derive(Clone, Debug, PartialEq)]
pub enum RecoveryFailure {
    /// Too few scan points or expected points to register.
    TooFewPoints {
        /// Scan points available.
        source: usize,
        /// Expected points available.
        expected: usize,
    },
    /// The best hypothesis failed the fitness gate.
    PoorFit {
        /// Its fitness.
        best: Fitness,
    },
    /// Two distant poses fit about equally well.
    Ambiguous {
        /// The best pose.
        first: Pose2,
        /// A distant runner-up.
        second: Pose2,
    },
    /// The fit does not constrain all three degrees of freedom.
    Degenerate,
}

/// Pose updating with its reusable buffers.
#[derive(Clone, Debug, Default)]
pub struct PoseUpdater {
    source: Vec<Point2>,
    expected: Vec<Point2>,
    grid: PointGrid,
    candidates: Vec<(Pose2, Fitness, f64, bool)>,
}

impl PoseUpdater {
    /// Empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Registers `scans` (robot frame, via each lidar's mounting pose) to the cloud expected in
    /// `map` from `predicted_in_map`. Rays of the expected cloud start at each lidar's position
    /// and count unknown cells as occupied; beams beyond `max_range_m` are not used.
    pub fn recover(
        &mut self,
        map: &OccupancyGrid,
        predicted_in_map: Pose2,
        scans: &[LaserScan],
        max_range_m: f64,
        p: &PoseUpdatingParams,
    ) -> PoseRecovery {
        self.source.clear();
        self.expected.clear();
        let step = p.source_beam_step.max(1) as usize;
        for scan in scans {
            if scan.validate().is_err() {
                continue;
            }
            let range_max = max_range_m.min(scan.range_max_m as f64);
            let lidar_in_map = scan.lidar_in_map(&predicted_in_map);
            let mut valid_k = 0usize;
            for (i, &r) in scan.ranges_m.iter().enumerate() {
                let a = scan.beam_angle(i as f64);
                let e = cast_ray(map, lidar_in_map.position(), lidar_in_map.yaw + a, range_max, true);
                if matches!(e.stop, RayStop::Occupied | RayStop::Unknown) {
                    let (s, c) = (lidar_in_map.yaw + a).sin_cos();
                    self.expected.push(Point2::new(lidar_in_map.x + e.range_m * c, lidar_in_map.y + e.range_m * s));
                }
                if scan.validity_of(r) == BeamValidity::Valid && (r as f64) < range_max {
                    if valid_k.is_multiple_of(step) {
                        let (s, c) = a.sin_cos();
                        let z = r as f64;
                        self.source.push(scan.lidar_in_robot.transform_point(Point2::new(z * c, z * s)));
                    }
                    valid_k += 1;
                }
            }
        }
        let min = p.min_points as usize;
        if self.source.len() < min.max(3) || self.expected.len() < min.max(3) {
            return PoseRecovery::NotRecovered {
                reason: RecoveryFailure::TooFewPoints { source: self.source.len(), expected: self.expected.len() },
            };
        }
        self.grid.build(&self.expected, p.max_correspondence_m);
        self.candidates.clear();
        for &dyaw in &p.yaw_offsets_rad {
            for &dx in &p.position_offsets_m {
                for &dy in &p.position_offsets_m {
                    let init =
                        Pose2::new(predicted_in_map.x + dx, predicted_in_map.y + dy, predicted_in_map.yaw + dyaw);
                    let (run, d) =
                        icp_from(&self.source, &self.grid, init, p, p.max_correspondence_m, COARSE_ITERATIONS);
                    let (fit, _) = fitness(&self.source, &self.grid, &run.pose, p.inlier_distance_m);
                    self.candidates.push((run.pose, fit, d, run.converged));
                }
            }
        }
        // Coarse-to-fine: only the most promising hypotheses are iterated to convergence.
        sort_candidates(&mut self.candidates);
        for cand in self.candidates.iter_mut().take(REFINED_HYPOTHESES) {
            if !cand.3 {
                let rest = p.max_iterations.saturating_sub(COARSE_ITERATIONS).max(1);
                let (run, d) = icp_from(&self.source, &self.grid, cand.0, p, cand.2, rest);
                let (fit, _) = fitness(&self.source, &self.grid, &run.pose, p.inlier_distance_m);
                *cand = (run.pose, fit, d, run.converged);
            }
        }
        self.candidates.truncate(REFINED_HYPOTHESES);
        sort_candidates(&mut self.candidates);
        let (best_pose, best_fit, _, _) = self.candidates[0];
        if best_fit.inlier_ratio < p.min_inlier_ratio || best_fit.rmse_m > p.max_rmse_m {
            return PoseRecovery::NotRecovered { reason: RecoveryFailure::PoorFit { best: best_fit } };
        }
        for &(pose, fit, _, _) in &self.candidates[1..] {
            if best_fit.inlier_ratio - fit.inlier_ratio > p.ambiguity_ratio_margin {
                break;
            }
            if pose.distance(&best_pose) > p.ambiguity_distance_m
                || angle_diff(pose.yaw, best_pose.yaw).abs() > p.ambiguity_rotation_rad
            {
                return PoseRecovery::NotRecovered {
                    reason: RecoveryFailure::Ambiguous { first: best_pose, second: pose },
                };
            }
        }
        let (fit, h) = fitness(&self.source, &self.grid, &best_pose, p.inlier_distance_m);
        let Some(h_inv) = h.try_inverse() else {
            return PoseRecovery::NotRecovered { reason: RecoveryFailure::Degenerate };
        };
        // Floor the residual at 1 cm so a perfect synthetic fit still has a usable covariance.
        let sigma2 = fit.rmse_m.max(0.01).powi(2);
        let mut covariance = [[0.0; 3]; 3];
        for (r, row) in covariance.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = sigma2 * h_inv[(r, c)];
            }
        }
        if covariance.iter().flatten().any(|v| !v.is_finite()) || covariance[2][2] <= 0.0 {
            return PoseRecovery::NotRecovered { reason: RecoveryFailure::Degenerate };
        }
        PoseRecovery::Recovered { pose_in_map: best_pose, covariance, fitness: fit }
    }
}
