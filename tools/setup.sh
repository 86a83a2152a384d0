#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Installs what is missing (Debian 12 packages) and builds ehpt in Release into build/.
# Sourced by tools/main.sh and tools/test.sh; safe to run again (only missing packages are
# installed, the build is incremental). Extra CMake options: EHPT_CMAKE_ARGS="...".
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
packages=(cmake make g++ libeigen3-dev libgtest-dev libbenchmark-dev libtomlplusplus-dev
          python3-matplotlib python3-numpy python3-pandas python3-can can-utils
          liblcm-dev liblcm-bin libglib2.0-dev iproute2 libsundials-dev rt-tests
          pybind11-dev python3-dev dpkg-dev file mkdocs python3-canmatrix
          python3-junitparser python3-pytest  # ehpt test's JUnit read back; the pytest example
          help2man lintian man-db)  # the man page, the package check (docs/packaging.md)

"$here/tools/apt_install.sh" "ehpt setup" "${packages[@]}"

cmake -S "$here" -B "$here/build" -DCMAKE_BUILD_TYPE=Release ${EHPT_CMAKE_ARGS:-} >/dev/null
cmake --build "$here/build" -j"$(nproc)"
