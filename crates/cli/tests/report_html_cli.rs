//! `report.html` and `--save-maps`, end to end on tiny validations: the page is parsed as a
//! browser would (html5ever, through `scraper`), every image is embedded and decodes, every
//! link resolves (anchors to an element of the page, files to a file of the folder), every
//! figure and every saved world is on it, and the maps `--save-maps` asks for, and only those,
//! are written.
#![allow(clippy::unwrap_used)]

mod common;

use base64::Engine as _;
use common::{mapkeeper, s, scratch, validate_args};
use scraper::{Html, Selector};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The figures every validation report shows (stems under `plots/`).
const FIGURES: usize = 9;

fn validate(dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let out = dir.join(name);
    let mut args = vec!["validate", "--route-length", "10", "--no-timing", "--out", s(&out)];
    args.extend_from_slice(extra);
    let args = validate_args(&args);
    let r = mapkeeper(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(r.status.success(), "validate {extra:?} failed: {}", String::from_utf8_lossy(&r.stderr));
    out
}

fn sel(css: &str) -> Selector {
    Selector::parse(css).unwrap()
}

/// Checks the page in `dir/report.html` and returns (number of images, the stepper worlds per
/// stepper id).
fn check_page(dir: &Path) -> (usize, Vec<(String, Vec<usize>)>) {
    let text = std::fs::read_to_string(dir.join("report.html")).unwrap();
    assert!(text.starts_with("<!DOCTYPE html>"), "not an HTML5 page");
    let page = Html::parse_document(&text);
    assert!(page.errors.is_empty(), "parse errors: {:?}", page.errors);
    let ids: BTreeSet<&str> = page.select(&sel("[id]")).filter_map(|e| e.value().attr("id")).collect();
    // No external resource: no script or style from elsewhere.
    assert_eq!(page.select(&sel("script[src], link[rel=stylesheet]")).count(), 0);
    let mut images = 0;
    for img in page.select(&sel("img")) {
        let src = img.value().attr("src").unwrap();
        let (head, data) = src.split_once(";base64,").unwrap_or_else(|| panic!("image not embedded: {src:.80}"));
        let bytes = base64::engine::general_purpose::STANDARD.decode(data).unwrap();
        match head {
            "data:image/png" => assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "not a PNG"),
            "data:image/svg+xml" => assert!(String::from_utf8(bytes).unwrap().contains("<svg"), "not an SVG"),
            other => panic!("image of type {other}"),
        }
        assert!(img.value().attr("alt").is_some_and(|a| !a.is_empty()), "an image without alt text");
        images += 1;
    }
    for a in page.select(&sel("a[href]")) {
        let href = a.value().attr("href").unwrap();
        match href.strip_prefix('#') {
            Some(id) => assert!(ids.contains(id), "link to #{id}, which the page lacks"),
            None => assert!(dir.join(href).is_file(), "link to {href}, which the folder lacks"),
        }
    }
    let steppers = page
        .select(&sel("section.stepper"))
        .map(|sec| {
            let worlds: Vec<usize> = sec
                .select(&sel("figure[data-world]"))
                .map(|f| f.value().attr("data-world").unwrap().parse().unwrap())
                .collect();
            let shown = sec.select(&sel("figure:not([hidden])")).count();
            assert_eq!(shown, 1, "a stepper shows one world at a time");
            let range = sec.select(&sel("input[type=range]")).next().unwrap();
            assert_eq!(range.value().attr("max").unwrap(), (worlds.len() - 1).to_string());
            (sec.value().attr("id").unwrap().to_string(), worlds)
        })
        .collect();
    // The results table and the paper's claims with their verdicts are on the page.
    assert!(page.select(&sel("table")).count() >= 2);
    assert!(text.contains("The paper’s claims beside this run") || text.contains("The paper's claims beside this run"));
    assert!(text.contains("<strong>reproduced</strong>") || text.contains("<strong>not reproduced</strong>"));
    (images, steppers)
}

#[test]
fn report_html_is_one_self_contained_page_with_every_figure_and_saved_world() {
    let dir = scratch("report-html", "pages");
    // The default sweep (paper, mapkeeper), two seeds, every world saved (3 worlds: W_2, W_3).
    let sweep = validate(&dir, "sweep", &["--presets", "paper,mapkeeper", "--worlds", "3", "--seeds", "2"]);
    for preset in ["paper", "mapkeeper"] {
        let (images, steppers) = check_page(&sweep.join(preset));
        assert_eq!(images, FIGURES + 2 * 3, "{preset}: the figures and 2 seeds × 3 worlds");
        let want = vec![("worlds-seed-1".to_string(), vec![1, 2, 3]), ("worlds-seed-2".to_string(), vec![1, 2, 3])];
        assert_eq!(steppers, want, "{preset}");
    }
    // The sweep's page holds both presets' reports and steppers, ids kept apart.
    let (images, steppers) = check_page(&sweep);
    assert_eq!(images, 2 * (FIGURES + 2 * 3));
    let ids: Vec<&str> = steppers.iter().map(|(id, _)| id.as_str()).collect();
    assert_eq!(
        ids,
        ["paper-worlds-seed-1", "paper-worlds-seed-2", "mapkeeper-worlds-seed-1", "mapkeeper-worlds-seed-2"]
    );
    // report.md links the saved worlds' files.
    let md = std::fs::read_to_string(sweep.join("paper/report.md")).unwrap();
    assert!(md.contains("## Saved worlds") && md.contains("[errors](seed-2/maps/E_003.png)"), "{md}");
    // Same flags, same page, byte for byte.
    let again = validate(&dir, "sweep-again", &["--presets", "paper,mapkeeper", "--worlds", "3", "--seeds", "2"]);
    assert!(std::fs::read(again.join("report.html")).unwrap() == std::fs::read(sweep.join("report.html")).unwrap());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn save_maps_keeps_the_worlds_asked_for_and_refuses_others() {
    let dir = scratch("report-html", "save-maps");
    let maps = |out: &Path| -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(out.join("seed-1/maps"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".png"))
            .collect();
        v.sort();
        v
    };
    // Five worlds: by default W_2 and the last; a list; all.
    let default = validate(&dir, "default", &["--worlds", "5"]);
    assert_eq!(maps(&default), ["E_001.png", "E_002.png", "E_005.png"]);
    let list = validate(&dir, "list", &["--worlds", "5", "--save-maps", "4,3,4"]);
    assert_eq!(maps(&list), ["E_001.png", "E_003.png", "E_004.png"]);
    assert!(list.join("seed-1/maps/M_004.yaml").is_file() && list.join("seed-1/maps/G_003.pgm").is_file());
    assert!(list.join("seed-1/trajectories/W_003_true.tum").is_file());
    let (_, steppers) = check_page(&list);
    assert_eq!(steppers, [("worlds-seed-1".to_string(), vec![1, 3, 4])]);
    let all = validate(&dir, "all", &["--worlds", "5", "--save-maps", "all"]);
    assert_eq!(maps(&all), ["E_001.png", "E_002.png", "E_003.png", "E_004.png", "E_005.png"]);
    // The maps a world keeps do not change its results.
    let summary = |d: &Path| -> serde_json::Value {
        let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(d.join("summary.json")).unwrap()).unwrap();
        v["params"].as_object_mut().unwrap().remove("saved_worlds");
        v
    };
    assert_eq!(summary(&default), summary(&all));
    for (value, want) in [
        ("6", "--save-maps: world 6 is beyond --worlds 5"),
        ("1", "W_2 or later"),
        ("2,x", "neither `all` nor a world number"),
        ("", "neither `all` nor a world number"),
    ] {
        let out = dir.join("refused");
        let r = mapkeeper(&["validate", "--worlds", "5", "--save-maps", value, "--out", s(&out)]);
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(!r.status.success() && err.contains(want), "--save-maps {value:?}: {err}");
        assert!(!out.exists(), "--save-maps {value:?} wrote {}", out.display());
    }
    let _ = std::fs::remove_dir_all(&dir);
}
