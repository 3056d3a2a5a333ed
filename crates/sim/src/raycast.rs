//! A ray caster for the static and movable geometry: boundary segments and circles binned in a
//! uniform grid, traversed cell by cell (Amanatides–Woo) from the lidar. It answers the same
//! question as rapier's `cast_ray` against those colliders (checked beam for beam in the tests)
//! in a fraction of the time, because most beams only visit a few cells with a few segments each.

use crate::shape::Shape;
use mapkeeper_grid::Point2;

#[derive(Clone, Copy, Debug)]
enum Prim {
    Seg { ax: f64, ay: f64, bx: f64, by: f64 },
    Circle { cx: f64, cy: f64, r: f64 },
}

/// Distance along the unit ray `(ox, oy) + t (dx, dy)` to a primitive, if hit with `t ≥ 0`.
#[inline]
fn hit(p: &Prim, ox: f64, oy: f64, dx: f64, dy: f64) -> Option<f64> {
    match *p {
        Prim::Seg { ax, ay, bx, by } => {
            let (ex, ey) = (bx - ax, by - ay);
            let den = dx * ey - dy * ex;
            if den.abs() < 1e-15 {
                return None;
            }
            let (wx, wy) = (ax - ox, ay - oy);
            let t = (wx * ey - wy * ex) / den;
            let u = (wx * dy - wy * dx) / den;
            (t >= 0.0 && (0.0..=1.0).contains(&u)).then_some(t)
        }
        Prim::Circle { cx, cy, r } => {
            let (wx, wy) = (ox - cx, oy - cy);
            let b = wx * dx + wy * dy;
            let c = wx * wx + wy * wy - r * r;
            if c <= 0.0 {
                return Some(0.0); // inside: a solid shape is hit at once
            }
            let disc = b * b - c;
            if disc < 0.0 {
                return None;
            }
            let t = -b - disc.sqrt();
            (t >= 0.0).then_some(t)
        }
    }
}

/// Static geometry binned in square cells.
#[derive(Clone)]
pub(crate) struct StaticCaster {
    x0: f64,
    y0: f64,
    cell: f64,
    nx: usize,
    ny: usize,
    /// Per cell: start and end into `items`.
    spans: Vec<(u32, u32)>,
    items: Vec<u32>,
    prims: Vec<Prim>,
    /// Shapes, for the "origin inside a solid" test.
    shapes: Vec<Shape>,
}

impl StaticCaster {
    pub(crate) fn new(shapes: &[Shape], cell: f64) -> Self {
        let mut prims = Vec::new();
        for s in shapes {
            match s {
                Shape::Circle { center, radius } => {
                    prims.push(Prim::Circle { cx: center[0], cy: center[1], r: *radius })
                }
                _ => {
                    let v = s.vertices().unwrap_or_default();
                    for i in 0..v.len() {
                        let (a, b) = (v[i], v[(i + 1) % v.len()]);
                        prims.push(Prim::Seg { ax: a.x, ay: a.y, bx: b.x, by: b.y });
                    }
                }
            }
        }
        let mut bounds = crate::shape::Bounds::EMPTY;
        for s in shapes {
            bounds = bounds.union(s.bounds());
        }
        if bounds.is_empty() {
            bounds = crate::shape::Bounds { min: Point2::new(0.0, 0.0), max: Point2::new(0.0, 0.0) };
        }
        let (x0, y0) = (bounds.min.x - cell, bounds.min.y - cell);
        let nx = (((bounds.max.x + cell - x0) / cell).ceil() as usize).clamp(1, 4096);
        let ny = (((bounds.max.y + cell - y0) / cell).ceil() as usize).clamp(1, 4096);
        let mut bins: Vec<Vec<u32>> = vec![Vec::new(); nx * ny];
        let clampi = |v: f64, n: usize| (v.floor().max(0.0) as usize).min(n - 1);
        for (i, p) in prims.iter().enumerate() {
            let (lx, ly, hx, hy) = match *p {
                Prim::Seg { ax, ay, bx, by } => (ax.min(bx), ay.min(by), ax.max(bx), ay.max(by)),
                Prim::Circle { cx, cy, r } => (cx - r, cy - r, cx + r, cy + r),
            };
            // Conservative: every cell of the primitive's bounding box (slightly grown).
            let e = 1e-6;
            for iy in clampi((ly - e - y0) / cell, ny)..=clampi((hy + e - y0) / cell, ny) {
                for ix in clampi((lx - e - x0) / cell, nx)..=clampi((hx + e - x0) / cell, nx) {
                    bins[iy * nx + ix].push(i as u32);
                }
            }
        }
        let mut spans = Vec::with_capacity(bins.len());
        let mut items = Vec::new();
        for b in bins {
            let s = items.len() as u32;
            items.extend(b);
            spans.push((s, items.len() as u32));
        }
        Self { x0, y0, cell, nx, ny, spans, items, prims, shapes: shapes.to_vec() }
    }

    /// Whether `p` is inside a static shape (rays from there hit at 0, as rapier's solid casts do).
    pub(crate) fn inside(&self, p: Point2) -> bool {
        self.shapes.iter().any(|s| s.contains(p))
    }

    /// The nearest hit within `max_t` along the unit direction `(dx, dy)` from `(ox, oy)`.
    pub(crate) fn cast(&self, ox: f64, oy: f64, dx: f64, dy: f64, max_t: f64) -> Option<f64> {
        let c = self.cell;
        let (gx, gy) = ((ox - self.x0) / c, (oy - self.y0) / c);
        let (nx, ny) = (self.nx as i64, self.ny as i64);
        let (mut ix, mut iy) = (gx.floor() as i64, gy.floor() as i64);
        if ix < 0 || iy < 0 || ix >= nx || iy >= ny {
            // Outside the binned area: test everything (rare; not the lidar's case).
            return self.prims.iter().filter_map(|p| hit(p, ox, oy, dx, dy)).filter(|&t| t <= max_t).reduce(f64::min);
        }
        let step_x: i64 = if dx > 0.0 { 1 } else { -1 };
        let step_y: i64 = if dy > 0.0 { 1 } else { -1 };
        let t_dx = if dx != 0.0 { c / dx.abs() } else { f64::INFINITY };
        let t_dy = if dy != 0.0 { c / dy.abs() } else { f64::INFINITY };
        let mut t_x = if dx > 0.0 {
            ((ix + 1) as f64 - gx) * t_dx
        } else if dx < 0.0 {
            (gx - ix as f64) * t_dx
        } else {
            f64::INFINITY
        };
        let mut t_y = if dy > 0.0 {
            ((iy + 1) as f64 - gy) * t_dy
        } else if dy < 0.0 {
            (gy - iy as f64) * t_dy
        } else {
            f64::INFINITY
        };
        let mut best = f64::INFINITY;
        loop {
            let (s, e) = self.spans[(iy * nx + ix) as usize];
            for &k in &self.items[s as usize..e as usize] {
                if let Some(t) = hit(&self.prims[k as usize], ox, oy, dx, dy)
                    && t < best
                {
                    best = t;
                }
            }
            let t_exit = t_x.min(t_y);
            if best <= t_exit || t_exit > max_t {
                break;
            }
            if t_x < t_y {
                ix += step_x;
                t_x += t_dx;
            } else {
                iy += step_y;
                t_y += t_dy;
            }
            if ix < 0 || iy < 0 || ix >= nx || iy >= ny {
                break;
            }
        }
        (best <= max_t).then_some(best)
    }
}

/// Distance to a shape along a ray (used for the agents), `None` if missed.
pub(crate) fn cast_shape(shape: &Shape, ox: f64, oy: f64, dx: f64, dy: f64) -> Option<f64> {
    if shape.contains(Point2::new(ox, oy)) {
        return Some(0.0);
    }
    match shape {
        Shape::Circle { center, radius } => {
            hit(&Prim::Circle { cx: center[0], cy: center[1], r: *radius }, ox, oy, dx, dy)
        }
        _ => {
            let v = shape.vertices().unwrap_or_default();
            (0..v.len())
                .filter_map(|i| {
                    let (a, b) = (v[i], v[(i + 1) % v.len()]);
                    hit(&Prim::Seg { ax: a.x, ay: a.y, bx: b.x, by: b.y }, ox, oy, dx, dy)
                })
                .reduce(f64::min)
        }
    }
}
