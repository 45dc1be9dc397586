#!/usr/bin/env bash
# rangeseg against PCL 1.13 and Open3D 0.16 on the same inputs, by the same scoring
# (`make compare`):
#   1. time per stage on ../shared/data/kinect/grabber_frame0.pcd, one process, one core;
#   2. SegComp scores (T = 0.8, `rangeseg eval`) of every method's planes on synthetic Kinect
#      scenes (seeds 1-16), the labelled OSD frames and the SegComp ABW images (when ../shared
#      is there).
# A library whose tools are not built in COMPARE_BUILD_DIR is left out. COMPARE_PARTS (default
# "time boxes mixed osd abw") picks the parts to run.
# Usage: scripts/compare.sh COMPARE_BUILD_DIR RANGESEG_BUILD_DIR OUT_DIR
set -euo pipefail
compare_build=${1:?build directory of bench/compare}
build=${2:?rangeseg build directory}
out=${3:?output directory}
rangeseg="$build/apps/rangeseg/rangeseg"
tools="$compare_build/bench/compare"
data="$(dirname "$0")/../../shared/data"
[[ -x "$rangeseg" ]] || { echo "compare: $rangeseg not built" >&2; exit 2; }
have_pcl=0 have_open3d=0
[[ -x "$tools/rangeseg_pcl_segment" && -x "$tools/rangeseg_bench_pcl" ]] && have_pcl=1
[[ -x "$tools/rangeseg_open3d_segment" && -x "$tools/rangeseg_bench_open3d" ]] && have_open3d=1
((have_pcl + have_open3d > 0)) || { echo "compare: no comparison tool in $tools" >&2; exit 2; }
mkdir -p "$out"
# Open3D's loops use OpenMP; all timings are single thread.
export OMP_NUM_THREADS=1
parts=" ${COMPARE_PARTS:-time boxes mixed osd abw} "
pin=()
if command -v taskset > /dev/null && (($(nproc) > 1)); then pin=(taskset -c 1); fi

[[ "$parts" == *" time "* ]] && echo "== Time per frame, single thread (median of 5 repetitions)"
for library in pcl open3d; do
  [[ "$parts" == *" time "* ]] || break
  [[ "$library" == pcl ]] && ((have_pcl == 0)) && continue
  [[ "$library" == open3d ]] && ((have_open3d == 0)) && continue
  "${pin[@]}" "$tools/rangeseg_bench_$library" --benchmark_repetitions=5 \
    --benchmark_display_aggregates_only=true | grep -E "_median"
done

# The methods whose planes are scored: a name, and the command that writes a label PNG for
# "$input" to "$labels". PCL's parameters: those of its organized_segmentation_demo
# (bench/compare/pcl_pipeline.hpp), the same after its FastBilateralFilter, and the best of 24
# settings tried on the synthetic box scenes below, i.e. tuned on the test data itself. Open3D's:
# its tutorial's (bench/compare/open3d_pipeline.hpp), and the best of 6 settings tried on the box
# scenes (each plane's inliers split by DBSCAN). docs/measurements.md has the settings tried.
methods=(plane auto)
declare -A title=([plane]="rangeseg, plane model" [auto]="rangeseg, --model auto")
declare -A command=([plane]='"$rangeseg" segment "$input" -o "$labels.d" > /dev/null && mv "$labels.d/labels.png" "$labels"'
                    [auto]='"$rangeseg" segment "$input" -o "$labels.d" --model auto > /dev/null && mv "$labels.d/labels.png" "$labels"')
if ((have_pcl)); then
  methods+=(pcl pcl_filtered pcl_tuned)
  title+=([pcl]="PCL OrganizedMultiPlaneSegmentation, demo parameters"
          [pcl_filtered]="PCL, FastBilateralFilter first" [pcl_tuned]="PCL, tuned on the box scenes")
  command+=([pcl]='"$tools/rangeseg_pcl_segment" "$input" -o "$labels"'
            [pcl_filtered]='"$tools/rangeseg_pcl_segment" "$input" -o "$labels" --smooth'
            [pcl_tuned]='"$tools/rangeseg_pcl_segment" "$input" -o "$labels" --smooth --angular-threshold 10 --distance-threshold 0.05 --normal-smoothing 10')
fi
if ((have_open3d)); then
  methods+=(open3d open3d_tuned)
  title+=([open3d]="Open3D SegmentPlane repeated, tutorial parameters"
          [open3d_tuned]="Open3D, tuned on the box scenes (DBSCAN 5 cm)")
  command+=([open3d]='"$tools/rangeseg_open3d_segment" "$input" -o "$labels"'
            [open3d_tuned]='"$tools/rangeseg_open3d_segment" "$input" -o "$labels" --cluster-radius 0.05')
fi

# score GT PRED [CLOUD]: "gt correct over under missed noise" of `rangeseg eval`'s table row.
score() {
  local args=("$1" "$2")
  [[ -n "${3:-}" ]] && args+=(--cloud "$3")
  "$rangeseg" eval "${args[@]}" | awk 'NR == 2 { print $2, $4, $5, $6, $7, $8 }'
}
# The methods left out of a set: on ABW's scale (millimetres between points) a 5 cm DBSCAN
# radius holds tens of thousands of neighbours a point (minutes and 5 GB an image).
declare -A skip=([abw]="open3d_tuned")
# evaluate NAME INPUT GT [CLOUD]: every method's labels of INPUT scored against GT, appended to
# $out/$set.<method>.
evaluate() {
  local name=$1 input=$2 gt=$3 cloud=$4 method labels
  for method in "${methods[@]}"; do
    [[ " ${skip[$set]:-} " == *" $method "* ]] && continue
    labels="$out/$name.$method.png"
    eval "${command[$method]}"
    score "$gt" "$labels" "$cloud" >> "$out/$set.$method"
  done
}
begin() {
  set=$1
  rm -f "$out/$set".*
}
# report TITLE: the table of $set, one row per method with the column sums.
report() {
  echo "| $1 | GT regions | correct | over | under | missed | noise |"
  echo "|---|---|---|---|---|---|---|"
  local method
  for method in "${methods[@]}"; do
    [[ " ${skip[$set]:-} " == *" $method "* ]] && continue
    awk -v name="${title[$method]}" '{ for (i = 1; i <= 6; ++i) s[i] += $i }
      END { printf "| %s | %d | %d (%.1f %%) | %d | %d | %d | %d |\n", name, s[1], s[2],
            s[1] ? 100 * s[2] / s[1] : 0, s[3], s[4], s[5], s[6] }' "$out/$set.$method"
  done
  echo
}

echo
echo "== SegComp scores, T = 0.8"
for scene in boxes mixed; do
  [[ "$parts" == *" $scene "* ]] || continue
  begin "$scene"
  for seed in $(seq 1 16); do
    dir="$out/$scene$seed"
    "$rangeseg" synth --scene "$scene" --seed "$seed" --noise kinect -o "$dir" > /dev/null 2>&1
    evaluate "$scene$seed" "$dir/cloud.pcd" "$dir/labels.png" "$dir/cloud.pcd"
  done
  report "synthetic $scene, seeds 1-16"
done

if [[ "$parts" != *" osd "* ]]; then
  :
elif [[ -d "$data/osd" ]]; then
  begin osd
  for frame in "$data"/osd/*.pcd; do evaluate "osd_$(basename "$frame" .pcd)" "$frame" "$frame" ""; done
  report "OSD frames (real Kinect)"
else
  echo "compare: $data/osd not found; skipping the OSD frames" >&2
fi

if [[ "$parts" != *" abw "* ]]; then
  :
elif [[ -d "$data/segcomp_abw" ]]; then
  begin abw
  for range in "$data"/segcomp_abw/abw.test.*.range; do
    evaluate "$(basename "$range" .range)" "$range" "${range%.range}.gt-seg" ""
  done
  report "SegComp ABW 0-9 (rangeseg: preset auto = abw)"
else
  echo "compare: $data/segcomp_abw not found; skipping ABW" >&2
fi
