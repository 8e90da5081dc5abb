#!/usr/bin/env bash
# Chooses the Gaussian-process map's length scale (merge.matcher.map.gaussian_process.
# length_scale_m) on the procedural tuning worlds, seeds 1-20, for the rigs it applies to (one
# magnetometer: imu, handheld): match_bench with the acceptance opened up
# (bench/matcher_features.yaml) at each candidate length scale, one CSV per value and rig in
# docs/bench/gp_length_scale_<value>_<rig>.csv (0.4, the value before, is the tuning run's
# docs/bench/procedural_tuning_<rig>.csv), grown a seed at a time so that a cut run resumes; then
# scripts/choose_gp_length_scale.py picks. Assumes scripts/build.sh has run.
set -euo pipefail
cd "$(dirname "$0")/.."
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for scale in 0.25 0.6; do
  cp bench/matcher_features.yaml "$tmp/$scale.yaml"
  printf '    map:\n      gaussian_process:\n        length_scale_m: %s\n' "$scale" >> "$tmp/$scale.yaml"
  for rig in imu handheld; do
    csv=docs/bench/gp_length_scale_${scale}_$rig.csv
    for seed in $(seq 1 20); do
      if [ -f "$csv" ] && cut -d, -f5 "$csv" | grep -qx "$seed"; then continue; fi
      ./build/bench/match_bench --presets procedural --first-seed "$seed" --seeds 1 --rigs "$rig" \
        --sensors realistic --calibrations estimated --methods default \
        --matcher "$tmp/$scale.yaml" --csv "$tmp/rows.csv" > /dev/null 2>&1
      if [ -f "$csv" ]; then tail -n +2 "$tmp/rows.csv" >> "$csv"; else cp "$tmp/rows.csv" "$csv"; fi
      echo "$scale $rig seed $seed"
    done
  done
done
/usr/bin/python3 scripts/choose_gp_length_scale.py | tee docs/bench/gp_length_scale.md
