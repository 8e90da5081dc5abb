#!/usr/bin/python3
"""Chooses the matcher's confidence thresholds from a tuning run of bench/match_bench with the
rule opened up (bench/matcher_permissive.yaml), so that the choice is written down and can be
re-run: for each (min_z, min_r) on a grid, how many overlapping pairs the rule would accept
aligned, accept wrong (a false or misplaced match) and how many disjoint pairs it would accept.

Usage: scripts/choose_thresholds.py TUNING_CSV [TUNING_CSV ...] [--max-second-ratio 0.75] [--rig imu]
                                     [--stage joint] [--z-grid 1,1.5,...] [--r-grid 0.6,0.65,...]
--stage keeps the rows of one stage (match_bench's stage column: the joint rule is chosen on the
rows the joint stage answered); the grids default to the field rule's.

The pick: among the thresholds with no wrong acceptance and no disjoint pair accepted, with a
margin (the next-looser step in z and in r must also have none: a threshold right at the edge
of the tuning data is tuned to it), those that accept the most aligned pairs; of these the
strictest (highest min_z, then highest min_r), which keeps the most distance from the
look-alikes at no cost on the tuning seeds.
"""
import argparse
import csv


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("csv", nargs="+")
    parser.add_argument("--max-second-ratio", type=float, default=0.75)
    parser.add_argument("--rig", default=None)
    parser.add_argument("--stage", default=None)
    parser.add_argument("--z-grid", default="1.0,1.5,2.0,2.5,3.0,3.5,4.0,5.0,6.0,7.0,8.0,9.0,10.0,12.0")
    parser.add_argument("--r-grid", default="0.6,0.65,0.7,0.75,0.8,0.825,0.85,0.875,0.9")
    args = parser.parse_args()
    rows = [r for path in args.csv for r in csv.DictReader(open(path))
            if (args.rig is None or r["rig"] == args.rig)
            and (args.stage is None or r.get("stage") == args.stage)]
    seeds = sorted({int(r["seed"]) for r in rows})
    if seeds and max(seeds) > 20:
        raise SystemExit(f"{' '.join(args.csv)} holds seeds above 20 ({max(seeds)}): thresholds are tuned on 1-20 only")
    z_grid = [float(v) for v in args.z_grid.split(",")]
    r_grid = [float(v) for v in args.r_grid.split(",")]

    def outcome(min_z, min_r):
        right = wrong = false = overlapping = disjoint = 0
        for r in rows:
            accept = (float(r["z"]) >= min_z and float(r["r"]) >= min_r
                      and float(r["second_mode_ratio"]) <= args.max_second_ratio)
            if r["overlapping"] == "1":
                overlapping += 1
                aligned = r["aligned"] == "1"
                right += accept and aligned
                wrong += accept and not aligned
            elif r["separate"] == "1":
                disjoint += 1
                false += accept
        return right, wrong, false, overlapping, disjoint

    print(f"{len(rows)} pairs, seeds {seeds[0]}-{seeds[-1]}; second-mode ratio <= {args.max_second_ratio}")
    print("| min_z | min_r | accepted aligned | accepted wrong | disjoint accepted |")
    print("|---|---|---|---|---|")
    safe = {}
    for z in z_grid:
        for rr in r_grid:
            right, wrong, false, overlapping, disjoint = outcome(z, rr)
            safe[(z, rr)] = wrong == 0 and false == 0
            print(f"| {z} | {rr} | {right}/{overlapping} | {wrong} | {false}/{disjoint} |")
    best = None
    for i, z in enumerate(z_grid):
        for j, rr in enumerate(r_grid):
            if i == 0 or j == 0:
                continue  # no looser step to show the margin
            looser = [(z_grid[i - 1], rr), (z, r_grid[j - 1])]
            if safe[(z, rr)] and all(safe[k] for k in looser):
                right = outcome(z, rr)[0]
                if best is None or (right, z, rr) > best:
                    best = (right, z, rr)
    if best:
        print(f"\npick: min_z {best[1]}, min_r {best[2]} ({best[0]} overlapping pairs accepted aligned)")
    else:
        print("\nno threshold on the grid is safe with a margin")


if __name__ == "__main__":
    main()
