#!/usr/bin/env python3
"""Plots add_bench's CSV: the seconds of each add against the number of sessions already in the
atlas, stacked by stage (loading the atlas, the session's match / refinement / solve, rewriting
the outputs), with the 10 s target of issue 6; the add's peak memory; and how far each add's
re-solve moved the sessions already placed (why the outputs are rebuilt, not patched).

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
    fig, (ax, mem, moved) = plt.subplots(1, 3, figsize=(18, 4.5))
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
    if "old_moved_beyond_5cm_at_30m" in rows[0]:
        moved.bar(x, [int(r["old_moved_beyond_5cm_at_30m"]) for r in rows], color="tab:red",
                  label="placed sessions moved > 5 cm at 30 m range")
        moved.plot(x, x, color="black", linestyle=":", label="sessions placed before the add")
        moved.set_xlabel("sessions in the atlas before the add")
        moved.set_ylabel("sessions")
        twin = moved.twinx()
        twin.plot(x, [float(r["old_max_move_m"]) for r in rows], marker="o", color="tab:blue",
                  label="largest keyframe move (m)")
        twin.set_ylabel("largest keyframe move of a placed session (m)")
        moved.set_title("what each re-solve moves")
        handles = moved.get_legend_handles_labels()
        twin_handles = twin.get_legend_handles_labels()
        moved.legend(handles[0] + twin_handles[0], handles[1] + twin_handles[1], fontsize=8,
                     loc="upper left")
        moved.set_ylim(0, max(x) * 1.6)
    else:
        moved.set_visible(False)
    fig.tight_layout()
    fig.savefig(sys.argv[2], dpi=110)


if __name__ == "__main__":
    main()
