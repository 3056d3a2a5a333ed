//! The loop: take a step from the source, let the controls act on the session or the robot,
//! give the frame to the session, show the step and the report to the observers.

use crate::HarnessError;
use crate::session::{Session, SessionStep};
use crate::source::{RobotControl, SensorSource, Step};

/// Something that watches a run: statistics, timelines, recorders. It sees the truth and the
/// session (read-only: the maps, the particles), and it cannot act on the run, by type.
pub trait Observer {
    /// Called once per step, after the session processed it and before the controls react.
    fn on_step(&mut self, step: &Step, report: &SessionStep, session: &Session<'_>);
}

/// What an experiment does to a run: bias the estimate, stop or move the robot, recover.
/// A control sees the truth (an experiment may displace the estimate from it); the session's
/// estimators still never do.
pub trait Control {
    /// Before the session processes `step`.
    fn before_step(
        &mut self,
        _step: &Step,
        _session: &mut Session<'_>,
        _robot: Option<&mut dyn RobotControl>,
    ) -> Result<(), HarnessError> {
        Ok(())
    }

    /// After the session processed `step` (and after the observers saw it).
    fn after_step(
        &mut self,
        _step: &Step,
        _report: &SessionStep,
        _session: &mut Session<'_>,
        _robot: Option<&mut dyn RobotControl>,
    ) -> Result<(), HarnessError> {
        Ok(())
    }
}

/// Runs one step; `Ok(false)` at the end of the source.
pub fn step_once(
    source: &mut dyn SensorSource,
    session: &mut Session<'_>,
    controls: &mut [&mut dyn Control],
    observers: &mut [&mut dyn Observer],
) -> Result<bool, HarnessError> {
    let Some(step) = source.next_step()? else { return Ok(false) };
    for c in controls.iter_mut() {
        c.before_step(&step, session, source.control())?;
    }
    let report = session.process(&step.frame);
    for o in observers.iter_mut() {
        o.on_step(&step, &report, session);
    }
    for c in controls.iter_mut() {
        c.after_step(&step, &report, session, source.control())?;
    }
    Ok(true)
}

/// Runs the source to its end; returns the number of steps.
pub fn run(
    source: &mut dyn SensorSource,
    session: &mut Session<'_>,
    controls: &mut [&mut dyn Control],
    observers: &mut [&mut dyn Observer],
) -> Result<u64, HarnessError> {
    let mut steps = 0;
    while step_once(source, session, controls, observers)? {
        steps += 1;
    }
    Ok(steps)
}
