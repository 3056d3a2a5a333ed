//! The chain localiser run one frame ahead, on a thread of its own, while the updater works on
//! the current frame ([`Session::set_localise_ahead`](crate::Session::set_localise_ahead)).
//!
//! Within a run the localiser and the updater depend on each other only at a few points: the
//! updater is given the localiser's pose, and a control may re-initialise the localiser (pose
//! updating handing a pose back, an experiment) or act on the robot (a stop after a Lost
//! verdict), which changes the frames to come. So while the updater processes frame k, the
//! localiser may already process frame k+1, from its state after k, which is saved first. When
//! frame k+1 comes, the speculative update is used only if nothing acted on the localiser in
//! between and the frame is bit for bit the one it processed; otherwise the filter goes back to
//! the saved state and processes the frame again. The filter's updates are therefore those of
//! the run in one thread, bit for bit (tests: `a_restored_state_replays_the_same_updates` in the
//! localiser, the scenario's `determinism.rs` and `lost_handling.rs`).
//!
//! Only frames on which the filter will run a sensor update are sent ahead
//! ([`Localiser::would_update`]): the others cost microseconds inline.

use crate::source::SensorFrame;
use mapkeeper_grid::Pose2;
use mapkeeper_localiser::{FilterState, Localiser, UpdateReport};
use mapkeeper_sensor::{LaserScan, SweepTiming};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;

/// One update to run ahead: the filter (moved to the worker and back), the odometry and the
/// frame as the filter sees it (deskewed where the session deskews).
struct Job {
    localiser: Box<Localiser>,
    odometry: Pose2,
    input: SensorFrame,
}

/// How the updates sent ahead ended.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AheadCounts {
    /// Updates run ahead.
    pub sent: u64,
    /// Of those, used as they were.
    pub used: u64,
    /// Of those, thrown away (the frame changed or a control acted on the filter) and the
    /// filter taken back to its saved state.
    pub discarded: u64,
}

/// The worker and the update it is running, if any.
pub(crate) struct LocaliserAhead {
    /// The worker's queue (`None` once closed, which ends the worker).
    jobs: Option<Sender<Job>>,
    /// The worker's answers: the filter, its report and the frame it processed (handed back
    /// to be compared with the frame that comes).
    done: Receiver<(Box<Localiser>, UpdateReport, SensorFrame)>,
    worker: Option<JoinHandle<()>>,
    /// Whether an update runs ahead (the filter is on the worker meanwhile).
    pending: bool,
    /// The filter's state before the update running ahead.
    saved: Option<FilterState>,
    counts: AheadCounts,
}

impl std::fmt::Debug for LocaliserAhead {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LocaliserAhead").field("pending", &self.pending).field("counts", &self.counts).finish()
    }
}

impl LocaliserAhead {
    /// Starts the worker thread.
    pub(crate) fn start() -> Self {
        let (jobs, rx) = channel::<Job>();
        let (tx, done) = channel();
        let worker = std::thread::spawn(move || {
            for mut job in rx {
                let report = job.localiser.update(job.odometry, &job.input.scans);
                if tx.send((job.localiser, report, job.input)).is_err() {
                    return;
                }
            }
        });
        Self {
            jobs: Some(jobs),
            done,
            worker: Some(worker),
            pending: false,
            saved: None,
            counts: AheadCounts::default(),
        }
    }

    /// Whether an update is running ahead (the filter is on the worker).
    pub(crate) fn is_pending(&self) -> bool {
        self.pending
    }

    /// What happened to the updates sent ahead so far.
    pub(crate) fn counts(&self) -> AheadCounts {
        self.counts
    }

    /// While an update runs ahead, the particles of the filter as it was before it (what the
    /// filter holds at this point of a run in one thread).
    pub(crate) fn saved_particles(&self) -> Option<&[Pose2]> {
        self.saved.as_ref().filter(|_| self.pending).map(FilterState::particles)
    }

    /// Saves `localiser`'s state and sends it to update with `odometry` and `input` on the
    /// worker (at most one update runs ahead: the caller takes it back first).
    pub(crate) fn send(&mut self, localiser: Box<Localiser>, odometry: Pose2, input: SensorFrame) {
        match &mut self.saved {
            Some(s) => localiser.save_state(s),
            None => self.saved = Some(localiser.state()),
        }
        self.pending = true;
        self.counts.sent += 1;
        let sent = self.jobs.as_ref().is_some_and(|q| q.send(Job { localiser, odometry, input }).is_ok());
        if !sent {
            self.worker_died();
        }
    }

    /// Waits for the update running ahead, if any, and hands the filter back: with that
    /// update's report, in the state after it, if `input` is bit for bit the frame it
    /// processed; otherwise (another frame, or `None`: a control acts on the filter) taken
    /// back to the state before it, without a report.
    pub(crate) fn take(&mut self, input: Option<&SensorFrame>) -> Option<(Box<Localiser>, Option<UpdateReport>)> {
        if !std::mem::take(&mut self.pending) {
            return None;
        }
        let (mut localiser, report, processed) = match self.done.recv() {
            Ok(r) => r,
            Err(_) => self.worker_died(),
        };
        if input.is_some_and(|f| same_frame(&processed, f)) {
            self.counts.used += 1;
            return Some((localiser, Some(report)));
        }
        if let Some(s) = &self.saved {
            localiser.restore_state(s);
        }
        self.counts.discarded += 1;
        Some((localiser, None))
    }

    /// The worker can only stop early by panicking in the filter's update: the same panic a
    /// run in one thread would have raised, raised here.
    fn worker_died(&mut self) -> ! {
        let payload: Box<dyn std::any::Any + Send> = match self.worker.take().map(JoinHandle::join) {
            Some(Err(p)) => p,
            _ => Box::new("the chain localiser's thread ended with the filter"),
        };
        std::panic::resume_unwind(payload)
    }
}

impl Drop for LocaliserAhead {
    /// Ends the worker (its queue closes) and waits for it.
    fn drop(&mut self) {
        drop(self.jobs.take());
        if let Some(w) = self.worker.take() {
            drop(w.join());
        }
    }
}

/// Whether two frames are the same bit for bit (floats compared by their bits, so that a NaN
/// range equals itself).
fn same_frame(a: &SensorFrame, b: &SensorFrame) -> bool {
    let SensorFrame { stamp_ns, odometry, scans } = a;
    let same_pose = |p: &Pose2, q: &Pose2| [p.x, p.y, p.yaw].map(f64::to_bits) == [q.x, q.y, q.yaw].map(f64::to_bits);
    *stamp_ns == b.stamp_ns
        && match (odometry, &b.odometry) {
            (Some(p), Some(q)) => same_pose(p, q),
            (None, None) => true,
            _ => false,
        }
        && scans.len() == b.scans.len()
        && scans.iter().zip(&b.scans).all(|(s, t)| same_scan(s, t, same_pose))
}

fn same_scan(a: &LaserScan, b: &LaserScan, same_pose: impl Fn(&Pose2, &Pose2) -> bool) -> bool {
    // Every field named, so that a new one cannot be forgotten here.
    let LaserScan {
        stamp_ns,
        lidar_id,
        lidar_in_robot,
        angle_min_rad,
        angle_increment_rad,
        range_min_m,
        range_max_m,
        ranges_m,
        sweep,
    } = a;
    *stamp_ns == b.stamp_ns
        && *lidar_id == b.lidar_id
        && same_pose(lidar_in_robot, &b.lidar_in_robot)
        && angle_min_rad.to_bits() == b.angle_min_rad.to_bits()
        && angle_increment_rad.to_bits() == b.angle_increment_rad.to_bits()
        && range_min_m.to_bits() == b.range_min_m.to_bits()
        && range_max_m.to_bits() == b.range_max_m.to_bits()
        && ranges_m.len() == b.ranges_m.len()
        && ranges_m.iter().zip(&b.ranges_m).all(|(x, y)| x.to_bits() == y.to_bits())
        && match (sweep, &b.sweep) {
            (Some(s), Some(t)) => {
                let SweepTiming { first_beam_s, time_increment_s } = s;
                first_beam_s.to_bits() == t.first_beam_s.to_bits()
                    && time_increment_s.to_bits() == t.time_increment_s.to_bits()
            }
            (None, None) => true,
            _ => false,
        }
}
