//! What a closed-loop run records around a kidnapping of the chain localiser's estimate and,
//! if asked, at every processed step (`RunnerParams::kidnap`, `RunnerParams::record_timeline`;
//! used by the robustness experiments, `docs/recovery.md`).

use crate::ScenarioError;
use mapkeeper_grid::Pose2;
use mapkeeper_updater::Verdict;
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
    pub(crate) fn validate(&self) -> Result<(), ScenarioError> {
        let finite = [self.at_s, self.dx_m, self.dy_m, self.dyaw_rad, self.sigma_xy_m, self.sigma_yaw_rad];
        if finite.iter().any(|v| !v.is_finite()) || self.at_s < 0.0 || self.sigma_xy_m < 0.0 || self.sigma_yaw_rad < 0.0
        {
            return Err(ScenarioError::InvalidParam {
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
