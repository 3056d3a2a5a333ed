//! Log replay: a recorded sensor log as a [`SensorSource`]. Scans close in time (within
//! [`ReplayOptions::sync_window_ns`] of the step's first scan, at most one per lidar) form one
//! step stamped with its latest scan; the odometry and the truth are associated with each
//! step's stamp by the rules of [`ReplayOptions`].

use crate::source::{SensorFrame, SensorSource, SourceError, Step, Truth};
use mapkeeper_grid::Pose2;
use mapkeeper_sensor::{LaserScan, LogRecord, SensorLog, StampedPose, interpolate, interpolate_within};

/// How a step's odometry is taken from the log's odometry records.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum OdometryAt {
    /// The latest record at or before the step (none before the first record), as a filter
    /// that must not look ahead.
    #[default]
    LatestAtOrBefore,
    /// Interpolated at the step's stamp, clamped outside the records' time span.
    Interpolated,
}

/// How a log is replayed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReplayOptions {
    /// The odometry rule.
    pub odometry_at: OdometryAt,
    /// Truth records farther than this from a step's stamp are not used for it, nanoseconds
    /// (see [`interpolate_within`]); `u64::MAX`: interpolate, clamped at the ends.
    pub max_truth_gap_ns: u64,
    /// Scans whose stamps lie within this of the first scan of a step join that step (at most
    /// one scan per lidar: a second scan of a lidar starts a new step), nanoseconds; the step's
    /// stamp is its latest scan's. 0: only scans with exactly the same stamp. Default 0 (`mapkeeper
    /// update` uses [`DEFAULT_SYNC_WINDOW_NS`]).
    pub sync_window_ns: u64,
    /// Whether the jobs deskew the scans that carry a sweep timing (a bag's `time_increment`)
    /// before the estimators see them ([`crate::Session::set_deskew`]). Default true.
    pub deskew: bool,
}

/// The synchronisation window `mapkeeper update` groups the scans of unsynchronised lidars
/// with by default: 0.05 s, nanoseconds.
pub const DEFAULT_SYNC_WINDOW_NS: u64 = 50_000_000;

impl Default for ReplayOptions {
    fn default() -> Self {
        Self { odometry_at: OdometryAt::LatestAtOrBefore, max_truth_gap_ns: u64::MAX, sync_window_ns: 0, deskew: true }
    }
}

/// Groups time-ordered scans into steps: a scan joins the open step if its stamp is within
/// `window_ns` of the step's first scan and no scan of its lidar is in it yet; each step is
/// stamped with its latest scan.
fn group_scans(scans: Vec<LaserScan>, window_ns: u64) -> Vec<(u64, Vec<LaserScan>)> {
    let mut steps: Vec<(u64, Vec<LaserScan>)> = Vec::new();
    for s in scans {
        match steps.last_mut() {
            Some((latest, group))
                if s.stamp_ns - group[0].stamp_ns <= window_ns && group.iter().all(|g| g.lidar_id != s.lidar_id) =>
            {
                *latest = s.stamp_ns;
                group.push(s);
            }
            _ => steps.push((s.stamp_ns, vec![s])),
        }
    }
    steps
}

/// A sensor log replayed step by step.
#[derive(Clone, Debug)]
pub struct LogSource {
    name: String,
    steps: Vec<(u64, Vec<LaserScan>)>,
    odometry: Vec<StampedPose>,
    truth: Vec<StampedPose>,
    options: ReplayOptions,
    next: usize,
    distance_m: f64,
    prev_truth: Option<Pose2>,
}

impl LogSource {
    /// How the log is replayed.
    pub fn options(&self) -> &ReplayOptions {
        &self.options
    }

    /// Replays `log` (named `name` in errors and reports). Records are ordered by stamp (stable
    /// within one stamp); scans are grouped into steps by [`ReplayOptions::sync_window_ns`].
    pub fn new(log: SensorLog, name: impl Into<String>, options: ReplayOptions) -> Self {
        let (mut odometry, mut truth, mut scans) = (Vec::new(), Vec::new(), Vec::new());
        for r in log.records {
            match r {
                LogRecord::Scan(s) => scans.push(s),
                LogRecord::Odom(o) => odometry.push(StampedPose { stamp_ns: o.stamp_ns, pose: o.pose_in_odom }),
                LogRecord::Truth(t) => truth.push(StampedPose { stamp_ns: t.stamp_ns, pose: t.pose_in_map }),
            }
        }
        scans.sort_by_key(|s| s.stamp_ns);
        odometry.sort_by_key(|o| o.stamp_ns);
        truth.sort_by_key(|t| t.stamp_ns);
        let steps = group_scans(scans, options.sync_window_ns);
        Self { name: name.into(), steps, odometry, truth, options, next: 0, distance_m: 0.0, prev_truth: None }
    }

    /// The source's name (the log's path).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Steps in the log (scan stamps).
    pub fn len(&self) -> usize {
        self.steps.len()
    }

    /// Whether the log has no scan.
    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }

    /// The stamp of the first step, if any.
    pub fn first_stamp_ns(&self) -> Option<u64> {
        self.steps.first().map(|s| s.0)
    }

    /// The log's odometry track, time-ordered.
    pub fn odometry(&self) -> &[StampedPose] {
        &self.odometry
    }

    /// The log's truth track, time-ordered.
    pub fn truth(&self) -> &[StampedPose] {
        &self.truth
    }

    fn odometry_at(&self, stamp_ns: u64) -> Option<Pose2> {
        match self.options.odometry_at {
            OdometryAt::LatestAtOrBefore => {
                let k = self.odometry.partition_point(|o| o.stamp_ns <= stamp_ns);
                k.checked_sub(1).map(|j| self.odometry[j].pose)
            }
            OdometryAt::Interpolated => interpolate(&self.odometry, stamp_ns),
        }
    }
}

impl SensorSource for LogSource {
    fn next_step(&mut self) -> Result<Option<Step>, SourceError> {
        let Some((stamp_ns, scans)) = self.steps.get_mut(self.next).map(|(t, s)| (*t, std::mem::take(s))) else {
            return Ok(None);
        };
        self.next += 1;
        let odometry = self.odometry_at(stamp_ns);
        let truth = interpolate_within(&self.truth, stamp_ns, self.options.max_truth_gap_ns).map(|pose_in_map| {
            if let Some(p) = self.prev_truth {
                self.distance_m += p.distance(&pose_in_map);
            }
            self.prev_truth = Some(pose_in_map);
            Truth { pose_in_map, distance_m: self.distance_m }
        });
        Ok(Some(Step { frame: SensorFrame { stamp_ns, odometry, scans }, truth }))
    }
}
