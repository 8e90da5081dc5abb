#!/usr/bin/env python3
"""Plots scale_bench's CSV: merge time, magnetic matches and the memory a merge adds (its peak
RSS above the RSS before it, which holds the sessions) against the number of sessions, one line
per matching strategy (log-log where growth rates matter).

Usage: plot_scale_bench.py SCALE_BENCH.csv OUT.png
"""
import csv
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: plot_scale_bench.py SCALE_BENCH.csv OUT.png")
    with open(sys.argv[1], newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"plot_scale_bench: no rows in {sys.argv[1]}")
    series = defaultdict(list)
    for r in rows:
        series[r["strategy"]].append(r)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5))
    for r in rows:
        r["added_mb"] = float(r["peak_rss_mb"]) - float(r["rss_before_mb"])
    panels = [("seconds", "merge time (s)", True), ("magnetic_matches", "magnetic matches run", True),
              ("added_mb", "memory added (MB, peak - before)", False)]
    for ax, (field, label, log) in zip(axes, panels):
        for strategy, points in series.items():
            points.sort(key=lambda r: int(r["sessions"]))
            ax.plot([int(r["sessions"]) for r in points], [float(r[field]) for r in points],
                    marker="o", label=strategy)
        ax.set_xscale("log", base=2)
        if log:
            ax.set_yscale("log")
        ax.set_xlabel("sessions")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    fig.suptitle("mm4mm merge against the number of sessions (170 m x 75 m warehouse)")
    fig.tight_layout()
    fig.savefig(sys.argv[2], dpi=100)


if __name__ == "__main__":
    main()
