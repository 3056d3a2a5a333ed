//! Line charts: one or more series over a numeric x axis, each with an optional shaded band.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::PlotError;
use crate::backend::AnyBackend;
use crate::render::{self, DrawFail, Extent, Rect, Scale};

/// Series with at most this many finite points also get a dot at each point.
pub const MARKER_MAX_POINTS: usize = 60;

/// One line of a [`LineChart`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// The points `(x, y)` in drawing order. Non-finite points are skipped and break the line.
    pub points: Vec<(f64, f64)>,
    /// Optional shaded band `(x, lo, hi)` in x order (e.g. mean ± one standard deviation),
    /// drawn under the line in the series colour. Non-finite entries break the band.
    pub band: Option<Vec<(f64, f64, f64)>>,
}

impl Series {
    /// A series without a band.
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Series { name: name.into(), points, band: None }
    }

    /// This series with a shaded band `(x, lo, hi)`.
    #[must_use]
    pub fn with_band(mut self, band: Vec<(f64, f64, f64)>) -> Self {
        self.band = Some(band);
        self
    }

    /// A mean line with a ± one-standard-deviation band, from `(x, mean, std)` triples (the
    /// paper's "(μ, σ)" plots, Fig. 25-26).
    pub fn mean_std(name: impl Into<String>, data: &[(f64, f64, f64)]) -> Self {
        let points = data.iter().map(|&(x, m, _)| (x, m)).collect();
        let band = data.iter().map(|&(x, m, s)| (x, m - s, m + s)).collect();
        Series { name: name.into(), points, band: Some(band) }
    }
}

/// A line chart (e.g. CC of M_1/G_i and M_i/G_i over world index i, paper Fig. 24).
///
/// Series take colours from [`crate::PALETTE`] in order (blue, red, ... as in the paper's
/// figures). Axis ranges cover all finite points and bands with a 4 % margin, unless
/// `y_range` is given (then lines and bands are clipped to it). A chart without any finite
/// point is written with the note "no data".
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LineChart {
    /// Caption above the plot.
    pub title: String,
    /// X axis description.
    pub x_label: String,
    /// Y axis description.
    pub y_label: String,
    /// The lines, drawn and listed in the legend in this order.
    pub series: Vec<Series>,
    /// Fixed y axis range `(lo, hi)` with `lo < hi`, both finite; `None` for automatic.
    pub y_range: Option<(f64, f64)>,
    /// Put x ticks on integers only (x is a count or an index, e.g. the world number).
    pub x_integer: bool,
}

impl LineChart {
    /// A chart without series.
    pub fn new(title: impl Into<String>, x_label: impl Into<String>, y_label: impl Into<String>) -> Self {
        LineChart { title: title.into(), x_label: x_label.into(), y_label: y_label.into(), ..Default::default() }
    }

    /// This chart with one more series.
    #[must_use]
    pub fn with_series(mut self, series: Series) -> Self {
        self.series.push(series);
        self
    }

    /// This chart with a fixed y range.
    #[must_use]
    pub fn with_y_range(mut self, lo: f64, hi: f64) -> Self {
        self.y_range = Some((lo, hi));
        self
    }

    /// This chart with x ticks on integers only.
    #[must_use]
    pub fn with_integer_x(mut self) -> Self {
        self.x_integer = true;
        self
    }

    /// Writes the chart as an SVG document of [`crate::SVG_SIZE_PX`] to `path`, atomically.
    pub fn write_svg(&self, path: &Path) -> Result<(), PlotError> {
        let ranges = self.ranges(path)?;
        render::write_svg(path, &|root, scale| self.draw(root, scale, ranges))
    }

    /// Writes the chart as an RGB PNG of `width_px` × `height_px` to `path`, atomically.
    /// Each side must be within [`crate::MIN_SIDE_PX`]..=[`crate::MAX_SIDE_PX`].
    pub fn write_png(&self, path: &Path, width_px: u32, height_px: u32) -> Result<(), PlotError> {
        let ranges = self.ranges(path)?;
        render::write_png(path, width_px, height_px, &|root, scale| self.draw(root, scale, ranges))
    }

    /// The data rectangle: x from the data, y from `y_range` or the data.
    fn ranges(&self, path: &Path) -> Result<Rect, PlotError> {
        let (mut ex, mut ey) = (Extent::EMPTY, Extent::EMPTY);
        for s in &self.series {
            for &(x, y) in s.points.iter().filter(|p| finite(**p)) {
                ex.add(x);
                ey.add(y);
            }
            for &(x, lo, hi) in s.band.iter().flatten().filter(|b| finite_band(**b)) {
                ex.add(x);
                ey.add(lo);
                ey.add(hi);
            }
        }
        let bad = |axis, lo, hi, reason: &str| PlotError::InvalidRange {
            path: path.to_path_buf(),
            axis,
            lo,
            hi,
            reason: reason.to_owned(),
        };
        let (x0, x1) =
            render::auto_range(ex.lo, ex.hi, 0.02).ok_or_else(|| bad("x", ex.lo, ex.hi, "span too large"))?;
        let (y0, y1) = match self.y_range {
            Some((lo, hi)) if lo.is_finite() && hi.is_finite() && lo < hi && (hi - lo).is_finite() => (lo, hi),
            Some((lo, hi)) => return Err(bad("y", lo, hi, "must be finite with lo < hi")),
            None => render::auto_range(ey.lo, ey.hi, 0.04).ok_or_else(|| bad("y", ey.lo, ey.hi, "span too large"))?,
        };
        Ok(Rect { x0, x1, y0, y1 })
    }

    /// The legend's corner: the one whose box covers the fewest points and bands.
    fn legend_position(&self, r: Rect) -> SeriesLabelPosition {
        let longest = self.series.iter().map(|s| s.name.chars().count()).max().unwrap_or(0) as f64;
        let legend_w = ((longest * 8.0 + 50.0) / 700.0).min(0.6);
        let legend_h = ((self.series.len() as f64 * 20.0 + 12.0) / 400.0).min(0.9);
        let items = self.series.iter().flat_map(|s| {
            let pts = s.points.iter().filter(|p| finite(**p)).map(|&(x, y)| Rect { x0: x, x1: x, y0: y, y1: y });
            let band = s.band.iter().flatten().filter(|b| finite_band(**b));
            pts.chain(band.map(|&(x, lo, hi)| Rect { x0: x, x1: x, y0: lo.min(hi), y1: lo.max(hi) }))
        });
        render::legend_corner(r, legend_w, legend_h, items)
    }

    fn draw(&self, root: &DrawingArea<AnyBackend<'_>, Shift>, scale: Scale, r: Rect) -> Result<(), DrawFail> {
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, scale.font(24.0))
            .margin(scale.px(14.0))
            .x_label_area_size(scale.px(48.0))
            .y_label_area_size(scale.px(64.0))
            .build_cartesian_2d(r.x0..r.x1, r.y0..r.y1)?;
        let tick = |v: &f64| render::format_tick(*v);
        // Asking for no more labels than there are integers in the range makes plotters pick
        // a step of 1 or more, so every tick is an integer.
        let x_labels = if self.x_integer { integers_in(r.x0, r.x1).clamp(1, 10) } else { 10 };
        chart
            .configure_mesh()
            .x_labels(x_labels)
            .x_desc(self.x_label.as_str())
            .y_desc(self.y_label.as_str())
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .label_style(scale.font(14.0))
            .axis_desc_style(scale.font(16.0))
            .bold_line_style(RGBColor(215, 215, 215))
            .light_line_style(RGBColor(242, 242, 242))
            .max_light_lines(4)
            .draw()?;

        let line_width = scale.px(2.0);
        let mut any_point = false;
        for (i, s) in self.series.iter().enumerate() {
            let colour = crate::colour(i);
            // Band first, so that every line stays on top of every band.
            for clipped in band_polygons(s, r) {
                chart.draw_series(std::iter::once(Polygon::new(clipped, colour.mix(0.18).filled())))?;
            }
        }
        for (i, s) in self.series.iter().enumerate() {
            let colour = crate::colour(i);
            let style = colour.stroke_width(line_width);
            // An empty series carries the legend entry, whatever the data.
            let legend_len = scale.px(22.0) as i32;
            chart
                .draw_series(LineSeries::new(std::iter::empty(), style))?
                .label(s.name.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + legend_len, y)], style));
            let n_finite = s.points.iter().filter(|p| finite(**p)).count();
            any_point |= n_finite > 0;
            for run in s.points.split(|p| !finite(*p)) {
                for piece in r.clip_polyline(run) {
                    chart.draw_series(LineSeries::new(piece, style))?;
                }
            }
            if n_finite <= MARKER_MAX_POINTS {
                let radius = scale.px(2.5);
                let dots = s.points.iter().filter(|p| finite(**p) && r.contains(**p));
                chart.draw_series(dots.map(|&p| Circle::new(p, radius, colour.filled())))?;
            }
        }

        if !any_point {
            render::draw_note(&chart.plotting_area().strip_coord_spec(), scale, "no data")?;
        }
        if !self.series.is_empty() {
            chart
                .configure_series_labels()
                .legend_area_size(scale.px(30.0))
                .position(self.legend_position(r))
                .label_font(scale.font(14.0))
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(180, 180, 180))
                .margin(scale.px(8.0))
                .draw()?;
        }
        Ok(())
    }
}

/// A series' band as polygons (each finite run of two or more points, upper edge then lower
/// edge back), clipped to the plot.
fn band_polygons(s: &Series, r: Rect) -> Vec<Vec<(f64, f64)>> {
    let Some(band) = &s.band else { return Vec::new() };
    band.split(|b| !finite_band(*b))
        .filter(|run| run.len() >= 2)
        .map(|run| {
            let outline: Vec<(f64, f64)> =
                run.iter().map(|&(x, _, hi)| (x, hi)).chain(run.iter().rev().map(|&(x, lo, _)| (x, lo))).collect();
            r.clip_polygon(&outline)
        })
        .filter(|c| c.len() >= 3)
        .collect()
}

/// How many integers lie in `[lo, hi]` (saturating; 0 for an empty or non-finite range).
fn integers_in(lo: f64, hi: f64) -> usize {
    if !(lo.is_finite() && hi.is_finite()) || hi < lo.ceil() {
        return 0;
    }
    let n = hi.floor() - lo.ceil() + 1.0;
    if n >= usize::MAX as f64 { usize::MAX } else { n as usize }
}

fn finite((x, y): (f64, f64)) -> bool {
    x.is_finite() && y.is_finite()
}

fn finite_band((x, lo, hi): (f64, f64, f64)) -> bool {
    x.is_finite() && lo.is_finite() && hi.is_finite()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integers_in_a_range_are_counted() {
        assert_eq!(integers_in(1.98, 3.02), 2);
        assert_eq!(integers_in(2.0, 2.0), 1);
        assert_eq!(integers_in(2.1, 2.9), 0);
        assert_eq!(integers_in(-0.5, 99.5), 100);
        assert_eq!(integers_in(f64::NAN, 1.0), 0);
    }
}
