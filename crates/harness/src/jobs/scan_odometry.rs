//! Odometry made by scan matching, for a log that has laser scans and nothing else
//! (`mapkeeper convert --odometry-from-scans`; `docs/real-data.md`, "Logs with scans only").
//!
//! The scans are taken in time order, one *step* per stamp (the scans of several lidars with the
//! same stamp match together, each through its own mount). Each step is matched against a local
//! map of the recent scans (scan-to-submap), in the `odom` frame, which starts at the identity
//! at the first step:
//!
//! 1. **Predict** with a constant velocity: the last step's increment, scaled by the ratio of
//!    this step's time gap to the last one's (at most [`MAX_GAP_RATIO`]); the first two steps
//!    predict no motion.
//! 2. **Match** the step's beam endpoints (`matcher.max_beams` per lidar, evenly over the valid
//!    readings shorter than `max_range_m`) against the local map from the prediction with the
//!    localiser's [`ScanMatcher`] (a correlative search in its window, then a refinement).
//! 3. **Accept or keep the prediction**: an accepted match gives the step's pose; a refused one
//!    (fewer than `matcher.min_inlier_share` of the beams within `matcher.inlier_m` of the local
//!    map) leaves the prediction, and is counted. After `restart_after_refused` refusals in a
//!    row the local map is started afresh from the step's scans at the prediction (a *restart*,
//!    counted): the robot has left the map behind, or the map no longer fits.
//! 4. **Grow the local map**: a step becomes a *key scan* when its pose is `key_distance_m` or
//!    `key_turn_rad` from the last key scan's; the local map is the distance field of the last
//!    `submap_scans` key scans' endpoints (to the points themselves, not to their cells, so the
//!    match is not pulled onto the cell lattice), in a square of `2 · submap_radius_m` around
//!    the newest key scan, rebuilt when a key scan is added. A robot standing still matches the same
//!    map again and again, so its odometry does not creep.
//!
//! Deterministic: no randomness, no clock. Any log is accepted: a step without a usable beam
//! keeps the prediction (counted apart), a scan whose header is invalid gives no beams, a log
//! without scans gives no odometry.
//!
//! Limits: the motion within a sweep is not deskewed; a long corridor whose walls are parallel
//! to the motion, or an open space beyond `max_range_m`, pins the pose across the corridor only
//! (the prediction carries it along); the drift of any incremental method grows with the path.

use mapkeeper_common::ParamError;
use mapkeeper_grid::{DistanceField, GridGeometry, Point2, Pose2, wrap_angle};
use mapkeeper_localiser::{BeamSelection, BeamSet, ScanMatchParams, ScanMatcher};
use mapkeeper_logs::ScanOdometrySummary;
use mapkeeper_sensor::{BeamValidity, LaserScan, LogRecord, OdometryReading, SensorLog};
use std::collections::VecDeque;

/// The prediction scales the last increment by this step's time gap over the last one's, at most
/// this much (a gap in the log, a dropped scan, is not extrapolated further).
pub const MAX_GAP_RATIO: f64 = 3.0;

/// The scan-odometry maker's parameters.
///
/// ```
/// use mapkeeper_harness::jobs::scan_odometry::ScanOdometryParams;
/// let mut p = ScanOdometryParams::default();
/// p.submap_scans = 30;
/// assert!(p.validate().is_ok());
/// p.key_distance_m = f64::NAN;
/// assert!(p.validate().is_err());
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScanOdometryParams {
    /// The match: windows around the prediction, kernel, inlier distance, acceptance, beams per
    /// lidar (`enabled` is not read). Default: the localiser's defaults with a ±0.2 m, ±0.15 rad
    /// window and acceptance at 0.4 of the beams within 0.1 m.
    pub matcher: ScanMatchParams,
    /// Readings at or beyond this are not matched nor mapped, metres. Default 15.
    pub max_range_m: f64,
    /// The local map's cell size, metres. Default 0.05.
    pub resolution_m: f64,
    /// Half the side of the local map's square around the newest key scan, metres. Default 15.
    pub submap_radius_m: f64,
    /// Key scans in the local map. Default 15.
    pub submap_scans: usize,
    /// A step becomes a key scan this far from the last key scan, metres. Default 0.25.
    pub key_distance_m: f64,
    /// … or turned this much from it, radians. Default 0.15.
    pub key_turn_rad: f64,
    /// Refused matches in a row after which the local map is started afresh. Default 10.
    pub restart_after_refused: usize,
}

impl Default for ScanOdometryParams {
    fn default() -> Self {
        Self {
            matcher: ScanMatchParams {
                enabled: true,
                window_xy_m: 0.2,
                window_yaw_rad: 0.15,
                min_inlier_share: 0.4,
                ..ScanMatchParams::default()
            },
            max_range_m: 15.0,
            resolution_m: 0.05,
            submap_radius_m: 15.0,
            submap_scans: 15,
            key_distance_m: 0.25,
            key_turn_rad: 0.15,
            restart_after_refused: 10,
        }
    }
}

impl ScanOdometryParams {
    /// Checks every field; the first violation is returned (the matcher's named `scan_match.…`).
    pub fn validate(&self) -> Result<(), ParamError> {
        self.matcher.validate()?;
        let checks: [(&'static str, f64, bool, &'static str); 7] = [
            ("max_range_m", self.max_range_m, self.max_range_m > 0.0, "must be > 0"),
            ("resolution_m", self.resolution_m, (0.005..=1.0).contains(&self.resolution_m), "must be in [0.005, 1]"),
            (
                "submap_radius_m",
                self.submap_radius_m,
                self.submap_radius_m >= 1.0 && self.submap_radius_m / self.resolution_m <= 4000.0,
                "must be >= 1 and at most 4000 cells",
            ),
            ("submap_scans", self.submap_scans as f64, (1..=10_000).contains(&self.submap_scans), "must be 1 to 10000"),
            ("key_distance_m", self.key_distance_m, self.key_distance_m >= 0.0, "must be >= 0"),
            ("key_turn_rad", self.key_turn_rad, self.key_turn_rad >= 0.0, "must be >= 0"),
            (
                "restart_after_refused",
                self.restart_after_refused as f64,
                self.restart_after_refused >= 1,
                "must be >= 1",
            ),
        ];
        for (name, value, ok, requirement) in checks {
            if !(ok && value.is_finite()) {
                return Err(ParamError::new(name, value, requirement));
            }
        }
        Ok(())
    }

    /// The method in a sentence, with its parameters (the import report's `method`).
    pub fn describe(&self) -> String {
        format!(
            "scan-to-local-map matching: each step's scans against the endpoints of the last {} key scans \
(one each {} m or {} rad), {} m cells; constant-velocity prediction, search ±{} m ±{} rad, accepted at {} of the \
beams within {} m, else the prediction is kept; beams < {} m",
            self.submap_scans,
            self.key_distance_m,
            self.key_turn_rad,
            self.resolution_m,
            self.matcher.window_xy_m,
            self.matcher.window_yaw_rad,
            self.matcher.min_inlier_share,
            self.matcher.inlier_m,
            self.max_range_m
        )
    }
}

/// The odometry made from a log's scans.
#[derive(Clone, Debug, PartialEq)]
pub struct ScanOdometry {
    /// One reading per step, at the step's stamp, in the `odom` frame (the identity at the first).
    pub readings: Vec<OdometryReading>,
    /// How it went.
    pub summary: ScanOdometrySummary,
}

/// One key scan of the local map: its pose and its points ([`map_points`]) in the robot frame.
#[derive(Clone, Debug)]
struct KeyScan {
    pose: Pose2,
    ends: Vec<[f64; 2]>,
}

/// The local map: the last key scans and the matcher built on them.
struct LocalMap {
    keys: VecDeque<KeyScan>,
    matcher: Option<ScanMatcher>,
}

impl LocalMap {
    fn new() -> Self {
        Self { keys: VecDeque::new(), matcher: None }
    }

    /// Whether `pose` is far enough from the last key scan to be one.
    fn wants_key(&self, pose: &Pose2, p: &ScanOdometryParams) -> bool {
        self.keys.back().is_none_or(|k| {
            k.pose.distance(pose) >= p.key_distance_m || wrap_angle(k.pose.yaw - pose.yaw).abs() >= p.key_turn_rad
        })
    }

    /// Adds a key scan, its points in the robot frame (dropping the oldest beyond
    /// `submap_scans`), and rebuilds the matcher.
    fn add(&mut self, pose: Pose2, points: &[[f64; 2]], p: &ScanOdometryParams) {
        self.keys.push_back(KeyScan { pose, ends: points.to_vec() });
        while self.keys.len() > p.submap_scans {
            self.keys.pop_front();
        }
        self.matcher = self.field(pose, p).map(|f| ScanMatcher::from_field(&f, p.matcher));
    }

    /// Forgets every key scan.
    fn clear(&mut self) {
        self.keys.clear();
        self.matcher = None;
    }

    /// The distance field of the key scans' endpoints in the square around `centre` (to the
    /// points themselves, not to their cells: no bias towards the cell lattice).
    fn field(&self, centre: Pose2, p: &ScanOdometryParams) -> Option<DistanceField> {
        let cells = (2.0 * p.submap_radius_m / p.resolution_m).ceil() as usize;
        let origin = Pose2::new(centre.x - p.submap_radius_m, centre.y - p.submap_radius_m, 0.0);
        let geometry = GridGeometry::new(cells, cells, p.resolution_m, origin).ok()?;
        let points = self.keys.iter().flat_map(|k| {
            let frame = k.pose.prepare();
            k.ends.iter().map(move |&[x, y]| frame.transform_point(Point2::new(x, y)))
        });
        Some(DistanceField::to_points(&geometry, points, ScanMatcher::cap_m(&p.matcher, p.resolution_m)))
    }
}

/// The largest gap between two neighbouring beams' endpoints that the local map fills in, metres
/// (a wider one is a jump from one surface to another, or a surface seen too obliquely to trust).
pub const MAX_FILL_GAP_M: f64 = 0.2;

/// The points of `scan` for the local map, robot frame: every valid endpoint short of
/// `max_range_m`, and between neighbouring beams whose endpoints are at most
/// [`MAX_FILL_GAP_M`] and five beam spacings apart, points every `spacing_m` along the segment
/// (a surface, not a scatter of points: a matched endpoint lands on the surface, not between
/// two samples of it).
fn map_points(scan: &LaserScan, max_range_m: f64, spacing_m: f64, out: &mut Vec<[f64; 2]>) {
    let mut last: Option<(f64, Point2)> = None;
    for (i, &r) in scan.ranges_m.iter().enumerate() {
        if scan.validity_of(r) != BeamValidity::Valid || (r as f64) >= max_range_m {
            last = None;
            continue;
        }
        let r = r as f64;
        let a = scan.beam_angle(i as f64);
        let p = scan.lidar_in_robot.transform_point(Point2::new(r * a.cos(), r * a.sin()));
        if let Some((r0, q)) = last {
            let gap = p.distance(q);
            let spacing = 5.0 * r.min(r0) * scan.angle_increment_rad.abs();
            if gap <= MAX_FILL_GAP_M.min(spacing.max(spacing_m)) {
                let n = (gap / spacing_m).floor() as usize;
                out.extend((1..=n.min(64)).map(|k| {
                    let t = k as f64 / (n + 1) as f64;
                    [q.x + t * (p.x - q.x), q.y + t * (p.y - q.y)]
                }));
            }
        }
        out.push([p.x, p.y]);
        last = Some((r, p));
    }
}

/// The local map's points of a step's scans (those with a valid header), robot frame.
fn step_points(step: &[&LaserScan], p: &ScanOdometryParams) -> Vec<[f64; 2]> {
    let mut out = Vec::new();
    for scan in step.iter().filter(|s| s.validate().is_ok()) {
        map_points(scan, p.max_range_m, 0.5 * p.resolution_m, &mut out);
    }
    out
}

/// The increment `d` scaled by `ratio` (a constant velocity over a longer or shorter gap).
fn scaled(d: &Pose2, ratio: f64) -> Pose2 {
    Pose2::new(d.x * ratio, d.y * ratio, wrap_angle(d.yaw * ratio))
}

/// The scans of `log` grouped into steps: consecutive scans with the same stamp.
fn steps(log: &SensorLog) -> Vec<Vec<&LaserScan>> {
    let mut out: Vec<Vec<&LaserScan>> = Vec::new();
    for s in log.scans() {
        match out.last_mut() {
            Some(step) if step[0].stamp_ns == s.stamp_ns => step.push(s),
            _ => out.push(vec![s]),
        }
    }
    out
}

/// Makes odometry from the scans of `log` (its odometry records, if any, are not read).
/// `params` must be valid ([`ScanOdometryParams::validate`]).
pub fn odometry_from_scans(log: &SensorLog, params: &ScanOdometryParams) -> ScanOdometry {
    let mut summary = ScanOdometrySummary { method: params.describe(), ..ScanOdometrySummary::default() };
    let mut readings = Vec::new();
    let mut map = LocalMap::new();
    let mut beams = BeamSet::new();
    let (mut pose, mut last_increment, mut last_gap_ns) = (Pose2::IDENTITY, Pose2::IDENTITY, 0u64);
    let mut last_stamp: Option<u64> = None;
    let mut refused_in_a_row = 0usize;
    for step in steps(log) {
        let stamp = step[0].stamp_ns;
        let gap = last_stamp.map_or(0, |t| stamp.saturating_sub(t));
        let ratio = if last_gap_ns > 0 { (gap as f64 / last_gap_ns as f64).min(MAX_GAP_RATIO) } else { 0.0 };
        let predicted = pose.compose(&scaled(&last_increment, ratio));
        beams.clear();
        for scan in step.iter().filter(|s| s.validate().is_ok()) {
            beams.add_scan(scan, params.matcher.max_beams, params.max_range_m, BeamSelection::EvenlyOverValid);
        }
        let ends = beams.endpoints();
        let now = if ends.is_empty() {
            summary.without_beams += 1;
            predicted
        } else if let Some(matcher) = &map.matcher {
            match matcher.match_scan(&predicted, ends).filter(|m| m.accepted && m.pose_in_map.is_finite()) {
                Some(m) => {
                    summary.matched += 1;
                    refused_in_a_row = 0;
                    if map.wants_key(&m.pose_in_map, params) {
                        map.add(m.pose_in_map, &step_points(&step, params), params);
                    }
                    m.pose_in_map
                }
                None => {
                    summary.refused += 1;
                    refused_in_a_row += 1;
                    if refused_in_a_row >= params.restart_after_refused {
                        summary.restarts += 1;
                        refused_in_a_row = 0;
                        map.clear();
                        map.add(predicted, &step_points(&step, params), params);
                    }
                    predicted
                }
            }
        } else {
            // The first step with beams starts the local map where the odometry is.
            map.add(predicted, &step_points(&step, params), params);
            predicted
        };
        let now = if now.is_finite() { now } else { pose };
        summary.path_m += pose.distance(&now);
        last_increment = pose.between(&now);
        last_gap_ns = gap;
        pose = now;
        last_stamp = Some(stamp);
        readings.push(OdometryReading { stamp_ns: stamp, pose_in_odom: pose });
    }
    summary.steps = readings.len();
    ScanOdometry { readings, summary }
}

/// `log` with its odometry records replaced by `odometry`'s readings (each just before the scans
/// of its stamp); the other records keep their order.
pub fn with_odometry(log: SensorLog, odometry: &ScanOdometry) -> SensorLog {
    let mut records: Vec<LogRecord> = log.records.into_iter().filter(|r| !matches!(r, LogRecord::Odom(_))).collect();
    records.extend(odometry.readings.iter().map(|o| LogRecord::Odom(*o)));
    // Stable: odometry before truth before scans at one stamp, as the importers write them.
    records.sort_by_key(|r| {
        let kind = match r {
            LogRecord::Odom(_) => 0u8,
            LogRecord::Truth(_) => 1,
            LogRecord::Scan(_) => 2,
        };
        (r.stamp_ns(), kind)
    });
    SensorLog { header: log.header, records }
}

#[cfg(test)]
mod tests;
