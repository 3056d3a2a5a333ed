#!/usr/bin/env python3
"""The `amcl` preset against an independent AMCL (issue 27 item 7; docs/localiser.md).

Drives Nav2's AMCL core, as packaged on PyPI (`pip install amcl`: nanobind bindings around
nav2_amcl's pf, sensor and motion-model code), over a mapkeeper sensor log the way nav2_amcl's
node does (`laserReceived`): the per-axis update gate on the odometry (`update_min_d`,
`update_min_a`), when it opens every lidar is due for one sensor update, each lidar's scan is a
sensor update and a resampling of its own, the estimate is the heaviest cluster's mean. Between
filter updates the pose is the last estimate moved by the odometry since, as the map -> odom
transform makes it.

Then it compares the errors against the log's true poses with those of estimates written by
`mapkeeper localise` (TUM files), step by step.

Benchmark only: the crates never depend on it. Nothing of the package is copied here.

    python3 nav2_amcl_compare.py --log SIM/log.jsonl --map MAP.yaml \
        --ours amcl=LOC/estimate.tum --ours amcl-joint=LOC2/estimate.tum [--json OUT.json]

The published wheel uses Nav2's `beam` laser model; `--expect-model likelihood_field` refuses
to run unless the installed module was built with the likelihood field (a local build: the
binding's `setMap` constructing `LikelihoodFieldModel(z_hit, z_rand, sigma_hit, 2.0, max_beams,
map)` instead of `BeamModel`, and `getPoseMean` returning the heaviest cluster's mean; the
figures in docs/localiser.md say which was used).
"""

import argparse
import bisect
import json
import math
import sys

# Robotnik's Summit-XL AMCL configuration, as the `amcl` preset uses it (docs/localiser.md).
PARAMS = dict(
    min_particles=500,
    max_particles=5000,
    alpha=(0.2, 0.2, 0.8, 0.2, 0.1),
    z_hit=0.5,
    z_rand=0.5,
    sigma_hit=0.2,
    max_beams=30,
    update_min_d=0.2,
    update_min_a=0.5,
    init_cov=(0.25, 0.25, (math.pi / 12) ** 2),
)


def wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


def compose(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], wrap(a[2] + b[2]))


def between(a, b):
    """a^-1 * b."""
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return (c * dx + s * dy, -s * dx + c * dy, wrap(b[2] - a[2]))


def read_map(path):
    """ROS map_server YAML + binary PGM, as AMCL reads it (trinary)."""
    meta = {}
    with open(path) as f:
        for line in f:
            if ":" in line:
                k, v = line.split(":", 1)
                meta[k.strip()] = v.strip()
    image = meta["image"]
    if not image.startswith("/"):
        image = path.rsplit("/", 1)[0] + "/" + image if "/" in path else image
    origin = [float(x) for x in meta["origin"].strip("[]").split(",")]
    res = float(meta["resolution"])
    occ_t, free_t = float(meta["occupied_thresh"]), float(meta["free_thresh"])
    negate = int(meta.get("negate", "0"))
    with open(image, "rb") as f:
        data = f.read()
    fields, pos = [], 0
    while len(fields) < 4:
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b"#":
            pos = data.index(b"\n", pos) + 1
            continue
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        fields.append(data[pos:end])
        pos = end
    if fields[0] != b"P5":
        sys.exit(f"{image}: only binary PGM (P5) is read here")
    w, h, maxval = int(fields[1]), int(fields[2]), int(fields[3])
    pixels = data[pos + 1:pos + 1 + w * h]
    rows = []
    for r in range(h - 1, -1, -1):  # bottom row first: AMCL's cell (i, j) is row j from the origin
        row = []
        for v in pixels[r * w:(r + 1) * w]:
            p = v / maxval if negate else (maxval - v) / maxval
            row.append(100 if p > occ_t else (0 if p < free_t else -1))
        rows.append(row)
    return rows, res, origin[0], origin[1]


def read_log(path):
    """Steps of the log: (stamp, odom, truth, [scans]) with all scans of one stamp together."""
    odom, truth, scans = {}, {}, {}
    with open(path) as f:
        header = json.loads(f.readline())
        if header.get("format") != "mapkeeper-sensor-log":
            sys.exit(f"{path}: not a mapkeeper sensor log")
        for line in f:
            r = json.loads(line)
            t = r["stamp_ns"]
            if r["type"] == "odom":
                p = r["pose_in_odom"]
                odom[t] = (p["x"], p["y"], p["yaw"])
            elif r["type"] == "truth":
                p = r["pose_in_map"]
                truth[t] = (p["x"], p["y"], p["yaw"])
            elif r["type"] == "scan":
                scans.setdefault(t, []).append(r)
    steps = []
    for t in sorted(scans):
        if t in odom and t in truth:
            steps.append((t, odom[t], truth[t], sorted(scans[t], key=lambda s: s["lidar_id"])))
    return steps


def read_tum(path):
    out = []
    with open(path) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            t, x, y, _z, _qx, _qy, qz, qw = (float(v) for v in line.split())
            out.append((t, (x, y, 2.0 * math.atan2(qz, qw))))
    return out


def run_nav2(amcl, steps, grid):
    p = PARAMS
    motion = amcl.MotionParameters(*p["alpha"])
    laser = amcl.LaserParameters(
        z_hit=p["z_hit"], z_short=0.0, z_max=0.0, z_rand=p["z_rand"], sigma_hit=p["sigma_hit"],
        lambda_short=0.1, chi_outlier=0.0, max_beams=p["max_beams"])
    f = amcl.AMCL(p["min_particles"], p["max_particles"], 0.0, 0.0, motion, laser, "omni")
    rows, res, ox, oy = grid
    f.set_map(amcl.create_occupancy_grid_from_list(rows, res, ox, oy))
    _, _, truth0, _ = steps[0]
    f.set_initial_pose(amcl.Vector3D(*truth0), amcl.create_diagonal_covariance(*p["init_cov"]))
    estimates, filter_pose, filter_odom, updates = [], None, None, 0
    for t, odom, _truth, scans in steps:
        due = filter_odom is None or (
            abs(odom[0] - filter_odom[0]) > p["update_min_d"]
            or abs(odom[1] - filter_odom[1]) > p["update_min_d"]
            or abs(wrap(odom[2] - filter_odom[2])) > p["update_min_a"])
        if due:
            for s in scans:  # one sensor update and resampling per laser, as nav2_amcl
                m = s["lidar_in_robot"]
                f.set_laser_pose(amcl.Vector3D(m["x"], m["y"], 0.0))
                rmax = s["range_max_m"]
                pairs = []
                for i, r in enumerate(s["ranges_m"]):
                    bearing = m["yaw"] + s["angle_min_rad"] + i * s["angle_increment_rad"]
                    if r is None or not math.isfinite(r):
                        r = rmax
                    elif r <= s["range_min_m"]:
                        r = rmax
                    pairs.append([r, bearing])
                f.update(amcl.create_laser_scan_from_list(pairs, rmax), amcl.Vector3D(*odom))
                updates += 1
            e = f.get_pose_mean()
            filter_pose, filter_odom = (e.x, e.y, e.theta), odom
        estimates.append((t * 1e-9, compose(filter_pose, between(filter_odom, odom))))
    return estimates, updates


def errors(estimates, steps):
    """(position m, |yaw| deg) at each step, the estimate nearest in time at or before it."""
    times = [e[0] for e in estimates]
    out = []
    for t, _odom, truth, _scans in steps:
        k = bisect.bisect_right(times, t * 1e-9 + 1e-6) - 1
        if k < 0:
            continue
        e = estimates[k][1]
        out.append((math.hypot(e[0] - truth[0], e[1] - truth[1]), abs(math.degrees(wrap(e[2] - truth[2])))))
    return out


def stats(errs):
    pos = sorted(e[0] for e in errs)
    yaw = sorted(e[1] for e in errs)

    def q(v, f):
        return v[min(len(v) - 1, int(f * len(v)))]

    return {
        "steps": len(errs),
        "position_mean_m": sum(pos) / len(pos),
        "position_p90_m": q(pos, 0.9),
        "position_max_m": pos[-1],
        "yaw_mean_deg": sum(yaw) / len(yaw),
        "yaw_p90_deg": q(yaw, 0.9),
        "yaw_max_deg": yaw[-1],
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--log", required=True, help="a mapkeeper sensor log (log.jsonl) with truth records")
    ap.add_argument("--map", required=True, help="the map to localise on (ROS map_server YAML, PGM)")
    ap.add_argument("--ours", action="append", default=[], metavar="LABEL=TUM",
                    help="an estimate of `mapkeeper localise` to compare (repeatable)")
    ap.add_argument("--expect-model", choices=["beam", "likelihood_field"],
                    help="refuse to run unless the installed amcl module has this laser model")
    ap.add_argument("--json", help="write the figures here as JSON")
    args = ap.parse_args()
    try:
        import amcl
    except ImportError:
        sys.exit("the independent AMCL is not installed: pip install amcl (see the docstring)")
    with open(amcl._amcl_impl.__file__, "rb") as lib:
        # The model the binding constructs is the one whose vtable the library carries.
        model = "likelihood_field" if b"ZTVN9nav2_amcl20LikelihoodFieldModelE" in lib.read() else "beam"
    if args.expect_model and args.expect_model != model:
        sys.exit(f"the installed amcl module ({amcl.__file__}) has the {model} model, not {args.expect_model}")
    steps = read_log(args.log)
    if not steps:
        sys.exit(f"{args.log}: no step with odometry, truth and scans")
    grid = read_map(args.map)
    nav2, updates = run_nav2(amcl, steps, grid)
    result = {"log": args.log, "map": args.map, "nav2_amcl": {"laser_model": model, "sensor_updates": updates,
                                                               **stats(errors(nav2, steps))}}
    for spec in args.ours:
        label, path = spec.split("=", 1)
        result[label] = stats(errors(read_tum(path), steps))
    text = json.dumps(result, indent=1, sort_keys=True)
    print(text)
    if args.json:
        with open(args.json, "w") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
