//! The node without the wire: messages in, steps through the harness's loop (the session, the
//! Lost policy when the node localises, the publishing observer), outputs and log lines out, the
//! map saved. It reads no clock: the caller passes `now` (its monotonic time, used only for
//! waits and idle flushes; everything published is stamped with sensor time), so a test drives
//! it message by message.

use crate::config::{NodeConfig, NodeParams, PoseFrom};
use crate::frames::{Assembly, AssemblySettings, Counts, PoseTrack, ReadyStep, ScanRefusal};
use crate::msgs;
use crate::outputs::{Output, Publisher};
use crate::save::{self, Saved};
use mapkeeper_grid::{OccupancyGrid, Pose2};
use mapkeeper_harness::{
    Control, DEFAULT_LOST_WAIT_S, LostPolicy, NoClock, Observer, PoseSource, SensorSource, Session, SourceError, Step,
};
use mapkeeper_localiser::{FilterParams, Localiser};
use mapkeeper_logs::{RawTransform, Rigid3, RosScanFields};
use mapkeeper_updater::{MapUpdater, UpdaterParams};
use std::path::PathBuf;

static NO_CLOCK: NoClock = NoClock;

/// The node could not start or save.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    /// A parameter, a file it names, or the state saved.
    #[error("{0}")]
    Setup(String),
    /// Saving failed.
    #[error("saving: {0}")]
    Save(String),
}

/// How serious a log line is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    /// Information.
    Info,
    /// Input that was not used, or a problem the node rides out.
    Warn,
}

/// A message the node received, already decoded.
// Each input is decoded once and moved into the core: boxing the large ones would only add an
// allocation per message.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum Input {
    /// A scan of lidar `lidar` (its index in `scan_topics`).
    Scan {
        /// The lidar.
        lidar: usize,
        /// The message.
        msg: msgs::LaserScan,
    },
    /// `nav_msgs/Odometry`.
    Odometry(msgs::Odometry),
    /// `/tf`.
    Tf(msgs::TfMessage),
    /// `/tf_static`.
    TfStatic(msgs::TfMessage),
    /// The robot's localiser's pose.
    Pose(msgs::PoseWithCovarianceStamped),
    /// `/initialpose`.
    InitialPose(msgs::PoseWithCovarianceStamped),
    /// `/clock`.
    Clock(msgs::Clock),
}

/// What the node has done so far.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct NodeCounts {
    /// Steps given to the updater.
    pub steps: u64,
    /// The assembly's counts.
    pub input: Counts,
    /// Cells changed.
    pub cells_changed: u64,
    /// Saves written.
    pub saves: u64,
    /// Messages refused that are not scans (a pose that is not one, a frame not expected).
    pub messages_refused: u64,
}

/// One frame handed to the loop.
struct OneStep(Option<Step>);

impl SensorSource for OneStep {
    fn next_step(&mut self) -> Result<Option<Step>, SourceError> {
        Ok(self.0.take())
    }
}

/// The node's state.
pub struct NodeCore {
    params: NodeParams,
    session: Session<'static>,
    lost: Option<LostPolicy>,
    awaiting_pose: bool,
    assembly: Assembly,
    publisher: Publisher,
    save_dir: Option<PathBuf>,
    last_save_stamp: Option<u64>,
    cells_at_save: u64,
    last_step_now: u64,
    last_stamp_ns: u64,
    last_clock_ns: Option<u64>,
    logs: Vec<(Level, String)>,
    processed: Vec<u64>,
    warned: std::collections::BTreeMap<&'static str, (u64, u64)>,
    counts: NodeCounts,
}

impl std::fmt::Debug for NodeCore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NodeCore").field("counts", &self.counts).finish()
    }
}

fn secs_ns(s: f64) -> u64 {
    (s * 1e9).round() as u64
}

/// The planar pose of a ROS pose; `None` for one that is not a pose.
pub fn planar(p: &msgs::Pose) -> Option<Pose2> {
    let t = [p.position.x, p.position.y, p.position.z];
    let q = [p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w];
    Rigid3::from_translation_quaternion(t, q).map(|r| r.planar().0)
}

impl NodeCore {
    /// Starts the node of `config` at `now_ns`: the map (or, with `resume`, the map and memory
    /// saved in `save_dir`), the updater, the pose source; the first `/map` is among the outputs.
    pub fn start(config: &NodeConfig, now_ns: u64) -> Result<NodeCore, NodeError> {
        let p = config.params.clone();
        let save_dir = config.resolve(&p.save_dir);
        let setup = |e: String| NodeError::Setup(e);
        let resumed = match (&save_dir, p.resume) {
            (Some(d), true) => save::load(d).map_err(setup)?,
            _ => None,
        };
        let mut logs = Vec::new();
        let (map, memory) = match resumed {
            Some(s) => {
                logs.push((
                    Level::Info,
                    format!("resuming from {} ({} memory records)", s.map_path.display(), s.memory.len()),
                ));
                (s.map, s.memory)
            }
            None => {
                let path = config.resolve(&p.map).unwrap_or_default();
                let map = mapkeeper_grid::map_io::load_map(&path).map_err(|e| setup(format!("map: {e}")))?;
                (map, mapkeeper_updater::StructureMemory::default())
            }
        };
        let uparams = UpdaterParams::preset(&p.preset).map_err(|e| setup(format!("preset: {e}")))?;
        let uparams = mapkeeper_harness::config::load_params(
            uparams,
            config.resolve(&p.updater_params).as_deref(),
            UpdaterParams::validate,
        )
        .map_err(|e| setup(format!("updater_params: {e}")))?;
        let updater =
            MapUpdater::with_memory(map.clone(), uparams, memory).map_err(|e| setup(format!("updater: {e}")))?;
        let (pose, lost, awaiting_pose) = pose_source(config, &p, &map)?;
        let mut session = Session::new(pose, Some(updater), None, &NO_CLOCK);
        session.set_deskew(true);
        let track = match p.pose_source {
            PoseFrom::Localiser => PoseTrack::None,
            PoseFrom::PoseTopic => PoseTrack::Poses,
            PoseFrom::Tf => PoseTrack::MapOdom,
        };
        let assembly = Assembly::new(AssemblySettings {
            scan_topics: p.scan_topics.clone(),
            window_ns: secs_ns(p.sync_window_s),
            max_wait_ns: secs_ns(p.max_wait_s),
            queue_limit: p.queue_limit,
            base_frame: p.base_frame.clone(),
            given_mounts: p.lidar_mounts.iter().map(|(f, m)| (f.clone(), Pose2::new(m[0], m[1], m[2]))).collect(),
            pose_track: track,
        });
        if awaiting_pose {
            logs.push((Level::Info, "waiting for /initialpose (no initial_pose, global_start false)".into()));
        }
        Ok(NodeCore {
            publisher: Publisher::new(&map, &p, 0),
            params: p,
            session,
            lost,
            awaiting_pose,
            assembly,
            save_dir,
            last_save_stamp: None,
            cells_at_save: 0,
            last_step_now: now_ns,
            last_stamp_ns: 0,
            last_clock_ns: None,
            logs,
            processed: Vec::new(),
            warned: std::collections::BTreeMap::new(),
            counts: NodeCounts::default(),
        })
    }

    /// Takes one message received at `now_ns`, and processes the steps it completes.
    pub fn handle(&mut self, input: Input, now_ns: u64) {
        match input {
            Input::Scan { lidar, msg } => self.scan(lidar, msg, now_ns),
            Input::Odometry(o) => {
                let Some(t) = self.stamp_of(&o.header, "odometry", now_ns) else { return };
                match planar(&o.pose.pose) {
                    Some(p) => {
                        if let Err(last) = self.assembly.odometry(t, p) {
                            self.warn(
                                "odometry",
                                now_ns,
                                format!(
                                    "odometry stamped {:.3} s, before the last ({:.3} s): not used",
                                    t as f64 / 1e9,
                                    last as f64 / 1e9
                                ),
                            );
                        }
                    }
                    None => self.refuse(
                        "odometry",
                        now_ns,
                        "odometry whose pose is not a pose (not finite, or a zero quaternion)".into(),
                    ),
                }
            }
            Input::Tf(tf) => self.tf(tf, now_ns),
            Input::TfStatic(tf) => {
                let raws = tf.transforms.iter().filter_map(|t| raw_transform(t, true)).collect::<Vec<_>>();
                if raws.len() < tf.transforms.len() {
                    self.refuse("tf_static", now_ns, "a /tf_static transform that is not a pose: not used".into());
                }
                self.assembly.static_transforms(raws);
            }
            Input::Pose(m) => self.pose(m, now_ns),
            Input::InitialPose(m) => self.initial_pose(m, now_ns),
            Input::Clock(c) => self.clock(c, now_ns),
        }
        self.pump(now_ns);
    }

    fn stamp_of(&mut self, h: &msgs::Header, what: &'static str, now_ns: u64) -> Option<u64> {
        let t = h.stamp.to_ns();
        if t.is_none() {
            self.refuse(what, now_ns, format!("{what} stamped {} s {} ns: not a time", h.stamp.sec, h.stamp.nanosec));
        }
        t
    }

    fn scan(&mut self, lidar: usize, msg: msgs::LaserScan, now_ns: u64) {
        let Some(topic) = self.params.scan_topics.get(lidar).cloned() else {
            self.refuse(
                "scan_lidar",
                now_ns,
                format!("a scan of lidar {lidar}: there are {} scan topics", self.params.scan_topics.len()),
            );
            return;
        };
        let Some(t) = self.stamp_of(&msg.header, "scan", now_ns) else { return };
        let fields = RosScanFields {
            angle_min: msg.angle_min,
            angle_increment: msg.angle_increment,
            time_increment: msg.time_increment,
            range_min: msg.range_min,
            range_max: msg.range_max,
            ranges: msg.ranges,
        };
        let result = self.assembly.scan(lidar, msg.header.frame_id, t, msg.angle_max, fields, now_ns);
        if let Err(e) = result {
            let kind = match e {
                ScanRefusal::NoMount { .. } => "scan_mount",
                ScanRefusal::Stale { .. } => "scan_stale",
                ScanRefusal::WrongSize(_) => "scan_size",
                ScanRefusal::Invalid(_) => "scan_invalid",
            };
            self.warn(kind, now_ns, format!("{topic}: scan not used: {e}"));
            if self.assembly.time_jumped_back() {
                self.restart_time(now_ns, "the scans' stamps jumped back");
            }
        }
    }

    fn tf(&mut self, tf: msgs::TfMessage, now_ns: u64) {
        for t in &tf.transforms {
            let (p, c) = (&self.params, &t.child_frame_id);
            let odom_edge = t.header.frame_id == p.odom_frame && *c == p.base_frame && p.odom_topic.is_empty();
            let map_edge = t.header.frame_id == p.map_frame && *c == p.odom_frame && p.pose_source == PoseFrom::Tf;
            if !(odom_edge || map_edge) {
                continue;
            }
            let Some(stamp) = self.stamp_of(&t.header, "tf", now_ns) else { continue };
            let Some(pose) = planar(&t.transform) else {
                self.refuse("tf", now_ns, format!("/tf {} -> {c} is not a pose: not used", t.header.frame_id));
                continue;
            };
            let r = if odom_edge { self.assembly.odometry(stamp, pose) } else { self.assembly.pose(stamp, pose) };
            if r.is_err() {
                self.warn(
                    "tf_order",
                    now_ns,
                    format!("/tf {} -> {c} stamped before the last one: not used", t.header.frame_id),
                );
            }
        }
    }

    fn pose(&mut self, m: msgs::PoseWithCovarianceStamped, now_ns: u64) {
        if self.params.pose_source != PoseFrom::PoseTopic {
            return;
        }
        let Some(t) = self.stamp_of(&m.header, "pose", now_ns) else { return };
        match planar(&m.pose.pose) {
            Some(p) => {
                if self.assembly.pose(t, p).is_err() {
                    self.warn(
                        "pose_order",
                        now_ns,
                        format!("{}: pose stamped before the last one: not used", self.params.pose_topic),
                    );
                }
            }
            None => self.refuse("pose", now_ns, format!("{}: not a pose: not used", self.params.pose_topic)),
        }
    }

    fn initial_pose(&mut self, m: msgs::PoseWithCovarianceStamped, now_ns: u64) {
        if self.params.pose_source != PoseFrom::Localiser {
            return;
        }
        let Some(p) = planar(&m.pose.pose) else {
            self.refuse("initialpose", now_ns, "/initialpose: not a pose: not used".into());
            return;
        };
        let c = &m.pose.covariance.0;
        let cov = [[c[0].max(1e-4), c[1], c[5]], [c[6], c[7].max(1e-4), c[11]], [c[30], c[31], c[35].max(1e-4)]];
        let odom = self.assembly.odometry.at_or_before(u64::MAX).unwrap_or(p);
        match self.session.set_estimate(p, cov) {
            Ok(()) => {
                // Mid-run, the updater's last good pose moves with the estimate (as the Lost
                // policy's hand-over does); before the first step there is none to move.
                if self.counts.steps > 0 {
                    self.session.reset_updater_reference(p, odom);
                }
                self.awaiting_pose = false;
                self.logs.push((
                    Level::Info,
                    format!("/initialpose: localiser set at ({:.3}, {:.3}, {:.3})", p.x, p.y, p.yaw),
                ));
            }
            Err(e) => self.refuse("initialpose", now_ns, format!("/initialpose: {e}: not used")),
        }
    }

    fn clock(&mut self, c: msgs::Clock, now_ns: u64) {
        let Some(t) = c.clock.to_ns() else { return };
        if let Some(last) = self.last_clock_ns
            && t < last
        {
            self.last_clock_ns = Some(t);
            self.restart_time(now_ns, &format!("/clock jumped back by {:.3} s", (last - t) as f64 / 1e9));
            return;
        }
        self.last_clock_ns = Some(t);
    }

    fn restart_time(&mut self, _now_ns: u64, why: &str) {
        let waiting = self.assembly.waiting();
        self.assembly.restart_time();
        self.logs.push((
            Level::Warn,
            format!("{why}: {waiting} waiting steps dropped, odometry and poses started anew; the map is kept"),
        ));
    }

    /// A warning of `kind`: the first, then at most one every 5 s with the count since.
    fn warn(&mut self, kind: &'static str, now_ns: u64, line: String) {
        let e = self.warned.entry(kind).or_insert((0, 0));
        e.1 += 1;
        if e.0 == 0 || now_ns.saturating_sub(e.0) >= 5_000_000_000 {
            let more = if e.1 > 1 { format!(" ({} like it since the last report)", e.1 - 1) } else { String::new() };
            self.logs.push((Level::Warn, format!("{line}{more}")));
            *e = (now_ns.max(1), 0);
        }
    }

    fn refuse(&mut self, kind: &'static str, now_ns: u64, line: String) {
        self.counts.messages_refused += 1;
        self.warn(kind, now_ns, line);
    }

    /// Processes the steps ready at `now_ns`; publishes the map whole and saves when the node has
    /// been idle for a publishing period (the end of a drive).
    pub fn tick(&mut self, now_ns: u64) {
        self.pump(now_ns);
        let idle = now_ns.saturating_sub(self.last_step_now) >= secs_ns(self.params.map_publish_period_s);
        if !idle || self.assembly.waiting() > 0 {
            return;
        }
        if let Some(map) = self.session.map() {
            self.publisher.full_map(map, self.last_stamp_ns, true);
        }
        if self.save_dir.is_some() && self.unsaved() {
            self.save_logged("idle");
        }
    }

    fn pump(&mut self, now_ns: u64) {
        while let Some(ready) = self.assembly.next_step(now_ns) {
            self.process(ready, now_ns);
        }
    }

    fn process(&mut self, ready: ReadyStep, now_ns: u64) {
        if self.awaiting_pose {
            self.warn("no_pose", now_ns, "step not processed: the localiser waits for /initialpose".into());
            return;
        }
        let stamp = ready.frame.stamp_ns;
        if let Some(p) = ready.pose {
            self.session.set_updater_pose_override(Some(p));
        }
        let mut source = OneStep(Some(Step { frame: ready.frame, truth: None }));
        let mut controls: Vec<&mut dyn Control> = Vec::new();
        if let Some(l) = self.lost.as_mut() {
            controls.push(l);
        }
        let mut observers: [&mut dyn Observer; 1] = [&mut self.publisher];
        if let Err(e) = mapkeeper_harness::step_once(&mut source, &mut self.session, &mut controls, &mut observers) {
            self.logs.push((Level::Warn, format!("step at {:.3} s: {e}", stamp as f64 / 1e9)));
        }
        self.counts.steps += 1;
        self.processed.push(ready.arrived_ns);
        self.last_step_now = now_ns;
        self.last_stamp_ns = stamp;
        let period = secs_ns(self.params.save_period_s);
        let due = period > 0 && self.last_save_stamp.is_none_or(|l| stamp >= l.saturating_add(period) || stamp < l);
        if due && self.unsaved() && self.save_dir.is_some() {
            self.save_logged("periodic");
        }
    }

    fn unsaved(&self) -> bool {
        self.publisher.cells_changed != self.cells_at_save
    }

    fn save_logged(&mut self, why: &str) {
        match self.save() {
            Ok(s) => self.logs.push((Level::Info, format!("saved ({why}) {}", s.map_path.display()))),
            Err(e) => self.logs.push((Level::Warn, e.to_string())),
        }
    }

    /// Saves the map, its memory and the counts in `save_dir` (each file atomically; the map's
    /// YAML last, so that a map that exists is whole).
    pub fn save(&mut self) -> Result<Saved, NodeError> {
        let Some(dir) = self.save_dir.clone() else {
            return Err(NodeError::Save("no save_dir set".into()));
        };
        let (Some(u), Some(map)) = (self.session.updater(), self.session.map()) else {
            return Err(NodeError::Save("the session has no updater".into()));
        };
        // The memory the next run starts with, computed from this run's start: saves within
        // one run do not compound.
        let memory = u.next_memory();
        let counts = self.counts();
        let saved = save::store(&dir, map, &memory, &counts).map_err(NodeError::Save)?;
        self.last_save_stamp = Some(self.last_stamp_ns);
        self.cells_at_save = self.publisher.cells_changed;
        self.counts.saves += 1;
        Ok(saved)
    }

    /// What the node has done.
    pub fn counts(&self) -> NodeCounts {
        NodeCounts {
            input: self.assembly.counts.clone(),
            cells_changed: self.publisher.cells_changed,
            ..self.counts.clone()
        }
    }

    /// The map as it is.
    pub fn map(&self) -> Option<&OccupancyGrid> {
        self.session.map()
    }

    /// The outputs and log lines produced since the last call, and the arrival times of the
    /// steps processed (their latency runs from there to the caller's publishing).
    pub fn drain(&mut self) -> (Vec<Output>, Vec<(Level, String)>, Vec<u64>) {
        (std::mem::take(&mut self.publisher.out), std::mem::take(&mut self.logs), std::mem::take(&mut self.processed))
    }

    /// The parameters.
    pub fn params(&self) -> &NodeParams {
        &self.params
    }
}

fn raw_transform(t: &msgs::TransformStamped, is_static: bool) -> Option<RawTransform> {
    let p = &t.transform;
    let transform = Rigid3::from_translation_quaternion(
        [p.position.x, p.position.y, p.position.z],
        [p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w],
    )?;
    Some(RawTransform {
        stamp_ns: t.header.stamp.to_ns().unwrap_or(0),
        parent: t.header.frame_id.clone(),
        child: t.child_frame_id.clone(),
        transform,
        is_static,
        record_ns: None,
    })
}

type PoseSetup = (PoseSource, Option<LostPolicy>, bool);

fn pose_source(config: &NodeConfig, p: &NodeParams, map: &OccupancyGrid) -> Result<PoseSetup, NodeError> {
    if p.pose_source != PoseFrom::Localiser {
        return Ok((PoseSource::None, None, false));
    }
    let setup = |e: String| NodeError::Setup(e);
    let fp = FilterParams::preset(&p.localiser_preset).map_err(|e| setup(format!("localiser_preset: {e}")))?;
    let fp = mapkeeper_harness::config::load_params(
        fp,
        config.resolve(&p.localiser_params).as_deref(),
        FilterParams::validate,
    )
    .map_err(|e| setup(format!("localiser_params: {e}")))?;
    let mut filter = Localiser::new(map, fp, mapkeeper_harness::jobs::chain_seed(p.seed))
        .map_err(|e| setup(format!("localiser: {e}")))?;
    let awaiting = match p.initial_pose.as_slice() {
        [x, y, yaw] => {
            filter
                .init_pose(Pose2::new(*x, *y, *yaw), fp.initial_covariance())
                .map_err(|e| setup(format!("initial_pose: {e}")))?;
            false
        }
        _ if p.global_start => {
            filter.init_global().map_err(|e| setup(format!("global_start: {e}")))?;
            false
        }
        _ => true,
    };
    let lost = LostPolicy::new(true, DEFAULT_LOST_WAIT_S, fp.initial_covariance());
    Ok((PoseSource::Localiser(Box::new(filter)), Some(lost), awaiting))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::msgs::{Header, Time};

    fn node(extra: &str, name: &str) -> (NodeCore, PathBuf) {
        let dir = std::env::temp_dir().join(format!("mapkeeper-node-core-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let map = mapkeeper_testkit::rooms::ten_by_ten_centred();
        mapkeeper_grid::map_io::save_map(&map, &dir.join("room.yaml")).unwrap();
        let text = format!("n:\n  ros__parameters:\n    map: room.yaml\n    save_dir: saved\n{extra}");
        let config = NodeConfig::parse(&text, dir.clone()).unwrap();
        (NodeCore::start(&config, 0).unwrap(), dir)
    }

    fn header(sec: i32) -> Header {
        Header { stamp: Time { sec, nanosec: 0 }, frame_id: "odom".into() }
    }

    fn pose(x: f64, q: msgs::Quaternion) -> msgs::PoseWithCovarianceStamped {
        msgs::PoseWithCovarianceStamped {
            header: header(1),
            pose: msgs::PoseWithCovariance {
                pose: msgs::Pose { position: msgs::Vector3 { x, y: 0.0, z: 0.0 }, orientation: q },
                covariance: msgs::Cov36::default(),
            },
        }
    }

    fn logs(n: &mut NodeCore) -> String {
        n.drain().1.into_iter().map(|(_, l)| l).collect::<Vec<_>>().join("\n")
    }

    #[test]
    fn input_that_is_not_usable_is_refused_with_a_line_and_counted() {
        let (mut n, _) = node("    pose_source: pose_topic\n", "refused");
        let (outs, _, _) = n.drain();
        assert!(matches!(outs[..], [Output::Map(_)]), "the map is published at start");
        let zero = msgs::Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 0.0 };
        n.handle(Input::Pose(pose(f64::NAN, msgs::Quaternion::default())), 1);
        n.handle(Input::Pose(pose(1.0, zero)), 2);
        let mut bad_stamp = pose(1.0, msgs::Quaternion::default());
        bad_stamp.header.stamp = Time { sec: -5, nanosec: 0 };
        n.handle(Input::Pose(bad_stamp), 3);
        let tf = msgs::TransformStamped {
            header: header(1),
            child_frame_id: "laser".into(),
            transform: msgs::Pose { orientation: zero, ..Default::default() },
        };
        n.handle(Input::TfStatic(msgs::TfMessage { transforms: vec![tf] }), 10_000_000_000);
        let text = logs(&mut n);
        assert_eq!(n.counts().messages_refused, 4, "{text}");
        assert!(
            text.contains("/amcl_pose: not a pose: not used (1 like it since the last report)")
                || text.contains("/amcl_pose: not a pose"),
            "{text}"
        );
        assert!(text.contains("/tf_static transform that is not a pose"), "{text}");
        assert_eq!(n.counts().steps, 0);
        // The initial pose is the robot's localiser's business in this mode.
        n.handle(Input::InitialPose(pose(1.0, msgs::Quaternion::default())), 11);
        assert!(logs(&mut n).is_empty());
    }

    #[test]
    fn a_clock_that_jumps_back_restarts_the_tracks_and_keeps_the_map() {
        let (mut n, _) = node("    use_sim_time: true\n    pose_source: pose_topic\n", "clock");
        n.handle(Input::Clock(msgs::Clock { clock: Time { sec: 10, nanosec: 0 } }), 1);
        n.handle(Input::Pose(pose(1.0, msgs::Quaternion::default())), 2);
        n.handle(Input::Clock(msgs::Clock { clock: Time { sec: 4, nanosec: 0 } }), 3);
        let text = logs(&mut n);
        assert!(text.contains("/clock jumped back by 6.000 s") && text.contains("the map is kept"), "{text}");
        assert_eq!(n.counts().input.time_jumps, 1);
    }

    #[test]
    fn the_own_localiser_waits_for_initialpose_and_the_saved_state_is_resumed() {
        let (mut n, dir) = node("    pose_source: localiser\n", "resume");
        assert!(logs(&mut n).contains("waiting for /initialpose"));
        n.handle(Input::InitialPose(pose(0.5, msgs::Quaternion::from_yaw(0.3))), 1);
        assert!(logs(&mut n).contains("/initialpose: localiser set at (0.500, 0.000, 0.300)"));
        let saved = n.save().unwrap();
        assert_eq!(saved.map_path, dir.join("saved/map.yaml"));
        // A restarted node continues from the saved map; a memory of another map is refused.
        let text = "n:\n  ros__parameters:\n    map: room.yaml\n    save_dir: saved\n    initial_pose: [0, 0, 0]\n";
        let config = NodeConfig::parse(text, dir.clone()).unwrap();
        let mut again = NodeCore::start(&config, 0).unwrap();
        assert!(logs(&mut again).contains("resuming from"), "resume");
        std::fs::write(dir.join("saved/memory.json"), r#"{"map_cells": 7, "memory": {"records": []}}"#).unwrap();
        let e = NodeCore::start(&config, 0).unwrap_err().to_string();
        assert!(e.contains("memory.json: a memory of a 7-cell map beside a"), "{e}");
        std::fs::write(dir.join("saved/memory.json"), "{").unwrap();
        let e = NodeCore::start(&config, 0).unwrap_err().to_string();
        assert!(e.contains("memory.json: not a memory file"), "{e}");
    }
}
