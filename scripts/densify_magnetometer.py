#!/usr/bin/env python3
"""Rewrites a session's magnetometer.csv with FACTOR times as many rows, for memory_bound.sh's
10 M-row log (issue 19): between two readings of every sensor, FACTOR - 1 readings interpolated
linearly in time, as a log at FACTOR times the rate of the same field would hold. Simulating such a
rate directly takes minutes per million rows; the bound counts rows, not their values.

Usage: scripts/densify_magnetometer.py SESSION_DIR FACTOR
The file must hold, at every time stamp, one reading of each sensor in the same order (what
`mm4mm simulate` writes); anything else is refused with the line.
"""
import csv
import os
import sys


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    path = os.path.join(sys.argv[1], "magnetometer.csv")
    factor = int(sys.argv[2])
    if factor < 1:
        sys.exit("densify_magnetometer: FACTOR must be >= 1")
    out_path = path + ".dense"
    with open(path, newline="") as f, open(out_path, "w", newline="") as out:
        rows = csv.reader(f)
        header = next(rows)
        if header != ["t", "sensor", "bx", "by", "bz"]:
            sys.exit(f"{path}:1: expected the header t,sensor,bx,by,bz")
        out.write(",".join(header) + "\n")
        block, block_t, previous = [], None, None

        def flush(current):
            # Writes `previous` and the blocks between it and `current` (None: the last block).
            if previous is None:
                return
            t0, readings0 = previous
            steps = factor if current is not None else 1
            for j in range(steps):
                w = j / factor
                t = t0 + w * (current[0] - t0) if current is not None else t0
                for (sensor, b0), (_, b1) in zip(readings0,
                                                  current[1] if current else readings0):
                    b = [x0 + w * (x1 - x0) for x0, x1 in zip(b0, b1)]
                    out.write(f"{t:.6f},{sensor},{b[0]:.4f},{b[1]:.4f},{b[2]:.4f}\n")

        for line, row in enumerate(rows, start=2):
            t, sensor = float(row[0]), row[1]
            if block_t is not None and t != block_t:
                current = (block_t, block)
                if previous is not None and [s for s, _ in previous[1]] != [s for s, _ in block]:
                    sys.exit(f"{path}:{line}: the sensors at t={block_t} differ from before")
                flush(current)
                previous, block = current, []
            block_t = t
            block.append((sensor, [float(x) for x in row[2:5]]))
        if block:
            current = (block_t, block)
            flush(current)
            previous = current
            flush(None)
    os.replace(out_path, path)


if __name__ == "__main__":
    main()
