#!/usr/bin/env bash
# The joint rule's tuning run (issue 31 slice 4): bench/match_bench --methods joint on the
# procedural tuning worlds (seeds 1-20; docs/heldout_set.md holds 2001 and up out) with the
# joint rule opened up (bench/joint_features.yaml) and the field's match as the default runs it,
# realistic sensors calibrated as merge does. Rows whose stage is "joint" are the pairs the field
# refused, with the best structure candidate the field chose and its features; the rule is then
# chosen by scripts/choose_thresholds.py --stage joint. One CSV per rig,
# docs/bench/joint_tuning_<rig>.csv, grown a seed at a time: a cut run resumes at the first seed
# the CSV lacks (scripts/procedural_tuning.sh's loop, named joint_tuning). MATCH_BENCH overrides
# the program (default ./build/bench/match_bench) and CODE_LABEL the commit recorded in
# docs/bench/joint_tuning.commits (default: HEAD's). NAME and MATCHER name another run and its
# matcher: the thin-overlap run (issue 31 slice 3) is
# NAME=joint_thin MATCHER=bench/joint_thin_features.yaml scripts/joint_tuning.sh imu handheld.
# Usage: scripts/joint_tuning.sh [RIG ...]   (default: imu handheld)
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -gt 0 ] || set -- imu handheld
NAME=${NAME:-joint_tuning} METHODS=joint MATCHER=${MATCHER:-bench/joint_features.yaml} exec scripts/procedural_tuning.sh "$@"
