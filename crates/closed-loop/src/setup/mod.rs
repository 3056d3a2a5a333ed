//! What the robustness experiments share: their worlds and maps ([`Setup`], made by [`prepare`]
//! from the `[recovery]` table, [`params::RecoveryParams`]), places on the tour
//! ([`tour_from`]), one drive set up from them ([`Setup::drive`], [`Drive`]) and when a pose
//! counts as recovered ([`recovery_time`]). The loop every experiment runs is [`crate::runner`];
//! the trial runner is [`crate::trials`]. No experiment imports another: what two of them need
//! lives here or in `mapkeeper-scenario`'s `experiments` module.

pub mod chain;
pub mod params;

use crate::ExperimentError;
use crate::controls::TrackSample;
use crate::runner::{NoClock, RunInputs, RunnerParams, WorldRun, run_world};
use crate::worlds::generator::{WorldChain, generate_worlds};
use crate::worlds::mapping::build_initial_map;
use mapkeeper_common::ParamError;
use mapkeeper_grid::{GridGeometry, OccupancyGrid, Point2, Pose2};
use mapkeeper_sim::{Route, StartPose, World, ground_truth_map};
use mapkeeper_updater::StructureMemory;
use params::{InitialMapKind, RecoveryParams, SuccessCriterion};

/// The worlds and maps every experiment shares.
#[derive(Clone, Debug)]
pub struct Setup {
    /// W_1 … W_K.
    pub chain: WorldChain,
    /// M_1, built in W_1.
    pub m1: OccupancyGrid,
    /// G_1 … G_K.
    pub ground_truth: Vec<OccupancyGrid>,
    /// The common grid.
    pub geometry: GridGeometry,
}

impl Setup {
    /// W_`i` and G_`i` (1-based), or an error naming the world if it was not generated.
    pub fn world(&self, i: usize) -> Result<(&World, &OccupancyGrid), ExperimentError> {
        match (self.chain.worlds.get(i.wrapping_sub(1)), self.ground_truth.get(i.wrapping_sub(1))) {
            (Some(w), Some(g)) => Ok((w, g)),
            _ => Err(ExperimentError::InvalidParam(ParamError::rule(
                "world",
                format!("W_{i} was not generated ({} worlds)", self.chain.worlds.len()),
            ))),
        }
    }

    /// The map of W_1 of the given kind.
    pub fn initial_map(&self, kind: InitialMapKind) -> &OccupancyGrid {
        match (kind, self.ground_truth.first()) {
            (InitialMapKind::GroundTruth, Some(g1)) => g1,
            _ => &self.m1,
        }
    }
}

/// Generates W_1 … W_K, builds M_1 in W_1 and rasterises G_1 … G_K.
pub fn prepare(w1: &World, params: &RecoveryParams, seed: u64) -> Result<Setup, ExperimentError> {
    params.validate()?;
    let geometry = w1.default_map_geometry(params.resolution_m)?;
    let chain = generate_worlds(w1, &params.tour, params.worlds_needed(), seed, &params.generator)?;
    let m1 = build_initial_map(w1, &params.exploration_route, &geometry, &params.runner.sim, &params.mapping, seed)?;
    let ground_truth = chain.worlds.iter().map(|w| ground_truth_map(w, &geometry)).collect();
    Ok(Setup { chain, m1: m1.map, ground_truth, geometry })
}

/// The pose `s` metres along the closed `tour` (heading of the segment there) and the route
/// from it onwards, `length_m` long, wrapping around the tour.
pub fn tour_from(tour: &Route, s: f64, length_m: f64) -> (Pose2, Route) {
    let pts = tour.points();
    let segs: Vec<(Point2, Point2, f64)> =
        pts.windows(2).map(|w| (w[0], w[1], w[0].distance(w[1]))).filter(|(_, _, d)| *d > 1e-9).collect();
    let total: f64 = segs.iter().map(|s| s.2).sum();
    if segs.is_empty() || total.is_nan() || total <= 0.0 {
        let p = pts.first().copied().unwrap_or_default();
        return (Pose2::new(p.x, p.y, 0.0), Route::new(&[p]));
    }
    let mut s = s.rem_euclid(total);
    let mut k = 0;
    while k + 1 < segs.len() && s >= segs[k].2 {
        s -= segs[k].2;
        k += 1;
    }
    let (a, b, d) = segs[k];
    let t = (s / d).clamp(0.0, 1.0);
    let start = Point2::new(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y));
    let yaw = (b.y - a.y).atan2(b.x - a.x);
    let mut route = vec![start];
    let mut left = length_m;
    let mut from = start;
    let mut idx = k;
    let mut guard = 0;
    while left > 1e-9 && guard < 100_000 {
        guard += 1;
        let to = segs[idx].1;
        let dd = from.distance(to);
        if dd >= left {
            let f = left / dd;
            route.push(Point2::new(from.x + f * (to.x - from.x), from.y + f * (to.y - from.y)));
            break;
        }
        if dd > 1e-9 {
            route.push(to);
        }
        left -= dd;
        from = to;
        idx = (idx + 1) % segs.len();
    }
    (Pose2::new(start.x, start.y, yaw), Route::new(&route))
}

/// One drive of a robustness experiment, set up once: W_k with the robot started on the tour,
/// the route from there, the map the robot localises on (and the updater starts from) and
/// G_k to score against. Every trial of every experiment runs through it ([`Setup::drive`],
/// then [`Drive::run`] with the trial's runner parameters), so that a drive is set up one way.
#[derive(Clone, Debug)]
pub struct Drive<'a> {
    /// W_k with the robot started at [`Drive::start`].
    pub world: World,
    /// The route from the start onwards.
    pub route: Route,
    /// Where the robot starts: on the tour, heading along it.
    pub start: Pose2,
    /// The map the chain and baseline localisers run on and the updater starts from.
    pub map: &'a OccupancyGrid,
    /// G_k, the ground truth of W_k.
    pub truth: &'a OccupancyGrid,
    /// The updater's cross-world memory that came with [`Drive::map`] (a chain's map,
    /// [`chain::ChainMap`]); `None`: a surveyed or stale map, every occupied cell established.
    pub memory: Option<&'a StructureMemory>,
}

impl Setup {
    /// The drive in W_`world` (1-based) on `map`, starting `position_m` along the closed `tour`
    /// and driving `length_m` of it ([`tour_from`]); an error names a world not generated.
    pub fn drive<'a>(
        &'a self,
        world: usize,
        map: &'a OccupancyGrid,
        tour: &Route,
        position_m: f64,
        length_m: f64,
    ) -> Result<Drive<'a>, ExperimentError> {
        let (w, truth) = self.world(world)?;
        let (start, route) = tour_from(tour, position_m, length_m);
        Ok(Drive { world: with_start(w, start), route, start, map, truth, memory: None })
    }
}

impl Drive<'_> {
    /// The closed loop's inputs: the chain and the baseline both on [`Drive::map`], with
    /// [`Drive::memory`].
    pub fn inputs(&self) -> RunInputs<'_> {
        RunInputs {
            world: &self.world,
            route: &self.route,
            prev_map: self.map,
            baseline_map: self.map,
            prev_memory: self.memory,
        }
    }

    /// Runs the drive once with `params` (the trial's updater, controls and time limit); the
    /// random streams derive from `seed` and `label`; nothing is timed.
    pub fn run(&self, params: &RunnerParams, seed: u64, label: &str) -> Result<WorldRun, ExperimentError> {
        run_world(&self.inputs(), params, seed, label, &NoClock)
    }
}

/// `world` with the robot started at `start`.
fn with_start(world: &World, start: Pose2) -> World {
    let mut w = world.clone();
    w.robot_start = StartPose { x: start.x, y: start.y, yaw_deg: start.yaw.to_degrees() };
    w
}

/// When the chain localiser's error came under the criterion for good: the start of the last
/// stretch of good samples, if it reaches the end of the track and lasts at least `hold_s`
/// (within one sample period). `None` if the last sample is bad or the track is empty.
pub fn recovery_time(track: &[TrackSample], c: &SuccessCriterion) -> Option<f64> {
    let good = |s: &TrackSample| c.holds(s.error_m, s.yaw_error_rad);
    let last = track.last()?;
    if !good(last) {
        return None;
    }
    let first_good = match track.iter().rposition(|s| !good(s)) {
        Some(i) => i + 1,
        None => 0,
    };
    let t_r = track[first_good].t_s;
    let period = if track.len() >= 2 { (last.t_s - track[0].t_s) / (track.len() - 1) as f64 } else { 0.0 };
    (last.t_s - t_r + period + 1e-9 >= c.hold_s).then_some(t_r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tour_from_wraps_and_has_the_asked_length() {
        let tour = Route::default_warehouse();
        let total = tour.length_m();
        for s in [0.0, 5.0, total - 1.0, total + 3.0] {
            let (start, r) = tour_from(&tour, s, 20.0);
            assert!((r.length_m() - 20.0).abs() < 1e-9, "{s}: {}", r.length_m());
            let p = r.points()[0];
            assert!((p.x - start.x).abs() < 1e-12 && (p.y - start.y).abs() < 1e-12);
        }
        let (start, _) = tour_from(&tour, 1.0, 5.0);
        // The tour starts north from (-3.65, -2.3).
        assert!((start.x + 3.65).abs() < 1e-9 && (start.y + 1.3).abs() < 1e-9);
        assert!((start.yaw - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
    }

    fn sample(t: f64, e: f64) -> TrackSample {
        TrackSample { t_s: t, error_m: e, yaw_error_rad: 0.0 }
    }

    #[test]
    fn recovery_time_is_the_start_of_the_last_good_stretch() {
        let c = SuccessCriterion { hold_s: 1.0, ..SuccessCriterion::default() };
        let track: Vec<_> =
            [1.0, 0.1, 0.5, 0.1, 0.1, 0.1].iter().enumerate().map(|(i, &e)| sample(i as f64 * 0.5, e)).collect();
        assert_eq!(recovery_time(&track, &c), Some(1.5));
        // Too short a good stretch.
        let c2 = SuccessCriterion { hold_s: 2.0, ..c };
        assert_eq!(recovery_time(&track, &c2), None);
        // Bad at the end.
        let bad: Vec<_> = [0.1, 0.1, 0.3].iter().enumerate().map(|(i, &e)| sample(i as f64, e)).collect();
        assert_eq!(recovery_time(&bad, &c), None);
        assert_eq!(recovery_time(&[], &c), None);
    }
}
