//! What an experiment does to a closed-loop run and what it records: the kidnapping of the
//! chain localiser's estimate ([`KidnapControl`]), the paper's reaction to a Lost verdict
//! ([`LostPolicy`], counted in [`LostCounts`]) and, if asked, the verdict at every processed step ([`TimelineRecorder`])
//! (`RunnerParams::kidnap`, `RunnerParams::record_timeline`; used by the robustness
//! experiments, `docs/recovery.md`). Each is a control or an observer of the harness loop.

use crate::ExperimentError;
use mapkeeper_common::ParamError;
use mapkeeper_grid::{Pose2, angle_diff, wrap_angle};
pub use mapkeeper_harness::lost::{LostCounts, LostEnd, LostEpisode, LostPolicy};
use mapkeeper_harness::{Control, HarnessError, Observer, PoseBias, RobotControl, Session, SessionStep, Step};
use mapkeeper_updater::{PoseRecovery, RecoveryFailure, Verdict};
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
            return Err(ExperimentError::InvalidParam(ParamError::rule(
                "kidnap",
                format!("needs finite values, at_s and sigmas ≥ 0, got {self:?}"),
            )));
        }
        Ok(())
    }
}

/// A kidnapping of the robot itself: at the first scan tick at or after `at_s` the simulated
/// robot is moved to `to` (map frame) at once; its odometry does not see the jump, and the
/// localiser and the updater are not told. The experiment chooses `to` in free space.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotKidnap {
    /// When, seconds of simulated time.
    pub at_s: f64,
    /// Where the robot is put, map frame.
    pub to: Pose2,
}

impl RobotKidnap {
    pub(crate) fn validate(&self) -> Result<(), ExperimentError> {
        let ok = self.at_s.is_finite()
            && self.at_s >= 0.0
            && [self.to.x, self.to.y, self.to.yaw].iter().all(|v| v.is_finite());
        if !ok {
            return Err(ExperimentError::InvalidParam(ParamError::rule(
                "robot_kidnap",
                format!("needs a finite at_s ≥ 0 and a finite pose, got {self:?}"),
            )));
        }
        Ok(())
    }
}

#[derive(Clone, Copy, Debug)]
enum KidnapAction {
    Estimate(Kidnap),
    Robot(RobotKidnap),
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

/// What happened around a [`Kidnap`] or a [`RobotKidnap`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KidnapRecord {
    /// When it was applied, seconds.
    pub at_s: f64,
    /// The true pose then (after the move, for a robot kidnap).
    pub truth: Pose2,
    /// The displaced estimate (for a robot kidnap: the true pose before the move, where the
    /// estimate still believes the robot is).
    pub estimate: Pose2,
    /// Lost verdicts before the kidnap.
    pub lost_before: u64,
    /// First Lost verdict at or after the kidnap, seconds.
    pub first_lost_s: Option<f64>,
    /// Every pose that pose updating returned at or after the kidnap, with its true error.
    pub recoveries: Vec<TrackSample>,
    /// For each of `recoveries`: it came from the global search (`mapkeeper`), not from the
    /// paper's local pose updating.
    pub recoveries_global: Vec<bool>,
    /// Refused pose recoveries at or after the kidnap.
    pub failed_recoveries: u64,
    /// …of them refused because two distant poses fitted about equally well
    /// (`RecoveryFailure::Ambiguous`); the others fitted too few points or nothing at all.
    #[serde(default)]
    pub ambiguous_recoveries: u64,
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

/// Applies a [`Kidnap`] of the estimate (or a [`RobotKidnap`] of the robot) at its time and
/// records what followed.
#[derive(Clone, Debug)]
pub struct KidnapControl {
    action: KidnapAction,
    lost_seen: u64,
    record: Option<KidnapRecord>,
}

impl KidnapControl {
    /// A control that will apply `kidnap`.
    pub fn new(kidnap: Kidnap) -> Self {
        Self { action: KidnapAction::Estimate(kidnap), lost_seen: 0, record: None }
    }

    /// A control that will move the robot as `kidnap` says.
    pub fn robot(kidnap: RobotKidnap) -> Self {
        Self { action: KidnapAction::Robot(kidnap), lost_seen: 0, record: None }
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
        robot: Option<&mut dyn RobotControl>,
    ) -> Result<(), HarnessError> {
        let t_s = seconds(step);
        let Some(before) = step.truth.map(|t| t.pose_in_map) else { return Ok(()) };
        let at_s = match self.action {
            KidnapAction::Estimate(k) => k.at_s,
            KidnapAction::Robot(r) => r.at_s,
        };
        if self.record.is_some() || t_s < at_s {
            return Ok(());
        }
        let (truth, estimate) = match self.action {
            KidnapAction::Estimate(k) => {
                let estimate = Pose2::new(before.x + k.dx_m, before.y + k.dy_m, wrap_angle(before.yaw + k.dyaw_rad));
                let (s2, a2) = (k.sigma_xy_m.powi(2), k.sigma_yaw_rad.powi(2));
                session.set_estimate(estimate, [[s2, 0.0, 0.0], [0.0, s2, 0.0], [0.0, 0.0, a2]])?;
                (before, estimate)
            }
            KidnapAction::Robot(r) => {
                let Some(robot) = robot else {
                    return Err(HarnessError::Unsupported("a robot kidnap needs a source that drives a robot".into()));
                };
                robot.move_robot(r.to);
                (r.to, before)
            }
        };
        self.record = Some(KidnapRecord {
            at_s: t_s,
            truth,
            estimate,
            lost_before: self.lost_seen,
            first_lost_s: None,
            recoveries: Vec::new(),
            recoveries_global: Vec::new(),
            failed_recoveries: 0,
            ambiguous_recoveries: 0,
            track: Vec::new(),
        });
        Ok(())
    }

    fn after_step(
        &mut self,
        step: &Step,
        report: &SessionStep,
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
            let u = report.updater.as_ref();
            match u.and_then(|u| u.pose_recovery.as_ref()) {
                Some(PoseRecovery::Recovered { pose_in_map, .. }) => {
                    rec.recoveries.push(TrackSample::of(t_s, pose_in_map, &truth));
                    rec.recoveries_global.push(u.and_then(|u| u.global_search.as_ref()).is_some_and(|g| g.chosen));
                }
                Some(PoseRecovery::NotRecovered { reason }) => {
                    rec.failed_recoveries += 1;
                    rec.ambiguous_recoveries += u64::from(matches!(reason, RecoveryFailure::Ambiguous { .. }));
                }
                None => {}
            }
        }
        Ok(())
    }
}

/// A pose error held for a while: from the first scan tick at or after `at_s` and for
/// `hold_s` seconds (`inf`: to the end of the run), the pose the updater is given is the chain
/// localiser's estimate moved by (`dx_m`, `dy_m`) in the map frame and by `dyaw_rad`. The
/// localiser itself runs on unbiased, so when the hold ends the estimate is right again at once
/// (a localiser that was wrong for `hold_s` and then converged). A pose that pose updating hands
/// back re-initialises the localiser and ends the hold early.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseErrorHold {
    /// Start, seconds of simulated time.
    pub at_s: f64,
    /// Duration, seconds (`inf`: to the end of the run).
    #[serde(with = "mapkeeper_updater::params::inf_as_text")]
    pub hold_s: f64,
    /// Offset along the map's x axis, metres.
    pub dx_m: f64,
    /// Offset along the map's y axis, metres.
    pub dy_m: f64,
    /// Heading offset, radians.
    pub dyaw_rad: f64,
}

impl PoseErrorHold {
    pub(crate) fn validate(&self) -> Result<(), ExperimentError> {
        let ok = self.at_s.is_finite()
            && self.at_s >= 0.0
            && !self.hold_s.is_nan()
            && self.hold_s >= 0.0
            && [self.dx_m, self.dy_m, self.dyaw_rad].iter().all(|v| v.is_finite());
        if !ok {
            return Err(ExperimentError::InvalidParam(ParamError::rule(
                "pose_error",
                format!("needs finite offsets, at_s ≥ 0 and hold_s ≥ 0, got {self:?}"),
            )));
        }
        Ok(())
    }
}

/// When a [`PoseErrorHold`] acted.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseErrorRecord {
    /// The tick it began, seconds.
    pub began_s: f64,
    /// The tick it ended (time up, or a recovered pose), seconds; `None` if it lasted to the end.
    pub ended_s: Option<f64>,
    /// It was ended by pose updating (the localiser was re-initialised) before its time.
    pub ended_by_recovery: bool,
}

/// Applies a [`PoseErrorHold`] through the session's pose bias.
#[derive(Clone, Debug)]
pub struct PoseErrorControl {
    hold: PoseErrorHold,
    record: Option<PoseErrorRecord>,
}

impl PoseErrorControl {
    /// A control that will apply `hold`.
    pub fn new(hold: PoseErrorHold) -> Self {
        Self { hold, record: None }
    }

    /// What happened, if the hold's time was reached.
    pub fn into_record(self) -> Option<PoseErrorRecord> {
        self.record
    }
}

impl Control for PoseErrorControl {
    fn before_step(
        &mut self,
        step: &Step,
        session: &mut Session<'_>,
        _robot: Option<&mut dyn RobotControl>,
    ) -> Result<(), HarnessError> {
        let (h, t_s) = (self.hold, seconds(step));
        match self.record.as_mut() {
            None if t_s >= h.at_s => {
                if h.hold_s > 0.0 {
                    session.set_pose_bias(Some(PoseBias { dx_m: h.dx_m, dy_m: h.dy_m, dyaw_rad: h.dyaw_rad }));
                }
                let ended_s = (h.hold_s <= 0.0).then_some(t_s);
                self.record = Some(PoseErrorRecord { began_s: t_s, ended_s, ended_by_recovery: false });
            }
            Some(rec) if rec.ended_s.is_none() => {
                if session.pose_bias().is_none() {
                    rec.ended_s = Some(t_s);
                    rec.ended_by_recovery = true;
                } else if t_s >= rec.began_s + h.hold_s {
                    session.set_pose_bias(None);
                    rec.ended_s = Some(t_s);
                }
            }
            _ => {}
        }
        Ok(())
    }
}

/// The updater's verdicts, counted (over a run, a trial or a comparison row).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct VerdictCounts {
    /// Update.
    pub update: u64,
    /// Suspend.
    pub suspend: u64,
    /// Lost.
    pub lost: u64,
}

/// Records every processed step's verdict with the chain localiser's true error.
#[derive(Clone, Debug, Default)]
pub struct TimelineRecorder {
    /// The samples, in order.
    pub samples: Vec<TimelineSample>,
}

impl Observer for TimelineRecorder {
    fn on_step(&mut self, step: &Step, report: &SessionStep, _session: &Session<'_>) {
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
