//! End-to-end test of `mapkeeper run` (one world: generate two worlds, then run W_2 on G_1),
//! as the real binary in a temporary folder.
#![allow(clippy::unwrap_used)]

mod common;

use common::{mapkeeper, s, scratch};

#[test]
fn run_one_world_end_to_end() {
    let dir = scratch("run-cli", "one");
    let gen_dir = dir.join("gen");
    let out = mapkeeper(&["generate", "--worlds", "2", "--seed", "3", "--out", s(&gen_dir)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // A short route keeps the test quick: the first 15 m of the default tour.
    std::fs::write(
        dir.join("route.toml"),
        "format = \"mapkeeper-route\"\nversion = 1\nwaypoints = [[-3.65, -2.3], [-3.65, 7.3], [-3.65, 2.0]]\n",
    )
    .unwrap();
    let run_dir = dir.join("run");
    let (world, map, route) =
        (gen_dir.join("worlds/W_002.toml"), gen_dir.join("ground_truth/G_001.yaml"), dir.join("route.toml"));
    let args = ["run", "--world", s(&world), "--map", s(&map), "--route", s(&route), "--out", s(&run_dir)];
    let out = mapkeeper(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for f in ["map.yaml", "map.pgm", "true.tum", "chain.tum", "baseline.tum", "run.json"] {
        assert!(run_dir.join(f).is_file(), "{f} missing");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run_dir.join("run.json")).unwrap()).unwrap();
    assert_eq!(json["route_done"], true);
    assert_eq!(json["collisions"], 0);
    assert!(json["chain"]["mean_error_m"].as_f64().unwrap() < 0.1);
    assert!(json["updater"]["processed"].as_u64().unwrap() > 50);
    let tum = std::fs::read_to_string(run_dir.join("true.tum")).unwrap();
    assert!(tum.lines().filter(|l| !l.starts_with('#')).all(|l| l.split_whitespace().count() == 8));
    // The output folder is not overwritten without --force; a bad map path names the file.
    let again = mapkeeper(&args);
    assert!(!again.status.success());
    let mut bad = args.to_vec();
    bad[4] = "/nonexistent/map.yaml";
    let out = mapkeeper(&bad);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/map.yaml"));
    // --mcap: the same run, also written as a ROS 2 bag that reads back (the run itself unchanged).
    let (run2, bag) = (dir.join("run2"), dir.join("run.mcap"));
    let mut with_mcap = args.to_vec();
    with_mcap[8] = s(&run2);
    with_mcap.extend(["--mcap", s(&bag)]);
    let out = mapkeeper(&with_mcap);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(std::fs::read(run_dir.join("map.pgm")).unwrap(), std::fs::read(run2.join("map.pgm")).unwrap());
    assert_eq!(std::fs::read(run_dir.join("chain.tum")).unwrap(), std::fs::read(run2.join("chain.tum")).unwrap());
    let conv = dir.join("conv");
    let out = mapkeeper(&["convert", "--log", s(&bag), "--truth-topic", "/truth", "--out", s(&conv)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let import: serde_json::Value = serde_json::from_slice(&std::fs::read(conv.join("import.json")).unwrap()).unwrap();
    let topics = &import["topics"];
    let verdicts = topics["/updater/verdict"]["messages"].as_u64().unwrap();
    assert!(verdicts > 50, "{import}");
    // The check's state every updater step (a step without a verdict too), and the layer of
    // changed cells beside the maps that changed.
    assert_eq!(topics["/updater/step"]["type_name"], "mapkeeper_msgs/msg/UpdaterStep", "{import}");
    assert!(topics["/updater/step"]["messages"].as_u64().unwrap() >= verdicts, "{import}");
    assert_eq!(topics["/updater/changes"]["type_name"], "nav_msgs/msg/OccupancyGrid", "{import}");
    let (maps, changes) =
        (topics["/map"]["messages"].as_u64().unwrap(), topics["/updater/changes"]["messages"].as_u64().unwrap());
    assert!(changes >= 1 && changes < maps, "{changes} change layers, {maps} maps: {import}");
}
