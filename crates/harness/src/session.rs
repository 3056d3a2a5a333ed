//! The estimators of one run, stepped together: a pose source (the chain localiser, or a
//! recorded trajectory), the map updater fed with that pose, and an optional baseline
//! localiser on another map. A [`Session`] sees only [`SensorFrame`]s; truth never reaches it,
//! except as a pose an experiment's control hands the updater explicitly
//! ([`Session::set_updater_pose_override`]).

use crate::HarnessError;
use crate::clock::Clock;
use crate::source::SensorFrame;
use mapkeeper_grid::{OccupancyGrid, Pose2};
use mapkeeper_localiser::{Covariance3, Estimate, Localiser, UpdateReport};
use mapkeeper_sensor::{StampedPose, deskew_all, interpolate};
use mapkeeper_updater::{MapUpdater, PoseSigma, StepOutcome, StepReport as UpdaterStep};
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::JoinHandle;

/// Where the session's robot pose comes from.
#[derive(Debug)]
pub enum PoseSource {
    /// A particle filter on the session's map (the paper's chain localiser).
    Localiser(Box<Localiser>),
    /// A recorded trajectory (e.g. a localiser's TUM output), interpolated at each stamp.
    Track(Vec<StampedPose>),
    /// No pose: the session only passes frames to observers (e.g. mapping at true poses).
    None,
}

/// Why a step was not given to the estimators.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Skip {
    /// The localiser needs odometry and the frame has none.
    NoOdometry,
    /// The recorded trajectory has no pose (it is empty).
    NoPose,
}

/// What the session did with one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct SessionStep {
    /// The frame's stamp, nanoseconds.
    pub stamp_ns: u64,
    /// The robot pose the updater was given (the localiser's estimate after this frame, the
    /// recorded pose, or an experiment's override, moved by the pose bias if one is in force);
    /// `None` if the step was skipped or the session has no pose source and no override.
    pub pose_in_map: Option<Pose2>,
    /// The chain localiser's report (with [`PoseSource::Localiser`]).
    pub localiser: Option<UpdateReport>,
    /// The updater's report (with an updater).
    pub updater: Option<UpdaterStep>,
    /// Time the updater call took, nanoseconds on the session's clock (`None` without a clock
    /// or without an updater call).
    pub updater_ns: Option<u64>,
    /// The updater's change state after the step, bytes (0 without an updater or when the
    /// step was not processed).
    pub updater_state_bytes: u64,
    /// Why the step was skipped, if it was.
    pub skipped: Option<Skip>,
}

impl SessionStep {
    fn skipped(stamp_ns: u64, why: Skip) -> Self {
        Self {
            stamp_ns,
            pose_in_map: None,
            localiser: None,
            updater: None,
            updater_ns: None,
            updater_state_bytes: 0,
            skipped: Some(why),
        }
    }
}

/// One update of the baseline localiser, in processing order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaselineSample {
    /// The frame's stamp, nanoseconds.
    pub stamp_ns: u64,
    /// Whether the filter's sensor update ran.
    pub sensor_update: bool,
    /// The estimate after the frame.
    pub estimate: Estimate,
}

/// The baseline localiser: on the caller's thread, or on one of its own (same results, in the
/// same order; the frames are queued).
#[derive(Debug)]
pub enum Baseline {
    /// Stepped inline after the chain localiser and the updater.
    Inline(Box<Localiser>, Vec<BaselineSample>),
    /// Stepped on a thread of its own.
    Threaded(SyncSender<SensorFrame>, JoinHandle<Vec<BaselineSample>>),
}

impl Baseline {
    /// A baseline stepped inline.
    pub fn inline(localiser: Localiser) -> Self {
        Self::Inline(Box::new(localiser), Vec::new())
    }

    /// A baseline stepped on a thread of its own.
    pub fn threaded(localiser: Localiser) -> Self {
        let (tx, rx): (SyncSender<SensorFrame>, Receiver<SensorFrame>) = sync_channel(256);
        let worker = std::thread::spawn(move || {
            let mut loc = localiser;
            let mut samples = Vec::new();
            for frame in rx {
                samples.extend(baseline_step(&mut loc, &frame));
            }
            samples
        });
        Self::Threaded(tx, worker)
    }

    fn feed(&mut self, frame: &SensorFrame) {
        match self {
            Self::Inline(loc, samples) => samples.extend(baseline_step(loc, frame)),
            // The worker stops only when the channel closes, so a send cannot fail while it lives.
            Self::Threaded(tx, _) => drop(tx.send(frame.clone())),
        }
    }

    fn finish(self) -> Result<Vec<BaselineSample>, HarnessError> {
        match self {
            Self::Inline(_, samples) => Ok(samples),
            Self::Threaded(tx, worker) => {
                drop(tx);
                worker.join().map_err(|_| HarnessError::BaselinePanicked)
            }
        }
    }
}

fn baseline_step(loc: &mut Localiser, frame: &SensorFrame) -> Option<BaselineSample> {
    let odometry = frame.odometry?;
    let r = loc.update(odometry, &frame.scans);
    Some(BaselineSample { stamp_ns: frame.stamp_ns, sensor_update: r.sensor_update, estimate: r.estimate })
}

/// What a finished session leaves.
#[derive(Debug)]
pub struct SessionOutput {
    /// The updater (with `M_i`, its statistics), if the session had one.
    pub updater: Option<MapUpdater>,
    /// The baseline localiser's updates, in order (empty without a baseline).
    pub baseline: Vec<BaselineSample>,
}

/// The estimators of one run, stepped by [`Session::process`].
pub struct Session<'c> {
    pose: PoseSource,
    updater: Option<MapUpdater>,
    baseline: Option<Baseline>,
    clock: &'c dyn Clock,
    /// An offset added to the pose source's pose before the updater sees it ([`Session::set_pose_bias`]).
    bias: Option<PoseBias>,
    /// The pose the updater is given on the next step instead of the pose source's
    /// ([`Session::set_updater_pose_override`]).
    updater_pose: Option<Pose2>,
    /// Whether scans with a sweep timing are deskewed ([`Session::set_deskew`]).
    deskew: bool,
    /// The last frame's odometry and its time (the motion over the next sweep).
    last_odometry: Option<(u64, Pose2)>,
}

/// Odometry older than this gives no motion for deskewing, nanoseconds.
const DESKEW_MAX_ODOMETRY_GAP_NS: u64 = 1_000_000_000;

/// An offset of the pose the updater is given (an experiment holding the estimate wrong while
/// the localiser itself runs on): the position moves by (`dx_m`, `dy_m`) in the map frame and
/// the heading by `dyaw_rad`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PoseBias {
    /// Along the map's x axis, metres.
    pub dx_m: f64,
    /// Along the map's y axis, metres.
    pub dy_m: f64,
    /// Heading, radians.
    pub dyaw_rad: f64,
}

impl PoseBias {
    /// `pose` moved by the bias.
    pub fn apply(&self, pose: Pose2) -> Pose2 {
        Pose2::new(pose.x + self.dx_m, pose.y + self.dy_m, mapkeeper_grid::wrap_angle(pose.yaw + self.dyaw_rad))
    }
}

impl std::fmt::Debug for Session<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Session").field("pose", &self.pose).field("updater", &self.updater.is_some()).finish()
    }
}

impl<'c> Session<'c> {
    /// A session; the updater's time per step is read from `clock`.
    pub fn new(
        pose: PoseSource,
        updater: Option<MapUpdater>,
        baseline: Option<Baseline>,
        clock: &'c dyn Clock,
    ) -> Self {
        Self { pose, updater, baseline, clock, bias: None, updater_pose: None, deskew: true, last_odometry: None }
    }

    /// Whether the scans that carry a sweep timing (`LaserScan::sweep`) are deskewed before
    /// every estimator sees them (default true): each beam is moved to where it would have been
    /// measured from the robot at the frame's time, the robot's motion over the sweep taken at
    /// constant velocity from the last two odometry readings ([`mapkeeper_sensor::deskew`]).
    /// Scans without timing, and frames without odometry now and less than a second before, are
    /// left as they are. Observers still see the raw frame.
    pub fn set_deskew(&mut self, on: bool) {
        self.deskew = on;
    }

    /// The frame the estimators see: `frame` with its timed scans deskewed, when deskewing is
    /// on and the motion is known; `None` to use `frame` as it is.
    fn deskewed(&self, frame: &SensorFrame, before: Option<(u64, Pose2)>) -> Option<SensorFrame> {
        if !self.deskew || frame.scans.iter().all(|s| s.sweep.is_none()) {
            return None;
        }
        let (now, before) = (frame.odometry?, before?);
        if frame.stamp_ns.saturating_sub(before.0) > DESKEW_MAX_ODOMETRY_GAP_NS {
            return None;
        }
        let scans = deskew_all(&frame.scans, before, (frame.stamp_ns, now));
        Some(SensorFrame { stamp_ns: frame.stamp_ns, odometry: frame.odometry, scans })
    }

    /// From the next step on, the pose the updater is given (and [`SessionStep::pose_in_map`])
    /// is the pose source's pose moved by `bias`; `None` removes it. The localiser itself is
    /// not touched. [`Session::set_estimate`] removes the bias (the estimate is re-initialised).
    pub fn set_pose_bias(&mut self, bias: Option<PoseBias>) {
        self.bias = bias;
    }

    /// The bias in force, if any.
    pub fn pose_bias(&self) -> Option<PoseBias> {
        self.bias
    }

    /// An experiment's oracle: on the next step (the next [`Session::process`], which consumes
    /// it) the updater is given `pose_in_map` instead of the pose source's pose, and
    /// [`SessionStep::pose_in_map`] is that pose (moved by the pose bias, if one is in force).
    /// The pose source is stepped as usual: the chain localiser runs on untouched, and a step
    /// it skips (no odometry) discards the override. With [`PoseSource::None`] the updater is
    /// given the override. Only an experiment control that sees the truth sets it (e.g. an
    /// updater fed true poses); `None` withdraws an override not yet used.
    pub fn set_updater_pose_override(&mut self, pose_in_map: Option<Pose2>) {
        self.updater_pose = pose_in_map;
    }

    /// The override waiting for the next step, if any.
    pub fn updater_pose_override(&self) -> Option<Pose2> {
        self.updater_pose
    }

    /// Steps every estimator with one frame: the pose source first, then the updater with
    /// that pose (or the override, [`Session::set_updater_pose_override`]; and the frame's
    /// odometry, or the pose where there is none), then the baseline.
    pub fn process(&mut self, frame: &SensorFrame) -> SessionStep {
        let before = self.last_odometry;
        if let Some(o) = frame.odometry {
            self.last_odometry = Some((frame.stamp_ns, o));
        }
        let deskewed = self.deskewed(frame, before);
        let frame = deskewed.as_ref().unwrap_or(frame);
        let oracle = self.updater_pose.take();
        let (pose, localiser) = match &mut self.pose {
            PoseSource::Localiser(loc) => {
                let Some(odometry) = frame.odometry else {
                    return SessionStep::skipped(frame.stamp_ns, Skip::NoOdometry);
                };
                let r = loc.update(odometry, &frame.scans);
                (Some(r.estimate.pose_in_map), Some(r))
            }
            PoseSource::Track(track) => match interpolate(track, frame.stamp_ns) {
                Some(p) => (Some(p), None),
                None => return SessionStep::skipped(frame.stamp_ns, Skip::NoPose),
            },
            PoseSource::None => (None, None),
        };
        let pose = oracle.or(pose);
        let pose = match (pose, self.bias) {
            (Some(p), Some(b)) => Some(b.apply(p)),
            _ => pose,
        };
        let (mut updater_ns, mut updater_state_bytes) = (None, 0);
        // The localiser's own uncertainty goes with its pose (not with an oracle's).
        let sigma = match (&localiser, oracle) {
            (Some(r), None) => PoseSigma::from_covariance(&r.estimate.covariance),
            _ => None,
        };
        let updater = match (self.updater.as_mut(), pose) {
            (Some(u), Some(p)) => {
                u.set_pose_sigma(sigma);
                let t0 = self.clock.now_ns();
                let step = u.process(p, frame.odometry.unwrap_or(p), &frame.scans);
                let t1 = self.clock.now_ns();
                updater_ns = (t1 > 0).then(|| t1.saturating_sub(t0));
                if step.outcome == StepOutcome::Processed {
                    updater_state_bytes = u.state_bytes() as u64;
                }
                Some(step)
            }
            _ => None,
        };
        if let Some(b) = self.baseline.as_mut() {
            b.feed(frame);
        }
        SessionStep {
            stamp_ns: frame.stamp_ns,
            pose_in_map: pose,
            localiser,
            updater,
            updater_ns,
            updater_state_bytes,
            skipped: None,
        }
    }

    /// Re-initialises the chain localiser at `pose_in_map` with `covariance` (an experiment
    /// biasing the estimate, or pose updating handing a pose back).
    pub fn set_estimate(&mut self, pose_in_map: Pose2, covariance: Covariance3) -> Result<(), HarnessError> {
        match &mut self.pose {
            PoseSource::Localiser(loc) => {
                loc.init_pose(pose_in_map, covariance)?;
                self.bias = None;
                Ok(())
            }
            _ => Err(HarnessError::Unsupported("the session's pose comes from no localiser".into())),
        }
    }

    /// Tells the updater that `pose_in_map` (at odometry `pose_in_odom`) is its new last good
    /// pose (after a recovery).
    pub fn reset_updater_reference(&mut self, pose_in_map: Pose2, pose_in_odom: Pose2) {
        if let Some(u) = self.updater.as_mut() {
            u.reset_reference_pose(pose_in_map, pose_in_odom);
        }
    }

    /// The chain localiser's particles (with [`PoseSource::Localiser`]).
    pub fn particles(&self) -> Option<&[Pose2]> {
        match &self.pose {
            PoseSource::Localiser(l) => Some(l.particles()),
            _ => None,
        }
    }

    /// The updater, if any.
    pub fn updater(&self) -> Option<&MapUpdater> {
        self.updater.as_ref()
    }

    /// The updated map so far, if the session has an updater.
    pub fn map(&self) -> Option<&OccupancyGrid> {
        self.updater.as_ref().map(MapUpdater::map)
    }

    /// Ends the session: joins the baseline and hands back the updater.
    pub fn finish(self) -> Result<SessionOutput, HarnessError> {
        let baseline = match self.baseline {
            Some(b) => b.finish()?,
            None => Vec::new(),
        };
        Ok(SessionOutput { updater: self.updater, baseline })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::NoClock;
    use mapkeeper_localiser::FilterParams;
    use mapkeeper_sensor::LaserScan;
    use mapkeeper_testkit::rooms::ten_by_ten_centred;
    use mapkeeper_updater::UpdaterParams;

    /// Step k: the robot 0.3 m further along x, one scan.
    fn frame(k: u64) -> SensorFrame {
        let stamp_ns = 100_000_000 * (k + 1);
        let scan = LaserScan {
            stamp_ns,
            lidar_id: 0,
            lidar_in_robot: Pose2::IDENTITY,
            angle_min_rad: -1.5,
            angle_increment_rad: 0.01,
            range_min_m: 0.05,
            range_max_m: 20.0,
            ranges_m: vec![3.0; 301],
            sweep: None,
        };
        SensorFrame { stamp_ns, odometry: Some(Pose2::new(0.3 * k as f64, 0.0, 0.0)), scans: vec![scan] }
    }

    /// The oracle's pose at step k: off the localiser's estimate by a metre.
    fn oracle(k: u64) -> Pose2 {
        Pose2::new(0.3 * k as f64 - 1.0, 0.5, 0.1)
    }

    fn session(pose: PoseSource) -> Session<'static> {
        let updater = MapUpdater::new(ten_by_ten_centred(), UpdaterParams::paper()).unwrap();
        Session::new(pose, Some(updater), None, &NoClock)
    }

    fn localiser() -> PoseSource {
        let mut loc = Localiser::new(&ten_by_ten_centred(), FilterParams::default(), 5).unwrap();
        loc.init_pose(Pose2::IDENTITY, [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.01]]).unwrap();
        PoseSource::Localiser(Box::new(loc))
    }

    #[test]
    fn an_override_reaches_the_updater_and_not_the_localiser() {
        let mut with = session(localiser());
        let mut without = session(localiser());
        let track = (0..8).map(|k| StampedPose { stamp_ns: frame(k).stamp_ns, pose: oracle(k) }).collect();
        let mut fed = session(PoseSource::Track(track));
        let mut processed = 0;
        for k in 0..8 {
            let f = frame(k);
            with.set_updater_pose_override(Some(oracle(k)));
            assert_eq!(with.updater_pose_override(), Some(oracle(k)));
            let (a, b, c) = (with.process(&f), without.process(&f), fed.process(&f));
            assert_eq!(with.updater_pose_override(), None, "consumed by the step");
            // The localiser runs on as if there were no override, bit for bit.
            assert_eq!(a.localiser, b.localiser);
            assert_ne!(a.pose_in_map, b.pose_in_map);
            // The updater does exactly what it does when the pose source is the oracle's pose.
            assert_eq!(a.pose_in_map, Some(oracle(k)));
            assert_eq!(a.updater, c.updater);
            processed += usize::from(a.updater.as_ref().is_some_and(|u| u.outcome == StepOutcome::Processed));
        }
        assert!(processed > 0, "the updater processed steps");
        let (w, f) = (with.finish().unwrap(), fed.finish().unwrap());
        assert_eq!(w.updater.map(|u| u.map().clone()), f.updater.map(|u| u.map().clone()));
    }

    #[test]
    fn the_bias_moves_the_override_and_a_skipped_step_discards_it() {
        let mut s = session(localiser());
        let bias = PoseBias { dx_m: 0.5, dy_m: 0.0, dyaw_rad: 0.0 };
        s.set_pose_bias(Some(bias));
        s.set_updater_pose_override(Some(oracle(0)));
        assert_eq!(s.process(&frame(0)).pose_in_map, Some(bias.apply(oracle(0))));
        s.set_updater_pose_override(Some(oracle(1)));
        let report = s.process(&SensorFrame { odometry: None, ..frame(1) });
        assert_eq!(report.skipped, Some(Skip::NoOdometry));
        assert_eq!(s.updater_pose_override(), None);
    }

    #[test]
    fn timed_scans_are_deskewed_by_the_odometry_when_on_and_known() {
        use mapkeeper_sensor::SweepTiming;
        let timed = |k: u64| {
            let mut f = frame(k);
            // 0.3 m per 0.1 s along x: the first beam was measured 0.03 s (9 cm) before the last.
            f.scans[0].sweep = Some(SweepTiming::ending_at_stamp(301, 1e-4));
            f
        };
        let mut s = session(PoseSource::None);
        let before = Some((frame(0).stamp_ns, frame(0).odometry.unwrap()));
        let out = s.deskewed(&timed(1), before).expect("a timed scan with the motion known");
        let (raw, fixed) = (&timed(1).scans[0], &out.scans[0]);
        assert!(fixed.sweep.is_none());
        // Beam 150 (straight ahead, measured 0.015 s early from 4.5 cm behind) now reads from the
        // robot at the frame's time, 4.5 cm shorter; beam 295, measured at the end, barely moves.
        let moved = |i: usize| raw.ranges_m[i] - fixed.ranges_m[i];
        assert!((moved(150) - 0.045).abs() < 0.005, "{}", moved(150));
        assert!(moved(295).abs() < 0.005, "{}", moved(295));
        // Not without the motion, not for untimed scans, not when off.
        assert!(s.deskewed(&timed(1), None).is_none());
        assert!(s.deskewed(&frame(1), before).is_none());
        let stale = Some((0, Pose2::IDENTITY));
        assert!(s.deskewed(&SensorFrame { stamp_ns: 2_000_000_000, ..timed(1) }, stale).is_none());
        s.set_deskew(false);
        assert!(s.deskewed(&timed(1), before).is_none());
    }
}
