#!/usr/bin/env bash
# Installs what is missing (Debian 12 packages) and builds ehpt in Release into build/.
# Sourced by tools/main.sh and tools/test.sh; safe to run again (only missing packages are
# installed, the build is incremental). Extra CMake options: EHPT_CMAKE_ARGS="...".
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
packages=(cmake make g++ libeigen3-dev libgtest-dev libbenchmark-dev libtomlplusplus-dev
          python3-matplotlib python3-numpy)

missing=()
for p in "${packages[@]}"; do
  dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "ehpt setup: installing ${missing[*]}" >&2
  sudo_cmd=()
  [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq "${missing[@]}" >/dev/null
fi

cmake -S "$here" -B "$here/build" -DCMAKE_BUILD_TYPE=Release ${EHPT_CMAKE_ARGS:-} >/dev/null
cmake --build "$here/build" -j"$(nproc)"
