#!/usr/bin/env bash
# clang-tidy (.clang-tidy; every finding an error) over the translation units of BUILD whose
# source lies under DIRS (a regex alternation relative to the repository root, e.g.
# 'src|apps'). With BASE (a commit whose units were all clean), only the units that may have
# changed since: those whose source or any file they include (from the compiler's dependency
# files in BUILD) differs from BASE or is untracked. Everything is linted when BASE is empty or
# not in this clone, or when .clang-tidy differs from it.
#   usage: scripts/lint.sh BUILD DIRS [BASE]
set -euo pipefail
build=$1 dirs=$2 base=${3:-}
root=$(pwd)
jobs=${JOBS:-$(nproc)}
scratch=$(mktemp -d)  # the list of changed files and the compile commands clang-tidy reads
trap 'rm -rf "$scratch"' EXIT

mapfile -t units < <(grep -o '"file": "[^"]*"' "$build/compile_commands.json" |
  sed -e 's/^"file": "//' -e 's/"$//' | grep -E "^$root/($dirs)/" | sort -u)
if [[ ${#units[@]} -eq 0 ]]; then
  echo "lint: no translation units under ($dirs) in $build/compile_commands.json" >&2
  exit 2
fi

selected=("${units[@]}")
if [[ -n $base ]]; then
  if git cat-file -e "$base^{commit}" 2>/dev/null && git diff --quiet "$base" -- .clang-tidy; then
    changed=$scratch/changed
    { git diff --name-only "$base" --; git ls-files --others --exclude-standard; } |
      sed "s|^|$root/|" | sort -u > "$changed"
    # Units named in a dependency file that names a changed file: the unit of its object file,
    # or for a unity object file (the CLI's, see apps/rangeseg/CMakeLists.txt) every source it
    # includes. Each file's names are kept until the next file starts (no ENDFILE in mawk).
    mapfile -t selected < <(find "$build" -name '*.o.d' -print0 | xargs -0 awk -v list="$changed" '
      BEGIN { while ((getline line < list) > 0) changed[line] = 1 }
      function flush(name) {
        if (file_hit) for (name in names) hit[name] = 1
        split("", names)
        file_hit = 0
      }
      FNR == 1 { flush() }
      {
        for (i = 1; i <= NF; ++i) {
          f = $i
          if (f == "\\" || f ~ /:$/) continue
          names[f] = 1
          if (f in changed) file_hit = 1
        }
      }
      END { flush(); for (u in hit) print u }' | sort -u | grep -Fx -f <(printf '%s\n' "${units[@]}") || true)
    echo "lint: ${#selected[@]} of ${#units[@]} translation units changed since $base"
  else
    echo "lint: base '$base' is not in this clone or .clang-tidy changed since: linting all"
  fi
fi
if [[ ${#selected[@]} -gt 0 ]]; then
  # run-clang-tidy takes regexes: match each unit's whole path.
  patterns=()
  for unit in "${selected[@]}"; do patterns+=("^$(printf '%s' "$unit" | sed 's/[][\.*^$+?(){}|]/\\&/g')\$"); done
  # The tests' precompiled header is GCC's (tests/CMakeLists.txt), which clang cannot read: the
  # commands lose its forced include (each test includes what it uses itself).
  sed -e 's| -Winvalid-pch -include [^ "]*/cmake_pch\.hxx||g' "$build/compile_commands.json" \
    > "$scratch/compile_commands.json"
  run-clang-tidy -quiet -p "$scratch" -j "$jobs" "${patterns[@]}"
fi
