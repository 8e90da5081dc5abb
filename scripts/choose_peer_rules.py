#!/usr/bin/env python3
"""Chooses each cloud peer's claim rule on tuning seeds (issue 15: a fair verdict for peers).

A peer (PCL GICP, NDT, FPFH + SAC-IA + GICP, Open3D FPFH + RANSAC + ICP, mm4mm's ICP-EM from
identity) claims an overlap when it converged, its fitness (share of source points within
0.5 m of the target once aligned) is at least MIN_FITNESS and its inlier RMSE at most
MAX_INLIER_RMSE_M (bench/peer_registration.hpp). This script picks, per method, the pair of
thresholds that maximises correct claims minus wrong claims over the pair registrations that
`peer_bench --pairs-csv` logged:
  correct claim: claimed, the pair truly overlaps and the answer is aligned (0.5 m / 2 deg);
  wrong claim:   claimed, and the pair does not overlap or the answer is not aligned.
Ties go to the loosest rule (most claims). Only seeds 1-20 may be used: the rules are then
scored on seeds from 1001 (docs/benchmarks.md).

Usage: choose_peer_rules.py PAIRS.csv > docs/bench/peer_claim_rules.csv
Writes: method,min_fitness,max_inlier_rmse_m,pairs,overlapping,correct_claims,wrong_claims

--multi-start (issue 31 slice 6): the peers run from several starts on match_bench's pairs
(scripts/peer_tuning.sh), each refusing as mm4mm refuses: it claims when its best answer converged,
fits at least MIN_FITNESS and the best distinct answer fits at most MAX_SECOND_RATIO of it
(bench/peer_registration.hpp's AmbiguityRule). The choice is made as mm4mm's own thresholds are
(scripts/choose_thresholds.py): among the rules with no wrong claim (an overlapping pair claimed
misaligned, or a separate pair claimed), with a margin (the next-looser step in either threshold
must claim nothing wrong either), those claiming the most aligned pairs; of these the strictest.
No rule on the grid qualifies: the method claims nothing (min_fitness 1.01).

Usage: choose_peer_rules.py --multi-start MATCH_BENCH.csv [...] > docs/bench/peer_ambiguity_rules.csv
Writes: method,min_fitness,max_second_ratio,pairs,overlapping,separate,aligned_claims,wrong_claims
"""
import csv
import sys
from collections import defaultdict

MAX_TUNING_SEED = 20


def outcome(rows, min_fitness, max_rmse):
    correct = wrong = 0
    for r in rows:
        if not (r["converged"] and r["fitness"] >= min_fitness and r["rmse"] <= max_rmse):
            continue
        if r["overlaps"] and r["aligned"]:
            correct += 1
        else:
            wrong += 1
    return correct, wrong


def choose(rows):
    fitnesses = sorted({0.0} | {r["fitness"] for r in rows})
    rmses = sorted({r["rmse"] for r in rows} | {1e9}, reverse=True)
    best = None
    for f in fitnesses:  # loosest first: a later rule must do strictly better to win
        for e in rmses:
            correct, wrong = outcome(rows, f, e)
            if best is None or correct - wrong > best[0]:
                best = (correct - wrong, f, e, correct, wrong)
    return best


# Fitness steps of 0.01 above 0.8, where the answers of these peers on building maps lie (right and
# wrong alike reach 0.85-1.0), 0.1 below.
FITNESS_GRID = [round(0.1 * k, 2) for k in range(8)] + [round(0.8 + 0.01 * k, 2) for k in range(21)]
RATIO_GRID = [0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.95, 0.98, 1.0]


def multi_start(paths):
    by_method = defaultdict(list)
    for path in paths:
        with open(path) as f:
            for row in csv.DictReader(f):
                if not row["method"].startswith("pcl-"):
                    continue
                if int(row["seed"]) > MAX_TUNING_SEED:
                    sys.exit(f"{path}: seed {row['seed']} is held out; tune on seeds 1-20 only")
                overlapping = row["overlapping"] == "1"
                by_method[row["method"]].append({
                    # The tuning run claims whatever converged: accepted is convergence there.
                    "converged": row["accepted"] == "1", "fitness": float(row["r"]),
                    "ratio": float(row["second_mode_ratio"]), "overlapping": overlapping,
                    "separate": row["separate"] == "1",
                    "aligned": overlapping and float(row["overlap_error_m"]) < 0.5
                    and float(row["overlap_error_deg"]) < 2.0})

    def outcome(rows, f, q):
        aligned = wrong = 0
        for r in rows:
            if not (r["converged"] and r["fitness"] >= f and r["ratio"] <= q):
                continue
            if r["overlapping"] and r["aligned"]:
                aligned += 1
            elif r["overlapping"] or r["separate"]:
                wrong += 1
        return aligned, wrong

    out = csv.writer(sys.stdout, lineterminator="\n")
    out.writerow(["method", "min_fitness", "max_second_ratio", "pairs", "overlapping", "separate",
                  "aligned_claims", "wrong_claims"])
    for method in sorted(by_method):
        rows = by_method[method]
        best = None  # (aligned claims, min_fitness, -max_second_ratio, wrong claims)
        for i, f in enumerate(FITNESS_GRID):
            for j, q in enumerate(RATIO_GRID):
                aligned, wrong = outcome(rows, f, q)
                looser_f = outcome(rows, FITNESS_GRID[max(i - 1, 0)], q)[1]
                looser_q = outcome(rows, f, RATIO_GRID[min(j + 1, len(RATIO_GRID) - 1)])[1]
                if wrong or looser_f or looser_q:
                    continue
                # Most aligned claims; ties to the strictest (higher fitness, then lower ratio).
                if best is None or (aligned, f, -q) > best[:3]:
                    best = (aligned, f, -q, wrong)
        aligned, f, q, wrong = (0, 1.01, -0.0, 0) if best is None else best
        q = -q
        out.writerow([method, f"{f:.2f}", f"{q:.2f}", len(rows),
                      sum(r["overlapping"] for r in rows), sum(r["separate"] for r in rows),
                      aligned, wrong])


def main():
    if len(sys.argv) >= 3 and sys.argv[1] == "--multi-start":
        multi_start(sys.argv[2:])
        return
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    by_method = defaultdict(list)
    with open(sys.argv[1]) as f:
        for row in csv.DictReader(f):
            if int(row["seed"]) > MAX_TUNING_SEED:
                sys.exit(f"{sys.argv[1]}: seed {row['seed']} is held out; tune on seeds 1-20 only")
            by_method[row["method"]].append({
                "converged": row["converged"] == "1", "fitness": float(row["fitness"]),
                "rmse": float(row["inlier_rmse_m"]), "overlaps": row["overlaps"] == "1",
                "aligned": row["aligned"] == "1"})
    out = csv.writer(sys.stdout, lineterminator="\n")
    out.writerow(["method", "min_fitness", "max_inlier_rmse_m", "pairs", "overlapping",
                  "correct_claims", "wrong_claims"])
    for method in sorted(by_method):
        rows = by_method[method]
        _, f, e, correct, wrong = choose(rows)
        out.writerow([method, f"{f:.4f}", f"{e:.4f}" if e < 1e8 else "1e9", len(rows),
                      sum(r["overlaps"] for r in rows), correct, wrong])


if __name__ == "__main__":
    main()
