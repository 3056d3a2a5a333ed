//! The node's parameter file: YAML in ROS conventions (`<node name>: ros__parameters: {...}`),
//! every value validated, each refusal one line naming the file, the parameter and the problem.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Where the robot pose the updater is given comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PoseFrom {
    /// The node's own localiser on the map being updated (it publishes `map → odom` on `/tf`,
    /// as AMCL does).
    Localiser,
    /// The robot's localiser's pose topic (`geometry_msgs/PoseWithCovarianceStamped`, as AMCL's
    /// `/amcl_pose`), interpolated at each step's stamp.
    PoseTopic,
    /// The robot's localiser's `map → odom` transform on `/tf`, composed with the odometry.
    Tf,
}

/// Reliability of the sensor subscriptions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reliability {
    /// Reliable (matches reliable and best-effort... only reliable publishers).
    Reliable,
    /// Best effort (matches every publisher: the sensor-data QoS of ROS 2 drivers).
    BestEffort,
}

/// How the `save_map` service's requests and replies are laid out on DDS: ROS 2's RMWs differ.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ServiceLayout {
    /// The request's identity in the sample's metadata (Fast DDS, ROS 2's default RMW; RTI
    /// Connext): DDS-RPC's enhanced mapping.
    Enhanced,
    /// The identity as a header inside the sample (rmw_cyclonedds).
    Cyclone,
    /// DDS-RPC's basic mapping.
    Basic,
}

/// The node's parameters (`ros__parameters`); defaults in [`NodeParams::default`], documented in
/// `docs/ros2.md`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NodeParams {
    /// The map to start from (map_server YAML), relative to the parameter file's folder.
    pub map: String,
    /// The updater preset.
    pub preset: String,
    /// A TOML file overriding fields of the preset ("" none).
    pub updater_params: String,
    /// Where the pose comes from.
    pub pose_source: PoseFrom,
    /// With `pose_source: localiser`: the localiser preset.
    pub localiser_preset: String,
    /// With `pose_source: localiser`: a TOML file overriding fields of it ("" none).
    pub localiser_params: String,
    /// With `pose_source: localiser`: the initial pose `[x, y, yaw]` (empty: wait for
    /// `/initialpose`, or start globally with `global_start`).
    pub initial_pose: Vec<f64>,
    /// With `pose_source: localiser` and no initial pose: start the filter over the whole map.
    pub global_start: bool,
    /// The localiser's seed.
    pub seed: u64,
    /// The lidars' `sensor_msgs/LaserScan` topics, in lidar order.
    pub scan_topics: Vec<String>,
    /// The odometry topic (`nav_msgs/Odometry`); "" takes `odom → base` from `/tf`.
    pub odom_topic: String,
    /// With `pose_source: pose_topic`: the pose topic.
    pub pose_topic: String,
    /// The map frame.
    pub map_frame: String,
    /// The odometry frame.
    pub odom_frame: String,
    /// The robot's base frame.
    pub base_frame: String,
    /// Lidar mounts given here rather than by `/tf_static`: frame → `[x, y, yaw]` in the base
    /// frame (a robot file's figures).
    pub lidar_mounts: BTreeMap<String, Vec<f64>>,
    /// Take time from `/clock`.
    pub use_sim_time: bool,
    /// Scans of different lidars within this of a step's first scan form one step, seconds
    /// (`mapkeeper update`'s default).
    pub sync_window_s: f64,
    /// How long a step waits for the odometry and pose that bracket its stamp, seconds.
    pub max_wait_s: f64,
    /// Steps waiting to be processed before the oldest is dropped (and counted).
    pub queue_limit: usize,
    /// The full map's topic (reliable, transient local, as map_server).
    pub map_topic: String,
    /// The partial updates' topic (`map_msgs/OccupancyGridUpdate`).
    pub map_updates_topic: String,
    /// A latched `std_msgs/Header` stamped before each grid change (Nav2's static layer
    /// `source_ready_topic`); "" none.
    pub barrier_topic: String,
    /// Publish a pose that pose updating recovers on `/initialpose` (re-seeding the robot's
    /// AMCL, as the paper's robot was); with `pose_source: localiser` the node re-seeds its own.
    pub publish_initialpose: bool,
    /// The full map is republished at most this often while it changes, seconds.
    pub map_publish_period_s: f64,
    /// Folder of the saved map, its memory and the node's figures ("" no saving).
    pub save_dir: String,
    /// Save every this many seconds while the map changes (0: only on request and at exit).
    pub save_period_s: f64,
    /// At start, continue from the map and memory saved in `save_dir` when there are some.
    pub resume: bool,
    /// The DDS domain.
    pub domain_id: u16,
    /// Network interfaces (their IPv4 addresses) DDS may use; empty: all.
    pub interfaces: Vec<String>,
    /// Reliability of the scan and odometry subscriptions.
    pub sensor_reliability: Reliability,
    /// The `/<node name>/save_map` service's layout on DDS, as the callers' RMW has it.
    pub service_layout: ServiceLayout,
}

impl Default for NodeParams {
    fn default() -> Self {
        NodeParams {
            map: String::new(),
            preset: "mapkeeper".into(),
            updater_params: String::new(),
            pose_source: PoseFrom::Localiser,
            localiser_preset: "mapkeeper-real".into(),
            localiser_params: String::new(),
            initial_pose: Vec::new(),
            global_start: false,
            seed: 1,
            scan_topics: vec!["/scan".into()],
            odom_topic: "/odom".into(),
            pose_topic: "/amcl_pose".into(),
            map_frame: "map".into(),
            odom_frame: "odom".into(),
            base_frame: "base_link".into(),
            lidar_mounts: BTreeMap::new(),
            use_sim_time: false,
            sync_window_s: 0.05,
            max_wait_s: 0.5,
            queue_limit: 4,
            map_topic: "/map".into(),
            map_updates_topic: "/map_updates".into(),
            barrier_topic: String::new(),
            publish_initialpose: true,
            map_publish_period_s: 5.0,
            save_dir: String::new(),
            save_period_s: 30.0,
            resume: true,
            domain_id: 0,
            interfaces: Vec::new(),
            sensor_reliability: Reliability::BestEffort,
            service_layout: ServiceLayout::Enhanced,
        }
    }
}

/// A parameter file that cannot be used.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct ConfigError {
    /// The file.
    pub path: PathBuf,
    /// Where and what.
    pub message: String,
}

/// The node's configuration: its name, its parameters, the folder relative paths start from.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeConfig {
    /// The node's name (the file's top-level key).
    pub name: String,
    /// The parameters.
    pub params: NodeParams,
    /// The parameter file's folder.
    pub base_dir: PathBuf,
}

impl NodeConfig {
    /// Reads and validates `path`.
    pub fn load(path: &Path) -> Result<NodeConfig, ConfigError> {
        let bad = |message: String| ConfigError { path: path.to_path_buf(), message };
        let text = std::fs::read_to_string(path).map_err(|e| bad(format!("cannot read: {e}")))?;
        let base_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        NodeConfig::parse(&text, base_dir).map_err(bad)
    }

    /// Parses and validates a parameter file's text; errors without the file name.
    pub fn parse(text: &str, base_dir: PathBuf) -> Result<NodeConfig, String> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Node {
            #[serde(rename = "ros__parameters")]
            params: NodeParams,
        }
        let top: BTreeMap<String, Node> =
            serde_saphyr::from_str(text).map_err(|e| one_line(&format!("not a ROS parameter file: {e}")))?;
        let mut nodes = top.into_iter();
        let (name, node) = nodes.next().ok_or("no node: the file must be `<node name>: ros__parameters: {...}`")?;
        if let Some((other, _)) = nodes.next() {
            return Err(format!("parameters for two nodes ('{name}' and '{other}'): give one"));
        }
        if name.is_empty()
            || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            || name.starts_with(|c: char| c.is_ascii_digit())
        {
            return Err(format!("node name '{name}': letters, digits and '_', not starting with a digit"));
        }
        node.params.validate().map_err(|e| format!("{name}.ros__parameters.{e}"))?;
        Ok(NodeConfig { name, params: node.params, base_dir })
    }

    /// A path parameter resolved against the parameter file's folder; `None` for "".
    pub fn resolve(&self, p: &str) -> Option<PathBuf> {
        (!p.is_empty()).then(|| self.base_dir.join(p))
    }
}

fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

fn topic(name: &str, v: &str, may_be_empty: bool) -> Result<(), String> {
    if v.is_empty() && may_be_empty {
        return Ok(());
    }
    let ok = v.starts_with('/')
        && v.len() > 1
        && !v.ends_with('/')
        && !v.contains("//")
        && v[1..].split('/').all(|p| {
            p.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') && !p.starts_with(|c: char| c.is_ascii_digit())
        });
    if ok { Ok(()) } else { Err(format!("{name}: '{v}' is not an absolute ROS topic name (/a/b_c)")) }
}

fn frame(name: &str, v: &str) -> Result<(), String> {
    if v.is_empty() || v.starts_with('/') || v.contains(char::is_whitespace) {
        return Err(format!("{name}: '{v}' is not a frame id (non-empty, no leading '/', no spaces)"));
    }
    Ok(())
}

fn positive(name: &str, v: f64, max: f64) -> Result<(), String> {
    if v.is_finite() && v > 0.0 && v <= max { Ok(()) } else { Err(format!("{name}: {v} must lie in (0, {max}]")) }
}

fn pose3(name: &str, v: &[f64]) -> Result<(), String> {
    if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
        return Err(format!("{name}: {v:?} must be [x, y, yaw], three finite numbers"));
    }
    Ok(())
}

impl NodeParams {
    /// Checks every value; the error names the parameter.
    pub fn validate(&self) -> Result<(), String> {
        if self.map.is_empty() {
            return Err("map: missing: the map to start from (map_server YAML)".into());
        }
        if !mapkeeper_updater::PRESET_NAMES.contains(&self.preset.as_str()) {
            return Err(format!(
                "preset: '{}' is not one of {}",
                self.preset,
                mapkeeper_updater::PRESET_NAMES.join(", ")
            ));
        }
        if mapkeeper_localiser::FilterParams::preset(&self.localiser_preset).is_err() {
            return Err(format!(
                "localiser_preset: '{}' is not one of {}",
                self.localiser_preset,
                mapkeeper_localiser::LOCALISER_PRESETS.join(", ")
            ));
        }
        if !self.initial_pose.is_empty() {
            pose3("initial_pose", &self.initial_pose)?;
        }
        if self.scan_topics.is_empty() || self.scan_topics.len() > 8 {
            return Err(format!("scan_topics: {} topics: give 1 to 8", self.scan_topics.len()));
        }
        for (k, t) in self.scan_topics.iter().enumerate() {
            topic(&format!("scan_topics[{k}]"), t, false)?;
            if self.scan_topics[..k].contains(t) {
                return Err(format!("scan_topics[{k}]: '{t}' is named twice"));
            }
        }
        topic("odom_topic", &self.odom_topic, true)?;
        topic("pose_topic", &self.pose_topic, self.pose_source != PoseFrom::PoseTopic)?;
        topic("map_topic", &self.map_topic, false)?;
        topic("map_updates_topic", &self.map_updates_topic, false)?;
        topic("barrier_topic", &self.barrier_topic, true)?;
        frame("map_frame", &self.map_frame)?;
        frame("odom_frame", &self.odom_frame)?;
        frame("base_frame", &self.base_frame)?;
        for (f, m) in &self.lidar_mounts {
            frame("lidar_mounts", f)?;
            pose3(&format!("lidar_mounts.{f}"), m)?;
        }
        positive("sync_window_s", self.sync_window_s, 1.0)?;
        positive("max_wait_s", self.max_wait_s, 10.0)?;
        if !(1..=1000).contains(&self.queue_limit) {
            return Err(format!("queue_limit: {} must lie in 1..=1000", self.queue_limit));
        }
        positive("map_publish_period_s", self.map_publish_period_s, 3600.0)?;
        if !(self.save_period_s.is_finite() && (0.0..=86_400.0).contains(&self.save_period_s)) {
            return Err(format!(
                "save_period_s: {} must lie in [0, 86400] (0: on request and at exit)",
                self.save_period_s
            ));
        }
        if self.domain_id > 232 {
            return Err(format!("domain_id: {} must lie in 0..=232", self.domain_id));
        }
        for (k, a) in self.interfaces.iter().enumerate() {
            if a.parse::<std::net::Ipv4Addr>().is_err() {
                return Err(format!("interfaces[{k}]: '{a}' is not an IPv4 address"));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "mapkeeper:\n  ros__parameters:\n    map: maps/m1.yaml\n    scan_topics: [/scan_front, /scan_rear]\n    pose_source: pose_topic\n    interfaces: [127.0.0.1]\n";

    fn parse(text: &str) -> Result<NodeConfig, String> {
        NodeConfig::parse(text, PathBuf::from("/robot"))
    }

    #[test]
    fn a_ros_parameter_file_is_read_with_defaults_for_what_it_does_not_say() {
        let c = parse(GOOD).unwrap();
        assert_eq!(c.name, "mapkeeper");
        assert_eq!(c.params.scan_topics, ["/scan_front", "/scan_rear"]);
        assert_eq!(c.params.pose_source, PoseFrom::PoseTopic);
        assert_eq!(c.params.preset, "mapkeeper");
        assert_eq!(c.resolve(&c.params.map), Some(PathBuf::from("/robot/maps/m1.yaml")));
        assert_eq!(c.resolve(""), None);
    }

    #[test]
    fn every_bad_value_is_refused_naming_the_parameter() {
        let cases = [
            (GOOD.replace("    map: maps/m1.yaml\n", ""), "mapkeeper.ros__parameters.map: missing"),
            (GOOD.replace("/scan_rear]", "scan_rear]"), "scan_topics[1]: 'scan_rear' is not an absolute"),
            (GOOD.replace("/scan_rear]", "/scan_front]"), "scan_topics[1]: '/scan_front' is named twice"),
            (GOOD.replace("127.0.0.1", "localhost"), "interfaces[0]: 'localhost' is not an IPv4"),
            (format!("{GOOD}    sync_window_s: -1\n"), "sync_window_s: -1 must lie in (0, 1]"),
            (format!("{GOOD}    preset: best\n"), "preset: 'best' is not one of"),
            (format!("{GOOD}    localiser_preset: nope\n"), "localiser_preset: 'nope'"),
            (format!("{GOOD}    initial_pose: [1, 2]\n"), "initial_pose: [1.0, 2.0] must be [x, y, yaw]"),
            (format!("{GOOD}    queue_limit: 0\n"), "queue_limit: 0 must lie in 1..=1000"),
            (format!("{GOOD}    base_frame: /base\n"), "base_frame: '/base' is not a frame id"),
            (format!("{GOOD}    colour: red\n"), "colour"),
            (format!("{GOOD}    sync_window_s: fast\n"), "sync_window_s"),
            (format!("{GOOD}other:\n  ros__parameters:\n    map: a.yaml\n"), "two nodes"),
            ("- a\n- b\n".to_string(), "not a ROS parameter file"),
            (String::new(), "no node"),
        ];
        for (text, want) in cases {
            let e = parse(&text).unwrap_err();
            assert!(e.contains(want), "{want:?} not in {e:?}");
            assert!(!e.contains('\n'), "{e:?}");
        }
        let e = NodeConfig::load(Path::new("/no/such/node.yaml")).unwrap_err().to_string();
        assert!(e.starts_with("/no/such/node.yaml: cannot read"), "{e}");
    }
}
