#!/usr/bin/python3
"""Every writer killed at random (issue 19): `mm4mm merge`, `mm4mm add`, `mm4mm export octomap` and
`mm4mm import` each SIGKILLed at KILLS moments over 1.3 times its own run (one moment drawn uniformly in each
KILLS-th of that span, from a fixed seed), on the small corridor (configs/corridor_small.yaml,
sessions s0-s2 of simulation seed 5). After each kill the target is examined:
  merge:  no atlas at the target ("old"), or one that `mm4mm eval` loads whole ("new");
  add:    the previous atlas byte for byte ("old"), or the new one, whole, with s2 ("new");
  export: the atlas byte for byte as add left it, without octomap.bt ("old"), or whole with
          octomap.bt, the file an export that ran to the end writes ("new");
  import: (TUM + PCD of s0, sensor 0's readings, --overwrite) the session an earlier import
          wrote with another id, byte for byte ("old"), or the one an uninterrupted import writes
          ("new").
Anything else is "partial" (a directory eval refuses, or one that is neither state). Afterwards
the writer runs once more to the end from the state before, and no scratch directory
(ATLAS.partial<pid>) of the killed ones may be left beside the atlas (the row counts the kills
that left one: those that landed while the atlas was being written). One row per writer is
appended to CSV (default docs/bench/kill_campaign.csv). Exits 1 when a kill left a partial atlas,
scratch was left after the next write, or a writer's kills did not land both before and after
its swap. Standard library only; about 10 minutes with 30 kills each.

Usage: python3 scripts/kill_campaign.py [--bin build/mm4mm] [--kills 30] [--seed 1]
                                        [--label LABEL] [--csv FILE]
"""
import argparse
import csv
import filecmp
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(args, check=True):
    done = subprocess.run(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if check and done.returncode != 0:
        sys.exit(f"failed ({done.returncode}): {' '.join(args)}\n{done.stdout}")
    return done


def same_tree(a, b):
    """True when directories a and b hold the same files with the same bytes."""
    def files(d):
        return sorted(os.path.relpath(os.path.join(p, f), d) for p, _, fs in os.walk(d) for f in fs)
    if files(a) != files(b):
        return False
    return all(filecmp.cmp(os.path.join(a, f), os.path.join(b, f), shallow=False) for f in files(a))


def loads(binary, atlas):
    return run([binary, "eval", atlas], check=False).returncode == 0


def scratch_left(atlas):
    parent, name = os.path.split(atlas)
    return [f for f in os.listdir(parent) if f.startswith(name + ".partial")]


def campaign(name, binary, command, prepare, outcome, kills, rng):
    """Kills `command` at `kills` moments; returns the row's counts."""
    prepare()
    start = time.monotonic()
    run(command)
    full_s = time.monotonic() - start
    counts = {"old": 0, "new": 0, "partial": 0}
    target = command_target(name, command)
    left_scratch = 0  # kills that left a scratch directory (killed while writing the atlas)
    for k in range(kills):
        prepare()
        before = set(scratch_left(target))
        child = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(1.3 * full_s * (k + rng.random()) / kills)
        child.send_signal(signal.SIGKILL)
        child.wait()
        counts[outcome()] += 1
        left_scratch += bool(set(scratch_left(target)) - before)
    prepare()
    run(command)  # the next writer, to the end: it removes the scratch of the killed ones
    left_after = len(scratch_left(target))
    print(f"{name}: full run {full_s:.1f} s; {kills} kills: {counts['old']} old, {counts['new']} new, "
          f"{counts['partial']} partial; {left_scratch} kills left a scratch directory, "
          f"{left_after} left after the next write", flush=True)
    return full_s, counts, left_scratch, left_after


def command_target(name, command):
    if name in ("merge", "import"):
        return command[command.index("--out") + 1]
    return command[3 if name == "export" else 2]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bin", default=os.path.join(ROOT, "build", "mm4mm"))
    parser.add_argument("--kills", type=int, default=30)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--label", default=None)
    parser.add_argument("--csv", default=os.path.join(ROOT, "docs", "bench", "kill_campaign.csv"))
    args = parser.parse_args()
    binary = os.path.abspath(args.bin)
    label = args.label or run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"]).stdout.strip()
    rng = random.Random(args.seed)
    tmp = tempfile.mkdtemp(prefix="mm4mm_kills_")
    try:
        sessions = os.path.join(tmp, "sessions")
        run([binary, "simulate", "--config", os.path.join(ROOT, "configs", "corridor_small.yaml"),
             "--sessions", "3", "--seed", "5", "--out", sessions])
        s = [os.path.join(sessions, f"s{i}") for i in range(3)]
        atlas = os.path.join(tmp, "atlas")
        states = {name: os.path.join(tmp, name) for name in ("two", "three", "three_octomap")}
        run([binary, "merge", s[0], s[1], "--out", states["two"]])
        shutil.copytree(states["two"], states["three"])
        run([binary, "add", states["three"], s[2]])
        shutil.copytree(states["three"], states["three_octomap"])
        run([binary, "export", "octomap", states["three_octomap"]])

        def restore(state):
            def prepare():
                shutil.rmtree(atlas, ignore_errors=True)
                if state:
                    shutil.copytree(states[state], atlas)
            return prepare

        def merge_outcome():
            if not os.path.exists(atlas):
                return "old"
            return "new" if loads(binary, atlas) else "partial"

        def add_outcome():
            if same_tree(atlas, states["two"]):
                return "old"
            whole = loads(binary, atlas) and "- id: s2" in open(os.path.join(atlas, "atlas.yaml")).read()
            return "new" if whole else "partial"

        def export_outcome():
            if same_tree(atlas, states["three"]):
                return "old"
            octomap = os.path.join(atlas, "octomap.bt")
            whole = (loads(binary, atlas) and os.path.exists(octomap) and
                     filecmp.cmp(octomap, os.path.join(states["three_octomap"], "octomap.bt"), shallow=False))
            return "new" if whole else "partial"

        # import: sensor 0's readings of s0 as a magnetometer table, its scans and poses as TUM
        # + PCD, over a session a first import wrote with another id (--overwrite).
        table = os.path.join(tmp, "mag.csv")
        with open(os.path.join(s[0], "magnetometer.csv")) as src, open(table, "w") as dst:
            dst.write("t,x,y,z\n")
            for line in list(src)[1:]:
                t, sensor, bx, by, bz = line.strip().split(",")
                if sensor == "0":
                    dst.write(f"{t},{bx},{by},{bz}\n")
        imported = os.path.join(tmp, "imported")

        def import_command(session_id, out):
            return [binary, "import", "--from", "tum_pcd", "--input", os.path.join(s[0], "scans"),
                    "--poses", os.path.join(s[0], "poses.txt"), "--mag", table, "--out", out,
                    "--id", session_id, "--overwrite"]
        states["imported_first"] = os.path.join(tmp, "imported_first")
        states["imported_second"] = os.path.join(tmp, "imported_second")
        run(import_command("first", states["imported_first"]))
        run(import_command("second", states["imported_second"]))

        def import_restore():
            shutil.rmtree(imported, ignore_errors=True)
            shutil.copytree(states["imported_first"], imported)

        def import_outcome():
            if same_tree(imported, states["imported_first"]):
                return "old"
            return "new" if same_tree(imported, states["imported_second"]) else "partial"

        writers = [
            ("merge", [binary, "merge", s[0], s[1], "--out", atlas], restore(None), merge_outcome),
            ("add", [binary, "add", atlas, s[2]], restore("two"), add_outcome),
            ("export", [binary, "export", "octomap", atlas], restore("three"), export_outcome),
            ("import", import_command("second", imported), import_restore, import_outcome),
        ]
        failures = []
        fresh = not os.path.exists(args.csv)
        with open(args.csv, "a", newline="") as fh:
            out = csv.writer(fh)
            if fresh:
                out.writerow(["label", "writer", "seed", "kills", "full_run_s", "old", "new", "partial",
                              "kills_leaving_scratch", "scratch_after_next_write"])
            for name, command, prepare, outcome in writers:
                full_s, counts, before, after = campaign(name, binary, command, prepare, outcome,
                                                         args.kills, rng)
                out.writerow([label, name, args.seed, args.kills, f"{full_s:.2f}", counts["old"],
                              counts["new"], counts["partial"], before, after])
                fh.flush()
                if counts["partial"] or after:
                    failures.append(f"{name}: {counts['partial']} partial, {after} scratch left")
                if not counts["old"] or not counts["new"]:
                    failures.append(f"{name}: the kills did not land both before and after the swap")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    for failure in failures:
        print("FAILED " + failure, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
