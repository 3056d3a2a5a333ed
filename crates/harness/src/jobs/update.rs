//! The map updater over a recorded log and a map: the path by which a real robot's logs are
//! processed (the paper's §5.5 used recorded bags).

use crate::HarnessError;
use crate::clock::Clock;
use crate::driver::{Control, Observer};
use crate::lost::{DEFAULT_LOST_WAIT_S, LostCounts, LostEpisode, LostPolicy};
use crate::replay::LogSource;
use crate::session::{PoseSource, Session, SessionStep};
use crate::source::Step;
use mapkeeper_grid::{OccupancyGrid, Pose2};
use mapkeeper_localiser::{FilterParams, Localiser};
use mapkeeper_sensor::StampedPose;
use mapkeeper_updater::{MapUpdater, PoseRecovery, RecoveryFailure, StepOutcome, UpdaterParams, UpdaterStats};
use std::fmt::Write as _;

/// Where the robot pose given to the updater comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum PoseInput {
    /// A recorded trajectory (e.g. a localiser's TUM output), interpolated at each step.
    Track(Vec<StampedPose>),
    /// The log's truth records (the user asks for the logged poses as the estimate).
    LoggedTruth,
    /// The log's odometry, aligned so that its first pose coincides with the first true pose
    /// if the log has truth records, otherwise with the map frame's origin.
    AlignedOdometry,
    /// The chain localiser on the updater's map, run over the log (the paper's loop on recorded
    /// data): from `init`, else the log's truth at the first scan, else globally.
    Localise {
        /// Its parameters.
        params: Box<FilterParams>,
        /// Its seed.
        seed: u64,
        /// Its initial pose (with the parameters' initial covariance).
        init: Option<Pose2>,
    },
}

/// What the updater did over the log.
#[derive(Debug)]
pub struct UpdateRun {
    /// M_i.
    pub map: OccupancyGrid,
    /// The updater's totals.
    pub stats: UpdaterStats,
    /// One row per step: `time_s,outcome,verdict,n,n_invalid,n_dc,cells_changed,recovery,microseconds`.
    pub steps_csv: String,
    /// The poses pose updating returned, in order.
    pub recovered_poses: Vec<StampedPose>,
    /// One row per attempt of pose updating: [`RECOVERIES_CSV_HEADER`].
    pub recoveries_csv: String,
    /// The pose the updater was given at each step that had one.
    pub poses: Vec<StampedPose>,
    /// With the localiser ([`PoseInput::Localise`]): the Lost episodes and what ended them. A
    /// pose that pose updating recovers is handed back to the localiser and the updater, as in
    /// the simulated runs ([`LostPolicy`]; a log has no robot to stop). Empty otherwise.
    pub lost: LostCounts,
    /// The episodes, in order.
    pub lost_episodes: Vec<LostEpisode>,
}

/// The columns of `recoveries.csv`: one row per step on which pose updating ran; `result` is
/// `recovered` (with the pose in `x_m,y_m,yaw_rad`, `reason` empty) or `refused` (pose empty,
/// `reason` says why).
pub const RECOVERIES_CSV_HEADER: &str = "time_s,verdict,result,x_m,y_m,yaw_rad,reason\n";

/// Why pose updating refused, in one CSV field (no commas).
pub fn refusal_reason(f: &RecoveryFailure) -> String {
    match f {
        RecoveryFailure::TooFewPoints { source, expected } => {
            format!("too_few_points: {source} scan points; {expected} expected points")
        }
        RecoveryFailure::PoorFit { best } => format!(
            "poor_fit: best inlier ratio {:.3}; rmse {:.4} m ({} of {} points)",
            best.inlier_ratio, best.rmse_m, best.inliers, best.source_points
        ),
        RecoveryFailure::Ambiguous { first, second } => format!(
            "ambiguous: ({:.3} {:.3} {:.4}) and ({:.3} {:.3} {:.4}) fit alike",
            first.x, first.y, first.yaw, second.x, second.y, second.yaw
        ),
        RecoveryFailure::Degenerate => "degenerate: the fit does not constrain x; y and yaw".into(),
    }
}

/// Writes one row per step.
struct Rows {
    csv: String,
    recovered: Vec<StampedPose>,
    recoveries: String,
    poses: Vec<StampedPose>,
}

impl Rows {
    fn recovery_row(&mut self, stamp_ns: u64, verdict: &str, r: &PoseRecovery) {
        let t = super::seconds(stamp_ns);
        let _ = match r {
            PoseRecovery::Recovered { pose_in_map: p, .. } => {
                writeln!(self.recoveries, "{t},{verdict},recovered,{:.6},{:.6},{:.6},", p.x, p.y, p.yaw)
            }
            PoseRecovery::NotRecovered { reason } => {
                writeln!(self.recoveries, "{t},{verdict},refused,,,,{}", refusal_reason(reason))
            }
        };
    }
}

impl Observer for Rows {
    fn on_step(&mut self, _step: &Step, report: &SessionStep, _session: &Session<'_>) {
        if let Some(pose) = report.pose_in_map {
            self.poses.push(StampedPose { stamp_ns: report.stamp_ns, pose });
        }
        let Some(r) = &report.updater else { return };
        let outcome = match r.outcome {
            StepOutcome::Processed => "processed",
            StepOutcome::Gated(_) => "gated",
            StepOutcome::NoValidBeams => "no_valid_beams",
            StepOutcome::TooFewBeams => "too_few_beams",
            StepOutcome::Unregistered => "unregistered",
        };
        let verdict = r.verdict.map_or("", |v| v.name());
        if let Some(rec) = &r.pose_recovery {
            self.recovery_row(report.stamp_ns, verdict, rec);
        }
        let recovery = match &r.pose_recovery {
            Some(PoseRecovery::Recovered { pose_in_map, .. }) => {
                self.recovered.push(StampedPose { stamp_ns: report.stamp_ns, pose: *pose_in_map });
                "recovered"
            }
            Some(PoseRecovery::NotRecovered { .. }) => "not_recovered",
            None => "",
        };
        let us = report.updater_ns.unwrap_or(0) as f64 / 1e3;
        let _ = writeln!(
            self.csv,
            "{},{},{},{},{},{},{},{},{:.1}",
            super::seconds(report.stamp_ns),
            outcome,
            verdict,
            r.n_valid,
            r.n_invalid,
            r.n_dc,
            r.changed_cells.len(),
            recovery,
            us
        );
    }
}

/// The pose track the updater is given.
fn pose_track(source: &LogSource, poses: PoseInput) -> Result<Vec<StampedPose>, HarnessError> {
    let name = source.name();
    match poses {
        PoseInput::Track(t) if t.is_empty() => Err(HarnessError::Invalid("the pose track has no poses".into())),
        PoseInput::Track(t) => Ok(t),
        PoseInput::LoggedTruth if source.truth().is_empty() => {
            Err(HarnessError::Invalid(format!("{name}: --true-poses given but the log has no truth records")))
        }
        PoseInput::LoggedTruth => Ok(source.truth().to_vec()),
        PoseInput::Localise { .. } => Err(HarnessError::Invalid("the localiser is not a pose track".into())),
        PoseInput::AlignedOdometry => {
            let Some(first) = source.odometry().first() else {
                return Err(HarnessError::Invalid(format!(
                    "{name}: no odometry records; give --poses or --true-poses"
                )));
            };
            let anchor = source.truth().first().map_or(Pose2::IDENTITY, |t| t.pose);
            let align = anchor.compose(&first.pose.inverse());
            Ok(source
                .odometry()
                .iter()
                .map(|o| StampedPose { stamp_ns: o.stamp_ns, pose: align.compose(&o.pose) })
                .collect())
        }
    }
}

/// Runs the updater over `source` (replayed with interpolated odometry) on `map`; the time
/// per step is read from `clock`; `observers` see every step (an MCAP recorder, say).
pub fn update_log(
    mut source: LogSource,
    map: OccupancyGrid,
    params: UpdaterParams,
    poses: PoseInput,
    clock: &dyn Clock,
    observers: &mut [&mut dyn Observer],
) -> Result<UpdateRun, HarnessError> {
    if source.is_empty() {
        return Err(HarnessError::Invalid(format!("{}: the log has no scan records", source.name())));
    }
    let mut lost = None;
    let pose_source = match poses {
        PoseInput::Localise { params: filter_params, seed, init } => {
            let filter_params = *filter_params;
            let mut filter = Localiser::new(&map, filter_params, super::chain_seed(seed))?;
            let first_truth = source.first_stamp_ns().and_then(|t| mapkeeper_sensor::interpolate(source.truth(), t));
            if let Some(p) = init.or(first_truth) {
                filter.init_pose(p, filter_params.initial_covariance())?;
            }
            lost = Some(LostPolicy::new(true, DEFAULT_LOST_WAIT_S, filter_params.initial_covariance()));
            PoseSource::Localiser(Box::new(filter))
        }
        other => PoseSource::Track(pose_track(&source, other)?),
    };
    let updater = MapUpdater::new(map, params)?;
    let mut session = Session::new(pose_source, Some(updater), None, clock);
    session.set_deskew(source.options().deskew);
    let mut rows = Rows {
        csv: "time_s,outcome,verdict,n,n_invalid,n_dc,cells_changed,recovery,microseconds\n".into(),
        recovered: Vec::new(),
        recoveries: RECOVERIES_CSV_HEADER.into(),
        poses: Vec::new(),
    };
    let mut controls: Vec<&mut dyn Control> = Vec::new();
    if let Some(l) = lost.as_mut() {
        controls.push(l);
    }
    let mut all: Vec<&mut dyn Observer> = vec![&mut rows];
    all.extend(observers.iter_mut().map(|o| &mut **o as &mut dyn Observer));
    crate::run(&mut source, &mut session, &mut controls, &mut all)?;
    drop((controls, all));
    let (lost, lost_episodes) = lost.map(LostPolicy::finish).unwrap_or_default();
    let out = session.finish()?;
    let Some(u) = out.updater else { return Err(HarnessError::Invalid("the session lost its updater".into())) };
    Ok(UpdateRun {
        stats: u.stats(),
        map: u.map().clone(),
        steps_csv: rows.csv,
        recovered_poses: rows.recovered,
        recoveries_csv: rows.recoveries,
        poses: rows.poses,
        lost,
        lost_episodes,
    })
}
