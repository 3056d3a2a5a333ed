//! What an experiment does to a closed-loop run and what it records: the kidnapping of the
//! chain localiser's estimate ([`KidnapControl`]), the paper's reaction to a Lost verdict
//! ([`LostPolicy`]) and, if asked, the verdict at every processed step ([`TimelineRecorder`])
//! (`RunnerParams::kidnap`, `RunnerParams::record_timeline`; used by the robustness
//! experiments, `docs/recovery.md`). Each is a control or an observer of the harness loop.

use crate::experiments::ExperimentError;
use mapkeeper_grid::{Pose2, angle_diff, wrap_angle};
use mapkeeper_harness::{Control, HarnessError, Observer, RobotControl, Session, Step, StepReport};
use mapkeeper_localiser::Covariance3;
use mapkeeper_updater::{PoseRecovery, Verdict};
use serde::{Deserialize, Serialize};

/// A kidnapping of the chain localiser's estimate: at the first scan tick at or after `at_s`,
/// the chain localiser is re-initialised at the true pose displaced by (`dx_m`, `dy_m`) in the
/// map frame and by `dyaw_rad`, with a Gaussian of the given spreads. The robot, its odometry
/// and the updater are not told. With `at_s` = 0 it is an initial error in a chosen direction.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Kidnap {
    /// When, seconds of simulated time.
    pub at_s: f64,
    /// Displacement of the estimate along the map's x axis, metres.
    pub dx_m: f64,
    /// Displacement of the estimate along the map's y axis, metres.
    pub dy_m: f64,
    /// Yaw displacement of the estimate, radians.
    pub dyaw_rad: f64,
    /// Standard deviation of the new particle cloud in x and y, metres.
    pub sigma_xy_m: f64,
    /// Standard deviation of the new particle cloud in yaw, radians.
    pub sigma_yaw_rad: f64,
}

impl Kidnap {
    pub(crate) fn validate(&self) -> Result<(), ExperimentError> {
        let finite = [self.at_s, self.dx_m, self.dy_m, self.dyaw_rad, self.sigma_xy_m, self.sigma_yaw_rad];
        if finite.iter().any(|v| !v.is_finite()) || self.at_s < 0.0 || self.sigma_xy_m < 0.0 || self.sigma_yaw_rad < 0.0
        {
            return Err(ExperimentError::InvalidParam {
                name: "kidnap",
                problem: format!("needs finite values, at_s and sigmas ≥ 0, got {self:?}"),
            });
        }
        Ok(())
    }
}

/// The chain localiser's error at one scan tick.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrackSample {
    /// Simulated time, seconds.
    pub t_s: f64,
    /// Position error, metres.
    pub error_m: f64,
    /// Absolute yaw error, radians.
    pub yaw_error_rad: f64,
}

/// What happened around a [`Kidnap`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KidnapRecord {
    /// When it was applied, seconds.
    pub at_s: f64,
    /// The true pose then.
    pub truth: Pose2,
    /// The displaced estimate.
    pub estimate: Pose2,
    /// Lost verdicts before the kidnap.
    pub lost_before: u64,
    /// First Lost verdict at or after the kidnap, seconds.
    pub first_lost_s: Option<f64>,
    /// Every pose that pose updating returned at or after the kidnap, with its true error.
    pub recoveries: Vec<TrackSample>,
    /// Refused pose recoveries at or after the kidnap.
    pub failed_recoveries: u64,
    /// The chain localiser's error at every scan tick from the kidnap on.
    pub track: Vec<TrackSample>,
}

/// One processed step of the updater (with [`crate::RunnerParams::record_timeline`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimelineSample {
    /// Simulated time, seconds.
    pub t_s: f64,
    /// The localisation check's verdict.
    pub verdict: Verdict,
    /// Valid beams n.
    pub n_valid: u32,
    /// Detected-change beams n_dc.
    pub n_dc: u32,
    /// The chain localiser's position error, metres.
    pub error_m: f64,
    /// Its absolute yaw error, radians.
    pub yaw_error_rad: f64,
    /// On Lost: whether pose updating returned a pose.
    pub recovered: Option<bool>,
}

impl TrackSample {
    fn of(t_s: f64, pose: &Pose2, truth: &Pose2) -> Self {
        Self { t_s, error_m: pose.distance(truth), yaw_error_rad: angle_diff(pose.yaw, truth.yaw).abs() }
    }
}

fn seconds(step: &Step) -> f64 {
    step.frame.stamp_ns as f64 / 1e9
}

/// Applies a [`Kidnap`] of the estimate at its time and records what followed.
#[derive(Clone, Debug)]
pub struct KidnapControl {
    kidnap: Kidnap,
    lost_seen: u64,
    record: Option<KidnapRecord>,
}

impl KidnapControl {
    /// A control that will apply `kidnap`.
    pub fn new(kidnap: Kidnap) -> Self {
        Self { kidnap, lost_seen: 0, record: None }
    }

    /// What happened, if the kidnap's time was reached.
    pub fn into_record(self) -> Option<KidnapRecord> {
        self.record
    }
}

impl Control for KidnapControl {
    fn before_step(
        &mut self,
        step: &Step,
        session: &mut Session<'_>,
        _robot: Option<&mut dyn RobotControl>,
    ) -> Result<(), HarnessError> {
        let (k, t_s) = (self.kidnap, seconds(step));
        let Some(truth) = step.truth.map(|t| t.pose_in_map) else { return Ok(()) };
        if self.record.is_some() || t_s < k.at_s {
            return Ok(());
        }
        let estimate = Pose2::new(truth.x + k.dx_m, truth.y + k.dy_m, wrap_angle(truth.yaw + k.dyaw_rad));
        let (s2, a2) = (k.sigma_xy_m.powi(2), k.sigma_yaw_rad.powi(2));
        session.set_estimate(estimate, [[s2, 0.0, 0.0], [0.0, s2, 0.0], [0.0, 0.0, a2]])?;
        self.record = Some(KidnapRecord {
            at_s: t_s,
            truth,
            estimate,
            lost_before: self.lost_seen,
            first_lost_s: None,
            recoveries: Vec::new(),
            failed_recoveries: 0,
            track: Vec::new(),
        });
        Ok(())
    }

    fn after_step(
        &mut self,
        step: &Step,
        report: &StepReport,
        _session: &mut Session<'_>,
        _robot: Option<&mut dyn RobotControl>,
    ) -> Result<(), HarnessError> {
        let verdict = report.updater.as_ref().and_then(|u| u.verdict);
        let lost = verdict == Some(Verdict::Lost);
        self.lost_seen += u64::from(lost);
        let (Some(rec), Some(truth)) = (self.record.as_mut(), step.truth.map(|t| t.pose_in_map)) else {
            return Ok(());
        };
        let t_s = seconds(step);
        if let Some(loc) = &report.localiser {
            rec.track.push(TrackSample::of(t_s, &loc.estimate.pose_in_map, &truth));
        }
        if lost {
            rec.first_lost_s.get_or_insert(t_s);
            match report.updater.as_ref().and_then(|u| u.pose_recovery.as_ref()) {
                Some(PoseRecovery::Recovered { pose_in_map, .. }) => {
                    rec.recoveries.push(TrackSample::of(t_s, pose_in_map, &truth))
                }
                Some(PoseRecovery::NotRecovered { .. }) => rec.failed_recoveries += 1,
                None => {}
            }
        }
        Ok(())
    }
}

/// The reaction to a Lost verdict: stop the robot (resumed by the source after
/// `lost_wait_s`), and when pose updating returns a pose, re-initialise the chain localiser
/// there, make it the updater's last good pose and resume.
#[derive(Clone, Copy, Debug)]
pub struct LostPolicy {
    /// Stop the robot on Lost.
    pub stop_on_lost: bool,
    /// Resume after this long stopped even without a recovered pose, seconds.
    pub lost_wait_s: f64,
    /// The initial covariance: a quarter of each of its variances is the floor of the
    /// recovered pose's (ICP's own is optimistic), and all of it the fallback.
    pub floor: Covariance3,
}

impl Control for LostPolicy {
    fn after_step(
        &mut self,
        step: &Step,
        report: &StepReport,
        session: &mut Session<'_>,
        robot: Option<&mut dyn RobotControl>,
    ) -> Result<(), HarnessError> {
        let Some(u) = report.updater.as_ref().filter(|u| u.verdict == Some(Verdict::Lost)) else { return Ok(()) };
        let mut robot = robot;
        if self.stop_on_lost
            && let Some(r) = robot.as_deref_mut()
        {
            r.stop(Some(self.lost_wait_s));
        }
        if let Some(PoseRecovery::Recovered { pose_in_map, covariance, .. }) = &u.pose_recovery {
            let mut c = *covariance;
            for (k, row) in c.iter_mut().enumerate() {
                row[k] = row[k].max(self.floor[k][k] * 0.25);
            }
            if session.set_estimate(*pose_in_map, c).is_err() {
                session.set_estimate(*pose_in_map, self.floor)?;
            }
            let odometry = step.frame.odometry.unwrap_or(*pose_in_map);
            session.reset_updater_reference(*pose_in_map, odometry);
            if let Some(r) = robot {
                r.resume();
            }
        }
        Ok(())
    }
}

/// Records every processed step's verdict with the chain localiser's true error.
#[derive(Clone, Debug, Default)]
pub struct TimelineRecorder {
    /// The samples, in order.
    pub samples: Vec<TimelineSample>,
}

impl Observer for TimelineRecorder {
    fn on_step(&mut self, step: &Step, report: &StepReport) {
        let (Some(u), Some(pose), Some(truth)) = (report.updater.as_ref(), report.pose_in_map, step.truth) else {
            return;
        };
        let Some(verdict) = u.verdict else { return };
        let truth = truth.pose_in_map;
        self.samples.push(TimelineSample {
            t_s: seconds(step),
            verdict,
            n_valid: u32::try_from(u.n_valid).unwrap_or(u32::MAX),
            n_dc: u32::try_from(u.n_dc).unwrap_or(u32::MAX),
            error_m: pose.distance(&truth),
            yaw_error_rad: angle_diff(pose.yaw, truth.yaw).abs(),
            recovered: u.pose_recovery.as_ref().map(|r| matches!(r, PoseRecovery::Recovered { .. })),
        });
    }
}
