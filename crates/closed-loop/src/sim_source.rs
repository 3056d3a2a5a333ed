//! The simulator as a [`SensorSource`]: it advances physics ticks until a lidar fires and hands
//! out that tick's scans and odometry, with the true pose (and the distance driven) apart. It
//! is also the [`RobotControl`] of the experiments: stop at once (with a timed resume), resume, move.

use mapkeeper_grid::Pose2;
use mapkeeper_harness::{RobotControl, SensorFrame, SensorSource, SourceError, Step, Truth};
use mapkeeper_sim::Simulator;

/// A simulator driving its route, tick by tick, until the route is done or the time is up.
#[derive(Clone)]
pub struct SimSource {
    sim: Simulator,
    max_ticks: u64,
    collisions: u64,
    distance_m: f64,
    prev_truth: Pose2,
    route_done: bool,
    /// The handed-out step's tick still has its end-of-tick work to do; with its route_done.
    pending: Option<bool>,
    /// Tick at which [`RobotControl::stop`] stopped the robot, and after how many ticks the
    /// source resumes it by itself.
    stopped: Option<(u64, Option<u64>)>,
}

impl std::fmt::Debug for SimSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimSource").field("tick", &self.sim.tick()).field("max_ticks", &self.max_ticks).finish()
    }
}

impl SimSource {
    /// A source over `sim` (its route already set) that ends after `max_sim_time_s`.
    pub fn new(sim: Simulator, max_sim_time_s: f64) -> Self {
        let max_ticks = (max_sim_time_s * 1e9 / sim.params().tick_ns as f64).ceil() as u64;
        let prev_truth = sim.true_pose();
        Self {
            sim,
            max_ticks,
            collisions: 0,
            distance_m: 0.0,
            prev_truth,
            route_done: false,
            pending: None,
            stopped: None,
        }
    }

    /// The simulator.
    pub fn sim(&self) -> &Simulator {
        &self.sim
    }

    /// Contacts of the robot that began so far.
    pub fn collisions(&self) -> u64 {
        self.collisions
    }

    /// Distance the robot travelled (true), metres.
    pub fn distance_m(&self) -> f64 {
        self.distance_m
    }

    /// Whether the route was completed.
    pub fn route_done(&self) -> bool {
        self.route_done
    }

    /// Simulated time so far, seconds.
    pub fn sim_time_s(&self) -> f64 {
        self.sim.stamp_ns() as f64 / 1e9
    }

    /// The end of a tick: a timed resume falls due.
    fn end_of_tick(&mut self) {
        if let Some((since, Some(wait))) = self.stopped
            && self.sim.tick() - since >= wait
        {
            self.sim.resume();
            self.stopped = None;
        }
    }
}

impl SensorSource for SimSource {
    fn next_step(&mut self) -> Result<Option<Step>, SourceError> {
        if let Some(route_done) = self.pending.take() {
            self.end_of_tick();
            if route_done {
                self.route_done = true;
                return Ok(None);
            }
        }
        while self.sim.tick() < self.max_ticks {
            let out = self.sim.step();
            self.collisions += out.collisions.iter().filter(|c| c.started).count() as u64;
            let truth = out.truth.pose_in_map;
            self.distance_m += self.prev_truth.distance(&truth);
            self.prev_truth = truth;
            if !out.scans.is_empty() {
                self.pending = Some(out.route_done);
                let frame =
                    SensorFrame { stamp_ns: out.stamp_ns, odometry: Some(out.odometry.pose_in_odom), scans: out.scans };
                return Ok(Some(Step {
                    frame,
                    truth: Some(Truth { pose_in_map: truth, distance_m: self.distance_m }),
                }));
            }
            self.end_of_tick();
            if out.route_done {
                self.route_done = true;
                return Ok(None);
            }
        }
        Ok(None)
    }

    fn control(&mut self) -> Option<&mut dyn RobotControl> {
        Some(self)
    }
}

impl RobotControl for SimSource {
    /// Halts the robot where it is ([`Simulator::halt`]: it stands still from the next tick on,
    /// rather than braking over up to 2 m), as the paper stops it while pose updating runs.
    fn stop(&mut self, resume_after_s: Option<f64>) {
        if self.stopped.is_none() {
            self.sim.halt();
            let tick_ns = self.sim.params().tick_ns as f64;
            self.stopped = Some((self.sim.tick(), resume_after_s.map(|s| (s * 1e9 / tick_ns).ceil() as u64)));
        }
    }

    fn resume(&mut self) {
        if self.stopped.take().is_some() {
            self.sim.resume();
        }
    }

    fn is_stopped(&self) -> bool {
        self.stopped.is_some()
    }

    fn move_robot(&mut self, pose_in_map: Pose2) {
        self.sim.teleport_robot(pose_in_map);
        self.prev_truth = self.sim.true_pose();
    }
}

/// What an experiment did to the robot at one step, replayed on the simulator's thread.
#[derive(Clone, Copy, Debug)]
enum RobotOp {
    Stop(Option<f64>),
    Resume,
    Move(Pose2),
}

/// From the simulator's thread: a step of the current epoch, or the end of the source.
enum Ahead {
    Step { epoch: u64, index: u64, step: Step, stopped: bool },
    End { epoch: u64, error: Option<SourceError> },
}

/// To the simulator's thread: go back to just after step `index`, apply `ops`, go on from there
/// as epoch `epoch` (or, with `finish`, stop there and hand the simulator back).
struct Rewind {
    index: u64,
    epoch: u64,
    ops: Vec<RobotOp>,
    finish: bool,
}

/// Steps the simulator may run ahead of the estimators.
const AHEAD_STEPS: usize = 6;

/// A [`SimSource`] run on a thread of its own, ahead of the estimators: the simulation of a
/// world does not depend on the estimates unless an experiment stops, resumes or moves the
/// robot, so the simulator produces the next steps while the caller's estimators work on this
/// one. It keeps a copy of itself after each step not yet confirmed; when a control acts on the
/// robot at step k, the steps it ran past k are thrown away, the copy after k is restored, the
/// actions are applied to it, and it runs on from there. The steps handed out are therefore bit
/// for bit those of the [`SimSource`] run inline (test `ahead_source_matches_the_inline_source`).
pub struct AheadSource {
    rx: Option<std::sync::mpsc::Receiver<Ahead>>,
    rewind: Option<std::sync::mpsc::Sender<Rewind>>,
    worker: Option<std::thread::JoinHandle<SimSource>>,
    epoch: u64,
    index: u64,
    /// Whether the robot is stopped at the current step, after `ops`.
    stopped: bool,
    /// What controls did to the robot at the current step.
    ops: Vec<RobotOp>,
    /// Times the simulator went back to a copy (a control acted on the robot).
    rewinds: u64,
    /// The source ended (in the current epoch).
    ended: bool,
}

impl std::fmt::Debug for AheadSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AheadSource").field("index", &self.index).field("rewinds", &self.rewinds).finish()
    }
}

impl AheadSource {
    /// Starts `source` on a thread of its own.
    pub fn start(source: SimSource) -> Self {
        let (tx, rx) = std::sync::mpsc::sync_channel(AHEAD_STEPS);
        let (rewind_tx, rewind_rx) = std::sync::mpsc::channel();
        let worker = std::thread::spawn(move || ahead_worker(source, &tx, &rewind_rx));
        Self {
            rx: Some(rx),
            rewind: Some(rewind_tx),
            worker: Some(worker),
            epoch: 0,
            index: 0,
            stopped: false,
            ops: Vec::new(),
            rewinds: 0,
            ended: false,
        }
    }

    /// Times a control's action sent the simulator back to a copy.
    pub fn rewinds(&self) -> u64 {
        self.rewinds
    }

    /// Ends the run: the simulator as it stands after the last step handed out (and the
    /// actions on the robot at that step), for its counters.
    pub fn finish(mut self) -> Result<SimSource, SourceError> {
        if !self.ended {
            // Stopped before the end: back to the last step handed out (the simulator ran past it).
            self.send(true);
        }
        drop(self.rewind.take());
        // Unblock a worker waiting to hand out a step nobody will take; it ends after the rewind.
        if let Some(rx) = self.rx.take() {
            while rx.recv().is_ok() {}
        }
        let worker = self.worker.take().ok_or_else(|| lost("finished twice"))?;
        worker.join().map_err(|_| lost("the simulator's thread panicked"))
    }

    /// Sends the actions of the current step (or, with `finish`, the end of the run).
    fn send(&mut self, finish: bool) {
        if self.ops.is_empty() && !finish {
            return;
        }
        self.epoch += 1;
        self.ended = false;
        self.rewinds += u64::from(!self.ops.is_empty());
        let msg = Rewind { index: self.index, epoch: self.epoch, ops: std::mem::take(&mut self.ops), finish };
        if let Some(tx) = &self.rewind {
            // A dead worker shows up as a closed step channel at the next receive.
            drop(tx.send(msg));
        }
    }
}

fn lost(what: &str) -> SourceError {
    SourceError { source_name: "simulator".into(), message: what.into() }
}

impl Drop for AheadSource {
    /// Stops the simulator's thread (a closed channel ends it at its next send or receive).
    fn drop(&mut self) {
        drop(self.rx.take());
        drop(self.rewind.take());
        if let Some(w) = self.worker.take() {
            drop(w.join());
        }
    }
}

/// The simulator's thread: produce steps, keep a copy after each, go back to a copy when told.
fn ahead_worker(
    mut source: SimSource,
    tx: &std::sync::mpsc::SyncSender<Ahead>,
    rewind: &std::sync::mpsc::Receiver<Rewind>,
) -> SimSource {
    // Copies after steps index - copies.len() + 1 ..= index; the caller is at most
    // AHEAD_STEPS + 1 steps behind (the channel's steps and the one in hand); the
    // AHEAD_STEPS + 4 copies kept (spares) reach every rewind.
    let mut copies: std::collections::VecDeque<SimSource> = std::collections::VecDeque::new();
    let (mut epoch, mut index) = (0u64, 0u64);
    let mut ended = false;
    loop {
        let cmd = if ended {
            match rewind.recv() {
                Ok(c) => Some(c),
                Err(_) => return source,
            }
        } else {
            match rewind.try_recv() {
                Ok(c) => Some(c),
                Err(std::sync::mpsc::TryRecvError::Empty) => None,
                Err(std::sync::mpsc::TryRecvError::Disconnected) => return source,
            }
        };
        if let Some(c) = cmd {
            let back = (index - c.index) as usize;
            // The copy after step c.index; a rewind never reaches further back than kept.
            let Some(at) = copies.len().checked_sub(back + 1).and_then(|i| copies.get(i)) else { return source };
            source = at.clone();
            copies.clear();
            for op in &c.ops {
                match *op {
                    RobotOp::Stop(after) => source.stop(after),
                    RobotOp::Resume => source.resume(),
                    RobotOp::Move(p) => source.move_robot(p),
                }
            }
            if c.finish {
                return source;
            }
            copies.push_back(source.clone());
            (epoch, index, ended) = (c.epoch, c.index, false);
            continue;
        }
        match source.next_step() {
            Ok(Some(step)) => {
                index += 1;
                if copies.len() > AHEAD_STEPS + 3 {
                    copies.pop_front();
                }
                copies.push_back(source.clone());
                let stopped = source.is_stopped();
                if tx.send(Ahead::Step { epoch, index, step, stopped }).is_err() {
                    return source;
                }
            }
            Ok(None) => {
                ended = true;
                if tx.send(Ahead::End { epoch, error: None }).is_err() {
                    return source;
                }
            }
            Err(e) => {
                ended = true;
                if tx.send(Ahead::End { epoch, error: Some(e) }).is_err() {
                    return source;
                }
            }
        }
    }
}

impl AheadSource {
    /// The next message of the current epoch (after sending the actions of the current step).
    fn receive(&mut self) -> Result<Ahead, SourceError> {
        self.send(false);
        let rx = self.rx.as_ref().ok_or_else(|| lost("the source was finished"))?;
        loop {
            match rx.recv() {
                Ok(m @ (Ahead::Step { epoch, .. } | Ahead::End { epoch, .. })) if epoch == self.epoch => return Ok(m),
                // A step the simulator ran past a control's action: thrown away.
                Ok(_) => {}
                Err(_) => return Err(lost("the simulator's thread ended early")),
            }
        }
    }
}

impl SensorSource for AheadSource {
    fn next_step(&mut self) -> Result<Option<Step>, SourceError> {
        if self.ended && self.ops.is_empty() {
            return Ok(None);
        }
        match self.receive()? {
            Ahead::Step { index, step, stopped, .. } => {
                self.index = index;
                self.stopped = stopped;
                Ok(Some(step))
            }
            Ahead::End { error, .. } => {
                self.ended = true;
                error.map_or(Ok(None), Err)
            }
        }
    }

    fn control(&mut self) -> Option<&mut dyn RobotControl> {
        Some(self)
    }
}

impl RobotControl for AheadSource {
    fn stop(&mut self, resume_after_s: Option<f64>) {
        if !self.stopped {
            self.ops.push(RobotOp::Stop(resume_after_s));
            self.stopped = true;
        }
    }

    fn resume(&mut self) {
        if self.stopped {
            self.ops.push(RobotOp::Resume);
            self.stopped = false;
        }
    }

    fn is_stopped(&self) -> bool {
        self.stopped
    }

    fn move_robot(&mut self, pose_in_map: Pose2) {
        self.ops.push(RobotOp::Move(pose_in_map));
    }
}

/// A simulated source run inline ([`SimSource`]) or ahead of the estimators on a thread of its
/// own ([`AheadSource`]): the same steps either way.
#[derive(Debug)]
pub enum Simulated {
    /// On the caller's thread.
    Inline(Box<SimSource>),
    /// On a thread of its own, ahead of the caller.
    Ahead(AheadSource),
}

impl Simulated {
    /// `source`, started ahead on a thread of its own if `ahead`.
    pub fn new(source: SimSource, ahead: bool) -> Self {
        if ahead { Self::Ahead(AheadSource::start(source)) } else { Self::Inline(Box::new(source)) }
    }

    /// Ends the run and hands back the simulator as it stands after the last step handed out.
    pub fn finish(self) -> Result<SimSource, SourceError> {
        match self {
            Self::Inline(s) => Ok(*s),
            Self::Ahead(a) => a.finish(),
        }
    }
}

impl SensorSource for Simulated {
    fn next_step(&mut self) -> Result<Option<Step>, SourceError> {
        match self {
            Self::Inline(s) => s.next_step(),
            Self::Ahead(a) => a.next_step(),
        }
    }

    fn control(&mut self) -> Option<&mut dyn RobotControl> {
        match self {
            Self::Inline(s) => s.control(),
            Self::Ahead(a) => a.control(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mapkeeper_sim::{Route, SimParams, World};

    fn source(seed: u64) -> SimSource {
        let mut sim = Simulator::new(&World::default_warehouse(), SimParams::default(), seed).expect("sim");
        sim.set_route(Route::default_warehouse().points());
        SimSource::new(sim, 40.0)
    }

    /// Acts on the robot at some steps, the same way on both sources; whether it called the
    /// robot at all.
    fn act(k: usize, c: &mut dyn RobotControl) -> bool {
        match k {
            40 => c.stop(None),
            41 => c.stop(Some(5.0)), // no-op: already stopped
            60 => c.resume(),
            90 => c.stop(Some(0.5)), // resumes by itself after 0.5 s
            150 => c.move_robot(Pose2::new(1.0, -2.3, 0.3)),
            200 => {
                c.stop(None);
                c.resume();
            }
            _ => return false,
        }
        true
    }

    /// The steps, the stopped flags and the final counters of the source run ahead equal those
    /// of the inline source, with stops, timed resumes, resumes and a move on the way; a run
    /// ended early hands back the simulator as of the last step taken, not as far as it ran.
    #[test]
    fn ahead_source_matches_the_inline_source() {
        for stop_at in [None, Some(120)] {
            let mut inline = source(3);
            let mut ahead = AheadSource::start(source(3));
            let mut k = 0;
            loop {
                let (a, b) = (inline.next_step().expect("inline"), ahead.next_step().expect("ahead"));
                assert_eq!(a, b, "step {k}");
                if a.is_none() || stop_at == Some(k) {
                    break;
                }
                assert_eq!(inline.is_stopped(), ahead.is_stopped(), "step {k}");
                act(k, &mut inline);
                act(k, &mut ahead);
                assert_eq!(inline.is_stopped(), ahead.is_stopped(), "step {k}, after the actions");
                k += 1;
            }
            assert!(k > 100, "the route ran {k} steps");
            let rewinds = if stop_at.is_some() { 3 } else { 5 };
            assert_eq!(ahead.rewinds(), rewinds, "rewinds of steps 40, 60, 90 (, 150, 200)");
            let back = ahead.finish().expect("finish");
            assert_eq!(
                (back.collisions(), back.distance_m(), back.sim_time_s(), back.route_done()),
                (inline.collisions(), inline.distance_m(), inline.sim_time_s(), inline.route_done()),
                "stop at {stop_at:?}"
            );
            assert_eq!(back.sim().true_pose(), inline.sim().true_pose());
        }
    }

    /// Dropping a source run ahead part-way stops its thread: `drop` joins the simulator's
    /// thread, so it returns only once that thread has ended. It runs on a helper thread so that
    /// a thread that never stops fails the test (after a generous 30 s) instead of hanging it.
    #[test]
    fn dropping_a_source_run_ahead_stops_its_thread() {
        let mut ahead = AheadSource::start(source(4));
        for _ in 0..5 {
            assert!(ahead.next_step().expect("step").is_some());
        }
        assert!(ahead.worker.as_ref().is_some_and(|w| !w.is_finished()), "the simulator's thread runs ahead");
        let (done_tx, done_rx) = std::sync::mpsc::channel();
        let dropper = std::thread::spawn(move || {
            drop(ahead);
            let _ = done_tx.send(());
        });
        let done = done_rx.recv_timeout(std::time::Duration::from_secs(30));
        assert_eq!(done, Ok(()), "dropping the source did not stop its thread within 30 s");
        dropper.join().expect("the dropping thread");
    }
}
