#!/usr/bin/env bash
# rangeseg against PCL 1.13 on the same inputs, by the same scoring (`make compare-pcl`):
#   1. time per stage on ../shared/data/kinect/grabber_frame0.pcd, one process, one core;
#   2. SegComp scores (T = 0.8) of both segmentations on synthetic Kinect scenes (seeds 1-16),
#      the labelled OSD frames and the SegComp ABW images, when ../shared is there.
# Usage: scripts/compare-pcl.sh PCL_BUILD_DIR RANGESEG_BUILD_DIR OUT_DIR
set -euo pipefail
pcl_build=${1:?PCL build directory}
build=${2:?rangeseg build directory}
out=${3:?output directory}
rangeseg="$build/apps/rangeseg/rangeseg"
pcl_segment="$pcl_build/bench/pcl/rangeseg_pcl_segment"
bench="$pcl_build/bench/pcl/rangeseg_bench_pcl"
data="$(dirname "$0")/../../shared/data"
for tool in "$rangeseg" "$pcl_segment" "$bench"; do
  [[ -x "$tool" ]] || { echo "compare-pcl: $tool not built" >&2; exit 2; }
done
mkdir -p "$out"
pin=()
if command -v taskset > /dev/null && (($(nproc) > 1)); then pin=(taskset -c 1); fi

echo "== Time per frame, single thread (median of 5 repetitions)"
"${pin[@]}" "$bench" --benchmark_repetitions=5 --benchmark_display_aggregates_only=true |
  grep -E "Benchmark|----|_median"

# score GT PRED [CLOUD]: "gt correct over under missed noise" of `rangeseg eval`'s table row.
score() {
  local args=("$1" "$2")
  [[ -n "${3:-}" ]] && args+=(--cloud "$3")
  "$rangeseg" eval "${args[@]}" | awk 'NR == 2 { print $2, $4, $5, $6, $7, $8 }'
}
# total NAME FILE: the column sums of a file of score lines, as a table row.
total() {
  awk -v name="$1" '{ for (i = 1; i <= 6; ++i) s[i] += $i }
    END { printf "| %s | %d | %d (%.1f %%) | %d | %d | %d | %d |\n", name, s[1], s[2],
          s[1] ? 100 * s[2] / s[1] : 0, s[3], s[4], s[5], s[6] }' "$2"
}
header() {
  echo "| $1 | GT regions | correct | over | under | missed | noise |"
  echo "|---|---|---|---|---|---|---|"
}

# PCL's parameters: those of its organized_segmentation_demo (bench/pcl/pcl_pipeline.hpp), the
# same after its FastBilateralFilter, and the best of 24 settings tried on the synthetic box scenes
# below (docs/measurements.md), i.e. tuned on the test data itself.
pcl_variants=(demo filtered tuned)
pcl_args_demo=()
pcl_args_filtered=(--smooth)
pcl_args_tuned=(--smooth --angular-threshold 10 --distance-threshold 0.05 --normal-smoothing 10)
pcl_names=([0]="PCL OrganizedMultiPlaneSegmentation, demo parameters"
           [1]="PCL, FastBilateralFilter first"
           [2]="PCL, tuned on the box scenes")

# evaluate NAME INPUT GT [CLOUD] [RANGESEG_ARGS...]: segments INPUT with rangeseg (plain and
# `--model auto`) and with each PCL variant into $out/NAME*, scores each against GT and appends
# the scores to $out/<set>.<method>, where <set> is $set.
evaluate() {
  local name=$1 input=$2 gt=$3 cloud=$4
  shift 4
  "$rangeseg" segment "$input" -o "$out/$name.plane" "$@" > /dev/null
  "$rangeseg" segment "$input" -o "$out/$name.auto" --model auto "$@" > /dev/null
  score "$gt" "$out/$name.plane/labels.png" "$cloud" >> "$out/$set.plane"
  score "$gt" "$out/$name.auto/labels.png" "$cloud" >> "$out/$set.auto"
  local variant
  for variant in "${pcl_variants[@]}"; do
    local -n args="pcl_args_$variant"
    "$pcl_segment" "$input" -o "$out/$name.pcl_$variant.png" "${args[@]}"
    score "$gt" "$out/$name.pcl_$variant.png" "$cloud" >> "$out/$set.pcl_$variant"
  done
}
# report TITLE: the table of $set.
report() {
  header "$1"
  total "rangeseg, plane model" "$out/$set.plane"
  total "rangeseg, --model auto" "$out/$set.auto"
  local i
  for i in "${!pcl_variants[@]}"; do
    total "${pcl_names[$i]}" "$out/$set.pcl_${pcl_variants[$i]}"
  done
  echo
}
begin() {
  set=$1
  rm -f "$out/$set".*
}

echo
echo "== SegComp scores, T = 0.8 (rangeseg eval)"
for scene in boxes mixed; do
  begin "$scene"
  for seed in $(seq 1 16); do
    dir="$out/$scene$seed"
    "$rangeseg" synth --scene "$scene" --seed "$seed" --noise kinect -o "$dir" > /dev/null 2>&1
    evaluate "$scene$seed" "$dir/cloud.pcd" "$dir/labels.png" "$dir/cloud.pcd"
  done
  report "synthetic $scene, seeds 1-16"
done

if [[ -d "$data/osd" ]]; then
  begin osd
  for frame in "$data"/osd/*.pcd; do evaluate "osd_$(basename "$frame" .pcd)" "$frame" "$frame" ""; done
  report "OSD frames (real Kinect)"
else
  echo "compare-pcl: $data/osd not found; skipping the OSD frames" >&2
fi

if [[ -d "$data/segcomp_abw" ]]; then
  begin abw
  for range in "$data"/segcomp_abw/abw.test.*.range; do
    evaluate "$(basename "$range" .range)" "$range" "${range%.range}.gt-seg" ""
  done
  report "SegComp ABW 0-9 (rangeseg: preset auto = abw)"
else
  echo "compare-pcl: $data/segcomp_abw not found; skipping ABW" >&2
fi
