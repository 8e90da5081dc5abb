#!/usr/bin/env python3
"""Plots peer_bench's CSV: the success rate of every method in every scenario (top), and the
distribution of the median overlap error (docs/design.md metric 1) per method, pooled over each
preset's comparisons (bottom, log scale; the dashed line is the 0.5 m success bound).

Usage: plot_peer_bench.py PEER_BENCH.csv OUT.png
"""
import csv
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: plot_peer_bench.py PEER_BENCH.csv OUT.png")
    with open(sys.argv[1], newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"plot_peer_bench: no rows in {sys.argv[1]}")
    methods = list(dict.fromkeys(r["method"] for r in rows))
    scenarios = list(dict.fromkeys((r["preset"], r["comparison"]) for r in rows))
    presets = [p for p in dict.fromkeys(r["preset"] for r in rows) if p != "disjoint"]
    success = defaultdict(list)
    errors = defaultdict(list)
    for r in rows:
        success[(r["preset"], r["comparison"], r["method"])].append(int(r["success"]))
        error = float(r["overlap_error_m"])
        if error >= 0:
            errors[(r["preset"], r["method"])].append(max(error, 1e-3))

    fig = plt.figure(figsize=(13, 11))
    grid = fig.add_gridspec(2, max(1, len(presets)), height_ratios=[1.1, 1])
    heat = fig.add_subplot(grid[0, :])
    rates = np.array([[100.0 * np.mean(success[(p, c, m)]) if success[(p, c, m)] else np.nan
                       for (p, c) in scenarios] for m in methods])
    heat.imshow(rates, cmap="RdYlGn", vmin=0, vmax=100, aspect="auto")
    for i in range(len(methods)):
        for j in range(len(scenarios)):
            if not np.isnan(rates[i, j]):
                heat.text(j, i, f"{rates[i, j]:.0f}", ha="center", va="center", fontsize=8)
    heat.set_yticks(range(len(methods)))
    heat.set_yticklabels(methods, fontsize=8)
    heat.set_xticks(range(len(scenarios)))
    heat.set_xticklabels([f"{p}\n{c}" for p, c in scenarios], fontsize=8)
    heat.set_title("success (%): every truly overlapping pair aligned within 0.5 m and 2°; "
                   "disjoint: the extra session left out", fontsize=10)

    colours = plt.cm.tab10.colors
    for col, preset in enumerate(presets):
        ax = fig.add_subplot(grid[1, col])
        for i, m in enumerate(methods):
            values = errors[(preset, m)]
            jitter = np.linspace(-0.2, 0.2, len(values)) if len(values) > 1 else [0.0]
            ax.scatter(np.asarray(jitter) + i, values, s=10, color=colours[i % 10], alpha=0.7)
        ax.set_yscale("log")
        ax.axhline(0.5, color="grey", linestyle="--", linewidth=0.8)
        ax.set_xticks(range(len(methods)))
        ax.set_xticklabels(methods, rotation=90, fontsize=7)
        ax.set_title(preset, fontsize=10)
        if col == 0:
            ax.set_ylabel("median overlap error (m)")
    fig.suptitle("mm4mm against registration peers on the same simulated sessions")
    fig.tight_layout()
    fig.savefig(sys.argv[2], dpi=100)


if __name__ == "__main__":
    main()
