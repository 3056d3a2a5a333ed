//! A world's scenario: its storage areas and its route, as the world file gives them or derived
//! from its geometry, and the check that the route can be driven (`docs/world-format.md`).
//!
//! - **Route**: the world's `[route]`, or a `--route` file, or planned: a seeded, deterministic
//!   closed patrol from the robot's start that visits one point of every `cover_spacing_m`
//!   square of the floor the robot can reach with `plan_clearance_m` to every obstacle (the
//!   point of most clearance in the square), in nearest-first order along the floor, joined by
//!   shortest paths that prefer the middle of the aisles, and straightened where the straight
//!   line keeps the clearance.
//! - **Storage areas**: the world's `[[storage_areas]]`, or derived: the largest axis-aligned
//!   rectangles (up to `max_areas`, each at least `area_min_side_m` a side) of floor that the
//!   robot's start reaches, at least `area_wall_gap_m` from static structure (walls, columns,
//!   rack footprints; movable items are ignored: their places are storage), inside the interior
//!   and at least `area_route_gap_m` from the route.
//! - **Check**: every leg of the route (from the start to the first waypoint, then waypoint to
//!   waypoint) keeps `route_clearance_m` from walls, columns, rack footprints and W_1's movable
//!   items, and every waypoint lies inside the interior; otherwise the world is refused naming
//!   the waypoint, its coordinates and the obstacle.

use crate::worlds::WorldsError;
use crate::worlds::generator::StorageArea;
use mapkeeper_grid::{CellCoord, CellState, DistanceField, GridGeometry, Point2};
use mapkeeper_sim::seeds::stream_rng;
use mapkeeper_sim::{Route, Shape, StorageRegion, World, WorldRoute, ground_truth_map};
use rand::RngExt;
use std::collections::{BinaryHeap, VecDeque};

/// Parameters of the derivation and the check.
#[derive(Clone, Debug, PartialEq)]
pub struct SiteParams {
    /// Smallest distance from the route to an obstacle, metres. Default 0.45: half the
    /// Summit-XL's 0.68 m width and 11 cm.
    pub route_clearance_m: f64,
    /// Clearance the planner keeps, metres (on its raster). Default 0.65: the robot's half
    /// diagonal (0.51 m, swept when it turns) and what the path follower cuts off corners.
    pub plan_clearance_m: f64,
    /// Cell size of the planner's raster, metres (made coarser on large worlds, to at most
    /// 400 000 cells). Default 0.1.
    pub plan_resolution_m: f64,
    /// Side of the squares the patrol visits one point of, metres. Default 3.0.
    pub cover_spacing_m: f64,
    /// Seed of the patrol (the offset of its squares). Default 0.
    pub seed: u64,
    /// Most derived storage areas. Default 8.
    pub max_areas: usize,
    /// Shortest side of a derived storage area, metres. Default 1.2.
    pub area_min_side_m: f64,
    /// Gap between a derived storage area and static structure, metres. Default 0.3.
    pub area_wall_gap_m: f64,
    /// Gap between a derived storage area and the route, metres. Default 1.1 (the generator's
    /// route clearance, 0.98 m, plus a cell).
    pub area_route_gap_m: f64,
    /// Longest side of a storage area derived before the route is planned, metres. Default 3.0.
    pub area_max_side_m: f64,
    /// Whether the exploration tour is checked too (it is driven in this world as W_1); false
    /// for a world that is only driven along its route (`run`). Default true.
    pub check_exploration: bool,
}

impl Default for SiteParams {
    fn default() -> Self {
        SiteParams {
            route_clearance_m: 0.45,
            plan_clearance_m: 0.65,
            plan_resolution_m: 0.1,
            cover_spacing_m: 3.0,
            seed: 0,
            max_areas: 8,
            area_min_side_m: 1.2,
            area_wall_gap_m: 0.3,
            area_route_gap_m: 1.1,
            area_max_side_m: 3.0,
            check_exploration: true,
        }
    }
}

/// A world with its scenario resolved.
#[derive(Clone, Debug, PartialEq)]
pub struct Site {
    /// The world, its `storage_areas` and `route` filled in (what generated worlds carry).
    pub world: World,
    /// The route driven in every W_i.
    pub route: Route,
    /// The exploration tour of W_1 for M_1.
    pub exploration: Route,
    /// The generator's storage areas.
    pub storage: Vec<StorageArea>,
    /// Whether the route was planned (the world has none and no route file was given).
    pub planned_route: bool,
    /// Whether the storage areas were derived (the world has none).
    pub derived_areas: bool,
}

fn refuse(origin: &str, problem: String) -> WorldsError {
    WorldsError::Generator(format!("{origin}: {problem}"))
}

impl Site {
    /// Resolves `world`'s scenario (`origin` names it in errors): the route from `route`
    /// (a `--route` file), else the world's, else planned; the storage areas from the world,
    /// else derived. The route and the exploration tour are checked ([`check_route`]).
    pub fn resolve(world: &World, route: Option<&Route>, origin: &str, p: &SiteParams) -> Result<Site, WorldsError> {
        let given = match (route, &world.route) {
            (Some(r), _) => Some(r.clone()),
            (None, Some(r)) => Some(r.route()),
            (None, None) => None,
        };
        let derived_areas = world.storage_areas.is_empty();
        let (route, planned_route, regions) = match given {
            Some(r) => {
                let regions =
                    if derived_areas { derive_storage_areas(world, Some(&r), p) } else { world.storage_areas.clone() };
                (r, false, regions)
            }
            None if !derived_areas => {
                (plan_route(world, &world.storage_areas, origin, p)?, true, world.storage_areas.clone())
            }
            None => {
                // Areas first (each kept only if the patrol can live with it: `areas_fit`), the
                // patrol around them.
                // Largest first: the first size (3 m a side, then smaller down to the shortest
                // side) that leaves at least one area the patrol can live with.
                let open = Floor::new(world, p.plan_resolution_m, true, &[])?;
                let mut regions = Vec::new();
                for side in area_sides(p) {
                    let q = SiteParams { area_max_side_m: side, ..p.clone() };
                    for a in derive_storage_areas(world, None, &q) {
                        regions.push(a);
                        if !areas_fit(&open, world, &regions, p)? {
                            regions.pop();
                        }
                    }
                    if !regions.is_empty() {
                        break;
                    }
                }
                (plan_route(world, &regions, origin, p)?, true, regions)
            }
        };

        let exploration = match &world.route {
            Some(r) if !r.exploration.is_empty() => r.exploration_route(),
            _ => route.clone(),
        };
        check_route(world, &route, origin, "route.waypoints", p.route_clearance_m)?;
        if p.check_exploration && exploration != route {
            check_route(world, &exploration, origin, "route.exploration", p.route_clearance_m)?;
        }
        let mut resolved = world.clone();
        resolved.storage_areas.clone_from(&regions);
        let own_exploration = if exploration == route { vec![] } else { exploration.waypoints.clone() };
        resolved.route = Some(WorldRoute { waypoints: route.waypoints.clone(), exploration: own_exploration });
        resolved.validate(origin)?;
        Ok(Site {
            world: resolved,
            route,
            exploration,
            storage: regions.iter().map(StorageArea::of_region).collect(),
            planned_route,
            derived_areas,
        })
    }
}

impl Site {
    /// Refuses a site without storage areas (the scenario generator needs one), naming `origin`.
    pub fn require_storage(&self, origin: &str, p: &SiteParams) -> Result<(), WorldsError> {
        if self.storage.is_empty() {
            return Err(refuse(
                origin,
                format!(
                    "storage_areas: none given and none could be derived (no floor {} m a side, {} m from static \
                     structure and {} m from the route)",
                    p.area_min_side_m, p.area_wall_gap_m, p.area_route_gap_m
                ),
            ));
        }
        Ok(())
    }
}

/// The sides tried for derived storage areas before the route is planned: `area_max_side_m`,
/// then 0.6 m less each time, down to `area_min_side_m`.
fn area_sides(p: &SiteParams) -> Vec<f64> {
    let mut sides = vec![p.area_max_side_m];
    let mut s = p.area_max_side_m - 0.6;
    while s > p.area_min_side_m + 1e-9 {
        sides.push(s);
        s -= 0.6;
    }
    if p.area_min_side_m < p.area_max_side_m {
        sides.push(p.area_min_side_m);
    }
    sides
}

/// The solid obstacles of a world for driving: walls, columns, rack footprints and (with
/// `movable`) movable items, each with its description.
fn solids(world: &World, movable: bool) -> Vec<(String, Shape)> {
    let mut out: Vec<(String, Shape)> = Vec::new();
    out.extend(world.walls.iter().map(|w| (format!("wall \"{}\"", w.id), w.shape.clone())));
    out.extend(world.columns.iter().map(|w| (format!("column \"{}\"", w.id), w.shape.clone())));
    out.extend(world.racks.iter().map(|r| (format!("rack \"{}\"", r.id), r.footprint())));
    if movable {
        out.extend(world.movable.iter().map(|m| (format!("movable item \"{}\"", m.id), m.shape.clone())));
    }
    out
}

/// Refuses a route the robot cannot drive in `world`: a waypoint outside the interior, or a
/// leg (start → waypoint 0, waypoint i → i+1) closer than `clearance_m` to a wall, column, rack
/// footprint or movable item. `entry` names the list in the message (`route.waypoints`).
pub fn check_route(
    world: &World,
    route: &Route,
    origin: &str,
    entry: &str,
    clearance_m: f64,
) -> Result<(), WorldsError> {
    let pts = route.points();
    if pts.is_empty() {
        return Err(refuse(origin, format!("{entry}: a route needs at least one waypoint")));
    }
    if let Some(interior) = &world.interior
        && let Some((i, p)) = pts.iter().enumerate().find(|(_, p)| !interior.contains(**p))
    {
        return Err(refuse(origin, format!("{entry}[{i}] [{}, {}] lies outside the interior", p.x, p.y)));
    }
    let start = world.robot_start.pose().position();
    let obstacles = solids(world, true);
    let legs = std::iter::once((start, pts[0])).chain(pts.windows(2).map(|w| (w[0], w[1])));
    for (i, (a, b)) in legs.enumerate() {
        for (what, shape) in &obstacles {
            let d = shape.segment_distance(a, b);
            if d < clearance_m {
                let leg = if i == 0 {
                    format!("{entry}[0] [{}, {}] (the leg from robot_start [{}, {}])", b.x, b.y, a.x, a.y)
                } else {
                    format!("{entry}[{}] [{}, {}] → {entry}[{i}] [{}, {}]", i - 1, a.x, a.y, b.x, b.y)
                };
                let why = if d <= 0.0 { "is blocked by".to_string() } else { format!("passes {d:.2} m from") };
                return Err(refuse(
                    origin,
                    format!("{leg} {why} {what}: the robot needs {clearance_m} m (half its width and a margin)"),
                ));
            }
        }
    }
    Ok(())
}

/// The planner's raster of a world: static and movable obstacles rasterised at a resolution
/// that keeps the grid under 400 000 cells, the clearance of every cell, and what the robot's
/// start reaches.
struct Floor {
    geo: GridGeometry,
    /// Clearance of each cell's centre to the nearest blocked cell, metres (0 for blocked).
    clear: Vec<f32>,
}

impl Floor {
    fn new(world: &World, res: f64, movable: bool, keep_off: &[Shape]) -> Result<Floor, WorldsError> {
        let mut solid = world.clone();
        solid
            .columns
            .extend(world.racks.iter().map(|r| mapkeeper_sim::StaticItem { id: r.id.clone(), shape: r.footprint() }));
        solid.columns.extend(
            keep_off
                .iter()
                .enumerate()
                .map(|(k, s)| mapkeeper_sim::StaticItem { id: format!("keep-off-{k}"), shape: s.clone() }),
        );
        solid.racks.clear();
        solid.agents.clear();
        if !movable {
            solid.movable.clear();
        }
        let mut res = res;
        let mut geo = world.default_map_geometry(res)?;
        while geo.len() > 400_000 {
            res *= 1.25;
            geo = world.default_map_geometry(res)?;
        }
        let gt = ground_truth_map(&solid, &geo);
        let field = DistanceField::from_sites(&geo, 1e3, |i| gt.cells()[i] != CellState::Free);
        let half = (res / 2.0) as f32;
        let clear = field.distances_m().iter().map(|&d| (d - half).max(0.0)).collect();
        Ok(Floor { geo, clear })
    }

    /// The cells reachable from `from` through cells of clearance ≥ `c` (8-connected), or
    /// `None` when `from`'s cell has less.
    fn reach(&self, from: Point2, c: f64) -> Option<Vec<bool>> {
        let start = self.geo.world_to_cell(from).and_then(|cc| self.geo.index(cc))?;
        if f64::from(self.clear[start]) < c {
            return None;
        }
        let mut seen = vec![false; self.geo.len()];
        seen[start] = true;
        let mut queue = VecDeque::from([start]);
        while let Some(i) = queue.pop_front() {
            for n in self.geo.coord(i).neighbours8() {
                if let Some(j) = self.geo.index(n)
                    && !seen[j]
                    && f64::from(self.clear[j]) >= c
                {
                    seen[j] = true;
                    queue.push_back(j);
                }
            }
        }
        Some(seen)
    }

    /// Whether the segment `a`–`b` keeps clearance `c` on the raster (sampled every half cell).
    fn line_clear(&self, a: Point2, b: Point2, c: f64) -> bool {
        let step = self.geo.resolution_m() / 2.0;
        let n = (a.distance(b) / step).ceil().max(1.0) as usize;
        (0..=n).all(|k| {
            let t = k as f64 / n as f64;
            let p = Point2::new(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y));
            self.geo.world_to_cell(p).and_then(|cc| self.geo.index(cc)).is_some_and(|i| f64::from(self.clear[i]) >= c)
        })
    }
}

/// Dijkstra from `from` over `ok` cells (8-connected; a step costs its length times a penalty
/// that grows as the clearance falls below 1 m, to keep to the middle of aisles) until a cell
/// with `is_goal` is settled: that cell and the path to it (cells, `from` first).
fn nearest(floor: &Floor, ok: &[bool], from: usize, is_goal: &dyn Fn(usize) -> bool) -> Option<(usize, Vec<usize>)> {
    #[derive(PartialEq)]
    struct Item(f64, usize);
    impl Eq for Item {}
    impl PartialOrd for Item {
        fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
            Some(self.cmp(o))
        }
    }
    impl Ord for Item {
        fn cmp(&self, o: &Self) -> std::cmp::Ordering {
            o.0.total_cmp(&self.0).then_with(|| o.1.cmp(&self.1))
        }
    }
    let n = floor.geo.len();
    let mut dist = vec![f64::INFINITY; n];
    let mut prev = vec![usize::MAX; n];
    let mut heap = BinaryHeap::from([Item(0.0, from)]);
    dist[from] = 0.0;
    while let Some(Item(d, i)) = heap.pop() {
        if d > dist[i] {
            continue;
        }
        if is_goal(i) {
            let mut path = vec![i];
            while let Some(&last) = path.last() {
                if prev[last] == usize::MAX {
                    break;
                }
                path.push(prev[last]);
            }
            path.reverse();
            return Some((i, path));
        }
        let c = floor.geo.coord(i);
        for n in c.neighbours8() {
            let Some(j) = floor.geo.index(n) else { continue };
            if !ok[j] {
                continue;
            }
            let len = if n.ix != c.ix && n.iy != c.iy { std::f64::consts::SQRT_2 } else { 1.0 };
            let penalty = 1.0 + 3.0 * (1.0 - f64::from(floor.clear[j])).max(0.0);
            let nd = d + len * penalty;
            if nd < dist[j] {
                dist[j] = nd;
                prev[j] = i;
                heap.push(Item(nd, j));
            }
        }
    }
    None
}

/// The storage areas as obstacles for the planner: grown so that the route keeps
/// `area_route_gap_m` from them (the planner itself keeps `plan_clearance_m`).
fn keep_off(areas: &[StorageRegion], p: &SiteParams) -> Vec<Shape> {
    let grow = (p.area_route_gap_m - p.plan_clearance_m).max(0.0);
    areas
        .iter()
        .map(|a| match &a.shape {
            Shape::Rect { center, size, yaw_deg } => {
                Shape::Rect { center: *center, size: [size[0] + 2.0 * grow, size[1] + 2.0 * grow], yaw_deg: *yaw_deg }
            }
            Shape::Circle { center, radius } => Shape::Circle { center: *center, radius: radius + grow },
            other @ Shape::Polygon { .. } => {
                let b = other.bounds();
                Shape::rect(
                    Point2::new((b.min.x + b.max.x) / 2.0, (b.min.y + b.max.y) / 2.0),
                    [b.max.x - b.min.x + 2.0 * grow, b.max.y - b.min.y + 2.0 * grow],
                    0.0,
                )
            }
        })
        .collect()
}

/// Whether the patrol can live with `areas` (as the planner keeps off them): they cut no floor
/// off the start (every cell reached through `plan_clearance_m` without them, `open`, and clear
/// of them, is reached with them), and at least 60 % of the floor stays reachable.
fn areas_fit(open: &Floor, world: &World, areas: &[StorageRegion], p: &SiteParams) -> Result<bool, WorldsError> {
    let start = world.robot_start.pose().position();
    let c = p.plan_clearance_m;
    let floor = Floor::new(world, p.plan_resolution_m, true, &keep_off(areas, p))?;
    let (Some(all), true) = (open.reach(start, c), open.geo.same_as(&floor.geo)) else { return Ok(true) };
    let Some(ok) = floor.reach(start, c) else { return Ok(false) };
    let shapes = keep_off(areas, p);
    let margin = c + 2.0 * floor.geo.resolution_m();
    let cut = (0..all.len()).filter(|&i| all[i] && !ok[i]).any(|i| {
        let q = floor.geo.cell_center(floor.geo.coord(i));
        shapes.iter().all(|s| s.distance_to(q) > margin)
    });
    let (n_all, n_ok) = (all.iter().filter(|&&r| r).count(), ok.iter().filter(|&&r| r).count());
    Ok(!cut && 10 * n_ok >= 6 * n_all)
}

/// Plans the patrol of a world without a route (see the module documentation), keeping off
/// the storage areas `areas` by the generator's route clearance.
pub fn plan_route(world: &World, areas: &[StorageRegion], origin: &str, p: &SiteParams) -> Result<Route, WorldsError> {
    let floor = Floor::new(world, p.plan_resolution_m, true, &keep_off(areas, p))?;

    let start = world.robot_start.pose().position();
    let c = p.plan_clearance_m;
    let Some(ok) = floor.reach(start, c) else {
        return Err(refuse(
            origin,
            format!(
                "robot_start [{}, {}]: no route can be planned, the start has less than {c} m clearance to the nearest obstacle",
                start.x, start.y
            ),
        ));
    };
    // One goal per square of the lattice (offset by the seed): its reachable cell of most clearance.
    let mut rng = stream_rng(p.seed, "route-planner");
    let s = p.cover_spacing_m;
    let (ox, oy) = (rng.random_range(0.0..s), rng.random_range(0.0..s));
    let mut best: std::collections::BTreeMap<(i64, i64), (f32, usize)> = std::collections::BTreeMap::new();
    for (i, _) in ok.iter().enumerate().filter(|(_, r)| **r) {
        let q = floor.geo.cell_center(floor.geo.coord(i));
        let key = (((q.x - ox) / s).floor() as i64, ((q.y - oy) / s).floor() as i64);
        let e = best.entry(key).or_insert((-1.0, i));
        if floor.clear[i] > e.0 {
            *e = (floor.clear[i], i);
        }
    }
    let mut is_goal = vec![false; floor.geo.len()];
    for &(_, i) in best.values() {
        is_goal[i] = true;
    }
    let start_cell = floor.geo.world_to_cell(start).and_then(|cc| floor.geo.index(cc)).unwrap_or(0);
    let mut cells = vec![start_cell];
    // Indices into `cells` the straightening must keep: the goals.
    let mut keep = vec![0];
    let mut here = start_cell;
    let mut left = best.len();
    while left > 0 {
        let Some((g, path)) = nearest(&floor, &ok, here, &|i| is_goal[i]) else { break };
        is_goal[g] = false;
        left -= 1;
        cells.extend_from_slice(&path[1..]);
        keep.push(cells.len() - 1);
        here = g;
    }
    if let Some((_, path)) = nearest(&floor, &ok, here, &|i| i == start_cell) {
        cells.extend_from_slice(&path[1..]);
    }
    keep.push(cells.len() - 1);
    let pts: Vec<Point2> = cells.iter().map(|&i| floor.geo.cell_center(floor.geo.coord(i))).collect();
    // Straighten each leg between goals: from each kept point, the farthest later point of the
    // leg in a straight line that keeps the clearance.
    let mut way = vec![start];
    for leg in keep.windows(2) {
        let (mut i, end) = (leg[0], leg[1]);
        while i < end {
            let mut j = i + 1;
            while j < end && floor.line_clear(pts[i], pts[j + 1], c) {
                j += 1;
            }
            way.push(pts[j]);
            i = j;
        }
    }
    if way.last().is_some_and(|l| l.distance(start) > 1e-9) {
        way.push(start);
    }
    let mm = |v: f64| (v * 1000.0).round() / 1000.0;
    let mut out: Vec<Point2> = Vec::with_capacity(way.len());
    for q in way {
        let q = Point2::new(mm(q.x), mm(q.y));
        if out.last().is_none_or(|l| l.distance(q) > 1e-6) {
            out.push(q);
        }
    }
    if out.len() < 3 || Route::new(&out).length_m() < 2.0 {
        return Err(refuse(
            origin,
            format!("robot_start [{}, {}]: no floor to patrol around the start", start.x, start.y),
        ));
    }
    Ok(Route::new(&out))
}

/// The storage areas of a world without any (see the module documentation): away from
/// `route` when it is known; without a route (it is planned around them afterwards), each at
/// most `area_max_side_m` a side, `area_route_gap_m` plus the planner's clearance from the start
/// and from each other (aisles between them), at most a quarter of the floor in all.
pub fn derive_storage_areas(world: &World, route: Option<&Route>, p: &SiteParams) -> Vec<StorageRegion> {
    let Ok(floor) = Floor::new(world, p.plan_resolution_m, false, &[]) else { return vec![] };
    let geo = floor.geo;
    let start = world.robot_start.pose().position();
    let Some(inside) = floor.reach(start, 1e-3) else { return vec![] };
    let half = geo.resolution_m() / 2.0;
    let aisle = p.area_route_gap_m + p.plan_clearance_m;
    // The route's cells (or the start's), for the distance to the route.
    let mut on_route = vec![false; geo.len()];
    let pts = route.map_or_else(|| vec![start], Route::points);
    if pts.is_empty() {
        return vec![];
    }
    let step = geo.resolution_m() / 2.0;
    for w in pts.windows(2).chain(std::iter::once(&pts[..1])) {
        let (a, b) = (w[0], *w.last().unwrap_or(&w[0]));
        let n = (a.distance(b) / step).ceil().max(1.0) as usize;
        for k in 0..=n {
            let t = k as f64 / n as f64;
            let q = Point2::new(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y));
            if let Some(i) = geo.world_to_cell(q).and_then(|cc| geo.index(cc)) {
                on_route[i] = true;
            }
        }
    }
    let route_d = DistanceField::from_sites(&geo, 1e3, |i| on_route[i]);
    let gap = if route.is_some() { p.area_route_gap_m } else { aisle };
    let mut free: Vec<bool> = (0..geo.len())
        .map(|i| {
            inside[i]
                && f64::from(floor.clear[i]) >= p.area_wall_gap_m + half
                && f64::from(route_d.distances_m()[i]) >= gap + half
                && world.interior.as_ref().is_none_or(|s| s.contains(geo.cell_center(geo.coord(i))))
        })
        .collect();
    let res = geo.resolution_m();
    let floor_m2 = inside.iter().filter(|&&r| r).count() as f64 * res * res;
    let min_cells = (p.area_min_side_m / res).ceil() as usize;
    let max_cells =
        if route.is_some() { usize::MAX } else { ((p.area_max_side_m / res).floor() as usize).max(min_cells) };
    let aisle_cells = if route.is_some() { 0 } else { (aisle / res).ceil() as usize };
    let taken: std::collections::BTreeSet<&str> = world_ids(world);
    let (w, h) = (geo.width(), geo.height());
    let mut out = Vec::new();
    let mut total_m2 = 0.0;
    while out.len() < p.max_areas {
        let Some((c0, r0, c1, r1)) = largest_rectangle(&free, w, h, min_cells) else { break };
        // At most max_cells a side, centred in what was found.
        let crop = |a: usize, b: usize| {
            let n = b + 1 - a;
            if n <= max_cells { (a, b) } else { (a + (n - max_cells) / 2, a + (n - max_cells) / 2 + max_cells - 1) }
        };
        let ((c0, c1), (r0, r1)) = (crop(c0, c1), crop(r0, r1));
        let area_m2 = ((c1 + 1 - c0) * (r1 + 1 - r0)) as f64 * res * res;
        if route.is_none() && total_m2 + area_m2 > 0.25 * floor_m2 {
            break;
        }
        total_m2 += area_m2;
        for r in r0.saturating_sub(aisle_cells)..=(r1 + aisle_cells).min(h - 1) {
            for c in c0.saturating_sub(aisle_cells)..=(c1 + aisle_cells).min(w - 1) {
                free[r * w + c] = false;
            }
        }
        let lo = geo.cell_center(CellCoord::new(c0 as i32, r0 as i32));
        let hi = geo.cell_center(CellCoord::new(c1 as i32, r1 as i32));
        let mm = |v: f64| (v * 1000.0).round() / 1000.0;
        let center = Point2::new(mm((lo.x + hi.x) / 2.0), mm((lo.y + hi.y) / 2.0));
        let size = [mm(hi.x - lo.x + 2.0 * half), mm(hi.y - lo.y + 2.0 * half)];
        let mut id = format!("derived-area-{}", out.len() + 1);
        while taken.contains(id.as_str()) {
            id.push('x');
        }
        out.push(StorageRegion { id, shape: Shape::rect(center, size, 0.0) });
    }
    out
}

fn world_ids(world: &World) -> std::collections::BTreeSet<&str> {
    let mut ids: std::collections::BTreeSet<&str> = std::collections::BTreeSet::new();
    ids.extend(world.walls.iter().chain(&world.columns).map(|w| w.id.as_str()));
    ids.extend(world.racks.iter().map(|r| r.id.as_str()));
    ids.extend(world.movable.iter().map(|m| m.id.as_str()));
    ids.extend(world.agents.iter().map(|a| a.id.as_str()));
    ids
}

/// The largest-area rectangle of `true` cells with both sides ≥ `min` cells: `(c0, r0, c1,
/// r1)`, inclusive (ties: the first found, rows bottom-up). Histogram method, O(cells).
fn largest_rectangle(mask: &[bool], w: usize, h: usize, min: usize) -> Option<(usize, usize, usize, usize)> {
    let mut heights = vec![0usize; w];
    let mut best: Option<(usize, (usize, usize, usize, usize))> = None;
    for r in 0..h {
        for (c, height) in heights.iter_mut().enumerate() {
            *height = if mask[r * w + c] { *height + 1 } else { 0 };
        }
        // Each bar's widest span where it is the lowest, by a stack of increasing heights.
        let mut stack: Vec<usize> = Vec::new();
        for c in 0..=w {
            let hc = if c < w { heights[c] } else { 0 };
            while let Some(&top) = stack.last() {
                if heights[top] <= hc {
                    break;
                }
                stack.pop();
                let ht = heights[top];
                let left = stack.last().map_or(0, |&l| l + 1);
                let width = c - left;
                if ht >= min && width >= min && best.is_none_or(|(a, _)| ht * width > a) {
                    best = Some((ht * width, (left, r + 1 - ht, c - 1, r)));
                }
            }
            stack.push(c);
        }
    }
    best.map(|(_, rect)| rect)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn largest_rectangle_finds_the_block() {
        // 6 × 4, a 3 × 3 block of true at columns 2..=4, rows 1..=3, and a stray cell.
        let (w, h) = (6, 4);
        let mut m = vec![false; w * h];
        for r in 1..4 {
            for c in 2..5 {
                m[r * w + c] = true;
            }
        }
        m[0] = true;
        assert_eq!(largest_rectangle(&m, w, h, 2), Some((2, 1, 4, 3)));
        assert_eq!(largest_rectangle(&m, w, h, 4), None);
    }
}
