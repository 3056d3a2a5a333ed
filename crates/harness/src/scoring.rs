//! Scoring a run against the truth: localisation accuracy and uncertainty ([`LocStats`]), the
//! chain localiser's error along the route, the trajectories, the updater's work. Observers
//! only: they read the truth, the estimators never do.

use crate::driver::Observer;
use crate::session::{BaselineSample, SessionStep};
use crate::source::Step;
use mapkeeper_grid::{Pose2, angle_diff};
use mapkeeper_localiser::Estimate;
use mapkeeper_sensor::StampedPose;
use mapkeeper_updater::StepOutcome;
use serde::{Deserialize, Serialize};

/// One localiser's accuracy and uncertainty over a run, at its sensor updates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LocStats {
    /// Sensor updates recorded.
    pub updates: u64,
    /// Mean position error, metres.
    pub mean_error_m: f64,
    /// Largest position error, metres.
    pub max_error_m: f64,
    /// Root mean square position error, metres.
    pub rmse_m: f64,
    /// Root mean square yaw error, radians.
    pub yaw_rmse_rad: f64,
    /// Mean trace of the 3×3 covariance (m² + rad², as the paper's Fig. 26).
    pub mean_trace: f64,
    /// Standard deviation of the trace.
    pub std_trace: f64,
    /// Mean largest eigenvalue of the covariance.
    pub mean_lambda_max: f64,
    /// Standard deviation of λmax.
    pub std_lambda_max: f64,
    /// Position error at the last update, metres.
    pub final_error_m: f64,
}

/// Running sums for [`LocStats`].
#[derive(Clone, Debug, Default)]
pub struct LocAcc {
    n: u64,
    sum_e: f64,
    sum_e2: f64,
    max_e: f64,
    sum_yaw2: f64,
    sum_tr: f64,
    sum_tr2: f64,
    sum_l: f64,
    sum_l2: f64,
    last_e: f64,
}

impl LocAcc {
    /// Adds one estimate scored against the true pose.
    pub fn add(&mut self, est: &Estimate, truth: &Pose2) {
        let e = est.pose_in_map.distance(truth);
        let dyaw = angle_diff(est.pose_in_map.yaw, truth.yaw);
        let c = &est.covariance;
        let tr = c[0][0] + c[1][1] + c[2][2];
        let l = est.lambda_max();
        self.n += 1;
        self.sum_e += e;
        self.sum_e2 += e * e;
        self.max_e = self.max_e.max(e);
        self.sum_yaw2 += dyaw * dyaw;
        self.sum_tr += tr;
        self.sum_tr2 += tr * tr;
        self.sum_l += l;
        self.sum_l2 += l * l;
        self.last_e = e;
    }

    /// The statistics so far (zeros before the first estimate).
    pub fn stats(&self) -> LocStats {
        if self.n == 0 {
            return LocStats::default();
        }
        let n = self.n as f64;
        let sd = |s: f64, s2: f64| ((s2 / n) - (s / n).powi(2)).max(0.0).sqrt();
        LocStats {
            updates: self.n,
            mean_error_m: self.sum_e / n,
            max_error_m: self.max_e,
            rmse_m: (self.sum_e2 / n).sqrt(),
            yaw_rmse_rad: (self.sum_yaw2 / n).sqrt(),
            mean_trace: self.sum_tr / n,
            std_trace: sd(self.sum_tr, self.sum_tr2),
            mean_lambda_max: self.sum_l / n,
            std_lambda_max: sd(self.sum_l, self.sum_l2),
            final_error_m: self.last_e,
        }
    }
}

/// The chain localiser's error at one of its sensor updates.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorSample {
    /// Distance the robot had travelled (true), metres.
    pub distance_m: f64,
    /// Position error, metres.
    pub error_m: f64,
    /// Absolute yaw error, radians.
    pub yaw_error_rad: f64,
}

/// The true and estimated trajectories of a run (TUM-ready).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Trajectories {
    /// The true pose.
    pub truth: Vec<StampedPose>,
    /// The chain localiser (on M_{i-1}).
    pub chain: Vec<StampedPose>,
    /// The baseline localiser (on M_1).
    pub baseline: Vec<StampedPose>,
}

/// Scores the chain localiser at its sensor updates, records the truth of every step (for the
/// baseline's score) and, if asked, the trajectories.
#[derive(Clone, Debug, Default)]
pub struct LocScore {
    /// The chain localiser's running statistics.
    pub chain: LocAcc,
    /// Its error at each sensor update.
    pub chain_errors: Vec<ErrorSample>,
    /// The true pose at every step with truth.
    pub truth: Vec<StampedPose>,
    /// The true and chain trajectories at every step, if recorded.
    pub trajectories: Option<Trajectories>,
}

impl LocScore {
    /// A scorer; with `record_trajectories` it also keeps the trajectories.
    pub fn new(record_trajectories: bool) -> Self {
        Self { trajectories: record_trajectories.then(Trajectories::default), ..Self::default() }
    }

    /// Scores the baseline localiser's updates against the truth recorded at the same stamps
    /// (in order) and, with trajectories, records its trajectory.
    pub fn score_baseline(&mut self, samples: &[BaselineSample]) -> LocStats {
        let mut acc = LocAcc::default();
        let mut k = 0;
        for s in samples {
            while self.truth.get(k).is_some_and(|t| t.stamp_ns < s.stamp_ns) {
                k += 1;
            }
            if s.sensor_update
                && let Some(t) = self.truth.get(k).filter(|t| t.stamp_ns == s.stamp_ns)
            {
                acc.add(&s.estimate, &t.pose);
            }
            if let Some(tr) = self.trajectories.as_mut() {
                tr.baseline.push(StampedPose { stamp_ns: s.stamp_ns, pose: s.estimate.pose_in_map });
            }
        }
        acc.stats()
    }
}

impl Observer for LocScore {
    fn on_step(&mut self, step: &Step, report: &SessionStep, _session: &crate::Session<'_>) {
        let Some(truth) = step.truth else { return };
        let stamp_ns = step.frame.stamp_ns;
        self.truth.push(StampedPose { stamp_ns, pose: truth.pose_in_map });
        if let Some(r) = report.localiser.as_ref().filter(|r| r.sensor_update) {
            let est = &r.estimate;
            self.chain.add(est, &truth.pose_in_map);
            self.chain_errors.push(ErrorSample {
                distance_m: truth.distance_m,
                error_m: est.pose_in_map.distance(&truth.pose_in_map),
                yaw_error_rad: angle_diff(est.pose_in_map.yaw, truth.pose_in_map.yaw).abs(),
            });
        }
        if let (Some(t), Some(pose)) = (self.trajectories.as_mut(), report.pose_in_map) {
            t.truth.push(StampedPose { stamp_ns, pose: truth.pose_in_map });
            t.chain.push(StampedPose { stamp_ns, pose });
        }
    }
}

/// The updater's work: valid beams of processed steps, the largest change state, the time per
/// processed step.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct UpdaterWork {
    /// Valid beams over processed steps.
    pub beams: u64,
    /// Largest change state seen after a processed step, bytes.
    pub max_state_bytes: u64,
    /// Updater time per processed step, microseconds, in order (empty without a clock).
    pub step_times_us: Vec<u32>,
}

impl Observer for UpdaterWork {
    fn on_step(&mut self, _step: &Step, report: &SessionStep, _session: &crate::Session<'_>) {
        let Some(u) = report.updater.as_ref().filter(|u| u.outcome == StepOutcome::Processed) else { return };
        self.beams += u.n_valid as u64;
        if let Some(ns) = report.updater_ns {
            self.step_times_us.push(u32::try_from(ns / 1000).unwrap_or(u32::MAX));
        }
        self.max_state_bytes = self.max_state_bytes.max(report.updater_state_bytes);
    }
}
