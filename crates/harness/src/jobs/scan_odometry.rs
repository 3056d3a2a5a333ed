//! Odometry made by scan matching, for a log that has laser scans and nothing else
//! (`mapkeeper convert --odometry-from-scans`; `docs/real-data.md`, "Logs with scans only").
//!
//! The scans are taken in time order, one *step* per stamp (the scans of several lidars with the
//! same stamp match together, each through its own mount). Each step is matched against a local
//! map of the recent scans (scan-to-submap), in the `odom` frame, which starts at the identity
//! at the first step:
//!
//! 1. **Predict** the last step's motion again (a constant motion per step: logs thinned by
//!    travel, as CARMEN's corrected logs are, have steps a metre apart at any time gap); the
//!    first step predicts none.
//! 2. **Match** the step's beam endpoints (`matcher.max_beams` per lidar, evenly over the valid
//!    readings shorter than `max_range_m`) against the local map from the prediction with the
//!    localiser's [`ScanMatcher`](mapkeeper_localiser::ScanMatcher) (a correlative search, then
//!    a refinement) in its window
//!    ([`ScanMatchParams::window_for`] of the predicted motion: ±0.2 m and ±0.15 rad unless
//!    `window_xy_per_m` or `window_yaw_per_motion` widen it).
//! 3. **Search wide** where that match is refused or clipped by its window's edge: every
//!    `wide_resolution_m` cell and `wide_yaw_step_rad` yaw within `matcher.max_window_xy_m` and
//!    `matcher.max_window_yaw_rad` of the prediction, scored on a coarse table over the beams
//!    that end where the key scans saw (a pose that sees past the local map is not outscored by
//!    a look-alike inside it), then the fine match from the best of them. The wide match replaces
//!    an accepted narrow one when it fits at least as large a share of the beams (plus
//!    `matcher.refused_min_inlier_gain`, default 0).
//! 4. **Accept or keep the prediction**: an accepted match gives the step's pose; a refused one
//!    (fewer than `matcher.min_inlier_share` of the beams within `matcher.inlier_m` of the local
//!    map) leaves the prediction, and is counted. After `restart_after_refused` refusals in a
//!    row the local map is started afresh from the step's scans at the prediction (a *restart*,
//!    counted): the robot has left the map behind, or the map no longer fits.
//! 5. **Grow the local map**: a step becomes a *key scan* when its pose is `key_distance_m` or
//!    `key_turn_rad` from the last key scan's; the local map is the distance field of the last
//!    `submap_scans` key scans' surfaces (their endpoints, with the gaps between neighbouring
//!    beams on one surface filled in, and the distance taken to the points themselves, not to
//!    their cells, so the match is not pulled onto the cell lattice), in a square of
//!    `2 · submap_radius_m` around the newest key scan, rebuilt when a key scan is added. A robot
//!    standing still matches the same map again and again, so its odometry does not creep.
//!
//! Deterministic: no randomness, no clock. Any log is accepted: a step without a usable beam
//! keeps the prediction (counted apart), a scan whose header is invalid gives no beams, a log
//! without scans gives no odometry.
//!
//! Limits: the motion within a sweep is not deskewed; a long corridor whose walls are parallel
//! to the motion, or an open space beyond `max_range_m`, pins the pose across the corridor only
//! (the prediction carries it along); the drift of any incremental method grows with the path.

use local_map::LocalMap;
use mapkeeper_common::ParamError;
use mapkeeper_grid::Pose2;
use mapkeeper_localiser::{BeamSelection, BeamSet, Match, ScanMatchParams, Window};
use mapkeeper_logs::ScanOdometrySummary;
use mapkeeper_sensor::{LaserScan, LogRecord, OdometryReading, SensorLog};

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
    /// lidar (`enabled` and the second-search fields are not read; `max_window_xy_m` and
    /// `max_window_yaw_rad` are the wide search's window, `refused_min_inlier_gain` how much
    /// more of the beams the wide search's match must fit to replace an accepted one). Default:
    /// the localiser's defaults with a ±0.2 m, ±0.15 rad window, a wide window of ±1.2 m and
    /// ±1 rad, and acceptance at 0.4 of the beams within 0.1 m.
    pub matcher: ScanMatchParams,
    /// Readings at or beyond this are not matched nor mapped, metres. Default 30 (a corridor's
    /// far end pins the pose along it).
    pub max_range_m: f64,
    /// The local map's cell size, metres. Default 0.05.
    pub resolution_m: f64,
    /// Half the side of the local map's square around the newest key scan, metres. Default 30.
    pub submap_radius_m: f64,
    /// Key scans in the local map. Default 15.
    pub submap_scans: usize,
    /// A step becomes a key scan this far from the last key scan, metres. Default 0.25.
    pub key_distance_m: f64,
    /// … or turned this much from it, radians. Default 0.15.
    pub key_turn_rad: f64,
    /// Refused matches in a row after which the local map is started afresh. Default 10.
    pub restart_after_refused: usize,
    /// The wide search's cell (its position step, and its kernel's σ), metres. Default 0.1.
    pub wide_resolution_m: f64,
    /// The wide search's yaw step, radians. Default 0.015 (0.86°).
    pub wide_yaw_step_rad: f64,
}

impl Default for ScanOdometryParams {
    fn default() -> Self {
        Self {
            matcher: ScanMatchParams {
                enabled: true,
                window_xy_m: 0.2,
                window_yaw_rad: 0.15,
                max_window_xy_m: 1.2,
                max_window_yaw_rad: 1.0,
                min_inlier_share: 0.4,
                ..ScanMatchParams::default()
            },
            max_range_m: 30.0,
            resolution_m: 0.05,
            submap_radius_m: 30.0,
            submap_scans: 15,
            key_distance_m: 0.25,
            key_turn_rad: 0.15,
            restart_after_refused: 10,
            wide_resolution_m: 0.1,
            wide_yaw_step_rad: 0.015,
        }
    }
}

impl ScanOdometryParams {
    /// Checks every field; the first violation is returned (the matcher's named `scan_match.…`).
    pub fn validate(&self) -> Result<(), ParamError> {
        self.matcher.validate()?;
        let checks: [(&'static str, f64, bool, &'static str); 9] = [
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
            (
                "wide_resolution_m",
                self.wide_resolution_m,
                self.wide_resolution_m >= self.resolution_m && self.wide_resolution_m <= 1.0,
                "must be at least resolution_m and at most 1",
            ),
            (
                "wide_yaw_step_rad",
                self.wide_yaw_step_rad,
                (0.001..=0.1).contains(&self.wide_yaw_step_rad),
                "must be in [0.001, 0.1]",
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
        let m = &self.matcher;
        format!(
            "scan-to-local-map matching: each step's scans against the surfaces of the last {} key scans \
(one each {} m or {} rad) in {} m cells; the last step's motion as the prediction, searched within ±{} m ±{} rad \
and, where refused or clipped, within ±{} m ±{} rad; accepted at {} of the beams within {} m, \
else the prediction is kept; beams < {} m",
            self.submap_scans,
            self.key_distance_m,
            self.key_turn_rad,
            self.resolution_m,
            m.window_xy_m,
            m.window_yaw_rad,
            m.max_window_xy_m,
            m.max_window_yaw_rad,
            m.min_inlier_share,
            m.inlier_m,
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

/// The match of `ends` from `predicted` (after the predicted motion `step_motion`) on `map`, if
/// one is accepted. First narrow, in the window the motion opens; where that is refused or
/// clipped by the window's edge, wide: from the best pose of the wide search. The wide match
/// replaces an accepted narrow one if it fits at least `matcher.refused_min_inlier_gain` more of
/// the beams (default 0: as many).
fn best_match(
    map: &LocalMap,
    predicted: &Pose2,
    step_motion: &Pose2,
    ends: &[[f64; 2]],
    p: &ScanOdometryParams,
) -> Option<Match> {
    let matcher = map.matcher.as_ref()?;
    let sm = &p.matcher;
    let window = sm.window_for(step_motion.x.hypot(step_motion.y), step_motion.yaw);
    let usable = |m: &Match| m.accepted && m.pose_in_map.is_finite();
    let first = matcher.match_scan_within(predicted, ends, window);
    if first.is_some_and(|m| usable(&m) && !m.at_edge) {
        return first;
    }
    let wide = Window { xy_m: sm.max_window_xy_m, yaw_rad: sm.max_window_yaw_rad };
    let second = map
        .wide
        .as_ref()
        .and_then(|w| w.search(predicted, ends, wide, p.wide_yaw_step_rad, sm.prior_weight))
        .and_then(|from| matcher.match_scan_within(&from, ends, sm.base_window()));
    match (first.filter(usable), second.filter(usable)) {
        (Some(a), Some(b)) => Some(if b.inlier_share >= a.inlier_share + sm.refused_min_inlier_gain { b } else { a }),
        (a, b) => a.or(b),
    }
}

/// The local map's points of a step's scans (those with a valid header), robot frame.
fn step_points(step: &[&LaserScan], p: &ScanOdometryParams) -> Vec<[f64; 2]> {
    let mut out = Vec::new();
    for scan in step.iter().filter(|s| s.validate().is_ok()) {
        local_map::map_points(scan, p.max_range_m, p.resolution_m, &mut out);
    }
    out
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
    let (mut pose, mut step_motion) = (Pose2::IDENTITY, Pose2::IDENTITY);
    let mut refused_in_a_row = 0usize;
    for step in steps(log) {
        let stamp = step[0].stamp_ns;
        let predicted = pose.compose(&step_motion);
        beams.clear();
        for scan in step.iter().filter(|s| s.validate().is_ok()) {
            beams.add_scan(scan, params.matcher.max_beams, params.max_range_m, BeamSelection::EvenlyOverValid);
        }
        let ends = beams.endpoints();
        let now = if ends.is_empty() {
            summary.without_beams += 1;
            predicted
        } else if map.matcher.is_some() {
            match best_match(&map, &predicted, &step_motion, ends, params) {
                Some(m) => {
                    summary.matched += 1;
                    refused_in_a_row = 0;
                    if map.wants_key(&m.pose_in_map, params) {
                        map.add(m.pose_in_map, step_points(&step, params), ends, params);
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
                        map.add(predicted, step_points(&step, params), ends, params);
                    }
                    predicted
                }
            }
        } else {
            // The first step with beams starts the local map where the odometry is.
            map.add(predicted, step_points(&step, params), ends, params);
            predicted
        };
        let now = if now.is_finite() { now } else { pose };
        summary.path_m += pose.distance(&now);
        step_motion = pose.between(&now);
        pose = now;
        readings.push(OdometryReading { stamp_ns: stamp, pose_in_odom: pose });
    }
    summary.steps = readings.len();
    ScanOdometry { readings, summary }
}

/// `log` with its odometry records replaced by `odometry`'s readings, the records in stamp order
/// (stable), odometry before truth before scans at one stamp, as the importers write them.
pub fn with_odometry(log: SensorLog, odometry: &ScanOdometry) -> SensorLog {
    let mut records: Vec<LogRecord> = log.records.into_iter().filter(|r| !matches!(r, LogRecord::Odom(_))).collect();
    records.extend(odometry.readings.iter().map(|o| LogRecord::Odom(*o)));
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

mod local_map;
#[cfg(test)]
mod tests;
