//! End-to-end: each chart kind written as SVG and PNG, read back and checked; degenerate
//! input (NaN, inf, empty series, no categories) never panics; bad requests give errors that
//! name the file.
//!
//! Determinism contract: the same chart value written twice gives byte-identical SVG and PNG
//! files (no clock, no randomness, no unordered iteration reaches the output).
#![allow(clippy::unwrap_used)] // helpers outside #[test] functions unwrap too

use std::path::{Path, PathBuf};

use mapkeeper_plot::{BarChart, LineChart, PALETTE, PlotError, Series};

/// A fresh, empty folder for one test.
fn temp_dir(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mapkeeper-plot-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Decodes an RGB(A) PNG: (width, height, bytes per pixel, pixels).
fn decode_png(path: &Path) -> (u32, u32, usize, Vec<u8>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    (info.width, info.height, info.color_type.samples(), buf)
}

/// The contents of the SVG's `<text>` elements, trimmed.
fn svg_texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| Some(t.split_once('>')?.1.split_once("</text>")?.0.trim().to_owned()))
        .collect()
}

/// The SVG's `<text>` elements: (attributes, trimmed contents).
fn svg_text_elements(svg: &str) -> Vec<(String, String)> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let (attrs, rest) = t.split_once('>')?;
            Some((attrs.to_owned(), rest.split_once("</text>")?.0.trim().to_owned()))
        })
        .collect()
}

/// The SVG's `<polyline>` elements: (attributes, points).
fn svg_polylines(svg: &str) -> Vec<(String, Vec<(f64, f64)>)> {
    svg.split("<polyline")
        .skip(1)
        .filter_map(|p| {
            let attrs = p.split_once("/>")?.0;
            let points = attrs.split_once("points=\"")?.1.split_once('"')?.0;
            let points = points
                .split_whitespace()
                .map(|xy| {
                    let (x, y) = xy.split_once(',')?;
                    Some((x.parse().ok()?, y.parse().ok()?))
                })
                .collect::<Option<Vec<(f64, f64)>>>()?;
            Some((attrs.to_owned(), points))
        })
        .collect()
}

/// A numeric attribute of an element's attribute text.
fn svg_attr(attrs: &str, name: &str) -> Option<f64> {
    attrs.split_once(&format!(" {name}=\""))?.1.split_once('"')?.0.parse().ok()
}

fn x_span(points: &[(f64, f64)]) -> f64 {
    let xs = points.iter().map(|p| p.0);
    xs.clone().fold(f64::NEG_INFINITY, f64::max) - xs.fold(f64::INFINITY, f64::min)
}

fn count_pixels(png: &(u32, u32, usize, Vec<u8>), rgb: [u8; 3]) -> usize {
    png.3.chunks_exact(png.2).filter(|p| p[..3] == rgb).count()
}

fn non_white_pixels(png: &(u32, u32, usize, Vec<u8>)) -> usize {
    png.3.chunks_exact(png.2).filter(|p| p[..3] != [255, 255, 255]).count()
}

/// Paper Fig. 24-like: two metrics over worlds 2..100, one with a band.
fn metric_chart() -> LineChart {
    let m1: Vec<(f64, f64)> = (2..=100).map(|i| (f64::from(i), 90.0 - 0.4 * f64::from(i))).collect();
    let mi: Vec<(f64, f64)> = (2..=100).map(|i| (f64::from(i), 96.0 - 0.01 * f64::from(i))).collect();
    let band = mi.iter().map(|&(x, y)| (x, y - 2.0, y + 2.0)).collect();
    LineChart::new("Occupied picture-distance function", "world i", "OPDF (%)")
        .with_series(Series::new("M_1 / G_i", m1))
        .with_series(Series::new("M_i / G_i", mi).with_band(band))
}

fn verdict_chart() -> BarChart {
    BarChart::new("Localisation-check verdicts", "scans", vec!["paper".into(), "reference".into(), "strict".into()])
        .with_group("Update", vec![950.0, 980.0, 900.0])
        .with_group("Suspend", vec![40.0, 15.0, 95.0])
        .with_group("Lost", vec![10.0, 5.0, 5.0])
}

#[test]
fn line_chart_svg_holds_title_axes_and_series_names() {
    let dir = temp_dir("line-svg");
    let path = dir.join("opdf.svg");
    metric_chart().write_svg(&path).unwrap();
    let svg = std::fs::read_to_string(&path).unwrap();
    assert!(svg.starts_with("<svg"), "not an SVG document: {}", &svg[..svg.len().min(80)]);
    assert!(svg.trim_end().ends_with("</svg>"));
    for text in ["Occupied picture-distance function", "world i", "OPDF (%)", "M_1 / G_i", "M_i / G_i"] {
        assert!(svg.contains(text), "SVG lacks {text:?}");
    }
    // The first two palette colours are used.
    for [r, g, b] in &PALETTE[..2] {
        let hex = format!("#{r:02X}{g:02X}{b:02X}");
        assert!(svg.to_uppercase().contains(&hex), "SVG lacks colour {hex}");
    }
    // Atomic write: only the final file is left in the folder.
    let names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names, vec![std::ffi::OsString::from("opdf.svg")]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn line_chart_png_has_the_requested_size_and_coloured_lines() {
    let dir = temp_dir("line-png");
    let path = dir.join("opdf.png");
    metric_chart().write_png(&path, 640, 400).unwrap();
    let png = decode_png(&path);
    assert_eq!((png.0, png.1), (640, 400));
    assert!(non_white_pixels(&png) > 5_000, "too few drawn pixels: {}", non_white_pixels(&png));
    // Both series' colours appear at full strength (line pixels, not only the band).
    assert!(count_pixels(&png, PALETTE[0]) > 200);
    assert!(count_pixels(&png, PALETTE[1]) > 200);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bar_chart_svg_and_png() {
    let dir = temp_dir("bar");
    let chart = verdict_chart();
    chart.write_svg(&dir.join("verdicts.svg")).unwrap();
    let svg = std::fs::read_to_string(dir.join("verdicts.svg")).unwrap();
    for text in ["Localisation-check verdicts", "scans", "paper", "reference", "strict", "Update", "Suspend", "Lost"] {
        assert!(svg.contains(text), "SVG lacks {text:?}");
    }
    // Bars carry their values.
    let texts = svg_texts(&svg);
    assert!(texts.iter().any(|t| t == "950") && texts.iter().any(|t| t == "95"), "{texts:?}");

    chart.write_png(&dir.join("verdicts.png"), 900, 600).unwrap();
    let png = decode_png(&dir.join("verdicts.png"));
    assert_eq!((png.0, png.1), (900, 600));
    // Three groups, three colours, each bar area well visible.
    for colour in &PALETTE[..3] {
        assert!(count_pixels(&png, *colour) > 100, "colour {colour:?} missing");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn table1_style_chart_with_a_fixed_range() {
    let dir = temp_dir("table1");
    let chart = BarChart::new("Table 1: maps against G_2", "score (%)", vec!["CC".into(), "MS".into(), "OPDF".into()])
        .with_group("always update", vec![66.86, 55.11, 90.40])
        .with_group("localisation check", vec![70.03, 61.24, 95.87])
        .with_y_range(0.0, 100.0);
    chart.write_svg(&dir.join("t1.svg")).unwrap();
    chart.write_png(&dir.join("t1.png"), 800, 500).unwrap();
    let svg = std::fs::read_to_string(dir.join("t1.svg")).unwrap();
    assert!(svg_texts(&svg).iter().any(|t| t == "70.03") && svg.contains("always update"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn non_finite_values_are_skipped_without_panic() {
    let dir = temp_dir("nan");
    let points =
        vec![(1.0, 1.0), (2.0, f64::NAN), (3.0, 3.0), (f64::INFINITY, 2.0), (5.0, f64::NEG_INFINITY), (6.0, 2.0)];
    let band = vec![(1.0, 0.5, 1.5), (2.0, f64::NAN, 2.0), (3.0, 2.0, 4.0), (4.0, 2.0, 4.0)];
    let chart = LineChart::new("gaps", "x", "y")
        .with_series(Series::new("with gaps", points).with_band(band))
        .with_series(Series::mean_std("all NaN", &[(f64::NAN, f64::NAN, f64::NAN)]));
    chart.write_svg(&dir.join("gaps.svg")).unwrap();
    chart.write_png(&dir.join("gaps.png"), 400, 300).unwrap();
    let svg = std::fs::read_to_string(dir.join("gaps.svg")).unwrap();
    assert!(svg.contains("with gaps") && svg.contains("all NaN"));
    assert!(!svg.contains("NaN\"") && !svg.contains("inf\""), "a non-finite coordinate reached the SVG");

    let bars = BarChart::new("nan bars", "v", vec!["a".into(), "b".into()])
        .with_group("g", vec![f64::NAN, f64::INFINITY])
        .with_group("h", vec![1.0, f64::NEG_INFINITY]);
    bars.write_svg(&dir.join("bars.svg")).unwrap();
    bars.write_png(&dir.join("bars.png"), 400, 300).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn empty_charts_are_written_with_a_note() {
    let dir = temp_dir("empty");
    let charts = [
        LineChart::new("nothing", "x", "y"),
        LineChart::new("empty series", "x", "y").with_series(Series::new("none yet", vec![])),
        LineChart::new("fixed range, no data", "x", "y").with_y_range(0.0, 100.0),
    ];
    for (i, chart) in charts.iter().enumerate() {
        let svg_path = dir.join(format!("line{i}.svg"));
        chart.write_svg(&svg_path).unwrap();
        chart.write_png(&dir.join(format!("line{i}.png")), 300, 200).unwrap();
        let svg = std::fs::read_to_string(&svg_path).unwrap();
        assert!(svg.contains("no data") && svg.contains(&chart.title));
    }
    let bars = [
        BarChart::new("no categories", "v", vec![]),
        BarChart::new("no groups", "v", vec!["a".into()]),
        BarChart::new("no categories, a group", "v", vec![]).with_group("g", vec![]),
    ];
    for (i, chart) in bars.iter().enumerate() {
        let svg_path = dir.join(format!("bar{i}.svg"));
        chart.write_svg(&svg_path).unwrap();
        chart.write_png(&dir.join(format!("bar{i}.png")), 300, 200).unwrap();
        assert!(std::fs::read_to_string(&svg_path).unwrap().contains("no data"));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_single_point_and_a_constant_series_get_a_usable_range() {
    let dir = temp_dir("degenerate");
    let chart = LineChart::new("one point", "x", "y").with_series(Series::new("p", vec![(3.0, 7.0)]));
    chart.write_png(&dir.join("one.png"), 300, 200).unwrap();
    let png = decode_png(&dir.join("one.png"));
    assert!(count_pixels(&png, PALETTE[0]) > 0, "the single point's marker is drawn");
    let flat = LineChart::new("flat", "x", "y").with_series(Series::new("c", vec![(0.0, 5.0), (10.0, 5.0)]));
    flat.write_svg(&dir.join("flat.svg")).unwrap();
    let svg = std::fs::read_to_string(dir.join("flat.svg")).unwrap();
    // The series is drawn: a horizontal polyline in its colour across the plot (the longest of
    // that colour; the legend's sample is a short one).
    let [r, g, b] = PALETTE[0];
    let stroke = format!("STROKE=\"#{r:02X}{g:02X}{b:02X}\"");
    let line = svg_polylines(&svg)
        .into_iter()
        .filter(|(attrs, _)| attrs.to_uppercase().contains(&stroke))
        .map(|(_, points)| points)
        .max_by(|a, b| x_span(a).total_cmp(&x_span(b)))
        .expect("a polyline in the series' colour");
    assert!(x_span(&line) > 400.0, "the series' line is too short: {line:?}");
    let line_y = line[0].1;
    assert!(line.iter().all(|p| p.1 == line_y), "a constant series is a flat line: {line:?}");
    // The y axis has a usable range: at least two distinct tick labels, below and above the
    // constant 5, with the line drawn between them (not on the plot's edge).
    let ticks: Vec<(f64, f64)> = svg_text_elements(&svg)
        .into_iter()
        .filter(|(attrs, _)| attrs.contains("text-anchor=\"end\""))
        .filter_map(|(attrs, text)| Some((text.parse::<f64>().ok()?, svg_attr(&attrs, "y")?)))
        .collect();
    let (lo, hi) = (
        ticks.iter().copied().min_by(|a, b| a.0.total_cmp(&b.0)).expect("y tick labels"),
        ticks.iter().copied().max_by(|a, b| a.0.total_cmp(&b.0)).expect("y tick labels"),
    );
    assert!(lo.0 < 5.0 && 5.0 < hi.0, "y ticks {ticks:?} do not bracket the constant 5");
    // SVG y grows downwards: the lowest value's label is at the largest y.
    assert!(hi.1 < line_y && line_y < lo.1, "line at y = {line_y}, ticks {ticks:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn same_input_gives_byte_identical_files() {
    let dir = temp_dir("determinism");
    let line = metric_chart();
    let bars = verdict_chart();
    for round in 0..2 {
        line.write_svg(&dir.join(format!("line{round}.svg"))).unwrap();
        line.write_png(&dir.join(format!("line{round}.png")), 800, 500).unwrap();
        bars.write_svg(&dir.join(format!("bars{round}.svg"))).unwrap();
        bars.write_png(&dir.join(format!("bars{round}.png")), 800, 500).unwrap();
    }
    for name in ["line", "bars"] {
        for ext in ["svg", "png"] {
            let a = std::fs::read(dir.join(format!("{name}0.{ext}"))).unwrap();
            let b = std::fs::read(dir.join(format!("{name}1.{ext}"))).unwrap();
            assert!(!a.is_empty());
            assert!(a == b, "{name}.{ext} differs between two writes");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn overwriting_replaces_the_file() {
    let dir = temp_dir("overwrite");
    let path = dir.join("chart.svg");
    LineChart::new("first", "x", "y").write_svg(&path).unwrap();
    LineChart::new("second", "x", "y").write_svg(&path).unwrap();
    let svg = std::fs::read_to_string(&path).unwrap();
    assert!(svg.contains("second") && !svg.contains("first"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn text_is_escaped_in_svg() {
    let dir = temp_dir("escape");
    let path = dir.join("e.svg");
    LineChart::new("a < b & c", "x", "y").with_series(Series::new("<M_1>", vec![(0.0, 1.0)])).write_svg(&path).unwrap();
    let svg = std::fs::read_to_string(&path).unwrap();
    assert!(svg.contains("a &lt; b &amp; c") && svg.contains("&lt;M_1&gt;"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_requests_are_errors_naming_the_file() {
    let dir = temp_dir("errors");
    let path = dir.join("bad.png");
    let err = metric_chart().write_png(&path, 10, 500).unwrap_err();
    assert!(matches!(err, PlotError::InvalidSize { width: 10, height: 500, .. }), "{err}");
    assert!(err.to_string().contains("bad.png"));

    let err = metric_chart().with_y_range(5.0, 5.0).write_svg(&path).unwrap_err();
    assert!(matches!(err, PlotError::InvalidRange { axis: "y", .. }), "{err}");
    let err = metric_chart().with_y_range(f64::NAN, 1.0).write_png(&path, 400, 300).unwrap_err();
    assert!(matches!(err, PlotError::InvalidRange { .. }), "{err}");

    let err = BarChart::new("t", "y", vec!["a".into(), "b".into()]).with_group("short", vec![1.0]).write_svg(&path);
    let err = err.unwrap_err();
    assert!(matches!(&err, PlotError::GroupLength { group, expected: 2, got: 1, .. } if group == "short"), "{err}");
    assert!(err.to_string().contains("bad.png") && err.to_string().contains("short"));

    let missing = dir.join("no-such-folder").join("x.svg");
    let err = metric_chart().write_svg(&missing).unwrap_err();
    assert!(matches!(err, PlotError::Io { .. }) && err.to_string().contains("x.svg"), "{err}");

    // Data spanning more than f64 can represent.
    let huge = LineChart::new("huge", "x", "y").with_series(Series::new("s", vec![(0.0, -1e308), (1.0, 1e308)]));
    assert!(matches!(huge.write_svg(&path).unwrap_err(), PlotError::InvalidRange { .. }));

    // Nothing was left behind.
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn integer_x_axis_has_integer_ticks_only() {
    let dir = temp_dir("integer-x");
    let path = dir.join("two-worlds.svg");
    LineChart::new("Two worlds", "world i", "error (m)")
        .with_series(Series::new("a", vec![(2.0, 0.5), (3.0, 0.7)]))
        .with_integer_x()
        .write_svg(&path)
        .unwrap();
    let texts = svg_texts(&std::fs::read_to_string(&path).unwrap());
    assert!(texts.iter().any(|t| t == "2") && texts.iter().any(|t| t == "3"), "ticks: {texts:?}");
    assert!(!texts.iter().any(|t| t.starts_with("2.")), "a fractional world tick: {texts:?}");
    // Without the option, plotters puts ticks between the worlds.
    LineChart::new("Two worlds", "world i", "error (m)")
        .with_series(Series::new("a", vec![(2.0, 0.5), (3.0, 0.7)]))
        .write_svg(&path)
        .unwrap();
    let texts = svg_texts(&std::fs::read_to_string(&path).unwrap());
    assert!(texts.iter().any(|t| t.starts_with("2.")), "ticks: {texts:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}
