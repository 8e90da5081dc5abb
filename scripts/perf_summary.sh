#!/usr/bin/env bash
# Prints perf's share of the cycles per library and the hottest symbols of a perf.data, under a
# title line: the profile summaries the speed scripts commit (scripts/match_speed.sh,
# scripts/merge_speed.sh).
# Usage: scripts/perf_summary.sh PERF_DATA TITLE LIBRARIES SYMBOLS
set -euo pipefail
data=$1 title=$2 libraries=$3 symbols=$4
echo "# $title: cycles per library"
perf report -i "$data" --no-children --sort dso --stdio 2>/dev/null |
  grep -E '^ +[0-9]' | awk -v n="$libraries" 'NR <= n'
echo "# the hottest symbols"
perf report -i "$data" --no-children --sort dso,sym --stdio 2>/dev/null |
  grep -E '^ +[0-9]' | awk -v n="$symbols" 'NR <= n' | cut -c1-150
