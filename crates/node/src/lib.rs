//! `mapkeeper node`: the map updater on a live robot, as a ROS 2 node in pure Rust
//! (`ros2-client` on RustDDS: no ROS installation needed to build or run it). It takes the
//! robot's scans, odometry and transforms, gets the pose from its own localiser or from the
//! robot's, keeps the map up to date with the harness's loop (the same session, Lost policy and
//! observers as every offline run), and publishes the map as map_server does, with partial
//! updates Nav2's static layer applies (`docs/ros2.md`).
//!
//! - [`config`]: the YAML parameter file, validated.
//! - [`msgs`]: the ROS 2 messages, as serde types.
//! - [`frames`]: live messages into steps, by the offline replay's rules.
//! - [`core`]: the node without the wire (driven message by message in the tests).
//! - [`outputs`]: what each step publishes.
//! - [`save`]: the saved map and memory.
//! - [`ros`]: the wire: DDS participant, topics, QoS, the loop.

pub mod config;
pub mod core;
pub mod frames;
pub mod msgs;
pub mod outputs;
pub mod replay;
pub mod ros;
pub mod save;

pub use config::{NodeConfig, NodeParams, PoseFrom};
pub use core::{Input, Level, NodeCore, NodeCounts, NodeError};
pub use outputs::Output;
