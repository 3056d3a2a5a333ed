//! The node on the wire: one DDS participant (RustDDS, optionally held to given interfaces), the
//! ROS 2 node and its topics with map_server's and AMCL's QoS, and the loop that takes every
//! message into [`NodeCore`], ticks it, and publishes what it produced. The caller gives the
//! clock (the binary's monotonic clock) and the stop flag (set on SIGINT / SIGTERM); on stop the
//! map is saved.

use crate::config::{NodeConfig, PoseFrom, Reliability, ServiceLayout};
use crate::core::{Input, Level, NodeCore, NodeError};
use crate::msgs::{self, RosType};
use crate::outputs::Output;
use mapkeeper_common::Clock;
use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::dds::rustdds::mio1::{Events, Interest, Poll, Token};
use ros2_client::{
    Context, Message, Name, Node, NodeName, NodeOptions, Publisher, QosProfile, Server, ServiceMapping,
    ServiceTypeName, Subscription,
    qos::{Durability, History, Reliability as Rel, WhenFull},
};
use serde::Serialize;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// The figures of a run of the node.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct RunFigures {
    /// Steps processed.
    pub steps: u64,
    /// Latency from a step's last scan's arrival to its outputs published: median, ms.
    pub latency_median_ms: f64,
    /// Its 99th percentile, ms.
    pub latency_p99_ms: f64,
    /// Its largest, ms.
    pub latency_max_ms: f64,
    /// Process CPU time over wall time (1.0: one core busy).
    pub cpu_share: f64,
    /// Resident memory at start and at the end, MiB.
    pub rss_start_mib: f64,
    /// At the end.
    pub rss_end_mib: f64,
    /// Largest seen (sampled every few seconds).
    pub rss_max_mib: f64,
    /// Wall seconds run.
    pub wall_s: f64,
}

/// Latencies in 10 µs bins up to 2 s (fixed memory whatever the run's length).
#[derive(Debug)]
struct Histogram {
    bins: Vec<u32>,
    n: u64,
    max_ns: u64,
}

const BIN_NS: u64 = 10_000;

impl Histogram {
    fn new() -> Self {
        Histogram { bins: vec![0; 200_000], n: 0, max_ns: 0 }
    }

    fn add(&mut self, ns: u64) {
        let k = ((ns / BIN_NS) as usize).min(self.bins.len() - 1);
        self.bins[k] += 1;
        self.n += 1;
        self.max_ns = self.max_ns.max(ns);
    }

    fn quantile_ms(&self, q: f64) -> f64 {
        if self.n == 0 {
            return 0.0;
        }
        let target = ((self.n as f64) * q).ceil().max(1.0) as u64;
        let mut seen = 0;
        for (k, &c) in self.bins.iter().enumerate() {
            seen += u64::from(c);
            if seen >= target {
                return ((k as u64 * BIN_NS + BIN_NS / 2) as f64 / 1e6).min(self.max_ns as f64 / 1e6);
            }
        }
        self.max_ns as f64 / 1e6
    }
}

/// This process's CPU time (user + system), seconds, from `/proc/self/stat`; 0 elsewhere.
fn cpu_s() -> f64 {
    let Ok(s) = std::fs::read_to_string("/proc/self/stat") else { return 0.0 };
    let fields: Vec<&str> = s.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let ticks = |k: usize| fields.get(k).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
}

/// This process's resident memory, MiB, from `/proc/self/status`; 0 elsewhere.
pub fn rss_mib() -> f64 {
    let Ok(s) = std::fs::read_to_string("/proc/self/status") else { return 0.0 };
    s.lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map_or(0.0, |kb| kb / 1024.0)
}

fn qos(reliable: bool, latched: bool, depth: usize) -> QosProfile {
    let reliability =
        if reliable { Rel::Reliable { when_full: WhenFull::Wait(Duration::from_millis(50)) } } else { Rel::BestEffort };
    QosProfile::subscription_default()
        .reliability(reliability)
        .durability(if latched { Durability::TransientLocal } else { Durability::Volatile })
        .history(History::KeepLast { depth })
}

fn name(topic: &str) -> Result<Name, NodeError> {
    let (ns, base) = topic.rsplit_once('/').unwrap_or(("", topic));
    Name::new(if ns.is_empty() { "/" } else { ns }, base)
        .map_err(|e| NodeError::Setup(format!("topic '{topic}': {e:?}")))
}

fn sub<M: Message + RosType + 'static>(
    node: &mut Node,
    topic: &str,
    q: QosProfile,
) -> Result<Subscription<M>, NodeError> {
    let t = node
        .create_topic(&name(topic)?, M::type_name(), &q)
        .map_err(|e| NodeError::Setup(format!("{topic}: {e:?}")))?;
    node.create_subscription::<M>(&t, Some(q)).map_err(|e| NodeError::Setup(format!("{topic}: {e:?}")))
}

fn publ<M: Message + RosType>(node: &mut Node, topic: &str, q: QosProfile) -> Result<Publisher<M>, NodeError> {
    let t = node
        .create_topic(&name(topic)?, M::type_name(), &q)
        .map_err(|e| NodeError::Setup(format!("{topic}: {e:?}")))?;
    node.create_publisher::<M>(&t, Some(q)).map_err(|e| NodeError::Setup(format!("{topic}: {e:?}")))
}

/// The node's subscriptions.
struct Inputs {
    scans: Vec<Subscription<msgs::LaserScan>>,
    odom: Option<Subscription<msgs::Odometry>>,
    tf: Subscription<msgs::TfMessage>,
    tf_static: Subscription<msgs::TfMessage>,
    pose: Option<Subscription<msgs::PoseWithCovarianceStamped>>,
    initialpose: Subscription<msgs::PoseWithCovarianceStamped>,
    clock: Option<Subscription<msgs::Clock>>,
}

/// The node's publishers.
struct Outputs {
    map: Publisher<msgs::OccupancyGrid>,
    updates: Publisher<msgs::OccupancyGridUpdate>,
    barrier: Option<Publisher<msgs::Header>>,
    step: Publisher<msgs::UpdaterStep>,
    changes: Publisher<msgs::OccupancyGrid>,
    initialpose: Publisher<msgs::PoseWithCovarianceStamped>,
    tf: Publisher<msgs::TfMessage>,
}

type SaveServer = Server<msgs::TriggerRequest, msgs::TriggerResponse>;

fn save_server(node: &mut Node, config: &NodeConfig) -> Result<SaveServer, NodeError> {
    let mapping = match config.params.service_layout {
        ServiceLayout::Enhanced => ServiceMapping::Enhanced,
        ServiceLayout::Cyclone => ServiceMapping::Cyclone,
        ServiceLayout::Basic => ServiceMapping::Basic,
    };
    let service = format!("/{}/save_map", config.name);
    let q = qos(true, false, 10);
    node.create_server(mapping, &name(&service)?, &ServiceTypeName::new("std_srvs", "Trigger"), q.clone(), q)
        .map_err(|e| NodeError::Setup(format!("{service}: {e:?}")))
}

fn open(config: &NodeConfig) -> Result<(Node, Inputs, Outputs), NodeError> {
    let p = &config.params;
    let setup = |e: String| NodeError::Setup(e);
    let mut b = DomainParticipantBuilder::new(p.domain_id);
    if !p.interfaces.is_empty() {
        let addrs: Vec<std::net::IpAddr> = p.interfaces.iter().filter_map(|a| a.parse().ok()).collect();
        b = b.with_only_networks(addrs);
    }
    let dp = b.build().map_err(|e| setup(format!("DDS participant (domain {}): {e:?}", p.domain_id)))?;
    let context = Context::from_domain_participant(dp).map_err(|e| setup(format!("ROS 2 context: {e:?}")))?;
    let node_name =
        NodeName::new("/", &config.name).map_err(|e| setup(format!("node name '{}': {e:?}", config.name)))?;
    let mut node = context
        .new_node(node_name, NodeOptions::new().enable_rosout(false))
        .map_err(|e| setup(format!("node: {e:?}")))?;
    let sensor = qos(p.sensor_reliability == Reliability::Reliable, false, 50);
    let latched = qos(true, true, 1);
    let inputs = Inputs {
        scans: p.scan_topics.iter().map(|t| sub(&mut node, t, sensor.clone())).collect::<Result<_, _>>()?,
        odom: if p.odom_topic.is_empty() { None } else { Some(sub(&mut node, &p.odom_topic, sensor.clone())?) },
        tf: sub(&mut node, "/tf", qos(false, false, 100))?,
        tf_static: sub(&mut node, "/tf_static", latched.clone())?,
        pose: if p.pose_source == PoseFrom::PoseTopic {
            Some(sub(&mut node, &p.pose_topic, qos(false, false, 50))?)
        } else {
            None
        },
        initialpose: sub(&mut node, "/initialpose", qos(false, false, 10))?,
        clock: if p.use_sim_time { Some(sub(&mut node, "/clock", qos(false, false, 10))?) } else { None },
    };
    let outputs = Outputs {
        map: publ(&mut node, &p.map_topic, latched.clone())?,
        updates: publ(&mut node, &p.map_updates_topic, qos(true, false, 100))?,
        barrier: if p.barrier_topic.is_empty() {
            None
        } else {
            Some(publ(&mut node, &p.barrier_topic, latched.clone())?)
        },
        step: publ(&mut node, "/updater/step", qos(true, false, 50))?,
        changes: publ(&mut node, "/updater/changes", latched)?,
        initialpose: publ(&mut node, "/initialpose", qos(true, false, 10))?,
        tf: publ(&mut node, "/tf", qos(true, false, 100))?,
    };
    Ok((node, inputs, outputs))
}

/// Takes what has arrived on `s`, each with the time this process received it (RustDDS's
/// reception stamp; 0 where it has none).
fn take<M: Message + 'static>(s: &Subscription<M>, into: &mut Vec<(i64, Input)>, wrap: impl Fn(M) -> Input) {
    for _ in 0..1000 {
        match s.take() {
            Ok(Some((m, info))) => into.push((info.received_timestamp().map_or(0, |t| t.to_nanos()), wrap(m))),
            Ok(None) => return,
            // A sample that does not decode (a peer with another definition) is dropped; DDS
            // goes on.
            Err(_) => continue,
        }
    }
}

impl Inputs {
    fn register(&mut self, poll: &Poll) -> Result<(), NodeError> {
        let r = poll.registry();
        let e = |e: std::io::Error| NodeError::Setup(format!("poll: {e}"));
        for (k, s) in self.scans.iter_mut().enumerate() {
            r.register(s, Token(10 + k), Interest::READABLE).map_err(e)?;
        }
        if let Some(s) = self.odom.as_mut() {
            r.register(s, Token(1), Interest::READABLE).map_err(e)?;
        }
        r.register(&mut self.tf, Token(2), Interest::READABLE).map_err(e)?;
        r.register(&mut self.tf_static, Token(3), Interest::READABLE).map_err(e)?;
        if let Some(s) = self.pose.as_mut() {
            r.register(s, Token(4), Interest::READABLE).map_err(e)?;
        }
        r.register(&mut self.initialpose, Token(5), Interest::READABLE).map_err(e)?;
        if let Some(s) = self.clock.as_mut() {
            r.register(s, Token(6), Interest::READABLE).map_err(e)?;
        }
        Ok(())
    }

    /// Everything that has arrived, in the order this process received it across topics (a
    /// batch holds whatever came since the last poll: taken topic by topic, a lidar's next scan
    /// would come before the other lidar's scan of the same step and split it; by stamps, a
    /// clock that jumped back would be hidden among the samples before the jump).
    fn drain(&self) -> (Vec<Input>, bool) {
        let mut v = self.take_all();
        let unstamped = v.iter().any(|(received, _)| *received == 0);
        v.sort_by_key(|(received, _)| *received);
        (v.into_iter().map(|(_, i)| i).collect(), unstamped)
    }

    fn take_all(&self) -> Vec<(i64, Input)> {
        let mut v = Vec::new();
        if let Some(s) = &self.clock {
            take(s, &mut v, Input::Clock);
        }
        take(&self.tf_static, &mut v, Input::TfStatic);
        take(&self.tf, &mut v, Input::Tf);
        if let Some(s) = &self.odom {
            take(s, &mut v, Input::Odometry);
        }
        if let Some(s) = &self.pose {
            take(s, &mut v, Input::Pose);
        }
        take(&self.initialpose, &mut v, Input::InitialPose);
        for (lidar, s) in self.scans.iter().enumerate() {
            take(s, &mut v, |msg| Input::Scan { lidar, msg });
        }
        v
    }
}

impl Outputs {
    fn publish(&self, o: Output) -> Result<(), String> {
        let r = match o {
            Output::Map(m) => self.map.publish(m).map_err(|e| format!("/map: {e:?}")),
            Output::MapUpdate(m) => self.updates.publish(m).map_err(|e| format!("map updates: {e:?}")),
            Output::Barrier(h) => match &self.barrier {
                Some(b) => b.publish(h).map_err(|e| format!("barrier: {e:?}")),
                None => Ok(()),
            },
            Output::Step(m) => self.step.publish(m).map_err(|e| format!("/updater/step: {e:?}")),
            Output::Changes(m) => self.changes.publish(m).map_err(|e| format!("/updater/changes: {e:?}")),
            Output::InitialPose(m) => self.initialpose.publish(m).map_err(|e| format!("/initialpose: {e:?}")),
            Output::Tf(m) => self.tf.publish(m).map_err(|e| format!("/tf: {e:?}")),
        };
        r.map_err(|e| e.chars().take(300).collect())
    }
}

/// Runs the node of `config` until `stop` is set; `log` gets every log line. Saves the map on
/// the way out (with a `save_dir`), and returns the run's figures.
pub fn run(
    config: &NodeConfig,
    clock: &dyn Clock,
    stop: &Arc<AtomicBool>,
    log: &mut dyn FnMut(Level, &str),
) -> Result<RunFigures, NodeError> {
    let (t0, cpu0, rss0) = (clock.now_ns(), cpu_s(), rss_mib());
    let mut core = NodeCore::start(config, t0)?;
    let (mut node, mut inputs, outputs) = open(config)?;
    let mut server = save_server(&mut node, config)?;
    let mut poll = Poll::new().map_err(|e| NodeError::Setup(format!("poll: {e}")))?;
    inputs.register(&poll)?;
    poll.registry()
        .register(&mut server, Token(7), Interest::READABLE)
        .map_err(|e| NodeError::Setup(format!("poll: {e}")))?;
    let mut events = Events::with_capacity(64);
    let mut hist = Histogram::new();
    let (mut rss_max, mut last_sample, mut warned_unstamped) = (rss0, t0, false);
    log(
        Level::Info,
        &format!(
            "node '{}' up: {} scan topic(s), pose from {:?}, map {}",
            config.name,
            config.params.scan_topics.len(),
            config.params.pose_source,
            config.params.map_topic
        ),
    );
    while !stop.load(Ordering::Relaxed) {
        let _ = poll.poll(&mut events, Some(Duration::from_millis(10)));
        let now = clock.now_ns();
        let (batch, unstamped) = inputs.drain();
        if unstamped && !warned_unstamped {
            log(Level::Warn, "a sample without a reception stamp: a batch of it is taken in topic order");
            warned_unstamped = true;
        }
        for input in batch {
            core.handle(input, now);
        }
        core.tick(clock.now_ns());
        serve(&server, &mut core, log);
        flush(&mut core, &outputs, clock, &mut hist, log);
        if now.saturating_sub(last_sample) > 2_000_000_000 {
            rss_max = rss_max.max(rss_mib());
            last_sample = now;
        }
    }
    if config.resolve(&config.params.save_dir).is_some() {
        match core.save() {
            Ok(s) => log(Level::Info, &format!("saved on exit: {}", s.map_path.display())),
            Err(e) => log(Level::Warn, &e.to_string()),
        }
    }
    flush(&mut core, &outputs, clock, &mut hist, log);
    let wall_s = clock.now_ns().saturating_sub(t0) as f64 / 1e9;
    let rss_end = rss_mib();
    Ok(RunFigures {
        steps: hist.n,
        latency_median_ms: hist.quantile_ms(0.5),
        latency_p99_ms: hist.quantile_ms(0.99),
        latency_max_ms: hist.max_ns as f64 / 1e6,
        cpu_share: if wall_s > 0.0 { (cpu_s() - cpu0) / wall_s } else { 0.0 },
        rss_start_mib: rss0,
        rss_end_mib: rss_end,
        rss_max_mib: rss_max.max(rss_end),
        wall_s,
    })
}

/// Answers the `save_map` requests that have come: the map saved now, or why not.
fn serve(server: &SaveServer, core: &mut NodeCore, log: &mut dyn FnMut(Level, &str)) {
    while let Ok(Some((id, _))) = server.receive_request() {
        let response = match core.save() {
            Ok(s) => msgs::TriggerResponse { success: true, message: s.map_path.display().to_string() },
            Err(e) => msgs::TriggerResponse { success: false, message: e.to_string() },
        };
        log(Level::Info, &format!("save_map: {}", response.message));
        if let Err(e) = server.send_response(id, response) {
            log(Level::Warn, &format!("save_map: the reply could not be sent: {e:?}"));
        }
    }
}

fn flush(
    core: &mut NodeCore,
    outputs: &Outputs,
    clock: &dyn Clock,
    hist: &mut Histogram,
    log: &mut dyn FnMut(Level, &str),
) {
    let (outs, logs, arrived) = core.drain();
    for o in outs {
        if let Err(e) = outputs.publish(o) {
            log(Level::Warn, &format!("publishing: {e}"));
        }
    }
    let now = clock.now_ns();
    for a in arrived {
        hist.add(now.saturating_sub(a));
    }
    for (level, line) in logs {
        log(level, &line);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_histogram_gives_quantiles_within_a_bin() {
        let mut h = Histogram::new();
        assert_eq!(h.quantile_ms(0.5), 0.0);
        for k in 1..=100u64 {
            h.add(k * 100_000);
        }
        assert!((h.quantile_ms(0.5) - 5.0).abs() <= 0.01, "{}", h.quantile_ms(0.5));
        assert!((h.quantile_ms(0.99) - 9.9).abs() <= 0.01, "{}", h.quantile_ms(0.99));
        h.add(10_000_000_000);
        assert_eq!(h.max_ns, 10_000_000_000);
        assert!(h.quantile_ms(1.0) <= 10_000.0);
    }
}
