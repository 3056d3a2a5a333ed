//! Routes: lists of waypoints for the robot's path follower, and their TOML file format.

use crate::error::SimError;
use crate::world::parse_toml;
use mapkeeper_grid::Point2;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The `format` value of a route file.
pub const ROUTE_FORMAT: &str = "mapkeeper-route";

/// A route: waypoints in the map frame, driven in order (a closed tour repeats its first point
/// at the end).
///
/// File format (TOML):
/// ```toml
/// format = "mapkeeper-route"
/// version = 1
/// waypoints = [[-3.65, -2.3], [-3.65, 7.3], [-3.65, -2.3]]
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Route {
    /// Always [`ROUTE_FORMAT`].
    pub format: String,
    /// Always 1.
    pub version: u32,
    /// Waypoints `[[x, y], ...]`, metres.
    pub waypoints: Vec<[f64; 2]>,
}

impl Route {
    /// A route through `points`.
    pub fn new(points: &[Point2]) -> Route {
        Route { format: ROUTE_FORMAT.into(), version: 1, waypoints: points.iter().map(|p| [p.x, p.y]).collect() }
    }

    /// The waypoints as points.
    pub fn points(&self) -> Vec<Point2> {
        self.waypoints.iter().map(|p| Point2::new(p[0], p[1])).collect()
    }

    /// Path length, metres.
    pub fn length_m(&self) -> f64 {
        self.points().windows(2).map(|w| w[0].distance(w[1])).sum()
    }

    /// Parses and validates a route.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Route, SimError> {
        let r: Route = parse_toml(text, origin)?;
        let bad = |entry: String, problem: String| SimError::Invalid { origin: origin.to_string(), entry, problem };
        if r.format != ROUTE_FORMAT {
            return Err(bad("format".into(), format!("is \"{}\", expected \"{ROUTE_FORMAT}\"", r.format)));
        }
        if r.version != 1 {
            return Err(bad("version".into(), format!("version {} is not supported (expected 1)", r.version)));
        }
        if let Some((entry, problem)) = r.problem() {
            return Err(bad(entry, problem));
        }
        Ok(r)
    }

    /// What is wrong with the waypoints, if anything: the entry (`waypoints` or
    /// `waypoints[i]`) and the problem. A route needs at least one waypoint, every one finite.
    /// Routes read as part of a larger file (experiment parameters) are checked with this too.
    pub fn problem(&self) -> Option<(String, String)> {
        if self.waypoints.is_empty() {
            return Some(("waypoints".into(), "a route needs at least one waypoint".into()));
        }
        let (i, p) = self.waypoints.iter().enumerate().find(|(_, p)| !(p[0].is_finite() && p[1].is_finite()))?;
        Some((format!("waypoints[{i}]"), format!("must be finite, got {p:?}")))
    }

    /// Reads a route file.
    pub fn load(path: &Path) -> Result<Route, SimError> {
        let text = std::fs::read_to_string(path).map_err(|source| SimError::Io { path: path.to_path_buf(), source })?;
        Route::from_toml_str(&text, &path.display().to_string())
    }

    /// The route as TOML.
    pub fn to_toml_string(&self) -> Result<String, SimError> {
        toml::to_string(self).map_err(|e| SimError::Parse { origin: "route".into(), message: e.to_string() })
    }

    /// A 72 m tour of the default warehouse's aisles from the robot's start pose and back:
    /// up and down the west aisle, across, up and down the east aisle, and back. Every point of
    /// it keeps ≥ 0.98 m (robot width + 0.3 m) from every movable item.
    pub fn default_warehouse() -> Route {
        Route::new(&[
            Point2::new(-3.65, -2.3),
            Point2::new(-3.65, 7.3),
            Point2::new(-3.65, -9.0),
            Point2::new(-3.65, -2.3),
            Point2::new(1.0, -2.3),
            Point2::new(1.0, 7.0),
            Point2::new(1.0, -8.3),
            Point2::new(1.0, -2.3),
            Point2::new(-3.65, -2.3),
        ])
    }

    /// An exploration tour of the default warehouse for map building: the default tour plus
    /// the north-west corner behind the long rack's end.
    pub fn exploration_warehouse() -> Route {
        Route::new(&[
            Point2::new(-3.65, -2.3),
            Point2::new(-3.65, 9.2),
            Point2::new(-5.6, 9.2),
            Point2::new(-3.65, 9.2),
            Point2::new(-3.65, -9.0),
            Point2::new(-3.65, -2.3),
            Point2::new(1.0, -2.3),
            Point2::new(1.0, 7.0),
            Point2::new(1.0, -8.3),
            Point2::new(1.0, -2.3),
            Point2::new(-3.65, -2.3),
        ])
    }
}

impl crate::world::WorldRoute {
    /// The route driven in every world.
    pub fn route(&self) -> Route {
        Route { format: ROUTE_FORMAT.into(), version: 1, waypoints: self.waypoints.clone() }
    }

    /// The exploration tour: `exploration`, or the route when it is empty.
    pub fn exploration_route(&self) -> Route {
        if self.exploration.is_empty() {
            self.route()
        } else {
            Route { format: ROUTE_FORMAT.into(), version: 1, waypoints: self.exploration.clone() }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::point_segment_distance;
    use crate::world::World;

    #[test]
    fn default_route_is_long_and_clear_of_movables() {
        let r = Route::default_warehouse();
        assert!(r.length_m() >= 60.0, "{}", r.length_m());
        let w = World::default_warehouse();
        let pts = r.points();
        for m in &w.movable {
            let v = m.shape.vertices().unwrap();
            for seg in pts.windows(2) {
                // Distance between segment and rectangle: min over vertex-to-segment and
                // path-point-to-rectangle distances (they do not cross).
                let d1 = v.iter().map(|&q| point_segment_distance(q, seg[0], seg[1])).fold(f64::INFINITY, f64::min);
                let d2 = m.shape.distance_to(seg[0]).min(m.shape.distance_to(seg[1]));
                let d = d1.min(d2);
                assert!(d >= 0.68 + 0.3 - 1e-9, "{} is {d} m from the route", m.id);
            }
        }
        let start = w.robot_start.pose().position();
        assert!(start.distance(pts[0]) < 1e-9);
    }

    #[test]
    fn route_file_round_trip_and_errors() {
        let r = Route::default_warehouse();
        let text = r.to_toml_string().unwrap();
        assert_eq!(Route::from_toml_str(&text, "r.toml").unwrap(), r);
        let e =
            Route::from_toml_str("format = \"mapkeeper-route\"\nversion = 1\nwaypoints = []\n", "r.toml").unwrap_err();
        assert!(e.to_string().contains("r.toml: waypoints"), "{e}");
        let e = Route::from_toml_str("format = \"mapkeeper-route\"\nversion = 1\nwaypoint = [[0, 0]]\n", "r.toml")
            .unwrap_err();
        assert!(e.to_string().contains("r.toml: line 3"), "{e}");
    }
}
