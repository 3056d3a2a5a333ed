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
    #[arg(long, value_name = "S", value_parser = super::positive_up_to(1e7, "s"), allow_hyphen_values = true)]
    pub seconds: Option<f64>,
    /// Write the run's figures (latency, CPU, memory) as JSON to this file at exit.
    #[arg(long, value_name = "FILE")]
    pub figures: Option<PathBuf>,
    /// The node's benchmark without the wire: replay this bag (ROS 2 MCAP: the parameters'
    /// topics) into the node as fast as the machine goes, and print the CPU time per step
    /// (median, p99, max, and the median's ratio to a reference workload timed in the same run)
    /// and the resident memory over the drive (sampled every 60 s of it). Nothing is published.
    #[arg(long, value_name = "BAG.mcap", conflicts_with = "check")]
    pub replay: Option<PathBuf>,
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
    if let Some(bag) = &args.replay {
        let figures = replay(&config, bag)?;
        outln!(
            "node --replay: {} steps over {:.0} s of drive; CPU per step median {:.3} ms (x{:.2} the reference), p99 {:.3} ms, max {:.3} ms; RSS {:.1} MiB after the first minute, {:.1} MiB at the end, max {:.1} MiB",
            figures.steps,
            figures.drive_s,
            figures.step_cpu_median_ms,
            figures.ratio_to_reference,
            figures.step_cpu_p99_ms,
            figures.step_cpu_max_ms,
            figures.rss_first_minute_mib,
            figures.rss_end_mib,
            figures.rss_max_mib
        );
        return write_figures(args.figures.as_deref(), &figures);
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
    write_figures(args.figures.as_deref(), &figures)
}

fn write_figures(path: Option<&std::path::Path>, figures: &impl serde::Serialize) -> anyhow::Result<()> {
    if let Some(f) = path {
        let text = serde_json::to_vec_pretty(figures)?;
        mapkeeper_grid::write_atomic(f, &text).with_context(|| f.display().to_string())?;
    }
    Ok(())
}

/// What `--replay` measured.
#[derive(Debug, Default, serde::Serialize)]
struct ReplayFigures {
    steps: u64,
    drive_s: f64,
    step_cpu_median_ms: f64,
    step_cpu_p99_ms: f64,
    step_cpu_max_ms: f64,
    reference_ms: f64,
    ratio_to_reference: f64,
    /// (drive seconds, MiB) every 60 s of the drive.
    rss_mib: Vec<(f64, f64)>,
    rss_first_minute_mib: f64,
    rss_end_mib: f64,
    rss_max_mib: f64,
}

fn reference_ms() -> f64 {
    use super::bench::clock::{reference_workload, thread_cpu_s};
    let mut t: Vec<f64> = (0..5)
        .map(|_| {
            let t0 = thread_cpu_s();
            std::hint::black_box(reference_workload());
            (thread_cpu_s() - t0) * 1e3
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[2]
}

fn replay(config: &NodeConfig, bag: &std::path::Path) -> anyhow::Result<ReplayFigures> {
    use super::bench::clock::thread_cpu_s;
    let bytes = std::fs::read(bag).with_context(|| format!("--replay {}", bag.display()))?;
    let mut core = mapkeeper_node::NodeCore::start(config, 0)?;
    let reference_before = reference_ms();
    let (mut per_step, mut first_t, mut last_t, mut next_sample) = (Vec::new(), None, 0u64, 60.0);
    let mut f = ReplayFigures::default();
    let stream = mcap::MessageStream::new(&bytes).with_context(|| format!("--replay {}", bag.display()))?;
    for (k, m) in stream.enumerate() {
        let m = m.with_context(|| format!("--replay {}: message {k}", bag.display()))?;
        let schema = m.channel.schema.as_ref().map_or("", |s| s.name.as_str());
        let input = mapkeeper_node::replay::bag_input(&config.params, &m.channel.topic, schema, &m.data)
            .map_err(|e| anyhow::anyhow!("--replay {}: message {k}: {e}", bag.display()))?;
        let Some(input) = input else { continue };
        let t0 = thread_cpu_s();
        core.handle(input, m.log_time);
        let (_, _, done) = core.drain();
        let dt = thread_cpu_s() - t0;
        if !done.is_empty() {
            per_step.extend(std::iter::repeat_n(dt * 1e3 / done.len() as f64, done.len()));
        }
        last_t = m.log_time;
        let drive_s = (last_t - *first_t.get_or_insert(last_t)) as f64 / 1e9;
        if drive_s >= next_sample {
            f.rss_mib.push((drive_s, mapkeeper_node::ros::rss_mib()));
            next_sample += 60.0;
        }
    }
    core.tick(last_t + 10_000_000_000);
    per_step.sort_by(f64::total_cmp);
    let q =
        |p: f64| per_step.get(((per_step.len() as f64 * p).ceil() as usize).saturating_sub(1)).copied().unwrap_or(0.0);
    f.steps = per_step.len() as u64;
    f.drive_s = (last_t - first_t.unwrap_or(last_t)) as f64 / 1e9;
    (f.step_cpu_median_ms, f.step_cpu_p99_ms, f.step_cpu_max_ms) =
        (q(0.5), q(0.99), per_step.last().copied().unwrap_or(0.0));
    f.reference_ms = (reference_before + reference_ms()) / 2.0;
    f.ratio_to_reference = f.step_cpu_median_ms / f.reference_ms;
    f.rss_end_mib = mapkeeper_node::ros::rss_mib();
    f.rss_first_minute_mib = f.rss_mib.first().map_or(f.rss_end_mib, |s| s.1);
    f.rss_max_mib = f.rss_mib.iter().map(|s| s.1).fold(f.rss_end_mib, f64::max);
    Ok(f)
}
