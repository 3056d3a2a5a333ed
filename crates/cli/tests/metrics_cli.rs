//! End-to-end tests of `mapkeeper metrics`, `mapkeeper render` and `mapkeeper map`, run as the
//! real binary on maps and logs written into a temporary folder.
// Helpers outside `#[test]` functions unwrap too: a failure is a test failure.
#![allow(clippy::unwrap_used)]

mod common;

use common::{mapkeeper, s, scratch};

use mapkeeper_grid::metrics::{MetricParams, map_metrics};
use mapkeeper_grid::{CellCoord, CellState, GridGeometry, Point2, Pose2, RayStop, cast_ray, map_io};
use mapkeeper_sensor::{LaserScan, LogHeader, LogRecord, LogWriter, TruePose};
use mapkeeper_testkit::rooms::four_by_three_in_unknown;
use std::path::Path;

#[test]
fn metrics_of_a_map_with_itself_is_100_in_json() {
    let dir = scratch("metrics-cli", "self");
    let a = dir.join("a.yaml");
    map_io::save_map(&four_by_three_in_unknown(Pose2::new(-1.0, -1.0, 0.0)), &a).unwrap();
    let out = mapkeeper(&["metrics", s(&a), s(&a), "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert_eq!(stdout.lines().count(), 1, "{stdout}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    let obj = v.as_object().unwrap();
    assert_eq!(obj.len(), 3);
    for key in ["cc", "ms", "opdf"] {
        assert_eq!(obj[key].as_f64(), Some(100.0), "{key}: {stdout}");
    }
    // The table form names all three and both OPDF directions.
    let out = mapkeeper(&["metrics", s(&a), s(&a)]);
    assert!(out.status.success());
    let table = String::from_utf8(out.stdout).unwrap();
    for word in ["CC", "MS", "OPDF", "A→B", "B→A"] {
        assert!(table.contains(word), "{word} missing: {table}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn mismatched_maps_fail_naming_both_unless_resampled() {
    let dir = scratch("metrics-cli", "mismatch");
    let a = dir.join("first_map.yaml");
    let b = dir.join("second_map.yaml");
    let truth = four_by_three_in_unknown(Pose2::new(-1.0, -1.0, 0.0));
    map_io::save_map(&truth, &a).unwrap();
    // The same room, on a grid shifted by 2 cells: same world content, different origin.
    let shifted_geometry = GridGeometry::new(120, 100, 0.05, Pose2::new(-1.1, -1.0, 0.0)).unwrap();
    let shifted = mapkeeper_grid::metrics::resample_onto(&truth, &shifted_geometry);
    map_io::save_map(&shifted, &b).unwrap();

    let out = mapkeeper(&["metrics", s(&a), s(&b), "--json"]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(stderr.starts_with("mapkeeper: error:"), "{stderr}");
    assert!(stderr.contains("first_map.yaml") && stderr.contains("second_map.yaml"), "{stderr}");
    assert!(out.stdout.is_empty());

    // With --resample, B goes back onto A's grid: every cell inside B matches, the 2 columns
    // outside B are unknown in the resampled B (unknown in A too), so the maps are identical.
    let out = mapkeeper(&["metrics", s(&a), s(&b), "--resample", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["cc"].as_f64(), Some(100.0), "{v}");
    assert_eq!(v["opdf"].as_f64(), Some(100.0), "{v}");

    // Bad parameters are refused as the command line is parsed (exit 2), naming the flag.
    let out = mapkeeper(&["metrics", s(&a), s(&a), "--unknown-value", "2"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--unknown-value"));
    // A missing file is named.
    let out = mapkeeper(&["metrics", s(&a), s(&dir.join("nope.yaml"))]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("nope.yaml"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Width, height, bit depth and colour type from a PNG's IHDR chunk (this crate does not
/// depend on a PNG decoder; the grid crate's tests decode the pixels).
fn png_header(path: &Path) -> (u32, u32, u8, u8) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "not a PNG");
    assert_eq!(&bytes[12..16], b"IHDR");
    let be = |i: usize| u32::from_be_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    assert!(bytes.ends_with(&[0, 0, 0, 0, b'I', b'E', b'N', b'D', 0xAE, 0x42, 0x60, 0x82]), "no IEND");
    (be(16), be(20), bytes[24], bytes[25])
}

#[test]
fn render_writes_a_png_and_a_diff() {
    let dir = scratch("metrics-cli", "render");
    let a = dir.join("a.yaml");
    let b = dir.join("b.yaml");
    let m = four_by_three_in_unknown(Pose2::IDENTITY);
    map_io::save_map(&m, &a).unwrap();
    let mut m2 = m.clone();
    m2.set(CellCoord::new(50, 50), CellState::Occupied); // added
    m2.set(CellCoord::new(20, 50), CellState::Free); // removed
    map_io::save_map(&m2, &b).unwrap();

    let png_path = dir.join("a.png");
    let out = mapkeeper(&["render", s(&a), "-o", s(&png_path), "--scale", "2"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // 8-bit RGB (colour type 2), twice the grid's size.
    assert_eq!(png_header(&png_path), (240, 200, 8, 2));
    // An existing output is refused without --force, as by every command, and replaced with it.
    let again = mapkeeper(&["render", s(&a), "-o", s(&png_path)]);
    assert!(!again.status.success() && String::from_utf8_lossy(&again.stderr).contains("--force"));
    let forced = mapkeeper(&["render", s(&a), "-o", s(&png_path), "--force"]);
    assert!(forced.status.success(), "{}", String::from_utf8_lossy(&forced.stderr));
    assert_eq!(png_header(&png_path), (120, 100, 8, 2));

    let diff_path = dir.join("diff.png");
    let out = mapkeeper(&["render", s(&a), "--diff", s(&b), "-o", s(&diff_path)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(png_header(&diff_path), (120, 100, 8, 2));
    // No temporary file is left beside the outputs.
    let mut names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    names.sort();
    assert_eq!(names, ["a.pgm", "a.png", "a.yaml", "b.pgm", "b.yaml", "diff.png"]);

    // A diff of maps of different geometry names both files.
    let c = dir.join("c.yaml");
    map_io::save_map(&four_by_three_in_unknown(Pose2::new(1.0, 0.0, 0.0)), &c).unwrap();
    let out = mapkeeper(&["render", s(&a), "--diff", s(&c), "-o", s(&diff_path)]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("a.yaml") && stderr.contains("c.yaml"), "{stderr}");

    let out = mapkeeper(&["render", s(&a), "-o", s(&png_path), "--scale", "0"]);
    assert_eq!(out.status.code(), Some(2), "clap refuses scale 0");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn map_from_a_logged_room_run_matches_the_room() {
    let dir = scratch("metrics-cli", "map");
    let truth_map = four_by_three_in_unknown(Pose2::new(-1.0, -1.0, 0.0));
    // Drive along a line inside the room; the lidar is mounted 0.2 m ahead, turned by 0.1 rad.
    let mount = Pose2::new(0.2, 0.0, 0.1);
    let beams = 360usize;
    let inc = std::f64::consts::TAU / beams as f64;
    let mut w = LogWriter::create(&dir.join("log.jsonl"), &LogHeader::new(serde_json::Map::new())).unwrap();
    // Motion linear in time (0.25 m, 0.05 m and 0.3 rad per 0.1 s), so interpolating the truth
    // records is exact; scans fall halfway between truth records.
    let robot_at = |s: f64| Pose2::new(0.8 + 0.25 * s, 1.2 + 0.05 * s, 0.3 * s);
    for k in 0..10u64 {
        let robot = robot_at(k as f64);
        w.write(&LogRecord::Truth(TruePose { stamp_ns: k * 100_000_000, pose_in_map: robot })).unwrap();
        if k == 9 {
            break;
        }
        let t_scan = k * 100_000_000 + 50_000_000;
        let lidar = robot_at(k as f64 + 0.5).compose(&mount);
        let ranges_m = (0..beams)
            .map(|i| {
                let a = lidar.yaw - std::f64::consts::PI + i as f64 * inc;
                let hit = cast_ray(&truth_map, lidar.position(), a, 10.0, false);
                assert_eq!(hit.stop, RayStop::Occupied);
                // One in ten of the beams longer than 1.5 m reports no return; run with
                // --no-return-clear-m 1 they clear 1 m, which stays inside the room.
                if i % 10 == 3 && hit.range_m > 1.5 {
                    return f32::INFINITY;
                }
                (hit.range_m + 1e-3) as f32
            })
            .collect();
        let scan = LaserScan {
            stamp_ns: t_scan,
            lidar_id: 0,
            lidar_in_robot: mount,
            angle_min_rad: -std::f64::consts::PI,
            angle_increment_rad: inc,
            range_min_m: 0.05,
            range_max_m: 30.0,
            ranges_m,
            sweep: None,
        };
        w.write(&LogRecord::Scan(scan)).unwrap();
    }
    w.finish().unwrap();

    let like = dir.join("truth.yaml");
    map_io::save_map(&truth_map, &like).unwrap();
    let out_yaml = dir.join("m1.yaml");
    let out =
        mapkeeper(&["map", "--log", s(&dir), "--out", s(&out_yaml), "--like", s(&like), "--no-return-clear-m", "1"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let built = map_io::load_map(&out_yaml).unwrap();
    let m = map_metrics(&built, &truth_map, &MetricParams::default()).unwrap();
    assert!(m.cc > 85.0 && m.ms > 85.0 && m.opdf > 95.0, "{m:?}");
    // Outside the room nothing was seen.
    assert_eq!(built.get_world(Point2::new(-0.5, -0.5)), Some(CellState::Unknown));
    assert_eq!(built.get_world(Point2::new(2.0, 1.5)), Some(CellState::Free));

    // Without --like the grid fits the observed area (walls at 0..4 m, 0..3 m) plus 1 m.
    let fitted = dir.join("fitted.yaml");
    let out = mapkeeper(&[
        "map",
        "--log",
        s(&dir.join("log.jsonl")),
        "--out",
        s(&fitted),
        "--resolution",
        "0.1",
        "--no-return-clear-m",
        "1",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let g = *map_io::load_map(&fitted).unwrap().geometry();
    assert_eq!(g.resolution_m(), 0.1);
    assert!((g.origin().x - -1.0).abs() < 0.11 && (g.origin().y - -1.0).abs() < 0.11, "{:?}", g.origin());
    let (ew, eh) = g.extent_m();
    assert!((ew - 6.0).abs() < 0.25 && (eh - 5.0).abs() < 0.25, "{ew} × {eh}");

    // A log without truth records is an error naming the file.
    let empty = dir.join("empty.jsonl");
    LogWriter::create(&empty, &LogHeader::new(serde_json::Map::new())).unwrap().finish().unwrap();
    let out = mapkeeper(&["map", "--log", s(&empty), "--out", s(&dir.join("x.yaml"))]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("empty.jsonl"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn help_is_complete() {
    for (cmd, flags) in [
        ("metrics", &["--resample", "--unknown-value", "--opdf-window-m", "--json"][..]),
        ("render", &["--out", "--diff", "--scale"][..]),
        ("map", &["--log", "--out", "--resolution", "--params", "--like", "--no-return-clear-m"][..]),
    ] {
        let out = mapkeeper(&[cmd, "--help"]);
        assert!(out.status.success());
        let help = String::from_utf8(out.stdout).unwrap();
        for f in flags {
            assert!(help.contains(f), "{cmd} --help lacks {f}");
        }
    }
}
