#!/usr/bin/python3
"""Regenerates the benchmark tables and quoted figures of README.md and docs/benchmarks.md from
the committed raw outputs in docs/bench/, so that every generated figure can be traced to a file
a benchmark program wrote.

Usage:
  python3 scripts/bench_tables.py          # rewrite the generated regions in place
  python3 scripts/bench_tables.py --check  # exit 1 and name every region that differs

Generated regions in the Markdown files:
  <!-- bench:NAME -->            a block (a table): the lines up to <!-- /bench:NAME -->
  ...
  <!-- /bench:NAME -->
  <!-- bench:NAME -->7 s<!-- /bench -->    one figure inside prose (the comments do not render)

Each NAME is one small function below (registered with @block or @inline) whose docstring says
which file and columns it reads and how it aggregates. Medians are the bench programs' upper
median (bench/bench_util.hpp: the element at size / 2 once sorted), so that a table here equals
the one the program printed. A region whose name no function knows, or a function whose region
is missing from the files, is an error.

Most sources are CSVs. A few programs print only a Markdown table (merge_bench, sim_bench,
add_bench's accuracy table); those regions parse the committed .md output, say so in their
docstring, and the program should also write a CSV (listed in docs/benchmarks.md).
Standard library only.
"""
import argparse
import csv
import os
import re
import sys
from collections import OrderedDict
from decimal import ROUND_HALF_UP, Decimal

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BENCH = os.path.join(ROOT, "docs", "bench")
FILES = ["docs/benchmarks.md", "README.md"]

BLOCKS = OrderedDict()
INLINES = OrderedDict()


def block(name):
    def register(function):
        BLOCKS[name] = function
        return function
    return register


def inline(name):
    def register(function):
        INLINES[name] = function
        return function
    return register


# ---------------------------------------------------------------------------------------------
# Readers and the bench programs' aggregations

_cache = {}


def rows(name):
    """The rows of docs/bench/NAME as dicts (csv.DictReader), read once."""
    if name not in _cache:
        with open(os.path.join(BENCH, name), newline="") as f:
            _cache[name] = list(csv.DictReader(f))
    return _cache[name]


def md_table(name, index=0):
    """The index-th Markdown table of docs/bench/NAME as a list of dicts keyed by header cell.
    For programs that print Markdown but write no CSV."""
    tables, current = [], None
    with open(os.path.join(BENCH, name)) as f:
        for line in f:
            line = line.strip()
            if line.startswith("|"):
                cells = [c.strip() for c in line.strip("|").split("|")]
                if current is None:
                    current = {"header": cells, "rows": []}
                elif not all(set(c) <= set("-: ") for c in cells):
                    current["rows"].append(dict(zip(current["header"], cells)))
            elif current is not None:
                tables.append(current["rows"])
                current = None
    if current is not None:
        tables.append(current["rows"])
    return tables[index]


def median(values):
    """Upper median, as bench::median: the element at len // 2 once sorted; 0 for none."""
    values = sorted(values)
    return values[len(values) // 2] if values else 0.0


def mean(values):
    return sum(values) / len(values) if values else 0.0


class Num(float):
    """A float read from a CSV that keeps the digits it was written with."""

    def __new__(cls, text):
        number = float.__new__(cls, text)
        number.text = text
        return number


def f(row, column):
    return Num(row[column])


def fx(x, digits):
    """x with `digits` decimals. A value read from a CSV (Num) is rounded half up from the digits
    the CSV holds (0.0355 -> 0.036), the reading of them closest to the program that wrote both the
    CSV and its table from the unrounded value; a computed value as printf would."""
    if isinstance(x, Num) and x.text.strip().lower() not in ("nan", "inf", "-inf"):
        quantum = Decimal(1).scaleb(-digits)
        return str(Decimal(x.text.strip()).quantize(quantum, rounding=ROUND_HALF_UP))
    return f"{float(x):.{digits}f}"


def one(row, column):
    return row[column] == "1"


def scaled(x, factor):
    """x * factor, exact on a CSV value's digits (Num stays Num: 0.0355 * 100 -> 3.55)."""
    if isinstance(x, Num):
        return Num(str(Decimal(x.text.strip()) * Decimal(str(factor))))
    return x * factor


def pct(k, n):
    """'k/n (p %)' as the bench programs print it (%.0f)."""
    return f"{k}/{n} ({fx(100.0 * k / n if n else 0.0, 0)} %)"


def span(values, digits=1, sep="-"):
    """'lo-hi' of the values with `digits` decimals, or one value when lo and hi print the same."""
    lo, hi = fx(min(values), digits), fx(max(values), digits)
    return lo if lo == hi else f"{lo}{sep}{hi}"


def select(data, **where):
    return [r for r in data if all(r.get(k) == v for k, v in where.items())]


class MatchSummary:
    """match_bench's summary of one group of CSV rows (bench/match_bench.cpp, the table it
    prints): overlapping = rows with overlapping 1, success = aligned 1 among them, wide = those
    with swath_overlap_m2 >= 15, medians of overlap_error_m/_deg and e_t_m/e_r_deg over the
    overlapping rows, disjoint = rows with separate 1, false overlaps = accepted 1 among them,
    median seconds over all rows."""

    def __init__(self, data):
        over = [r for r in data if one(r, "overlapping")]
        sep = [r for r in data if not one(r, "overlapping") and one(r, "separate")]
        self.rows, self.over, self.sep = data, over, sep
        self.overlapping = len(over)
        self.success = sum(one(r, "aligned") for r in over)
        wide = [r for r in over if "swath_overlap_m2" in r and f(r, "swath_overlap_m2") >= 15.0]
        self.wide, self.wide_success = len(wide), sum(one(r, "aligned") for r in wide)
        self.et = median([f(r, "overlap_error_m") for r in over])
        self.er = median([f(r, "overlap_error_deg") for r in over])
        self.ft = median([f(r, "e_t_m") for r in over])
        self.fr = median([f(r, "e_r_deg") for r in over])
        self.disjoint = len(sep)
        self.false_overlaps = sum(one(r, "accepted") for r in sep)
        self.seconds = median([f(r, "seconds") for r in data])
        # Accepted at a wrong place: an overlapping pair accepted but not aligned.
        self.wrong = [r for r in over if one(r, "accepted") and not one(r, "aligned")]

    def success_cell(self):
        return pct(self.success, self.overlapping)

    def wide_cell(self):
        return pct(self.wide_success, self.wide)

    def errors(self):
        return f"{fx(self.et, 3)} / {fx(self.er, 3)}"

    def frames(self):
        return f"{fx(self.ft, 3)} / {fx(self.fr, 3)}"

    def false_cell(self):
        return f"{self.false_overlaps} ({fx(100.0 * self.false_overlaps / self.disjoint if self.disjoint else 0, 0)} %)"


def summary(name, **where):
    return MatchSummary(select(rows(name), **where))


def table(header, body):
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in body]
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# docs/benchmarks.md: realistic magnetometers (issue 14)

@block("field-statistics")
def field_statistics():
    """docs/bench/field_statistics.csv (scripts/field_statistics.py): one row per session;
    readings, bh_std_uT and bv_std_uT (%.1f), rho_0.25m..rho_2m (%.2f), correlation_length_m
    (%.1f; nan, no distance up to 3 m below 0.5, prints '> 3')."""
    body = []
    for r in rows("field_statistics.csv"):
        length = r["correlation_length_m"]
        length = "> 3" if length == "nan" else fx(f(r, "correlation_length_m"), 1)
        body.append([r["session"], r["readings"], f"{fx(f(r, 'bh_std_uT'), 1)}", f"{fx(f(r, 'bv_std_uT'), 1)}"]
                    + [f"{fx(f(r, c), 2)}" for c in ("rho_0.25m", "rho_0.5m", "rho_1m", "rho_2m")] + [length])
    return table(["session", "readings", "B_h std (µT)", "B_v std (µT)", "ρ(0.25 m)", "ρ(0.5 m)", "ρ(1 m)",
                  "ρ(2 m)", "correlation length (ρ < 0.5, m)"], body)


def threshold_outcome(name, min_z, min_r, max_second_ratio=0.75):
    """scripts/choose_thresholds.py's outcome(): over docs/bench/NAME, a row is accepted when
    z >= min_z, r >= min_r and second_mode_ratio <= 0.75; returns (accepted and aligned,
    accepted and not aligned, overlapping rows, separate rows accepted, separate rows)."""
    right = wrong = overlapping = false = disjoint = 0
    for r in rows(name):
        accept = f(r, "z") >= min_z and f(r, "r") >= min_r and f(r, "second_mode_ratio") <= max_second_ratio
        if one(r, "overlapping"):
            overlapping += 1
            right += accept and one(r, "aligned")
            wrong += accept and not one(r, "aligned")
        elif one(r, "separate"):
            disjoint += 1
            false += accept
    return right, wrong, overlapping, false, disjoint


@inline("tuning-imu-pick")
def tuning_imu_pick():
    """docs/bench/match_tuning.csv under the picked rule z >= 3, r >= 0.85 (threshold_outcome)."""
    right, wrong, n, false, d = threshold_outcome("match_tuning.csv", 3.0, 0.85)
    return f"{right} of {n} overlapping pairs aligned, {wrong} wrong, {false} of {d} disjoint accepted"


@inline("tuning-array-pick")
def tuning_array_pick():
    """docs/bench/match_tuning_array.csv under the picked rule z >= 8, r >= 0.825."""
    right, wrong, n, false, d = threshold_outcome("match_tuning_array.csv", 8.0, 0.825)
    return f"{right} of {n} aligned, {wrong} wrong, {false} of {d} disjoint"


@inline("tuning-array-old")
def tuning_array_old():
    """docs/bench/match_tuning_array.csv under the old rule z >= 9, r >= 0.9: aligned of overlapping."""
    right, _, n, _, _ = threshold_outcome("match_tuning_array.csv", 9.0, 0.9)
    return f"{right} of those {n}"


JOINT_METHODS = [("default", "field alone"), ("joint", "joint"), ("geometry", "geometry alone")]


@block("heldout-joint")
def heldout_joint():
    """docs/bench/match_heldout_joint.csv, per preset (warehouse, corridor) and method:
    MatchSummary; 'accepted at a wrong place' = overlapping rows accepted but not aligned (with
    overlap_error_m / _deg when there are any); median seconds over all of the group's rows."""
    body = []
    for preset in ("warehouse", "corridor"):
        for method, label in JOINT_METHODS:
            s = summary("match_heldout_joint.csv", preset=preset, method=method)
            wrong = str(len(s.wrong))
            if s.wrong:
                wrong += " (" + ", ".join(f"{fx(f(r, 'overlap_error_m'), 0)} m, {fx(f(r, 'overlap_error_deg'), 0)}° off"
                                          for r in s.wrong) + ")"
            body.append([preset, label, f"{s.success}/{s.overlapping}", f"{s.wide_success}/{s.wide}", wrong,
                         f"{s.false_overlaps}/{s.disjoint}", f"{fx(s.seconds, 1)}"])
    return table(["preset", "method", "overlapping pairs aligned", "of those sharing ≥ 15 m²",
                  "accepted at a wrong place", "disjoint pairs accepted", "median s per pair"], body)


HELDOUT = [("warehouse", "imu"), ("warehouse", "array7"), ("random", "imu"), ("random", "array7"),
           ("corridor", "imu"), ("corridor", "array7")]


def heldout(preset, rig):
    return summary(f"match_heldout_{rig}.csv", preset=preset, rig=rig)


@block("heldout-matching")
def heldout_matching():
    """docs/bench/match_heldout_imu.csv and match_heldout_array7.csv, per preset and rig:
    MatchSummary (aligned of overlapping, aligned of those with swath_overlap_m2 >= 15, median
    overlap error over the overlapping pairs, accepted of the separate pairs)."""
    body = []
    for preset, rig in HELDOUT:
        s = heldout(preset, rig)
        wide = s.wide_cell() if s.wide else "0/0 (no pair shares 15 m²)"
        label = "imu (1 sensor)" if (preset, rig) == ("warehouse", "imu") else rig
        body.append([preset, label, s.success_cell(), wide, s.errors(), f"{s.false_overlaps}/{s.disjoint}"])
    return table(["preset", "rig", "overlapping pairs aligned (< 0.5 m, 2°)",
                  "of those whose swaths share ≥ 15 m² at the truth", "median overlap error (m / °)",
                  "disjoint pairs accepted"], body)


def heldout_imu_all():
    return [heldout(p, "imu") for p in ("warehouse", "random", "corridor")]


@inline("heldout-imu-false")
def heldout_imu_false():
    """match_heldout_imu.csv: separate pairs accepted of separate pairs, all presets."""
    ss = heldout_imu_all()
    return f"{sum(s.false_overlaps for s in ss)} false overlaps in {sum(s.disjoint for s in ss)} disjoint single-sensor pairs"


@inline("heldout-imu-wide-range")
def heldout_imu_wide_range():
    """match_heldout_imu.csv: the range over presets of aligned / overlapping pairs with
    swath_overlap_m2 >= 15 (presets with no such pair left out), in %."""
    return span([100.0 * s.wide_success / s.wide for s in heldout_imu_all() if s.wide], 0) + " %"


@inline("heldout-imu-range")
def heldout_imu_range():
    """match_heldout_imu.csv: the range over presets of aligned / overlapping pairs, in %."""
    return span([100.0 * s.success / s.overlapping for s in heldout_imu_all()], 0) + " %"


@inline("heldout-array-range")
def heldout_array_range():
    """match_heldout_array7.csv: the range over presets of aligned / overlapping pairs, in %."""
    ss = [heldout(p, "array7") for p in ("warehouse", "random", "corridor")]
    return span([100.0 * s.success / s.overlapping for s in ss], 0) + " %"


@inline("heldout-array-wide-range")
def heldout_array_wide_range():
    """match_heldout_array7.csv: the range over presets of aligned / overlapping pairs with
    swath_overlap_m2 >= 15, in %."""
    ss = [heldout(p, "array7") for p in ("warehouse", "random", "corridor")]
    return span([100.0 * s.wide_success / s.wide for s in ss if s.wide], 0) + " %"


@inline("heldout-imu-misses")
def heldout_imu_misses():
    """match_heldout_imu.csv: overlapping pairs not aligned, counted by verdict."""
    misses = [r for s in heldout_imu_all() for r in s.over if not one(r, "aligned")]
    count = lambda v: sum(r["verdict"] == v for r in misses)
    return (f"the {len(misses)} misses: {count('no overlap')} refused as no overlap, "
            f"{count('ambiguous')} ambiguous, and {count('yaw uncertain')} refused as yaw uncertain")


SENSOR_VARIANTS = [("clean", "none", "clean"), ("realistic", "none", "uncalibrated"),
                   ("realistic", "true", "true calibration given"),
                   ("realistic", "estimated", "calibrated by the pipeline")]


@block("heldout-sensors")
def heldout_sensors():
    """docs/bench/match_heldout_sensors_{imu,array7}.csv (clean, uncalibrated, true calibration)
    and, for 'calibrated by the pipeline', the rows of seeds 1001-1003 of the warehouse in
    match_heldout_{imu,array7}.csv: aligned of overlapping pairs; accepted not aligned with their
    overlap_error_m / _deg; separate pairs accepted."""
    body = []
    for rig, label in (("imu", "one magnetometer"), ("array7", "7-sensor array")):
        cells = [label]
        false = disjoint = 0
        for sensors, calibration, _ in SENSOR_VARIANTS:
            if calibration == "estimated":
                data = [r for r in rows(f"match_heldout_{rig}.csv")
                        if r["preset"] == "warehouse" and r["sensors"] == sensors
                        and r["calibration"] == calibration and 1001 <= int(r["seed"]) <= 1003]
            else:
                data = select(rows(f"match_heldout_sensors_{rig}.csv"), sensors=sensors, calibration=calibration)
            s = MatchSummary(data)
            cell = f"{s.success}/{s.overlapping}"
            if s.wrong:
                cell += ", **" + ", ".join(f"1 accepted {fx(f(r, 'overlap_error_m'), 2)} m / "
                                           f"{fx(f(r, 'overlap_error_deg'), 1)}° off" for r in s.wrong) + "**"
            elif s.success == 0:
                cell += " (all refused)"
            cells.append(cell)
            false += s.false_overlaps
            disjoint += s.disjoint
        cells.append(f"{false}/{disjoint}")
        body.append(cells)
    return table(["warehouse seeds 1001-1003"] + [v[2] for v in SENSOR_VARIANTS] +
                 ["disjoint pairs accepted (all four)"], body)


MERGE_VARIANTS = [("clean", "none", "clean"), ("realistic", "estimated", "realistic, calibrated"),
                  ("realistic", "none", "realistic, uncalibrated")]


def merge_heldout(preset, sensors, calibration):
    """docs/bench/merge_heldout.csv (merge_bench --csv): pair rows (pair != all) give aligned of
    overlapping and, over connected pairs only, the median overlap error; the per-seed 'all'
    rows give ate_m and odometry_ate_m, of which the medians."""
    data = select(rows("merge_heldout.csv"), preset=preset, sensors=sensors, calibration=calibration)
    pairs = [r for r in data if r["pair"] != "all"]
    seeds = [r for r in data if r["pair"] == "all"]
    connected = [r for r in pairs if one(r, "connected")]
    return dict(pairs=len(pairs), aligned=sum(one(r, "aligned") for r in pairs), connected=len(connected),
                et=median([f(r, "overlap_error_m") for r in connected]),
                er=median([f(r, "overlap_error_deg") for r in connected]),
                ate=median([f(r, "ate_m") for r in seeds]), odo=median([f(r, "odometry_ate_m") for r in seeds]))


@block("merge-heldout")
def merge_heldout_table():
    """docs/bench/merge_heldout.csv per preset and sensor variant (merge_heldout())."""
    body = []
    for preset in ("warehouse", "corridor"):
        for sensors, calibration, label in MERGE_VARIANTS:
            m = merge_heldout(preset, sensors, calibration)
            aligned = f"{m['aligned']}/{m['pairs']}" + (" (nothing connected)" if not m["connected"] else "")
            errors = f"{fx(m['et'], 3)} / {fx(m['er'], 3)}" if m["connected"] else "–"
            body.append([preset, label, aligned, errors, f"{fx(m['ate'], 3)} / {fx(m['odo'], 3)}"])
    return table(["preset", "sensors", "overlapping pairs aligned",
                  "median overlap error after the solve (m / °)",
                  "ATE after solve / odometry at true frames (m)"], body)


@inline("merge-heldout-translation")
def merge_heldout_translation():
    """merge_heldout.csv: median overlap translation error of the calibrated rows, warehouse and
    corridor, in cm."""
    return " and ".join(f"{fx(scaled(merge_heldout(p, 'realistic', 'estimated')['et'], 100), 1)}"
                        for p in ("warehouse", "corridor")) + " cm"


@inline("merge-heldout-rotation")
def merge_heldout_rotation():
    """merge_heldout.csv: range of the median overlap rotation errors of every connected row."""
    values = [merge_heldout(p, s, c)["er"] for p in ("warehouse", "corridor") for s, c, _ in MERGE_VARIANTS
              if merge_heldout(p, s, c)["connected"]]
    return span(values, 2) + "°"


AALTO_GROUPS = [("1-5", "1–5, unchanged field"), ("6-9", "6–9, shelves brought in"),
                ("across", "across the two groups")]


def aalto(group):
    """docs/bench/aalto_invensense.csv (scripts/eval_aalto.py --csv), rows of one group: best mode
    right = best_mode_correct 1 (< 0.5 m, 2°); accepted = verdict 'match'."""
    g = select(rows("aalto_invensense.csv"), group=group)
    accepted = [r for r in g if r["verdict"] == "match"]
    right = [r for r in accepted if one(r, "best_mode_correct")]
    return dict(n=len(g), best=sum(one(r, "best_mode_correct") for r in g), accepted=len(accepted),
                right=len(right), wrong=len(accepted) - len(right), rows=g)


@block("aalto-default")
def aalto_default():
    """docs/bench/aalto_invensense.csv per group (aalto())."""
    body = []
    for group, label in AALTO_GROUPS:
        a = aalto(group)
        body.append([f"{label} ({a['n']})", a["best"], a["accepted"], a["right"], a["wrong"]])
    return table(["pairs", "best mode right (< 0.5 m, 2°)", "accepted", "accepted and right",
                  "accepted and wrong"], body)


@inline("aalto-unchanged-accepted")
def aalto_unchanged_accepted():
    """aalto_invensense.csv, group 1-5: accepted of all pairs."""
    a = aalto("1-5")
    return f"{a['accepted']} of {a['n']}"


@inline("aalto-unchanged-best")
def aalto_unchanged_best():
    """aalto_invensense.csv, group 1-5: best_mode_correct of all pairs."""
    a = aalto("1-5")
    return f"{a['best']} of {a['n']}"


@inline("aalto-unchanged-swath")
def aalto_unchanged_swath():
    """aalto_invensense.csv, group 1-5, every pair: range of overlap_m2 and of z."""
    g = aalto("1-5")["rows"]
    return (f"{span([f(r, 'overlap_m2') for r in g], 1)} m², where z stays at "
            f"{span([f(r, 'z') for r in g], 1)}")


# ---------------------------------------------------------------------------------------------
# docs/benchmarks.md: simulator, matching on clean sensors

@block("sim-bench")
def sim_bench():
    """docs/bench/sim_bench.md (sim_bench prints Markdown only; no CSV): its table as printed,
    the last column's '(all threads)' read as this machine's 2."""
    t = md_table("sim_bench.md")
    header = list(t[0].keys())
    header[-1] = header[-1].replace("(all threads)", "(2 threads)")
    return table(header, [list(r.values()) for r in t])


@inline("sim-warehouse-seconds")
def sim_warehouse_seconds():
    """docs/bench/sim_bench.md (no CSV): the warehouse row's seconds per session, rounded to 0.1 s."""
    row = [r for r in md_table("sim_bench.md") if r["world"] == "warehouse"][0]
    return f"{fx(float(list(row.values())[-1]), 1)} s"


PRESETS = ["corridor", "random", "warehouse"]


@block("match-default")
def match_default():
    """docs/bench/match_bench_default.csv per preset (method default): MatchSummary."""
    body = []
    for preset in PRESETS:
        s = summary("match_bench_default.csv", preset=preset, method="default")
        body.append([preset, s.overlapping, s.success_cell(), s.wide_cell(), s.errors(), s.frames(),
                     s.disjoint, s.false_cell(), f"{fx(s.seconds, 2)}"])
    return table(["preset", "overlapping pairs", "success", "success where the swath is >= 15 m²",
                  "median overlap error (m / °)", "median e_t (m) / e_r (°)", "pairs without overlap",
                  "false overlaps", "median s per match"], body)


def plain_rows(name, method_presets):
    body = []
    for preset, method in method_presets:
        s = summary(name, preset=preset, method=method)
        body.append([preset, method, s.overlapping, s.success_cell(), s.errors(), s.frames(), s.disjoint,
                     s.false_cell(), f"{fx(s.seconds, 2)}"])
    return table(["preset", "method", "overlapping pairs", "success", "median overlap error (m / °)",
                  "median e_t (m) / e_r (°)", "pairs without overlap", "false overlaps",
                  "median s per match"], body)


@block("match-paper")
def match_paper():
    """docs/bench/match_bench_paper.csv per preset, method paper: MatchSummary."""
    return plain_rows("match_bench_paper.csv", [(p, "paper") for p in PRESETS])


REFINERS = ["compass", "concordance", "default", "grid", "none"]


@block("match-refinement")
def match_refinement():
    """docs/bench/match_refinement.csv, warehouse, per method: MatchSummary."""
    return plain_rows("match_refinement.csv", [("warehouse", m) for m in REFINERS])


def default_summaries():
    return {p: summary("match_bench_default.csv", preset=p, method="default") for p in PRESETS}


@inline("match-default-false")
def match_default_false():
    """match_bench_default.csv: accepted separate pairs of separate pairs, all presets."""
    ss = default_summaries().values()
    return f"{sum(s.false_overlaps for s in ss)} false overlaps in {sum(s.disjoint for s in ss)} pairs without overlap"


@inline("match-default-refusals")
def match_default_refusals():
    """match_bench_default.csv: overlapping pairs not aligned, all presets."""
    return str(sum(s.overlapping - s.success for s in default_summaries().values()))


@inline("match-default-disjoint")
def match_default_disjoint():
    """match_bench_default.csv: the number of separate pairs, all presets."""
    return str(sum(s.disjoint for s in default_summaries().values()))


def rate(s):
    return f"{fx(100.0 * s.success / s.overlapping, 0)} %"


@inline("match-first-run")
def match_first_run():
    """match_bench_paper.csv, method default (the first run's default rows): success rate per
    preset, warehouse / random / corridor."""
    return " / ".join(rate(summary("match_bench_paper.csv", preset=p, method="default"))
                      for p in ("warehouse", "random", "corridor"))


@inline("match-warehouse")
def match_warehouse():
    """match_bench_default.csv, warehouse: success rate."""
    return rate(default_summaries()["warehouse"])


@inline("match-warehouse-wide")
def match_warehouse_wide():
    """match_bench_default.csv, warehouse: success rate among pairs with swath_overlap_m2 >= 15."""
    s = default_summaries()["warehouse"]
    return f"{fx(100.0 * s.wide_success / s.wide, 0)} %"


@inline("match-random")
def match_random():
    """match_bench_default.csv, random: success rate."""
    return rate(default_summaries()["random"])


@inline("match-corridor")
def match_corridor():
    """match_bench_default.csv, corridor: success rate."""
    return rate(default_summaries()["corridor"])


@inline("match-paper-range")
def match_paper_range():
    """match_bench_paper.csv, method paper: range of the success rates over presets."""
    values = [100.0 * s.success / s.overlapping for s in
              (summary("match_bench_paper.csv", preset=p, method="paper") for p in PRESETS)]
    return span(values, 0, "–") + " %"


@inline("refinement-default-seconds")
def refinement_default_seconds():
    """match_refinement.csv, method default: median seconds per match."""
    return f"{fx(summary('match_refinement.csv', method='default').seconds, 2)} s"


@inline("refinement-compass-seconds")
def refinement_compass_seconds():
    """match_refinement.csv, method compass: median seconds per match."""
    return f"{fx(summary('match_refinement.csv', method='compass').seconds, 2)} s"


@inline("match-default-warehouse-seconds")
def match_default_warehouse_seconds():
    """match_bench_default.csv, warehouse: median seconds per match."""
    return f"{fx(default_summaries()['warehouse'].seconds, 2)} s"


# ---------------------------------------------------------------------------------------------
# docs/benchmarks.md: merges (merge_bench prints Markdown only)

def merge_md(name, preset, variant="magnetic"):
    return [r for r in md_table(name) if r["preset"] == preset and r["variant"] == variant][0]


@block("merge-bench")
def merge_bench():
    """docs/bench/merge_bench.md (merge_bench prints Markdown only, no CSV without --csv): its
    rows for warehouse and corridor, the atlas write column without the OctoMap share."""
    body = []
    for preset in ("warehouse", "corridor"):
        r = merge_md("merge_bench.md", preset)
        cols = list(r.values())
        body.append([preset, r["seeds"], cols[3], cols[4], cols[5], cols[6], cols[7], cols[8].split(" / ")[0]])
    return table(["preset", "seeds", "overlapping pairs aligned", "median overlap error after solve (m / °)",
                  "median e_t (m) / e_r (°)",
                  "ATE after solve / odometry at true frames / rigid tree (m, median)", "merge s (median)",
                  "atlas write s (median)"], body)


@block("merge-featureless")
def merge_featureless():
    """docs/bench/merge_featureless.md (Markdown only): variant magnetic and geometric; aligned
    pairs without the percentage, the first figure of the ATE column."""
    body = []
    for variant, label in (("magnetic", "with magnetic residuals"), ("geometric", "without")):
        cols = list(merge_md("merge_featureless.md", "featureless", variant).values())
        body.append([label, cols[3].split(" ")[0], cols[4], cols[5], cols[6].split(" / ")[0]])
    return table(["variant", "overlapping pairs aligned", "median overlap error after solve (m / °)",
                  "median e_t (m) / e_r (°)", "ATE median (m)"], body)


def merge_fig(preset, column_index, part):
    cols = list(merge_md("merge_bench.md", preset).values())
    return cols[column_index].split(" / ")[part].split(" ")[0]


@inline("merge-warehouse-aligned")
def merge_warehouse_aligned():
    """merge_bench.md, warehouse: the percentage of overlapping pairs aligned."""
    return re.search(r"\((\d+ %)\)", merge_fig("warehouse", 3, 0) + " " +
                     list(merge_md("merge_bench.md", "warehouse").values())[3]).group(1)


@inline("merge-warehouse-overlap")
def merge_warehouse_overlap():
    """merge_bench.md, warehouse: median overlap error after the solve, cm / °."""
    return f"{fx(100 * float(merge_fig('warehouse', 4, 0)), 1)} cm / {merge_fig('warehouse', 4, 1)}°"


@inline("merge-warehouse-ate")
def merge_warehouse_ate():
    """merge_bench.md, warehouse: ATE after the solve against the odometry at its true frames."""
    return f"ATE {merge_fig('warehouse', 6, 0)} m against {merge_fig('warehouse', 6, 1)} m"


@inline("merge-corridor-aligned")
def merge_corridor_aligned():
    """merge_bench.md, corridor: the percentage of overlapping pairs aligned."""
    return re.search(r"\((\d+ %)\)", list(merge_md("merge_bench.md", "corridor").values())[3]).group(1)


@inline("merge-corridor-overlap")
def merge_corridor_overlap():
    """merge_bench.md, corridor: median overlap translation error after the solve, cm."""
    return f"{fx(100 * float(merge_fig('corridor', 4, 0)), 1)} cm"


@inline("merge-corridor-ate")
def merge_corridor_ate():
    """merge_bench.md, corridor: ATE after the solve against the odometry at its true frames."""
    return f"ATE {merge_fig('corridor', 6, 0)} m against {merge_fig('corridor', 6, 1)} m"


# ---------------------------------------------------------------------------------------------
# docs/benchmarks.md: peers (peer_bench --csv)

PEER_SOURCES = {
    # preset -> CSV holding its latest run (the warehouse rerun after the review fix of b9f3621,
    # the corridor and disjoint session at 10 seeds, the random starts of the first reduced run)
    "warehouse": "peer_bench_warehouse.csv",
    "corridor": "peer_bench_corridor_disjoint.csv",
    "disjoint": "peer_bench_corridor_disjoint.csv",
    "random": "peer_bench.csv",
}
PEER_SCENARIOS = [("warehouse", "1+2", "warehouse 1+2"), ("warehouse", "3+4", "warehouse 3+4"),
                  ("warehouse", "(1+2)+(3+4)", "warehouse (1+2)+(3+4)"), ("warehouse", "all", "warehouse all"),
                  ("corridor", "1+2", "corridor 1+2"), ("corridor", "2+3", "corridor 2+3"),
                  ("corridor", "all", "corridor all"), ("random", "*", "random starts (all four)"),
                  ("disjoint", "1+disjoint", "disjoint session left out")]
MM4MM_METHODS = ["mm4mm", "mm4mm-magnetic-only", "mm4mm-icp-identity", "mm4mm-paper",
                 "mm4mm-no-magnetic-residuals"]
PEERS = [("pcl-gicp", "PCL GICP"), ("pcl-ndt", "PCL NDT"), ("pcl-fpfh-sacia-gicp", "PCL FPFH + SAC-IA + GICP"),
         ("open3d-fpfh-ransac-icp", "Open3D")]


def peer_rows(preset, comparison, method):
    """The rows of one (preset, comparison, method) in PEER_SOURCES[preset] (comparison '*': all
    four of the preset's comparisons together); peer_bench writes a row only for comparisons it
    counts (a judged pair truly overlaps), success 0/1."""
    data = select(rows(PEER_SOURCES[preset]), preset=preset, method=method)
    return data if comparison == "*" else select(data, comparison=comparison)


def peer_success(preset, comparison, method):
    data = peer_rows(preset, comparison, method)
    return sum(one(r, "success") for r in data), len(data)


def peer_seeds(preset):
    seeds = sorted({int(r["seed"]) for r in rows(PEER_SOURCES[preset]) if r["preset"] == preset})
    return f"{seeds[0]}–{seeds[-1]}"


@block("peer-summary")
def peer_summary():
    """PEER_SOURCES per scenario: successes / counted rows for mm4mm and its ablations; best peer =
    the peer method with the most successes (ties: the first in PEERS order), named when > 0."""
    body = []
    for preset, comparison, label in PEER_SCENARIOS:
        cells = [label, peer_seeds(preset)]
        for method in MM4MM_METHODS:
            k, n = peer_success(preset, comparison, method)
            cells.append(f"{k}/{n}")
        best = max(PEERS, key=lambda p: peer_success(preset, comparison, p[0])[0])
        k, n = peer_success(preset, comparison, best[0])
        cells.append(f"{k}/{n}" + (f" ({best[1]})" if k else ""))
        body.append(cells)
    return table(["scenario", "seeds", "mm4mm", "magnetic only", "ICP-EM from identity", "paper's Eq. 4–5 + PSO",
                  "no magnetic residuals", "best peer"], body)


def table_one_comparisons():
    return [c for p, c, _ in PEER_SCENARIOS if p == "warehouse" and c != "all"]


@inline("peer-mm4mm-total")
def peer_mm4mm_total():
    """PEER_SOURCES: mm4mm's successes / counted rows over every scenario of PEER_SCENARIOS."""
    k = n = 0
    for preset, comparison, _ in PEER_SCENARIOS:
        a, b = peer_success(preset, comparison, "mm4mm")
        k, n = k + a, n + b
    return f"{k} of {n}"


@inline("peer-warehouse-seeds")
def peer_warehouse_seeds():
    """peer_bench_warehouse.csv: the warehouse seeds run."""
    return peer_seeds("warehouse")


@inline("peer-warehouse-errors")
def peer_warehouse_errors():
    """peer_bench_warehouse.csv, method mm4mm: mean e_t_m / e_r_deg over seeds (rows with e_t_m
    >= 0) for 1+2, 3+4 and (1+2)+(3+4)."""
    parts = []
    for c in table_one_comparisons():
        data = [r for r in peer_rows("warehouse", c, "mm4mm") if f(r, "e_t_m") >= 0]
        parts.append(f"{c} {fx(mean([f(r, 'e_t_m') for r in data]), 3)} m / {fx(mean([f(r, 'e_r_deg') for r in data]), 2)}°")
    return ", ".join(parts)


@inline("peer-34-rotation")
def peer_34_rotation():
    """peer_bench_warehouse.csv, mm4mm, comparison 3+4: mean e_r_deg over seeds."""
    data = [r for r in peer_rows("warehouse", "3+4", "mm4mm") if f(r, "e_t_m") >= 0]
    return f"{fx(mean([f(r, 'e_r_deg') for r in data]), 2)}°"


PAPER_TABLE_ONE = [  # the paper's Table I, quoted (not measured here)
    ("GICP (paper)", "1.513 / 0.595", "0.793 / 0.300", "2.769 / 182.610"),
    ("NDT (paper)", "1.146 / 0.647", "0.231 / 0.253", "2.713 / 180.350"),
    ("MM4MM (paper)", "1.162 / 0.472", "0.177 / 0.192", "0.150 / 0.378"),
]


@block("peer-table-one")
def peer_table_one():
    """The paper's Table I rows (quoted) and, from peer_bench_warehouse.csv, the mean over seeds
    of e_t_m (%.3f) / e_r_deg (%.2f) of pcl-gicp, pcl-ndt and mm4mm per comparison."""
    body = [list(r) for r in PAPER_TABLE_ONE]
    for method, label in (("pcl-gicp", "PCL GICP (here)"), ("pcl-ndt", "PCL NDT (here)"), ("mm4mm", "mm4mm (here)")):
        cells = [label]
        for c in table_one_comparisons():
            data = [r for r in peer_rows("warehouse", c, method) if f(r, "e_t_m") >= 0]
            cells.append(f"{fx(mean([f(r, 'e_t_m') for r in data]), 3)} / {fx(mean([f(r, 'e_r_deg') for r in data]), 2)}")
        body.append(cells)
    return table(["method", "1+2 (m / °)", "3+4 (m / °)", "(1+2)+(3+4) (m / °)"], body)


@block("peer-reduced")
def peer_reduced():
    """docs/bench/peer_bench.csv (the first reduced run, seeds 1-2 of each preset): per preset and
    comparison, successes / counted rows of mm4mm and of each peer."""
    data = rows("peer_bench.csv")
    body = []
    for preset in ("warehouse", "corridor", "random", "disjoint"):
        comparisons = []
        for r in data:
            if r["preset"] == preset and r["comparison"] not in comparisons:
                comparisons.append(r["comparison"])
        for c in comparisons:
            cells = [preset, c]
            for method in ["mm4mm"] + [p for p, _ in PEERS]:
                d = select(data, preset=preset, comparison=c, method=method)
                cells.append(f"{sum(one(r, 'success') for r in d)}/{len(d)}")
            body.append(cells)
    return table(["preset", "comparison", "mm4mm"] + [label for _, label in PEERS], body)


# ---------------------------------------------------------------------------------------------
# docs/benchmarks.md: scaling and add

@block("scale-bench")
def scale_bench():
    """docs/bench/scale_bench.csv, one row per (strategy, sessions): seconds (%.1f), magnetic
    matches, candidate pairs, connected / sessions, aligned_pairs / overlapping_pairs ('–' with
    none), rss_before_mb / peak_rss_mb (%.0f), added = peak - before (%.0f)."""
    body = []
    for r in rows("scale_bench.csv"):
        n_over = int(r["overlapping_pairs"])
        body.append([r["strategy"], r["sessions"], f"{fx(f(r, 'seconds'), 1)}", r["magnetic_matches"],
                     r["candidate_pairs"], f"{r['connected']}/{r['sessions']}",
                     f"{r['aligned_pairs']}/{n_over}" if n_over else "–",
                     f"{fx(f(r, 'rss_before_mb'), 0)} / {fx(f(r, 'peak_rss_mb'), 0)}",
                     f"{fx(f(r, 'peak_rss_mb') - f(r, 'rss_before_mb'), 0)}"])
    return table(["strategy", "sessions", "merge s", "magnetic matches", "candidate pairs", "connected",
                  "overlapping pairs aligned", "RSS before / peak (MB)", "added (MB)"], body)


def scale(strategy, sessions):
    return [r for r in rows("scale_bench.csv") if r["strategy"] == strategy and int(r["sessions"]) == sessions][0]


def largest_growing():
    return max((r for r in rows("scale_bench.csv") if r["strategy"] == "growing map"), key=lambda r: int(r["sessions"]))


@inline("scale-growing-summary")
def scale_growing_summary():
    """scale_bench.csv, growing map at the largest N: sessions, magnetic matches against all
    N (N - 1) / 2 pairs, seconds in minutes (%.1f), aligned / overlapping pairs in %, peak RSS
    in GB (MB / 1000, %.1f)."""
    r = largest_growing()
    n = int(r["sessions"])
    return (f"{n} sessions of a 170 m × 75 m warehouse merge with {r['magnetic_matches']} magnetic matches "
            f"instead of {n * (n - 1) // 2}, in {fx(f(r, 'seconds') / 60, 1)} minutes, "
            f"{fx(100.0 * int(r['aligned_pairs']) / int(r['overlapping_pairs']), 0)} % of their overlapping pairs "
            f"aligned ({fx(scaled(f(r, 'peak_rss_mb'), 0.001), 1)} GB peak")


@inline("scale-matches")
def scale_matches():
    """scale_bench.csv, growing map: magnetic matches at the largest N, all pairs N (N - 1) / 2,
    and the matches per N in order."""
    r = largest_growing()
    n = int(r["sessions"])
    series = ", ".join(x["magnetic_matches"] for x in rows("scale_bench.csv") if x["strategy"] == "growing map")
    return f"{r['magnetic_matches']} magnetic matches for {n} sessions where every pair would be {n * (n - 1) // 2}: linear in N ({series})"


@inline("scale-memory")
def scale_memory():
    """scale_bench.csv, growing map at the largest N: added (peak - before) and peak RSS, GB."""
    r = largest_growing()
    return (f"{fx((f(r, 'peak_rss_mb') - f(r, 'rss_before_mb')) / 1000, 1)} GB added at N = {r['sessions']} "
            f"({fx(scaled(f(r, 'peak_rss_mb'), 0.001), 1)} GB peak")


ADD_ROWS = [1, 4, 8, 12, 15]


def add_row(sessions_before):
    return [r for r in rows("add_bench.csv") if int(r["sessions_before"]) == sessions_before][0]


@block("add-bench")
def add_bench():
    """docs/bench/add_bench.csv, the adds with 1, 4, 8, 12 and 15 sessions before: stage seconds
    load_s, maps_s, matching_s, refinement_s (ICP-EM + edges), solve_s, write_s, total_s (%.1f),
    peak_rss_mb / 1000 (GB, %.1f), old_max_move_m (m, %.2f) and old_moved_beyond_5cm_at_30m of
    the sessions placed before."""
    body = []
    for k in ADD_ROWS:
        r = add_row(k)
        moved = f"{fx(f(r, 'old_max_move_m'), 2)} m" if f(r, "old_max_move_m") >= 0.005 else "0 m"
        body.append([k] + [f"{fx(f(r, c), 1)}" for c in ("load_s", "maps_s", "matching_s", "refinement_s", "solve_s",
                                                      "write_s", "total_s")] +
                    [f"{fx(scaled(f(r, 'peak_rss_mb'), 0.001), 1)}", f"{moved}; {r['old_moved_beyond_5cm_at_30m']} of {k}"])
    return table(["sessions before", "load", "maps", "matching", "ICP-EM + edges", "solve", "rewrite outputs",
                  "total (s)", "peak RSS (GB)",
                  "placed sessions moved (largest keyframe move; number > 5 cm at 30 m)"], body)


@inline("add-first")
def add_first():
    """add_bench.csv: total_s of the first add (one session before), %.0f s."""
    return f"{fx(f(add_row(1), 'total_s'), 0)} s"


@inline("add-from-eight")
def add_from_eight():
    """add_bench.csv: range of total_s over the adds with 8 or more sessions before, %.0f s."""
    return span([f(r, "total_s") for r in rows("add_bench.csv") if int(r["sessions_before"]) >= 8], 0, "–") + " s"


@inline("add-last")
def add_last():
    """add_bench.csv: total_s of the last add, %.0f s."""
    last = max(rows("add_bench.csv"), key=lambda r: int(r["sessions_before"]))
    return f"{fx(f(last, 'total_s'), 0)} s"


@inline("add-write")
def add_write():
    """add_bench.csv: write_s of the first and the last add."""
    last = max(rows("add_bench.csv"), key=lambda r: int(r["sessions_before"]))
    return f"{fx(f(add_row(1), 'write_s'), 1)} s → {fx(f(last, 'write_s'), 0)} s"


@inline("add-load")
def add_load():
    """add_bench.csv: load_s of the first and the last add."""
    last = max(rows("add_bench.csv"), key=lambda r: int(r["sessions_before"]))
    return f"{fx(f(add_row(1), 'load_s'), 1)} s → {fx(f(last, 'load_s'), 1)} s"


@inline("add-memory")
def add_memory():
    """add_bench.csv: peak_rss_mb of the first and the last add, GB (/ 1000)."""
    last = max(rows("add_bench.csv"), key=lambda r: int(r["sessions_before"]))
    return f"{fx(scaled(f(add_row(1), 'peak_rss_mb'), 0.001), 1)} → {fx(scaled(f(last, 'peak_rss_mb'), 0.001), 1)} GB"


def add_accuracy(label):
    """docs/bench/add_bench.md, second table (add_bench prints it; the CSV has no accuracy):
    the row whose atlas column starts with label."""
    return [r for r in md_table("add_bench.md", 1) if r["atlas"].startswith(label)][0]


@inline("add-accuracy")
def add_accuracy_figures():
    """add_bench.md (accuracy table, no CSV): the atlas grown by add: aligned pairs, median overlap
    error (cm / °), ATE against the odometry's."""
    r = add_accuracy("grown by add")
    aligned, total = [x.strip() for x in r["overlapping pairs aligned"].split("/")]
    t, deg = [float(x) for x in r["median overlap error (m / °)"].split("/")]
    ate, odo = re.match(r"([\d.]+) \(odometry ([\d.]+)\)", r["ATE (m)"]).groups()
    return (f"aligns {aligned} of their {total} overlapping pairs ({fx(100 * t, 1)} cm / {fx(deg, 2)}°, "
            f"ATE {ate} m against {odo} m for the odometry)")


# ---------------------------------------------------------------------------------------------
# Rewriting the files

BLOCK_RE = re.compile(r"(<!-- bench:(?P<name>[\w.-]+) -->\n)(?P<body>.*?)\n?(<!-- /bench:(?P=name) -->)", re.S)
INLINE_RE = re.compile(r"(<!-- bench:(?P<name>[\w.-]+) -->)(?P<body>[^\n]*?)(<!-- /bench -->)")


def regenerate(text, path, seen, differences):
    def replace_block(m):
        name = m.group("name")
        if name not in BLOCKS:
            raise SystemExit(f"{path}: block region '{name}' has no generator")
        seen.add(("block", name))
        new = BLOCKS[name]()
        if new != m.group("body"):
            differences.append((path, name, m.group("body"), new))
        return m.group(1) + new + "\n" + m.group(4)

    def replace_inline(m):
        name = m.group("name")
        if name not in INLINES:
            raise SystemExit(f"{path}: inline region '{name}' has no generator")
        seen.add(("inline", name))
        new = INLINES[name]()
        if new != m.group("body"):
            differences.append((path, name, m.group("body"), new))
        return m.group(1) + new + m.group(4)

    text = BLOCK_RE.sub(replace_block, text)
    return INLINE_RE.sub(replace_inline, text)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--check", action="store_true",
                        help="change nothing; exit 1 and name each region that differs from the CSVs")
    args = parser.parse_args()
    seen, differences, outputs = set(), [], {}
    for path in FILES:
        with open(os.path.join(ROOT, path)) as fh:
            text = fh.read()
        outputs[path] = (text, regenerate(text, path, seen, differences))
    unused = [n for n in BLOCKS if ("block", n) not in seen] + [n for n in INLINES if ("inline", n) not in seen]
    if unused:
        print("generators without a region in " + ", ".join(FILES) + ": " + ", ".join(unused), file=sys.stderr)
        return 1
    if args.check:
        for path, name, old, new in differences:
            print(f"{path}: region '{name}' differs from its source")
            print("  now:       " + old.replace("\n", "\n             "))
            print("  generated: " + new.replace("\n", "\n             "))
        if differences:
            print(f"{len(differences)} region(s) out of date: run python3 scripts/bench_tables.py", file=sys.stderr)
        return 1 if differences else 0
    for path, (old, new) in outputs.items():
        if old != new:
            with open(os.path.join(ROOT, path), "w") as fh:
                fh.write(new)
    for path, name, _, _ in differences:
        print(f"{path}: rewrote region '{name}'")
    return 0


if __name__ == "__main__":
    sys.exit(main())
