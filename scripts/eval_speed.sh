#!/usr/bin/env bash
# How long `mm4mm eval` takes on a 4-session warehouse atlas (issue 35, slice 2: eval reads where
# each session went, not its magnetometer readings and scans). Warehouse seed 1, four sessions
# merged without the OctoMap by BIN's mm4mm; then `mm4mm eval` of that atlas RUNS times (default
# 5) by BEFORE's mm4mm (a copy of an earlier build with its libraries beside it) and by BIN's,
# alternating, so both see the same page cache. Appends one row per binary, labelled LABEL (default:
# the checkout's commit, "+" when it has uncommitted changes) and "before" or "after", to
# docs/bench/eval_speed.csv: the median wall time, the median peak resident memory, and the size
# of the sessions' files. About a minute.
# Usage: BEFORE=DIR [BIN=DIR] [RUNS=N] scripts/eval_speed.sh [LABEL]
set -euo pipefail
cd "$(dirname "$0")/.."
label=${1:-$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- src include || echo +)}
before=$(realpath "${BEFORE:?BEFORE: the directory of an earlier build\'s mm4mm}")
bin=$(realpath "${BIN:-./build}")
runs=${RUNS:-5}
csv=docs/bench/eval_speed.csv
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$bin/mm4mm" simulate --world warehouse --sessions 4 --seed 1 --out "$tmp/wh" >/dev/null 2>&1
"$bin/mm4mm" merge "$tmp"/wh/s* --out "$tmp/atlas" --no-octomap >/dev/null 2>&1
session_mib=$(du -sm "$tmp/wh" | cut -f1)
for run in $(seq "$runs"); do
  for which in before after; do
    dir=$bin
    [ "$which" = after ] || dir=$before
    LD_LIBRARY_PATH="$dir" /usr/bin/time -f "%e %M" -o "$tmp/time" "$dir/mm4mm" eval \
      "$tmp/atlas" >"$tmp/eval_$which.txt" 2>&1
    echo "$which $(cat "$tmp/time")" >>"$tmp/times"
  done
done
# The same accuracy figures from both: eval's answer must not depend on what it reads.
if ! diff -q "$tmp/eval_before.txt" "$tmp/eval_after.txt" >/dev/null; then
  diff "$tmp/eval_before.txt" "$tmp/eval_after.txt" || true
  echo "eval_speed: the two binaries printed different evaluations" >&2
  exit 1
fi
if [ ! -f "$csv" ]; then
  echo "label,binary,sessions,session_files_mib,runs,seconds_median,peak_rss_mib_median" >"$csv"
fi
python3 - "$label" "$session_mib" "$runs" "$tmp/times" "$csv" <<'PY'
import statistics, sys
label, mib, runs, times, out = sys.argv[1:]
rows = [line.split() for line in open(times)]
for which in ("before", "after"):
    seconds = [float(r[1]) for r in rows if r[0] == which]
    kib = [int(r[2]) for r in rows if r[0] == which]
    row = (f"{label},{which},4,{mib},{runs},{statistics.median(seconds):.2f},"
           f"{statistics.median(kib) / 1024:.0f}")
    open(out, "a").write(row + "\n")
    print(row)
PY
