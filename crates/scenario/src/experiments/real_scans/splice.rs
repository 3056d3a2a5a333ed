//! A real kidnap made from a real log (issue 52, item 4): cut the records between two
//! reference poses out of the log and join its two ends so that the odometry carries no motion
//! across the cut. The robot was moved and its odometry did not see it, with real scans on both
//! sides ([`splice`]). Which cuts: seeded draws of two scan stamps whose reference poses are
//! 0.5-5 m apart, any turn, each with a window of the log around it that a trial replays
//! ([`draw_cuts`], [`CutParams`]).
//!
//! **The splice.** A cut `(t_a, t_b)` removes every record (scans, odometry, reference) stamped
//! strictly after `t_a` up to and including `t_b`. The records after it are moved back in time
//! by `t_b − t_a − JOIN_NS`: `t_b` lands [`JOIN_NS`] (1 ns) after `t_a`, so the records after
//! the cut keep their own spacing from `t_b`. When `t_a` and `t_b` are scan stamps (as the drawn
//! cuts are), the first scan after the cut comes one of the log's own scan periods (the one
//! that followed `t_b`), plus 1 ns, after the last scan before it: the log's time runs on as if
//! nothing had happened. The odometry after the cut is re-expressed to continue from the
//! odometry pose at `t_a`: `o'(t) = o(t_a) ∘ o(t_b)⁻¹ ∘ o(t)`. Two odometry records make the
//! joint explicit: one at `t_a` holding `o(t_a)` (the log's own if it has one then, else
//! interpolated) and one at the joint (`t_a + JOIN_NS`) holding exactly the same pose: the
//! odometry increment across the cut is the identity, bit for bit. The reference records keep
//! their poses (in the map frame the robot really is there), with a record at `t_a` and one at
//! the joint holding the reference at `t_b`, so that the reference jumps within the 1 ns of the
//! joint and nowhere is it interpolated across the cut.

use crate::experiments::ExperimentError;
use mapkeeper_common::{ParamError, stream_rng};
use mapkeeper_grid::{Pose2, angle_diff};
use mapkeeper_sensor::{LogRecord, OdometryReading, SensorLog, StampedPose, TruePose, interpolate, interpolate_within};
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// How long the joint of a spliced log lasts: the records stamped `t_b` in the log land this
/// long after `t_a`, nanoseconds.
pub const JOIN_NS: u64 = 1;

/// The largest time from a scan to the reference pose it is given when cuts are drawn,
/// nanoseconds (0.1 s, real-data's rule for mapping at reference poses).
pub const REFERENCE_GAP_NS: u64 = 100_000_000;

/// A cut of a log: the records stamped in `(start_ns, end_ns]` are removed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Cut {
    /// `t_a`: the last moment kept before the cut, nanoseconds of the log.
    pub start_ns: u64,
    /// `t_b`: the last moment removed, nanoseconds of the log (> `start_ns`).
    pub end_ns: u64,
}

impl Cut {
    /// The time the spliced log is shorter by: `t_b − t_a − JOIN_NS`, nanoseconds.
    pub fn removed_ns(&self) -> u64 {
        self.end_ns.saturating_sub(self.start_ns).saturating_sub(JOIN_NS)
    }

    /// The stamp of the joint in the spliced log (`t_a + JOIN_NS`): where `t_b` lands.
    pub fn joint_ns(&self) -> u64 {
        self.start_ns.saturating_add(JOIN_NS)
    }

    /// Where a stamp of the log lands in the spliced log: unchanged up to `t_a`, `None` inside
    /// the cut, moved back by [`Cut::removed_ns`] after it.
    pub fn spliced_stamp(&self, stamp_ns: u64) -> Option<u64> {
        if stamp_ns <= self.start_ns {
            Some(stamp_ns)
        } else if stamp_ns <= self.end_ns {
            None
        } else {
            Some(stamp_ns - self.removed_ns())
        }
    }
}

/// Why a log cannot be spliced at a cut.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SpliceError {
    /// The cut does not end after it starts.
    #[error("splice: the cut ends at {end_ns} ns, which is not after its start at {start_ns} ns")]
    EmptyCut {
        /// `t_a`.
        start_ns: u64,
        /// `t_b`.
        end_ns: u64,
    },
    /// The log has no scan at or before the cut's start, or none after its end.
    #[error(
        "splice: the cut {start_ns}-{end_ns} ns does not lie inside the log's scans ({first_ns}-{last_ns} ns): \
it needs a scan at or before its start and one after its end"
    )]
    OutsideScans {
        /// `t_a`.
        start_ns: u64,
        /// `t_b`.
        end_ns: u64,
        /// The first scan's stamp (0 without scans).
        first_ns: u64,
        /// The last scan's stamp (0 without scans).
        last_ns: u64,
    },
    /// The records of one kind do not span the cut (the odometry always must; the reference
    /// must if the log has any).
    #[error(
        "splice: the log's {what} records ({span}) do not span the cut {start_ns}-{end_ns} ns: a {what} pose at both \
ends is needed"
    )]
    Uncovered {
        /// `odometry` or `reference`.
        what: &'static str,
        /// The records' time span, or `none`.
        span: String,
        /// `t_a`.
        start_ns: u64,
        /// `t_b`.
        end_ns: u64,
    },
}

/// A time-sorted track of one kind of pose record of `log`.
fn track(log: &SensorLog, odometry: bool) -> Vec<StampedPose> {
    let mut t: Vec<StampedPose> = if odometry {
        log.odometry().map(|o| StampedPose { stamp_ns: o.stamp_ns, pose: o.pose_in_odom }).collect()
    } else {
        log.truth().map(|t| StampedPose { stamp_ns: t.stamp_ns, pose: t.pose_in_map }).collect()
    };
    t.sort_by_key(|p| p.stamp_ns);
    t
}

/// The pose of `track` at the cut's two ends (interpolated inside the track's span, never
/// extrapolated), or why not.
fn ends(track: &[StampedPose], cut: Cut, what: &'static str) -> Result<(Pose2, Pose2), SpliceError> {
    let covered = track.first().is_some_and(|f| f.stamp_ns <= cut.start_ns)
        && track.last().is_some_and(|l| l.stamp_ns >= cut.end_ns);
    match (covered, interpolate(track, cut.start_ns), interpolate(track, cut.end_ns)) {
        (true, Some(a), Some(b)) => Ok((a, b)),
        _ => Err(SpliceError::Uncovered {
            what,
            span: match (track.first(), track.last()) {
                (Some(f), Some(l)) => format!("{}-{} ns", f.stamp_ns, l.stamp_ns),
                _ => "none".into(),
            },
            start_ns: cut.start_ns,
            end_ns: cut.end_ns,
        }),
    }
}

/// `log` spliced at `cut` (module doc): the records in `(t_a, t_b]` removed, the later ones
/// moved back to `t_a + JOIN_NS` onwards with the odometry re-expressed so that it carries no
/// motion across the cut, the reference kept in the map frame. Records outside the cut keep
/// their order, and those up to `t_a` are untouched. The header's `meta` gains `splice`
/// (`start_ns`, `end_ns`, `join_ns`).
///
/// ```
/// use mapkeeper_scenario::experiments::real_scans::splice::{Cut, SpliceError, splice};
/// use mapkeeper_sensor::{LogHeader, SensorLog};
/// let log = SensorLog { header: LogHeader::new(Default::default()), records: vec![] };
/// let bad = splice(&log, Cut { start_ns: 5, end_ns: 5 });
/// assert!(matches!(bad, Err(SpliceError::EmptyCut { .. })));
/// ```
pub fn splice(log: &SensorLog, cut: Cut) -> Result<SensorLog, SpliceError> {
    if cut.end_ns <= cut.start_ns {
        return Err(SpliceError::EmptyCut { start_ns: cut.start_ns, end_ns: cut.end_ns });
    }
    let (first, last) = log.scans().fold((u64::MAX, 0), |(f, l), s| (f.min(s.stamp_ns), l.max(s.stamp_ns)));
    if first > cut.start_ns || last <= cut.end_ns {
        return Err(SpliceError::OutsideScans {
            start_ns: cut.start_ns,
            end_ns: cut.end_ns,
            first_ns: if first == u64::MAX { 0 } else { first },
            last_ns: last,
        });
    }
    let (odo_a, odo_b) = ends(&track(log, true), cut, "odometry")?;
    let truth = track(log, false);
    let reference = if truth.is_empty() { None } else { Some(ends(&truth, cut, "reference")?) };
    // o'(t) = o(t_a) ∘ o(t_b)⁻¹ ∘ o(t).
    let reexpress = odo_a.compose(&odo_b.inverse());
    let has = |odometry: bool, stamp_ns: u64| {
        log.records.iter().any(|r| match r {
            LogRecord::Odom(o) => odometry && o.stamp_ns == stamp_ns,
            LogRecord::Truth(t) => !odometry && t.stamp_ns == stamp_ns,
            LogRecord::Scan(_) => false,
        })
    };
    let mut records: Vec<LogRecord> = log.records.iter().filter(|r| r.stamp_ns() <= cut.start_ns).cloned().collect();
    // The joint: the odometry stands still across it, the reference jumps within it.
    if !has(true, cut.start_ns) {
        records.push(LogRecord::Odom(OdometryReading { stamp_ns: cut.start_ns, pose_in_odom: odo_a }));
    }
    records.push(LogRecord::Odom(OdometryReading { stamp_ns: cut.joint_ns(), pose_in_odom: odo_a }));
    if let Some((ref_a, ref_b)) = reference {
        if !has(false, cut.start_ns) {
            records.push(LogRecord::Truth(TruePose { stamp_ns: cut.start_ns, pose_in_map: ref_a }));
        }
        records.push(LogRecord::Truth(TruePose { stamp_ns: cut.joint_ns(), pose_in_map: ref_b }));
    }
    let shift = cut.removed_ns();
    for r in log.records.iter().filter(|r| r.stamp_ns() > cut.end_ns) {
        records.push(match r {
            LogRecord::Scan(s) => {
                let mut s = s.clone();
                s.stamp_ns -= shift;
                LogRecord::Scan(s)
            }
            LogRecord::Odom(o) => LogRecord::Odom(OdometryReading {
                stamp_ns: o.stamp_ns - shift,
                pose_in_odom: reexpress.compose(&o.pose_in_odom),
            }),
            LogRecord::Truth(t) => {
                LogRecord::Truth(TruePose { stamp_ns: t.stamp_ns - shift, pose_in_map: t.pose_in_map })
            }
        });
    }
    let mut header = log.header.clone();
    header.meta.insert(
        "splice".into(),
        serde_json::json!({ "start_ns": cut.start_ns, "end_ns": cut.end_ns, "join_ns": JOIN_NS }),
    );
    Ok(SensorLog { header, records })
}

/// The records of `log` stamped in `[from_ns, to_ns]`, unchanged and in order.
pub fn window(log: &SensorLog, from_ns: u64, to_ns: u64) -> SensorLog {
    let records = log.records.iter().filter(|r| (from_ns..=to_ns).contains(&r.stamp_ns())).cloned().collect();
    SensorLog { header: log.header.clone(), records }
}

/// How cuts are drawn (`[real_kidnap.cuts]` of a parameter file).
///
/// ```
/// use mapkeeper_scenario::experiments::real_scans::splice::CutParams;
/// let p = CutParams { count: 5, ..CutParams::default() };
/// assert!(p.validate().is_ok());
/// let bad = CutParams { min_jump_m: 6.0, ..CutParams::default() };
/// assert_eq!(bad.validate().unwrap_err().name, "min_jump_m");
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CutParams {
    /// Cuts drawn per log. Default 20.
    pub count: usize,
    /// The reference poses at the cut's two ends are at least this far apart, metres (any
    /// turn). Default 0.5.
    pub min_jump_m: f64,
    /// …and at most this far, metres. Default 5.
    pub max_jump_m: f64,
    /// A trial's window starts at least this long before the cut, seconds. Default 10.
    pub before_s: f64,
    /// …and at least this many scans before it (the sparse logs: Intel's scans are 2.9 s
    /// apart). Default 5.
    pub before_scans: usize,
    /// The window ends at least this long after the cut's end, seconds (at least the recovery
    /// window, so that "stays recovered" is seen). Default 20.
    pub after_s: f64,
    /// …and at least this many scans after it. Default 10.
    pub after_scans: usize,
    /// Tries of a start before a draw gives up (each start may have no end in range).
    /// Default 1000.
    pub max_tries: usize,
}

impl Default for CutParams {
    fn default() -> Self {
        Self {
            count: 20,
            min_jump_m: 0.5,
            max_jump_m: 5.0,
            before_s: 10.0,
            before_scans: 5,
            after_s: 20.0,
            after_scans: 10,
            max_tries: 1000,
        }
    }
}

impl CutParams {
    /// Checks every field: a count ≥ 1, finite non-negative times, 0 < `min_jump_m` ≤
    /// `max_jump_m` (a cut that moves nothing is no kidnap), at least one scan before and
    /// after, at least one try.
    pub fn validate(&self) -> Result<(), ParamError> {
        if self.count == 0 {
            return Err(ParamError::new("count", 0, "must be ≥ 1"));
        }
        for (name, v) in [("before_s", self.before_s), ("after_s", self.after_s), ("max_jump_m", self.max_jump_m)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ParamError::new(name, v, "must be finite and ≥ 0"));
            }
        }
        if !(self.min_jump_m.is_finite() && self.min_jump_m > 0.0 && self.min_jump_m <= self.max_jump_m) {
            return Err(ParamError::new("min_jump_m", self.min_jump_m, "must be finite, > 0 and ≤ max_jump_m"));
        }
        for (name, v) in [("before_scans", self.before_scans), ("after_scans", self.after_scans)] {
            if v == 0 {
                return Err(ParamError::new(name, v, "must be ≥ 1"));
            }
        }
        if self.max_tries == 0 {
            return Err(ParamError::new("max_tries", 0, "must be ≥ 1"));
        }
        Ok(())
    }
}

/// One drawn cut and the window of the log a trial replays around it (times of the log).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CutDraw {
    /// The draw's index.
    pub index: usize,
    /// The cut (both ends scan stamps).
    pub cut: Cut,
    /// The window's first scan, nanoseconds of the log.
    pub window_start_ns: u64,
    /// The window's last scan, nanoseconds of the log.
    pub window_end_ns: u64,
    /// The reference pose at the cut's start, map frame.
    pub from: Pose2,
    /// The reference pose at the cut's end, map frame: where the robot is moved to.
    pub to: Pose2,
    /// The distance between them, metres (in `[min_jump_m, max_jump_m]`).
    pub jump_m: f64,
    /// The turn from one to the other, radians, in (−π, π].
    pub turn_rad: f64,
    /// Scans of the window before the cut (the one at `t_a` included).
    pub scans_before: usize,
    /// Scans of the window after the cut.
    pub scans_after: usize,
}

impl CutDraw {
    /// The window spliced at the cut: what a kidnapped trial replays.
    pub fn spliced(&self, log: &SensorLog) -> Result<SensorLog, SpliceError> {
        splice(&window(log, self.window_start_ns, self.window_end_ns), self.cut)
    }

    /// The same window unspliced, from the same start and as long as the spliced one (cut
    /// short at the log's end): its paired run without a kidnap.
    pub fn unspliced(&self, log: &SensorLog) -> SensorLog {
        let span = self.window_end_ns - self.window_start_ns - self.cut.removed_ns();
        window(log, self.window_start_ns, self.window_start_ns + span)
    }
}

/// The log's scans that have a reference pose within [`REFERENCE_GAP_NS`]: (stamp, pose),
/// time-ordered, one per stamp.
pub fn referenced_scans(log: &SensorLog) -> Vec<StampedPose> {
    let truth = track(log, false);
    let mut stamps: Vec<u64> = log.scans().map(|s| s.stamp_ns).collect();
    stamps.sort_unstable();
    stamps.dedup();
    stamps
        .into_iter()
        .filter_map(|t| interpolate_within(&truth, t, REFERENCE_GAP_NS).map(|pose| StampedPose { stamp_ns: t, pose }))
        .collect()
}

/// Draws `params.count` cuts of `log` (seeded: the draw `k` from the stream
/// `real-kidnap/cut/k` of `seed`): a start `t_a` uniformly among the scans with the window's
/// room before them, then an end `t_b` uniformly among the later scans with room after them
/// whose reference pose lies `min_jump_m`-`max_jump_m` from `t_a`'s (any turn); a start with no
/// such end is drawn again, at most `max_tries` times. Both ends are scans with a reference
/// pose ([`referenced_scans`]). Bad parameters are refused as `cuts.…`; a log with no room
/// for a cut is an error naming the log (`name`) and what is missing.
pub fn draw_cuts(log: &SensorLog, name: &str, params: &CutParams, seed: u64) -> Result<Vec<CutDraw>, ExperimentError> {
    params.validate().map_err(|e| ExperimentError::from(e.within("cuts")))?;
    let scans = referenced_scans(log);
    let (Some(first), Some(last)) = (scans.first(), scans.last()) else {
        return Err(ExperimentError::Invalid(format!(
            "{name}: no scan with a reference pose within 0.1 s: no cut can be drawn"
        )));
    };
    let (before_ns, after_ns) = ((params.before_s * 1e9).round() as u64, (params.after_s * 1e9).round() as u64);
    let n = scans.len();
    let starts: Vec<usize> = (params.before_scans..n)
        .filter(|&i| scans[i].stamp_ns - first.stamp_ns >= before_ns)
        .filter(|&i| i + 1 + params.after_scans < n)
        .collect();
    let end_ok = |j: usize| j + params.after_scans < n && last.stamp_ns - scans[j].stamp_ns >= after_ns;
    let mut draws = Vec::with_capacity(params.count);
    for k in 0..params.count {
        let mut rng = stream_rng(seed, &format!("real-kidnap/cut/{k:04}"));
        let mut found = None;
        for _ in 0..params.max_tries {
            if starts.is_empty() {
                break;
            }
            let a = starts[rng.random_range(0..starts.len())];
            let ends: Vec<usize> = (a + 1..n)
                .filter(|&j| end_ok(j))
                .filter(|&j| {
                    let d = scans[a].pose.distance(&scans[j].pose);
                    d >= params.min_jump_m && d <= params.max_jump_m
                })
                .collect();
            if !ends.is_empty() {
                found = Some((a, ends[rng.random_range(0..ends.len())]));
                break;
            }
        }
        let Some((a, b)) = found else {
            return Err(ExperimentError::Invalid(format!(
                "{name}: cut {k}: no two scans with reference poses {}-{} m apart and the window's room ({} s / {} \
scans before, {} s / {} scans after) in {} tries",
                params.min_jump_m,
                params.max_jump_m,
                params.before_s,
                params.before_scans,
                params.after_s,
                params.after_scans,
                params.max_tries
            )));
        };
        // The window's ends are scans: the latest at or before the earlier of the two starts
        // (`starts` leaves room for both), the earliest at or after the later of the two ends.
        let start = scans[a - params.before_scans].stamp_ns.min(scans[a].stamp_ns - before_ns);
        let start = scans[scans.partition_point(|s| s.stamp_ns <= start) - 1].stamp_ns;
        let end = scans[b + params.after_scans].stamp_ns.max(scans[b].stamp_ns + after_ns);
        let end = scans[scans.partition_point(|s| s.stamp_ns < end).min(n - 1)].stamp_ns;
        let (from, to) = (scans[a].pose, scans[b].pose);
        draws.push(CutDraw {
            index: k,
            cut: Cut { start_ns: scans[a].stamp_ns, end_ns: scans[b].stamp_ns },
            window_start_ns: start,
            window_end_ns: end,
            from,
            to,
            jump_m: from.distance(&to),
            turn_rad: angle_diff(to.yaw, from.yaw),
            scans_before: scans[..=a].iter().filter(|s| s.stamp_ns >= start).count(),
            scans_after: scans[b + 1..].iter().filter(|s| s.stamp_ns <= end).count(),
        });
    }
    Ok(draws)
}

#[cfg(test)]
mod tests;
