#!/usr/bin/python3
"""Chooses the magnetic change score's settings (issue 18, slice 1; MagneticChangeConfig in
include/mm4mm/merge/magnetic_change.hpp, and the scale on each session's calibration evidence)
from the tuning sweep of bench/change_bench --sweep (scripts/change_sweep.sh: tuning seeds only),
so that the choice is written down and can be re-run. The rule, fixed before any sweep was run:

1. No false region: over every row (both rigs, the changed warehouse and the unchanged one), the
   pairs on one side of the change report no region at this setting, nor at the setting one
   chi-square step looser with the rest the same (a step of margin; the loosest chi-square of the
   grid can show no margin and is never chosen).
2. Precision at least 80 % (the issue's target): of the region area the pairs across the change
   report, the share on truly changed cells (both rigs).
3. Of those, the most recall of the area changed by 5 µT or more with the seven-sensor array
   (the strongly changed area inside a region over the strongly changed area compared); ties go to
   the stricter setting (larger chi-square, then area, floor and calibration scale).

Prints every setting that passes 1 and 2 with its figures, best first, and the choice; --markdown
FILE writes the same as a table.

Usage: scripts/choose_change_settings.py [--csv docs/bench/change_sweep.csv] [--label L]
                                         [--markdown FILE]
"""
import argparse
import collections
import csv

SETTING = ("noise_floor_uT", "min_chi2", "min_region_area_m2", "calibration_scale")
SUMS = ("pairs_compared", "pairs_across", "false_regions", "false_region_m2", "regions_across",
        "region_area_m2", "true_m2", "true_found_m2", "strong_m2", "strong_found_m2")


def ratio(num, den):
    return num / den if den > 0 else float("nan")


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--csv", default="docs/bench/change_sweep.csv")
    parser.add_argument("--label", help="the sweep's label (default: the only one in the file)")
    parser.add_argument("--markdown")
    args = parser.parse_args()

    rows = list(csv.DictReader(open(args.csv)))
    labels = sorted({r["label"] for r in rows})
    label = args.label or (labels[0] if len(labels) == 1 else None)
    if label is None:
        raise SystemExit(f"choose_change_settings: several labels ({', '.join(labels)}); "
                         "pick one with --label")
    rows = [r for r in rows if r["label"] == label]
    if any(int(r["seed"]) > 20 for r in rows):
        raise SystemExit("choose_change_settings: a row beyond tuning seeds 1-20; refusing")

    # Per setting: sums over every case, and the array's over the changed warehouse.
    total = collections.defaultdict(lambda: collections.Counter())
    array = collections.defaultdict(lambda: collections.Counter())
    cases = collections.defaultdict(set)
    for r in rows:
        key = tuple(float(r[k]) for k in SETTING)
        for k in SUMS:
            total[key][k] += float(r[k])
            if r["rig"] == "array7" and r["world"] == "changed":
                array[key][k] += float(r[k])
        cases[key].add((r["seed"], r["rig"], r["world"]))
    counts = {len(c) for c in cases.values()}
    if len(counts) != 1:
        raise SystemExit("choose_change_settings: the settings were not run on the same cases; "
                         "the sweep is incomplete")

    chi2_steps = sorted({k[1] for k in total})

    def looser(key):
        i = chi2_steps.index(key[1])
        return None if i == 0 else (key[0], chi2_steps[i - 1], key[2], key[3])

    passed = []
    for key, t in total.items():
        step = looser(key)
        if t["false_regions"] > 0 or step is None or total[step]["false_regions"] > 0:
            continue
        precision = ratio(t["true_found_m2"], t["region_area_m2"])
        if not precision >= 0.8:
            continue
        a = array[key]
        passed.append((ratio(a["strong_found_m2"], a["strong_m2"]), key, precision,
                       ratio(a["true_found_m2"], a["true_m2"]), t))
    # Best recall first; among equals the stricter setting.
    passed.sort(key=lambda p: (-p[0], -p[1][1], -p[1][2], -p[1][0], -p[1][3]))

    lines = [f"Sweep {label}: {counts.pop()} cases (seed, rig, world), "
             f"{len(total)} settings, {len(passed)} pass the rule.", "",
             "| floor µT | chi2 | area m² | cal. scale | array recall ≥5 µT | array recall ≥1 µT "
             "| precision | regions across | false regions (one step looser) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for recall, key, precision, recall1, t in passed:
        step = looser(key)
        lines.append(f"| {key[0]:g} | {key[1]:g} | {key[2]:g} | {key[3]:g} | {100 * recall:.0f} % "
                     f"| {100 * recall1:.0f} % | {100 * precision:.0f} % "
                     f"| {int(t['regions_across'])} | 0 ({int(total[step]['false_regions'])}) |")
    if passed:
        key = passed[0][1]
        lines += ["", f"Chosen: noise_floor_uT {key[0]:g}, min_chi2 {key[1]:g}, "
                      f"min_region_area_m2 {key[2]:g}, calibration scale {key[3]:g}."]
    else:
        lines += ["", "No setting passes the rule: keep the defaults."]
    print("\n".join(lines))
    if args.markdown:
        with open(args.markdown, "w") as f:
            f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
