#!/usr/bin/python3
"""Chooses the two sigmas with which the fused map's vertical anchor weighs what knows B_v
absolutely (issue 32; FieldOffsetConfig in include/mm4mm/merge/field_offsets.hpp), from the
committed tuning runs of bench/field_seams_bench (tuning seeds only: warehouse and corridor 1-3,
procedural 1-5), so that the choice is written down and can be re-run:

- observed_vertical_sigma_uT: how far one tilting session's own calibration leaves its vertical
  bias (true minus calibrated, the hard-iron CSVs' sessions with vertical_observed = 1); each
  session once.
- earth_vertical_sigma_uT: how far a building's median B_v at the covered cells departs from the
  Earth's main field (the seams CSVs' `site` rows, d_vertical); each world and rig once.

Each sigma is the root mean square of its errors: the weights are inverse variances, and a
robust spread would hide the tails that a wrong anchor costs most.

Usage: scripts/choose_anchor_sigmas.py [--bench docs/bench]
"""
import argparse
import csv
import math
import os


def rms(values):
    return math.sqrt(sum(v * v for v in values) / len(values))


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bench", default="docs/bench")
    args = parser.parse_args()

    observed = {}
    for name in ["field_seams_hard_iron.csv", "field_seams_procedural_handheld_hard_iron.csv"]:
        for row in csv.DictReader(open(os.path.join(args.bench, name))):
            if row["vertical_observed"] != "1" or int(row["seed"]) > 20:
                continue
            key = (row["preset"], row["rig"], row["seed"], row["session"])
            observed[key] = float(row["true_vertical_bias_uT"]) - float(
                row["calibrated_vertical_bias_uT"])

    site = {}
    for name in ["field_seams.csv", "field_seams_procedural_handheld.csv"]:
        for row in csv.DictReader(open(os.path.join(args.bench, name))):
            if row["row"] != "site" or int(row["seed"]) > 20:
                continue
            site[(row["preset"], row["rig"], row["seed"])] = float(row["d_vertical_uT"])

    for label, values in [("observed_vertical_sigma_uT", observed), ("earth_vertical_sigma_uT", site)]:
        errors = list(values.values())
        presets = sorted({k[0] for k in values})
        print(f"{label}: {rms(errors):.2f}  (RMS of {len(errors)}, {', '.join(presets)}; "
              f"largest {max(abs(e) for e in errors):.2f})")


if __name__ == "__main__":
    main()
