#!/usr/bin/env python3
"""Plots add_bench's CSV: the seconds of each add against the number of sessions already in the
atlas, stacked by stage (loading the atlas, the session's match / refinement / solve, rewriting
the outputs), with the 10 s target of issue 6; and the add's peak memory.

Usage: plot_add_bench.py ADD_BENCH.csv OUT.png
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: plot_add_bench.py ADD_BENCH.csv OUT.png")
    with open(sys.argv[1], newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"plot_add_bench: no rows in {sys.argv[1]}")
    x = [int(r["sessions_before"]) for r in rows]
    stages = [("load_s", "load atlas"), ("maps_s", "magnetic maps"), ("matching_s", "matching"),
              ("refinement_s", "ICP-EM + edges"), ("solve_s", "solve"), ("write_s", "rewrite outputs")]
    fig, (ax, mem) = plt.subplots(1, 2, figsize=(13, 4.5))
    bottom = [0.0] * len(rows)
    for field, label in stages:
        values = [float(r[field]) for r in rows]
        ax.bar(x, values, bottom=bottom, label=label)
        bottom = [b + v for b, v in zip(bottom, values)]
    ax.axhline(10.0, color="black", linestyle="--", linewidth=1, label="target 10 s")
    ax.set_xlabel("sessions in the atlas before the add")
    ax.set_ylabel("seconds per add")
    ax.set_title("mm4mm add, one warehouse session at a time")
    ax.legend(fontsize=8)
    mem.plot(x, [float(r["peak_rss_mb"]) / 1024 for r in rows], marker="o")
    mem.set_xlabel("sessions in the atlas before the add")
    mem.set_ylabel("peak RSS of the add (GiB)")
    mem.set_ylim(bottom=0)
    mem.set_title("memory")
    fig.tight_layout()
    fig.savefig(sys.argv[2], dpi=110)


if __name__ == "__main__":
    main()
