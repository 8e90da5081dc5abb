#!/usr/bin/python3
"""Spatial statistics of the magnetic field along session tracks: how strong the field's
anomalies are and over what distance they decorrelate. Compares simulated sessions with real
recordings (the Aalto robot's, converted by scripts/convert_aalto.py).

Usage: scripts/field_statistics.py [--csv FILE] LABEL=SESSION_DIR [LABEL=SESSION_DIR ...]

Per session, one magnetometer (sensor 0): each reading is levelled with the attitude of the
odometry stream (odometry.txt, else poses.txt, interpolated at the reading's time) and reduced to
B_h = |horizontal| and B_v (µT). Printed per session: the standard deviation of B_h and B_v about
their means, and the correlation of B_h anomalies between readings a distance d apart in the
plane (every pair of up to 4000 evenly subsampled readings within ±20 % of d: along the track
and across passes), at d = 0.25, 0.5, 1 and 2 m, and the correlation length (first d where it falls
below 0.5). Simulated readings must come from clean sensors (magnetometer_errors.model: clean) so
that the statistics are the field's, not the sensor's errors'.
"""
import argparse
import csv
import sys

import numpy as np


def read_tum(path):
    rows = [l.split() for l in open(path) if l.strip() and not l.startswith("#")]
    return np.array(rows, dtype=float)


def quat_to_matrix(q):
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def session_readings(directory):
    poses_path = f"{directory}/odometry.txt"
    try:
        poses = read_tum(poses_path)
    except FileNotFoundError:
        poses = read_tum(f"{directory}/poses.txt")
    mag = np.array([[float(v) for v in row] for row in list(csv.reader(open(f"{directory}/magnetometer.csv")))[1:]])
    mag = mag[mag[:, 1] == 0]
    mag = mag[(mag[:, 0] >= poses[0, 0]) & (mag[:, 0] <= poses[-1, 0])]
    index = np.clip(np.searchsorted(poses[:, 0], mag[:, 0]), 1, len(poses) - 1)
    # Nearest pose's attitude (50 Hz or denser: well under a degree between poses), linear position.
    t0, t1 = poses[index - 1, 0], poses[index, 0]
    f = ((mag[:, 0] - t0) / np.maximum(t1 - t0, 1e-9))[:, None]
    position = (1 - f) * poses[index - 1, 1:3] + f * poses[index, 1:3]
    nearest = np.where(f[:, 0] < 0.5, index - 1, index)
    world = np.array([quat_to_matrix(poses[k, 4:8]) @ m for k, m in zip(nearest, mag[:, 2:5])])
    return mag[:, 0], position, np.hypot(world[:, 0], world[:, 1]), world[:, 2]


def correlation_curve(p, values, distances, max_readings=4000):
    """ρ(d) of the anomalies over every pair of (a subsample of) the readings within ±20 % of d."""
    step = max(1, len(values) // max_readings)
    p, anomaly = p[::step], values[::step] - values.mean()
    distance = np.linalg.norm(p[:, None, :] - p[None, :, :], axis=2)
    upper = np.triu(np.ones_like(distance, dtype=bool), 1)
    rho = []
    for d in distances:
        i, j = np.nonzero(upper & (np.abs(distance - d) <= 0.2 * d))
        rho.append(float(np.corrcoef(anomaly[i], anomaly[j])[0, 1]) if len(i) >= 100 else float("nan"))
    return rho


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("sessions", nargs="+", help="LABEL=SESSION_DIR")
    parser.add_argument("--csv")
    args = parser.parse_args()
    distances = [0.25, 0.5, 1.0, 2.0]
    grid = np.arange(0.1, 3.01, 0.1)
    rows = []
    for item in args.sessions:
        if "=" not in item:
            sys.exit(f"expected LABEL=SESSION_DIR, got {item}")
        label, directory = item.split("=", 1)
        t, p, bh, bv = session_readings(directory)
        rho = correlation_curve(p, bh, distances)
        curve = correlation_curve(p, bh, grid)
        below = [d for d, r in zip(grid, curve) if np.isfinite(r) and r < 0.5]
        length = below[0] if below else float("nan")
        rows.append([label, directory, len(t), bh.std(), bv.std()] + rho + [length])
    print("| session | readings | B_h std (µT) | B_v std (µT) | ρ(0.25 m) | ρ(0.5 m) | ρ(1 m) | ρ(2 m) | "
          "correlation length (ρ < 0.5, m) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[2]} | {r[3]:.1f} | {r[4]:.1f} | " + " | ".join(f"{v:.2f}" for v in r[5:9]) +
              (f" | {r[9]:.1f} |" if np.isfinite(r[9]) else f" | > {grid[-1]:.0f} |"))
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["session", "directory", "readings", "bh_std_uT", "bv_std_uT", "rho_0.25m", "rho_0.5m",
                        "rho_1m", "rho_2m", "correlation_length_m"])
            for r in rows:
                w.writerow([r[0], r[1], r[2]] + [f"{v:.4f}" for v in r[3:]])


if __name__ == "__main__":
    main()
