//! The paper's reaction to a Lost verdict, as a control of the loop: stop the robot, keep
//! feeding scans on which the updater retries pose updating, hand a recovered pose back to the
//! chain localiser and the updater, resume ([`LostPolicy`], counted in [`LostCounts`]). The
//! simulated runs and the replay of a recorded log (`update_log` with the localiser) use the
//! same policy; a replayed log has no robot to stop.

use crate::{Control, HarnessError, RobotControl, Session, SessionStep, Step};
use mapkeeper_grid::Pose2;
use mapkeeper_localiser::Covariance3;
use mapkeeper_updater::{PoseRecovery, Verdict};
use serde::{Deserialize, Serialize};

/// How long a Lost episode may last without a recovered pose before the robot resumes anyway,
/// seconds (the default of the simulated runs and of the replay).
pub const DEFAULT_LOST_WAIT_S: f64 = 2.0;

/// Holding a handed-over pose (issue 54 item 1): for `hold_s` after pose updating hands a
/// pose over, every step whose registration before writing (`mapkeeper`'s
/// `registration.enabled`) accepts a correction of at least `min_shift_m` or `min_turn_rad`
/// re-seeds the chain localiser at the refined pose, with the fit's own uncertainty (floored as
/// a handover's is). The failure it prevents: a filter re-seeded at the right pose in a stale
/// world drifts back past 0.2 m or 5° within seconds (its particles follow the changed
/// structure), while the scan still fits the map's unchanged surfaces at the right pose. On for
/// 30 s by default (`hold_s` = 0 turns it off; `docs/recovery.md`, "Holding what was found",
/// has the measurements); without registration (`paper`, `authors`) it does nothing.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HandoverHold {
    /// How long after a handover registration may correct the localiser, seconds; 0: off.
    /// Default 30.
    pub hold_s: f64,
    /// Smallest accepted correction that re-seeds, metres. Default 0.05.
    pub min_shift_m: f64,
    /// …or the smallest turn, radians. Default 1° (0.01745).
    pub min_turn_rad: f64,
}

impl Default for HandoverHold {
    fn default() -> Self {
        Self { hold_s: 30.0, min_shift_m: 0.05, min_turn_rad: 1f64.to_radians() }
    }
}

impl HandoverHold {
    /// No hold: a handed-over pose is left to the filter (the behaviour before issue 54).
    pub fn off() -> Self {
        Self { hold_s: 0.0, ..Self::default() }
    }

    /// Whether it is off (`hold_s` = 0).
    pub fn is_off(&self) -> bool {
        self.hold_s <= 0.0
    }

    /// Checks every field: finite and ≥ 0; the error names the field (`handover_hold.<field>`).
    pub fn validate(&self) -> Result<(), mapkeeper_common::ParamError> {
        for (name, v) in [
            ("handover_hold.hold_s", self.hold_s),
            ("handover_hold.min_shift_m", self.min_shift_m),
            ("handover_hold.min_turn_rad", self.min_turn_rad),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(mapkeeper_common::ParamError::new(name, v, "must be finite and ≥ 0"));
            }
        }
        Ok(())
    }
}

/// How a Lost episode ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LostEnd {
    /// Pose updating returned a pose; the chain localiser was re-initialised there.
    Recovered,
    /// A processed step said Update or Suspend again before any recovery.
    Cleared,
    /// No recovery within `lost_wait_s`: the robot resumed without a new pose.
    GaveUp,
    /// The run ended during the episode.
    RunEnded,
}

impl LostEnd {
    /// Its name in CSV files: `recovered`, `cleared`, `gave-up`, `run-ended` (as serialised).
    pub fn name(self) -> &'static str {
        match self {
            LostEnd::Recovered => "recovered",
            LostEnd::Cleared => "cleared",
            LostEnd::GaveUp => "gave-up",
            LostEnd::RunEnded => "run-ended",
        }
    }
}

/// One Lost episode: from the Lost verdict that opened it to its end.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LostEpisode {
    /// The stamp of the Lost step that opened it, nanoseconds.
    pub start_ns: u64,
    /// The stamp of the step that ended it (the last step seen, with [`LostEnd::RunEnded`]).
    pub end_ns: u64,
    /// Whether the robot was stopped for it (`stop_on_lost` and a source that drives a robot).
    pub stopped: bool,
    /// Attempts of pose updating in it (steps whose report has `pose_recovery`).
    pub attempts: u64,
    /// How it ended.
    pub end: LostEnd,
}

/// The reaction to Lost over a run, per run (summed over worlds in the validation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct LostCounts {
    /// Lost episodes (a Lost verdict while no episode was open).
    pub episodes: u64,
    /// Attempts of pose updating (steps with `pose_recovery`, recovered or refused).
    pub attempts: u64,
    /// Episodes ended by a recovered pose.
    pub recoveries: u64,
    /// Episodes ended by Update or Suspend before any recovery.
    pub cleared: u64,
    /// Episodes given up after `lost_wait_s` without a recovered pose.
    pub give_ups: u64,
    /// Time the robot stood stopped for Lost, nanoseconds of simulated time.
    pub stopped_ns: u64,
    /// Re-seedings of the localiser by registration while holding a handed-over pose
    /// ([`HandoverHold`]; not written when 0).
    #[serde(skip_serializing_if = "is_zero")]
    pub hold_corrections: u64,
}

fn is_zero(v: &u64) -> bool {
    *v == 0
}

impl LostCounts {
    /// [`LostCounts::stopped_ns`] in seconds.
    pub fn stopped_s(&self) -> f64 {
        self.stopped_ns as f64 / 1e9
    }

    /// The sum of two runs' counts.
    pub fn add(&self, o: &Self) -> Self {
        Self {
            episodes: self.episodes + o.episodes,
            attempts: self.attempts + o.attempts,
            recoveries: self.recoveries + o.recoveries,
            cleared: self.cleared + o.cleared,
            give_ups: self.give_ups + o.give_ups,
            stopped_ns: self.stopped_ns + o.stopped_ns,
            hold_corrections: self.hold_corrections + o.hold_corrections,
        }
    }
}

/// One line: `N episodes, N attempts, recovered/cleared/gave up a/b/c, stopped S s`.
impl std::fmt::Display for LostCounts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} episodes, {} attempts, recovered/cleared/gave up {}/{}/{}, stopped {:.1} s",
            self.episodes,
            self.attempts,
            self.recoveries,
            self.cleared,
            self.give_ups,
            self.stopped_s()
        )
    }
}

/// The reaction to a Lost verdict (the paper stops the robot until pose updating is done): on
/// Lost, stop the robot (at once) and keep feeding the scans, on which the updater retries pose
/// updating itself; when it returns a pose, re-initialise the chain localiser there, make it the
/// updater's last good pose and resume. A processed Update or Suspend ends the episode too
/// (resume); after `lost_wait_s` without a recovered pose, resume anyway and count a give-up.
/// The next Lost opens a new episode. Counts everything in [`LostCounts`].
#[derive(Clone, Debug)]
pub struct LostPolicy {
    stop_on_lost: bool,
    lost_wait_ns: u64,
    floor: Covariance3,
    open: Option<LostEpisode>,
    last_stamp_ns: u64,
    counts: LostCounts,
    episodes: Vec<LostEpisode>,
    hold: HandoverHold,
    /// The stamp of the last handover, nanoseconds.
    handed_over_ns: Option<u64>,
    /// How long the robot walks on after a stopped episode gave up, nanoseconds (0: it stops
    /// again at the next Lost).
    walk_ns: u64,
    /// Lost steps before this stamp do not stop the robot (it walks on, looking).
    walk_until_ns: Option<u64>,
}

impl LostPolicy {
    /// A policy that stops the robot on Lost if `stop_on_lost`, gives up after `lost_wait_s`
    /// (finite, ≥ 0; checked by `RunnerParams::validate`), and floors the recovered pose's
    /// covariance at a quarter of `floor`'s variances (ICP's own is optimistic), `floor` itself
    /// being the fallback.
    pub fn new(stop_on_lost: bool, lost_wait_s: f64, floor: Covariance3) -> Self {
        Self {
            stop_on_lost,
            lost_wait_ns: (lost_wait_s.max(0.0) * 1e9).round() as u64,
            floor,
            open: None,
            last_stamp_ns: 0,
            counts: LostCounts::default(),
            episodes: Vec::new(),
            hold: HandoverHold::default(),
            handed_over_ns: None,
            walk_ns: 0,
            walk_until_ns: None,
        }
    }

    /// The same policy, letting the robot walk on for `walk_s` (finite, ≥ 0; checked by the
    /// caller) after a stopped episode gave up: Lost steps in that time open episodes that do
    /// not stop it, so pose updating keeps trying on scans from new places (the views of
    /// `global_search.views` come from there), and the next Lost after it stops the robot
    /// again. 0 (the default): the robot stops again at the next Lost, and stands, looking from
    /// one place (the paper's reaction).
    pub fn with_walk(mut self, walk_s: f64) -> Self {
        self.walk_ns = (walk_s.max(0.0) * 1e9).round() as u64;
        self
    }

    /// The same policy, holding each handed-over pose with registration as `hold` says (the
    /// default is [`HandoverHold::default`]; checked by the caller: [`HandoverHold::validate`]).
    pub fn with_hold(mut self, hold: HandoverHold) -> Self {
        self.hold = hold;
        self
    }

    /// Within `hold_s` of the last handover, a step whose registration accepted a correction
    /// past the thresholds re-seeds the localiser at the refined pose.
    fn hold_step(&mut self, step: &Step, report: &SessionStep, session: &mut Session<'_>) -> Result<(), HarnessError> {
        let Some(t0) = self.handed_over_ns else { return Ok(()) };
        let stamp_ns = step.frame.stamp_ns;
        if self.hold.is_off() || stamp_ns.saturating_sub(t0) as f64 > self.hold.hold_s * 1e9 {
            return Ok(());
        }
        let Some(u) = report.updater.as_ref() else { return Ok(()) };
        let Some(reg) = u.registration.as_ref().filter(|r| r.accepted()) else { return Ok(()) };
        if u.verdict == Some(Verdict::Lost)
            || (reg.shift_m < self.hold.min_shift_m && reg.turn_rad.abs() < self.hold.min_turn_rad)
        {
            return Ok(());
        }
        let (sxy, syaw) = (reg.xy_sigma_m * reg.xy_sigma_m, reg.yaw_sigma_rad * reg.yaw_sigma_rad);
        let cov = [[sxy, 0.0, 0.0], [0.0, sxy, 0.0], [0.0, 0.0, syaw]];
        self.adopt(step, session, reg.pose, &cov)?;
        self.counts.hold_corrections += 1;
        Ok(())
    }

    /// The counts and the episodes (in order) so far; an episode still open is closed as
    /// [`LostEnd::RunEnded`] at the last step seen (its stopped time counted to there).
    pub fn finish(mut self) -> (LostCounts, Vec<LostEpisode>) {
        let last = self.last_stamp_ns;
        self.close(last, LostEnd::RunEnded);
        (self.counts, self.episodes)
    }

    fn close(&mut self, stamp_ns: u64, end: LostEnd) {
        let Some(mut ep) = self.open.take() else { return };
        ep.end_ns = stamp_ns;
        ep.end = end;
        if ep.stopped {
            self.counts.stopped_ns += stamp_ns.saturating_sub(ep.start_ns);
        }
        match end {
            LostEnd::Recovered => self.counts.recoveries += 1,
            LostEnd::Cleared => self.counts.cleared += 1,
            LostEnd::GaveUp => {
                self.counts.give_ups += 1;
                if ep.stopped && self.walk_ns > 0 {
                    self.walk_until_ns = Some(stamp_ns.saturating_add(self.walk_ns));
                }
            }
            LostEnd::RunEnded => {}
        }
        self.episodes.push(ep);
    }

    fn adopt(
        &self,
        step: &Step,
        session: &mut Session<'_>,
        pose: Pose2,
        cov: &Covariance3,
    ) -> Result<(), HarnessError> {
        let mut c = *cov;
        for (k, row) in c.iter_mut().enumerate() {
            row[k] = row[k].max(self.floor[k][k] * 0.25);
        }
        if session.set_estimate(pose, c).is_err() {
            session.set_estimate(pose, self.floor)?;
        }
        session.reset_updater_reference(pose, step.frame.odometry.unwrap_or(pose));
        Ok(())
    }
}

impl Control for LostPolicy {
    fn after_step(
        &mut self,
        step: &Step,
        report: &SessionStep,
        session: &mut Session<'_>,
        robot: Option<&mut dyn RobotControl>,
    ) -> Result<(), HarnessError> {
        let stamp_ns = step.frame.stamp_ns;
        self.last_stamp_ns = stamp_ns;
        if self.open.is_none() {
            self.hold_step(step, report, session)?;
        }
        let u = report.updater.as_ref();
        let verdict = u.and_then(|u| u.verdict);
        let mut robot = robot;
        if self.open.is_none() {
            if verdict != Some(Verdict::Lost) {
                return Ok(());
            }
            let mut stopped = false;
            let walking = self.walk_until_ns.is_some_and(|t| stamp_ns < t);
            if self.stop_on_lost
                && !walking
                && let Some(r) = robot.as_deref_mut()
            {
                r.stop(None);
                stopped = r.is_stopped();
            }
            self.counts.episodes += 1;
            let ep = LostEpisode { start_ns: stamp_ns, end_ns: stamp_ns, stopped, attempts: 0, end: LostEnd::RunEnded };
            self.open = Some(ep);
        }
        let recovery = u.and_then(|u| u.pose_recovery.as_ref());
        if let (Some(_), Some(ep)) = (recovery, self.open.as_mut()) {
            ep.attempts += 1;
            self.counts.attempts += 1;
        }
        let since = self.open.map_or(0, |ep| stamp_ns.saturating_sub(ep.start_ns));
        let end = match (recovery, verdict) {
            (Some(PoseRecovery::Recovered { pose_in_map, covariance, .. }), _) => {
                self.adopt(step, session, *pose_in_map, covariance)?;
                self.handed_over_ns = Some(stamp_ns);
                Some(LostEnd::Recovered)
            }
            (_, Some(Verdict::Update | Verdict::Suspend)) => Some(LostEnd::Cleared),
            _ if since >= self.lost_wait_ns => Some(LostEnd::GaveUp),
            _ => None,
        };
        if let Some(end) = end {
            self.close(stamp_ns, end);
            if let Some(r) = robot {
                r.resume();
            }
        }
        Ok(())
    }
}

/// The columns of `lost.csv`: one row per Lost episode, its start and end (seconds of the
/// log's or the simulation's clock), the attempts of pose updating in it and how it ended
/// ([`LostEnd::name`]).
pub const LOST_CSV_HEADER: &str = "start_s,end_s,attempts,end\n";

/// `episodes` as `lost.csv` ([`LOST_CSV_HEADER`]).
pub fn episodes_csv(episodes: &[LostEpisode]) -> String {
    use std::fmt::Write as _;
    let mut csv = String::from(LOST_CSV_HEADER);
    for e in episodes {
        let (start, end) = (crate::jobs::seconds(e.start_ns), crate::jobs::seconds(e.end_ns));
        let _ = writeln!(csv, "{start},{end},{},{}", e.attempts, e.end.name());
    }
    csv
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn episodes_as_csv_and_counts_as_one_line() {
        let eps = [
            LostEpisode {
                start_ns: 1_500_000_000,
                end_ns: 2_000_000_000,
                stopped: false,
                attempts: 3,
                end: LostEnd::Recovered,
            },
            LostEpisode {
                start_ns: 4_000_000_000,
                end_ns: 6_000_000_000,
                stopped: true,
                attempts: 0,
                end: LostEnd::GaveUp,
            },
        ];
        let csv = episodes_csv(&eps);
        let rows: Vec<&str> = csv.lines().collect();
        assert_eq!(rows[0], "start_s,end_s,attempts,end");
        assert_eq!(rows.len(), 3);
        assert!(rows[1].ends_with(",3,recovered") && rows[2].ends_with(",0,gave-up"), "{csv}");
        let serialised: Vec<String> = [LostEnd::Recovered, LostEnd::Cleared, LostEnd::GaveUp, LostEnd::RunEnded]
            .iter()
            .map(|e| serde_json::to_string(e).unwrap())
            .collect();
        assert_eq!(serialised, ["\"recovered\"", "\"cleared\"", "\"gave-up\"", "\"run-ended\""]);
        let c = LostCounts {
            episodes: 2,
            attempts: 3,
            recoveries: 1,
            cleared: 0,
            give_ups: 1,
            stopped_ns: 2_000_000_000,
            hold_corrections: 0,
        };
        assert_eq!(c.to_string(), "2 episodes, 3 attempts, recovered/cleared/gave up 1/0/1, stopped 2.0 s");
    }

    #[test]
    fn the_hold_is_on_by_default_and_its_fields_are_checked_by_name() {
        let h = HandoverHold::default();
        assert!(!h.is_off() && h.validate().is_ok() && h.hold_s == 30.0);
        assert!(HandoverHold::off().is_off() && HandoverHold::off().validate().is_ok());
        for (bad, name) in [
            (HandoverHold { hold_s: f64::NAN, ..h }, "handover_hold.hold_s"),
            (HandoverHold { min_shift_m: -0.1, ..h }, "handover_hold.min_shift_m"),
            (HandoverHold { min_turn_rad: f64::INFINITY, ..h }, "handover_hold.min_turn_rad"),
        ] {
            let e = bad.validate().expect_err("refused").to_string();
            assert!(e.contains(name), "{e}");
        }
        // Not written when 0: the run records of runs without a re-seeding are unchanged.
        let json = serde_json::to_string(&LostCounts::default()).unwrap();
        assert!(!json.contains("hold_corrections"), "{json}");
    }
}
