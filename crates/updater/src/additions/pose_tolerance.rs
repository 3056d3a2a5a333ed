//! Tolerances that follow the step's pose uncertainty (a `mapkeeper` addition, issue 27 item 3).
//!
//! The paper's tolerances are fixed: the classifier's virtual rays cover ±n_e·v·Δθ whatever the
//! pose error, D_th(z) and tol(z) grow with range only, and a detected change votes every
//! non-free cell it crosses. A step whose pose is off by more than that writes its error into
//! the map. Here each step gets a [`StepTolerance`] from the uncertainty of its pose (σ_xy,
//! σ_yaw, scaled by `k_sigma`), and every test that compares a beam with `M_{i-1}` allows for it:
//!
//! - **Classifier** (eq. 3-5): a yaw error δ turns the whole scan, and a lateral position error
//!   e moves a beam's ray sideways, which at range z is the same as turning it by e/z. The
//!   virtual rays therefore cover ±(k·σ_yaw + k·σ_xy/z) (at least the preset's window, at most
//!   `max_window_deg`), per beam: the casts at the offsets give the geometry of each surface,
//!   so a beam meeting a wall at a steep incidence, whose range changes most with the angle,
//!   is judged at the incidence it really has. The position error along the beam adds k·σ_xy
//!   to D_th(z).
//! - **Added obstacle** (§4.3.2): p_i may lie up to k·(σ_xy + z·σ_yaw) from where the beam
//!   really ended, so every cell within tol(z) plus that margin must be free.
//! - **Removed obstacle** (§4.3.1): at range s the ray may lie up to u(s) = k·(σ_xy + s·σ_yaw)
//!   to either side of where it is drawn. A non-free cell gets its "changed" vote only if the
//!   ray crossed non-free space of `M_{i-1}` across that whole band (no free cell within u(s)
//!   of the crossing, perpendicular to the ray): a ray that passes through a removed box votes,
//!   a ray that skims a wall face at a shallow incidence (the free side of the face lies within
//!   the band) does not. This is the incidence rule that makes walls erode under a yaw error,
//!   replaced by one that follows the error's size.
//!
//! Where σ comes from, in order: registration before writing, when it accepted the step (the
//! spread of its fit: the inverse of the inliers' information times their RMSE); else the
//! localiser's own covariance, when the caller hands it over
//! ([`crate::MapUpdater::set_pose_sigma`]); else nothing. σ is never below the floors
//! `min_xy_sigma_m` and `min_yaw_sigma_deg` (a fit's covariance counts its points as independent,
//! which they are not), and every margin is capped (`max_margin_m`), so a localiser that reports
//! a huge covariance cannot make every beam agree with the map.

pub use crate::support::step_tolerance::StepTolerance;
use mapkeeper_common::ParamError;
use serde::{Deserialize, Serialize};

/// Parameters of the uncertainty-following tolerances (`UpdaterParams::tolerance`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ToleranceParams {
    /// Use them (the rules of the module docs). Default `false` (`mapkeeper` `true`).
    pub enabled: bool,
    /// Margins are `k_sigma` standard deviations. Default 2.
    pub k_sigma: f64,
    /// Floor of σ_xy, metres. Default 0.01.
    pub min_xy_sigma_m: f64,
    /// Floor of σ_yaw, degrees. Default 0.05.
    pub min_yaw_sigma_deg: f64,
    /// Cap of the classifier's angular half-window, degrees. Default 2.
    pub max_window_deg: f64,
    /// Cap of every distance margin (D_th, tol, the removal band), metres. Default 0.15.
    pub max_margin_m: f64,
}

impl Default for ToleranceParams {
    fn default() -> Self {
        Self {
            enabled: false,
            k_sigma: 2.0,
            min_xy_sigma_m: 0.01,
            min_yaw_sigma_deg: 0.05,
            max_window_deg: 2.0,
            max_margin_m: 0.15,
        }
    }
}

impl ToleranceParams {
    /// Checks every field; the first bad one is named with its dotted name (`tolerance.…`).
    pub fn validate(&self) -> Result<(), ParamError> {
        for (name, v, hi) in [
            ("tolerance.k_sigma", self.k_sigma, 10.0),
            ("tolerance.min_xy_sigma_m", self.min_xy_sigma_m, 1.0),
            ("tolerance.min_yaw_sigma_deg", self.min_yaw_sigma_deg, 10.0),
            ("tolerance.max_window_deg", self.max_window_deg, 10.0),
            ("tolerance.max_margin_m", self.max_margin_m, 1.0),
        ] {
            if !(v.is_finite() && (0.0..=hi).contains(&v)) {
                return Err(ParamError::new(name, v, format!("must lie in [0, {hi}]")));
            }
        }
        Ok(())
    }
}

/// One-sigma uncertainty of a pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseSigma {
    /// Position, metres (the larger axis of the x-y ellipse).
    pub xy_m: f64,
    /// Yaw, radians.
    pub yaw_rad: f64,
}

impl PoseSigma {
    /// From a 3×3 covariance of (x m, y m, yaw rad): the square root of the x-y block's larger
    /// eigenvalue and of the yaw variance. `None` if it is not a finite covariance.
    pub fn from_covariance(c: &[[f64; 3]; 3]) -> Option<Self> {
        let (a, b, d) = (c[0][0], c[0][1], c[1][1]);
        let half_trace = 0.5 * (a + d);
        let largest = half_trace + (0.25 * (a - d) * (a - d) + b * b).sqrt();
        let yaw = c[2][2];
        (largest.is_finite() && yaw.is_finite() && largest >= 0.0 && yaw >= 0.0)
            .then(|| Self { xy_m: largest.sqrt(), yaw_rad: yaw.sqrt() })
    }
}

impl StepTolerance {
    /// The margins for a pose of uncertainty `sigma` (`None`: unknown, the floors), or
    /// [`StepTolerance::NONE`] when `p` is off.
    pub fn new(sigma: Option<PoseSigma>, p: &ToleranceParams) -> Self {
        if !p.enabled {
            return Self::NONE;
        }
        let (xy, yaw) = sigma.map_or((0.0, 0.0), |s| (s.xy_m, s.yaw_rad));
        let floor = |v: f64, min: f64| if v.is_finite() { v.max(min) } else { min };
        Self {
            xy_m: p.k_sigma * floor(xy, p.min_xy_sigma_m),
            yaw_rad: p.k_sigma * floor(yaw, p.min_yaw_sigma_deg.to_radians()),
            max_window_rad: p.max_window_deg.to_radians(),
            max_margin_m: p.max_margin_m,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Point2, Pose2};

    fn on() -> ToleranceParams {
        ToleranceParams { enabled: true, ..ToleranceParams::default() }
    }

    #[test]
    fn off_is_the_fixed_tolerance() {
        let t = StepTolerance::new(Some(PoseSigma { xy_m: 0.5, yaw_rad: 0.1 }), &ToleranceParams::default());
        assert!(t.is_none());
        assert_eq!(t.window_rad(3.0, 0.004), 0.004);
        assert_eq!(t.change_distance_margin_m(), 0.0);
        assert_eq!(t.lateral_m(10.0), 0.0);
    }

    #[test]
    fn margins_follow_sigma_with_floors_and_caps() {
        let p = on();
        // Unknown uncertainty: the floors (k = 2: 2 cm, 0.1°).
        let t = StepTolerance::new(None, &p);
        assert!((t.xy_m - 0.02).abs() < 1e-12 && (t.yaw_rad - 0.1f64.to_radians()).abs() < 1e-12);
        // The window: the preset's at long range, wider close by (the position error seen as
        // an angle), never beyond the cap.
        let fixed = 0.25f64.to_radians();
        assert_eq!(t.window_rad(20.0, fixed), fixed);
        assert!((t.window_rad(2.0, fixed) - (t.yaw_rad + 0.01)).abs() < 1e-12);
        assert!((t.window_rad(0.01, fixed) - 2f64.to_radians()).abs() < 1e-12);
        // A large sigma: margins grow with range and stop at the caps.
        let t = StepTolerance::new(Some(PoseSigma { xy_m: 0.03, yaw_rad: 1f64.to_radians() }), &p);
        assert!((t.lateral_m(2.0) - (0.06 + 2.0 * 2f64.to_radians())).abs() < 1e-12);
        assert_eq!(t.lateral_m(20.0), 0.15);
        assert_eq!(t.window_rad(10.0, 0.0), 2f64.to_radians());
        // A non-finite sigma falls back to the floors.
        let t = StepTolerance::new(Some(PoseSigma { xy_m: f64::NAN, yaw_rad: f64::INFINITY }), &p);
        assert_eq!(t, StepTolerance::new(None, &p));
    }

    #[test]
    fn covariance_to_sigma() {
        let s = PoseSigma::from_covariance(&[[0.04, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 1e-4]]).unwrap();
        assert!((s.xy_m - 0.2).abs() < 1e-12 && (s.yaw_rad - 0.01).abs() < 1e-12);
        // Correlated x-y: the larger axis of the ellipse.
        let s = PoseSigma::from_covariance(&[[0.02, 0.01, 0.0], [0.01, 0.02, 0.0], [0.0, 0.0, 0.0]]).unwrap();
        assert!((s.xy_m - 0.03f64.sqrt()).abs() < 1e-12);
        assert!(PoseSigma::from_covariance(&[[f64::NAN; 3]; 3]).is_none());
        assert!(PoseSigma::from_covariance(&[[0.0; 3], [0.0; 3], [0.0, 0.0, -1.0]]).is_none());
    }

    #[test]
    fn the_band_votes_through_a_box_not_along_a_wall_face() {
        // A 0.05 m grid: a wall along y = 0 (rows 0-3 occupied) and a 10 × 10-cell box.
        let g = GridGeometry::new(200, 100, 0.05, Pose2::IDENTITY).unwrap();
        let mut m = OccupancyGrid::filled(g, CellState::Free);
        for ix in 0..200 {
            for iy in 0..4 {
                m.set(CellCoord::new(ix, iy), CellState::Occupied);
            }
        }
        for ix in 100..110 {
            for iy in 50..60 {
                m.set(CellCoord::new(ix, iy), CellState::Occupied);
            }
        }
        let t = StepTolerance::new(Some(PoseSigma { xy_m: 0.01, yaw_rad: 0.5f64.to_radians() }), &on());
        // A ray straight through the middle of the box, 4 m away: the band (about ±0.16 m,
        // capped at 0.15) stays inside the box's 0.5 m.
        let origin = Point2::new(1.0, 2.75);
        let dir = (1.0, 0.0);
        assert!(t.band_is_non_free(&m, origin, dir, g.cell_center(CellCoord::new(103, 55))));
        // Near the box's side the band reaches free space: withheld.
        assert!(!t.band_is_non_free(&m, Point2::new(1.0, 2.52), dir, g.cell_center(CellCoord::new(103, 50))));
        // A ray skimming the wall's face at 3°: the face cell it crosses has free space within
        // the band (withheld); without an allowance it votes.
        let a = 3f64.to_radians();
        let (ux, uy) = (a.cos(), -a.sin());
        let origin = Point2::new(0.5, 0.5);
        let s = (0.5 - 0.19) / a.sin(); // where the ray is at y = 0.19 (the face row's centre)
        let face = Point2::new(origin.x + s * ux, 0.175);
        assert!(!t.band_is_non_free(&m, origin, (ux, uy), face));
        let none = StepTolerance::NONE;
        assert!(none.band_is_non_free(&m, origin, (ux, uy), face));
    }
}
