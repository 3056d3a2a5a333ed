//! One scan and one mount as the estimators see them: the conversion every reader and the live
//! node share (`RawScan::from_ros`, `RawScan::to_laser_scan`, the mount through the static
//! transforms).

use super::{RawScan, RawTransform};
use crate::ImportError;
use crate::rigid::Rigid3;
use mapkeeper_grid::Pose2;
use mapkeeper_sensor::{LaserScan, SweepTiming};
use std::collections::{BTreeMap, HashMap, VecDeque};
use std::path::Path;

/// The fields of a ROS `sensor_msgs/LaserScan` as the readers and the live node take them.
#[derive(Clone, Debug, PartialEq)]
pub struct RosScanFields {
    /// `angle_min`, radians.
    pub angle_min: f32,
    /// `angle_increment`, radians.
    pub angle_increment: f32,
    /// `time_increment`, seconds (0: unknown).
    pub time_increment: f32,
    /// `range_min`, metres.
    pub range_min: f32,
    /// `range_max`, metres (inclusive, as ROS has it).
    pub range_max: f32,
    /// `ranges`, metres.
    pub ranges: Vec<f32>,
}

impl RawScan {
    /// A ROS scan message's fields as a raw scan: the one conversion of the bag readers and the
    /// live node (`range_max` is inclusive in ROS, so the exclusive limit is the next float).
    pub fn from_ros(topic: &str, frame_id: String, stamp_ns: u64, f: RosScanFields, place: String) -> RawScan {
        RawScan {
            topic: topic.to_string(),
            frame_id,
            stamp_ns,
            angle_min_rad: f64::from(f.angle_min),
            angle_increment_rad: f64::from(f.angle_increment),
            range_min_m: f.range_min,
            range_max_m: f.range_max.next_up(),
            ranges_m: f.ranges,
            time_increment_s: f64::from(f.time_increment),
            place,
            record_ns: None,
        }
    }

    /// The scan as the estimators see it, for lidar `id` mounted at `mount` (mirrored: upside
    /// down), its stamp unchanged; the conversion the assembler applies to every scan of a log.
    pub fn to_laser_scan(self, id: u32, mount: Pose2, mirrored: bool) -> Result<LaserScan, String> {
        let mut untimed = BTreeMap::new();
        let place = self.place.clone();
        to_scan(Path::new(""), self, id, mount, mirrored, 0, &mut untimed).map_err(|e| match e {
            ImportError::Parse { message, .. } => message,
            other => format!("{place}: {other}"),
        })
    }
}

/// The mount of lidar frame `frame` in the base frame `base` through the static transforms
/// `edges` (each usable both ways): the planar pose, whether the lidar is upside down and its tilt
/// from level in degrees; `None` without a chain. The assembler's rule for `/tf_static`.
pub fn mount_from_transforms(edges: &[&RawTransform], base: &str, frame: &str) -> Option<(Pose2, bool, f64)> {
    chain(edges, base, frame).map(|r| r.planar())
}

pub(super) fn to_scan(
    path: &Path,
    s: RawScan,
    id: u32,
    mount: Pose2,
    mirrored: bool,
    epoch_ns: u64,
    untimed: &mut BTreeMap<String, (usize, String)>,
) -> Result<LaserScan, ImportError> {
    let n = s.ranges_m.len();
    let sweep = (s.time_increment_s != 0.0)
        .then_some(SweepTiming { first_beam_s: 0.0, time_increment_s: s.time_increment_s })
        .filter(|t| match t.check(n) {
            Ok(()) => true,
            Err(why) => {
                let e = untimed.entry(s.topic.clone()).or_insert((0, why.to_string()));
                e.0 += 1;
                false
            }
        });
    let (angle_min_rad, angle_increment_rad) =
        if mirrored { (-s.angle_min_rad, -s.angle_increment_rad) } else { (s.angle_min_rad, s.angle_increment_rad) };
    let scan = LaserScan {
        stamp_ns: s.stamp_ns - epoch_ns,
        lidar_id: id,
        lidar_in_robot: mount,
        angle_min_rad,
        angle_increment_rad,
        range_min_m: s.range_min_m,
        range_max_m: s.range_max_m,
        ranges_m: s.ranges_m,
        sweep,
    };
    scan.validate()
        .map_err(|e| ImportError::parse(path, format!("{} ({})", s.place, s.topic), format!("scan: {e}")))?;
    Ok(scan)
}

/// The transform of frame `to` in frame `from` through `edges` (each usable both ways), by a
/// breadth-first search; `None` without a path.
pub(super) fn chain(edges: &[&RawTransform], from: &str, to: &str) -> Option<Rigid3> {
    let mut seen: HashMap<&str, Rigid3> = HashMap::new();
    seen.insert(from, Rigid3::IDENTITY);
    let mut queue = VecDeque::from([from]);
    while let Some(f) = queue.pop_front() {
        let here = seen[f];
        if f == to {
            return Some(here);
        }
        for e in edges {
            let (next, step) = if e.parent == f {
                (e.child.as_str(), e.transform)
            } else if e.child == f {
                (e.parent.as_str(), e.transform.inverse())
            } else {
                continue;
            };
            if !seen.contains_key(next) {
                seen.insert(next, here.compose(&step));
                queue.push_back(next);
            }
        }
    }
    None
}
