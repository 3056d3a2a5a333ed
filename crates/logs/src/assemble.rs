//! From decoded messages to a sensor log: the part every reader shares.
//!
//! A reader decodes its file into [`RawScan`], [`RawOdometry`], [`RawTransform`] and
//! [`RawPose`] events, in file order, and hands them to an [`Assembler`]. The assembler picks
//! the lidars (by topic), finds each lidar's mount from the static transforms (or a mount the
//! reader knows, as CARMEN's `PARAM` lines give), projects a mount that is upside down or tilted
//! onto the plane, takes the odometry from a topic or from the `odom → base` transform, counts
//! and clamps timestamps that step back (to 1 ns after the stamp before), re-bases time on the log's first stamp and validates
//! every scan.

use crate::ImportError;
use crate::options::{ImportOptions, OdometryFrom, StampFrom, Thinning, TimeSource};
use crate::report::{BackwardSteps, ImportReport, LidarInfo, TopicCount};
use crate::rigid::Rigid3;
use crate::timing::StreamStamps;
use mapkeeper_grid::Pose2;
use mapkeeper_sensor::{LogRecord, OdometryReading, SensorLog, TruePose};
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};

/// One decoded laser scan (ROS `sensor_msgs/LaserScan` fields), stamped on the log's clock.
#[derive(Clone, Debug, PartialEq)]
pub struct RawScan {
    /// Topic (ROS) or message name (CARMEN `FLASER`).
    pub topic: String,
    /// The lidar's frame (`header.frame_id`).
    pub frame_id: String,
    /// Stamp, nanoseconds on the log's clock (absolute; the assembler re-bases it).
    pub stamp_ns: u64,
    /// First beam's angle in the lidar frame, radians.
    pub angle_min_rad: f64,
    /// Angle between beams, radians.
    pub angle_increment_rad: f64,
    /// Smallest valid range, metres.
    pub range_min_m: f32,
    /// Readings at or beyond this are invalid, metres (a ROS reader passes the next float above
    /// the message's inclusive `range_max`).
    pub range_max_m: f32,
    /// One reading per beam, metres.
    pub ranges_m: Vec<f32>,
    /// Time between beams, seconds, the first beam at the stamp (ROS `time_increment`); 0 when
    /// unknown (CARMEN).
    pub time_increment_s: f64,
    /// Where the message is in the file, for errors (`line 12`, `message 40`).
    pub place: String,
    /// When the recorder received it (a bag's record time, MCAP `log_time`), if the format says;
    /// used in place of the stamps when they cannot be trusted (`timing`).
    pub record_ns: Option<u64>,
}

/// One decoded odometry message (`nav_msgs/Odometry`, CARMEN `ODOM`) or a reference pose topic.
#[derive(Clone, Debug, PartialEq)]
pub struct RawOdometry {
    /// Topic or message name.
    pub topic: String,
    /// Stamp, nanoseconds on the log's clock.
    pub stamp_ns: u64,
    /// The base pose in the message's frame, projected on the plane.
    pub pose: Pose2,
    /// When the recorder received it (a bag's record time, MCAP `log_time`), if the format says;
    /// used in place of the stamps when they cannot be trusted (`timing`).
    pub record_ns: Option<u64>,
}

/// One transform of `/tf` or `/tf_static` (`geometry_msgs/TransformStamped`).
#[derive(Clone, Debug, PartialEq)]
pub struct RawTransform {
    /// Stamp, nanoseconds on the log's clock.
    pub stamp_ns: u64,
    /// Parent frame (`header.frame_id`).
    pub parent: String,
    /// Child frame (`child_frame_id`).
    pub child: String,
    /// The child frame in the parent frame.
    pub transform: Rigid3,
    /// Whether it came from `/tf_static`.
    pub is_static: bool,
    /// When the recorder received it (a bag's record time, MCAP `log_time`), if the format says;
    /// used in place of the stamps when they cannot be trusted (`timing`).
    pub record_ns: Option<u64>,
}

/// A reference pose in the map frame (CARMEN's corrected poses, a ground-truth topic).
#[derive(Clone, Debug, PartialEq)]
pub struct RawPose {
    /// Stamp, nanoseconds on the log's clock.
    pub stamp_ns: u64,
    /// The base pose in the map frame.
    pub pose: Pose2,
    /// When the recorder received it (a bag's record time, MCAP `log_time`), if the format says;
    /// used in place of the stamps when they cannot be trusted (`timing`).
    pub record_ns: Option<u64>,
}

/// The odometry source of an import whose odometry the caller makes from the scans, until it
/// does ([`OdometryFrom::Scans`]).
pub const SCANS_TO_COME: &str = "none read: to be made from the scans (--odometry-from-scans)";

/// Collects a reader's events and turns them into a [`SensorLog`] and an [`ImportReport`].
#[derive(Debug)]
pub struct Assembler {
    path: PathBuf,
    format: &'static str,
    scans: BTreeMap<String, Vec<RawScan>>,
    /// The topic of every scan, in arrival order (to regroup scans by frame).
    scan_order: Vec<String>,
    odometry: BTreeMap<String, Vec<RawOdometry>>,
    transforms: Vec<RawTransform>,
    truth: Vec<RawPose>,
    truth_source: Option<String>,
    mounts: HashMap<String, (Pose2, String)>,
    topics: BTreeMap<String, TopicCount>,
    notes: Vec<String>,
}

impl Assembler {
    /// An empty assembler for the file `path` of format `format` (named in the report).
    pub fn new(path: &Path, format: &'static str) -> Self {
        Self {
            path: path.to_path_buf(),
            format,
            scans: BTreeMap::new(),
            scan_order: Vec::new(),
            odometry: BTreeMap::new(),
            transforms: Vec::new(),
            truth: Vec::new(),
            truth_source: None,
            mounts: HashMap::new(),
            topics: BTreeMap::new(),
            notes: Vec::new(),
        }
    }

    /// Counts one message of `topic` with type `type_name`, used or not (the report lists every
    /// topic of the file).
    pub fn count_message(&mut self, topic: &str, type_name: &str) {
        let e = self
            .topics
            .entry(topic.to_string())
            .or_insert_with(|| TopicCount { type_name: type_name.to_string(), messages: 0 });
        e.messages += 1;
    }

    /// Adds a scan.
    pub fn scan(&mut self, scan: RawScan) {
        self.scan_order.push(scan.topic.clone());
        self.scans.entry(scan.topic.clone()).or_default().push(scan);
    }

    /// Adds an odometry message.
    pub fn odometry(&mut self, odom: RawOdometry) {
        self.odometry.entry(odom.topic.clone()).or_default().push(odom);
    }

    /// Adds a transform.
    pub fn transform(&mut self, tf: RawTransform) {
        self.transforms.push(tf);
    }

    /// Adds a reference pose; `source` names where the reference comes from (in the report).
    pub fn truth(&mut self, pose: RawPose, source: &str) {
        if self.truth_source.is_none() {
            self.truth_source = Some(source.to_string());
        }
        self.truth.push(pose);
    }

    /// Gives the mount of lidar frame `frame_id` in the base frame directly (for formats without
    /// transforms); `source` says where it comes from.
    pub fn known_mount(&mut self, frame_id: &str, mount: Pose2, source: &str) {
        self.mounts.insert(frame_id.to_string(), (mount, source.to_string()));
    }

    /// Whether a mount for `frame_id` was given with [`Assembler::known_mount`].
    pub fn has_mount(&self, frame_id: &str) -> bool {
        self.mounts.contains_key(frame_id)
    }

    /// Adds a free-form note to the report (a skipped message type, a field ignored).
    pub fn note(&mut self, note: impl Into<String>) {
        self.notes.push(note.into());
    }

    /// Builds the sensor log.
    pub fn finish(mut self, options: &ImportOptions) -> Result<(SensorLog, ImportReport), ImportError> {
        self.check_options(options)?;
        self.settle_time(options)?;
        let (mut lidars, mut scan_records, mut backward) = self.lidar_streams(options)?;
        let (odom_source, mut odom) = self.odometry_track(options)?;
        backward.extend(clamp_track(&odom_source, &mut odom));
        let mut truth: Vec<(u64, Pose2)> =
            std::mem::take(&mut self.truth).into_iter().map(|p| (p.stamp_ns, p.pose)).collect();
        let truth_source = self.truth_source.clone();
        if let Some(src) = &truth_source {
            backward.extend(clamp_track(src, &mut truth));
        }
        for (stream, track) in [(Some(&odom_source), &odom), (truth_source.as_ref(), &truth)] {
            check_finite(&self.path, stream.map_or("?", String::as_str), track)?;
        }
        if options.thinning != Thinning::All {
            let before: usize = scan_records.iter().map(|r| r.3.len()).sum();
            for (r, info) in scan_records.iter_mut().zip(lidars.iter_mut()) {
                thin(&mut r.3, &odom, options.thinning);
                info.scans = r.3.len();
            }
            let after: usize = scan_records.iter().map(|r| r.3.len()).sum();
            self.notes.push(thinning_note(options.thinning, before, after));
        }
        let firsts = scan_records
            .iter()
            .filter_map(|r| r.3.first().map(|s| s.stamp_ns))
            .chain(odom.first().map(|o| o.0))
            .chain(truth.first().map(|p| p.0));
        let epoch_ns = firsts.min().unwrap_or(0);
        let mut records: Vec<(u64, u8, u32, LogRecord)> = Vec::new();
        for (t, pose) in &odom {
            let o = OdometryReading { stamp_ns: t - epoch_ns, pose_in_odom: *pose };
            records.push((o.stamp_ns, 0, 0, LogRecord::Odom(o)));
        }
        for (t, pose) in &truth {
            let p = TruePose { stamp_ns: t - epoch_ns, pose_in_map: *pose };
            records.push((p.stamp_ns, 1, 0, LogRecord::Truth(p)));
        }
        let n_scans: usize = scan_records.iter().map(|r| r.3.len()).sum();
        let (mut timed, mut untimed) = (0usize, BTreeMap::<String, (usize, String)>::new());
        for (id, mount, mirrored, scans) in scan_records {
            for s in scans {
                let scan = to_scan(&self.path, s, id, mount, mirrored, epoch_ns, &mut untimed)?;
                timed += usize::from(scan.sweep.is_some());
                records.push((scan.stamp_ns, 2, id, LogRecord::Scan(scan)));
            }
        }
        if timed > 0 {
            self.notes.push(format!(
                "{timed} scans carry a time_increment: each beam's time is known, and the estimators deskew them \
by the odometry over the sweep (docs/real-data.md)"
            ));
        }
        for (topic, (count, why)) in untimed {
            self.notes.push(format!("{topic}: the time_increment of {count} scans is ignored: {why}"));
        }
        records.sort_by_key(|r| (r.0, r.1, r.2));
        let duration_s = records.last().map_or(0.0, |r| r.0 as f64 * 1e-9);
        let report = ImportReport {
            source: self.path.display().to_string(),
            format: self.format.to_string(),
            epoch_ns,
            duration_s,
            scans: n_scans,
            odometry_source: odom_source,
            odometry_messages: odom.len(),
            scan_odometry: None,
            truth_source,
            truth_poses: truth.len(),
            lidars,
            backward_steps: backward,
            topics: self.topics,
            notes: self.notes,
        };
        let log = SensorLog { header: report.log_header(), records: records.into_iter().map(|r| r.3).collect() };
        Ok((log, report))
    }

    /// Refuses a thinning that cannot be used, alone or with where the odometry comes from.
    fn check_options(&self, options: &ImportOptions) -> Result<(), ImportError> {
        if let Some(problem) = options.thinning.problem() {
            return Err(ImportError::unusable(&self.path, format!("thinning {:?}: {problem}", options.thinning)));
        }
        if options.odometry == OdometryFrom::Scans && matches!(options.thinning, Thinning::EveryMetres(_)) {
            return Err(ImportError::unusable(
                &self.path,
                "--every-m thins the scans by the odometry's travel, and --odometry-from-scans makes the odometry from \
the scans after the import: thin with --keep-every instead",
            ));
        }
        Ok(())
    }

    /// The chosen lidars: their report entries, (id, mount, mirrored, scans with clamped
    /// stamps), and the streams whose stamps stepped back.
    #[allow(clippy::type_complexity)]
    fn lidar_streams(
        &mut self,
        options: &ImportOptions,
    ) -> Result<(Vec<LidarInfo>, Vec<(u32, Pose2, bool, Vec<RawScan>)>, Vec<BackwardSteps>), ImportError> {
        let scan_topics = if options.scan_frames.is_empty() {
            self.select_scan_topics(options)?
        } else {
            self.regroup_by_frame(&options.scan_frames)?
        };
        let (mut lidars, mut streams, mut backward) = (Vec::new(), Vec::new(), Vec::new());
        for (id, stream) in scan_topics.iter().enumerate() {
            let mut scans = self.scans.remove(stream).unwrap_or_default();
            let topic = &scans[0].topic.clone();
            let frame = scans[0].frame_id.clone();
            let (mount, mount_source, mirrored, tilt_deg) = self.mount_of(&frame, options)?;
            let mut stamps: Vec<u64> = scans.iter().map(|s| s.stamp_ns).collect();
            backward.extend(clamp_backward(stream, &mut stamps));
            for (s, t) in scans.iter_mut().zip(stamps) {
                s.stamp_ns = t;
            }
            lidars.push(LidarInfo {
                id: id as u32,
                topic: topic.clone(),
                frame_id: frame,
                mount,
                mount_source,
                mirrored,
                tilt_deg,
                scans: scans.len(),
                beams: scans[0].ranges_m.len(),
            });
            streams.push((id as u32, mount, mirrored, scans));
        }
        Ok((lidars, streams, backward))
    }

    /// Regroups the scans by frame: one stream (`frame <f>`) per frame of `frames`, from any
    /// topic, in arrival order; returns the stream names in lidar-id order.
    fn regroup_by_frame(&mut self, frames: &[String]) -> Result<Vec<String>, ImportError> {
        let mut by_topic: BTreeMap<String, std::vec::IntoIter<RawScan>> =
            std::mem::take(&mut self.scans).into_iter().map(|(t, v)| (t, v.into_iter())).collect();
        let mut regrouped: BTreeMap<String, Vec<RawScan>> = BTreeMap::new();
        let mut seen_frames = BTreeSet::new();
        for topic in &self.scan_order {
            let Some(s) = by_topic.get_mut(topic).and_then(Iterator::next) else { continue };
            seen_frames.insert(s.frame_id.clone());
            if frames.contains(&s.frame_id) {
                regrouped.entry(format!("frame {}", s.frame_id)).or_default().push(s);
            }
        }
        let mut names = Vec::new();
        for f in frames {
            let name = format!("frame {f}");
            if !regrouped.contains_key(&name) {
                return Err(ImportError::unusable(
                    &self.path,
                    format!(
                        "scan frame '{f}' has no laser scans; the log's scan frames: [{}]",
                        seen_frames.iter().cloned().collect::<Vec<_>>().join(", ")
                    ),
                ));
            }
            if names.contains(&name) {
                return Err(ImportError::unusable(&self.path, format!("scan frame '{f}' is named twice")));
            }
            names.push(name);
        }
        self.scans = regrouped;
        Ok(names)
    }

    fn select_scan_topics(&self, options: &ImportOptions) -> Result<Vec<String>, ImportError> {
        let available: Vec<&String> = self.scans.keys().collect();
        if available.is_empty() {
            let topics: Vec<String> =
                self.topics.iter().map(|(t, c)| format!("{t} ({}, {})", c.type_name, c.messages)).collect();
            return Err(ImportError::unusable(
                &self.path,
                format!("no laser scans in the log; its topics: [{}]", topics.join(", ")),
            ));
        }
        if options.scan_topics.is_empty() {
            return Ok(available.into_iter().cloned().collect());
        }
        let mut seen = BTreeSet::new();
        for t in &options.scan_topics {
            if !self.scans.contains_key(t) {
                return Err(ImportError::unusable(
                    &self.path,
                    format!(
                        "scan topic '{t}' has no laser scans; the log's scan topics: [{}]",
                        available.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
                    ),
                ));
            }
            if !seen.insert(t) {
                return Err(ImportError::unusable(&self.path, format!("scan topic '{t}' is named twice")));
            }
        }
        Ok(options.scan_topics.clone())
    }

    /// The lidar's mount in the base frame, where it came from, whether the scan is mirrored
    /// (the lidar upside down) and its tilt from level, degrees.
    fn mount_of(&self, frame: &str, options: &ImportOptions) -> Result<(Pose2, String, bool, f64), ImportError> {
        if let Some((m, src)) = self.mounts.get(frame) {
            return Ok((*m, src.clone(), false, 0.0));
        }
        if frame == options.base_frame {
            return Ok((Pose2::IDENTITY, format!("the lidar frame is the base frame '{frame}'"), false, 0.0));
        }
        let static_edges: Vec<&RawTransform> = self.transforms.iter().filter(|t| t.is_static).collect();
        let (rigid, source) = match chain(&static_edges, &options.base_frame, frame) {
            Some(r) => (r, format!("/tf_static {} -> {frame}", options.base_frame)),
            None => {
                // Fixed mounts published on /tf (older ROS 1 drivers): the first transform of
                // each edge other than the odometry's.
                let mut firsts: Vec<&RawTransform> = Vec::new();
                for t in self.transforms.iter().filter(|t| !t.is_static) {
                    let odom_edge = t.parent == options.odom_frame && t.child == options.base_frame;
                    if !odom_edge && !firsts.iter().any(|f| f.parent == t.parent && f.child == t.child) {
                        firsts.push(t);
                    }
                }
                let r = chain(&firsts, &options.base_frame, frame).ok_or_else(|| {
                    ImportError::unusable(
                        &self.path,
                        format!(
                            "no transform from the base frame '{}' to the lidar frame '{frame}' in /tf_static or /tf \
(set the base frame with --base-frame, or record the robot's static transforms)",
                            options.base_frame
                        ),
                    )
                })?;
                (r, format!("/tf (first transform) {} -> {frame}", options.base_frame))
            }
        };
        let (mount, mirrored, tilt_deg) = rigid.planar();
        Ok((mount, source, mirrored, tilt_deg))
    }

    /// The odometry track: its name and (stamp, pose) in file order.
    fn odometry_track(&mut self, options: &ImportOptions) -> Result<(String, Vec<(u64, Pose2)>), ImportError> {
        let from_topic = |me: &mut Self, topic: &str| {
            me.odometry.remove(topic).map(|v| v.into_iter().map(|o| (o.stamp_ns, o.pose)).collect())
        };
        let from_tf = |me: &Self| -> Vec<(u64, Pose2)> {
            me.transforms
                .iter()
                .filter(|t| !t.is_static && t.parent == options.odom_frame && t.child == options.base_frame)
                .map(|t| (t.stamp_ns, t.transform.planar().0))
                .collect()
        };
        let tf_name = format!("/tf {} -> {}", options.odom_frame, options.base_frame);
        let make_it = "or make it from the scans with `mapkeeper convert --odometry-from-scans`";
        match &options.odometry {
            OdometryFrom::Scans => {
                let tf = from_tf(self).len();
                let mut held: Vec<String> =
                    self.odometry.iter().map(|(t, v)| format!("{} readings of {t}", v.len())).collect();
                if tf > 0 {
                    held.push(format!("{tf} transforms {tf_name}"));
                }
                if !held.is_empty() {
                    self.notes.push(format!(
                        "the log's own odometry ({}) is not used: --odometry-from-scans replaces it",
                        held.join(", ")
                    ));
                }
                self.odometry.clear();
                Ok((SCANS_TO_COME.to_string(), Vec::new()))
            }
            OdometryFrom::Topic(topic) => match from_topic(self, topic) {
                Some(v) => Ok((topic.clone(), v)),
                None => Err(ImportError::unusable(
                    &self.path,
                    format!(
                        "odometry topic '{topic}' has no odometry messages; odometry topics: [{}] ({make_it})",
                        self.odometry_topics()
                    ),
                )),
            },
            OdometryFrom::Tf => {
                let v = from_tf(self);
                if v.is_empty() {
                    return Err(ImportError::unusable(
                        &self.path,
                        format!("no transforms {tf_name} in the log ({make_it})"),
                    ));
                }
                Ok((tf_name, v))
            }
            OdometryFrom::Auto => {
                if let Some(v) = from_topic(self, "/odom") {
                    return Ok(("/odom".into(), v));
                }
                if self.odometry.len() == 1 {
                    let topic = self.odometry.keys().next().cloned().unwrap_or_default();
                    if let Some(v) = from_topic(self, &topic) {
                        return Ok((topic, v));
                    }
                }
                let v = from_tf(self);
                if !v.is_empty() {
                    return Ok((tf_name, v));
                }
                Err(ImportError::unusable(
                    &self.path,
                    format!(
                        "no odometry: no topic '/odom', {} odometry topics [{}] (choose one with --odom-topic), and no \
{tf_name} (set the frames with --odom-frame and --base-frame), {make_it}",
                        self.odometry.len(),
                        self.odometry_topics()
                    ),
                ))
            }
        }
    }

    /// Where the header stamps of a bag cannot be trusted (`timing::StreamStamps`: many repeats
    /// or steps back in a stream) or `--time-source line` is asked for, every message is stamped
    /// with its record time instead (when the recorder received it: the file's order), with a
    /// note. CARMEN logs have no record times and settle their own times before they come here.
    fn settle_time(&mut self, options: &ImportOptions) -> Result<(), ImportError> {
        if options.stamp == StampFrom::Record || self.format == "carmen" {
            return Ok(());
        }
        let reasons: Vec<String> = self
            .stamp_streams(options)
            .iter()
            .filter_map(|(name, v)| StreamStamps::of(name, v, &[], |i| format!("message {}", i + 1)).distrust())
            .collect();
        let has_record = self.scans.values().flatten().all(|s| s.record_ns.is_some())
            && self.odometry.values().flatten().all(|o| o.record_ns.is_some())
            && self.transforms.iter().all(|t| t.is_static || t.record_ns.is_some())
            && self.truth.iter().all(|p| p.record_ns.is_some());
        let why = match options.time_source {
            TimeSource::Stamp | TimeSource::Auto if reasons.is_empty() => return Ok(()),
            TimeSource::Stamp => {
                self.notes.push(format!(
                    "header stamps taken as written (--time-source stamp) though they cannot order the messages \
({}): scans and odometry may be paired wrongly",
                    reasons.join("; ")
                ));
                return Ok(());
            }
            TimeSource::Line if reasons.is_empty() => "--time-source line".to_string(),
            TimeSource::Auto | TimeSource::Line => reasons.join("; "),
        };
        if !has_record {
            return Err(ImportError::unusable(
                &self.path,
                format!(
                    "the header stamps cannot order the messages ({why}), and the file has no record times to order \
them by instead: take the stamps as written with --time-source stamp"
                ),
            ));
        }
        let record = |r: Option<u64>, t: u64| r.unwrap_or(t);
        for s in self.scans.values_mut().flatten() {
            s.stamp_ns = record(s.record_ns, s.stamp_ns);
        }
        for o in self.odometry.values_mut().flatten() {
            o.stamp_ns = record(o.record_ns, o.stamp_ns);
        }
        for t in self.transforms.iter_mut().filter(|t| !t.is_static) {
            t.stamp_ns = record(t.record_ns, t.stamp_ns);
        }
        for p in &mut self.truth {
            p.stamp_ns = record(p.record_ns, p.stamp_ns);
        }
        if options.rate_hz.is_some() {
            self.notes.push("--rate is not used: a bag's messages are timed by their record times".into());
        }
        self.notes.push(format!(
            "header stamps not used ({why}): every message is stamped with its record time (when the recorder \
received it), as --stamp record does"
        ));
        Ok(())
    }

    /// The header stamps, in file order, of every stream the import may use: the scan topics
    /// asked for (else all), the odometry topic asked for (else all), the `odom → base` edge of
    /// `/tf`, the reference. A stream the import does not read cannot re-time the log.
    fn stamp_streams(&self, options: &ImportOptions) -> Vec<(String, Vec<u64>)> {
        let mut streams: Vec<(String, Vec<u64>)> = Vec::new();
        let scan_used = |t: &str| options.scan_topics.is_empty() || options.scan_topics.iter().any(|s| s == t);
        for (topic, v) in self.scans.iter().filter(|(t, _)| scan_used(t)) {
            streams.push((topic.clone(), v.iter().map(|s| s.stamp_ns).collect()));
        }
        let odom_used = |t: &str| match &options.odometry {
            OdometryFrom::Topic(o) => o == t,
            OdometryFrom::Auto => true,
            OdometryFrom::Tf | OdometryFrom::Scans => false,
        };
        for (topic, v) in self.odometry.iter().filter(|(t, _)| odom_used(t)) {
            streams.push((topic.clone(), v.iter().map(|o| o.stamp_ns).collect()));
        }
        let odom_edge: Vec<u64> = self
            .transforms
            .iter()
            .filter(|t| !t.is_static && t.parent == options.odom_frame && t.child == options.base_frame)
            .map(|t| t.stamp_ns)
            .collect();
        if !odom_edge.is_empty() && options.odometry != OdometryFrom::Scans {
            streams.push((format!("/tf {} -> {}", options.odom_frame, options.base_frame), odom_edge));
        }
        if let Some(src) = &self.truth_source {
            streams.push((src.clone(), self.truth.iter().map(|p| p.stamp_ns).collect()));
        }
        streams
    }

    fn odometry_topics(&self) -> String {
        self.odometry.keys().cloned().collect::<Vec<_>>().join(", ")
    }
}

/// A pose the reader took as written (a corrected CARMEN pose of 1e308, odometry chained from
/// such poses or from /tf) must still be a pose: ±inf or NaN would reach every estimator. The
/// JSONL reader refuses the same (mapkeeper_sensor::log).
fn check_finite(path: &Path, stream: &str, track: &[(u64, Pose2)]) -> Result<(), ImportError> {
    match track.iter().enumerate().find(|(_, (_, p))| !p.is_finite()) {
        Some((i, (t, pose))) => Err(ImportError::parse(
            path,
            format!("{stream}, reading {} (stamp {t} ns)", i + 1),
            format!("the pose is not finite ({}, {}, {}): not a pose an estimator can use", pose.x, pose.y, pose.yaw),
        )),
        None => Ok(()),
    }
}

/// Moves stamps that step back to 1 ns after the stamp before, in place (so the order of the
/// file is kept and no two messages of the stream share a stamp they did not have: a scan and
/// its odometry reading, clamped alike, stay paired); reports how many and the largest step.
fn clamp_backward(stream: &str, stamps: &mut [u64]) -> Option<BackwardSteps> {
    let (mut count, mut largest) = (0usize, 0u64);
    for i in 1..stamps.len() {
        if stamps[i] < stamps[i - 1] {
            count += 1;
            largest = largest.max(stamps[i - 1] - stamps[i]);
            stamps[i] = stamps[i - 1].saturating_add(1);
        }
    }
    (count > 0).then(|| BackwardSteps { stream: stream.to_string(), count, largest_s: largest as f64 * 1e-9 })
}

/// The import report's note on a thinning (the flag it comes from, with its value).
fn thinning_note(t: Thinning, before: usize, after: usize) -> String {
    let flag = match t {
        Thinning::All => "every scan".into(),
        Thinning::KeepEvery(n) => format!("--keep-every {n}"),
        Thinning::EveryMetres(m) => format!("--every-m {m}"),
    };
    format!("{flag}: {after} of {before} scans kept (odometry and reference all kept)")
}

/// Keeps the scans of one lidar (stamps in order) that `thinning` asks for; `odom` is the
/// odometry track, whose path length up to a scan's stamp is the travel `EveryMetres` counts.
fn thin(scans: &mut Vec<RawScan>, odom: &[(u64, Pose2)], thinning: Thinning) {
    match thinning {
        Thinning::All => {}
        Thinning::KeepEvery(n) => {
            let mut k = 0usize;
            scans.retain(|_| {
                k += 1;
                (k - 1).is_multiple_of(n.max(1))
            });
        }
        Thinning::EveryMetres(m) => {
            let along = path_length_at(odom);
            let mut last: Option<f64> = None;
            scans.retain(|s| {
                let d = along(s.stamp_ns);
                let keep = last.is_none_or(|l| d - l >= m);
                if keep {
                    last = Some(d);
                }
                keep
            });
        }
    }
}

/// The odometry's path length at a stamp, metres: its readings up to it, then the stretch to the
/// pose interpolated at the stamp (0 before the first reading).
fn path_length_at(odom: &[(u64, Pose2)]) -> impl Fn(u64) -> f64 + '_ {
    let step = |i: usize| {
        let (p, q) = (odom[i].1, odom[i - 1].1);
        (p.x - q.x).hypot(p.y - q.y)
    };
    let mut cumulative = Vec::with_capacity(odom.len());
    let mut total = 0.0;
    for i in 0..odom.len() {
        if i > 0 {
            total += step(i);
        }
        cumulative.push(total);
    }
    move |t: u64| {
        let i = odom.partition_point(|(s, _)| *s <= t);
        if i == 0 {
            return 0.0;
        }
        let t0 = odom[i - 1].0;
        match odom.get(i) {
            Some(&(t1, _)) if t1 > t0 => cumulative[i - 1] + (t - t0) as f64 / (t1 - t0) as f64 * step(i),
            _ => cumulative[i - 1],
        }
    }
}

/// [`clamp_backward`] on a track of stamped poses.
fn clamp_track(stream: &str, track: &mut [(u64, Pose2)]) -> Option<BackwardSteps> {
    let mut stamps: Vec<u64> = track.iter().map(|p| p.0).collect();
    let b = clamp_backward(stream, &mut stamps);
    for (p, t) in track.iter_mut().zip(stamps) {
        p.0 = t;
    }
    b
}

mod convert;

pub use convert::{RosScanFields, mount_from_transforms};
use convert::{chain, to_scan};

#[cfg(test)]
mod tests;
