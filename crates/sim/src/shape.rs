//! Plane shapes of the world file: oriented rectangles, circles and simple polygons, with the
//! exact geometry the ground truth and the physics need.

use mapkeeper_grid::geometry::polygon_contains;
use mapkeeper_grid::{Point2, Pose2};
use serde::{Deserialize, Serialize};

/// A shape in the plane. Coordinates are metres in the frame the shape belongs to (the map
/// frame for obstacles, the agent's own frame for agent footprints); angles are degrees in the
/// file, as the name says.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Shape {
    /// An oriented rectangle.
    Rect {
        /// Centre `[x, y]`, metres.
        #[serde(default)]
        center: [f64; 2],
        /// Side lengths `[along local x, along local y]` before the rotation, metres.
        size: [f64; 2],
        /// Rotation about the centre, degrees counter-clockwise (default 0).
        #[serde(default)]
        yaw_deg: f64,
    },
    /// A circle.
    Circle {
        /// Centre `[x, y]`, metres.
        #[serde(default)]
        center: [f64; 2],
        /// Radius, metres.
        radius: f64,
    },
    /// A simple polygon (convex or not, not self-intersecting), vertices in order.
    Polygon {
        /// Vertices `[[x, y], ...]`, metres; at least three; the last joins the first.
        points: Vec<[f64; 2]>,
    },
}

/// An axis-aligned box `[min, max]`, metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// Lower-left corner.
    pub min: Point2,
    /// Upper-right corner.
    pub max: Point2,
}

impl Bounds {
    /// The empty box (union identity).
    pub const EMPTY: Bounds = Bounds {
        min: Point2::new(f64::INFINITY, f64::INFINITY),
        max: Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY),
    };

    /// The union of two boxes.
    pub fn union(self, o: Bounds) -> Bounds {
        Bounds {
            min: Point2::new(self.min.x.min(o.min.x), self.min.y.min(o.min.y)),
            max: Point2::new(self.max.x.max(o.max.x), self.max.y.max(o.max.y)),
        }
    }

    /// Whether the box contains nothing.
    pub fn is_empty(&self) -> bool {
        !(self.min.x <= self.max.x && self.min.y <= self.max.y)
    }
}

impl Shape {
    /// An axis-aligned or rotated rectangle.
    pub fn rect(center: Point2, size: [f64; 2], yaw_deg: f64) -> Shape {
        Shape::Rect { center: [center.x, center.y], size, yaw_deg }
    }

    /// A circle.
    pub fn circle(center: Point2, radius: f64) -> Shape {
        Shape::Circle { center: [center.x, center.y], radius }
    }

    /// What is wrong with the shape's numbers, if anything.
    pub fn problem(&self) -> Option<String> {
        let finite2 = |p: &[f64; 2]| p[0].is_finite() && p[1].is_finite();
        match self {
            Shape::Rect { center, size, yaw_deg } => {
                if !finite2(center) {
                    return Some(format!("rect center must be finite, got {center:?}"));
                }
                if !(size[0].is_finite() && size[1].is_finite()) {
                    return Some(format!("rect size must be finite, got {size:?}"));
                }
                if size[0] <= 0.0 || size[1] <= 0.0 {
                    return Some(format!("rect size must be positive (width and height > 0 m), got {size:?}"));
                }
                if !yaw_deg.is_finite() {
                    return Some(format!("rect yaw_deg must be finite, got {yaw_deg}"));
                }
                None
            }
            Shape::Circle { center, radius } => {
                if !finite2(center) {
                    return Some(format!("circle center must be finite, got {center:?}"));
                }
                if !(radius.is_finite() && *radius > 0.0) {
                    return Some(format!("circle radius must be a finite positive number of metres, got {radius}"));
                }
                None
            }
            Shape::Polygon { points } => {
                if points.len() < 3 {
                    return Some(format!("polygon needs at least 3 points, got {}", points.len()));
                }
                if let Some(p) = points.iter().find(|p| !finite2(p)) {
                    return Some(format!("polygon point must be finite, got {p:?}"));
                }
                if self.area().abs() < 1e-12 {
                    return Some("polygon has zero area".to_string());
                }
                None
            }
        }
    }

    /// The same shape moved by `pose` (the shape is expressed in `pose`'s frame).
    pub fn transformed(&self, pose: &Pose2) -> Shape {
        let tp = |p: &[f64; 2]| {
            let q = pose.transform_point(Point2::new(p[0], p[1]));
            [q.x, q.y]
        };
        match self {
            Shape::Rect { center, size, yaw_deg } => {
                Shape::Rect { center: tp(center), size: *size, yaw_deg: yaw_deg + pose.yaw.to_degrees() }
            }
            Shape::Circle { center, radius } => Shape::Circle { center: tp(center), radius: *radius },
            Shape::Polygon { points } => Shape::Polygon { points: points.iter().map(tp).collect() },
        }
    }

    /// Signed area (positive for counter-clockwise polygons), square metres.
    pub fn area(&self) -> f64 {
        match self {
            Shape::Rect { size, .. } => size[0] * size[1],
            Shape::Circle { radius, .. } => std::f64::consts::PI * radius * radius,
            Shape::Polygon { points } => {
                let n = points.len();
                (0..n)
                    .map(|i| {
                        let (a, b) = (points[i], points[(i + 1) % n]);
                        a[0] * b[1] - b[0] * a[1]
                    })
                    .sum::<f64>()
                    / 2.0
            }
        }
    }

    /// The corners of a rectangle or the vertices of a polygon, counter-clockwise for
    /// rectangles; `None` for a circle.
    pub fn vertices(&self) -> Option<Vec<Point2>> {
        match self {
            Shape::Rect { center, size, yaw_deg } => {
                let pose = Pose2::new(center[0], center[1], yaw_deg.to_radians());
                let (hx, hy) = (size[0] / 2.0, size[1] / 2.0);
                Some(
                    [(-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)]
                        .iter()
                        .map(|&(x, y)| pose.transform_point(Point2::new(x, y)))
                        .collect(),
                )
            }
            Shape::Circle { .. } => None,
            Shape::Polygon { points } => Some(points.iter().map(|p| Point2::new(p[0], p[1])).collect()),
        }
    }

    /// The centre of a rectangle or circle, the vertex mean of a polygon.
    pub fn center(&self) -> Point2 {
        match self {
            Shape::Rect { center, .. } | Shape::Circle { center, .. } => Point2::new(center[0], center[1]),
            Shape::Polygon { points } => {
                let n = points.len().max(1) as f64;
                Point2::new(points.iter().map(|p| p[0]).sum::<f64>() / n, points.iter().map(|p| p[1]).sum::<f64>() / n)
            }
        }
    }

    /// Radius of the smallest circle about [`Shape::center`] that holds the shape.
    pub fn bounding_radius(&self) -> f64 {
        match self {
            Shape::Rect { size, .. } => size[0].hypot(size[1]) / 2.0,
            Shape::Circle { radius, .. } => *radius,
            Shape::Polygon { points } => {
                let c = self.center();
                points.iter().map(|p| c.distance(Point2::new(p[0], p[1]))).fold(0.0, f64::max)
            }
        }
    }

    /// Axis-aligned bounds.
    pub fn bounds(&self) -> Bounds {
        match self {
            Shape::Circle { center, radius } => Bounds {
                min: Point2::new(center[0] - radius, center[1] - radius),
                max: Point2::new(center[0] + radius, center[1] + radius),
            },
            _ => self
                .vertices()
                .unwrap_or_default()
                .iter()
                .fold(Bounds::EMPTY, |b, p| b.union(Bounds { min: *p, max: *p })),
        }
    }

    /// Whether `p` lies inside the shape (boundary points may go either way).
    pub fn contains(&self, p: Point2) -> bool {
        match self {
            Shape::Rect { center, size, yaw_deg } => {
                let local = Pose2::new(center[0], center[1], yaw_deg.to_radians()).inverse().transform_point(p);
                local.x.abs() < size[0] / 2.0 && local.y.abs() < size[1] / 2.0
            }
            Shape::Circle { center, radius } => p.distance_sq(Point2::new(center[0], center[1])) < radius * radius,
            // Even-odd rule.
            Shape::Polygon { points } => polygon_contains(points, p),
        }
    }

    /// Distance from `p` to the shape (0 inside).
    pub fn distance_to(&self, p: Point2) -> f64 {
        if self.contains(p) {
            return 0.0;
        }
        match self {
            Shape::Circle { center, radius } => (p.distance(Point2::new(center[0], center[1])) - radius).max(0.0),
            _ => {
                let v = self.vertices().unwrap_or_default();
                let n = v.len();
                (0..n).map(|i| point_segment_distance(p, v[i], v[(i + 1) % n])).fold(f64::INFINITY, f64::min)
            }
        }
    }
}

/// Whether the closed segments `a`–`b` and `c`–`d` meet.
fn segments_meet(a: Point2, b: Point2, c: Point2, d: Point2) -> bool {
    let cross = |o: Point2, p: Point2, q: Point2| (p.x - o.x) * (q.y - o.y) - (p.y - o.y) * (q.x - o.x);
    let (d1, d2, d3, d4) = (cross(c, d, a), cross(c, d, b), cross(a, b, c), cross(a, b, d));
    ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
}

impl Shape {
    /// Distance from the segment `a`–`b` to the shape (0 when they meet or overlap).
    pub fn segment_distance(&self, a: Point2, b: Point2) -> f64 {
        if self.contains(a) || self.contains(b) {
            return 0.0;
        }
        match self {
            Shape::Circle { center, radius } => {
                (point_segment_distance(Point2::new(center[0], center[1]), a, b) - radius).max(0.0)
            }
            _ => {
                let v = self.vertices().unwrap_or_default();
                let n = v.len();
                let mut best = f64::INFINITY;
                for i in 0..n {
                    let (p, q) = (v[i], v[(i + 1) % n]);
                    if segments_meet(a, b, p, q) {
                        return 0.0;
                    }
                    best = best
                        .min(point_segment_distance(a, p, q))
                        .min(point_segment_distance(b, p, q))
                        .min(point_segment_distance(p, a, b));
                }
                best
            }
        }
    }
}

/// Distance from `p` to the segment `a`–`b`.
pub fn point_segment_distance(p: Point2, a: Point2, b: Point2) -> f64 {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 { (((p.x - a.x) * dx + (p.y - a.y) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
    p.distance(Point2::new(a.x + t * dx, a.y + t * dy))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rect_geometry() {
        let r = Shape::rect(Point2::new(1.0, 2.0), [2.0, 1.0], 90.0);
        let b = r.bounds();
        assert!((b.min.x - 0.5).abs() < 1e-12 && (b.max.y - 3.0).abs() < 1e-12);
        assert!(r.contains(Point2::new(1.0, 2.9)));
        assert!(!r.contains(Point2::new(1.9, 2.0)));
        assert!((r.distance_to(Point2::new(3.0, 2.0)) - 1.5).abs() < 1e-12);
        assert!(r.problem().is_none());
        assert!(Shape::rect(Point2::new(0.0, 0.0), [-1.0, 1.0], 0.0).problem().is_some());
        assert!(Shape::rect(Point2::new(0.0, 0.0), [f64::NAN, 1.0], 0.0).problem().is_some());
    }

    #[test]
    fn segment_distances() {
        let r = Shape::rect(Point2::new(0.0, 0.0), [2.0, 2.0], 0.0);
        // Crossing the square without an end inside it.
        assert_eq!(r.segment_distance(Point2::new(-3.0, 0.0), Point2::new(3.0, 0.0)), 0.0);
        assert!((r.segment_distance(Point2::new(-3.0, 1.5), Point2::new(3.0, 1.5)) - 0.5).abs() < 1e-12);
        assert!((r.segment_distance(Point2::new(2.0, 3.0), Point2::new(2.0, 5.0)) - 2f64.hypot(1.0)).abs() < 1e-12);
        let c = Shape::circle(Point2::new(0.0, 0.0), 1.0);
        assert!((c.segment_distance(Point2::new(-3.0, 2.0), Point2::new(3.0, 2.0)) - 1.0).abs() < 1e-12);
        assert_eq!(c.segment_distance(Point2::new(-3.0, 0.5), Point2::new(3.0, 0.5)), 0.0);
    }

    #[test]
    fn polygon_contains_concave() {
        // An L shape.
        let l = Shape::Polygon { points: vec![[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]] };
        assert!(l.contains(Point2::new(0.5, 1.5)));
        assert!(!l.contains(Point2::new(1.5, 1.5)));
        assert!((l.area() - 3.0).abs() < 1e-12);
        assert!(Shape::Polygon { points: vec![[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]] }.problem().is_some());
    }
}
