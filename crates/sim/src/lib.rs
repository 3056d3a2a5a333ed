//! # mapkeeper-sim
//!
//! A headless, deterministic 2D warehouse simulator on rapier2d: a Robotnik Summit-XL Steel
//! (omni or skid-steer) driven along a route by a pure-pursuit follower, two noisy SICK S300
//! lidars (or any [`LidarParams`]), wheel odometry with AMCL-style noise and bias, people and
//! other robots as kinematic agents, and the exact ground-truth map of a world.
//!
//! Worlds are versioned TOML files (`docs/world-format.md`); the default warehouse is embedded
//! ([`World::default_warehouse`]). Time is an integer tick clock (50 Hz by default); every
//! random stream derives from one run seed by name ([`seeds`]), so the same seed gives
//! bit-identical outputs.
//!
//! ```
//! use mapkeeper_sim::{Route, SimParams, Simulator, World};
//! let world = World::default_warehouse();
//! let mut sim = Simulator::new(&world, SimParams::default(), 7).unwrap();
//! sim.set_route(Route::default_warehouse().points());
//! let mut scans = 0;
//! for _ in 0..50 {
//!     let out = sim.step(); // 20 ms
//!     scans += out.scans.len();
//!     assert!(out.collisions.is_empty());
//! }
//! assert_eq!(scans, 2 * 13); // two lidars at 12.5 Hz for one second
//! assert!(sim.true_pose().y > -2.3); // heading north up the west aisle
//! ```
#![warn(missing_docs)]

mod agents;
mod error;
mod import;
mod lidar;
mod odometry;
mod raycast;
mod realism;
mod robot;
mod robot_file;
mod route;
/// Named random streams (`mapkeeper_common::seeds`).
pub use mapkeeper_common::seeds;
mod shape;
mod sim;
mod truth;
mod world;

pub use agents::AgentParams;
pub use error::SimError;
pub use import::{CellRect, merge_occupied, seal_free_space};
pub use lidar::{LIDAR_MODELS, LidarNoise, LidarParams};
pub use odometry::OdometryParams;
pub use realism::{SensorEffect, SensorRealism};
pub use robot::{DriveKind, FollowerParams, RobotParams};
pub use robot_file::{EMBEDDED_ROBOTS, ROBOT_FORMAT, RobotFile};
pub use route::{ROUTE_FORMAT, Route};
pub use shape::{Bounds, Shape, point_segment_distance};
pub use sim::{CollisionEvent, SimParams, Simulator, StepOutput};
pub use truth::ground_truth_map;
pub use world::{
    Agent, AgentKind, EMBEDDED_WORLDS, FRAME_BAR_M, Motion, MovableItem, MovableKind, ObstacleRef, Rack, StartPose,
    StaticItem, StorageRegion, WORLD_FORMAT, WORLD_VERSION, World, WorldRoute,
};
