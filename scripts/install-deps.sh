#!/usr/bin/env bash
# Installs the Debian packages rangeseg needs, and only those that are missing.
# Idempotent; works as root or through sudo.
set -euo pipefail
packages=(build-essential cmake pkg-config libeigen3-dev libpng-dev liblzf-dev nlohmann-json3-dev libyaml-cpp-dev
          libnanoflann-dev libcli11-dev googletest libgtest-dev libgmock-dev libbenchmark-dev
          pybind11-dev python3-dev python3-numpy)
if [[ "${RANGESEG_WITH_CLANG:-0}" == 1 ]]; then packages+=(clang libclang-rt-14-dev); fi
if [[ "${RANGESEG_WITH_LINT:-0}" == 1 ]]; then packages+=(clang-tidy clang-format); fi
if [[ "${RANGESEG_WITH_COMPARE:-0}" == 1 ]]; then packages+=(libpcl-dev libopen3d-dev); fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
((${#missing[@]} == 0)) && exit 0
echo "rangeseg: installing missing Debian packages: ${missing[*]}" >&2
if [[ $(id -u) -eq 0 ]]; then sudo=(); else sudo=(sudo); fi
export DEBIAN_FRONTEND=noninteractive
"${sudo[@]}" apt-get install -y --no-install-recommends "${missing[@]}" || {
  "${sudo[@]}" apt-get update && "${sudo[@]}" apt-get install -y --no-install-recommends "${missing[@]}"; }
