//! The margins of one step's pose uncertainty, as every test that compares a beam with
//! `M_{i-1}` applies them ([`StepTolerance::NONE`]: the paper's fixed tolerances). Where the
//! margins come from is the `mapkeeper` addition `additions::pose_tolerance`.

use mapkeeper_grid::{CellState, OccupancyGrid, Point2};

/// The margins of one step: k·σ in position and yaw, floored, with the caps.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepTolerance {
    /// k·σ_xy, metres (0: the fixed tolerances of the preset).
    pub xy_m: f64,
    /// k·σ_yaw, radians.
    pub yaw_rad: f64,
    /// Cap of the classifier's half-window, radians.
    pub(crate) max_window_rad: f64,
    /// Cap of the distance margins, metres.
    pub(crate) max_margin_m: f64,
}

impl StepTolerance {
    /// No allowance: the preset's fixed tolerances.
    pub const NONE: Self = Self { xy_m: 0.0, yaw_rad: 0.0, max_window_rad: 0.0, max_margin_m: 0.0 };

    /// Whether the step has any allowance (off: the preset's fixed tolerances, bit for bit).
    pub fn is_none(&self) -> bool {
        *self == Self::NONE
    }

    /// The classifier's angular half-window for a beam of range `z_m`, given the preset's own
    /// `fixed_rad`: k·σ_yaw + k·σ_xy/z, at least `fixed_rad`, at most the cap (or `fixed_rad`
    /// if larger).
    pub fn window_rad(&self, z_m: f64, fixed_rad: f64) -> f64 {
        if self.is_none() {
            return fixed_rad;
        }
        let w = self.yaw_rad + self.xy_m / z_m.max(1e-3);
        w.min(self.max_window_rad).max(fixed_rad)
    }

    /// What D_th(z) gains: the position error along the beam, capped.
    pub fn change_distance_margin_m(&self) -> f64 {
        self.xy_m.min(self.max_margin_m)
    }

    /// How far a point at range `s_m` from the lidar may lie from where the pose puts it:
    /// k·(σ_xy + s·σ_yaw), capped.
    pub fn lateral_m(&self, s_m: f64) -> f64 {
        (self.xy_m + s_m.max(0.0) * self.yaw_rad).min(self.max_margin_m)
    }

    /// The removal band: whether a ray from `origin` along the unit direction (`ux`, `uy`)
    /// crosses only non-free cells of `base` across its whole uncertainty at `centre` (a
    /// crossed cell's centre): the points at up to [`StepTolerance::lateral_m`] on either side
    /// of the ray, perpendicular to it, through the projection of `centre` on the ray, sampled
    /// every half cell. Cells outside the grid count as non-free.
    pub fn band_is_non_free(&self, base: &OccupancyGrid, origin: Point2, (ux, uy): (f64, f64), centre: Point2) -> bool {
        if self.is_none() {
            return true;
        }
        let s = (centre.x - origin.x) * ux + (centre.y - origin.y) * uy;
        let half = self.lateral_m(s);
        let (px, py) = (origin.x + s * ux, origin.y + s * uy);
        let g = base.geometry();
        let step = 0.5 * g.resolution_m();
        let n = (half / step).ceil() as i32;
        (-n..=n).all(|k| {
            let t = (k as f64 * step).clamp(-half, half);
            let q = Point2::new(px - t * uy, py + t * ux);
            g.world_to_cell(q).and_then(|c| base.get(c)) != Some(CellState::Free)
        })
    }
}
