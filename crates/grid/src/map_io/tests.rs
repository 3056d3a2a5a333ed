//! Unit tests of `map_io`.

use super::*;
use crate::grid::CellCoord;
use proptest::prelude::*;

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("mapkeeper-map-io-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

const YAML: &str =
    "image: m.pgm\nresolution: 0.5\norigin: [-1.0, -2.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";

#[test]
fn save_load_round_trip_and_flip() {
    let d = tmpdir("rt");
    let g = GridGeometry::new(4, 3, 0.05, Pose2::new(-7.0, -10.5, 0.0)).unwrap();
    let mut m = OccupancyGrid::filled(g, CellState::Free);
    m.set(CellCoord::new(0, 0), CellState::Occupied);
    m.set(CellCoord::new(3, 2), CellState::Unknown);
    let y = d.join("map.yaml");
    save_map(&m, &y).unwrap();
    let pgm = std::fs::read(d.join("map.pgm")).unwrap();
    // Header, then the top row first: cell (3, 2) is the last pixel of the first image row.
    assert!(pgm.starts_with(b"P5\n4 3\n255\n"));
    let raster = &pgm[b"P5\n4 3\n255\n".len()..];
    assert_eq!(raster[3], PGM_UNKNOWN);
    assert_eq!(raster[8], PGM_OCCUPIED);
    assert_eq!(raster[0], PGM_FREE);
    assert_eq!(load_map(&y).unwrap(), m);
    assert!(!d.join(".map.yaml.tmp").exists() && !d.join(".map.pgm.tmp").exists());
}

#[test]
fn thresholds_follow_map_server() {
    let d = tmpdir("thr");
    // 0 → p = 1 occupied; 254 → free; 205 → p = 0.196078 > 0.196: unknown; 89 → p = 0.651 occupied;
    // 90 → p = 0.647 unknown; 206 → p = 0.192 free; 206 with negate → p = 0.81 occupied.
    std::fs::write(d.join("m.pgm"), b"P2\n# a comment\n6 1\n255\n0 254 205 89 90 206\n").unwrap();
    std::fs::write(d.join("m.yaml"), YAML).unwrap();
    let m = load_map(&d.join("m.yaml")).unwrap();
    use CellState::*;
    assert_eq!(m.cells(), &[Occupied, Free, Unknown, Occupied, Unknown, Free]);
    std::fs::write(d.join("n.yaml"), YAML.replace("negate: 0", "negate: 1")).unwrap();
    let n = load_map(&d.join("n.yaml")).unwrap();
    assert_eq!(n.cells(), &[Free, Occupied, Occupied, Unknown, Unknown, Occupied]);
    std::fs::write(d.join("r.yaml"), format!("{YAML}mode: raw\n")).unwrap();
    std::fs::write(d.join("m.pgm"), b"P2\n3 1\n255\n0 100 255\n").unwrap();
    let r = load_map(&d.join("r.yaml")).unwrap();
    assert_eq!(r.cells(), &[Free, Occupied, Unknown]);
}

#[test]
fn sixteen_bit_pgm_and_png() {
    let d = tmpdir("img");
    // 16-bit P5: 65535 → 255 (free), 0 → occupied.
    let mut pgm = b"P5 2 1 65535\n".to_vec();
    pgm.extend([0xff, 0xff, 0x00, 0x00]);
    std::fs::write(d.join("m.pgm"), pgm).unwrap();
    std::fs::write(d.join("m.yaml"), YAML).unwrap();
    assert_eq!(load_map(&d.join("m.yaml")).unwrap().cells(), &[CellState::Free, CellState::Occupied]);
    // RGB PNG 2 × 2: top row white, black; bottom row grey (205), white.
    let mut png_bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut png_bytes, 2, 2);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().unwrap();
        w.write_image_data(&[255, 255, 255, 0, 0, 0, 205, 205, 205, 254, 254, 254]).unwrap();
    }
    std::fs::write(d.join("p.png"), png_bytes).unwrap();
    std::fs::write(d.join("p.yaml"), YAML.replace("m.pgm", "p.png")).unwrap();
    let m = load_map(&d.join("p.yaml")).unwrap();
    use CellState::*;
    // Grid row 0 is the image's bottom row.
    assert_eq!(m.cells(), &[Unknown, Free, Free, Occupied]);
}

#[test]
fn yaml_forms_real_files_use() {
    let p = Path::new("x.yaml");
    let text = "# CREATOR: map_saver\nimage: \"map #1.pgm\"  # the image\nresolution: 0.050000\norigin:\n  - -7.0\n  - -10.5\n  - 0\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n";
    let y = parse_map_yaml(text, p).unwrap();
    assert_eq!(y.image, "map #1.pgm");
    assert_eq!(y.origin, Pose2::new(-7.0, -10.5, 0.0));
    assert_eq!(y.mode, MapMode::Trinary);
}

#[test]
fn yaml_errors_name_file_and_problem() {
    let p = Path::new("bad.yaml");
    let cases = [
        (YAML.replace("resolution: 0.5", "resolution: 0"), "resolution"),
        (YAML.replace("resolution: 0.5", "resolution: -1"), "resolution"),
        (YAML.replace("resolution: 0.5", "resolution: abc"), "resolution"),
        // Finer than 5 mm: every per-cell loop (scan matching, free discs) would be unbounded.
        (
            YAML.replace("resolution: 0.5", "resolution: 1e-9"),
            "bad.yaml:2: key 'resolution': must lie in [0.005, 10] m per cell, found 0.000000001",
        ),
        (YAML.replace("negate: 0", "negate: 2"), "bad.yaml:4: key 'negate'"),
        (YAML.replace("origin: [-1.0, -2.0, 0.0]", "origin: [-1.0, -2.0]"), "origin"),
        (YAML.replace("origin: [-1.0, -2.0, 0.0]", "origin: [.nan, 0, 0]"), "origin"),
        (YAML.replace("origin: [-1.0, -2.0, 0.0]", "origin: [1, 2, 3"), "unterminated"),
        (YAML.replace("image: m.pgm\n", ""), "missing key 'image'"),
        (YAML.replace("free_thresh: 0.196\n", ""), "missing key 'free_thresh'"),
        (YAML.replace("negate: 0", "negate: 2"), "negate"),
        (YAML.replace("free_thresh: 0.196", "free_thresh: 0.9"), "free_thresh"),
        (format!("{YAML}mode: fancy\n"), "mode"),
        (format!("{YAML}resolution: 1\n"), "duplicate"),
        ("just some text\n".to_string(), "expected 'key: value'"),
    ];
    for (text, want) in cases {
        let e = parse_map_yaml(&text, p).unwrap_err().to_string();
        assert!(e.contains("bad.yaml") && e.contains(want), "{e} (wanted {want})");
    }
}

#[test]
fn image_errors() {
    let d = tmpdir("bad-img");
    std::fs::write(d.join("m.yaml"), YAML).unwrap();
    let cases: [(&[u8], &str); 9] = [
        (b"P5\n2 2\n100\n\x05\x06\x07\xc8", "pixel 3 (image row 1, column 1; byte 14): value 200 exceeds maxval 100"),
        (b"P5\n100000 100000\n255\n", "exceeds the limit"),
        (b"P5\n0 5\n255\n", "zero-size"),
        (b"P5\n3 3\n255\n\x00\x01", "truncated PGM raster"),
        (b"P5\n3", "truncated PGM header"),
        (
            b"P2\n2 1\n100\n5 200\n",
            "pixel 1 (image row 0, column 1; the value ending before byte 16): value 200 exceeds maxval 100",
        ),
        (b"P5\n2 1\n0\n\x00\x00", "maxval"),
        (b"GIF89a", "unrecognised"),
        (b"\x89PNG\r\n\x1a\n\x00\x00", "bad PNG"),
    ];
    for (bytes, want) in cases {
        std::fs::write(d.join("m.pgm"), bytes).unwrap();
        let e = load_map(&d.join("m.yaml")).unwrap_err().to_string();
        assert!(e.contains("m.pgm") && e.contains(want), "{e} (wanted {want})");
    }
    std::fs::remove_file(d.join("m.pgm")).unwrap();
    let e = load_map(&d.join("m.yaml")).unwrap_err().to_string();
    assert!(e.contains("m.pgm"), "{e}");
    std::fs::write(d.join("u.yaml"), b"image: m.pgm\xff\xfe\n").unwrap();
    let e = load_map(&d.join("u.yaml")).unwrap_err().to_string();
    assert!(e.contains("u.yaml:1") && e.contains("UTF-8"), "{e}");
}

proptest! {
    #[test]
    fn pgm_reader_never_panics(data in proptest::collection::vec(any::<u8>(), 0..200), ascii in any::<bool>()) {
        let mut bytes = if ascii { b"P2".to_vec() } else { b"P5".to_vec() };
        bytes.extend(data);
        if let Err(e) = decode_pgm(&bytes, Path::new("fuzz.pgm")) {
            let m = e.to_string();
            prop_assert!(m.starts_with("fuzz.pgm: ") && !m.contains('\n'), "{}", m);
        }
    }

    #[test]
    fn pgm_header_fuzz(w in 0u64..50, h in 0u64..50, maxval in 0u64..70000, extra in 0usize..4000) {
        let mut bytes = format!("P5 {w} {h} {maxval}\n").into_bytes();
        bytes.extend(std::iter::repeat_n(7u8, extra));
        if let Ok(img) = decode_pgm(&bytes, Path::new("fuzz.pgm")) {
            prop_assert_eq!(img.pixels.len() as u64, w * h);
        }
    }

    #[test]
    fn yaml_reader_never_panics(text in "[a-z_:#\\[\\], \\-\\.0-9\"'\n ]{0,200}") {
        if let Err(e) = parse_map_yaml(&text, Path::new("fuzz.yaml")) {
            let m = e.to_string();
            prop_assert!(m.starts_with("fuzz.yaml") && !m.contains('\n'), "{}", m);
        }
    }
}
