//! Shift check (a `mapkeeper-shift` addition to the localisation check, issue 12 item 5): does a
//! nearby pose fit the scan to `M_{i-1}` better than the given one?
//!
//! The paper's check (§4.2) counts detected-change beams, so it cannot tell a wrong pose from a
//! stale map: both make beams disagree with `M_{i-1}`. A wrong pose, though, has a better pose
//! nearby (the true one), while a right pose in a changed world does not (the changed parts fit
//! nowhere). The score of a pose is the mean, over a subsample of the step's valid beams, of the
//! distance from the beam's end point to the nearest occupied cell of `M_{i-1}`, truncated at
//! [`ShiftCheckParams::truncate_m`]; it is evaluated at the given pose and on a grid of poses
//! around it (±[`ShiftCheckParams::search_xy_m`], ±[`ShiftCheckParams::search_yaw_rad`]).
//!
//! The verdict of the paper's check is then changed in two ways:
//! - a pose that scores at least [`ShiftCheckParams::better_margin_m`] better exists nearby: at
//!   least Suspend (a wrong pose the change count missed);
//! - otherwise, if the given pose fits well (score ≤ [`ShiftCheckParams::fit_ok_m`]): Update (a
//!   right pose in a stale world, a false alarm of the change count).
//!
//! Any other case keeps the paper's verdict (a pose whose better fit lies beyond the search, or a
//! scan that fits poorly everywhere).
//!
//! [`ShiftCheckParams::when`] says on which steps the search runs: on every processed step
//! ([`ShiftWhen::EveryStep`], `mapkeeper-shift`: both rules above), or only on the steps where
//! the paper's check raised an alarm ([`ShiftWhen::OnAlarm`], `mapkeeper`). On alarm only, the
//! first rule can never change a verdict (an alarm is at least Suspend already), so the check
//! only *lifts* the change count's stale-map false alarms and never adds one; and the search's
//! cost (about 1.5 ms) is paid only on alarm steps, a few per cent of a stale run's steps and
//! almost none of a validation's, where `M_{i-1}` is kept current.

use crate::paper::localisation_check::Verdict;
use mapkeeper_common::ParamError;
use mapkeeper_grid::{DistanceField, Point2, Pose2};
use mapkeeper_sensor::{BeamValidity, LaserScan};
use serde::{Deserialize, Serialize};

/// The shift check's parameters (`UpdaterParams::shift_check`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ShiftCheckParams {
    /// Run it. Default `false` (`mapkeeper` and `mapkeeper-shift`: `true`).
    pub enabled: bool,
    /// On which steps: `every_step` (default, `mapkeeper-shift`) or `on_alarm` (`mapkeeper`:
    /// only where the paper's check says Suspend or Lost, so it only lifts false alarms).
    pub when: ShiftWhen,
    /// Half-width of the position search, metres. Default 1.6.
    pub search_xy_m: f64,
    /// Position step of the search, metres. Default 0.2.
    pub step_xy_m: f64,
    /// Half-width of the heading search, radians. Default 20° (0.3491).
    pub search_yaw_rad: f64,
    /// Heading step, radians. Default 5° (0.0873).
    pub step_yaw_rad: f64,
    /// Beams scored per step (evenly over the valid ones). Default 60.
    pub max_beams: usize,
    /// End-point distances are truncated here, metres. Default 0.3.
    pub truncate_m: f64,
    /// A nearby pose better by at least this (mean distance, metres) means the given pose is
    /// wrong. Default 0.015.
    pub better_margin_m: f64,
    /// With no better pose nearby, a given pose scoring at most this fits: Update. Default 0.2.
    pub fit_ok_m: f64,
}

/// On which steps the shift check runs ([`ShiftCheckParams::when`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShiftWhen {
    /// Every processed step: lifts false alarms and adds Suspend where a better pose lies nearby.
    #[default]
    EveryStep,
    /// Only steps whose paper verdict is Suspend or Lost: lifts false alarms, adds none.
    OnAlarm,
}

impl ShiftWhen {
    /// Whether the search runs on a step whose paper verdict is `verdict`.
    pub fn runs_on(self, verdict: Verdict) -> bool {
        match self {
            Self::EveryStep => true,
            Self::OnAlarm => verdict != Verdict::Update,
        }
    }
}

impl Default for ShiftCheckParams {
    fn default() -> Self {
        Self {
            enabled: false,
            when: ShiftWhen::EveryStep,
            search_xy_m: 1.6,
            step_xy_m: 0.2,
            search_yaw_rad: 20f64.to_radians(),
            step_yaw_rad: 5f64.to_radians(),
            max_beams: 60,
            truncate_m: 0.3,
            better_margin_m: 0.015,
            fit_ok_m: 0.2,
        }
    }
}

impl ShiftCheckParams {
    /// Whether it is off with default values (then not written to files).
    pub fn is_default_off(&self) -> bool {
        *self == Self::default()
    }

    /// Checks every field; the first bad one is named `shift_check.…`.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.check_fields().map_err(|e| e.within("shift_check"))
    }

    fn check_fields(&self) -> Result<(), ParamError> {
        for (name, v) in [
            ("search_xy_m", self.search_xy_m),
            ("search_yaw_rad", self.search_yaw_rad),
            ("better_margin_m", self.better_margin_m),
            ("fit_ok_m", self.fit_ok_m),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ParamError::new(name, v, "must be finite and ≥ 0"));
            }
        }
        for (name, v) in
            [("step_xy_m", self.step_xy_m), ("step_yaw_rad", self.step_yaw_rad), ("truncate_m", self.truncate_m)]
        {
            if !(v.is_finite() && v > 0.0) {
                return Err(ParamError::new(name, v, "must be finite and > 0"));
            }
        }
        for (name, search, step, step_name) in [
            ("search_xy_m", self.search_xy_m, self.step_xy_m, "step_xy_m"),
            ("search_yaw_rad", self.search_yaw_rad, self.step_yaw_rad, "step_yaw_rad"),
        ] {
            if search / step > 50.0 {
                return Err(ParamError::new(name, search, format!("must be at most 50 steps of {step_name}")));
            }
        }
        if !(1..=10_000).contains(&self.max_beams) {
            return Err(ParamError::new("max_beams", self.max_beams, "must lie in 1..=10000"));
        }
        Ok(())
    }
}

/// What the search found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShiftResult {
    /// The given pose's score, metres.
    pub given_m: f64,
    /// The best score in the search, metres.
    pub best_m: f64,
    /// The best pose.
    pub best_pose: Pose2,
}

/// Scores the given pose and the poses around it; `None` without a valid beam.
pub fn search(
    field: &DistanceField,
    robot_in_map: Pose2,
    scans: &[LaserScan],
    p: &ShiftCheckParams,
) -> Option<ShiftResult> {
    // (lidar_in_robot, beam angle in the lidar frame, range) of the valid beams.
    let mut beams: Vec<(Pose2, f64, f64)> = Vec::new();
    for s in scans {
        if s.validate().is_err() {
            continue;
        }
        for i in 0..s.ranges_m.len() {
            if s.validity(i) == BeamValidity::Valid {
                beams.push((s.lidar_in_robot, s.beam_angle(i as f64), f64::from(s.ranges_m[i])));
            }
        }
    }
    if beams.is_empty() {
        return None;
    }
    let stride = beams.len().div_ceil(p.max_beams).max(1);
    // Each beam's end point in the robot frame, once: a candidate heading then only rotates
    // them, and a candidate position only shifts them.
    let ends: Vec<Point2> = beams
        .into_iter()
        .step_by(stride)
        .map(|(mount, a, r)| mount.transform_point(Point2::new(r * a.cos(), r * a.sin())))
        .collect();
    let n = ends.len() as f64;
    let (nx, ny) = ((p.search_xy_m / p.step_xy_m).round() as i64, (p.search_yaw_rad / p.step_yaw_rad).round() as i64);
    let mut offsets = vec![Point2::new(0.0, 0.0); ends.len()];
    let mut given_m = f64::INFINITY;
    let mut best = (f64::INFINITY, robot_in_map);
    for ia in -ny..=ny {
        let yaw = robot_in_map.yaw + ia as f64 * p.step_yaw_rad;
        let (sin, cos) = yaw.sin_cos();
        for (o, e) in offsets.iter_mut().zip(&ends) {
            *o = Point2::new(cos * e.x - sin * e.y, sin * e.x + cos * e.y);
        }
        for ix in -nx..=nx {
            for iy in -nx..=nx {
                let (x, y) = (robot_in_map.x + ix as f64 * p.step_xy_m, robot_in_map.y + iy as f64 * p.step_xy_m);
                let sum: f64 = offsets
                    .iter()
                    .map(|o| f64::from(field.at_world(Point2::new(x + o.x, y + o.y))).min(p.truncate_m))
                    .sum();
                let score = sum / n;
                if (ia, ix, iy) == (0, 0, 0) {
                    given_m = score;
                }
                if score < best.0 || (score == best.0 && (ia, ix, iy) == (0, 0, 0)) {
                    best = (score, Pose2::new(x, y, yaw));
                }
            }
        }
    }
    Some(ShiftResult { given_m, best_m: best.0, best_pose: best.1 })
}

/// The verdict with the shift check applied to the paper's `verdict` (module docs).
pub fn combine(verdict: Verdict, r: &ShiftResult, p: &ShiftCheckParams) -> Verdict {
    if r.given_m - r.best_m >= p.better_margin_m {
        verdict.max(Verdict::Suspend)
    } else if r.given_m <= p.fit_ok_m {
        Verdict::Update
    } else {
        verdict
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mapkeeper_grid::CellState;
    use mapkeeper_testkit::rooms::{fill_cells, walled_cells};

    /// A 6 m × 6 m room with walls, and a lidar at its centre with 360 beams.
    fn room() -> (DistanceField, impl Fn(Pose2) -> LaserScan) {
        let mut m = walled_cells(120, 120, 0.05, Pose2::new(-3.0, -3.0, 0.0));
        // An L-shaped item so that no shift is ambiguous.
        fill_cells(&mut m, 20..50, 30..31, CellState::Occupied);
        fill_cells(&mut m, 20..21, 20..50, CellState::Occupied);
        let field = DistanceField::to_occupied(&m, 1.0);
        let caster = mapkeeper_grid::RayCaster::new(&m, true);
        let scan = move |truth: Pose2| {
            let ranges = (0..360)
                .map(|i| {
                    let a = truth.yaw + (i as f64).to_radians();
                    let h = caster.cast(truth.position(), a, 10.0);
                    if h.cell.is_some() { h.range_m as f32 } else { f32::INFINITY }
                })
                .collect();
            LaserScan {
                stamp_ns: 0,
                lidar_id: 0,
                lidar_in_robot: Pose2::IDENTITY,
                angle_min_rad: 0.0,
                angle_increment_rad: 1f64.to_radians(),
                range_min_m: 0.05,
                range_max_m: 10.0,
                ranges_m: ranges,
                sweep: None,
            }
        };
        (field, scan)
    }

    #[test]
    fn a_wrong_pose_has_a_better_one_nearby_and_a_right_one_does_not() {
        let (field, scan) = room();
        let p = ShiftCheckParams { enabled: true, ..ShiftCheckParams::default() };
        let truth = Pose2::new(0.3, -0.2, 0.4);
        let s = scan(truth);
        let right = search(&field, truth, std::slice::from_ref(&s), &p).unwrap();
        assert!(right.given_m < 0.04 && right.given_m - right.best_m < p.better_margin_m, "{right:?}");
        assert_eq!(combine(Verdict::Lost, &right, &p), Verdict::Update, "a false alarm is lifted");
        let wrong = search(&field, Pose2::new(0.6, -0.2, 0.4), std::slice::from_ref(&s), &p).unwrap();
        assert!(wrong.given_m - wrong.best_m > p.better_margin_m, "{wrong:?}");
        assert!(wrong.best_pose.distance(&truth) < 0.11, "{wrong:?}");
        assert_eq!(combine(Verdict::Update, &wrong, &p), Verdict::Suspend, "a missed error is caught");
        assert_eq!(combine(Verdict::Lost, &wrong, &p), Verdict::Lost);
        let e = ShiftCheckParams { step_xy_m: 0.0, ..p }.validate().unwrap_err();
        assert_eq!(e, ParamError::new("shift_check.step_xy_m", 0, "must be finite and > 0"));
        let e = ShiftCheckParams { search_yaw_rad: 1.0, step_yaw_rad: 0.01, ..p }.validate().unwrap_err();
        assert_eq!(e.to_string(), "shift_check.search_yaw_rad must be at most 50 steps of step_yaw_rad, got 1");
    }

    #[test]
    fn on_alarm_the_search_runs_only_where_the_paper_raised_one() {
        assert!(ShiftWhen::EveryStep.runs_on(Verdict::Update));
        assert!(!ShiftWhen::OnAlarm.runs_on(Verdict::Update));
        assert!(ShiftWhen::OnAlarm.runs_on(Verdict::Suspend) && ShiftWhen::OnAlarm.runs_on(Verdict::Lost));
        // Read from a parameter file by name.
        let p: ShiftCheckParams = serde_json::from_str(r#"{"enabled": true, "when": "on_alarm"}"#).unwrap();
        assert_eq!(p.when, ShiftWhen::OnAlarm);
        assert!(serde_json::from_str::<ShiftCheckParams>(r#"{"when": "sometimes"}"#).is_err());
    }
}
