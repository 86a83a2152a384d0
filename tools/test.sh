#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Every test: install what is missing, build with warnings as errors, run all tests (ctest).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
EHPT_CMAKE_ARGS="-DEHPT_WERROR=ON ${EHPT_CMAKE_ARGS:-}" "$here/tools/setup.sh"
cd "$here/build"
ctest --output-on-failure -j"$(nproc)"
