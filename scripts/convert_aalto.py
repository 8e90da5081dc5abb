#!/usr/bin/python3
"""Convert the Aalto magnetic data (AaltoML/magnetic-data) into mm4mm session directories.

The data: a small wheeled robot driven over a marked area of about 6 m x 6 m, nine sequences of
about three minutes, three sensors (one folder each: invensense, nexus, trivisio). Per sequence
`<sensor>/<N>-time.csv` (s since the sequence's start), `<N>-loc.csv` (x, y in metres, Vicon
frame, 2-D: the sensor's position) and `<N>-mag.csv` (mx, my, mz: calibrated and already rotated
into the Vicon frame, the robot's attitude compensated), one row per sample in all three.
Sequences 1-5 see an unchanged magnetic field; in 6-9 large steel toolbox shelves were brought in.

Usage
-----
One sequence into one session directory:

    scripts/convert_aalto.py --data DATA --sensor invensense --seq 1 --out DIR \
        [--yaw-deg A] [--offset-x X] [--offset-y Y] [--id ID] [--force] ...

All nine sequences of one sensor (default invensense) with the fixed table of transforms below:

    scripts/convert_aalto.py --data DATA --all OUTDIR [--force]

DATA defaults to $AALTO_MAGNETIC_DATA. Needs Python 3 and numpy (Debian: python3-numpy; the
shebang is /usr/bin/python3 so that a pyenv or venv python without numpy is not picked up).

Output (magnetic-only session: no scans/, no lidar in session.yaml)
------
    DIR/session.yaml      comments with the source and the applied T_session_world, then
                          id and `magnetometers: [[0, 0, 0]]` (one sensor, at the body origin)
    DIR/poses.txt         keyframes in the session frame, TUM (t x y z qx qy qz qw)
    DIR/odometry.txt      the pose at every reading, session frame, TUM
    DIR/ground_truth.txt  the same keyframes in the Vicon (world) frame, TUM
    DIR/magnetometer.csv  t,sensor,bx,by,bz: every reading from the first to the last keyframe,
                          sensor 0, µT along the body axes
    --all also writes OUTDIR/truth.json: per session its sequence, yaw, offset and
    T_session_world (4x4 row-major), and the groups "unchanged_field" (1-5) and
    "shelves_added" (6-9). The true T_a_b of two sessions is T_a_world · T_b_world⁻¹.

The directory is built in DIR.tmp and renamed into place; an existing DIR is refused unless
--force (then it is replaced, never mixed with the old one).

Frames (this is the part to get right)
------
W: the Vicon frame (z up). S: the session frame. The user's transform is a rigid planar one,
T_S_W = [Rz(yaw) | (offset_x, offset_y, 0)], applied to everything; default the identity. Two
sequences converted with different transforms thus have a known relative transform
T_a_b = T_a_W · T_b_W⁻¹, which a matcher must recover; ground_truth.txt lets `mm4mm eval` compute
it exactly as for simulated sessions.

B: the body frame. The robot's orientation is not in the data (only readings already rotated
into W), so the body is given the heading of travel, taken from the Vicon positions over ±0.3 s
(held where the robot stands still or creeps below 5 cm/s): R_W_B = Rz(ψ). Where that says
nothing about the heading (below 5 cm/s, or where the direction of travel turns faster than
60°/s: the robot pivots, and its sensor, off the pivot axis, moves sideways) the readings are
dropped and counted, 1-14 % of them. The readings go into
that frame, b_B = R_W_Bᵀ · m_W, as a real robot's magnetometer reports them, so whatever of the
robot's own magnetism the data's calibration left (about 3 µT along the body, measured where the
robot crossed its own track at other headings) turns with the heading again, and mm4mm's
calibration can find it. Its origin is the sensor (the Vicon position is the sensor's), so the rig
is `magnetometers: [[0, 0, 0]]` and the height is counted once, in the poses' z
(= --sensor-height, default 0):

    ground_truth.txt  T_W_B(k) = [ Rz(ψ_k)        | (x_k, y_k, h) ]
    poses.txt         T_S_B(k) = T_S_W · T_W_B(k) = [ Rz(yaw + ψ_k) | Rz(yaw)·(x_k, y_k) + offset, h ]
    odometry.txt      the same at every reading (the pose stream mm4mm places readings by)

so roll = pitch = 0, levelling is the identity, and B_h = |(b_x, b_y)| = |(m_x, m_y)|, B_v = m_z
as in the data. --body-frame world keeps the former convention instead: R_W_B = I, readings as
the data gives them (already heading-compensated, so nothing is left to calibrate).

Keyframes and readings
----------------------
A keyframe at the first sample, then at the first sample after --keyframe-distance metres
travelled (default 0.25 m; the area is only 6 m across) or --keyframe-interval seconds (default
2 s) since the last keyframe, whichever comes first, and at the last sample. mm4mm places the
readings between keyframes by interpolating the keyframe poses in time, i.e. on the chord at
constant speed; where the robot turns sharply, reverses or changes speed that is several cm
off, so keyframes are then added (at the worst-placed sample, recursively) until no reading is
placed more than --max-placement-error from its own Vicon position (default 0.02 m; 0 turns this
off). That adds about a third more keyframes. The converter reports the remaining error.

Rows with a NaN or infinity in any of the three files are dropped and counted (trivisio/8 has
one: 5 NaN values). Times are written to 1 µs; a row whose time repeats the previous one's (to
1 µs) is dropped and counted; times going backwards are an error. A row whose position is
further from the last kept row's than --max-speed (default 5 m/s) allows is a Vicon glitch and is
dropped and counted (nexus/3 has one, a 0.27 m jump for one sample at 182.71 s; the robot itself
drives below 1.5 m/s, and trivisio's positions jitter by 2-3 cm between 10 ms samples).

trivisio: its readings are normalised so that |B| ≈ 1 (the calibration sphere's radius); they are
multiplied by --trivisio-scale-uT (default 50 µT, a typical Earth field, NOT a measured value),
so absolute trivisio values in µT are only nominal. invensense and nexus are in µT already.

--all: the nine sequences of --sensor (default invensense) go to OUTDIR/seq1 … seq9 (ids seq1 …
seq9) with the transforms of ALL_TRANSFORMS below, a fixed table drawn once with
numpy.random.default_rng(2018): for N = 1..9 in order, yaw = uniform(-180, 180) deg then
(offset_x, offset_y) = uniform(-5, 5, 2) m, rounded to 0.1 deg and 1 mm. The table, not the
generator, is authoritative.

Exit codes: 0 success, 2 bad input or refused (message on stderr).
"""

import argparse
import json
import math
import os
import shutil
import sys

import numpy as np

from aalto_trajectory import (heading_reliable, interpolation_error, position_glitches,
                              refine_keyframes, select_keyframes, travel_headings)

SENSORS = ("invensense", "nexus", "trivisio")

# sequence -> (yaw_deg, offset_x_m, offset_y_m); see the docstring for how it was drawn.
ALL_TRANSFORMS = {
    1: (-4.5, -3.208, 4.106),
    2: (177.1, -3.612, -3.169),
    3: (163.8, 1.158, -2.455),
    4: (103.4, 2.146, 4.319),
    5: (-59.4, 1.729, -3.872),
    6: (-178.7, -3.567, 3.253),
    7: (165.0, -3.450, -0.176),
    8: (161.4, 3.020, -1.201),
    9: (-27.5, -2.429, 3.523),
}
GROUPS = {"unchanged_field": [1, 2, 3, 4, 5], "shelves_added": [6, 7, 8, 9]}

MAX_FIELD_UT = 1000.0  # mm4mm's reader refuses readings above this


class InputProblem(Exception):
    """Bad input or a refused request: reported on stderr, exit code 2."""


# ---- reading ------------------------------------------------------------------------------


def load_csv(path, columns):
    if not os.path.isfile(path):
        raise InputProblem(f"{path}: not found")
    try:
        values = np.loadtxt(path, delimiter=",", ndmin=2, dtype=float)
    except ValueError as e:
        raise InputProblem(f"{path}: not a numeric CSV ({e})")
    if values.shape[1] != columns:
        raise InputProblem(f"{path}: expected {columns} columns, got {values.shape[1]}")
    return values


def load_sequence(data_dir, sensor, seq, trivisio_scale_uT, max_speed):
    """Returns (t, xy, mag_uT, stats) with bad and duplicate rows removed."""
    base = os.path.join(data_dir, sensor, str(seq))
    t = load_csv(base + "-time.csv", 1)[:, 0]
    xy = load_csv(base + "-loc.csv", 2)
    mag = load_csv(base + "-mag.csv", 3)
    if not (len(t) == len(xy) == len(mag)):
        raise InputProblem(f"{base}-*.csv: row counts differ (time {len(t)}, loc {len(xy)}, "
                           f"mag {len(mag)})")
    stats = {"rows": len(t)}
    finite = np.isfinite(t) & np.isfinite(xy).all(axis=1) & np.isfinite(mag).all(axis=1)
    stats["nonfinite_rows_dropped"] = int((~finite).sum())
    t, xy, mag = t[finite], xy[finite], mag[finite]
    if len(t) < 2:
        raise InputProblem(f"{base}-*.csv: fewer than two usable rows")

    t_us = np.round(t * 1e6).astype(np.int64)  # the 1 µs that magnetometer.csv keeps
    step = np.diff(t_us)
    if (step < 0).any():
        i = int(np.argmax(step < 0)) + 1
        raise InputProblem(f"{base}-time.csv: time {t[i]} goes back from {t[i - 1]}")
    keep = np.concatenate([[True], step > 0])
    stats["duplicate_times_dropped"] = int((~keep).sum())
    t, xy, mag = t_us[keep] / 1e6, xy[keep], mag[keep]

    glitch = position_glitches(t, xy, max_speed)
    stats["position_glitches_dropped"] = int(glitch.sum())
    if glitch.sum() > 0.01 * len(t):
        raise InputProblem(f"{base}-loc.csv: {glitch.sum()} of {len(t)} positions would need "
                           f"over {max_speed:g} m/s; a bad first row or a too low --max-speed")
    t, xy, mag = t[~glitch], xy[~glitch], mag[~glitch]

    if sensor == "trivisio":
        mag = mag * trivisio_scale_uT
    magnitude = np.linalg.norm(mag, axis=1)
    if (magnitude > MAX_FIELD_UT).any():
        raise InputProblem(f"{base}-mag.csv: a reading of {magnitude.max():.1f} µT (over 1000)")
    stats["field_uT_median"] = float(np.median(magnitude))
    return t, xy, mag, stats


# ---- keyframes and transforms ---------------------------------------------------------------


def planar_transform(yaw_deg, offset_x, offset_y):
    """T_session_world as a 4x4 matrix."""
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    return np.array([[c, -s, 0.0, offset_x], [s, c, 0.0, offset_y], [0.0, 0.0, 1.0, 0.0],
                     [0.0, 0.0, 0.0, 1.0]])


def matrix_rows(T):
    """A 4x4 as a nested list, with round-off below 1e-15 cleaned to exact numbers."""
    return [[float(round(v, 15)) + 0.0 for v in row] for row in T]


# ---- writing --------------------------------------------------------------------------------


def format_json(value, indent=""):
    """JSON with lists of numbers (matrix rows, offsets) kept on one line."""
    inner = indent + "  "
    if isinstance(value, dict):
        items = [f"{inner}{json.dumps(k)}: {format_json(v, inner)}" for k, v in value.items()]
        return "{\n" + ",\n".join(items) + "\n" + indent + "}"
    if isinstance(value, list) and any(isinstance(v, (list, dict)) for v in value):
        items = [inner + format_json(v, inner) for v in value]
        return "[\n" + ",\n".join(items) + "\n" + indent + "]"
    return json.dumps(value, ensure_ascii=False)


def write_text(path, text):
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.write(text)


def yaw_quaternion(yaw_rad):
    return (0.0, 0.0, math.sin(yaw_rad / 2.0), math.cos(yaw_rad / 2.0))


def tum_stream(t, positions, yaws):
    lines = ["# t x y z qx qy qz qw"]
    for ti, p, yaw in zip(t, positions, yaws):
        qx, qy, qz, qw = (0.0 if abs(v) < 1e-15 else v for v in yaw_quaternion(yaw))
        lines.append(f"{ti:.6f} {p[0]:.6f} {p[1]:.6f} {p[2]:.6f} "
                     f"{qx:.12g} {qy:.12g} {qz:.12g} {qw:.12g}")
    return "\n".join(lines) + "\n"


def write_session(dir_path, session_id, source, t, xy, mag, kf, yaw_deg, offset, height_m,
                  body_frame, extra_comments=()):
    """Writes a complete session into dir_path (which must not exist yet)."""
    T = planar_transform(yaw_deg, *offset)
    R = T[:2, :2]
    psi = travel_headings(t, xy) if body_frame == "heading" else np.zeros(len(t))
    world = np.column_stack([xy, np.full(len(t), height_m)])
    session = np.column_stack([xy @ R.T + np.asarray(offset), np.full(len(t), height_m)])
    yaw = math.radians(yaw_deg)
    c, s_ = np.cos(psi), np.sin(psi)
    body = np.column_stack([c * mag[:, 0] + s_ * mag[:, 1], -s_ * mag[:, 0] + c * mag[:, 1],
                            mag[:, 2]])

    rows = ",\n ".join("[" + ", ".join(f"{v:.12g}" for v in row) + "]" for row in T)
    rows = "[" + rows + "]"
    frame_comments = (
        ["# Body frame: the heading of travel (from the Vicon positions), so magnetometer.csv",
         "# holds the readings turned into it; ground_truth.txt has the keyframes in the Vicon",
         "# frame. Magnetic-only: no scans/, no lidar."]
        if body_frame == "heading" else
        ["# Body axes = world (Vicon) axes, so every keyframe's session-frame orientation is the",
         "# yaw above and magnetometer.csv holds the world-frame field; ground_truth.txt has the",
         "# keyframes in the Vicon frame. Magnetic-only: no scans/, no lidar."])
    yaml = "\n".join([
        f"# Converted by mm4mm scripts/convert_aalto.py from the Aalto magnetic data, {source}.",
        "# Applied rigid planar transform T_session_world (session frame <- Vicon frame):",
        f"#   yaw_deg: {yaw_deg:.12g}",
        f"#   offset_m: [{offset[0]:.12g}, {offset[1]:.12g}]",
        "#   T_session_world (4x4 row-major):",
        *("#    " + line for line in rows.splitlines()),
        *frame_comments,
        *("# " + c for c in extra_comments),
        f"id: {session_id}",
        "magnetometers:                 # the Vicon position is the sensor's: body origin",
        "  - [0.0, 0.0, 0.0]",
    ]) + "\n"

    t0, t1 = t[kf[0]], t[kf[-1]]
    inside = (t >= t0) & (t <= t1)
    reliable = heading_reliable(t, xy, psi) if body_frame == "heading" else np.ones(len(t), bool)
    written = inside & reliable
    csv = ["t,sensor,bx,by,bz"]
    csv += [f"{ti:.6f},0,{b[0]:.4f},{b[1]:.4f},{b[2]:.4f}"
            for ti, b in zip(t[written], body[written])]

    os.makedirs(dir_path)
    write_text(os.path.join(dir_path, "session.yaml"), yaml)
    write_text(os.path.join(dir_path, "poses.txt"), tum_stream(t[kf], session[kf], yaw + psi[kf]))
    if body_frame == "heading":
        write_text(os.path.join(dir_path, "odometry.txt"),
                   tum_stream(t[inside], session[inside], yaw + psi[inside]))
    write_text(os.path.join(dir_path, "ground_truth.txt"), tum_stream(t[kf], world[kf], psi[kf]))
    write_text(os.path.join(dir_path, "magnetometer.csv"), "\n".join(csv) + "\n")
    return int(written.sum()), int((inside & ~reliable).sum()), T


def staged_replace(target, force, build):
    """Calls build(staging_dir), then renames staging_dir to target (replacing it if force)."""
    target = os.path.abspath(target).rstrip(os.sep)
    if os.path.lexists(target) and not force:
        raise InputProblem(f"{target}: exists; use --force to replace it")
    staging = target + ".tmp"
    if os.path.lexists(staging):
        shutil.rmtree(staging)
    os.makedirs(os.path.dirname(target), exist_ok=True)
    try:
        result = build(staging)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    if os.path.lexists(target):
        old = target + ".old"
        if os.path.lexists(old):
            shutil.rmtree(old)
        os.rename(target, old)
        os.rename(staging, target)
        shutil.rmtree(old)
    else:
        os.rename(staging, target)
    return result


# ---- commands -------------------------------------------------------------------------------


def convert(args, sensor, seq, dir_path, shown_path, session_id, yaw_deg, offset, log):
    t, xy, mag, stats = load_sequence(args.data, sensor, seq, args.trivisio_scale_uT,
                                      args.max_speed)
    kf = select_keyframes(t, xy, args.keyframe_distance, args.keyframe_interval)
    regular = len(kf)
    kf = refine_keyframes(t, xy, kf, args.max_placement_error)
    source = f"{sensor}/{seq}"
    extra = []
    if sensor == "trivisio":
        extra.append(f"trivisio readings (normalised, |B| ~ 1) scaled by "
                     f"{args.trivisio_scale_uT:g} µT: nominal, not measured, µT.")
    readings, pivoting, T = write_session(dir_path, session_id, source, t, xy, mag, kf, yaw_deg,
                                          offset, args.sensor_height, args.body_frame, extra)
    path_m = float(np.linalg.norm(np.diff(xy, axis=0), axis=1).sum())
    err = interpolation_error(t, xy, kf)
    log(f"{source} -> {shown_path}: {stats['rows']} rows, "
        f"{stats['nonfinite_rows_dropped']} with NaN/inf dropped, "
        f"{stats['duplicate_times_dropped']} duplicate times and "
        f"{stats['position_glitches_dropped']} position glitches dropped; {len(kf)} keyframes "
        f"({len(kf) - regular} added for placement) over "
        f"{path_m:.1f} m and {t[kf[-1]] - t[kf[0]]:.1f} s; {readings} readings ({pivoting} "
        f"dropped where standing or pivoting hides the heading), median "
        f"|B| {stats['field_uT_median']:.1f} µT; placement by keyframe interpolation off by "
        f"median {1000 * np.median(err):.1f} mm, max {1000 * err.max():.1f} mm")
    return T, {"keyframes": int(len(kf)), "readings": readings,
               "readings_dropped_heading_unknown": pivoting,
               "nonfinite_rows_dropped": stats["nonfinite_rows_dropped"],
               "duplicate_times_dropped": stats["duplicate_times_dropped"],
               "position_glitches_dropped": stats["position_glitches_dropped"]}
    if sensor == "trivisio":
        log(f"  trivisio: readings scaled by --trivisio-scale-uT {args.trivisio_scale_uT:g} "
            f"(normalised data; the µT values are nominal)")


def run_single(args, log):
    if args.sensor is None or args.seq is None or args.out is None:
        raise InputProblem("give --sensor, --seq and --out (or --all OUTDIR)")
    session_id = args.id if args.id is not None else os.path.basename(
        os.path.abspath(args.out).rstrip(os.sep))
    if not session_id or "/" in session_id or "\\" in session_id or session_id in (".", ".."):
        raise InputProblem(f"id '{session_id}' is not usable as a file name")
    yaw = args.yaw_deg if args.yaw_deg is not None else 0.0
    offset = (args.offset_x or 0.0, args.offset_y or 0.0)
    staged_replace(args.out, args.force,
                   lambda staging: convert(args, args.sensor, args.seq, staging,
                                           os.path.abspath(args.out), session_id, yaw, offset,
                                           log))
    log(f"wrote {os.path.abspath(args.out)} (T_session_world: yaw {yaw:g} deg, offset "
        f"({offset[0]:g}, {offset[1]:g}) m)")


def run_all(args, log):
    if any(v is not None for v in (args.seq, args.out, args.id, args.yaw_deg, args.offset_x,
                                   args.offset_y)):
        raise InputProblem("--all takes its transforms from the fixed table; do not combine it "
                           "with --seq, --out, --id, --yaw-deg or --offset-x/-y")
    sensor = args.sensor or "invensense"

    def build(staging):
        os.makedirs(staging)
        sessions = {}
        for seq, (yaw, ox, oy) in sorted(ALL_TRANSFORMS.items()):
            name = f"seq{seq}"
            T, counts = convert(args, sensor, seq, os.path.join(staging, name),
                                os.path.join(os.path.abspath(args.all), name), name, yaw,
                                (ox, oy), log)
            sessions[name] = {"sequence": seq, "sensor": sensor, "yaw_deg": yaw,
                              "offset_m": [ox, oy], "T_session_world": matrix_rows(T), **counts}
        truth = {
            "source": "Aalto magnetic data (AaltoML/magnetic-data), converted by "
                      "scripts/convert_aalto.py --all",
            "convention": "T_session_world: session frame <- Vicon world frame, 4x4 row-major; "
                          "true T_a_b = T_a_world * inverse(T_b_world)",
            "sensor": sensor,
            "keyframe_distance_m": args.keyframe_distance,
            "keyframe_interval_s": args.keyframe_interval,
            "max_placement_error_m": args.max_placement_error,
            "sensor_height_m": args.sensor_height,
            "body_frame": args.body_frame,
            "sessions": sessions,
            "groups": {group: [f"seq{n}" for n in seqs] for group, seqs in GROUPS.items()},
        }
        if sensor == "trivisio":
            truth["trivisio_scale_uT"] = args.trivisio_scale_uT
        write_text(os.path.join(staging, "truth.json"), format_json(truth) + "\n")

    staged_replace(args.all, args.force, build)
    log(f"wrote {os.path.abspath(args.all)}: seq1 … seq9 and truth.json")


def parse_args(argv):
    parser = argparse.ArgumentParser(
        description="Convert Aalto magnetic data sequences into mm4mm session directories "
                    "(see the docstring at the top of this script for the frames).")
    parser.add_argument("--data", default=os.environ.get("AALTO_MAGNETIC_DATA"),
                        help="the data directory holding invensense/ nexus/ trivisio/ "
                             "(default: $AALTO_MAGNETIC_DATA)")
    parser.add_argument("--sensor", choices=SENSORS,
                        help="sensor folder (required for one sequence; --all: invensense)")
    parser.add_argument("--seq", type=int, choices=range(1, 10), metavar="N",
                        help="sequence number 1-9")
    parser.add_argument("--out", help="session directory to write")
    parser.add_argument("--id", help="session id (default: the name of --out)")
    parser.add_argument("--all", metavar="OUTDIR",
                        help="convert all nine sequences into OUTDIR/seq1 … seq9 with the fixed "
                             "transform table, and write OUTDIR/truth.json")
    parser.add_argument("--yaw-deg", type=float, help="yaw of T_session_world (deg, default 0)")
    parser.add_argument("--offset-x", type=float, help="x of T_session_world (m, default 0)")
    parser.add_argument("--offset-y", type=float, help="y of T_session_world (m, default 0)")
    parser.add_argument("--keyframe-distance", type=float, default=0.25,
                        help="a keyframe every this many metres travelled (default 0.25)")
    parser.add_argument("--keyframe-interval", type=float, default=2.0,
                        help="and at least every this many seconds (default 2)")
    parser.add_argument("--max-placement-error", type=float, default=0.02,
                        help="add keyframes until interpolating them places every reading "
                             "within this of its Vicon position (m, default 0.02; 0: off)")
    parser.add_argument("--max-speed", type=float, default=5.0,
                        help="drop a row whose position is further than this speed allows from "
                             "the last kept row's (m/s, default 5; the robot drives < 1.5 m/s, "
                             "trivisio's position jitter reaches 3 m/s)")
    parser.add_argument("--sensor-height", type=float, default=0.0,
                        help="z of the keyframes (m, default 0); the magnetometer sits at the "
                             "body origin")
    parser.add_argument("--trivisio-scale-uT", type=float, default=50.0,
                        help="µT per unit of the normalised trivisio readings (default 50)")
    parser.add_argument("--body-frame", choices=("heading", "world"), default="heading",
                        help="body axes along the heading of travel (default; the readings "
                             "turned into them) or the data's world axes")
    parser.add_argument("--force", action="store_true", help="replace an existing output")
    args = parser.parse_args(argv)
    if not args.data:
        parser.error("give --data DIR or set AALTO_MAGNETIC_DATA")
    for name in ("yaw_deg", "offset_x", "offset_y", "sensor_height", "trivisio_scale_uT",
                 "keyframe_distance", "keyframe_interval", "max_placement_error", "max_speed"):
        value = getattr(args, name)
        if value is not None and not math.isfinite(value):
            parser.error(f"--{name.replace('_', '-')} must be finite")
    if not args.keyframe_distance > 0 or not args.keyframe_interval > 0:
        parser.error("--keyframe-distance and --keyframe-interval must be > 0")
    if not args.max_speed > 0:
        parser.error("--max-speed must be > 0")
    if not args.trivisio_scale_uT > 0:
        parser.error("--trivisio-scale-uT must be > 0")
    return args


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)

    def log(message):
        print(message, flush=True)

    try:
        if args.all is not None:
            run_all(args, log)
        else:
            run_single(args, log)
    except InputProblem as e:
        print(f"convert_aalto: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
