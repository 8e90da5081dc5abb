#!/usr/bin/python3
"""Fits the matcher's confidence model: the probability that a match's best mode is right (aligned
within 0.5 m and 2 degrees) from its features, by L2-regularised logistic regression on tuning
runs of bench/match_bench with the rule opened up (scripts/procedural_tuning.sh), and chooses the
probability a match must reach to be accepted.

Usage: scripts/fit_match_confidence.py [--out-md FILE] TUNING_CSV [TUNING_CSV ...]

Rows: overlapping pairs (label: aligned) and separate pairs (label 0); pairs that share a few
keyframes only are left out (their truth is neither). Seeds above 20 are refused: the model is
fitted on tuning seeds only.

Features (as src/magnetic/match_confidence.cpp computes them from a MagneticMatchResult):
  atanh(r)                     how well the fields agree
  log(overlap m2)              how much they share
  second-mode ratio            how close the best distinct rival comes (capped at 1.5)
  log(length / width)          the overlap's shape: a strip of one pass is long and thin
  log(field std uT)            how much field the overlap holds
  log(yaw uncertainty deg)     how well the yaw is pinned (capped at 30 degrees)
  single track                 1 where either session is one magnetometer's track

The threshold: from leave-one-seed-out probabilities (each seed's pairs scored by a model fitted
without that seed), the lowest probability at which no wrong pair (a misplaced overlap or a
separate pair) is accepted and at which the next lower grid step accepts at most 1 % wrong; it
is then never below 0.5. The model printed last is fitted on every row.
"""
import argparse
import csv
import math
import sys

import numpy as np

FEATURES = ["atanh_r", "log_overlap_m2", "second_mode_ratio", "log_aspect", "log_field_std",
            "log_yaw_uncertainty", "single_track"]
SINGLE_TRACK_RIGS = {"imu", "handheld"}
LAMBDA = 1.0  # L2 weight on the standardised coefficients (not the intercept)


def features(row):
    r = min(max(float(row["r"]), -0.999), 0.999)
    overlap = max(float(row["overlap_m2"]), 1.0)
    length = max(float(row["overlap_length_m"]), 0.1)
    width = max(float(row["overlap_width_m"]), 0.1)
    return [math.atanh(r), math.log(overlap), min(float(row["second_mode_ratio"]), 1.5),
            math.log(length / width), math.log(max(float(row["field_std_uT"]), 0.05)),
            math.log(min(max(float(row["yaw_uncertainty_deg"]), 0.1), 30.0)),
            1.0 if row["rig"] in SINGLE_TRACK_RIGS else 0.0]


def fit(x, y):
    """Newton's method on the penalised log-likelihood; x standardised, first column 1."""
    w = np.zeros(x.shape[1])
    penalty = LAMBDA * np.eye(x.shape[1])
    penalty[0, 0] = 0.0
    for _ in range(100):
        p = 1.0 / (1.0 + np.exp(-x @ w))
        gradient = x.T @ (y - p) - penalty @ w
        hessian = x.T @ (x * (p * (1 - p))[:, None]) + penalty
        step = np.linalg.solve(hessian, gradient)
        w += step
        if np.max(np.abs(step)) < 1e-10:
            break
    return w


class Model:
    def __init__(self, raw, y):
        self.mean = raw.mean(axis=0)
        self.scale = raw.std(axis=0)
        self.scale[self.scale == 0] = 1.0
        self.w = fit(self.design(raw), y)

    def design(self, raw):
        return np.hstack([np.ones((len(raw), 1)), (raw - self.mean) / self.scale])

    def probability(self, raw):
        return 1.0 / (1.0 + np.exp(-self.design(raw) @ self.w))

    def raw_coefficients(self):
        """Intercept and weights on the unstandardised features."""
        weights = self.w[1:] / self.scale
        return self.w[0] - float(weights @ self.mean), weights


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("csv", nargs="+")
    parser.add_argument("--out-md", default=None)
    args = parser.parse_args()
    rows = []
    for path in args.csv:
        for r in csv.DictReader(open(path)):
            if int(r["seed"]) > 20:
                raise SystemExit(f"{path} holds seed {r['seed']}: the model is fitted on tuning seeds 1-20 only")
            if r["overlapping"] == "1" or r["separate"] == "1":
                if not math.isfinite(float(r["z"])) or float(r["overlap_m2"]) <= 0:
                    continue  # no mode at all: nothing to judge, refused whatever the model says
                rows.append(r)
    raw = np.array([features(r) for r in rows])
    y = np.array([1.0 if r["overlapping"] == "1" and r["aligned"] == "1" else 0.0 for r in rows])
    groups = np.array([f"{r['preset']}|{r['seed']}" for r in rows])
    out = []

    def say(line=""):
        out.append(line)
        print(line)

    say(f"{len(rows)} pairs from {', '.join(args.csv)}: {int(y.sum())} aligned overlaps, "
        f"{sum(1 for r in rows if r['overlapping'] == '1' and r['aligned'] != '1')} misplaced overlaps, "
        f"{sum(1 for r in rows if r['separate'] == '1')} separate pairs")
    # Leave one seed (world) out.
    held = np.zeros(len(rows))
    for g in sorted(set(groups)):
        test = groups == g
        if y[~test].min() == y[~test].max():
            held[test] = y[~test][0]
            continue
        held[test] = Model(raw[~test], y[~test]).probability(raw[test])
    grid = [round(0.05 * k, 2) for k in range(10, 20)] + [0.96, 0.97, 0.98, 0.99]

    def outcome(threshold):
        accept = held >= threshold
        right = int(np.sum(accept & (y == 1)))
        wrong = int(np.sum(accept & (y == 0)))
        return right, wrong

    say("")
    say("Leave-one-seed-out, accepted at probability >= p:")
    say("")
    say("| p | accepted aligned | accepted wrong | wrong share |")
    say("|---|---|---|---|")
    for t in grid:
        right, wrong = outcome(t)
        share = wrong / max(right + wrong, 1)
        say(f"| {t:.2f} | {right} of {int(y.sum())} | {wrong} | {100 * share:.1f} % |")
    pick = None
    for i, t in enumerate(grid):
        right, wrong = outcome(t)
        lower = grid[i - 1] if i > 0 else None
        lower_ok = lower is None or outcome(lower)[1] <= 0.01 * max(sum(outcome(lower)), 1)
        if wrong == 0 and lower_ok:
            pick = t
            break
    if pick is None:
        pick = grid[-1]
    right, wrong = outcome(pick)
    say("")
    say(f"Pick: p >= {pick:.2f} ({right} of {int(y.sum())} aligned overlaps accepted, {wrong} wrong, "
        f"leave-one-seed-out)")
    # The z / r thresholds the matcher decides with (magnetic_matcher.hpp), on the same rows.
    def old_rule(r):
        single = r["rig"] in SINGLE_TRACK_RIGS
        min_z, min_r = (3.5, 0.85) if single else (8.0, 0.825)
        return (float(r["z"]) >= min_z and float(r["r"]) >= min_r and float(r["second_mode_ratio"]) <= 0.75
                and float(r["yaw_uncertainty_deg"]) <= 2.0)
    old = np.array([old_rule(r) for r in rows])
    say(f"The z / r thresholds (z >= 8, r >= 0.825; single track z >= 3.5, r >= 0.85; second-mode ratio <= 0.75; "
        f"yaw +-2 deg): {int(np.sum(old & (y == 1)))} of {int(y.sum())} aligned overlaps accepted, "
        f"{int(np.sum(old & (y == 0)))} wrong")
    # The probability rule with the yaw rule beside it, as the matcher applies it.
    yaw_ok = np.array([float(r["yaw_uncertainty_deg"]) <= 2.0 for r in rows])
    both = (held >= pick) & yaw_ok
    say(f"The probability rule with the yaw rule (+-2 deg) beside it: {int(np.sum(both & (y == 1)))} of "
        f"{int(y.sum())} aligned accepted, {int(np.sum(both & (y == 0)))} wrong (leave-one-seed-out)")
    # Reliability: predicted against observed.
    say("")
    say("| predicted (leave-one-seed-out) | pairs | aligned |")
    say("|---|---|---|")
    for lo, hi in [(0, 0.1), (0.1, 0.3), (0.3, 0.5), (0.5, 0.7), (0.7, 0.9), (0.9, 1.01)]:
        sel = (held >= lo) & (held < hi)
        if sel.any():
            say(f"| {lo:.1f}-{min(hi, 1):.1f} | {int(sel.sum())} | {100 * y[sel].mean():.0f} % |")
    model = Model(raw, y)
    intercept, weights = model.raw_coefficients()
    say("")
    say("Model on every row (raw features; src/magnetic/match_confidence.hpp):")
    say("")
    say(f"    intercept: {intercept:.4f}")
    for name, w in zip(FEATURES, weights):
        say(f"    {name}: {w:.4f}")
    say(f"    min_probability: {pick:.2f}")
    if args.out_md:
        with open(args.out_md, "w") as f:
            f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
