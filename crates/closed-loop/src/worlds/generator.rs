//! The scenario generator: W_2 … W_N from W_1 by a few seeded edits per world to movable items
//! (add, remove, move, rotate boxes and pallets within storage areas), so that change
//! accumulates the way goods are rearranged over months (paper §5.3.2, Fig. 21).
//!
//! Every edit keeps the world drivable and physically plausible: an edited item lies inside a
//! storage area (new positions) and inside the world's interior, at least
//! [`GeneratorParams::route_clearance_m`] from the route polyline, clear of every agent's path
//! by the agent's size plus [`GeneratorParams::agent_clearance_m`], and at least
//! [`GeneratorParams::item_gap_m`] from static structure (walls, columns, rack footprints) and
//! from every other movable item. People and the other robot are kept from W_1. All randomness
//! comes from the one stream `stream_rng(seed, "generator")`.

use crate::worlds::WorldsError;
use crate::worlds::outline::Outline;
use mapkeeper_common::ParamError;
use mapkeeper_grid::Point2;
use mapkeeper_sim::seeds::stream_rng;
use mapkeeper_sim::{MovableItem, MovableKind, Route, Shape, World};
use rand::RngExt;
use rand::rngs::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// A storage area where goods may be put down: an axis-aligned box, or any shape (`shape`)
/// whose bounding box is `min`–`max`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StorageArea {
    /// Name (for reports).
    pub name: String,
    /// Lower-left corner `[x, y]`, metres.
    pub min: [f64; 2],
    /// Upper-right corner `[x, y]`, metres.
    pub max: [f64; 2],
    /// The area's outline when it is not the box `min`–`max` (a turned rectangle, a circle, a
    /// polygon): an item must lie inside it. Not written when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shape: Option<Shape>,
}

impl StorageArea {
    /// The area of a world's storage area: an unturned rectangle becomes its box (corners
    /// rounded to the millimetre), any other shape keeps its outline inside its bounding box.
    pub fn of_region(region: &mapkeeper_sim::StorageRegion) -> StorageArea {
        let b = region.shape.bounds();
        let mm = |v: f64| (v * 1000.0).round() / 1000.0;
        let boxed = matches!(region.shape, Shape::Rect { yaw_deg, .. } if yaw_deg.rem_euclid(180.0) == 0.0);
        StorageArea {
            name: region.id.clone(),
            min: [mm(b.min.x), mm(b.min.y)],
            max: [mm(b.max.x), mm(b.max.y)],
            shape: (!boxed).then(|| region.shape.clone()),
        }
    }

    fn area_m2(&self) -> f64 {
        match &self.shape {
            Some(s) => s.area().abs(),
            None => (self.max[0] - self.min[0]).max(0.0) * (self.max[1] - self.min[1]).max(0.0),
        }
    }

    fn holds(&self, shape: &Shape) -> bool {
        let b = shape.bounds();
        let in_box =
            b.min.x >= self.min[0] && b.min.y >= self.min[1] && b.max.x <= self.max[0] && b.max.y <= self.max[1];
        match &self.shape {
            None => in_box,
            // Every corner inside the outline and no corner of the outline inside the item (a
            // concave outline's notch); a circular item by its bounding box's corners.
            Some(area) => {
                let corners = shape.vertices().unwrap_or_else(|| {
                    vec![b.min, Point2::new(b.max.x, b.min.y), b.max, Point2::new(b.min.x, b.max.y)]
                });
                in_box
                    && corners.iter().all(|&c| area.contains(c))
                    && area.vertices().unwrap_or_default().iter().all(|&v| !shape.contains(v))
            }
        }
    }
}

/// The default warehouse's storage areas: the open floor where the stacks stand in W_1 (east
/// yard north of the racks, and the floor between the two aisles, north and south of the
/// cross aisle).
pub fn default_storage_areas() -> Vec<StorageArea> {
    vec![
        StorageArea { name: "east-yard".into(), min: [2.0, 1.2], max: [6.95, 10.42], shape: None },
        StorageArea { name: "centre-north".into(), min: [-2.7, -1.0], max: [0.3, 10.42], shape: None },
        StorageArea { name: "centre-south".into(), min: [-2.7, -10.42], max: [0.3, -3.5], shape: None },
    ]
}

/// Parameters of the generator.
///
/// ```
/// use mapkeeper_closed_loop::GeneratorParams;
/// let mut p = GeneratorParams::default();
/// assert_eq!(p.route_clearance_m, 0.98);
/// p.max_edits_per_world = 5;
/// assert!(p.validate().is_ok());
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GeneratorParams {
    /// Fewest edits per world (≥ 1). Default 1.
    pub min_edits_per_world: u32,
    /// Most edits per world. Default 3.
    pub max_edits_per_world: u32,
    /// Smallest distance from an edited item to the route polyline, metres. Default 0.98
    /// (robot width 0.68 m + 0.3 m).
    pub route_clearance_m: f64,
    /// Extra distance from an edited item to an agent's path, beyond the agent's bounding
    /// radius, metres. Default 0.15.
    pub agent_clearance_m: f64,
    /// Smallest gap between an edited item and static structure or another item, metres.
    /// Default 0.15.
    pub item_gap_m: f64,
    /// Adding is not tried with this many movable items or more. Default 30.
    pub max_items: usize,
    /// Removing is not tried with this many movable items or fewer. Default 8.
    pub min_items: usize,
    /// Placement attempts per edit before another edit is drawn. Default 60.
    pub attempts_per_edit: u32,
    /// Relative weights of add, remove, move, rotate. Default [0.25, 0.2, 0.35, 0.2].
    pub op_weights: [f64; 4],
    /// Where goods may be put down. Default: [`default_storage_areas`].
    pub storage_areas: Vec<StorageArea>,
    /// Harder worlds: from W_2 on, each world's route is the tour started at a seeded waypoint
    /// (a closed tour) and driven either way, and the robot starts at its first waypoint facing
    /// the second. Default false (the paper's setting: one route, one start; not written when
    /// false).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub route_variants: bool,
    /// Harder worlds: from W_2 on, every person stops and stands at each waypoint of its path for
    /// a seeded random time up to this many seconds (0 to 600). Default 0 (not written when 0).
    #[serde(skip_serializing_if = "is_zero")]
    pub people_pause_s: f64,
}

// serde's skip_serializing_if passes a reference.
#[allow(clippy::trivially_copy_pass_by_ref)]
fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl Default for GeneratorParams {
    fn default() -> Self {
        Self {
            min_edits_per_world: 1,
            max_edits_per_world: 3,
            route_clearance_m: 0.98,
            agent_clearance_m: 0.15,
            item_gap_m: 0.15,
            max_items: 30,
            min_items: 8,
            attempts_per_edit: 60,
            op_weights: [0.25, 0.2, 0.35, 0.2],
            storage_areas: default_storage_areas(),
            route_variants: false,
            people_pause_s: 0.0,
        }
    }
}

impl GeneratorParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), WorldsError> {
        let bad = |name, problem: String| Err(WorldsError::InvalidParam(ParamError::rule(name, problem)));
        if self.min_edits_per_world < 1 || self.max_edits_per_world < self.min_edits_per_world {
            return bad(
                "min_edits_per_world",
                format!("need 1 ≤ min ≤ max, got {} and {}", self.min_edits_per_world, self.max_edits_per_world),
            );
        }
        for (name, v) in [
            ("route_clearance_m", self.route_clearance_m),
            ("agent_clearance_m", self.agent_clearance_m),
            ("item_gap_m", self.item_gap_m),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(name, format!("must be a finite length ≥ 0 m, got {v}"));
            }
        }
        if !(self.people_pause_s.is_finite() && (0.0..=600.0).contains(&self.people_pause_s)) {
            return bad("people_pause_s", format!("must lie in 0..=600 s, got {}", self.people_pause_s));
        }
        if self.min_items > self.max_items {
            return bad("min_items", format!("{} exceeds max_items {}", self.min_items, self.max_items));
        }
        if self.attempts_per_edit == 0 {
            return bad("attempts_per_edit", "must be ≥ 1".into());
        }
        if self.op_weights.iter().any(|w| !(w.is_finite() && *w >= 0.0)) || self.op_weights.iter().sum::<f64>() <= 0.0 {
            return bad("op_weights", format!("must be finite, ≥ 0 and not all 0, got {:?}", self.op_weights));
        }
        if self.storage_areas.is_empty()
            || self.storage_areas.iter().any(|a| a.area_m2().is_nan() || a.area_m2() <= 0.0)
        {
            return bad("storage_areas", "need at least one area, each with max > min".into());
        }
        for a in &self.storage_areas {
            let finite = a.min.iter().chain(&a.max).all(|v| v.is_finite());
            if !finite || a.max[0] <= a.min[0] || a.max[1] <= a.min[1] {
                return bad("storage_areas", format!("area \"{}\" needs finite corners with max > min", a.name));
            }
            if let Some(p) = a.shape.as_ref().and_then(Shape::problem) {
                return bad("storage_areas", format!("area \"{}\": {p}", a.name));
            }
        }
        Ok(())
    }
}

/// One edit the generator made.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub enum Edit {
    /// A new item.
    Add {
        /// Its id.
        id: String,
        /// Its outline.
        shape: Shape,
    },
    /// An item taken away.
    Remove {
        /// Its id.
        id: String,
    },
    /// An item put somewhere else.
    Move {
        /// Its id.
        id: String,
        /// New centre `[x, y]`, metres.
        to: [f64; 2],
    },
    /// An item turned in place.
    Rotate {
        /// Its id.
        id: String,
        /// New yaw, degrees.
        yaw_deg: f64,
    },
}

/// W_1 … W_N and the edits that made each from its predecessor (`edits[0]` is empty).
#[derive(Clone, Debug, PartialEq)]
pub struct WorldChain {
    /// The worlds, W_1 first.
    pub worlds: Vec<World>,
    /// `edits[i]`: the edits that turned `worlds[i-1]` into `worlds[i]`.
    pub edits: Vec<Vec<Edit>>,
    /// `routes[i]`: the route driven in `worlds[i]` (all the given route unless
    /// [`GeneratorParams::route_variants`]).
    pub routes: Vec<Route>,
}

/// Fixed obstacles a placement must keep clear of, precomputed once.
struct Context {
    statics: Vec<Outline>,
    route: Outline,
    agent_paths: Vec<(Outline, f64)>,
    interior: Option<Shape>,
}

impl Context {
    fn new(world: &World, route: &Route) -> Context {
        let mut statics: Vec<Outline> = Vec::new();
        statics.extend(world.walls.iter().map(|w| Outline::of_shape(&w.shape)));
        statics.extend(world.columns.iter().map(|w| Outline::of_shape(&w.shape)));
        statics.extend(world.racks.iter().map(|r| Outline::of_shape(&r.footprint())));
        let mut pts = route.points();
        pts.insert(0, world.robot_start.pose().position());
        let agent_paths = world
            .agents
            .iter()
            .map(|a| {
                let mut w = a.motion.waypoints();
                if matches!(a.motion, mapkeeper_sim::Motion::Loop { .. })
                    && let Some(&first) = w.first()
                {
                    w.push(first);
                }
                let reach = a.footprint.center().distance(Point2::new(0.0, 0.0)) + a.footprint.bounding_radius();
                (Outline::Polyline(w), reach)
            })
            .collect();
        Context { statics, route: Outline::Polyline(pts), agent_paths, interior: world.interior.clone() }
    }
}

/// Whether `shape` may stand in `world` (ignoring the item `exclude`, the one being edited).
fn placement_ok(ctx: &Context, p: &GeneratorParams, world: &World, shape: &Shape, exclude: Option<&str>) -> bool {
    if shape.problem().is_some() {
        return false;
    }
    if let Some(interior) = &ctx.interior {
        let inside = match shape.vertices() {
            Some(v) => v.iter().all(|q| interior.contains(*q)),
            None => interior.contains(shape.center()),
        };
        if !inside {
            return false;
        }
    }
    let o = Outline::of_shape(shape);
    if o.distance(&ctx.route) < p.route_clearance_m {
        return false;
    }
    if ctx.agent_paths.iter().any(|(path, r)| o.distance(path) < r + p.agent_clearance_m) {
        return false;
    }
    if ctx.statics.iter().any(|s| o.distance(s) < p.item_gap_m) {
        return false;
    }
    world
        .movable
        .iter()
        .filter(|m| Some(m.id.as_str()) != exclude)
        .all(|m| o.distance(&Outline::of_shape(&m.shape)) >= p.item_gap_m)
}

/// A random centre in a random storage area (chosen by area).
fn random_point(rng: &mut ChaCha8Rng, areas: &[StorageArea]) -> (usize, Point2) {
    let total: f64 = areas.iter().map(StorageArea::area_m2).sum();
    let mut u = rng.random::<f64>() * total;
    let mut k = areas.len() - 1;
    for (i, a) in areas.iter().enumerate() {
        if u < a.area_m2() {
            k = i;
            break;
        }
        u -= a.area_m2();
    }
    let a = &areas[k];
    (k, Point2::new(rng.random_range(a.min[0]..a.max[0]), rng.random_range(a.min[1]..a.max[1])))
}

/// A new item's kind and footprint `[x, y]`, metres (pallets 1.2 × 0.8 or 1.2 × 1.0, boxes and
/// box stacks 0.5-1.4 m a side, bins, buckets).
fn random_item(rng: &mut ChaCha8Rng) -> (MovableKind, [f64; 2]) {
    let r = rng.random::<f64>();
    let round = |v: f64| (v * 100.0).round() / 100.0;
    if r < 0.35 {
        let depth = if rng.random::<f64>() < 0.5 { 0.8 } else { 1.0 };
        let stacked = if rng.random::<f64>() < 0.4 { 2.0 } else { 1.0 };
        (MovableKind::PalletStack, [1.2 * stacked, depth])
    } else if r < 0.8 {
        (MovableKind::Box, [round(rng.random_range(0.5..1.4)), round(rng.random_range(0.5..1.4))])
    } else if r < 0.9 {
        (MovableKind::Bin, [1.48, 0.91])
    } else {
        (MovableKind::Bucket, [0.94, 1.22])
    }
}

fn with_center(shape: &Shape, c: Point2) -> Shape {
    match shape {
        Shape::Rect { size, yaw_deg, .. } => Shape::Rect { center: [c.x, c.y], size: *size, yaw_deg: *yaw_deg },
        Shape::Circle { radius, .. } => Shape::Circle { center: [c.x, c.y], radius: *radius },
        Shape::Polygon { points } => {
            let old = shape.center();
            Shape::Polygon { points: points.iter().map(|p| [p[0] - old.x + c.x, p[1] - old.y + c.y]).collect() }
        }
    }
}

fn with_yaw(shape: &Shape, yaw: f64) -> Option<Shape> {
    match shape {
        Shape::Rect { center, size, .. } => Some(Shape::Rect { center: *center, size: *size, yaw_deg: yaw }),
        _ => None,
    }
}

fn yaw_of(shape: &Shape) -> f64 {
    match shape {
        Shape::Rect { yaw_deg, .. } => *yaw_deg,
        _ => 0.0,
    }
}

/// Normalises degrees to (−180, 180].
fn norm_deg(d: f64) -> f64 {
    let mut a = d % 360.0;
    if a <= -180.0 {
        a += 360.0;
    } else if a > 180.0 {
        a -= 360.0;
    }
    a
}

/// Rounds coordinates to the millimetre so that the TOML stays short and exact.
fn mm(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

/// Tries one edit of kind `op` on `world`; returns it if it was made.
fn try_edit(
    op: usize,
    rng: &mut ChaCha8Rng,
    ctx: &Context,
    p: &GeneratorParams,
    world: &mut World,
    next_id: &mut u64,
    world_no: usize,
) -> Option<Edit> {
    let n = world.movable.len();
    match op {
        0 => {
            if n >= p.max_items {
                return None;
            }
            let (kind, size) = random_item(rng);
            let yaw = if rng.random::<f64>() < 0.5 { 0.0 } else { 90.0 };
            for _ in 0..p.attempts_per_edit {
                let (k, c) = random_point(rng, &p.storage_areas);
                let shape = Shape::rect(Point2::new(mm(c.x), mm(c.y)), size, yaw);
                if p.storage_areas[k].holds(&shape) && placement_ok(ctx, p, world, &shape, None) {
                    let id = format!("gen-{world_no:03}-{next_id}");
                    *next_id += 1;
                    world.movable.push(MovableItem { id: id.clone(), kind, shape: shape.clone() });
                    return Some(Edit::Add { id, shape });
                }
            }
            None
        }
        1 => {
            if n <= p.min_items || n == 0 {
                return None;
            }
            let i = rng.random_range(0..n);
            let item = world.movable.remove(i);
            Some(Edit::Remove { id: item.id })
        }
        2 => {
            if n == 0 {
                return None;
            }
            let i = rng.random_range(0..n);
            for _ in 0..p.attempts_per_edit {
                let (k, c) = random_point(rng, &p.storage_areas);
                let c = Point2::new(mm(c.x), mm(c.y));
                let shape = with_center(&world.movable[i].shape, c);
                if p.storage_areas[k].holds(&shape) && placement_ok(ctx, p, world, &shape, Some(&world.movable[i].id)) {
                    world.movable[i].shape = shape;
                    return Some(Edit::Move { id: world.movable[i].id.clone(), to: [c.x, c.y] });
                }
            }
            None
        }
        _ => {
            if n == 0 {
                return None;
            }
            let i = rng.random_range(0..n);
            for _ in 0..p.attempts_per_edit.min(8) {
                let turn = match rng.random_range(0..4u32) {
                    0 => 90.0,
                    1 => -90.0,
                    2 => rng.random_range(10.0..45.0f64).round(),
                    _ => -rng.random_range(10.0..45.0f64).round(),
                };
                let yaw = norm_deg(yaw_of(&world.movable[i].shape) + turn);
                let shape = with_yaw(&world.movable[i].shape, yaw)?;
                if placement_ok(ctx, p, world, &shape, Some(&world.movable[i].id)) {
                    world.movable[i].shape = shape;
                    return Some(Edit::Rotate { id: world.movable[i].id.clone(), yaw_deg: yaw });
                }
            }
            None
        }
    }
}

/// Generates W_1 … W_`count` from `base` (W_1) for `route`, seeded by `seed` (stream
/// `"generator"`). The first k worlds are the same for any `count ≥ k`.
///
/// ```
/// use mapkeeper_closed_loop::{GeneratorParams, generate_worlds};
/// use mapkeeper_sim::{Route, World};
/// let chain = generate_worlds(&World::default_warehouse(), &Route::default_warehouse(), 4, 7,
///     &GeneratorParams::default()).unwrap();
/// assert_eq!(chain.worlds.len(), 4);
/// assert!(chain.edits[1..].iter().all(|e| !e.is_empty()));
/// assert_ne!(chain.worlds[3].movable, chain.worlds[0].movable);
/// ```
pub fn generate_worlds(
    base: &World,
    route: &Route,
    count: usize,
    seed: u64,
    params: &GeneratorParams,
) -> Result<WorldChain, WorldsError> {
    params.validate()?;
    if count == 0 {
        return Err(WorldsError::InvalidParam(ParamError::rule("worlds", "need at least one world")));
    }
    let ctx = Context::new(base, route);
    let mut rng = stream_rng(seed, "generator");
    let mut worlds = vec![base.clone()];
    let mut edits = vec![Vec::new()];
    let weights_total: f64 = params.op_weights.iter().sum();
    let mut next_id = 1u64;
    for w in 2..=count {
        let mut world = worlds[w - 2].clone();
        world.name = format!("{}-W{w:03}", base.name);
        let want = rng.random_range(params.min_edits_per_world..=params.max_edits_per_world) as usize;
        let mut made = Vec::new();
        let mut tries = 0;
        while made.len() < want && tries < 20 * want {
            tries += 1;
            let mut u = rng.random::<f64>() * weights_total;
            let mut op = 3;
            for (k, wt) in params.op_weights.iter().enumerate() {
                if u < *wt {
                    op = k;
                    break;
                }
                u -= wt;
            }
            if let Some(e) = try_edit(op, &mut rng, &ctx, params, &mut world, &mut next_id, w) {
                made.push(e);
            }
        }
        if made.is_empty() {
            return Err(WorldsError::Generator(format!("no edit could be made for world {w}")));
        }
        world.validate(&world.name.clone())?;
        worlds.push(world);
        edits.push(made);
    }
    let routes = harden(&mut worlds, route, seed, params)?;
    Ok(WorldChain { worlds, edits, routes })
}

/// The route of `route` started at waypoint `k` of its cycle (a closed tour: first = last),
/// reversed if asked; an open route can only be reversed.
pub fn route_variant(route: &Route, k: usize, reverse: bool) -> Route {
    let p = route.points();
    let closed = p.len() >= 3 && p[0].distance(p[p.len() - 1]) < 1e-9;
    let mut q: Vec<Point2> = if closed {
        let cycle = &p[..p.len() - 1];
        let k = k % cycle.len();
        let mut v: Vec<Point2> = cycle[k..].iter().chain(&cycle[..k]).copied().collect();
        v.push(v[0]);
        v
    } else {
        p
    };
    if reverse {
        q.reverse();
    }
    Route::new(&q)
}

/// The harder-world knobs on W_2..W_N: route variants with their start poses, people who stop
/// and stand. Returns each world's route. Its random stream is its own, so the edits (and the
/// default worlds) do not change with the knobs.
fn harden(worlds: &mut [World], route: &Route, seed: u64, params: &GeneratorParams) -> Result<Vec<Route>, WorldsError> {
    let mut rng = stream_rng(seed, "generator/harder");
    let mut routes = vec![route.clone()];
    for w in worlds.iter_mut().skip(1) {
        if params.people_pause_s > 0.0 {
            for a in w.agents.iter_mut().filter(|a| a.kind == mapkeeper_sim::AgentKind::Person) {
                match &mut a.motion {
                    mapkeeper_sim::Motion::Loop { max_pause_s, .. }
                    | mapkeeper_sim::Motion::RandomWalk { max_pause_s, .. } => *max_pause_s = params.people_pause_s,
                }
            }
        }
        if !params.route_variants {
            routes.push(route.clone());
            continue;
        }
        // The waypoints of the cycle (a closed tour repeats its first at the end).
        let n = route.waypoints.len().saturating_sub(1).max(1);
        let r = route_variant(route, rng.random_range(0..n), rng.random::<bool>());
        let p = r.points();
        if p.len() >= 2 {
            let yaw = (p[1].y - p[0].y).atan2(p[1].x - p[0].x);
            w.robot_start = mapkeeper_sim::StartPose { x: p[0].x, y: p[0].y, yaw_deg: yaw.to_degrees() };
        }
        w.validate(&w.name.clone())?;
        routes.push(r);
    }
    Ok(routes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chain(n: usize, seed: u64) -> WorldChain {
        generate_worlds(&World::default_warehouse(), &Route::default_warehouse(), n, seed, &GeneratorParams::default())
            .unwrap()
    }

    #[test]
    fn harder_worlds_vary_the_route_and_start_and_keep_the_edits() {
        let (w1, route) = (World::default_warehouse(), Route::default_warehouse());
        let plain = chain(12, 5);
        assert!(plain.routes.iter().all(|r| *r == route), "the default keeps the paper's one route");
        let params = GeneratorParams { route_variants: true, people_pause_s: 15.0, ..GeneratorParams::default() };
        let hard = generate_worlds(&w1, &route, 12, 5, &params).unwrap();
        assert_eq!(hard.edits, plain.edits, "the knobs draw from their own stream: the same edits");
        assert_eq!(hard.routes[0], route);
        let distinct: std::collections::BTreeSet<String> =
            hard.routes.iter().map(|r| format!("{:?}", r.waypoints)).collect();
        assert!(distinct.len() >= 6, "{} distinct routes in 12 worlds", distinct.len());
        for (w, r) in hard.worlds.iter().zip(&hard.routes).skip(1) {
            let p = r.points();
            assert!((r.length_m() - route.length_m()).abs() < 1e-9, "a variant drives the same tour");
            assert!((w.robot_start.x - p[0].x).abs() < 1e-12 && (w.robot_start.y - p[0].y).abs() < 1e-12);
            let people: Vec<_> = w.agents.iter().filter(|a| a.kind == mapkeeper_sim::AgentKind::Person).collect();
            assert!(!people.is_empty(), "no person to check the pause of");
            for a in people {
                let pause = match a.motion {
                    mapkeeper_sim::Motion::Loop { max_pause_s, .. }
                    | mapkeeper_sim::Motion::RandomWalk { max_pause_s, .. } => max_pause_s,
                };
                assert_eq!(pause, 15.0);
            }
        }
        // An open route can only be reversed.
        let open = Route::new(&[Point2::new(0.0, 0.0), Point2::new(1.0, 0.0), Point2::new(1.0, 1.0)]);
        assert_eq!(route_variant(&open, 1, false), open);
        assert_eq!(route_variant(&open, 1, true).points()[0], Point2::new(1.0, 1.0));
        let bad = GeneratorParams { people_pause_s: -1.0, ..GeneratorParams::default() };
        assert!(bad.validate().unwrap_err().to_string().contains("people_pause_s"));
    }

    #[test]
    fn same_seed_same_worlds_and_prefix_stable() {
        let a = chain(12, 3);
        let b = chain(12, 3);
        assert_eq!(a, b);
        let c = chain(6, 3);
        assert_eq!(&a.worlds[..6], &c.worlds[..]);
        assert_ne!(chain(12, 4).worlds[11], a.worlds[11]);
    }

    #[test]
    fn every_edited_item_keeps_its_clearances() {
        let p = GeneratorParams::default();
        let route = Route::default_warehouse();
        let base = World::default_warehouse();
        let ctx = Context::new(&base, &route);
        let c = chain(60, 11);
        let mut checked = 0;
        for (w, world) in c.worlds.iter().enumerate().skip(1) {
            let mut checked_here = 0;
            for m in &world.movable {
                // Items never touched keep their W_1 place; all others obey the rules.
                if base.movable.contains(m) {
                    continue;
                }
                checked_here += 1;
                let o = Outline::of_shape(&m.shape);
                assert!(o.distance(&ctx.route) >= p.route_clearance_m - 1e-9, "W{} {} too near the route", w + 1, m.id);
                assert!(ctx.statics.iter().all(|s| o.distance(s) >= p.item_gap_m - 1e-9), "{} hits structure", m.id);
                for other in &world.movable {
                    if other.id != m.id {
                        let d = o.distance(&Outline::of_shape(&other.shape));
                        assert!(d >= p.item_gap_m - 1e-9, "W{} {} overlaps {} ({d})", w + 1, m.id, other.id);
                    }
                }
            }
            // Every world edits at least `min_edits_per_world` items on the way from W_1.
            assert!(checked_here > 0, "W{}: no edited item to check", w + 1);
            checked += checked_here;
        }
        assert!(checked >= 59, "{checked} edited items checked in W2..W60");
    }

    #[test]
    fn change_accumulates() {
        let c = chain(100, 1);
        let base = &c.worlds[0].movable;
        let unchanged = |w: &World| w.movable.iter().filter(|m| base.contains(m)).count();
        let u50 = unchanged(&c.worlds[49]);
        let u100 = unchanged(&c.worlds[99]);
        assert!(u50 < base.len() / 2, "W50 keeps {u50} of {} items", base.len());
        assert!(u100 <= u50);
        assert!(c.worlds.iter().all(|w| w.agents == c.worlds[0].agents));
    }

    #[test]
    fn bad_params_are_refused() {
        let p = GeneratorParams { min_edits_per_world: 0, ..GeneratorParams::default() };
        assert!(p.validate().is_err());
        let p = GeneratorParams { storage_areas: vec![], ..GeneratorParams::default() };
        assert!(p.validate().is_err());
        let p = GeneratorParams { item_gap_m: f64::NAN, ..GeneratorParams::default() };
        assert!(p.validate().is_err());
    }
}
