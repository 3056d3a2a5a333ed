//! A run recorded as a ROS 2 MCAP bag (`--mcap FILE`): the scans, odometry, `/tf`, the true and
//! estimated poses, the particle cloud, the map being updated and the updater's verdict per
//! scan, so the run can be watched in Foxglove or replayed with `ros2 bag` (`docs/real-data.md`).

use crate::HarnessError;
use crate::driver::Control;
use crate::session::{Session, StepReport};
use crate::source::{RobotControl, Step};
use mapkeeper_logs::{McapRunWriter, McapWriteError};
use std::path::{Path, PathBuf};

/// How often the map is written while it changes, nanoseconds (1 s: a map message is the
/// whole grid).
pub const MAP_PERIOD_NS: u64 = 1_000_000_000;

/// A [`Control`] that writes every step of the run it sees to an MCAP file.
pub struct McapRecorder {
    writer: Option<McapRunWriter>,
    path: PathBuf,
    last_map_ns: Option<u64>,
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
            map_dirty: true,
            last_stamp_ns: 0,
            error: None,
        })
    }

    fn record(&mut self, step: &Step, report: &StepReport, session: &Session<'_>) -> Result<(), McapWriteError> {
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
            self.map_dirty |= !u.changed_cells.is_empty();
        }
        let due = self.last_map_ns.is_none_or(|last| t >= last + MAP_PERIOD_NS);
        if let (true, Some(map)) = (self.map_dirty && due, session.map()) {
            w.map(t, map)?;
            self.last_map_ns = Some(t);
            self.map_dirty = false;
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
            w.map(self.last_stamp_ns, map).map_err(err)?;
        }
        w.finish().map_err(err)
    }
}

impl Control for McapRecorder {
    fn after_step(
        &mut self,
        step: &Step,
        report: &StepReport,
        session: &mut Session<'_>,
        _robot: Option<&mut dyn RobotControl>,
    ) -> Result<(), HarnessError> {
        if self.error.is_some() {
            return Ok(());
        }
        if let Err(e) = self.record(step, report, session) {
            let message = e.to_string();
            self.error = Some(e);
            return Err(HarnessError::Invalid(message));
        }
        Ok(())
    }
}
