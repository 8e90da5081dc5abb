#!/usr/bin/env bash
# The held-out run (issue 31 slice 5; the set is fixed in docs/heldout_set.md): every headline
# figure measured once on the procedural worlds at seeds 2001 and up, realistic sensors, each
# session calibrated from its own readings, the default config at the commit that runs it.
# A seed at a time and a part at a time, each part's rows appended to its CSV and the commit that
# wrote them to docs/bench/heldout.commits (part,seed,commit): a cut run resumes at the first
# (seed, part) not recorded there. Parts:
#   match  bench/match_bench, every rig (imu, husky3, array7, handheld), field then joint as
#          merge runs it (method joint): docs/bench/heldout_match.csv. The field alone (method
#          default, docs/heldout_set.md's command) is read from the same rows: the field accepted
#          where the stage is "field" and the pair is accepted, and refused elsewhere (the joint
#          method runs the default's field match first, same settings, same answer). Seeds 2001-2003
#          ran both methods, before this was seen to double the field's work.
#   peers  the cloud peers on the same pairs, the imu robot's sessions (a peer reads no
#          magnetometer), refusing by the rules chosen on tuning seeds
#          (docs/bench/peer_ambiguity_rules.csv, scripts/peer_tuning.sh); skipped, and said so,
#          until that file exists: docs/bench/heldout_peers.csv
#   merge  bench/merge_bench, one sensor (imu) and the 7-sensor array: every overlapping session
#          pair of the four sessions: docs/bench/heldout_merge.csv
#   offset (issue 32) the matching part again for imu and array7 with s1, s3 and the disjoint
#          session's readings shifted by 10 uT along the body's z after calibration (every pair's
#          sessions then differ by that in B_v): docs/bench/heldout_match_offset.csv, to be read
#          pair by pair against heldout_match.csv (the same decision is the target)
#   seams  (issue 32) bench/field_seams_bench, imu and array7, the Earth's vertical field stated:
#          the seams between sessions and the fused map against the truth,
#          docs/bench/heldout_seams.csv; each session's vertical bias left,
#          docs/bench/heldout_seams_hard_iron.csv
#   add    bench/add_bench: the four sessions added one at a time, and merged at once:
#          docs/bench/heldout_add_pairs.csv (the grown atlas's pairs and the merged one's)
#   seams_handheld (issue 32) the seams part with the handheld rig, whose sessions observe their
#          own vertical: the same CSVs
#   anchor (issue 32) the seams part with the handheld rig and with a mix (the first session
#          handheld, the others the imu robot), each merge measured with B_v's anchor as the atlas
#          combines it and with either reference alone (--anchors combined,earth,observed): the
#          same CSVs, labels COMMIT, COMMIT:earth, COMMIT:observed; run on seeds 6001 and up
#   placement (issue 32) the seams part with the mix (the first session handheld, the others
#          the imu robot) and with the imu robot alone, the atlas in the frame of its largest
#          group of matched sessions: which sessions were placed and whether right,
#          docs/bench/heldout_placement.csv (field_seams_bench --placement-csv); the seams and
#          vertical biases of the same merges, docs/bench/heldout_placement_seams.csv and
#          heldout_placement_hard_iron.csv; run on seeds 7001 and up
#   pyramid (issue 33) bench/match_bench, every rig, each pair matched with coarse to fine and
#          with the exhaustive sweep (methods pyramid, exhaustive): docs/bench/heldout_pyramid.csv
#   refine_all (issue 33) the same, each pair matched with every mode of the exhaustive sweep
#          refined and with the best three (methods refine_all, exhaustive):
#          docs/bench/heldout_refine_all.csv; run on seeds 12001 and up
#   joint_pyramid (issue 33) the same, each pair matched by the joint stage with its structure
#          modes proposed by coarse to fine and by the joint stage as merge runs it (methods
#          joint_pyramid, joint): docs/bench/heldout_joint_pyramid.csv; run on seeds 16001 and up
# Usage: scripts/heldout.sh            SEEDS=10 (default 30: 2001-2030) PARTS="match merge"
#        FIRST_SEED=3001 (default 2001): the adds' second set (docs/heldout_set.md)
# Assumes scripts/build.sh has run; BENCH_DIR overrides where the programs are (default
# ./build/bench) and CODE_LABEL the commit recorded.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${BENCH_DIR:-./build/bench}
label=${CODE_LABEL:-$(git rev-parse HEAD)}
parts=(${PARTS:-match peers merge add offset seams})
log=docs/bench/heldout.commits
tmp=$(mktemp)
trap 'rm -rf "$tmp" "$tmp.atlas" "$tmp.hard_iron" "$tmp.placement"' EXIT
append() {  # csv: the part's rows in $tmp appended, the header only to a new file
  if [ -f "$1" ]; then tail -n +2 "$tmp" >>"$1"; else cp "$tmp" "$1"; fi
}
first=${FIRST_SEED:-2001}
for seed in $(seq "$first" $((first - 1 + ${SEEDS:-30}))); do
  for part in "${parts[@]}"; do
    if [ -f "$log" ] && grep -q "^$part,$seed," "$log"; then continue; fi
    rm -f "$tmp"
    case $part in
      match)
        "$bin/match_bench" --presets procedural --first-seed "$seed" --seeds 1 \
          --rigs imu,husky3,array7,handheld --sensors realistic --calibrations estimated \
          --methods joint --csv "$tmp" >/dev/null 2>&1
        append docs/bench/heldout_match.csv ;;
      peers)
        if [ ! -f docs/bench/peer_ambiguity_rules.csv ]; then
          echo "seed $seed: peers skipped, no docs/bench/peer_ambiguity_rules.csv (scripts/peer_tuning.sh)"
          continue
        fi
        "$bin/match_bench" --presets procedural --first-seed "$seed" --seeds 1 --rigs imu \
          --sensors realistic --calibrations estimated \
          --methods pcl-gicp,pcl-ndt,pcl-fpfh-sacia-gicp \
          --peer-rules docs/bench/peer_ambiguity_rules.csv --csv "$tmp" >/dev/null 2>&1
        append docs/bench/heldout_peers.csv ;;
      merge)
        "$bin/merge_bench" --presets procedural --first-seed "$seed" --seeds 1 --rigs imu,array7 \
          --sensors realistic --calibrations estimated --write-atlas 0 --csv "$tmp" >/dev/null 2>&1
        append docs/bench/heldout_merge.csv ;;
      offset)
        "$bin/match_bench" --presets procedural --first-seed "$seed" --seeds 1 \
          --rigs imu,array7 --sensors realistic --calibrations estimated --methods joint \
          --vertical-offset-uT 10 --csv "$tmp" >/dev/null 2>&1
        append docs/bench/heldout_match_offset.csv ;;
      seams | seams_handheld)
        rigs=imu,array7
        [ "$part" = seams ] || rigs=handheld
        "$bin/field_seams_bench" --presets procedural --rigs "$rigs" --first-seed "$seed" \
          --seeds 1 --label "$label" --earth-vertical stated --csv "$tmp" \
          --hard-iron-csv "$tmp.hard_iron" >/dev/null 2>&1
        append docs/bench/heldout_seams.csv
        mv "$tmp.hard_iron" "$tmp"
        append docs/bench/heldout_seams_hard_iron.csv ;;
      anchor)
        "$bin/field_seams_bench" --presets procedural --rigs handheld,handheld+imu \
          --anchors combined,earth,observed --first-seed "$seed" --seeds 1 --label "$label" \
          --earth-vertical stated --csv "$tmp" --hard-iron-csv "$tmp.hard_iron" >/dev/null 2>&1
        append docs/bench/heldout_seams.csv
        mv "$tmp.hard_iron" "$tmp"
        append docs/bench/heldout_seams_hard_iron.csv ;;
      placement)
        "$bin/field_seams_bench" --presets procedural --rigs handheld+imu,imu \
          --first-seed "$seed" --seeds 1 --label "$label" --earth-vertical stated --csv "$tmp" \
          --hard-iron-csv "$tmp.hard_iron" --placement-csv "$tmp.placement" >/dev/null 2>&1
        append docs/bench/heldout_placement_seams.csv
        mv "$tmp.hard_iron" "$tmp"
        append docs/bench/heldout_placement_hard_iron.csv
        mv "$tmp.placement" "$tmp"
        append docs/bench/heldout_placement.csv ;;
      pyramid)
        "$bin/match_bench" --presets procedural --first-seed "$seed" --seeds 1 \
          --rigs imu,husky3,array7,handheld --sensors realistic --calibrations estimated \
          --methods pyramid,exhaustive --csv "$tmp" >/dev/null 2>&1
        append docs/bench/heldout_pyramid.csv ;;
      refine_all)
        "$bin/match_bench" --presets procedural --first-seed "$seed" --seeds 1 \
          --rigs imu,husky3,array7,handheld --sensors realistic --calibrations estimated \
          --methods refine_all,exhaustive --csv "$tmp" >/dev/null 2>&1
        append docs/bench/heldout_refine_all.csv ;;
      joint_pyramid)
        "$bin/match_bench" --presets procedural --first-seed "$seed" --seeds 1 \
          --rigs imu,husky3,array7,handheld --sensors realistic --calibrations estimated \
          --methods joint_pyramid,joint --csv "$tmp" >/dev/null 2>&1
        append docs/bench/heldout_joint_pyramid.csv ;;
      add)
        "$bin/add_bench" --preset procedural --sessions 4 --seed "$seed" --dir "$tmp.atlas" \
          --csv /dev/null --pairs-csv "$tmp" >/dev/null 2>&1
        rm -rf "$tmp.atlas"
        append docs/bench/heldout_add_pairs.csv ;;
    esac
    echo "$part,$seed,$label" >>"$log"
    echo "seed $seed: $part done"
  done
done
