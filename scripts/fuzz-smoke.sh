#!/usr/bin/env bash
# Runs every fuzz target briefly on its committed seed corpus (fuzz/corpus/<target>/).
set -euo pipefail
build=${1:-build-fuzz}
seconds=${FUZZ_SECONDS:-15}
root=$(cd "$(dirname "$0")/.." && pwd)
shopt -s nullglob
for bin in "$build"/fuzz/fuzz_*; do
  [[ -x $bin && ! -d $bin ]] || continue
  name=$(basename "$bin")
  corpus="$root/fuzz/corpus/${name#fuzz_}"
  work=$(mktemp -d)
  [[ -d $corpus ]] && cp -r "$corpus"/. "$work"/
  echo "fuzz smoke: $name for ${seconds}s" >&2
  "$bin" -max_total_time="$seconds" -max_len=65536 -rss_limit_mb=1024 -print_final_stats=1 "$work" 2>&1 | tail -n 3
  rm -rf "$work"
done
