//! A recorded bag's messages as the node's inputs, for replaying a drive into the node without
//! the wire (tests, `mapkeeper node --replay`): each message of a topic the parameters name, in
//! file order, with its record time as its arrival.

use crate::config::NodeParams;
use crate::core::Input;
use crate::msgs::{self, from_cdr};

/// `geometry_msgs/PoseStamped` (a bag's reference topic may be one).
#[derive(serde::Deserialize)]
struct PoseStamped {
    header: msgs::Header,
    pose: msgs::Pose,
}

/// The input a bag message is for the node of `p`; `Ok(None)` for a topic it does not take.
pub fn bag_input(p: &NodeParams, topic: &str, schema: &str, data: &[u8]) -> Result<Option<Input>, String> {
    let bad = |e: String| format!("{topic} ({schema}): {e}");
    let input = if let Some(lidar) = p.scan_topics.iter().position(|t| t == topic) {
        Input::Scan { lidar, msg: from_cdr(data).map_err(bad)? }
    } else if topic == p.odom_topic {
        Input::Odometry(from_cdr(data).map_err(bad)?)
    } else if topic == "/tf" {
        Input::Tf(from_cdr(data).map_err(bad)?)
    } else if topic == "/tf_static" {
        Input::TfStatic(from_cdr(data).map_err(bad)?)
    } else if topic == p.pose_topic && schema.ends_with("PoseStamped") && !schema.contains("Covariance") {
        let s: PoseStamped = from_cdr(data).map_err(bad)?;
        Input::Pose(msgs::PoseWithCovarianceStamped {
            header: s.header,
            pose: msgs::PoseWithCovariance { pose: s.pose, covariance: msgs::Cov36::default() },
        })
    } else if topic == p.pose_topic {
        Input::Pose(from_cdr(data).map_err(bad)?)
    } else if topic == "/initialpose" {
        Input::InitialPose(from_cdr(data).map_err(bad)?)
    } else if topic == "/clock" && p.use_sim_time {
        Input::Clock(from_cdr(data).map_err(bad)?)
    } else {
        return Ok(None);
    };
    Ok(Some(input))
}

/// Every message of the MCAP bytes `bag` the node of `p` takes, as (record time, input).
pub fn bag_inputs(p: &NodeParams, bag: &[u8]) -> Result<Vec<(u64, Input)>, String> {
    let mut out = Vec::new();
    for (k, m) in mcap::MessageStream::new(bag).map_err(|e| e.to_string())?.enumerate() {
        let m = m.map_err(|e| format!("message {k}: {e}"))?;
        let schema = m.channel.schema.as_ref().map_or("", |s| s.name.as_str());
        if let Some(i) = bag_input(p, &m.channel.topic, schema, &m.data).map_err(|e| format!("message {k}: {e}"))? {
            out.push((m.log_time, i));
        }
    }
    Ok(out)
}
