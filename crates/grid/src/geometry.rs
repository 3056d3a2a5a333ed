//! Plane geometry on [`Point2`] shared by the simulator and the world generator.

use crate::Point2;

/// Whether `p` lies inside the closed polygon `vertices` by the even-odd rule (crossings of a
/// ray from `p` towards +x; self-intersecting polygons alternate inside and outside).
///
/// The rule is applied literally, edge `vertices[i]`–`vertices[i − 1]` for every `i` (the last
/// vertex closes the ring), with half-open edges in y: a point exactly on the boundary may go
/// either way (an axis-aligned rectangle holds its left and bottom edges, not its right and
/// top ones), and a horizontal edge never counts. Fewer than three vertices enclose nothing: no vertex or
/// one vertex gives `false`; two vertices make two coincident edges whose crossings are
/// computed from opposite ends, so a point within rounding of the segment can come out
/// `true`. Callers that want `false` there check the length first.
///
/// ```
/// use mapkeeper_grid::Point2;
/// use mapkeeper_grid::geometry::polygon_contains;
/// let square = [Point2::new(0.0, 0.0), Point2::new(1.0, 0.0), Point2::new(1.0, 1.0), Point2::new(0.0, 1.0)];
/// assert!(polygon_contains(&square, Point2::new(0.5, 0.5)));
/// assert!(!polygon_contains(&square, Point2::new(1.5, 0.5)));
/// // Vertices may come as `[x, y]` arrays.
/// assert!(polygon_contains(&[[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]], Point2::new(0.5, 0.5)));
/// ```
pub fn polygon_contains<V: Copy + Into<Point2>>(vertices: &[V], p: Point2) -> bool {
    let Some(&last) = vertices.last() else { return false };
    let mut inside = false;
    let mut b: Point2 = last.into();
    for &v in vertices {
        let a: Point2 = v.into();
        if (a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x {
            inside = !inside;
        }
        b = a;
    }
    inside
}

/// `x.floor()` bit for bit (signed zeros, infinities and NaN included), without the libm call
/// that `f64::floor` is on the baseline x86-64 target (it has no rounding instruction), for hot
/// loops: below 2^52 in magnitude through the integer conversion, above it `x` is already whole.
///
/// ```
/// use mapkeeper_grid::geometry::floor_exact;
/// for x in [2.5, -2.5, -0.0, 0.3, -0.3, 1e300, f64::NEG_INFINITY] {
///     assert_eq!(floor_exact(x).to_bits(), x.floor().to_bits());
/// }
/// ```
#[inline(always)]
pub fn floor_exact(x: f64) -> f64 {
    if x.abs() < 4_503_599_627_370_496.0 {
        let t = (x as i64) as f64;
        if t > x {
            t - 1.0
        } else {
            // The truncation of -0.3 or -0.0 is +0.0, their floors -1.0 and -0.0: the sign of a
            // zero comes from x.
            t.copysign(x)
        }
    } else {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn pt(x: f64, y: f64) -> Point2 {
        Point2::new(x, y)
    }

    const SQUARE: [Point2; 4] =
        [Point2::new(0.0, 0.0), Point2::new(2.0, 0.0), Point2::new(2.0, 2.0), Point2::new(0.0, 2.0)];

    #[test]
    fn inside_and_outside_of_a_square_in_both_windings() {
        let cw: Vec<Point2> = SQUARE.iter().rev().copied().collect();
        for poly in [&SQUARE[..], &cw[..]] {
            assert!(polygon_contains(poly, pt(1.0, 1.0)));
            assert!(polygon_contains(poly, pt(1e-9, 1.999)));
            for q in [pt(-0.1, 1.0), pt(2.1, 1.0), pt(1.0, -0.1), pt(1.0, 2.1), pt(3.0, 3.0)] {
                assert!(!polygon_contains(poly, q), "{q:?}");
            }
            assert!(!polygon_contains(poly, pt(f64::NAN, 1.0)));
        }
    }

    #[test]
    fn edges_and_vertices_are_half_open() {
        // Left and bottom edges in, right and top edges out.
        assert!(polygon_contains(&SQUARE, pt(0.0, 1.0)));
        assert!(polygon_contains(&SQUARE, pt(1.0, 0.0)));
        assert!(!polygon_contains(&SQUARE, pt(2.0, 1.0)));
        assert!(!polygon_contains(&SQUARE, pt(1.0, 2.0)));
        assert!(polygon_contains(&SQUARE, pt(0.0, 0.0)));
        assert!(!polygon_contains(&SQUARE, pt(2.0, 2.0)));
    }

    #[test]
    fn concave_and_self_intersecting_polygons() {
        // An L: the notch (1..2) × (1..2) is outside.
        let l = [pt(0.0, 0.0), pt(2.0, 0.0), pt(2.0, 1.0), pt(1.0, 1.0), pt(1.0, 2.0), pt(0.0, 2.0)];
        assert!(polygon_contains(&l, pt(0.5, 1.5)));
        assert!(polygon_contains(&l, pt(1.5, 0.5)));
        assert!(!polygon_contains(&l, pt(1.5, 1.5)));
        // A bow tie: both lobes inside, the crossing's left and right outside.
        let bow = [pt(0.0, 0.0), pt(2.0, 2.0), pt(2.0, 0.0), pt(0.0, 2.0)];
        assert!(polygon_contains(&bow, pt(0.2, 1.0)) && polygon_contains(&bow, pt(1.8, 1.0)));
        assert!(!polygon_contains(&bow, pt(1.0, 0.2)) && !polygon_contains(&bow, pt(1.0, 1.8)));
    }

    #[test]
    fn fewer_than_three_vertices() {
        assert!(!polygon_contains::<Point2>(&[], pt(0.0, 0.0)));
        assert!(!polygon_contains(&[pt(0.0, 0.0)], pt(0.0, 0.0)));
        let seg = [pt(0.0, 0.0), pt(2.0, 2.0)];
        assert!(!polygon_contains(&seg, pt(0.5, 1.0)) && !polygon_contains(&seg, pt(1.5, 1.0)));
        // Two edges computed from opposite ends: a point between the two roundings is "inside".
        let (a, b) = (pt(-3.656357558875988, 3.4743373693723267), pt(2.6377461897661405, -2.449309742605783));
        assert!(polygon_contains(&[a, b], pt(-0.4805736491080843, 0.485472880219016)));
    }

    #[test]
    fn arrays_and_points_agree() {
        let arr: Vec<[f64; 2]> = SQUARE.iter().map(|p| [p.x, p.y]).collect();
        for q in [pt(1.0, 1.0), pt(0.0, 1.0), pt(2.0, 1.0), pt(-1.0, 0.0)] {
            assert_eq!(polygon_contains(&arr, q), polygon_contains(&SQUARE, q));
        }
    }

    #[test]
    fn floor_exact_is_floor_bit_for_bit_at_the_edges() {
        let edges = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0 - f64::EPSILON / 2.0,
            -(1.0 - f64::EPSILON / 2.0),
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            4_503_599_627_370_495.5,
            -4_503_599_627_370_495.5,
            4_503_599_627_370_496.0,
            -4_503_599_627_370_497.0,
            9.3e18,
            -9.3e18,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for x in edges {
            assert_eq!(floor_exact(x).to_bits(), x.floor().to_bits(), "{x:e}");
        }
        assert!(floor_exact(f64::NAN).is_nan());
    }

    proptest! {
        /// Any bit pattern (every finite and infinite value): the same bits as `f64::floor`.
        #[test]
        fn floor_exact_is_floor_bit_for_bit(bits in any::<u64>(), small in -1e6f64..1e6) {
            for x in [f64::from_bits(bits), small] {
                if !x.is_nan() {
                    prop_assert_eq!(floor_exact(x).to_bits(), x.floor().to_bits(), "{:e}", x);
                }
            }
        }

        /// A convex polygon (a regular n-gon) holds exactly the points left of every edge,
        /// away from the boundary.
        #[test]
        fn convex_polygons_match_the_half_plane_test(
            n in 3usize..12, r in 0.1f64..5.0, phase in 0.0f64..6.3, cx in -3.0f64..3.0, cy in -3.0f64..3.0,
            qx in -6.0f64..6.0, qy in -6.0f64..6.0,
        ) {
            let v: Vec<Point2> = (0..n)
                .map(|k| {
                    let t = phase + k as f64 * std::f64::consts::TAU / n as f64;
                    pt(cx + r * t.cos(), cy + r * t.sin())
                })
                .collect();
            let q = pt(cx + qx, cy + qy);
            let sides: Vec<f64> = (0..n)
                .map(|i| {
                    let (a, b) = (v[i], v[(i + 1) % n]);
                    ((b.x - a.x) * (q.y - a.y) - (b.y - a.y) * (q.x - a.x)) / a.distance(b)
                })
                .collect();
            let margin = sides.iter().map(|s| s.abs()).fold(f64::INFINITY, f64::min);
            prop_assume!(margin > 1e-9);
            prop_assert_eq!(polygon_contains(&v, q), sides.iter().all(|&s| s > 0.0));
        }
    }
}
