//! What both chart kinds share: the bundled font, the two in-memory backends, atomic file
//! writes, sizes, tick formatting, axis ranges, clipping and legend placement.

use std::error::Error;
use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::PlotError;
use crate::backend::AnyBackend;

/// DejaVu Sans, bundled so that bitmaps never depend on system fonts (licence beside it).
static FONT_BYTES: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// The family every text of this crate uses. SVG files name it (`font-family="sans-serif"`)
/// and let the viewer choose; bitmaps and all text layout use the bundled DejaVu Sans.
pub(crate) const FONT_FAMILY: &str = "sans-serif";

/// Registers the bundled font with plotters' `ab_glyph` font table, once per process.
fn ensure_font() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, FONT_BYTES)
                .map_err(|_| "the bundled font DejaVuSans.ttf was rejected by ab_glyph".to_owned())
        })
        .clone()
}

/// Smallest accepted image side, px (smaller leaves no room for the plotting area).
pub const MIN_SIDE_PX: u32 = 200;
/// Largest accepted image side, px (an 8192 × 8192 RGB buffer is 192 MiB).
pub const MAX_SIDE_PX: u32 = 8192;
/// Size of the SVG documents written by `write_svg`, px (width, height).
pub const SVG_SIZE_PX: (u32, u32) = (800, 500);

/// A drawing failure from plotters, as text (its error type is generic over the backend).
pub(crate) struct DrawFail(pub(crate) String);

impl<E: Error + Send + Sync> From<DrawingAreaErrorKind<E>> for DrawFail {
    fn from(e: DrawingAreaErrorKind<E>) -> Self {
        DrawFail(e.to_string())
    }
}

/// Text sizes and line widths for one image size: everything is designed at 800 × 500 px
/// and scaled by the smaller of the two ratios, but never below 0.75 (legible text).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Scale(pub(crate) f64);

impl Scale {
    pub(crate) fn for_size(width: u32, height: u32) -> Self {
        let s = (f64::from(width) / 800.0).min(f64::from(height) / 500.0);
        Scale(s.clamp(0.75, 4.0))
    }
    /// A length in px at this scale, at least 1.
    pub(crate) fn px(self, base: f64) -> u32 {
        (base * self.0).round().max(1.0) as u32
    }
    pub(crate) fn font(self, base: f64) -> FontDesc<'static> {
        FontDesc::new(FontFamily::Name(FONT_FAMILY), base * self.0, FontStyle::Normal)
    }
}

fn check_size(path: &Path, width: u32, height: u32) -> Result<(), PlotError> {
    let ok = |s: u32| (MIN_SIDE_PX..=MAX_SIDE_PX).contains(&s);
    if ok(width) && ok(height) {
        Ok(())
    } else {
        Err(PlotError::InvalidSize { path: path.to_path_buf(), width, height })
    }
}

/// What `draw` receives: the whole image area and the scale of its size.
pub(crate) type DrawFn<'c> = dyn Fn(&DrawingArea<AnyBackend<'_>, Shift>, Scale) -> Result<(), DrawFail> + 'c;

/// Renders with `draw` into an SVG document of `SVG_SIZE_PX` and writes it atomically.
pub(crate) fn write_svg(path: &Path, draw: &DrawFn<'_>) -> Result<(), PlotError> {
    let (width, height) = SVG_SIZE_PX;
    let draw_err = |e: DrawFail| PlotError::Draw { path: path.to_path_buf(), message: e.0 };
    ensure_font().map_err(|m| draw_err(DrawFail(m)))?;
    let mut svg = String::new();
    {
        let root = AnyBackend::Svg(SVGBackend::with_string(&mut svg, (width, height))).into_drawing_area();
        draw(&root, Scale::for_size(width, height)).map_err(draw_err)?;
        root.present().map_err(|e| draw_err(e.into()))?;
    }
    write_atomically(path, svg.as_bytes())
}

/// Renders with `draw` into an RGB bitmap of `width` × `height` px, encodes it as PNG and
/// writes it atomically.
pub(crate) fn write_png(path: &Path, width: u32, height: u32, draw: &DrawFn<'_>) -> Result<(), PlotError> {
    check_size(path, width, height)?;
    let draw_err = |e: DrawFail| PlotError::Draw { path: path.to_path_buf(), message: e.0 };
    ensure_font().map_err(|m| draw_err(DrawFail(m)))?;
    // Sides are at most MAX_SIDE_PX, so this cannot overflow.
    let mut rgb = vec![255u8; width as usize * height as usize * 3];
    {
        let backend = BitMapBackend::with_buffer_and_format(&mut rgb, (width, height))
            .map_err(|e| draw_err(DrawFail(e.to_string())))?;
        let root = AnyBackend::Bitmap(backend).into_drawing_area();
        draw(&root, Scale::for_size(width, height)).map_err(draw_err)?;
        root.present().map_err(|e| draw_err(e.into()))?;
    }
    let mut bytes = Vec::new();
    {
        let png_err = |source| PlotError::Png { path: path.to_path_buf(), source };
        let mut encoder = png::Encoder::new(&mut bytes, width, height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(png_err)?;
        writer.write_image_data(&rgb).map_err(png_err)?;
        writer.finish().map_err(png_err)?;
    }
    write_atomically(path, &bytes)
}

/// Writes `bytes` to `path` atomically ([`mapkeeper_grid::write_atomic`]), naming the file on
/// error.
pub(crate) fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), PlotError> {
    mapkeeper_grid::write_atomic(path, bytes).map_err(|source| PlotError::Io { path: path.to_path_buf(), source })
}

/// A tick label: at most four decimals with trailing zeros trimmed, scientific notation for
/// very large or very small magnitudes.
pub(crate) fn format_tick(v: f64) -> String {
    if !v.is_finite() {
        return String::new();
    }
    let a = v.abs();
    if a < 1e-9 {
        return "0".to_owned();
    }
    if !(1e-3..1e6).contains(&a) {
        return format!("{v:.2e}");
    }
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".to_owned() } else { s.to_owned() }
}

/// An axis range: the data extent plus a margin of `margin` × span on each side. A single
/// value gets ±max(1, 5 %·|value|); no data gets 0..1. `None` when the span is not finite.
pub(crate) fn auto_range(lo: f64, hi: f64, margin: f64) -> Option<(f64, f64)> {
    if !(lo.is_finite() && hi.is_finite()) || lo > hi {
        return Some((0.0, 1.0));
    }
    let span = hi - lo;
    let (a, b) = if span > 0.0 {
        (lo - margin * span, hi + margin * span)
    } else {
        let d = (0.05 * lo.abs()).max(1.0);
        (lo - d, hi + d)
    };
    ((b - a).is_finite() && b > a).then_some((a, b))
}

/// Extent accumulator over finite values only.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Extent {
    pub(crate) lo: f64,
    pub(crate) hi: f64,
}

impl Extent {
    pub(crate) const EMPTY: Extent = Extent { lo: f64::INFINITY, hi: f64::NEG_INFINITY };
    pub(crate) fn add(&mut self, v: f64) {
        if v.is_finite() {
            self.lo = self.lo.min(v);
            self.hi = self.hi.max(v);
        }
    }
}

/// The data rectangle of a chart, used to clip what the caller's `y_range` cuts off
/// (plotters itself does not clip).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Rect {
    pub(crate) x0: f64,
    pub(crate) x1: f64,
    pub(crate) y0: f64,
    pub(crate) y1: f64,
}

impl Rect {
    pub(crate) fn contains(&self, (x, y): (f64, f64)) -> bool {
        (self.x0..=self.x1).contains(&x) && (self.y0..=self.y1).contains(&y)
    }

    /// Liang–Barsky: the part of segment `p`–`q` inside the rectangle, if any.
    pub(crate) fn clip_segment(&self, p: (f64, f64), q: (f64, f64)) -> Option<((f64, f64), (f64, f64))> {
        let (dx, dy) = (q.0 - p.0, q.1 - p.1);
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for (den, num) in [(-dx, p.0 - self.x0), (dx, self.x1 - p.0), (-dy, p.1 - self.y0), (dy, self.y1 - p.1)] {
            if den == 0.0 {
                if num < 0.0 {
                    return None;
                }
            } else {
                let t = num / den;
                if den < 0.0 {
                    t0 = t0.max(t);
                } else {
                    t1 = t1.min(t);
                }
            }
        }
        (t0 <= t1).then_some(((p.0 + t0 * dx, p.1 + t0 * dy), (p.0 + t1 * dx, p.1 + t1 * dy)))
    }

    /// Splits a polyline into the runs that lie inside the rectangle.
    pub(crate) fn clip_polyline(&self, points: &[(f64, f64)]) -> Vec<Vec<(f64, f64)>> {
        let mut runs: Vec<Vec<(f64, f64)>> = Vec::new();
        let mut current: Vec<(f64, f64)> = Vec::new();
        if let [only] = points {
            if self.contains(*only) {
                runs.push(vec![*only]);
            }
            return runs;
        }
        for pair in points.windows(2) {
            let (p, q) = (pair[0], pair[1]);
            match self.clip_segment(p, q) {
                Some((a, b)) => {
                    if current.last() != Some(&a) {
                        if !current.is_empty() {
                            runs.push(std::mem::take(&mut current));
                        }
                        current.push(a);
                    }
                    current.push(b);
                }
                None => {
                    if !current.is_empty() {
                        runs.push(std::mem::take(&mut current));
                    }
                }
            }
        }
        if !current.is_empty() {
            runs.push(current);
        }
        runs
    }

    /// Sutherland–Hodgman: the part of a polygon inside the rectangle (possibly empty).
    pub(crate) fn clip_polygon(&self, polygon: &[(f64, f64)]) -> Vec<(f64, f64)> {
        type Inside = fn(&Rect, (f64, f64)) -> bool;
        type Cross = fn(&Rect, (f64, f64), (f64, f64)) -> (f64, f64);
        fn at_x(p: (f64, f64), q: (f64, f64), x: f64) -> (f64, f64) {
            (x, p.1 + (q.1 - p.1) * (x - p.0) / (q.0 - p.0))
        }
        fn at_y(p: (f64, f64), q: (f64, f64), y: f64) -> (f64, f64) {
            (p.0 + (q.0 - p.0) * (y - p.1) / (q.1 - p.1), y)
        }
        let edges: [(Inside, Cross); 4] = [
            (|r, p| p.0 >= r.x0, |r, p, q| at_x(p, q, r.x0)),
            (|r, p| p.0 <= r.x1, |r, p, q| at_x(p, q, r.x1)),
            (|r, p| p.1 >= r.y0, |r, p, q| at_y(p, q, r.y0)),
            (|r, p| p.1 <= r.y1, |r, p, q| at_y(p, q, r.y1)),
        ];
        let mut poly = polygon.to_vec();
        for (inside, cross) in edges {
            let input = std::mem::take(&mut poly);
            let Some(&last) = input.last() else { break };
            let mut prev = last;
            for &cur in &input {
                match (inside(self, cur), inside(self, prev)) {
                    (true, true) => poly.push(cur),
                    (true, false) => {
                        poly.push(cross(self, prev, cur));
                        poly.push(cur);
                    }
                    (false, true) => poly.push(cross(self, prev, cur)),
                    (false, false) => {}
                }
                prev = cur;
            }
        }
        poly
    }
}

/// Picks the plot corner for the legend that covers the fewest data rectangles (points are
/// zero-size rectangles), preferring upper right, then upper left, lower right, lower left.
/// `legend_w` and `legend_h` are the legend's size as fractions of the plot.
pub(crate) fn legend_corner(
    plot: Rect,
    legend_w: f64,
    legend_h: f64,
    items: impl Iterator<Item = Rect> + Clone,
) -> SeriesLabelPosition {
    let (w, h) = ((plot.x1 - plot.x0) * legend_w, (plot.y1 - plot.y0) * legend_h);
    let corners = [
        (SeriesLabelPosition::UpperRight, Rect { x0: plot.x1 - w, x1: plot.x1, y0: plot.y1 - h, y1: plot.y1 }),
        (SeriesLabelPosition::UpperLeft, Rect { x0: plot.x0, x1: plot.x0 + w, y0: plot.y1 - h, y1: plot.y1 }),
        (SeriesLabelPosition::LowerRight, Rect { x0: plot.x1 - w, x1: plot.x1, y0: plot.y0, y1: plot.y0 + h }),
        (SeriesLabelPosition::LowerLeft, Rect { x0: plot.x0, x1: plot.x0 + w, y0: plot.y0, y1: plot.y0 + h }),
    ];
    let overlaps = |a: &Rect, b: &Rect| a.x0 <= b.x1 && b.x0 <= a.x1 && a.y0 <= b.y1 && b.y0 <= a.y1;
    let mut best = (usize::MAX, SeriesLabelPosition::UpperRight);
    for (position, zone) in corners {
        let n = items.clone().filter(|r| overlaps(r, &zone)).count();
        if n < best.0 {
            best = (n, position);
        }
    }
    best.1
}

/// The style of legend boxes and "no data" notes shared by both charts.
pub(crate) fn draw_note(area: &DrawingArea<AnyBackend<'_>, Shift>, scale: Scale, text: &str) -> Result<(), DrawFail> {
    let (w, h) = area.dim_in_pixel();
    let style = scale.font(16.0).color(&RGBColor(110, 110, 110)).pos(Pos::new(HPos::Center, VPos::Center));
    area.draw(&Text::new(text.to_owned(), (w as i32 / 2, h as i32 / 2), style))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_short_and_trimmed() {
        assert_eq!(format_tick(0.30000000000000004), "0.3");
        assert_eq!(format_tick(100.0), "100");
        assert_eq!(format_tick(-2.5), "-2.5");
        assert_eq!(format_tick(1e-12), "0");
        assert_eq!(format_tick(-0.00001), "-1.00e-5");
        assert_eq!(format_tick(2.5e7), "2.50e7");
        assert_eq!(format_tick(f64::NAN), "");
    }

    #[test]
    fn auto_range_adds_margins_and_handles_degenerate_data() {
        assert_eq!(auto_range(0.0, 10.0, 0.05), Some((-0.5, 10.5)));
        assert_eq!(auto_range(3.0, 3.0, 0.05), Some((2.0, 4.0)));
        assert_eq!(auto_range(100.0, 100.0, 0.05), Some((95.0, 105.0)));
        assert_eq!(auto_range(f64::INFINITY, f64::NEG_INFINITY, 0.05), Some((0.0, 1.0)));
        assert_eq!(auto_range(-1e308, 1e308, 0.05), None);
    }

    #[test]
    fn segments_are_clipped_to_the_rectangle() {
        let r = Rect { x0: 0.0, x1: 10.0, y0: 0.0, y1: 10.0 };
        assert_eq!(r.clip_segment((-5.0, 5.0), (5.0, 5.0)), Some(((0.0, 5.0), (5.0, 5.0))));
        assert_eq!(r.clip_segment((0.0, 20.0), (10.0, 20.0)), None);
        assert_eq!(r.clip_segment((5.0, -10.0), (5.0, 20.0)), Some(((5.0, 0.0), (5.0, 10.0))));
        // Up out of the box and back: two runs.
        let runs = r.clip_polyline(&[(0.0, 5.0), (2.0, 15.0), (4.0, 5.0)]);
        assert_eq!(runs, vec![vec![(0.0, 5.0), (1.0, 10.0)], vec![(3.0, 10.0), (4.0, 5.0)]]);
    }

    #[test]
    fn polygons_are_clipped_to_the_rectangle() {
        let r = Rect { x0: 0.0, x1: 10.0, y0: 0.0, y1: 10.0 };
        // A square overhanging the top edge keeps its lower half.
        let clipped = r.clip_polygon(&[(2.0, 5.0), (8.0, 5.0), (8.0, 15.0), (2.0, 15.0)]);
        let ext_y = clipped.iter().fold(Extent::EMPTY, |mut e, p| {
            e.add(p.1);
            e
        });
        assert_eq!((ext_y.lo, ext_y.hi), (5.0, 10.0));
        assert!(r.clip_polygon(&[(20.0, 20.0), (30.0, 20.0), (30.0, 30.0)]).is_empty());
    }

    #[test]
    fn legend_avoids_the_crowded_corner() {
        let plot = Rect { x0: 0.0, x1: 1.0, y0: 0.0, y1: 1.0 };
        let pt = |x, y| Rect { x0: x, x1: x, y0: y, y1: y };
        let items = [pt(0.9, 0.9), pt(0.95, 0.95), pt(0.1, 0.1)];
        let corner = legend_corner(plot, 0.3, 0.3, items.iter().copied());
        assert!(matches!(corner, SeriesLabelPosition::UpperLeft));
    }
}
