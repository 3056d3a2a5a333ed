//! The particle-filter localiser over a recorded log: estimates, covariances, and the error
//! against the log's truth where it has any.

use crate::driver::Observer;
use crate::replay::LogSource;
use crate::session::{PoseSource, Session, SessionStep};
use crate::source::Step;
use crate::{HarnessError, NoClock};
use mapkeeper_grid::{OccupancyGrid, Pose2, angle_diff};
use mapkeeper_localiser::{Covariance3, FilterParams, Localiser, UpdateOutcome};
use mapkeeper_sensor::{StampedPose, interpolate};
use std::fmt::Write as _;

/// AMCL's default initial covariance, σ = 0.5 m in x and y and π/12 rad in yaw: the default of
/// `FilterParams::initial_cov_*`, which [`localise_log`] uses for an explicit or logged initial
/// pose.
pub const INIT_COVARIANCE: Covariance3 =
    [[0.25, 0.0, 0.0], [0.0, 0.25, 0.0], [0.0, 0.0, (std::f64::consts::PI / 12.0) * (std::f64::consts::PI / 12.0)]];

/// Where the filter started.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InitFrom {
    /// The caller's pose.
    Given(Pose2),
    /// The log's true pose at the first scan (the operator's initial pose of a real run).
    LoggedTruth(Pose2),
    /// Particles uniform over the map's free space.
    Global,
}

impl std::fmt::Display for InitFrom {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Given(p) => write!(f, "--init ({}, {}, {})", p.x, p.y, p.yaw),
            Self::LoggedTruth(p) => write!(f, "truth ({}, {}, {})", p.x, p.y, p.yaw),
            Self::Global => f.write_str("global"),
        }
    }
}

/// What a localisation run over a log produced.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LocaliseRun {
    /// The estimate after every filter call.
    pub estimates: Vec<StampedPose>,
    /// `time_s,trace,lambda_max,particles,ess` per filter call, with its header line.
    pub covariance_csv: String,
    /// Filter calls.
    pub updates: u64,
    /// Calls whose sensor update ran (degenerate ones included).
    pub sensor_updates: u64,
    /// Sensor updates whose weights degenerated and were recovered.
    pub degenerate: u64,
    /// Calls without a usable beam.
    pub no_beams: u64,
    /// Steps before the first odometry record, skipped.
    pub no_odometry: u64,
    /// Position and yaw RMSE against the log's truth, and over how many estimates (`None`
    /// without truth records).
    pub rmse: Option<(f64, f64, usize)>,
}

/// Records every filter call and scores it against the truth.
#[derive(Default)]
struct Recorder {
    run: LocaliseRun,
    sq_pos: f64,
    sq_yaw: f64,
    n_err: usize,
}

impl Observer for Recorder {
    fn on_step(&mut self, step: &Step, report: &SessionStep, _session: &Session<'_>) {
        let Some(r) = report.localiser else {
            self.run.no_odometry += 1;
            return;
        };
        let run = &mut self.run;
        run.updates += 1;
        match r.outcome {
            UpdateOutcome::Updated => run.sensor_updates += 1,
            UpdateOutcome::Degenerate { .. } => {
                run.sensor_updates += 1;
                run.degenerate += 1;
            }
            UpdateOutcome::NoUsableBeams => run.no_beams += 1,
            UpdateOutcome::Gated | UpdateOutcome::InvalidOdometry => {}
        }
        let (t, e) = (report.stamp_ns, r.estimate);
        let p = e.pose_in_map;
        run.estimates.push(StampedPose { stamp_ns: t, pose: p });
        let trace = e.covariance[0][0] + e.covariance[1][1] + e.covariance[2][2];
        let _ = writeln!(
            run.covariance_csv,
            "{},{trace:.9e},{:.9e},{},{:.3}",
            super::seconds(t),
            e.lambda_max(),
            r.particles,
            r.ess
        );
        if let Some(truth) = step.truth {
            self.sq_pos += p.distance(&truth.pose_in_map).powi(2);
            self.sq_yaw += angle_diff(p.yaw, truth.pose_in_map.yaw).powi(2);
            self.n_err += 1;
        }
    }
}

/// Localises over `source` on `map`: the filter starts at `init`, else at the log's truth at
/// the first scan, else globally; one filter call per step with odometry (the latest reading
/// at or before the step; steps before the first are skipped). `observers` see every step (an
/// MCAP recorder, say).
pub fn localise_log(
    mut source: LogSource,
    map: &OccupancyGrid,
    params: FilterParams,
    init: Option<Pose2>,
    seed: u64,
    observers: &mut [&mut dyn Observer],
) -> Result<(LocaliseRun, InitFrom), HarnessError> {
    if source.is_empty() {
        return Err(HarnessError::Invalid(format!("{}: the log has no scans", source.name())));
    }
    let mut filter = Localiser::new(map, params, super::chain_seed(seed))?;
    let init = match (init, source.first_stamp_ns().and_then(|t| interpolate(source.truth(), t))) {
        (Some(p), _) => InitFrom::Given(p),
        (None, Some(p)) => InitFrom::LoggedTruth(p),
        (None, None) => InitFrom::Global,
    };
    if let InitFrom::Given(p) | InitFrom::LoggedTruth(p) = init {
        filter.init_pose(p, params.initial_covariance())?;
    }
    let mut session = Session::new(PoseSource::Localiser(Box::new(filter)), None, None, &NoClock);
    session.set_deskew(source.options().deskew);
    let mut rec = Recorder::default();
    rec.run.covariance_csv.push_str("time_s,trace,lambda_max,particles,ess\n");
    let mut all: Vec<&mut dyn Observer> = vec![&mut rec];
    all.extend(observers.iter_mut().map(|o| &mut **o as &mut dyn Observer));
    crate::run(&mut source, &mut session, &mut [], &mut all)?;
    drop(all);
    let n = rec.n_err as f64;
    rec.run.rmse = (rec.n_err > 0).then(|| ((rec.sq_pos / n).sqrt(), (rec.sq_yaw / n).sqrt(), rec.n_err));
    Ok((rec.run, init))
}
