//! From live messages to the steps the estimators see, by the rules `mapkeeper update` replays a
//! log with, so that a drive processed live and the same drive's bag processed offline give the
//! same map: scans of different lidars within the synchronisation window of a step's first scan
//! (at most one per lidar) form one step stamped with its latest scan; the step's odometry is
//! the latest reading at or before its stamp; a pose track is interpolated at it. A step waits
//! (at most `max_wait_s`) until the odometry and the pose that bracket its stamp have arrived.
//!
//! Everything here is driven by the messages and the `now` the caller passes: no clock is read.

use mapkeeper_grid::Pose2;
use mapkeeper_harness::SensorFrame;
use mapkeeper_logs::{RawScan, RawTransform, RosScanFields, mount_from_transforms};
use mapkeeper_sensor::{LaserScan, StampedPose, interpolate};
use std::collections::VecDeque;

/// The most samples a track keeps (older ones are dropped): ~80 s of 50 Hz odometry.
const TRACK_CAP: usize = 4096;

/// Successive scans refused as older than their lidar's last one after which the node takes it
/// for a time jump back (a restarted bag, a simulator reset) and starts its tracks anew.
const JUMP_AFTER_STALE: u32 = 25;

/// A time-ordered pose track, bounded.
#[derive(Clone, Debug, Default)]
pub struct Track {
    poses: Vec<StampedPose>,
}

impl Track {
    /// Appends a sample; `Err` with the last stamp if it is older than it (nothing kept).
    pub fn push(&mut self, stamp_ns: u64, pose: Pose2) -> Result<(), u64> {
        if let Some(last) = self.poses.last()
            && stamp_ns < last.stamp_ns
        {
            return Err(last.stamp_ns);
        }
        if self.poses.len() >= 2 * TRACK_CAP {
            self.poses.drain(..TRACK_CAP);
        }
        self.poses.push(StampedPose { stamp_ns, pose });
        Ok(())
    }

    /// The last sample's stamp.
    pub fn last_stamp(&self) -> Option<u64> {
        self.poses.last().map(|p| p.stamp_ns)
    }

    /// The latest pose at or before `stamp_ns`.
    pub fn at_or_before(&self, stamp_ns: u64) -> Option<Pose2> {
        let k = self.poses.partition_point(|p| p.stamp_ns <= stamp_ns);
        k.checked_sub(1).map(|j| self.poses[j].pose)
    }

    /// The track interpolated at `stamp_ns` (clamped outside its span).
    pub fn interpolated(&self, stamp_ns: u64) -> Option<Pose2> {
        interpolate(&self.poses, stamp_ns)
    }

    /// Forgets every sample.
    pub fn clear(&mut self) {
        self.poses.clear();
    }
}

/// Why a scan was not used.
#[derive(Clone, Debug, PartialEq)]
pub enum ScanRefusal {
    /// Its lidar's mount is not known yet (no `/tf_static` chain to the base frame).
    NoMount {
        /// The lidar's frame.
        frame: String,
    },
    /// Older than (or as old as) the last scan of its lidar.
    Stale {
        /// Its stamp.
        stamp_ns: u64,
        /// The last one's.
        last_ns: u64,
    },
    /// Its beams do not agree with its angles, or with the lidar's first scan.
    WrongSize(String),
    /// The scan is not valid (a range, an angle).
    Invalid(String),
}

impl std::fmt::Display for ScanRefusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ScanRefusal::NoMount { frame } => write!(
                f,
                "no mount for frame '{frame}' yet (no /tf_static chain from the base frame, no lidar_mounts entry)"
            ),
            ScanRefusal::Stale { stamp_ns, last_ns } => {
                write!(
                    f,
                    "stamp {:.3} s is not after the lidar's last scan ({:.3} s)",
                    *stamp_ns as f64 / 1e9,
                    *last_ns as f64 / 1e9
                )
            }
            ScanRefusal::WrongSize(m) | ScanRefusal::Invalid(m) => f.write_str(m),
        }
    }
}

#[derive(Clone, Debug, Default)]
struct Lidar {
    topic: String,
    beams: Option<usize>,
    last_ns: Option<u64>,
}

/// A step being formed or waiting for its odometry and pose.
#[derive(Clone, Debug)]
struct Pending {
    stamp_ns: u64,
    first_ns: u64,
    scans: Vec<LaserScan>,
    /// When (caller's time) its latest scan arrived.
    arrived_ns: u64,
}

/// A step ready for the session, and what the node knows of it.
#[derive(Clone, Debug)]
pub struct ReadyStep {
    /// The frame.
    pub frame: SensorFrame,
    /// The pose the updater is to be given (the robot's localiser's), if the node does not
    /// localise itself.
    pub pose: Option<Pose2>,
    /// When (caller's time) its latest scan arrived: its latency runs from there.
    pub arrived_ns: u64,
    /// Whether it waited its full time for missing odometry or pose.
    pub timed_out: bool,
}

/// What the step's pose comes from (beside the odometry).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PoseTrack {
    /// The node's own localiser: no pose track.
    None,
    /// A pose topic, interpolated.
    Poses,
    /// The `map → odom` transform (latest at or before) composed with the odometry.
    MapOdom,
}

/// The counts the node reports.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Counts {
    /// Scans taken.
    pub scans: u64,
    /// Scans refused without a mount.
    pub scans_without_mount: u64,
    /// Scans refused as not newer than their lidar's last.
    pub scans_stale: u64,
    /// Scans refused for their size.
    pub scans_wrong_size: u64,
    /// Scans refused as invalid.
    pub scans_invalid: u64,
    /// Odometry, pose or transform samples refused as older than their track's last.
    pub samples_out_of_order: u64,
    /// Steps dropped because the node was behind (the queue was full).
    pub steps_dropped_behind: u64,
    /// Steps dropped for want of a pose.
    pub steps_without_pose: u64,
    /// Steps processed after waiting their full time for odometry or pose.
    pub steps_timed_out: u64,
    /// Time jumps back seen (tracks started anew).
    pub time_jumps: u64,
}

/// The assembly of steps from live messages.
#[derive(Debug)]
pub struct Assembly {
    window_ns: u64,
    max_wait_ns: u64,
    queue_limit: usize,
    base_frame: String,
    lidars: Vec<Lidar>,
    given_mounts: Vec<(String, Pose2)>,
    static_tf: Vec<RawTransform>,
    open: Option<Pending>,
    ready: VecDeque<Pending>,
    /// The odometry.
    pub odometry: Track,
    /// The robot's localiser's poses (pose topic) or `map → odom` (tf), by `pose_track`.
    pub poses: Track,
    pose_track: PoseTrack,
    stale_run: u32,
    /// The counts.
    pub counts: Counts,
}

/// The assembly's settings.
#[derive(Clone, Debug)]
pub struct AssemblySettings {
    /// The lidars' topics, in lidar order.
    pub scan_topics: Vec<String>,
    /// Synchronisation window, ns.
    pub window_ns: u64,
    /// Longest wait for odometry and pose, ns.
    pub max_wait_ns: u64,
    /// Steps waiting at most.
    pub queue_limit: usize,
    /// The robot's base frame.
    pub base_frame: String,
    /// Mounts given by parameter: frame → mount.
    pub given_mounts: Vec<(String, Pose2)>,
    /// The pose track.
    pub pose_track: PoseTrack,
}

impl Assembly {
    /// An empty assembly.
    pub fn new(s: AssemblySettings) -> Assembly {
        Assembly {
            window_ns: s.window_ns,
            max_wait_ns: s.max_wait_ns,
            queue_limit: s.queue_limit,
            base_frame: s.base_frame,
            lidars: s.scan_topics.into_iter().map(|topic| Lidar { topic, ..Lidar::default() }).collect(),
            given_mounts: s.given_mounts,
            static_tf: Vec::new(),
            open: None,
            ready: VecDeque::new(),
            odometry: Track::default(),
            poses: Track::default(),
            pose_track: s.pose_track,
            stale_run: 0,
            counts: Counts::default(),
        }
    }

    /// Adds the static transforms of one `/tf_static` message (a newer edge replaces an older
    /// one between the same frames); mounts found from them apply from the next scan.
    pub fn static_transforms(&mut self, tfs: Vec<RawTransform>) {
        for t in tfs {
            self.static_tf.retain(|o| !(o.parent == t.parent && o.child == t.child));
            self.static_tf.push(t);
        }
    }

    fn mount(&self, frame: &str) -> Option<(Pose2, bool)> {
        if let Some((_, m)) = self.given_mounts.iter().find(|(f, _)| f == frame) {
            return Some((*m, false));
        }
        if frame == self.base_frame {
            return Some((Pose2::IDENTITY, false));
        }
        let edges: Vec<&RawTransform> = self.static_tf.iter().collect();
        mount_from_transforms(&edges, &self.base_frame, frame).map(|(m, mirrored, _)| (m, mirrored))
    }

    /// Takes one scan of lidar `lidar` (its index in the scan topics) that arrived at `now_ns`.
    /// `angle_max` is the message's, to check its size.
    pub fn scan(
        &mut self,
        lidar: usize,
        frame_id: String,
        stamp_ns: u64,
        angle_max: f32,
        fields: RosScanFields,
        now_ns: u64,
    ) -> Result<(), ScanRefusal> {
        let refused = self.check_scan(lidar, &frame_id, stamp_ns, angle_max, &fields);
        let (mount, mirrored) = match refused {
            Ok(m) => m,
            Err(e) => {
                self.count(&e);
                return Err(e);
            }
        };
        let l = &mut self.lidars[lidar];
        let topic = l.topic.clone();
        let raw = RawScan::from_ros(&topic, frame_id, stamp_ns, fields, format!("scan at {stamp_ns} ns"));
        let scan = raw.to_laser_scan(lidar as u32, mount, mirrored).map_err(|e| {
            self.counts.scans_invalid += 1;
            ScanRefusal::Invalid(e)
        })?;
        let l = &mut self.lidars[lidar];
        l.last_ns = Some(stamp_ns);
        l.beams.get_or_insert(scan.ranges_m.len());
        self.stale_run = 0;
        self.counts.scans += 1;
        self.add_scan(scan, now_ns);
        Ok(())
    }

    fn count(&mut self, e: &ScanRefusal) {
        let c = &mut self.counts;
        match e {
            ScanRefusal::NoMount { .. } => c.scans_without_mount += 1,
            ScanRefusal::Stale { .. } => {
                c.scans_stale += 1;
                self.stale_run += 1;
            }
            ScanRefusal::WrongSize(_) => c.scans_wrong_size += 1,
            ScanRefusal::Invalid(_) => c.scans_invalid += 1,
        }
    }

    /// Whether a run of stale scans says that time jumped back.
    pub fn time_jumped_back(&self) -> bool {
        self.stale_run >= JUMP_AFTER_STALE
    }

    fn check_scan(
        &self,
        lidar: usize,
        frame_id: &str,
        stamp_ns: u64,
        angle_max: f32,
        f: &RosScanFields,
    ) -> Result<(Pose2, bool), ScanRefusal> {
        let l = &self.lidars[lidar];
        if let Some(last_ns) = l.last_ns
            && stamp_ns <= last_ns
        {
            return Err(ScanRefusal::Stale { stamp_ns, last_ns });
        }
        let n = f.ranges.len();
        if f.angle_increment.is_finite() && f.angle_increment != 0.0 && angle_max.is_finite() && f.angle_min.is_finite()
        {
            let expected = (f64::from(angle_max) - f64::from(f.angle_min)) / f64::from(f.angle_increment) + 1.0;
            if (expected - n as f64).abs() > 1.01 {
                return Err(ScanRefusal::WrongSize(format!(
                    "{n} ranges where angle_min {:.4}, angle_max {angle_max:.4} and angle_increment {:.6} rad make {:.0}",
                    f.angle_min, f.angle_increment, expected
                )));
            }
        }
        if let Some(b) = l.beams
            && b != n
        {
            return Err(ScanRefusal::WrongSize(format!("{n} ranges where the lidar's first scan had {b}")));
        }
        self.mount(frame_id).ok_or_else(|| ScanRefusal::NoMount { frame: frame_id.to_string() })
    }

    fn add_scan(&mut self, scan: LaserScan, now_ns: u64) {
        let joins = self.open.as_ref().is_some_and(|g| {
            scan.stamp_ns >= g.first_ns
                && scan.stamp_ns - g.first_ns <= self.window_ns
                && g.scans.iter().all(|s| s.lidar_id != scan.lidar_id)
        });
        if joins {
            if let Some(g) = self.open.as_mut() {
                g.stamp_ns = g.stamp_ns.max(scan.stamp_ns);
                g.arrived_ns = now_ns;
                g.scans.push(scan);
            }
        } else {
            self.close_open();
            self.open = Some(Pending {
                stamp_ns: scan.stamp_ns,
                first_ns: scan.stamp_ns,
                scans: vec![scan],
                arrived_ns: now_ns,
            });
        }
        if self.open.as_ref().is_some_and(|g| g.scans.len() == self.lidars.len()) {
            self.close_open();
        }
    }

    fn close_open(&mut self) {
        if let Some(g) = self.open.take() {
            self.ready.push_back(g);
            while self.ready.len() > self.queue_limit {
                self.ready.pop_front();
                self.counts.steps_dropped_behind += 1;
            }
        }
    }

    /// Adds an odometry sample; `Err` (counted) if older than the last.
    pub fn odometry(&mut self, stamp_ns: u64, pose: Pose2) -> Result<(), u64> {
        self.odometry.push(stamp_ns, pose).inspect_err(|_| self.counts.samples_out_of_order += 1)
    }

    /// Adds a sample of the pose track; `Err` (counted) if older than the last.
    pub fn pose(&mut self, stamp_ns: u64, pose: Pose2) -> Result<(), u64> {
        self.poses.push(stamp_ns, pose).inspect_err(|_| self.counts.samples_out_of_order += 1)
    }

    /// Forgets the steps waiting and the tracks (time jumped back); mounts and beam counts stay.
    pub fn restart_time(&mut self) {
        self.open = None;
        self.ready.clear();
        self.odometry.clear();
        self.poses.clear();
        for l in &mut self.lidars {
            l.last_ns = None;
        }
        self.stale_run = 0;
        self.counts.time_jumps += 1;
    }

    /// The steps waiting or being formed.
    pub fn waiting(&self) -> usize {
        self.ready.len() + usize::from(self.open.is_some())
    }

    /// The next step to process at `now_ns`, if one is ready: its odometry and pose have come,
    /// or it waited `max_wait_s`. A step whose pose cannot be had is dropped (counted) and the
    /// next one is tried.
    pub fn next_step(&mut self, now_ns: u64) -> Option<ReadyStep> {
        // A step still missing a lidar's scan closes when a scan that does not fit it arrives
        // (as offline), when every lidar is in it, or after `max_wait_s` without news (a lidar
        // that stopped): never after the synchronisation window alone, which delivery jitter
        // exceeds and which would split a step the offline replay keeps whole.
        if self.open.as_ref().is_some_and(|g| now_ns.saturating_sub(g.arrived_ns) >= self.max_wait_ns) {
            self.close_open();
        }
        loop {
            let front = self.ready.front()?;
            let t = front.stamp_ns;
            let odom_in = self.odometry.last_stamp().is_some_and(|s| s >= t);
            let pose_in = match self.pose_track {
                PoseTrack::None => true,
                PoseTrack::Poses => self.poses.last_stamp().is_some_and(|s| s >= t),
                PoseTrack::MapOdom => self.poses.last_stamp().is_some(),
            };
            let timed_out = now_ns.saturating_sub(front.arrived_ns) >= self.max_wait_ns;
            if !(timed_out || odom_in && pose_in) {
                return None;
            }
            let g = self.ready.pop_front()?;
            let odometry = self.odometry.at_or_before(t);
            let pose = match self.pose_track {
                PoseTrack::None => None,
                PoseTrack::Poses => match self.poses.interpolated(t) {
                    Some(p) => Some(p),
                    None => {
                        self.counts.steps_without_pose += 1;
                        continue;
                    }
                },
                PoseTrack::MapOdom => match (self.poses.at_or_before(t), odometry) {
                    (Some(map_odom), Some(o)) => Some(map_odom.compose(&o)),
                    _ => {
                        self.counts.steps_without_pose += 1;
                        continue;
                    }
                },
            };
            let timed_out = !(odom_in && pose_in);
            self.counts.steps_timed_out += u64::from(timed_out);
            let frame = SensorFrame { stamp_ns: t, odometry, scans: g.scans };
            return Some(ReadyStep { frame, pose, arrived_ns: g.arrived_ns, timed_out });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;

    fn fields(n: usize) -> RosScanFields {
        RosScanFields {
            angle_min: -1.0,
            angle_increment: 2.0 / (n as f32 - 1.0),
            time_increment: 0.0,
            range_min: 0.05,
            range_max: 20.0,
            ranges: vec![3.0; n],
        }
    }

    fn assembly(lidars: usize, track: PoseTrack) -> Assembly {
        let mut a = Assembly::new(AssemblySettings {
            scan_topics: (0..lidars).map(|k| format!("/scan_{k}")).collect(),
            window_ns: 50 * MS,
            max_wait_ns: 500 * MS,
            queue_limit: 4,
            base_frame: "base_link".into(),
            given_mounts: vec![("lidar_0".into(), Pose2::new(0.3, 0.0, 0.0))],
            pose_track: track,
        });
        let t = mapkeeper_logs::Rigid3::from_translation_quaternion([-0.3, 0.0, 0.2], [1.0, 0.0, 0.0, 0.0]).unwrap();
        a.static_transforms(vec![RawTransform {
            stamp_ns: 0,
            parent: "base_link".into(),
            child: "lidar_1".into(),
            transform: t,
            is_static: true,
            record_ns: None,
        }]);
        a
    }

    fn scan(a: &mut Assembly, lidar: usize, stamp_ns: u64, now_ns: u64) -> Result<(), ScanRefusal> {
        a.scan(lidar, format!("lidar_{lidar}"), stamp_ns, 1.0, fields(21), now_ns)
    }

    #[test]
    fn scans_of_both_lidars_form_one_step_that_waits_for_its_odometry_and_pose() {
        let mut a = assembly(2, PoseTrack::Poses);
        a.odometry(0, Pose2::IDENTITY).unwrap();
        a.pose(0, Pose2::new(1.0, 0.0, 0.0)).unwrap();
        scan(&mut a, 0, 100 * MS, 0).unwrap();
        scan(&mut a, 1, 110 * MS, 1).unwrap();
        // Closed (both lidars in it) but the odometry and pose stop before its stamp: it waits.
        assert!(a.next_step(2).is_none());
        a.odometry(110 * MS, Pose2::new(0.1, 0.0, 0.0)).unwrap();
        assert!(a.next_step(3).is_none());
        a.pose(120 * MS, Pose2::new(2.2, 0.0, 0.0)).unwrap();
        let s = a.next_step(4).unwrap();
        assert_eq!(s.frame.stamp_ns, 110 * MS);
        assert_eq!(s.frame.scans.iter().map(|s| s.lidar_id).collect::<Vec<_>>(), [0, 1]);
        assert_eq!(s.frame.odometry, Some(Pose2::new(0.1, 0.0, 0.0)));
        let p = s.pose.unwrap();
        assert!((p.x - (1.0 + 1.2 * 110.0 / 120.0)).abs() < 1e-12, "{p:?}");
        assert!(!s.timed_out);
        // The rear lidar is upside down on /tf_static: its angles are mirrored.
        assert_eq!(s.frame.scans[1].angle_increment_rad, -f64::from(fields(21).angle_increment));
        assert_eq!(s.frame.scans[1].lidar_in_robot.x, -0.3);
    }

    #[test]
    fn a_late_second_scan_joins_its_step_and_a_silent_lidar_closes_it_after_the_wait() {
        let mut a = assembly(2, PoseTrack::None);
        a.odometry(500 * MS, Pose2::IDENTITY).unwrap();
        scan(&mut a, 0, 100 * MS, 0).unwrap();
        // The rear scan, stamped 5 ms later, arrives 120 ms later (delivery jitter).
        assert!(a.next_step(119 * MS).is_none());
        scan(&mut a, 1, 105 * MS, 120 * MS).unwrap();
        assert_eq!(a.next_step(121 * MS).unwrap().frame.scans.len(), 2);
        // The rear lidar falls silent: the front scan goes alone after max_wait_s.
        scan(&mut a, 0, 180 * MS, 200 * MS).unwrap();
        assert!(a.next_step(699 * MS).is_none());
        assert_eq!(a.next_step(700 * MS).unwrap().frame.scans.len(), 1);
    }

    #[test]
    fn a_step_without_its_inputs_goes_after_the_wait_and_one_without_any_pose_is_dropped() {
        let mut a = assembly(1, PoseTrack::Poses);
        a.odometry(0, Pose2::IDENTITY).unwrap();
        scan(&mut a, 0, 100 * MS, 0).unwrap();
        assert!(a.next_step(499 * MS).is_none());
        assert!(a.next_step(500 * MS).is_none(), "no pose at all: dropped");
        assert_eq!(a.counts.steps_without_pose, 1);
        a.pose(50 * MS, Pose2::new(1.0, 1.0, 0.0)).unwrap();
        scan(&mut a, 0, 200 * MS, 600 * MS).unwrap();
        let s = a.next_step(1200 * MS).unwrap();
        assert!(s.timed_out);
        assert_eq!(s.pose, Some(Pose2::new(1.0, 1.0, 0.0)), "clamped to the last pose");
        assert_eq!(a.counts.steps_timed_out, 1);
    }

    #[test]
    fn bad_scans_are_refused_and_counted_and_the_next_good_one_is_taken() {
        let mut a = assembly(2, PoseTrack::None);
        scan(&mut a, 0, 100 * MS, 0).unwrap();
        let e = scan(&mut a, 0, 100 * MS, 0).unwrap_err();
        assert!(matches!(e, ScanRefusal::Stale { .. }), "{e}");
        let e = a.scan(0, "lidar_0".into(), 200 * MS, 1.0, fields(11), 0).unwrap_err();
        assert!(e.to_string().contains("11 ranges where the lidar's first scan had 21"), "{e}");
        let mut wrong = fields(21);
        wrong.angle_increment = 0.2;
        let e = a.scan(0, "lidar_0".into(), 200 * MS, 1.0, wrong, 0).unwrap_err();
        assert!(
            e.to_string().contains(
                "21 ranges where angle_min -1.0000, angle_max 1.0000 and angle_increment 0.200000 rad make 11"
            ),
            "{e}"
        );
        let e = a.scan(1, "lidar_9".into(), 200 * MS, 1.0, fields(21), 0).unwrap_err();
        assert!(e.to_string().contains("no mount for frame 'lidar_9'"), "{e}");
        let mut nan = fields(21);
        nan.range_min = f32::NAN;
        assert!(matches!(a.scan(0, "lidar_0".into(), 200 * MS, 1.0, nan, 0).unwrap_err(), ScanRefusal::Invalid(_)));
        scan(&mut a, 0, 300 * MS, 0).unwrap();
        let c = &a.counts;
        assert_eq!(
            (c.scans, c.scans_stale, c.scans_wrong_size, c.scans_without_mount, c.scans_invalid),
            (2, 1, 2, 1, 1)
        );
    }

    #[test]
    fn the_queue_is_bounded_and_a_run_of_stale_scans_is_a_time_jump() {
        let mut a = assembly(1, PoseTrack::None);
        for k in 1..=10 {
            scan(&mut a, 0, k * 100 * MS, 0).unwrap();
        }
        // One lidar: each scan is a whole step at once; four wait, the six oldest were dropped.
        assert_eq!(a.waiting(), 4);
        assert_eq!(a.counts.steps_dropped_behind, 6);
        for k in 0..JUMP_AFTER_STALE {
            assert!(!a.time_jumped_back());
            scan(&mut a, 0, u64::from(k) * MS, 0).unwrap_err();
        }
        assert!(a.time_jumped_back());
        a.restart_time();
        assert_eq!(a.waiting(), 0);
        scan(&mut a, 0, MS, 0).unwrap();
        assert_eq!(a.odometry.push(5, Pose2::IDENTITY), Ok(()));
        assert_eq!(a.odometry(4, Pose2::IDENTITY), Err(5));
        assert_eq!(a.counts.samples_out_of_order, 1);
    }

    #[test]
    fn map_to_odom_composes_with_the_odometry_at_the_step() {
        let mut a = assembly(1, PoseTrack::MapOdom);
        a.pose(0, Pose2::new(10.0, 0.0, std::f64::consts::FRAC_PI_2)).unwrap();
        a.odometry(100 * MS, Pose2::new(1.0, 0.0, 0.0)).unwrap();
        scan(&mut a, 0, 100 * MS, 0).unwrap();
        let p = a.next_step(1).unwrap().pose.unwrap();
        assert!((p.x - 10.0).abs() < 1e-12 && (p.y - 1.0).abs() < 1e-12, "{p:?}");
    }
}
