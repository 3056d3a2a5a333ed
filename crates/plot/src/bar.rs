//! Grouped bar charts: for each category, one bar per group.

use std::ops::Range;
use std::path::Path;

use plotters::coord::Shift;
use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, Ranged, ValueFormatter};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::PlotError;
use crate::backend::AnyBackend;
use crate::render::{self, DrawFail, Extent, Rect, Scale};

/// Bars carry their value as a label above them when the chart has at most this many bars.
pub const VALUE_LABEL_MAX_BARS: usize = 40;

/// A grouped bar chart (e.g. verdict counts Update / Suspend / Lost per preset, or the
/// paper's Table 1: CC, MS, OPDF for always-update vs. the localisation check).
///
/// Category `c` gets one bar per group, in group order, coloured from [`crate::PALETTE`] and
/// named in the legend. Every group must hold one value per category; a non-finite value
/// leaves its bar out. The y axis starts at zero (or includes it) and leaves headroom for the
/// value labels, unless `y_range` is given (bars are then clipped to it).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BarChart {
    /// Caption above the plot.
    pub title: String,
    /// Category names along the x axis.
    pub categories: Vec<String>,
    /// `(group name, one value per category)`, drawn side by side within each category.
    pub groups: Vec<(String, Vec<f64>)>,
    /// Y axis description.
    pub y_label: String,
    /// Fixed y axis range `(lo, hi)` with `lo < hi`, both finite; `None` for automatic.
    pub y_range: Option<(f64, f64)>,
}

impl BarChart {
    /// A chart with categories and no groups yet.
    pub fn new(title: impl Into<String>, y_label: impl Into<String>, categories: Vec<String>) -> Self {
        BarChart { title: title.into(), y_label: y_label.into(), categories, ..Default::default() }
    }

    /// This chart with one more group (one value per category).
    #[must_use]
    pub fn with_group(mut self, name: impl Into<String>, values: Vec<f64>) -> Self {
        self.groups.push((name.into(), values));
        self
    }

    /// This chart with a fixed y range.
    #[must_use]
    pub fn with_y_range(mut self, lo: f64, hi: f64) -> Self {
        self.y_range = Some((lo, hi));
        self
    }

    /// Writes the chart as an SVG document of [`crate::SVG_SIZE_PX`] to `path`, atomically.
    pub fn write_svg(&self, path: &Path) -> Result<(), PlotError> {
        let r = self.check(path)?;
        render::write_svg(path, &|root, scale| self.draw(root, scale, r))
    }

    /// Writes the chart as an RGB PNG of `width_px` × `height_px` to `path`, atomically.
    /// Each side must be within [`crate::MIN_SIDE_PX`]..=[`crate::MAX_SIDE_PX`].
    pub fn write_png(&self, path: &Path, width_px: u32, height_px: u32) -> Result<(), PlotError> {
        let r = self.check(path)?;
        render::write_png(path, width_px, height_px, &|root, scale| self.draw(root, scale, r))
    }

    /// Validates the group lengths and returns the data rectangle (x spans the categories).
    fn check(&self, path: &Path) -> Result<Rect, PlotError> {
        let n = self.categories.len();
        if let Some((name, values)) = self.groups.iter().find(|(_, v)| v.len() != n) {
            return Err(PlotError::GroupLength {
                path: path.to_path_buf(),
                group: name.clone(),
                expected: n,
                got: values.len(),
            });
        }
        let mut e = Extent::EMPTY;
        e.add(0.0);
        self.groups.iter().flat_map(|(_, v)| v).for_each(|&v| e.add(v));
        let (y0, y1) = match self.y_range {
            Some((lo, hi)) if lo.is_finite() && hi.is_finite() && lo < hi && (hi - lo).is_finite() => (lo, hi),
            Some((lo, hi)) => {
                return Err(PlotError::InvalidRange {
                    path: path.to_path_buf(),
                    axis: "y",
                    lo,
                    hi,
                    reason: "must be finite with lo < hi".to_owned(),
                });
            }
            None => {
                let span = e.hi - e.lo;
                let headroom = if span > 0.0 { 0.12 * span } else { 1.0 };
                let y0 = if e.lo < 0.0 { e.lo - headroom } else { 0.0 };
                let y1 = if e.hi > 0.0 || span == 0.0 { e.hi + headroom } else { 0.0 };
                if !(y1 - y0).is_finite() {
                    return Err(PlotError::InvalidRange {
                        path: path.to_path_buf(),
                        axis: "y",
                        lo: e.lo,
                        hi: e.hi,
                        reason: "span too large".to_owned(),
                    });
                }
                (y0, y1)
            }
        };
        Ok(Rect { x0: 0.0, x1: n.max(1) as f64, y0, y1 })
    }

    /// The bars as `(group index, category index, rectangle)`, clipped to the y range.
    fn bars(&self, r: Rect) -> impl Iterator<Item = (usize, usize, f64, Rect)> + Clone + '_ {
        let g = self.groups.len().max(1) as f64;
        let slot = 0.8 / g;
        self.groups.iter().enumerate().flat_map(move |(j, (_, values))| {
            values.iter().enumerate().filter(|(_, v)| v.is_finite()).filter_map(move |(c, &v)| {
                let x0 = c as f64 + 0.1 + slot * j as f64 + 0.04 * slot;
                let x1 = x0 + 0.92 * slot;
                let (lo, hi) = (v.min(0.0).clamp(r.y0, r.y1), v.max(0.0).clamp(r.y0, r.y1));
                (hi > lo).then_some((j, c, v, Rect { x0, x1, y0: lo, y1: hi }))
            })
        })
    }

    fn draw(&self, root: &DrawingArea<AnyBackend<'_>, Shift>, scale: Scale, r: Rect) -> Result<(), DrawFail> {
        root.fill(&WHITE)?;
        let axis = CategoryAxis { names: &self.categories };
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, scale.font(24.0))
            .margin(scale.px(14.0))
            .x_label_area_size(scale.px(36.0))
            .y_label_area_size(scale.px(64.0))
            .build_cartesian_2d(axis, r.y0..r.y1)?;
        let tick = |v: &f64| render::format_tick(*v);
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(self.categories.len().max(1))
            .y_label_formatter(&tick)
            .y_desc(self.y_label.as_str())
            .label_style(scale.font(14.0))
            .axis_desc_style(scale.font(16.0))
            .bold_line_style(RGBColor(215, 215, 215))
            .light_line_style(RGBColor(242, 242, 242))
            .max_light_lines(4)
            .draw()?;

        let legend_box = scale.px(10.0) as i32;
        for (j, (name, _)) in self.groups.iter().enumerate() {
            let colour = crate::colour(j);
            chart
                .draw_series(
                    self.bars(r)
                        .filter(|b| b.0 == j)
                        .map(|(_, _, _, b)| Rectangle::new([(b.x0, b.y0), (b.x1, b.y1)], colour.filled())),
                )?
                .label(name.as_str())
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - legend_box / 2), (x + legend_box, y + legend_box / 2)], colour.filled())
                });
        }
        if r.y0 < 0.0 && r.y1 > 0.0 {
            chart.draw_series(LineSeries::new([(r.x0, 0.0), (r.x1, 0.0)], BLACK.stroke_width(1)))?;
        }

        let n_bars = self.bars(r).count();
        if n_bars <= VALUE_LABEL_MAX_BARS {
            let gap = scale.px(3.0) as i32;
            let font = scale.font(12.0);
            let labels = self.bars(r).filter(|(_, _, v, _)| (r.y0..=r.y1).contains(v)).map(|(_, _, v, b)| {
                let (y, dy, vpos) = if v >= 0.0 { (b.y1, -gap, VPos::Bottom) } else { (b.y0, gap, VPos::Top) };
                let style = font.clone().color(&RGBColor(60, 60, 60)).pos(Pos::new(HPos::Center, vpos));
                EmptyElement::at(((b.x0 + b.x1) / 2.0, y)) + Text::new(format_value(v), (0, dy), style)
            });
            chart.draw_series(labels)?;
        }

        if self.categories.is_empty() || self.groups.is_empty() {
            render::draw_note(&chart.plotting_area().strip_coord_spec(), scale, "no data")?;
        } else if n_bars == 0 {
            render::draw_note(&chart.plotting_area().strip_coord_spec(), scale, "no finite value")?;
        }
        if !self.groups.is_empty() {
            let longest = self.groups.iter().map(|(s, _)| s.chars().count()).max().unwrap_or(0) as f64;
            let legend_w = ((longest * 8.0 + 40.0) / 700.0).min(0.6);
            let legend_h = ((self.groups.len() as f64 * 20.0 + 12.0) / 400.0).min(0.9);
            let items = self.bars(r).map(|(_, _, _, b)| b);
            chart
                .configure_series_labels()
                .legend_area_size(scale.px(30.0))
                .position(render::legend_corner(r, legend_w, legend_h, items))
                .label_font(scale.font(14.0))
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(180, 180, 180))
                .margin(scale.px(8.0))
                .draw()?;
        }
        Ok(())
    }
}

/// A bar's label: integers without decimals (counts), other values with up to two.
fn format_value(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{v:.0}")
    } else if (1e-2..1e6).contains(&v.abs()) {
        let s = format!("{v:.2}");
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        format!("{v:.2e}")
    }
}

/// The x axis of a bar chart: category `i` spans `[i, i + 1)`; its name is the tick label
/// at `i + 0.5`. Without categories the axis spans `[0, 1)` and has no tick.
#[derive(Debug, Clone, Copy)]
struct CategoryAxis<'a> {
    names: &'a [String],
}

impl Ranged for CategoryAxis<'_> {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let f = value / self.names.len().max(1) as f64;
        limit.0 + (f64::from(limit.1 - limit.0) * f).round() as i32
    }

    fn key_points<Hint: KeyPointHint>(&self, _hint: Hint) -> Vec<f64> {
        (0..self.names.len()).map(|i| i as f64 + 0.5).collect()
    }

    fn range(&self) -> Range<f64> {
        0.0..self.names.len().max(1) as f64
    }
}

impl ValueFormatter<f64> for CategoryAxis<'_> {
    fn format(_value: &f64) -> String {
        String::new()
    }

    fn format_ext(&self, value: &f64) -> String {
        let i = value.floor();
        if i >= 0.0 { self.names.get(i as usize).cloned().unwrap_or_default() } else { String::new() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_labelled_compactly() {
        assert_eq!(format_value(12.0), "12");
        assert_eq!(format_value(70.03), "70.03");
        assert_eq!(format_value(66.8), "66.8");
        assert_eq!(format_value(0.001234), "1.23e-3");
    }

    #[test]
    fn bars_fill_their_category_slot_from_zero() {
        let chart = BarChart::new("t", "y", vec!["a".into(), "b".into()])
            .with_group("g0", vec![2.0, -1.0])
            .with_group("g1", vec![f64::NAN, 4.0]);
        let r = chart.check(Path::new("x.svg")).unwrap();
        assert_eq!((r.x0, r.x1), (0.0, 2.0));
        assert!(r.y0 < -1.0 && r.y1 > 4.0);
        let bars: Vec<_> = chart.bars(r).collect();
        // The NaN bar is left out.
        assert_eq!(bars.len(), 3);
        let (j, c, v, b) = bars[0];
        assert_eq!((j, c, v), (0, 0, 2.0));
        assert!(b.x0 > 0.1 && b.x1 < 0.5 && b.y0 == 0.0 && b.y1 == 2.0);
        let (_, c, _, b) = bars[1];
        assert_eq!(c, 1);
        assert!(b.y0 == -1.0 && b.y1 == 0.0);
        let (j, _, _, b) = bars[2];
        assert_eq!(j, 1);
        assert!(b.x0 > 1.5 && b.x1 < 1.9);
    }

    #[test]
    fn bars_are_clipped_to_a_fixed_range() {
        let chart = BarChart::new("t", "y", vec!["a".into()]).with_group("g", vec![150.0]).with_y_range(50.0, 100.0);
        let r = chart.check(Path::new("x.svg")).unwrap();
        let bars: Vec<_> = chart.bars(r).collect();
        assert_eq!((bars[0].3.y0, bars[0].3.y1), (50.0, 100.0));
    }
}
