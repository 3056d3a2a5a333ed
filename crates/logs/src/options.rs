//! How a recorded log is read: which topics are the lidars, where the odometry comes from,
//! which frames are the robot's base and odometry frames, which clock stamps the messages.

/// Where the odometry comes from.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum OdometryFrom {
    /// The topic `/odom` if the log has it, else the only odometry topic, else the
    /// `odom → base` transform of `/tf`.
    #[default]
    Auto,
    /// This `nav_msgs/Odometry` topic (CARMEN: `ODOM`).
    Topic(String),
    /// The `odom → base` transform of `/tf` ([`ImportOptions::odom_frame`],
    /// [`ImportOptions::base_frame`]).
    Tf,
}

/// Which clock stamps a message.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StampFrom {
    /// The message's own stamp (`header.stamp`; CARMEN's `ipc_timestamp`), as a ROS node sees it.
    #[default]
    Header,
    /// When the recorder received it (the bag's record time, MCAP `log_time`; CARMEN's
    /// `logger_timestamp`).
    Record,
}

/// How a recorded log is turned into a sensor log.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ImportOptions {
    /// The lidars' scan topics, in lidar-id order; empty: every topic with laser scans, sorted by
    /// name.
    pub scan_topics: Vec<String>,
    /// The lidars by their scans' `frame_id` instead, in lidar-id order (for a driver that puts
    /// several lidars on one topic); when given, [`Self::scan_topics`] is not used.
    pub scan_frames: Vec<String>,
    /// The odometry.
    pub odometry: OdometryFrom,
    /// The robot's base frame (lidar mounts are found from it; `base_link`).
    pub base_frame: String,
    /// The odometry frame (`odom`).
    pub odom_frame: String,
    /// A topic of reference poses in the map frame (`nav_msgs/Odometry`,
    /// `geometry_msgs/PoseStamped` or `PoseWithCovarianceStamped`), written as truth records;
    /// `None`: no reference (CARMEN's corrected poses are always the reference).
    pub truth_topic: Option<String>,
    /// The clock.
    pub stamp: StampFrom,
}

impl Default for ImportOptions {
    fn default() -> Self {
        Self {
            scan_topics: Vec::new(),
            scan_frames: Vec::new(),
            odometry: OdometryFrom::Auto,
            base_frame: "base_link".into(),
            odom_frame: "odom".into(),
            truth_topic: None,
            stamp: StampFrom::Header,
        }
    }
}
