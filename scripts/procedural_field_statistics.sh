#!/usr/bin/env bash
# The field of the procedural buildings against the real Aalto recordings: one clean-sensor
# session (one magnetometer at 0.3 m, 250 m from a random start) per building type at three
# tuning seeds of its own (hallway 1-3, office 4-6, ... hall 13-15: each building a floor of its
# own, since a type's floor steel is drawn first from its seed), through scripts/field_statistics.py, with the Aalto sequences beside them where
# ../shared/data holds them. Writes docs/bench/field_statistics_procedural.{csv,md}.
# Assumes scripts/build.sh has run. About a minute.
set -euo pipefail
cd "$(dirname "$0")/.."
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
sessions=()
first=1
for building in hallway office garage racks hall; do
  printf 'world: procedural\nprocedural: {building: %s}\nlidar: {enabled: false}\n' "$building" \
    > "$tmp/$building.yaml"
  printf 'magnetometer_errors: {model: clean}\n' >> "$tmp/$building.yaml"
  for seed in $(seq $first $((first + 2))); do
    ./build/mm4mm simulate --config "$tmp/$building.yaml" --sessions 1 --seed "$seed" \
      --out "$tmp/$building-$seed" >/dev/null
    sessions+=("$building-$seed=$tmp/$building-$seed/s0")
  done
  first=$((first + 3))
done
data=../shared/data/aalto-magnetic-data
if [ -d "$data" ]; then
  /usr/bin/python3 scripts/convert_aalto.py --data "$data" --all "$tmp/aalto" >/dev/null
  for k in 1 3 5 7; do sessions+=("aalto-$k=$tmp/aalto/seq$k"); done
else
  echo "note: $data not found; simulated buildings only" >&2
fi
/usr/bin/python3 scripts/field_statistics.py --csv docs/bench/field_statistics_procedural.csv \
  "${sessions[@]}" | tee docs/bench/field_statistics_procedural.md
