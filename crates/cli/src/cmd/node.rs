//! `mapkeeper node`: the map updater live, as a ROS 2 node (`docs/ros2.md`).

use anyhow::Context;
use mapkeeper_node::{Level, NodeConfig};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// Arguments of `mapkeeper node`.
#[derive(clap::Args, Debug)]
#[command(
    long_about = "Run the map updater live as a ROS 2 node, in pure Rust (RustDDS; no ROS installation needed).\n\n\
It subscribes to the lidars' LaserScan topics, the odometry (nav_msgs/Odometry or odom -> base_link on /tf), \
/tf_static (the lidars' mounts), /initialpose and, with use_sim_time, /clock; takes the pose from its own \
localiser (publishing map -> odom on /tf) or from the robot's (/amcl_pose, or map -> odom on /tf); and \
publishes the map as map_server does (/map, reliable, transient local), the changed cells' bounding box on \
/map_updates (for Nav2's static layer with subscribe_to_updates), /updater/step, /updater/changes, and a pose \
that pose updating recovered on /initialpose. The map is saved atomically in save_dir (periodically, when idle, \
on SIGINT / SIGTERM), with the cross-world memory, so a restarted node continues where it stopped.\n\n\
Parameters: a YAML file in ROS conventions (`<node name>: ros__parameters: {...}`); every parameter and its \
default: docs/ros2.md.",
    after_help = "Examples:\n  mapkeeper node --params node.yaml\n  mapkeeper node --params node.yaml --check"
)]
pub struct Args {
    /// The parameter file (YAML, `<node name>: ros__parameters: {...}`).
    #[arg(long, value_name = "FILE")]
    pub params: PathBuf,
    /// Check the parameter file and the map, print the node's configuration and exit.
    #[arg(long)]
    pub check: bool,
    /// Stop after this many seconds (a bounded run, for tests and benchmarks).
    #[arg(long, value_name = "S", value_parser = super::positive_up_to(1e7, "s"))]
    pub seconds: Option<f64>,
    /// Write the run's figures (latency, CPU, memory) as JSON to this file at exit.
    #[arg(long, value_name = "FILE")]
    pub figures: Option<PathBuf>,
}

/// Runs `mapkeeper node`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let config = NodeConfig::load(&args.params)?;
    if args.check {
        let core = mapkeeper_node::NodeCore::start(&config, 0).with_context(|| args.params.display().to_string())?;
        let p = core.params();
        let map = core.map().map(|m| *m.geometry());
        outln!(
            "{}: node '{}' ready: preset {}, pose from {:?}, {} scan topic(s) [{}]",
            args.params.display(),
            config.name,
            p.preset,
            p.pose_source,
            p.scan_topics.len(),
            p.scan_topics.join(", ")
        );
        if let Some(g) = map {
            outln!("map: {} x {} cells at {} m", g.width(), g.height(), g.resolution_m());
        }
        return Ok(());
    }
    let stop = Arc::new(AtomicBool::new(false));
    let s = Arc::clone(&stop);
    ctrlc::set_handler(move || s.store(true, Ordering::Relaxed)).context("installing the SIGINT / SIGTERM handler")?;
    if let Some(secs) = args.seconds {
        let s = Arc::clone(&stop);
        std::thread::spawn(move || {
            std::thread::sleep(std::time::Duration::from_secs_f64(secs));
            s.store(true, Ordering::Relaxed);
        });
    }
    let clock = super::Wall::start();
    let mut log = |level: Level, line: &str| match level {
        Level::Info => errln!("mapkeeper node: {line}"),
        Level::Warn => errln!("mapkeeper node: warning: {line}"),
    };
    let figures = mapkeeper_node::ros::run(&config, &clock, &stop, &mut log)
        .with_context(|| args.params.display().to_string())?;
    outln!(
        "node: {} steps; latency median {:.2} ms, p99 {:.2} ms, max {:.2} ms; CPU {:.1} % of one core; RSS {:.1} -> {:.1} MiB (max {:.1}) over {:.1} s",
        figures.steps,
        figures.latency_median_ms,
        figures.latency_p99_ms,
        figures.latency_max_ms,
        figures.cpu_share * 100.0,
        figures.rss_start_mib,
        figures.rss_end_mib,
        figures.rss_max_mib,
        figures.wall_s
    );
    if let Some(f) = &args.figures {
        let text = serde_json::to_vec_pretty(&figures)?;
        mapkeeper_grid::write_atomic(f, &text).with_context(|| f.display().to_string())?;
    }
    Ok(())
}
