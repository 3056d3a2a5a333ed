//! A simulated drive recorded as a sensor log (`docs/sensor-log.md`): odometry and the true
//! pose at every physics tick, scans as the lidars fire, for replay by the localiser, the
//! updater or anyone's own stack.

use mapkeeper_grid::Pose2;
use mapkeeper_sensor::{LogError, LogHeader, LogRecord, LogWriter, StampedPose};
use mapkeeper_sim::{CollisionEvent, Route, SimParams, Simulator, World};
use std::path::Path;

/// What to record.
#[derive(Clone, Copy, Debug)]
pub struct DriveSpec<'a> {
    /// The world.
    pub world: &'a World,
    /// The route, if the robot drives one.
    pub route: Option<&'a Route>,
    /// Simulator parameters.
    pub params: &'a SimParams,
    /// Run seed.
    pub seed: u64,
    /// Simulated duration, seconds.
    pub seconds: f64,
    /// End as soon as the route is done (else run for `seconds`).
    pub stop_at_route_end: bool,
    /// The program recorded in the log's header (`tool`), e.g. "mapkeeper simulate".
    pub tool: &'a str,
}

/// What was recorded.
#[derive(Clone, Debug, PartialEq)]
pub struct Drive {
    /// The true pose at every tick.
    pub truth: Vec<StampedPose>,
    /// Every contact event of the robot.
    pub collisions: Vec<CollisionEvent>,
    /// Distance driven (true), metres.
    pub distance_m: f64,
    /// Scans recorded.
    pub scans: usize,
    /// Whether the route was done at the end.
    pub route_done: bool,
    /// Simulated time, seconds.
    pub simulated_s: f64,
}

/// What can go wrong while recording.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RecordingError {
    /// The simulator refused the world or its parameters.
    #[error(transparent)]
    Sim(#[from] mapkeeper_sim::SimError),
    /// The duration is not a finite time in (0, 10⁶] s.
    #[error("the duration must be a finite number of seconds in (0, 1e6], got {0}")]
    Duration(f64),
    /// The log could not be written.
    #[error(transparent)]
    Log(#[from] LogError),
}

/// Drives `spec` and writes the log to `log_path` (atomically); `progress(tick)` is called
/// every 500 ticks.
pub fn record_drive(spec: &DriveSpec<'_>, log_path: &Path, progress: &dyn Fn(u64)) -> Result<Drive, RecordingError> {
    if !(spec.seconds.is_finite() && spec.seconds > 0.0 && spec.seconds <= 1e6) {
        return Err(RecordingError::Duration(spec.seconds));
    }
    let mut sim = Simulator::new(spec.world, spec.params.clone(), spec.seed)?;
    if let Some(r) = spec.route {
        sim.set_route(r.points());
    }
    let mut meta = serde_json::Map::new();
    meta.insert("tool".into(), format!("{} {}", spec.tool, env!("CARGO_PKG_VERSION")).into());
    meta.insert("seed".into(), spec.seed.into());
    meta.insert("world".into(), spec.world.name.clone().into());
    meta.insert("tick_ns".into(), spec.params.tick_ns.into());
    for (k, v) in [
        ("robot", serde_json::to_value(&spec.params.robot)),
        ("lidars", serde_json::to_value(&spec.params.lidars)),
        ("odometry", serde_json::to_value(&spec.params.odometry)),
    ] {
        meta.insert(k.into(), v.unwrap_or(serde_json::Value::Null));
    }
    let mut log = LogWriter::create(log_path, &LogHeader::new(meta))?;
    let ticks = (spec.seconds * 1e9 / spec.params.tick_ns as f64).round() as u64;
    let mut d = Drive {
        truth: Vec::new(),
        collisions: Vec::new(),
        distance_m: 0.0,
        scans: 0,
        route_done: false,
        simulated_s: 0.0,
    };
    let mut last: Pose2 = sim.true_pose();
    for k in 0..ticks {
        let out = sim.step();
        log.write(&LogRecord::Odom(out.odometry))?;
        log.write(&LogRecord::Truth(out.truth))?;
        d.scans += out.scans.len();
        for s in out.scans {
            log.write(&LogRecord::Scan(s))?;
        }
        let p = out.truth.pose_in_map;
        d.distance_m += p.distance(&last);
        last = p;
        d.truth.push(StampedPose { stamp_ns: out.stamp_ns, pose: p });
        d.collisions.extend(out.collisions);
        if k % 500 == 0 {
            progress(k);
        }
        d.route_done = out.route_done;
        if spec.route.is_some() && spec.stop_at_route_end && out.route_done {
            break;
        }
    }
    log.finish()?;
    d.simulated_s = sim.stamp_ns() as f64 / 1e9;
    Ok(d)
}
