//! `--world` and `import-map` end to end (issue 13): a ROS map written here becomes a world
//! that `validate` runs; the lab runs as an embedded world; a world whose route cannot be
//! driven is refused naming the file and the waypoint.
#![allow(clippy::unwrap_used)]

mod common;

use common::{mapkeeper, s, scratch};

/// A 9 m × 6 m room with a pillar as a trinary PGM at 0.05 m (walls two cells thick, unknown
/// outside) and its map_server YAML.
fn write_room_map(dir: &std::path::Path) -> std::path::PathBuf {
    let (w, h) = (200usize, 140usize);
    let mut px = vec![205u8; w * h];
    for r in 0..h {
        for c in 0..w {
            let inside = (10..190).contains(&c) && (10..130).contains(&r);
            let wall = (8..192).contains(&c) && (8..132).contains(&r) && !inside;
            let pillar = (95..105).contains(&c) && (65..75).contains(&r);
            // PGM rows run top down.
            px[r * w + c] = if wall || pillar {
                0
            } else if inside {
                254
            } else {
                205
            };
        }
    }
    let mut pgm = format!("P5\n# written by world_cli.rs\n{w} {h}\n255\n").into_bytes();
    pgm.extend_from_slice(&px);
    std::fs::write(dir.join("room.pgm"), pgm).unwrap();
    let yaml = dir.join("room.yaml");
    std::fs::write(
        &yaml,
        "image: room.pgm\nresolution: 0.05\norigin: [-5.0, -3.5, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n",
    )
    .unwrap();
    yaml
}

#[test]
fn an_imported_map_validates_end_to_end() {
    let dir = scratch("world-cli", "import");
    let yaml = write_room_map(&dir);
    let world = dir.join("room.toml");
    let out = mapkeeper(&["import-map", s(&yaml), "--out", s(&world)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&world).unwrap();
    assert!(
        text.contains("name = \"room\"") && text.contains("[[storage_areas]]") && text.contains("[route]"),
        "{text}"
    );
    // Not overwritten without --force.
    let again = mapkeeper(&["import-map", s(&yaml), "--out", s(&world)]);
    assert!(!again.status.success());
    let v = dir.join("v");
    let out = mapkeeper(&[
        "validate",
        "--world",
        s(&world),
        "--worlds",
        "2",
        "--seeds",
        "1",
        "--preset",
        "mapkeeper",
        "--no-timing",
        "--out",
        s(&v),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&std::fs::read(v.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["params"]["world"], s(&world));
    assert_eq!(summary["routes_completed"], 1, "{}", summary["routes_completed"]);
    assert_eq!(summary["collisions"], 0);
    assert!(summary["map_quality"]["cc"]["updated_mean"].as_f64().unwrap() > 30.0);
    let resolved = std::fs::read_to_string(v.join("world.toml")).unwrap();
    assert!(resolved.contains("[route]"));
    // A missing map names the file.
    let out = mapkeeper(&["import-map", "/nonexistent/m.yaml", "--out", s(&dir.join("x.toml"))]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/m.yaml"));
}

#[test]
fn the_lab_runs_and_bad_routes_are_refused() {
    let dir = scratch("world-cli", "lab");
    let v = dir.join("lab");
    let out = mapkeeper(&[
        "validate",
        "--world",
        "lab",
        "--worlds",
        "2",
        "--seeds",
        "1",
        "--preset",
        "mapkeeper",
        "--route-length",
        "8",
        "--no-timing",
        "--out",
        s(&v),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&std::fs::read(v.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["params"]["world"], "lab");
    assert_eq!(summary["params"]["generator"]["storage_areas"][0]["name"], "centre");
    // The report has the per-world table of Table 2's layout with the paper's lab beside it.
    let report = std::fs::read_to_string(v.join("report.md")).unwrap();
    assert!(report.contains("## Per world (the layout of the paper's Table 2)"), "{report}");
    let cc = report.lines().find(|l| l.starts_with("| W_2 | CC |")).unwrap_or_else(|| panic!("{report}"));
    assert!(cc.ends_with("| 69.69 | 78.95 | +9.26 |"), "{cc}");
    // A route through the lab's pillar: refused naming the route file's waypoints.
    let route = dir.join("through.toml");
    std::fs::write(
        &route,
        "format = \"mapkeeper-route\"\nversion = 1\nwaypoints = [[-2.5, -1.5], [-2.0, 0.0], [3.0, 0.0]]\n",
    )
    .unwrap();
    let bad = dir.join("bad");
    let out = mapkeeper(&["validate", "--world", "lab", "--route", s(&route), "--worlds", "2", "--out", s(&bad)]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--route: ")
            && err.contains("through.toml: waypoints[1] [-2, 0] → waypoints[2] [3, 0] is blocked by column \"pillar\""),
        "{err}"
    );
    assert!(!bad.exists(), "no output folder for a refused world");
    // The same rule in `simulate` (which took a route 500 m outside the world and drove 0 m),
    // naming the flag that brought the file.
    let far = dir.join("far.toml");
    std::fs::write(&far, "format = \"mapkeeper-route\"\nversion = 1\nwaypoints = [[500.0, 500.0], [510.0, 500.0]]\n")
        .unwrap();
    for cmd in
        [&["simulate", "--route", s(&far), "--out", s(&bad)][..], &["validate", "--route", s(&far), "--out", s(&bad)]]
    {
        let out = mapkeeper(cmd);
        assert!(!out.status.success(), "{cmd:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("--route: ") && err.contains("far.toml: waypoints[0] [500, 500] lies outside the interior"),
            "{err}"
        );
        assert!(!bad.exists(), "{cmd:?}: no output folder");
    }
    // A world file whose agent walks through a wall: file, agent and place named.
    let w = dir.join("w.toml");
    std::fs::write(
        &w,
        "format = \"mapkeeper-world\"\nversion = 1\nname = \"w\"\nrobot_start = { x = 0.0, y = 1.0 }\n\
         [[walls]]\nid = \"w1\"\nshape = { type = \"rect\", center = [1.5, 0.0], size = [0.2, 4.0] }\n\
         [[agents]]\nid = \"p\"\nkind = \"person\"\nfootprint = { type = \"circle\", radius = 0.25 }\n\
         speed_mps = 1.0\nmotion = { type = \"loop\", waypoints = [[-1.0, 0.0], [3.0, 0.0]] }\n",
    )
    .unwrap();
    let out = mapkeeper(&["generate", "--world", s(&w), "--worlds", "2", "--out", s(&dir.join("g"))]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(&format!("{}: agents[0] \"p\": path segment 0", w.display())), "{err}");
    assert!(err.contains("wall \"w1\""), "{err}");
}

/// A 10 m × 7 m room with a column and two boxes: no storage areas, no route.
const ROOM: &str = r#"format = "mapkeeper-world"
version = 1
name = "test-room"
robot_start = { x = -3.5, y = -2.3, yaw_deg = 0.0 }
interior = { type = "rect", center = [0.0, 0.0], size = [10.0, 7.0] }
[[walls]]
id = "north"
shape = { type = "rect", center = [0.0, 3.6], size = [10.4, 0.2] }
[[walls]]
id = "south"
shape = { type = "rect", center = [0.0, -3.6], size = [10.4, 0.2] }
[[walls]]
id = "east"
shape = { type = "rect", center = [5.1, 0.0], size = [0.2, 7.0] }
[[walls]]
id = "west"
shape = { type = "rect", center = [-5.1, 0.0], size = [0.2, 7.0] }
[[columns]]
id = "column"
shape = { type = "rect", center = [0.0, 0.0], size = [0.6, 0.6] }
[[movable]]
id = "box-1"
kind = "box"
shape = { type = "rect", center = [2.5, 1.0], size = [0.8, 0.8] }
[[movable]]
id = "box-2"
kind = "box"
shape = { type = "rect", center = [-2.5, 1.5], size = [0.6, 0.9], yaw_deg = 20.0 }
"#;

/// `recover --params` shortening every experiment, with no warehouse coordinates in it.
const SHORT_RECOVER_ANY_WORLD: &str = "[demo]\nduration_s = 4.0\n[table1]\nruns = 1\nroute_length_m = 4.0\n[lost]\nruns = 1\n\
route_length_m = 4.0\n[kidnap]\nstale_max_world = 2\nkidnap_min_s = 2.0\nkidnap_max_s = 2.5\nrecovery_window_s = 4.0\n";

#[test]
fn a_world_written_here_without_scenario_runs_in_generate_validate_run_and_recover() {
    let dir = scratch("world-cli", "room");
    let world = dir.join("room.toml");
    std::fs::write(&world, ROOM).unwrap();
    let stderr = |o: &std::process::Output| String::from_utf8_lossy(&o.stderr).into_owned();
    // generate: the patrol is planned and the areas derived (noted), the worlds carry both.
    let g = dir.join("g");
    let out = mapkeeper(&["generate", "--world", s(&world), "--worlds", "3", "--seed", "4", "--out", s(&g)]);
    assert!(out.status.success(), "{}", stderr(&out));
    let note = stderr(&out);
    assert!(note.contains("has no route: planned a") && note.contains("has no storage areas: derived"), "{note}");
    let w3 = std::fs::read_to_string(g.join("worlds/W_003.toml")).unwrap();
    assert!(w3.contains("[route]") && w3.contains("derived-area-"), "{w3}");
    // validate: the chain runs, the route is driven to its end without a collision.
    let v = dir.join("v");
    let out = mapkeeper(&[
        "validate",
        "--world",
        s(&world),
        "--worlds",
        "2",
        "--seeds",
        "1",
        "--preset",
        "paper",
        "--no-timing",
        "--out",
        s(&v),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let summary: serde_json::Value = serde_json::from_slice(&std::fs::read(v.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["routes_completed"], 1);
    assert_eq!(summary["collisions"], 0);
    // run: one world on the generated map M = G_1, along the planned patrol.
    let r = dir.join("r");
    let map = g.join("ground_truth/G_001.yaml");
    let out = mapkeeper(&["run", "--world", s(&world), "--map", s(&map), "--out", s(&r)]);
    assert!(out.status.success(), "{}", stderr(&out));
    let run: serde_json::Value = serde_json::from_slice(&std::fs::read(r.join("run.json")).unwrap()).unwrap();
    assert_eq!(run["route_done"], true, "{run}");
    assert_eq!(run["collisions"], 0, "{run}");
    // recover: the stress suite in this world.
    let params = dir.join("short.toml");
    std::fs::write(&params, SHORT_RECOVER_ANY_WORLD).unwrap();
    let rec = dir.join("rec");
    let out = mapkeeper(&[
        "recover",
        "--world",
        s(&world),
        "--trials",
        "1",
        "--seed",
        "2",
        "--no-best-case",
        "--params",
        s(&params),
        "--out",
        s(&rec),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let sum = std::fs::read_to_string(rec.join("summary.json")).unwrap();
    // The tour recorded is the room's planned patrol (it starts at the room's robot_start).
    assert!(sum.contains("-3.5") && sum.contains("-2.3"), "the room's tour is not in the summary");
}

/// The robot-kidnap suite (issue 33 item 3) runs in the lab and on an imported map as in the
/// warehouse: the world is named in the outputs, the tour is the world's, the robot is moved
/// and the paired runs are counted; a world file that does not exist is refused naming the flag.
#[test]
fn kidnap_robot_runs_in_the_lab_and_on_an_imported_map() {
    let dir = scratch("world-cli", "kidnap");
    let yaml = write_room_map(&dir);
    let room = dir.join("room.toml");
    let out = mapkeeper(&["import-map", s(&yaml), "--out", s(&room)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mut tours = Vec::new();
    for (world, name) in [("lab", "lab".to_string()), (s(&room), room.display().to_string())] {
        let k = dir.join(format!("k-{}", tours.len()));
        let o = mapkeeper(&[
            "experiment",
            "kidnap-robot",
            "--quick",
            "--preset",
            "mapkeeper",
            "--world",
            world,
            "--out",
            s(&k),
            "--jobs",
            "1",
        ]);
        assert!(o.status.success(), "{world}: {}", String::from_utf8_lossy(&o.stderr));
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(stdout.contains(&format!("kidnap-robot: {name}, seed 41")), "{stdout}");
        let v: serde_json::Value = serde_json::from_slice(&std::fs::read(k.join("summary.json")).unwrap()).unwrap();
        assert_eq!(v["world"], name.as_str());
        let kr = &v["kidnap_robot"];
        assert!(kr["applied"].as_u64().unwrap() >= 1, "{world}: {kr}");
        for f in ["false_lost_rate", "false_lost_right_pose_rate", "false_lost_well_localised_rate"] {
            let r = kr[f].as_f64().unwrap();
            assert!((0.0..=1.0).contains(&r), "{world}: {f} {kr}");
        }
        // Lost while well localised ⊆ while right ⊆ at all, run by run.
        assert!(kr["false_lost_well_localised_rate"].as_f64() <= kr["false_lost_right_pose_rate"].as_f64(), "{kr}");
        assert!(kr["false_lost_right_pose_rate"].as_f64() <= kr["false_lost_rate"].as_f64(), "{kr}");
        let report = std::fs::read_to_string(k.join("report.md")).unwrap();
        assert!(report.starts_with("# Real kidnaps") && report.contains(&format!("World `{name}`")), "{report}");
        tours.push(v["recovery"]["tour"].clone());
    }
    // Each world drove its own tour, neither the warehouse's.
    assert_ne!(tours[0], tours[1]);
    let warehouse = mapkeeper_sim::Route::default_warehouse();
    for t in &tours {
        assert_ne!(t, &serde_json::to_value(&warehouse).unwrap());
    }
    let o = mapkeeper(&["experiment", "kidnap-robot", "--quick", "--world", s(&dir.join("none.toml"))]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--world") && err.contains("none.toml"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}
