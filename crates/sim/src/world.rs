//! The world file (`docs/world-format.md`): static structure, movable items and agents, in a
//! versioned TOML format, validated on load.

use crate::error::SimError;
use crate::shape::{Bounds, Shape};
use mapkeeper_grid::{GridGeometry, Point2, Pose2};
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::path::Path;

/// The `format` value of every world file.
pub const WORLD_FORMAT: &str = "mapkeeper-world";
/// The world format version this crate reads and writes.
pub const WORLD_VERSION: u32 = 1;

/// The default warehouse, embedded so that it needs no file.
const DEFAULT_WAREHOUSE_TOML: &str = include_str!("../../../worlds/warehouse.toml");

/// The paper's lab (§5.5), embedded too.
const LAB_TOML: &str = include_str!("../../../worlds/lab.toml");

/// The names of the embedded worlds ([`World::embedded`]): the default warehouse and the
/// paper's lab.
pub const EMBEDDED_WORLDS: [&str; 2] = ["warehouse", "lab"];

/// A simulated world: plain data, edited by the scenario generator and written back.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct World {
    /// Always [`WORLD_FORMAT`].
    pub format: String,
    /// Always [`WORLD_VERSION`].
    pub version: u32,
    /// A short name (recorded in logs).
    pub name: String,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Where the robot starts.
    pub robot_start: StartPose,
    /// The region inside the walls; cells outside it are unknown in the ground truth. Optional.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub interior: Option<Shape>,
    /// Walls (static).
    #[serde(default)]
    pub walls: Vec<StaticItem>,
    /// Columns and other fixed structure (static).
    #[serde(default)]
    pub columns: Vec<StaticItem>,
    /// Racks, seen by the lidars only through their posts (static).
    #[serde(default)]
    pub racks: Vec<Rack>,
    /// Movable items: what the scenario generator adds, removes, moves and turns.
    #[serde(default)]
    pub movable: Vec<MovableItem>,
    /// People and other robots.
    #[serde(default)]
    pub agents: Vec<Agent>,
    /// Where the scenario generator may put goods down (optional; derived when absent, see
    /// `docs/world-format.md`). Not written when empty.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub storage_areas: Vec<StorageRegion>,
    /// The robot's route (optional; planned when absent). Not written when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub route: Option<WorldRoute>,
}

/// A storage area: floor where goods may be put down (any shape).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StorageRegion {
    /// Stable identifier, unique in the world.
    pub id: String,
    /// Its outline in the map frame.
    pub shape: Shape,
}

/// The route a world carries: the tour driven in every world and, optionally, the exploration
/// tour that builds the initial map M_1.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorldRoute {
    /// Waypoints `[[x, y], ...]`, metres, driven in order from the robot's start (a closed tour
    /// repeats its first point at the end); at least one.
    pub waypoints: Vec<[f64; 2]>,
    /// The exploration tour of W_1 for M_1 (default: `waypoints`). Not written when empty.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub exploration: Vec<[f64; 2]>,
}

/// The robot's start pose.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartPose {
    /// x, metres.
    pub x: f64,
    /// y, metres.
    pub y: f64,
    /// Heading, degrees counter-clockwise from the x axis.
    #[serde(default)]
    pub yaw_deg: f64,
}

impl StartPose {
    /// As a pose (radians).
    pub fn pose(&self) -> Pose2 {
        Pose2::new(self.x, self.y, self.yaw_deg.to_radians())
    }
}

/// A piece of static structure.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StaticItem {
    /// Stable identifier, unique in the world.
    pub id: String,
    /// Its outline in the map frame.
    pub shape: Shape,
}

/// A rack: a footprint whose long sides carry posts (uprights); a lidar at ~0.3 m sees only
/// the posts (and, with `frames`, the low cross-bracing between the two posts of a frame).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rack {
    /// Stable identifier, unique in the world.
    pub id: String,
    /// Centre of the footprint `[x, y]`, metres.
    pub center: [f64; 2],
    /// Footprint `[along local x, along local y]`, metres; posts run along the longer side.
    pub size: [f64; 2],
    /// Rotation, degrees counter-clockwise (default 0).
    #[serde(default)]
    pub yaw_deg: f64,
    /// Side of the square posts, metres (default 0.1).
    #[serde(default = "default_post_size")]
    pub post_size_m: f64,
    /// Largest distance between consecutive posts along a side, metres (default 2.0); posts
    /// stand at both ends and evenly between.
    #[serde(default = "default_post_spacing")]
    pub max_post_spacing_m: f64,
    /// Whether each pair of facing posts is joined by a bracing bar across the depth, as the
    /// real warehouse map shows (default false).
    #[serde(default)]
    pub frames: bool,
}

fn default_post_size() -> f64 {
    0.1
}
fn default_post_spacing() -> f64 {
    2.0
}

/// Thickness of a rack's frame bar, metres.
pub const FRAME_BAR_M: f64 = 0.05;

/// The most post intervals a rack may have along its length (a 20 km rack at the default 2 m
/// spacing): a bound on the shapes one rack becomes, so that a world file cannot ask for an
/// allocation of any size.
pub const MAX_RACK_POST_INTERVALS: usize = 10_000;

impl Rack {
    /// The long side and depth of the rack, and the extra yaw (degrees) of the frame whose x
    /// runs along the long side.
    fn long_frame(&self) -> (f64, f64, f64) {
        if self.size[0] >= self.size[1] {
            (self.size[0], self.size[1], 0.0)
        } else {
            (self.size[1], self.size[0], 90.0)
        }
    }

    /// The side of a post (at most the rack's depth), the length between the first and the
    /// last post's centres, and the number of intervals between posts (≥ 1; a float, as a huge
    /// rack's count may not fit a `usize`).
    fn post_run(&self) -> (f64, f64, f64) {
        let (len, depth, _) = self.long_frame();
        let p = self.post_size_m.min(len).min(depth);
        let run = (len - p).max(0.0);
        (p, run, (run / self.max_post_spacing_m).ceil().max(1.0))
    }

    /// The number of intervals between posts along the long side (≥ 1).
    pub fn post_intervals(&self) -> f64 {
        self.post_run().2
    }

    /// The posts (and frame bars) of the rack as shapes in the map frame, in a fixed order.
    /// A rack that passed [`World::validate`] has at most `MAX_RACK_POST_INTERVALS` intervals;
    /// the count is capped there in any case.
    pub fn parts(&self) -> Vec<Shape> {
        let pose = Pose2::new(self.center[0], self.center[1], self.yaw_deg.to_radians());
        // Work in a frame whose x runs along the long side.
        let (_, depth, extra_yaw) = self.long_frame();
        let frame = pose.compose(&Pose2::new(0.0, 0.0, f64::to_radians(extra_yaw)));
        let (p, run, intervals) = self.post_run();
        let intervals = intervals.min(MAX_RACK_POST_INTERVALS as f64) as usize;
        let mut parts = Vec::with_capacity(3 * (intervals + 1));
        for k in 0..=intervals {
            let x = -run / 2.0 + run * k as f64 / intervals as f64;
            for side in [-1.0, 1.0] {
                let c = frame.transform_point(Point2::new(x, side * (depth - p) / 2.0));
                parts.push(Shape::rect(c, [p, p], self.yaw_deg + extra_yaw));
            }
            if self.frames && depth - 2.0 * p > 1e-9 {
                let c = frame.transform_point(Point2::new(x, 0.0));
                parts.push(Shape::rect(c, [FRAME_BAR_M.min(p), depth - 2.0 * p], self.yaw_deg + extra_yaw));
            }
        }
        parts
    }

    /// The footprint as a rectangle.
    pub fn footprint(&self) -> Shape {
        Shape::Rect { center: self.center, size: self.size, yaw_deg: self.yaw_deg }
    }
}

/// The kind of a movable item (documentation and statistics only; physics treats all alike).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MovableKind {
    /// A box or box stack.
    Box,
    /// A pallet stack.
    PalletStack,
    /// A bucket.
    Bucket,
    /// A bin.
    Bin,
    /// A pallet jack.
    PalletJack,
    /// Anything else.
    Other,
}

/// A movable item.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MovableItem {
    /// Stable identifier, unique in the world (the scenario generator refers to items by it).
    pub id: String,
    /// What it is.
    pub kind: MovableKind,
    /// Its outline in the map frame.
    pub shape: Shape,
}

/// The kind of an agent.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AgentKind {
    /// A person (a circle of r ≈ 0.25 m).
    Person,
    /// Another robot (a rectangle).
    Robot,
}

/// How an agent moves.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Motion {
    /// Visit the waypoints in order, then start again from the first.
    Loop {
        /// Waypoints `[[x, y], ...]`, metres; at least two. The agent starts at the first.
        waypoints: Vec<[f64; 2]>,
        /// Longest stand at a waypoint, seconds (default 0: never stops; a person who stops and
        /// stands for a seeded random time up to this at each waypoint).
        #[serde(default, skip_serializing_if = "is_zero")]
        max_pause_s: f64,
    },
    /// Wander along the polyline: at each waypoint, go on to a random neighbour (the previous or
    /// the next waypoint), after a random pause of up to `max_pause_s`.
    RandomWalk {
        /// Polyline `[[x, y], ...]`, metres; at least two. The agent starts at the first.
        waypoints: Vec<[f64; 2]>,
        /// Longest pause at a waypoint, seconds (default 0).
        #[serde(default)]
        max_pause_s: f64,
    },
}

// serde's skip_serializing_if passes a reference.
#[allow(clippy::trivially_copy_pass_by_ref)]
fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl Motion {
    /// The waypoints, as points.
    pub fn waypoints(&self) -> Vec<Point2> {
        let w = match self {
            Motion::Loop { waypoints, .. } | Motion::RandomWalk { waypoints, .. } => waypoints,
        };
        w.iter().map(|p| Point2::new(p[0], p[1])).collect()
    }
}

/// A moving agent: a person or another robot, a kinematic body.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Agent {
    /// Stable identifier, unique in the world (it also names the agent's random stream).
    pub id: String,
    /// What it is.
    pub kind: AgentKind,
    /// Outline in the agent's own frame (x forward), e.g. a circle of radius 0.25 m.
    pub footprint: Shape,
    /// Walking / driving speed, m/s (people 0.5-1.4).
    pub speed_mps: f64,
    /// Its path.
    pub motion: Motion,
}

/// What a collider of the world is, for collision reports and filters.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(tag = "class", content = "id", rename_all = "snake_case")]
pub enum ObstacleRef {
    /// A wall (by id).
    Wall(String),
    /// A column (by id).
    Column(String),
    /// A post or frame of a rack (by rack id).
    Rack(String),
    /// A movable item (by id).
    Movable(String),
    /// An agent (by id).
    Agent(String),
}

impl World {
    /// The built-in default warehouse (`worlds/warehouse.toml`, embedded).
    pub fn default_warehouse() -> World {
        match World::from_toml_str(DEFAULT_WAREHOUSE_TOML, "worlds/warehouse.toml (embedded)") {
            Ok(w) => w,
            // The embedded file is checked by the crate's tests; this cannot happen in a release.
            Err(e) => panic!("the embedded default world is invalid: {e}"),
        }
    }

    /// An embedded world by name ([`EMBEDDED_WORLDS`]): `warehouse` (the default) or `lab`.
    pub fn embedded(name: &str) -> Option<World> {
        let (text, origin) = match name {
            "warehouse" => (DEFAULT_WAREHOUSE_TOML, "worlds/warehouse.toml (embedded)"),
            "lab" => (LAB_TOML, "worlds/lab.toml (embedded)"),
            _ => return None,
        };
        match World::from_toml_str(text, origin) {
            Ok(w) => Some(w),
            // The embedded files are checked by the crate's tests; this cannot happen in a release.
            Err(e) => panic!("an embedded world is invalid: {e}"),
        }
    }

    /// A world named on the command line: an embedded world's name, else a world file.
    pub fn named_or_load(arg: &Path) -> Result<World, SimError> {
        match arg.to_str().and_then(World::embedded) {
            Some(w) => Ok(w),
            None => World::load(arg),
        }
    }

    /// The text of the embedded default warehouse.
    pub fn default_warehouse_toml() -> &'static str {
        DEFAULT_WAREHOUSE_TOML
    }

    /// Parses and validates a world. `origin` names the text in error messages (a file name).
    pub fn from_toml_str(text: &str, origin: &str) -> Result<World, SimError> {
        let world: World = parse_toml(text, origin)?;
        world.validate(origin)?;
        Ok(world)
    }

    /// Reads, parses and validates a world file.
    pub fn load(path: &Path) -> Result<World, SimError> {
        let text = std::fs::read_to_string(path).map_err(|source| SimError::Io { path: path.to_path_buf(), source })?;
        World::from_toml_str(&text, &path.display().to_string())
    }

    /// The world as TOML; deterministic (same world, same bytes) and read back equal.
    pub fn to_toml_string(&self) -> Result<String, SimError> {
        toml::to_string(self).map_err(|e| SimError::Parse { origin: self.name.clone(), message: e.to_string() })
    }

    /// Semantic checks: format and version, unique non-empty ids, finite positive sizes, agent
    /// paths with at least two points, sane speeds. Overlaps are allowed.
    pub fn validate(&self, origin: &str) -> Result<(), SimError> {
        let bad = |entry: String, problem: String| SimError::Invalid { origin: origin.to_string(), entry, problem };
        if self.format != WORLD_FORMAT {
            return Err(bad("format".into(), format!("is \"{}\", expected \"{WORLD_FORMAT}\"", self.format)));
        }
        if self.version != WORLD_VERSION {
            return Err(bad(
                "version".into(),
                format!("version {} is not supported (this reader reads version {WORLD_VERSION})", self.version),
            ));
        }
        let s = &self.robot_start;
        if !(s.x.is_finite() && s.y.is_finite() && s.yaw_deg.is_finite()) {
            return Err(bad("robot_start".into(), format!("must be finite, got {s:?}")));
        }
        if let Some(interior) = &self.interior {
            if let Some(p) = interior.problem() {
                return Err(bad("interior".into(), p));
            }
            if !interior.contains(s.pose().position()) {
                return Err(bad("robot_start".into(), "lies outside the interior".into()));
            }
        }
        self.validate_entries(origin)?;
        self.validate_scenario(origin)?;
        self.validate_agent_paths(origin)
    }

    /// The storage areas' shapes and the route's waypoints.
    fn validate_scenario(&self, origin: &str) -> Result<(), SimError> {
        let bad = |entry: String, problem: String| SimError::Invalid { origin: origin.to_string(), entry, problem };
        for (i, a) in self.storage_areas.iter().enumerate() {
            let entry = format!("storage_areas[{i}] \"{}\"", a.id);
            if let Some(p) = a.shape.problem() {
                return Err(bad(entry, p));
            }
            if a.shape.area().abs() < 0.25 {
                return Err(bad(
                    entry,
                    format!("is too small to hold goods ({:.3} m², need ≥ 0.25 m²)", a.shape.area().abs()),
                ));
            }
        }
        if let Some(r) = &self.route {
            if r.waypoints.is_empty() {
                return Err(bad("route.waypoints".into(), "a route needs at least one waypoint".into()));
            }
            for (list, pts) in [("waypoints", &r.waypoints), ("exploration", &r.exploration)] {
                if let Some((i, p)) = pts.iter().enumerate().find(|(_, p)| !(p[0].is_finite() && p[1].is_finite())) {
                    return Err(bad(format!("route.{list}[{i}]"), format!("must be finite, got {p:?}")));
                }
            }
        }
        Ok(())
    }

    /// Agents are kinematic and would pass through anything: their paths, swept by their
    /// footprints, must stay clear of walls, columns, rack footprints and movable items, and
    /// inside the interior.
    fn validate_agent_paths(&self, origin: &str) -> Result<(), SimError> {
        let mut solid: Vec<(String, Shape)> = Vec::new();
        solid.extend(self.walls.iter().map(|w| (format!("wall \"{}\"", w.id), w.shape.clone())));
        solid.extend(self.columns.iter().map(|w| (format!("column \"{}\"", w.id), w.shape.clone())));
        solid.extend(self.racks.iter().map(|r| (format!("rack \"{}\"", r.id), r.footprint())));
        solid.extend(self.movable.iter().map(|m| (format!("movable item \"{}\"", m.id), m.shape.clone())));
        for (i, a) in self.agents.iter().enumerate() {
            let reach = a.footprint.center().distance(Point2::new(0.0, 0.0)) + a.footprint.bounding_radius();
            let mut pts = a.motion.waypoints();
            if matches!(a.motion, Motion::Loop { .. }) && pts.len() >= 3 {
                pts.push(pts[0]);
            }
            let bad = |problem: String| SimError::Invalid {
                origin: origin.to_string(),
                entry: format!("agents[{i}] \"{}\"", a.id),
                problem,
            };
            if let Some(interior) = &self.interior
                && let Some((k, p)) = pts.iter().enumerate().find(|(_, p)| !interior.contains(**p))
            {
                return Err(bad(format!("waypoint {k} [{}, {}] lies outside the interior", p.x, p.y)));
            }
            for (k, seg) in pts.windows(2).enumerate() {
                for (what, shape) in &solid {
                    let d = shape.segment_distance(seg[0], seg[1]);
                    if d < reach - 1e-9 {
                        return Err(bad(format!(
                            "path segment {k} [{}, {}] → [{}, {}] comes within {d:.3} m of {what}, but the \
                             agent reaches {reach:.3} m from its path (agents pass through obstacles: keep \
                             their paths clear)",
                            seg[0].x, seg[0].y, seg[1].x, seg[1].y
                        )));
                    }
                }
            }
        }
        Ok(())
    }

    /// The entries' checks: unique non-empty ids, shapes, racks' posts, agents.
    fn validate_entries(&self, origin: &str) -> Result<(), SimError> {
        let bad = |entry: String, problem: String| SimError::Invalid { origin: origin.to_string(), entry, problem };
        let mut ids = BTreeSet::new();
        let mut check_id = |entry: &str, id: &str| -> Result<(), SimError> {
            if id.trim().is_empty() {
                return Err(bad(entry.to_string(), "id must not be empty".into()));
            }
            if !ids.insert(id.to_string()) {
                return Err(bad(entry.to_string(), format!("id \"{id}\" is used twice")));
            }
            Ok(())
        };
        for (list, items) in [("walls", &self.walls), ("columns", &self.columns)] {
            for (i, it) in items.iter().enumerate() {
                let entry = format!("{list}[{i}] \"{}\"", it.id);
                check_id(&entry, &it.id)?;
                if let Some(p) = it.shape.problem() {
                    return Err(bad(entry, p));
                }
            }
        }
        for (i, r) in self.racks.iter().enumerate() {
            let entry = format!("racks[{i}] \"{}\"", r.id);
            check_id(&entry, &r.id)?;
            if let Some(p) = r.footprint().problem() {
                return Err(bad(entry, p));
            }
            let min_side = r.size[0].min(r.size[1]);
            if !(r.post_size_m.is_finite() && r.post_size_m > 0.0 && r.post_size_m * 2.0 <= min_side) {
                return Err(bad(
                    entry,
                    format!("post_size_m must be > 0 and at most half the rack's depth, got {}", r.post_size_m),
                ));
            }
            if !(r.max_post_spacing_m.is_finite() && r.max_post_spacing_m >= r.post_size_m) {
                return Err(bad(
                    entry,
                    format!("max_post_spacing_m must be finite and ≥ post_size_m, got {}", r.max_post_spacing_m),
                ));
            }
            let intervals = r.post_intervals();
            if intervals > MAX_RACK_POST_INTERVALS as f64 {
                return Err(bad(
                    entry,
                    format!(
                        "{intervals:.3e} post intervals along its {:.3e} m side (at max_post_spacing_m {}); at \
                         most {MAX_RACK_POST_INTERVALS} are allowed: raise max_post_spacing_m or shorten the rack",
                        r.size[0].max(r.size[1]),
                        r.max_post_spacing_m
                    ),
                ));
            }
        }
        for (i, m) in self.movable.iter().enumerate() {
            let entry = format!("movable[{i}] \"{}\"", m.id);
            check_id(&entry, &m.id)?;
            if let Some(p) = m.shape.problem() {
                return Err(bad(entry, p));
            }
        }
        for (i, a) in self.storage_areas.iter().enumerate() {
            check_id(&format!("storage_areas[{i}] \"{}\"", a.id), &a.id)?;
        }
        for (i, a) in self.agents.iter().enumerate() {
            let entry = format!("agents[{i}] \"{}\"", a.id);
            check_id(&entry, &a.id)?;
            Self::agent_problem(a).map_or(Ok(()), |p| Err(bad(entry, p)))?;
        }
        let s = &self.robot_start;
        // A robot starting inside an obstacle would be stuck in (or thrown out of) a collider.
        let start = s.pose().position();
        if let Some((r, _)) = self.obstacles().into_iter().find(|(_, shape)| shape.contains(start)) {
            let (class, id) = match &r {
                ObstacleRef::Wall(id) => ("wall", id),
                ObstacleRef::Column(id) => ("column", id),
                ObstacleRef::Rack(id) => ("a post or frame of rack", id),
                ObstacleRef::Movable(id) => ("movable item", id),
                ObstacleRef::Agent(id) => ("agent", id),
            };
            return Err(bad("robot_start".into(), format!("({}, {}) lies inside {class} \"{id}\"", s.x, s.y)));
        }
        Ok(())
    }

    /// What is wrong with an agent's footprint, speed or motion, if anything.
    fn agent_problem(a: &Agent) -> Option<String> {
        let problem = || -> Result<(), String> {
            if let Some(p) = a.footprint.problem() {
                return Err(format!("footprint: {p}"));
            }
            if !(a.speed_mps.is_finite() && a.speed_mps > 0.0 && a.speed_mps <= 5.0) {
                return Err(format!("speed_mps must be in (0, 5] m/s, got {}", a.speed_mps));
            }
            let w = a.motion.waypoints();
            if w.len() < 2 {
                return Err(format!("motion needs at least 2 waypoints, got {}", w.len()));
            }
            if let Some(p) = w.iter().find(|p| !p.is_finite()) {
                return Err(format!("waypoint must be finite, got [{}, {}]", p.x, p.y));
            }
            if w.windows(2).any(|s| s[0].distance(s[1]) < 1e-6) {
                return Err("two consecutive waypoints coincide".into());
            }
            if let Motion::RandomWalk { max_pause_s, .. } | Motion::Loop { max_pause_s, .. } = a.motion
                && !(max_pause_s.is_finite() && max_pause_s >= 0.0)
            {
                return Err(format!("max_pause_s must be finite and ≥ 0, got {max_pause_s}"));
            }
            Ok(())
        };
        problem().err()
    }

    /// Every static and movable obstacle (not agents) as shapes in the map frame, in file order:
    /// walls, columns, rack parts, movable items.
    pub fn obstacles(&self) -> Vec<(ObstacleRef, Shape)> {
        let mut out = Vec::new();
        out.extend(self.walls.iter().map(|w| (ObstacleRef::Wall(w.id.clone()), w.shape.clone())));
        out.extend(self.columns.iter().map(|w| (ObstacleRef::Column(w.id.clone()), w.shape.clone())));
        for r in &self.racks {
            out.extend(r.parts().into_iter().map(|s| (ObstacleRef::Rack(r.id.clone()), s)));
        }
        out.extend(self.movable.iter().map(|m| (ObstacleRef::Movable(m.id.clone()), m.shape.clone())));
        out
    }

    /// Bounds of the interior (if any) and of every obstacle.
    pub fn bounds(&self) -> Bounds {
        let mut b = self.interior.as_ref().map_or(Bounds::EMPTY, Shape::bounds);
        for (_, s) in self.obstacles() {
            b = b.union(s.bounds());
        }
        let p = self.robot_start.pose().position();
        b.union(Bounds { min: p, max: p })
    }

    /// A grid geometry covering the world at `resolution_m`: the bounds of the interior and
    /// every obstacle, grown by 0.2 m and snapped outward to multiples of the resolution.
    pub fn default_map_geometry(&self, resolution_m: f64) -> Result<GridGeometry, SimError> {
        if !(resolution_m.is_finite() && resolution_m > 0.0) {
            return Err(SimError::Grid(mapkeeper_grid::GridError::BadResolution(resolution_m)));
        }
        let b = self.bounds();
        let margin = 0.2;
        let x0 = ((b.min.x - margin) / resolution_m).floor();
        let y0 = ((b.min.y - margin) / resolution_m).floor();
        let x1 = ((b.max.x + margin) / resolution_m).ceil();
        let y1 = ((b.max.y + margin) / resolution_m).ceil();
        let (w, h) = ((x1 - x0).max(1.0), (y1 - y0).max(1.0));
        if !(w.is_finite() && h.is_finite()) || w > 1e9 || h > 1e9 {
            return Err(SimError::Build(format!("world bounds {b:?} are not usable for a grid")));
        }
        Ok(GridGeometry::new(
            w as usize,
            h as usize,
            resolution_m,
            Pose2::new(x0 * resolution_m, y0 * resolution_m, 0.0),
        )?)
    }

    /// Looks an agent up by id.
    pub fn agent(&self, id: &str) -> Option<&Agent> {
        self.agents.iter().find(|a| a.id == id)
    }
}

/// Line and column (1-based) of a byte offset in `text`.
pub fn line_col(text: &str, byte: usize) -> (usize, usize) {
    let before = &text.as_bytes()[..byte.min(text.len())];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let col = before.iter().rev().take_while(|&&b| b != b'\n').count() + 1;
    (line, col)
}

/// Parses with line/column in messages (used by [`World::from_toml_str`]).
pub(crate) fn parse_toml<T: serde::de::DeserializeOwned>(text: &str, origin: &str) -> Result<T, SimError> {
    toml::from_str(text).map_err(|e| {
        let message = match e.span() {
            Some(span) => {
                let (l, c) = line_col(text, span.start);
                format!("line {l}, column {c}: {}", e.message().trim())
            }
            None => e.message().trim().to_string(),
        };
        SimError::Parse { origin: origin.to_string(), message }
    })
}
