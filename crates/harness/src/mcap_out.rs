//! A run recorded as a ROS 2 MCAP bag (`--mcap FILE`): the scans, odometry, `/tf`, the true and
//! estimated poses, the particle cloud, the map being updated and, per step, the updater's verdict
//! and check state (`/updater/step`) and, with each map, the cells changed since the previous one
//! (`/updater/changes`), so the run can be watched in Foxglove or replayed with `ros2 bag`
//! (`docs/real-data.md`).

use crate::HarnessError;
use crate::driver::Observer;
use crate::session::{Session, SessionStep};
use crate::source::Step;
use mapkeeper_grid::{CellState, ChangeKind, OccupancyGrid};
use mapkeeper_logs::{
    CHANGE_ADDED, CHANGE_NONE, CHANGE_OTHER, CHANGE_REMOVED, McapRunWriter, McapWriteError, UpdaterStepMsg,
};
use mapkeeper_updater::{PoseRecovery, StepOutcome, StepReport as UpdaterStep};
use std::path::{Path, PathBuf};

/// How often the map is written while it changes, nanoseconds (1 s: a map message is the
/// whole grid).
pub const MAP_PERIOD_NS: u64 = 1_000_000_000;

/// An [`Observer`] that writes every step of the run it sees to an MCAP file: what the step
/// produced, before any control reacts to it. It cannot change the run (observers see the
/// session read-only); a write error stops the recording and is returned by
/// [`McapRecorder::finish`].
pub struct McapRecorder {
    writer: Option<McapRunWriter>,
    path: PathBuf,
    last_map_ns: Option<u64>,
    /// The map as last written on `/map` (the changes layer is the difference to it).
    last_map: Option<OccupancyGrid>,
    map_dirty: bool,
    last_stamp_ns: u64,
    error: Option<McapWriteError>,
}

impl std::fmt::Debug for McapRecorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapRecorder").field("path", &self.path).finish()
    }
}

impl McapRecorder {
    /// Starts the file at `path` (written beside it and renamed by [`McapRecorder::finish`]).
    pub fn create(path: &Path) -> Result<Self, HarnessError> {
        let writer = McapRunWriter::create(path).map_err(|e| HarnessError::Invalid(e.to_string()))?;
        Ok(Self {
            writer: Some(writer),
            path: path.to_path_buf(),
            last_map_ns: None,
            last_map: None,
            map_dirty: true,
            last_stamp_ns: 0,
            error: None,
        })
    }

    fn record(&mut self, step: &Step, report: &SessionStep, session: &Session<'_>) -> Result<(), McapWriteError> {
        let Some(w) = self.writer.as_mut() else { return Ok(()) };
        let t = step.frame.stamp_ns;
        self.last_stamp_ns = t;
        if let Some(odom) = step.frame.odometry {
            w.odometry(t, odom)?;
        }
        for s in &step.frame.scans {
            w.scan(s)?;
        }
        if let Some(truth) = &step.truth {
            w.true_pose(t, truth.pose_in_map)?;
        }
        if let Some(pose) = report.pose_in_map {
            let cov = report.localiser.as_ref().map(|l| l.estimate.covariance);
            w.estimate(t, pose, cov, step.frame.odometry)?;
        }
        if let (Some(_), Some(p)) = (&report.localiser, session.particles()) {
            w.particles(t, p)?;
        }
        if let Some(u) = &report.updater {
            if let Some(v) = u.verdict {
                w.verdict(t, v.name())?;
            }
            w.updater_step(t, &step_message(u))?;
            self.map_dirty |= !u.changed_cells.is_empty();
        }
        let due = self.last_map_ns.is_none_or(|last| t >= last + MAP_PERIOD_NS);
        if let (true, Some(map)) = (self.map_dirty && due, session.map()) {
            self.write_map(t, map)?;
            self.last_map_ns = Some(t);
            self.map_dirty = false;
        }
        Ok(())
    }

    /// `/map`, and `/updater/changes` against the map written before (when a cell changed).
    fn write_map(&mut self, t: u64, map: &OccupancyGrid) -> Result<(), McapWriteError> {
        let Some(w) = self.writer.as_mut() else { return Ok(()) };
        w.map(t, map)?;
        if let Some(before) = self.last_map.as_ref().filter(|b| b.geometry().same_as(map.geometry())) {
            let values: Vec<i8> = before.cells().iter().zip(map.cells()).map(|(&a, &b)| change_value(a, b)).collect();
            if values.iter().any(|&v| v != CHANGE_NONE) {
                w.changes(t, map.geometry(), &values)?;
            }
        }
        match &mut self.last_map {
            Some(m) if m.geometry().same_as(map.geometry()) => m.clone_from(map),
            last => *last = Some(map.clone()),
        }
        Ok(())
    }

    /// Writes `final_map` (the updated map at the end, if it changed since it was last written)
    /// and renames the file into place; returns its path.
    pub fn finish(mut self, final_map: Option<&mapkeeper_grid::OccupancyGrid>) -> Result<PathBuf, HarnessError> {
        let err = |e: McapWriteError| HarnessError::Invalid(e.to_string());
        if let Some(e) = self.error.take() {
            return Err(err(e));
        }
        let Some(mut w) = self.writer.take() else { return Ok(self.path) };
        if let (true, Some(map)) = (self.map_dirty, final_map) {
            self.writer = Some(w);
            self.write_map(self.last_stamp_ns, map).map_err(err)?;
            let Some(taken) = self.writer.take() else { return Ok(self.path) };
            w = taken;
        }
        w.finish().map_err(err)
    }
}

/// The value of a cell of `/updater/changes` that was `a` and is `b`.
pub fn change_value(a: CellState, b: CellState) -> i8 {
    match ChangeKind::of(a, b) {
        ChangeKind::Same => CHANGE_NONE,
        ChangeKind::Added => CHANGE_ADDED,
        ChangeKind::Removed => CHANGE_REMOVED,
        ChangeKind::Other => CHANGE_OTHER,
    }
}

/// `/updater/step` of an updater report.
pub fn step_message(u: &UpdaterStep) -> UpdaterStepMsg {
    let count = |kind: ChangeKind| {
        u32::try_from(u.changed_cells.iter().filter(|c| ChangeKind::of(c.from, c.to) == kind).count())
            .unwrap_or(u32::MAX)
    };
    let outcome = match u.outcome {
        StepOutcome::Processed => "processed",
        StepOutcome::Gated(_) => "gated",
        StepOutcome::NoValidBeams => "no_valid_beams",
        StepOutcome::TooFewBeams => "too_few_beams",
        StepOutcome::Unregistered => "unregistered",
    };
    let pose_recovery = match &u.pose_recovery {
        None => String::new(),
        Some(PoseRecovery::Recovered { .. }) if u.global_search.as_ref().is_some_and(|g| g.chosen) => {
            "recovered_global".into()
        }
        Some(PoseRecovery::Recovered { .. }) => "recovered".into(),
        Some(PoseRecovery::NotRecovered { reason }) => crate::jobs::update::refusal_reason(reason),
    };
    UpdaterStepMsg {
        verdict: u.verdict.map(|v| v.name().to_string()).unwrap_or_default(),
        check_verdict: u.check_verdict.map(|v| v.name().to_string()).unwrap_or_default(),
        outcome: outcome.into(),
        valid_beams: u32::try_from(u.n_valid).unwrap_or(u32::MAX),
        detected_change_beams: u32::try_from(u.n_dc).unwrap_or(u32::MAX),
        cells_added: count(ChangeKind::Added),
        cells_removed: count(ChangeKind::Removed),
        cells_other: count(ChangeKind::Other),
        registration: u.registration.as_ref().map(|r| (r.accepted(), r.shift_m, r.turn_rad)),
        pose_recovery,
    }
}

impl Observer for McapRecorder {
    fn on_step(&mut self, step: &Step, report: &SessionStep, session: &Session<'_>) {
        if self.error.is_none()
            && let Err(e) = self.record(step, report, session)
        {
            self.error = Some(e);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use CellState::{Free as F, Occupied as O, Unknown as U};
    use mapkeeper_grid::CellCoord;
    use mapkeeper_updater::{CellChange, Verdict};

    #[test]
    fn change_values_of_every_pair() {
        let want = [
            ((F, F), CHANGE_NONE),
            ((O, O), CHANGE_NONE),
            ((U, U), CHANGE_NONE),
            ((F, O), CHANGE_ADDED),
            ((U, O), CHANGE_ADDED),
            ((O, F), CHANGE_REMOVED),
            ((O, U), CHANGE_REMOVED),
            ((F, U), CHANGE_OTHER),
            ((U, F), CHANGE_OTHER),
        ];
        for ((a, b), v) in want {
            assert_eq!(change_value(a, b), v, "{a:?} → {b:?}");
        }
    }

    #[test]
    fn a_step_message_counts_the_changes_and_says_both_verdicts() {
        let change = |x, from, to| CellChange { cell: CellCoord::new(x, 0), from, to };
        let u = UpdaterStep {
            outcome: StepOutcome::Processed,
            verdict: Some(Verdict::Update),
            check_verdict: Some(Verdict::Lost),
            n_valid: 500,
            n_invalid: 0,
            invalid_scans: 0,
            occluded_scans: 0,
            n_dc: 250,
            changed_cells: vec![change(0, F, O), change(1, U, O), change(2, O, F), change(3, U, F)],
            pose_recovery: None,
            registration: None,
            global_search: None,
            shift_check: None,
        };
        let m = step_message(&u);
        assert_eq!((m.verdict.as_str(), m.check_verdict.as_str(), m.outcome.as_str()), ("update", "lost", "processed"));
        assert_eq!((m.valid_beams, m.detected_change_beams), (500, 250));
        assert_eq!((m.cells_added, m.cells_removed, m.cells_other), (2, 1, 1));
        assert_eq!((m.registration, m.pose_recovery.as_str()), (None, ""));
    }
}
