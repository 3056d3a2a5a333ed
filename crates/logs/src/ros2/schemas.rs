//! The `ros2msg` schemas the run writer names: each message's definition followed by the
//! definitions of every type it uses, as `ros2 bag record` stores them (a line of 80 `=`, then
//! `MSG: pkg/Type`, then that type's fields), so Foxglove Studio and `ros2 bag` decode the file
//! without the message packages installed.

/// One message definition.
#[derive(Debug)]
pub struct Def {
    /// Package (`sensor_msgs`).
    pub package: &'static str,
    /// Type (`LaserScan`).
    pub name: &'static str,
    /// Its fields, one a line, as in its `.msg` file (types of the same package unqualified).
    pub fields: &'static str,
    /// The types its fields use directly.
    pub uses: &'static [&'static Def],
}

impl Def {
    /// The schema name (`sensor_msgs/msg/LaserScan`).
    pub fn schema_name(&self) -> String {
        format!("{}/msg/{}", self.package, self.name)
    }

    /// The schema text: this definition, then each type it uses (directly or not) once, depth
    /// first in field order.
    pub fn schema_text(&self) -> String {
        let mut seen: Vec<&Def> = vec![self];
        let mut out = self.fields.to_string();
        let mut stack: Vec<&Def> = self.uses.iter().rev().copied().collect();
        while let Some(d) = stack.pop() {
            if seen.iter().any(|s| std::ptr::eq(*s, d)) {
                continue;
            }
            seen.push(d);
            out.push_str(SEPARATOR);
            out.push_str(&format!("MSG: {}/{}\n", d.package, d.name));
            out.push_str(d.fields);
            stack.extend(d.uses.iter().rev().copied());
        }
        out
    }
}

const SEPARATOR: &str = "================================================================================\n";

/// `builtin_interfaces/msg/Time`.
pub static TIME: Def =
    Def { package: "builtin_interfaces", name: "Time", fields: "int32 sec\nuint32 nanosec\n", uses: &[] };

/// `std_msgs/msg/Header`.
pub static HEADER: Def = Def {
    package: "std_msgs",
    name: "Header",
    fields: "builtin_interfaces/Time stamp\nstring frame_id\n",
    uses: &[&TIME],
};

/// `std_msgs/msg/String`.
pub static STRING: Def = Def { package: "std_msgs", name: "String", fields: "string data\n", uses: &[] };

/// `geometry_msgs/msg/Point`.
pub static POINT: Def =
    Def { package: "geometry_msgs", name: "Point", fields: "float64 x\nfloat64 y\nfloat64 z\n", uses: &[] };

/// `geometry_msgs/msg/Vector3`.
pub static VECTOR3: Def =
    Def { package: "geometry_msgs", name: "Vector3", fields: "float64 x\nfloat64 y\nfloat64 z\n", uses: &[] };

/// `geometry_msgs/msg/Quaternion`.
pub static QUATERNION: Def = Def {
    package: "geometry_msgs",
    name: "Quaternion",
    fields: "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
    uses: &[],
};

/// `geometry_msgs/msg/Pose`.
pub static POSE: Def = Def {
    package: "geometry_msgs",
    name: "Pose",
    fields: "Point position\nQuaternion orientation\n",
    uses: &[&POINT, &QUATERNION],
};

/// `geometry_msgs/msg/PoseStamped`.
pub static POSE_STAMPED: Def = Def {
    package: "geometry_msgs",
    name: "PoseStamped",
    fields: "std_msgs/Header header\nPose pose\n",
    uses: &[&HEADER, &POSE],
};

/// `geometry_msgs/msg/PoseWithCovariance`.
pub static POSE_WITH_COVARIANCE: Def = Def {
    package: "geometry_msgs",
    name: "PoseWithCovariance",
    fields: "Pose pose\nfloat64[36] covariance\n",
    uses: &[&POSE],
};

/// `geometry_msgs/msg/PoseWithCovarianceStamped`.
pub static POSE_WITH_COVARIANCE_STAMPED: Def = Def {
    package: "geometry_msgs",
    name: "PoseWithCovarianceStamped",
    fields: "std_msgs/Header header\nPoseWithCovariance pose\n",
    uses: &[&HEADER, &POSE_WITH_COVARIANCE],
};

/// `geometry_msgs/msg/PoseArray`.
pub static POSE_ARRAY: Def = Def {
    package: "geometry_msgs",
    name: "PoseArray",
    fields: "std_msgs/Header header\nPose[] poses\n",
    uses: &[&HEADER, &POSE],
};

/// `geometry_msgs/msg/Twist`.
pub static TWIST: Def =
    Def { package: "geometry_msgs", name: "Twist", fields: "Vector3 linear\nVector3 angular\n", uses: &[&VECTOR3] };

/// `geometry_msgs/msg/TwistWithCovariance`.
pub static TWIST_WITH_COVARIANCE: Def = Def {
    package: "geometry_msgs",
    name: "TwistWithCovariance",
    fields: "Twist twist\nfloat64[36] covariance\n",
    uses: &[&TWIST],
};

/// `geometry_msgs/msg/Transform`.
pub static TRANSFORM: Def = Def {
    package: "geometry_msgs",
    name: "Transform",
    fields: "Vector3 translation\nQuaternion rotation\n",
    uses: &[&VECTOR3, &QUATERNION],
};

/// `geometry_msgs/msg/TransformStamped`.
pub static TRANSFORM_STAMPED: Def = Def {
    package: "geometry_msgs",
    name: "TransformStamped",
    fields: "std_msgs/Header header\nstring child_frame_id\nTransform transform\n",
    uses: &[&HEADER, &TRANSFORM],
};

/// `tf2_msgs/msg/TFMessage`.
pub static TF_MESSAGE: Def = Def {
    package: "tf2_msgs",
    name: "TFMessage",
    fields: "geometry_msgs/TransformStamped[] transforms\n",
    uses: &[&TRANSFORM_STAMPED],
};

/// `sensor_msgs/msg/LaserScan`.
pub static LASER_SCAN: Def = Def {
    package: "sensor_msgs",
    name: "LaserScan",
    fields: "std_msgs/Header header\n\nfloat32 angle_min\nfloat32 angle_max\nfloat32 angle_increment\n\n\
float32 time_increment\n\nfloat32 scan_time\n\nfloat32 range_min\nfloat32 range_max\n\n\
float32[] ranges\nfloat32[] intensities\n",
    uses: &[&HEADER],
};

/// `nav_msgs/msg/Odometry`.
pub static ODOMETRY: Def = Def {
    package: "nav_msgs",
    name: "Odometry",
    fields: "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n\
geometry_msgs/TwistWithCovariance twist\n",
    uses: &[&HEADER, &POSE_WITH_COVARIANCE, &TWIST_WITH_COVARIANCE],
};

/// `nav_msgs/msg/MapMetaData`.
pub static MAP_META_DATA: Def = Def {
    package: "nav_msgs",
    name: "MapMetaData",
    fields: "builtin_interfaces/Time map_load_time\nfloat32 resolution\nuint32 width\nuint32 height\n\
geometry_msgs/Pose origin\n",
    uses: &[&TIME, &POSE],
};

/// `nav_msgs/msg/OccupancyGrid`.
pub static OCCUPANCY_GRID: Def = Def {
    package: "nav_msgs",
    name: "OccupancyGrid",
    fields: "std_msgs/Header header\n\nMapMetaData info\n\nint8[] data\n",
    uses: &[&HEADER, &MAP_META_DATA],
};

/// `mapkeeper_msgs/msg/UpdaterStep`: what the map updater did with one step (this project's
/// own type; the definition travels in the file, so Foxglove decodes and plots it).
pub static UPDATER_STEP: Def = Def {
    package: "mapkeeper_msgs",
    name: "UpdaterStep",
    fields: "std_msgs/Header header\n\
# The verdict acted on (update, suspend, lost; empty: the step was not checked).\n\
string verdict\n\
# The paper's localisation check (section 4.2) alone: differs from verdict where the shift check\n\
# lifted a false alarm or raised one.\n\
string check_verdict\n\
# processed, gated, unregistered, no_valid_beams, too_few_beams.\n\
string outcome\n\
uint32 valid_beams\n\
uint32 detected_change_beams\n\
# detected_change_beams / valid_beams (0 without valid beams).\n\
float64 detected_share\n\
# Cells of the map that became occupied, stopped being occupied, or changed between free and unknown.\n\
uint32 cells_added\n\
uint32 cells_removed\n\
uint32 cells_other\n\
# Registration before writing: ran, accepted, and its correction of the pose.\n\
bool registration_ran\n\
bool registration_accepted\n\
float64 registration_shift_m\n\
float64 registration_turn_deg\n\
# Pose updating on Lost: empty (no attempt), recovered, recovered_global (a pose of the global search), or why it failed.\n\
string pose_recovery\n",
    uses: &[&HEADER],
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_schema_holds_every_type_it_uses_once() {
        let text = ODOMETRY.schema_text();
        assert_eq!(ODOMETRY.schema_name(), "nav_msgs/msg/Odometry");
        assert!(text.starts_with("std_msgs/Header header\nstring child_frame_id\n"), "{text}");
        for t in [
            "std_msgs/Header",
            "builtin_interfaces/Time",
            "geometry_msgs/PoseWithCovariance",
            "geometry_msgs/Pose",
            "geometry_msgs/Point",
            "geometry_msgs/Quaternion",
            "geometry_msgs/TwistWithCovariance",
            "geometry_msgs/Twist",
            "geometry_msgs/Vector3",
        ] {
            assert_eq!(text.matches(&format!("\nMSG: {t}\n")).count(), 1, "{t} in\n{text}");
        }
        assert_eq!(text.matches(SEPARATOR).count(), 9);
        assert!(text.contains(&format!("{SEPARATOR}MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\n")));
        assert_eq!(STRING.schema_text(), "string data\n");
    }
}
