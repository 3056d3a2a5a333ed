//! Exact plane distances between shapes and polylines, for the generator's placement checks.
//!
//! Shapes are reduced to an [`Outline`]: a closed simple polygon (rectangles, polygons), an
//! open polyline (routes, agent paths) or a circle. Two outlines are at distance 0 when they
//! overlap or touch; otherwise the distance is the smallest vertex-to-edge distance either way
//! (exact for non-crossing simple polygons and segments).

use mapkeeper_grid::Point2;
use mapkeeper_sim::{Shape, point_segment_distance};

/// A shape reduced to points.
#[derive(Clone, Debug, PartialEq)]
pub enum Outline {
    /// A closed simple polygon (the last vertex joins the first).
    Polygon(Vec<Point2>),
    /// An open polyline (segments between consecutive points).
    Polyline(Vec<Point2>),
    /// A circle: centre and radius.
    Circle(Point2, f64),
}

impl Outline {
    /// The outline of a world shape.
    pub fn of_shape(shape: &Shape) -> Outline {
        match shape {
            Shape::Circle { center, radius } => Outline::Circle(Point2::new(center[0], center[1]), *radius),
            _ => Outline::Polygon(shape.vertices().unwrap_or_default()),
        }
    }

    /// The edges as point pairs.
    fn edges(&self) -> Vec<(Point2, Point2)> {
        match self {
            Outline::Polygon(v) => (0..v.len()).map(|i| (v[i], v[(i + 1) % v.len()])).collect(),
            Outline::Polyline(v) => v.windows(2).map(|w| (w[0], w[1])).collect(),
            Outline::Circle(..) => Vec::new(),
        }
    }

    fn points(&self) -> &[Point2] {
        match self {
            Outline::Polygon(v) | Outline::Polyline(v) => v,
            Outline::Circle(..) => &[],
        }
    }

    /// Whether `p` lies inside (closed polygons and circles only).
    pub fn contains(&self, p: Point2) -> bool {
        match self {
            Outline::Polygon(v) => polygon_contains(v, p),
            Outline::Polyline(_) => false,
            Outline::Circle(c, r) => c.distance(p) <= *r,
        }
    }

    /// Distance from a point to the outline (0 inside a polygon or circle).
    pub fn distance_to_point(&self, p: Point2) -> f64 {
        match self {
            Outline::Circle(c, r) => (c.distance(p) - r).max(0.0),
            _ => {
                if self.contains(p) {
                    return 0.0;
                }
                let e = self.edges();
                if e.is_empty() {
                    return self.points().first().map_or(f64::INFINITY, |q| q.distance(p));
                }
                e.iter().map(|&(a, b)| point_segment_distance(p, a, b)).fold(f64::INFINITY, f64::min)
            }
        }
    }

    /// Distance between two outlines (0 when they overlap or touch).
    pub fn distance(&self, other: &Outline) -> f64 {
        match (self, other) {
            (Outline::Circle(c, r), o) | (o, Outline::Circle(c, r)) => (o.distance_to_point(*c) - r).max(0.0),
            _ => {
                let (ea, eb) = (self.edges(), other.edges());
                for &(a0, a1) in &ea {
                    for &(b0, b1) in &eb {
                        if segments_intersect(a0, a1, b0, b1) {
                            return 0.0;
                        }
                    }
                }
                if self.points().iter().any(|&p| other.contains(p)) || other.points().iter().any(|&p| self.contains(p))
                {
                    return 0.0;
                }
                let mut d = f64::INFINITY;
                for &p in self.points() {
                    for &(b0, b1) in &eb {
                        d = d.min(point_segment_distance(p, b0, b1));
                    }
                }
                for &p in other.points() {
                    for &(a0, a1) in &ea {
                        d = d.min(point_segment_distance(p, a0, a1));
                    }
                }
                d
            }
        }
    }
}

/// Even-odd point-in-polygon test; fewer than three vertices hold nothing.
fn polygon_contains(v: &[Point2], p: Point2) -> bool {
    v.len() >= 3 && mapkeeper_grid::geometry::polygon_contains(v, p)
}

fn orient(a: Point2, b: Point2, c: Point2) -> f64 {
    (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)
}

/// Whether segments `a0a1` and `b0b1` share a point (touching counts).
fn segments_intersect(a0: Point2, a1: Point2, b0: Point2, b1: Point2) -> bool {
    let (d1, d2) = (orient(b0, b1, a0), orient(b0, b1, a1));
    let (d3, d4) = (orient(a0, a1, b0), orient(a0, a1, b1));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0)) {
        return true;
    }
    let on = |p: Point2, q: Point2, r: Point2, d: f64| {
        d == 0.0 && r.x >= p.x.min(q.x) && r.x <= p.x.max(q.x) && r.y >= p.y.min(q.y) && r.y <= p.y.max(q.y)
    };
    on(b0, b1, a0, d1) || on(b0, b1, a1, d2) || on(a0, a1, b0, d3) || on(a0, a1, b1, d4)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(cx: f64, cy: f64, side: f64) -> Outline {
        Outline::of_shape(&Shape::rect(Point2::new(cx, cy), [side, side], 0.0))
    }

    #[test]
    fn separated_squares_have_the_gap_as_distance() {
        let a = square(0.0, 0.0, 1.0);
        let b = square(3.0, 0.0, 1.0);
        assert!((a.distance(&b) - 2.0).abs() < 1e-12);
        assert!((b.distance(&a) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn overlapping_and_nested_shapes_are_at_zero() {
        assert_eq!(square(0.0, 0.0, 1.0).distance(&square(0.5, 0.5, 1.0)), 0.0);
        assert_eq!(square(0.0, 0.0, 4.0).distance(&square(0.0, 0.0, 1.0)), 0.0);
        // A cross: no vertex inside the other, edges cross.
        let a = Outline::of_shape(&Shape::rect(Point2::new(0.0, 0.0), [4.0, 0.5], 0.0));
        let b = Outline::of_shape(&Shape::rect(Point2::new(0.0, 0.0), [0.5, 4.0], 0.0));
        assert_eq!(a.distance(&b), 0.0);
    }

    #[test]
    fn polyline_crossing_a_box_is_at_zero_and_passing_one_is_not() {
        let b = square(0.0, 0.0, 1.0);
        let through = Outline::Polyline(vec![Point2::new(-5.0, 0.0), Point2::new(5.0, 0.0)]);
        assert_eq!(b.distance(&through), 0.0);
        let past = Outline::Polyline(vec![Point2::new(-5.0, 2.0), Point2::new(5.0, 2.0), Point2::new(5.0, 9.0)]);
        assert!((b.distance(&past) - 1.5).abs() < 1e-12);
    }

    #[test]
    fn circle_distances() {
        let c = Outline::Circle(Point2::new(3.0, 0.0), 0.5);
        assert!((square(0.0, 0.0, 1.0).distance(&c) - 2.0).abs() < 1e-12);
        let line = Outline::Polyline(vec![Point2::new(0.0, -1.0), Point2::new(0.0, 1.0)]);
        assert!((c.distance(&line) - 2.5).abs() < 1e-12);
        assert_eq!(Outline::Circle(Point2::new(0.0, 0.0), 1.0).distance(&line), 0.0);
    }
}
