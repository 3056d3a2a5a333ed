#!/usr/bin/env python3
"""Writes the seed corpus in fuzz/corpus/<target>/ from inputs the project itself writes
(worlds/, crates/sim/tests/bad_worlds/, tests/data/bad_maps/, small hand-written files) and
deterministic mutations of them. Never reads ../shared. Rerun: python3 fuzz/make_seed_corpus.py
(files found by fuzzing are kept next to these under their libFuzzer hash names)."""
import os, random, struct, zlib, pathlib

ROOT = pathlib.Path(__file__).resolve().parent.parent
OUT = ROOT / "fuzz" / "corpus"
rng = random.Random(16)

def write(target, name, data):
    d = OUT / target
    d.mkdir(parents=True, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    (d / name).write_bytes(data)

def mutations(data, n):
    """n deterministic mutants: truncation, byte flips, deletion, duplication of a line."""
    out = []
    for k in range(n):
        b = bytearray(data)
        op = k % 4
        if op == 0 and len(b) > 1:
            b = b[: rng.randrange(1, len(b))]
        elif op == 1 and b:
            for _ in range(rng.randrange(1, 4)):
                b[rng.randrange(len(b))] = rng.randrange(256)
        elif op == 2 and len(b) > 2:
            i = rng.randrange(len(b) - 1)
            del b[i : i + rng.randrange(1, min(8, len(b) - i))]
        else:
            lines = bytes(b).split(b"\n")
            i = rng.randrange(len(lines))
            lines.insert(i, lines[i])
            b = bytearray(b"\n".join(lines))
        out.append(bytes(b))
    return out

def seed(target, name, data, n_mut):
    write(target, f"{name}", data)
    for i, m in enumerate(mutations(data if isinstance(data, bytes) else data.encode(), n_mut)):
        write(target, f"{name}.mut{i}", m)

# --- map YAML -------------------------------------------------------------------------------
yaml = "image: m.pgm\nresolution: 0.5\norigin: [-1.0, -2.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
seed("map_yaml", "valid.yaml", yaml, 6)
seed("map_yaml", "block_list.yaml", "# CREATOR: map_saver\nimage: \"map #1.pgm\"  # the image\nresolution: 0.050000\norigin:\n  - -7.0\n  - -10.5\n  - 0\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n", 6)
seed("map_yaml", "raw.yaml", yaml + "mode: raw\n", 2)
seed("map_yaml", "scale.yaml", "image: 'p.png'\nresolution: 1e-2\norigin: [0,0,3.14]\nnegate: 1\nmode: scale\n---\n", 2)
for p in sorted((ROOT / "tests/data/bad_maps").glob("*.yaml")):
    write("map_yaml", "bad_" + p.name, p.read_bytes())

# --- PGM ------------------------------------------------------------------------------------
p5 = b"P5\n# comment\n4 3\n255\n" + bytes([0, 254, 205, 100, 255, 0, 0, 0, 10, 20, 30, 40])
p5_16 = b"P5 2 2 1023\n" + struct.pack(">4H", 0, 1023, 512, 7)
p2 = b"P2\n# a comment\n6 1\n255\n0 254 205 89 90 206\n"
p2_max = b"P2\n3 2\n15\n0 15 7\n1 2 3"
for name, data, n in [("p5.pgm", p5, 6), ("p5_16bit.pgm", p5_16, 4), ("p2.pgm", p2, 6), ("p2_maxval15.pgm", p2_max, 4)]:
    seed("pgm", name, data, n)
for p in sorted((ROOT / "tests/data/bad_maps").glob("*.pgm")):
    data = p.read_bytes()
    write("pgm", "bad_" + p.name, data[:4096])
write("pgm", "huge_p2_header.pgm", b"P2\n16384 16384\n255\n0 1 2\n")

# --- PNG ------------------------------------------------------------------------------------
def chunk(kind, body):
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)

def png(w, h, depth, color, rows, extra=b"", interlace=0):
    ihdr = struct.pack(">IIBBBBB", w, h, depth, color, 0, 0, interlace)
    raw = b"".join(b"\x00" + r for r in rows)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + extra + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")

pngs = {
    "gray8.png": png(3, 2, 8, 0, [bytes([0, 128, 255]), bytes([205, 254, 1])]),
    "gray16.png": png(2, 1, 16, 0, [struct.pack(">2H", 0, 65535)]),
    "gray1.png": png(8, 1, 1, 0, [bytes([0b10101010])]),
    "rgb.png": png(2, 1, 8, 2, [bytes([0, 0, 0, 255, 255, 255])]),
    "rgba.png": png(2, 1, 8, 6, [bytes([0, 0, 0, 255, 255, 255, 255, 0])]),
    "gray_alpha.png": png(2, 1, 8, 4, [bytes([0, 255, 200, 0])]),
    "palette.png": png(2, 1, 8, 3, [bytes([0, 1])], extra=chunk(b"PLTE", bytes([0, 0, 0, 255, 255, 255]))),
    "interlaced.png": png(3, 3, 8, 0, [bytes([0, 1, 2])] * 3, interlace=1),
    "zero_width.png": png(0, 1, 8, 0, [b""]),
    "huge_header.png": png(100000, 100000, 8, 0, [bytes([0])]),
}
for name, data in pngs.items():
    seed("png", name, data, 3)
write("png", "bad_truncated.png", (ROOT / "tests/data/bad_maps/truncated.png").read_bytes()[:4096])

# --- world TOML -----------------------------------------------------------------------------
world = (ROOT / "worlds/warehouse.toml").read_text()
seed("world_toml", "warehouse.toml", world, 8)
small = """format = "mapkeeper-world"
version = 1
name = "room"
robot_start = { x = 0.0, y = 0.0, yaw_deg = 0.0 }
interior = { type = "rect", center = [0.0, 0.0], size = [4.0, 4.0] }
[[walls]]
id = "w"
shape = { type = "rect", center = [0.0, 2.1], size = [4.4, 0.2] }
[[movable]]
id = "box-1"
kind = "box"
shape = { type = "polygon", points = [[1.0, 1.0], [1.5, 1.0], [1.5, 1.5]] }
[[agents]]
id = "person-1"
kind = "person"
footprint = { type = "circle", radius = 0.25 }
speed_mps = 1.0
motion = { type = "loop", waypoints = [[-1.0, -1.0], [1.0, -1.0]] }
"""
seed("world_toml", "small_room.toml", small, 8)
for p in sorted((ROOT / "crates/sim/tests/bad_worlds").glob("*.toml")):
    write("world_toml", "bad_" + p.name, p.read_bytes())

# --- route TOML -----------------------------------------------------------------------------
route = 'format = "mapkeeper-route"\nversion = 1\nwaypoints = [[-3.65, -2.3], [-3.65, 8.0], [3.0, 8.0], [3.0, -8.0]]\n'
seed("route_toml", "route.toml", route, 8)
for name, text in {
    "empty_waypoints.toml": 'format = "mapkeeper-route"\nversion = 1\nwaypoints = []\n',
    "nan_waypoint.toml": 'format = "mapkeeper-route"\nversion = 1\nwaypoints = [[nan, 0.0]]\n',
    "wrong_version.toml": 'format = "mapkeeper-route"\nversion = 2\nwaypoints = [[0.0, 0.0]]\n',
    "wrong_format.toml": 'format = "route"\nversion = 1\nwaypoints = [[0.0, 0.0]]\n',
    "three_d.toml": 'format = "mapkeeper-route"\nversion = 1\nwaypoints = [[0.0, 0.0, 1.0]]\n',
    "inf.toml": 'format = "mapkeeper-route"\nversion = 1\nwaypoints = [[inf, -inf]]\n',
}.items():
    write("route_toml", name, text)

# --- parameter TOML (MapperParams, MetricParams, SimParams, FilterParams) --------------------
params = {
    "mapper.toml": "l_free = -0.7\nl_occ = 0.85\n",
    "mapper_bad.toml": "l_free = 0.7\n",
    "metric.toml": "unknown_value = 0.3\n",
    "sim_tick.toml": "tick_ns = 20000000\n",
    "sim_bad_tick.toml": "tick_ns = 0\n",
    "sim_lidars.toml": "[[lidars]]\nmax_range_m = 30.0\n[[lidars]]\nmax_range_m = -1.0\n",
    "sim_robot.toml": "[robot]\nmax_speed_mps = 1.0\n[odometry]\n[agents]\n",
    "filter.toml": 'kinematics = "differential"\nmax_beams = 60\nmin_particles = 100\nmax_particles = 200\n',
    "filter_bad.toml": "min_particles = 500\nmax_particles = 10\n",
    "filter_motion.toml": "[motion]\nalpha1 = 0.2\nalpha2 = -1.0\n",
    "filter_nan.toml": "sigma_hit_m = nan\n",
    "filter_huge.toml": "max_particles = 18446744073709551615\n",
    "unknown_key.toml": "bogus = 1\n",
    "wrong_type.toml": 'kld_err = "small"\n',
    "empty.toml": "",
}
for name, text in params.items():
    seed("params_toml", name, text, 2)

# --- sensor log (JSON Lines) ----------------------------------------------------------------
header = '{"format":"mapkeeper-sensor-log","version":1,"meta":{"seed":3,"world":"room"}}'
odom = '{"type":"odom","stamp_ns":20000000,"pose_in_odom":{"x":0.0,"y":0.00024,"yaw":0.0}}'
truth = '{"type":"truth","stamp_ns":20000000,"pose_in_map":{"x":-3.65,"y":-2.29976,"yaw":1.5707963}}'
scan = ('{"type":"scan","stamp_ns":20000000,"lidar_id":0,"lidar_in_robot":{"x":0.2865,"y":-0.2089,"yaw":-0.785},'
        '"angle_min_rad":-2.356,"angle_increment_rad":0.0087,"range_min_m":0.1,"range_max_m":30.0,"ranges_m":[3.41,3.42,null,0.0,-1.0]}')
log = "\n".join([header, odom, truth, scan]) + "\n"
seed("sensor_log", "log.jsonl", log, 10)
for name, text in {
    "header_only.jsonl": header + "\n",
    "empty.jsonl": "",
    "wrong_version.jsonl": header.replace('"version":1', '"version":2') + "\n",
    "backwards.jsonl": "\n".join([header, odom, odom.replace("20000000", "10")]) + "\n",
    "nan_pose.jsonl": "\n".join([header, odom.replace("0.00024", "1e999")]) + "\n",
    "zero_increment.jsonl": "\n".join([header, scan.replace("0.0087", "0.0")]) + "\n",
    "huge_angle.jsonl": "\n".join([header, scan.replace("0.0087", "1e300")]) + "\n",
    "negative_stamp.jsonl": "\n".join([header, odom.replace("20000000", "-1")]) + "\n",
    "not_utf8.jsonl": (header + "\n").encode() + b"\xff\xfe\n",
    "unknown_type.jsonl": header + '\n{"type":"imu","stamp_ns":0}\n',
}.items():
    write("sensor_log", name, text)

# --- TUM ------------------------------------------------------------------------------------
tum = "# t x y z qx qy qz qw\n0.02 -3.65 -2.3 0 0 0 0.7071068 0.7071068\n0.04 -3.65 -2.29 0 0 0 0.7071068 0.7071068\n"
seed("tum", "truth.tum", tum, 10)
for name, text in {
    "backwards.tum": "1 0 0 0 0 0 0 1\n0.5 0 0 0 0 0 0 1\n",
    "not_planar.tum": "0 0 0 0 0.7 0 0 0.7\n",
    "short.tum": "0 0 0\n",
    "huge_time.tum": "1e300 0 0 0 0 0 0 1\n",
    "nan.tum": "0 nan 0 0 0 0 0 1\n",
    "zero_quat.tum": "0 0 0 0 0 0 0 0\n",
}.items():
    write("tum", name, text)

# --- updater parameter TOML (UpdaterParams over each preset) ------------------------------------
# Last in this file: the generator is shared, so the targets above keep their mutants.
# `paper.toml` is every field of the `paper` preset (as `toml::to_string` writes it, with the
# limits as `inf`); laid over any preset it gives `paper` back (checked by the replay test).
paper = """method = "stefanini"
gating_min_translation_m = 0.05
gating_min_rotation_rad = 0.3490658503988659
gating_min_interval_s = 0.0
fast_rotation_rad_s = inf
fast_rotation_pause_s = 1.2
fast_rotation_pause_m = 1.6
max_range_m = inf
virtual_rays_each_side = 3
virtual_ray_spacing_beams = 0.25
virtual_window_rad = 0.0
change_slope = 0.01327
change_intercept_m = 0.1473
change_max_m = 0.3
min_change_run = 1
localisation_check = true
d_eps_min = 0.75
d_eps_max = 0.9
min_valid_beams = 20
tol_slope = 0.01
tol_intercept_m = 0.1
tol_max_m = 0.2
skip_changed_slope = 0.02
skip_changed_min_m = 0.15
skip_unchanged_slope = 0.02
skip_unchanged_min_m = 0.15
unchanged_hit = "adjacent8"
unchanged_ray_free_only = false
skip_near_changes_beams = 0
free_pass_votes = false
map_update = true
buffer_size = 10
change_threshold = 8
flags = "step-majority"
revert = "below-threshold"
neighbour_support = false
border_reconstruction = true
border_interior_only = true

[removal]
hit_clearance_m = 0.0
min_incidence_rad = 0.0
max_offset_cells = inf
shadow = false

[pose_updating]
enabled = true
retry_interval_s = 0.5
source_beam_step = 2
max_correspondence_m = 1.0
correspondence_decay = 0.8
min_correspondence_m = 0.25
max_iterations = 40
convergence_translation_m = 0.0001
convergence_rotation_rad = 0.0001
yaw_offsets_rad = [0.0, 0.2, -0.2, 0.4, -0.4, 0.8, -0.8]
position_offsets_m = [0.0, 0.6, -0.6]
inlier_distance_m = 0.1
min_inlier_ratio = 0.7
max_rmse_m = 0.06
min_points = 30
ambiguity_ratio_margin = 0.02
ambiguity_distance_m = 0.3
ambiguity_rotation_rad = 0.1
search_radius_m = 2.0
search_yaw_rad = 0.8
search_step_m = 0.1
search_yaw_step_rad = 0.03
search_candidates = 6

[shift_check]
enabled = false
when = "every_step"
search_xy_m = 1.6
step_xy_m = 0.2
search_yaw_rad = 0.3490658503988659
step_yaw_rad = 0.08726646259971647
max_beams = 60
truncate_m = 0.3
better_margin_m = 0.015
fit_ok_m = 0.2

[global_search]
enabled = false
confident_inlier_ratio = 0.9
tolerance_m = 0.25
yaw_step_rad = 0.02
max_points = 120
levels = 6
candidates = 6
min_score = 0.45
max_nodes = 400000
min_inlier_ratio = 0.55
ambiguity_ratio_margin = 0.08
views = 1
view_baseline_m = 0.3
view_turn_rad = 0.26
view_max_age_s = 30.0
kept_candidates = 0

[registration]
enabled = false
max_points = 240
min_points = 40
yaw_search_rad = 0.05235987755982989
yaw_step_rad = 0.003490658503988659
truncate_m = 0.25
iterations = 12
inlier_m = 0.05
min_inlier_share = 0.5
max_inlier_rmse_m = 0.03
min_constraint = 0.08
max_shift_m = 0.3
max_turn_rad = 0.05235987755982989
pull_to_centres = false

[memory]
enabled = false
established_after_worlds = 3
established_removal_threshold = 9
scar_worlds = 30

[evidence]
enabled = false
band_m = 0.15
max_sigma_m = 0.05
min_xy_sigma_m = 0.01
min_yaw_sigma_deg = 0.1
min_incidence_deg = 10.0
planarity_m = 0.02
surface_margin_m = 0.0
min_weight = 60.0
grow_established = true
trust_unreported_pose = false
occupied_share = 0.6
free_share = 0.1
max_weight = 500.0
drop_margin = 0.05

[log_odds]
l_occ = 0.85
l_free = -0.4
l_min = -2.0
l_max = 3.5
occ_threshold = 0.65
free_threshold = 0.196
prior_l = 2.0
"""
seed("updater_params", "paper.toml", paper, 3)
# The fields in which `authors` and `mapkeeper` differ from `paper-strict` (the `paper` of the first releases).
seed("updater_params", "authors.toml", """gating_min_interval_s = 0.3
fast_rotation_rad_s = 0.20943951023931956
max_range_m = 18.0
virtual_ray_spacing_beams = 1.0
virtual_window_rad = 0.06981317007977318
change_slope = 0.013265
change_intercept_m = 0.14735
min_change_run = 3
d_eps_min = 0.58
d_eps_max = 0.58
tol_slope = 0.013
tol_intercept_m = 0.15
tol_max_m = "inf"
skip_changed_min_m = 0.15
skip_near_changes_beams = 2
unchanged_hit = "cross4"
unchanged_ray_free_only = true
flags = "step-each-kind"
revert = "below-threshold"
neighbour_support = true
""", 2)
seed("updater_params", "mapkeeper.toml", """free_pass_votes = true
revert = "unchanged-threshold"
border_interior_only = true

[removal]
hit_clearance_m = 0.2
min_incidence_rad = 0.17453292519943295
shadow = true
""", 2)
seed("updater_params", "log_odds.toml", 'method = "log-odds"\nlocalisation_check = false\n[log_odds]\nl_occ = 2.0\nl_free = -0.1\nprior_l = 0.0\n', 1)
seed("updater_params", "pose_updating.toml", "[pose_updating]\nmax_iterations = 1000\nsearch_candidates = 64\nsource_beam_step = 1\nmin_points = 0\nmin_inlier_ratio = 0.0\nmax_rmse_m = inf\n", 2)
for name, text in {
    # Edge values validate() accepts: the algorithm must cope with them.
    "zero_windows.toml": "virtual_rays_each_side = 0\nvirtual_window_rad = 0.0\ngating_min_translation_m = 0.0\ngating_min_rotation_rad = 0.0\ntol_slope = 0.0\ntol_intercept_m = 0.0\nchange_slope = 0.0\nchange_intercept_m = 0.0\n",
    "widest_windows.toml": "virtual_rays_each_side = 64\nvirtual_window_rad = 1e300\nvirtual_ray_spacing_beams = 5e-324\nmin_change_run = 4294967295\nskip_near_changes_beams = 4294967295\n",
    "biggest_buffers.toml": 'buffer_size = 32\nchange_threshold = 32\nrevert = "unchanged-threshold"\nflags = "step-each-kind"\nneighbour_support = true\n',
    "smallest_buffers.toml": 'buffer_size = 1\nchange_threshold = 1\nrevert = "below-threshold"\nmin_valid_beams = 1\nd_eps_min = 0.0\nd_eps_max = 0.0\n',
    "tiny_limits.toml": "max_range_m = 5e-324\nchange_max_m = 5e-324\ntol_max_m = 5e-324\nfast_rotation_rad_s = 5e-324\n[removal]\nmax_offset_cells = 5e-324\n",
    "huge_values.toml": "gating_min_interval_s = 1e300\nskip_changed_min_m = 1e300\nskip_unchanged_min_m = 1e300\nchange_intercept_m = 1e300\n[removal]\nhit_clearance_m = 1e300\n",
    "inf_as_text.toml": 'max_range_m = "Infinity"\ntol_max_m = "INF"\nfast_rotation_rad_s = inf\n[removal]\nmax_offset_cells = "inf"\n',
    # The flat names of the removal gates before the `removal` section: still read.
    "flat_removal_names.toml": 'removal_hit_clearance_m = 0.2\nremoval_min_incidence_rad = 0.17453292519943295\nremoval_max_offset_cells = "inf"\nremoval_shadow = true\n',
    "flat_and_section.toml": "removal_shadow = true\n[removal]\nshadow = false\nhit_clearance_m = -1.0\n",
    "unknown_removal_key.toml": "[removal]\nhit_clearance = 0.2\n",
    "huge_search.toml": "[pose_updating]\nsearch_radius_m = 1e300\nsearch_step_m = 1e300\nsearch_yaw_rad = 3.2\nsearch_yaw_step_rad = 5e-324\n",
    "many_hypotheses.toml": "[pose_updating]\nyaw_offsets_rad = [" + ", ".join(f"{0.01 * k:.2f}" for k in range(64)) + "]\nposition_offsets_m = [0.0, 0.1, -0.1, 0.2, -0.2, 0.3, -0.3, 0.4]\n",
    "nan.toml": "tol_slope = nan\n",
    "nan_offsets.toml": "[pose_updating]\nyaw_offsets_rad = [nan]\n",
    "negative.toml": "change_max_m = -0.3\n",
    "bad_threshold.toml": "buffer_size = 4\nchange_threshold = 9\n",
    "bad_d_eps.toml": "d_eps_min = 0.95\nd_eps_max = 0.9\n",
    "bad_log_odds.toml": "[log_odds]\nl_free = 0.7\n",
    # Refused before validation: the key must be named.
    "wrong_type.toml": 'buffer_size = "ten"\n',
    "float_for_int.toml": "buffer_size = 1e3\n",
    "negative_int.toml": "min_valid_beams = -1\n",
    "overflow_int.toml": "virtual_rays_each_side = 4294967296\n",
    "unknown_key.toml": "bogus = 1\n",
    "unknown_nested_key.toml": "[pose_updating]\nbogus = 1\n",
    "bad_enum.toml": 'revert = "sometimes"\n',
    "bad_inf_text.toml": 'max_range_m = "far"\n',
    "table_of_tables.toml": "[[pose_updating]]\nenabled = false\n",
    "dotted_keys.toml": "pose_updating.enabled = false\nlog_odds.l_occ = 1.0\n",
    # Syntax errors: line and column.
    "syntax.toml": "buffer_size = \n",
    "duplicate_key.toml": "buffer_size = 5\nbuffer_size = 6\n",
    "unterminated.toml": '[pose_updating\nmethod = "log-odds\n',
    "empty.toml": "",
}.items():
    write("updater_params", name, text)

# --- validation folder files read back by `mapkeeper merge` (runs.json NUL summary.json) --------
# From tests/data/validation_run/, written by
# `mapkeeper validate --preset paper --localiser mapkeeper --seed 1 --seeds 1 --route-length 10 --worlds 2 --no-timing --out tests/data/validation_run`
# (only runs.json and summary.json kept), compacted to fit libFuzzer's 16 KiB inputs.
import json, copy
vrun = ROOT / "tests/data/validation_run"
runs = json.loads((vrun / "runs.json").read_text())
summary = json.loads((vrun / "summary.json").read_text())
compact = lambda v: json.dumps(v, separators=(",", ":"), ensure_ascii=False)

def pair(r, s):
    return compact(r).encode() + b"\0" + (compact(s).encode() if isinstance(s, dict) else s)

seed("merge_json", "valid.json", pair(runs, summary), 3)
write("merge_json", "runs_only.json", compact(runs))

def edited(edit, s=summary):
    r = copy.deepcopy(runs)
    edit(r)
    return pair(r, s)

def set_path(path, value):
    def f(r):
        d = r
        for k in path[:-1]:
            d = d[k]
        d[path[-1]] = value
    return f

row = ["seeds", 0, "rows", 0]
for name, data in {
    "wrong_format.json": edited(set_path(["format"], "mapkeeper-sweep")),
    "wrong_version.json": edited(set_path(["format_version"], 1)),
    "no_seed.json": edited(set_path(["seeds"], [])),
    "duplicate_seed.json": edited(lambda r: r["seeds"].append(copy.deepcopy(r["seeds"][0]))),
    "missing_row.json": edited(set_path(["seeds", 0, "rows"], [])),
    "wrong_world.json": edited(set_path(row + ["world"], 7)),
    "one_edit_list.json": edited(lambda r: r["seeds"][0]["edits"].pop()),
    "histogram_decreasing.json": edited(set_path(["seeds", 0, "scan_time_histogram_us"], [[5, 1], [3, 2]])),
    "histogram_zero_count.json": edited(set_path(["seeds", 0, "scan_time_histogram_us"], [[5, 0]])),
    "huge_counts.json": edited(set_path(row + ["updater", "processed"], 18446744073709551615)),
    "huge_histogram.json": edited(set_path(["seeds", 0, "scan_time_histogram_us"], [[1, 18446744073709551615], [2, 18446744073709551615]])),
    "negative_count.json": edited(set_path(row + ["collisions"], -1)),
    "huge_float.json": edited(set_path(row + ["sim_time_s"], 1e308)),
    "one_world.json": edited(set_path(["params", "worlds"], 1)),
    "bad_updater_params.json": edited(set_path(["params", "runner", "updater", "buffer_size"], 0)),
    "unknown_field.json": edited(set_path(["bogus"], 1)),
    "summary_disagrees.json": pair(runs, {**summary, "rows": summary["rows"] + 1}),
    "summary_not_json.json": pair(runs, b"{\"tool\": "),
    "not_json.json": b'{"format": "mapkeeper-validation-runs", "format_version": 3,\n  "seeds": [\n',
    "empty.json": b"",
}.items():
    write("merge_json", name, data)

# --- parameter TOML: RecoveryParams (`recover --params`), appended to the params_toml corpus --
recovery = {
    "recovery_short.toml": '[demo]\nduration_s = 4.0\n[table1]\nruns = 1\nroute_length_m = 4.0\n[lost]\nruns = 1\n[kidnap]\nstale_max_world = 2\nkidnap_min_s = 2.0\nkidnap_max_s = 2.5\n',
    "recovery_route.toml": 'exploration_route = { format = "mapkeeper-route", version = 1, waypoints = [[-3.65, -2.3], [-3.65, 7.3]] }\n',
    "recovery_bad_kidnap.toml": "[kidnap]\nkidnap_min_s = 5.0\nkidnap_max_s = 1.0\n",
    "recovery_nan.toml": "resolution_m = nan\n[demo]\nduration_s = inf\n",
    "recovery_runner.toml": '[runner]\nstart_error_m = -1.0\n[runner.updater]\nbuffer_size = 0\n',
    "recovery_empty_route.toml": 'tour = { format = "mapkeeper-route", version = 1, waypoints = [] }\n',
}
for name, text in recovery.items():
    seed("params_toml", name, text, 2)

# --- appended last so that the mutations above keep their random numbers ---------------------
# Robot TOML (`--robot FILE`, docs/robot-format.md): the example robots and bad ones.
for p in sorted((ROOT / "robots").glob("*.toml")):
    seed("robot_toml", p.name, p.read_bytes(), 6)
for name, text in {
    "unknown_model.toml": 'format = "mapkeeper-robot"\nversion = 1\n[[lidars]]\nmodel = "velodyne"\nx = 0\ny = 0\nyaw_deg = 0\n',
    "inline_missing.toml": 'format = "mapkeeper-robot"\nversion = 1\n[[lidars]]\nmodel = { fov_deg = 270 }\nx = 0\ny = 0\nyaw_deg = 0\n',
    "nan_mount.toml": 'format = "mapkeeper-robot"\nversion = 1\n[[lidars]]\nmodel = "sick_s300"\nx = nan\ny = 0\nyaw_deg = 0\n',
    "no_lidars.toml": 'format = "mapkeeper-robot"\nversion = 1\n',
    "bad_body.toml": 'format = "mapkeeper-robot"\nversion = 1\n[body]\nwidth_m = -1\n[[lidars]]\nmodel = "sick_s300"\nx = 0\ny = 0\nyaw_deg = 0\n',
    "noise.toml": 'format = "mapkeeper-robot"\nversion = 1\n[[lidars]]\nmodel = "hokuyo_ust20lx"\nx = 0\ny = 0\nyaw_deg = 0\nupside_down = true\nphase_offset_s = 0.01\n[lidars.noise]\nsigma_m = 0.02\nquantisation_m = 0.0\ndropout_probability = 0.0\nspurious_probability = 0.0\nspurious_max_m = 2.0\n',
}.items():
    write("robot_toml", name, text)

# SimParams with sensor realism: every field of SensorRealism (the realistic profile), a bad
# value, an upside-down lidar.
for name, text in {
    "sim_realism.toml": "[realism]\nmixed_pixels = true\nmixed_pixel_probability = 0.5\nmixed_pixel_min_jump_m = 0.3\nrange_noise = true\nrange_noise_sigma_per_m = 0.002\nmotion_distortion = true\nunsync = true\nextrinsic_error = true\nextrinsic_sigma_xy_m = 0.01\nextrinsic_sigma_yaw_rad = 0.008726646259971648\nlatency = true\nlatency_s = 0.015\njitter_s = 0.01\nlegs = true\nleg_radius_m = 0.06\nleg_separation_m = 0.22\nstride_m = 1.2\n",
    "sim_realism_bad.toml": "[realism]\nlatency = true\nlatency_s = -1.0\n",
    "sim_upside_down.toml": "[[lidars]]\nupside_down = true\n",
}.items():
    seed("params_toml", name, text, 2)
