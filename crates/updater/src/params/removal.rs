//! The `removal` section of the updater's parameters ([`RemovalParams`]): the gates on the
//! removal vote of `crate::additions::removal_gates`.

use super::inf_as_text;
use mapkeeper_common::ParamError;
use serde::{Deserialize, Serialize};

/// The gates on the removal vote (`UpdaterParams::removal`): all off by default (`paper`,
/// `paper-strict`, `authors`); `mapkeeper` sets the hit clearance, the grazing gate and the
/// shadow. Parameter files and records written before the section existed name these fields
/// `removal_hit_clearance_m`, `removal_min_incidence_rad`, `removal_max_offset_cells` and
/// `removal_shadow` at the top level; those names are still read (see [`super::UpdaterParams`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RemovalParams {
    /// Hit clearance: a cell crossed by a detected-change ray gets no "changed" (removed) vote
    /// when a beam of the same step hit a surface closer than this to the cell's centre,
    /// metres; 0 disables the rule. It stops rays at grazing incidence from eroding the edge
    /// cells of walls when the pose is a fraction of a cell off. Default 0 (`mapkeeper` 0.20).
    pub hit_clearance_m: f64,
    /// Grazing gate: a cell on the boundary of a wall of `M_{i-1}` gets no "changed" (removed)
    /// vote from a ray that meets the wall at less than this angle (see the `grazing` module),
    /// radians, at most π/2; 0 disables the gate. Default 0 (`mapkeeper` 10°, 0.1745).
    pub min_incidence_rad: f64,
    /// Ray core (off in every preset: it did not help on the tuning seeds): a cell gets a
    /// "changed" (removed) vote only if the ray passes within this many cells of its centre, so
    /// a ray that clips a corner of the cell does not vote it; `inf` disables. Default `inf`.
    #[serde(with = "inf_as_text")]
    pub max_offset_cells: f64,
    /// Shadow of a withheld vote: after the hit clearance or the grazing gate withheld a vote,
    /// the rest of that run of non-free cells gets none either. Default `false` (`mapkeeper`
    /// `true`).
    pub shadow: bool,
}

impl Default for RemovalParams {
    fn default() -> Self {
        Self { hit_clearance_m: 0.0, min_incidence_rad: 0.0, max_offset_cells: f64::INFINITY, shadow: false }
    }
}

impl RemovalParams {
    /// The gates of the `mapkeeper` presets: hit clearance 0.2 m, grazing gate 10°, shadow;
    /// the ray core off.
    pub fn mapkeeper() -> Self {
        Self { hit_clearance_m: 0.20, min_incidence_rad: 10f64.to_radians(), shadow: true, ..Self::default() }
    }

    /// Checks every field; the first bad one is named `removal.…`.
    pub fn validate(&self) -> Result<(), ParamError> {
        let bad = |name: &str, v: f64, requirement: &str| Err(ParamError::new(name, v, requirement).within("removal"));
        if !(self.hit_clearance_m.is_finite() && self.hit_clearance_m >= 0.0) {
            return bad("hit_clearance_m", self.hit_clearance_m, "must be finite and >= 0");
        }
        if self.max_offset_cells.is_nan() || self.max_offset_cells <= 0.0 {
            return bad("max_offset_cells", self.max_offset_cells, "must be > 0");
        }
        if !(0.0..=std::f64::consts::FRAC_PI_2).contains(&self.min_incidence_rad) {
            return bad("min_incidence_rad", self.min_incidence_rad, "must be within 0..=pi/2");
        }
        Ok(())
    }
}
