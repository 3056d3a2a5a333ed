//! A filter's state apart from its map ([`FilterState`]): saved and restored, the filter gives
//! the same updates from there, bit for bit.

use super::{Estimate, Localiser};
use crate::scan_match::Match;
use mapkeeper_grid::Pose2;
use rand::rngs::ChaCha8Rng;

/// Everything a [`Localiser`] carries from one update to the next (its particles, weights,
/// random stream, odometry references and filter statistics), without its map tables or
/// scratch: [`Localiser::save_state`] / [`Localiser::restore_state`] take a filter back to an
/// earlier step, after which it gives the same updates, bit for bit, as it gave from there the
/// first time (for a caller that tries a step two ways and keeps one).
#[derive(Debug)]
pub struct FilterState {
    rng: ChaCha8Rng,
    particles: Vec<Pose2>,
    weights: Vec<f64>,
    odom_at_filter: Option<Pose2>,
    last_odom: Option<Pose2>,
    force_update: bool,
    sensor_updates_since_resample: u32,
    ln_w_slow: f64,
    ln_w_fast: f64,
    filter_estimate: Estimate,
    ess: f64,
    last_match: Option<Match>,
}

impl FilterState {
    /// The particles' poses at the saved step.
    pub fn particles(&self) -> &[Pose2] {
        &self.particles
    }
}

/// An exact copy of a random stream (rand's generator is not `Clone`; its saved state is its
/// key, stream and position, so the copy draws exactly the numbers the original would).
fn copy_rng(rng: &ChaCha8Rng) -> ChaCha8Rng {
    ChaCha8Rng::deserialize_state(&rng.serialize_state())
}

impl Localiser {
    /// The filter's state now ([`FilterState`]).
    pub fn state(&self) -> FilterState {
        FilterState {
            rng: copy_rng(&self.rng),
            particles: self.particles.clone(),
            weights: self.weights.clone(),
            odom_at_filter: self.odom_at_filter,
            last_odom: self.last_odom,
            force_update: self.force_update,
            sensor_updates_since_resample: self.sensor_updates_since_resample,
            ln_w_slow: self.ln_w_slow,
            ln_w_fast: self.ln_w_fast,
            filter_estimate: self.filter_estimate,
            ess: self.ess,
            last_match: self.last_match,
        }
    }

    /// [`Localiser::state`] into `into`, reusing its buffers.
    pub fn save_state(&self, into: &mut FilterState) {
        let FilterState {
            rng,
            particles,
            weights,
            odom_at_filter,
            last_odom,
            force_update,
            sensor_updates_since_resample,
            ln_w_slow,
            ln_w_fast,
            filter_estimate,
            ess,
            last_match,
        } = into;
        *rng = copy_rng(&self.rng);
        particles.clone_from(&self.particles);
        weights.clone_from(&self.weights);
        *odom_at_filter = self.odom_at_filter;
        *last_odom = self.last_odom;
        *force_update = self.force_update;
        *sensor_updates_since_resample = self.sensor_updates_since_resample;
        *ln_w_slow = self.ln_w_slow;
        *ln_w_fast = self.ln_w_fast;
        *filter_estimate = self.filter_estimate;
        *ess = self.ess;
        *last_match = self.last_match;
    }

    /// Takes the filter back to a state saved from it (or from a filter with the same map and
    /// parameters): its next updates are those it gave after the save.
    pub fn restore_state(&mut self, from: &FilterState) {
        let FilterState {
            rng,
            particles,
            weights,
            odom_at_filter,
            last_odom,
            force_update,
            sensor_updates_since_resample,
            ln_w_slow,
            ln_w_fast,
            filter_estimate,
            ess,
            last_match,
        } = from;
        self.rng = copy_rng(rng);
        self.particles.clone_from(particles);
        self.weights.clone_from(weights);
        self.odom_at_filter = *odom_at_filter;
        self.last_odom = *last_odom;
        self.force_update = *force_update;
        self.sensor_updates_since_resample = *sensor_updates_since_resample;
        self.ln_w_slow = *ln_w_slow;
        self.ln_w_fast = *ln_w_fast;
        self.filter_estimate = *filter_estimate;
        self.ess = *ess;
        self.last_match = *last_match;
    }
}
