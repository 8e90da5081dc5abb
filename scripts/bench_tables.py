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

Each NAME is one small function (registered with @block or @inline) whose docstring says which
file and columns it reads and how it aggregates. The generators live in scripts/bench_tables_lib/:
common.py (registration, readers, the bench programs' aggregations), matching.py (field
statistics, tuning, held-out matching and merges, Aalto, simulator, match bench, refinement),
merge_peers.py (merge bench, featureless merges, peer benchmark), registration.py (ICP-EM against
GICP, the peers' claim rules and held-out verdicts), scale_add.py (scale and add benches) and
heldout.py (issue 31's held-out run, scripts/heldout.sh); this script imports every generator module, parses the arguments and rewrites or
checks the regions.

Medians are the bench programs' upper median (bench/bench_util.hpp: the element at size / 2 once
sorted), so that a table here equals the one the program printed. A region whose name no
function knows, or a function whose region is missing from the files, is an error.

Most sources are CSVs. A few programs print only a Markdown table (merge_bench, sim_bench,
add_bench's accuracy table); those regions parse the committed .md output, say so in their
docstring, and the program should also write a CSV (listed in docs/benchmarks.md).
Standard library only.
"""
import argparse
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from bench_tables_lib import heldout, matching, merge_peers, registration, scale_add  # noqa: E402,F401  (register the regions)
from bench_tables_lib.common import BLOCKS, FILES, INLINES, ROOT  # noqa: E402


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
