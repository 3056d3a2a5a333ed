//! The `evidence` section of the updater's parameters ([`EvidenceParams`]): the surface
//! evidence across worlds of `crate::additions::surface_evidence` (issue 53; its rules are in
//! that module's docs).

use mapkeeper_common::ParamError;
use serde::{Deserialize, Serialize};

/// Parameters of the surface evidence (`UpdaterParams::evidence`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EvidenceParams {
    /// Use it (the rules of the module docs). Default `false` (`mapkeeper-evidence` `true`).
    pub enabled: bool,
    /// The band before a beam's end whose cells get its passes, metres. Default 0.15.
    pub band_m: f64,
    /// A beam whose end point's spread exceeds this gives no evidence, metres. Default 0.05.
    pub max_sigma_m: f64,
    /// Floor of the step's position spread, metres. Default 0.01.
    pub min_xy_sigma_m: f64,
    /// Floor of the step's yaw spread, degrees. Default 0.1.
    pub min_yaw_sigma_deg: f64,
    /// Beams meeting their surface at less than this give no evidence, degrees. Default 10.
    pub min_incidence_deg: f64,
    /// RMS distance of five neighbouring end points from their fitted line above which the beam
    /// ended on no single surface (a corner, a leg, an edge) and gives no evidence, metres.
    /// Default 0.02.
    pub planarity_m: f64,
    /// A crossed cell counts as free only if its centre lies this much more than its half-extent
    /// in front of the fitted surface, metres. Default 0.
    pub surface_margin_m: f64,
    /// Weighted flags a record needs before it decides the cell. Default 60 (decisions integrate
    /// over several passes and worlds: registration's error is correlated within a pass).
    pub min_weight: f64,
    /// Whether a face of established structure (see the structure memory) may grow by a cell;
    /// `false`: only cells beside young structure (items added in the last worlds) are added,
    /// so established structure can thin but never move. Default `true` (`false` measured:
    /// worse, `docs/updater.md`, "Surface evidence").
    pub grow_established: bool,
    /// A step whose pose comes with no uncertainty (an oracle's true pose: `validate --poses
    /// true`) is weighed at the floors `min_xy_sigma_m`, `min_yaw_sigma_deg`. Default `false`:
    /// such a step gives no evidence (a pose of unknown quality is not trusted).
    pub trust_unreported_pose: bool,
    /// Hit share at which a cell becomes occupied. Default 0.6.
    pub occupied_share: f64,
    /// Hit share at which an occupied cell becomes free. Default 0.1.
    pub free_share: f64,
    /// Weighted flags a record holds at most (older ones fade). Default 500.
    pub max_weight: f64,
    /// A record that agrees with its cell's state within this share of certainty is dropped.
    /// Default 0.05.
    pub drop_margin: f64,
}

impl Default for EvidenceParams {
    fn default() -> Self {
        Self {
            enabled: false,
            band_m: 0.15,
            max_sigma_m: 0.05,
            min_xy_sigma_m: 0.01,
            min_yaw_sigma_deg: 0.1,
            min_incidence_deg: 10.0,
            planarity_m: 0.02,
            surface_margin_m: 0.0,
            min_weight: 60.0,
            grow_established: true,
            trust_unreported_pose: false,
            occupied_share: 0.6,
            free_share: 0.1,
            max_weight: 500.0,
            drop_margin: 0.05,
        }
    }
}

impl EvidenceParams {
    /// Whether these are the defaults with the evidence off (then not written with the
    /// parameters, so that the paper's presets serialise as before).
    pub fn is_default_off(&self) -> bool {
        *self == Self::default()
    }

    /// Checks every field; the first bad one is named `evidence.…`.
    pub fn validate(&self) -> Result<(), ParamError> {
        let positive = |name: &str, v: f64, max: f64| {
            if v.is_finite() && v > 0.0 && v <= max {
                Ok(())
            } else {
                Err(ParamError::new(name, v, format!("must be finite, > 0 and ≤ {max}")))
            }
        };
        let check = || -> Result<(), ParamError> {
            positive("band_m", self.band_m, 2.0)?;
            positive("max_sigma_m", self.max_sigma_m, 1.0)?;
            positive("min_xy_sigma_m", self.min_xy_sigma_m, 1.0)?;
            positive("min_yaw_sigma_deg", self.min_yaw_sigma_deg, 45.0)?;
            if !(0.0..90.0).contains(&self.min_incidence_deg) {
                return Err(ParamError::new("min_incidence_deg", self.min_incidence_deg, "must lie in [0, 90)"));
            }
            positive("planarity_m", self.planarity_m, 1.0)?;
            if !(self.surface_margin_m.is_finite() && (0.0..=1.0).contains(&self.surface_margin_m)) {
                return Err(ParamError::new("surface_margin_m", self.surface_margin_m, "must lie in [0, 1]"));
            }
            positive("min_weight", self.min_weight, 1e6)?;
            positive("max_weight", self.max_weight, 1e6)?;
            if self.max_weight < self.min_weight {
                return Err(ParamError::new("max_weight", self.max_weight, "must be ≥ min_weight"));
            }
            if !(self.occupied_share > 0.0 && self.occupied_share <= 1.0) {
                return Err(ParamError::new("occupied_share", self.occupied_share, "must lie in (0, 1]"));
            }
            if !(self.free_share >= 0.0 && self.free_share < self.occupied_share) {
                return Err(ParamError::new("free_share", self.free_share, "must lie in [0, occupied_share)"));
            }
            if !(0.0..0.5).contains(&self.drop_margin) {
                return Err(ParamError::new("drop_margin", self.drop_margin, "must lie in [0, 0.5)"));
            }
            Ok(())
        };
        check().map_err(|e| e.within("evidence"))
    }
}
