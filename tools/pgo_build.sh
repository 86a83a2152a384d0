#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# A profile-guided build of ehpt with GCC (docs/packaging.md "Profile-guided optimisation"),
# all three steps in one build folder (GCC finds a profile by its object's path, and the
# generated sources are in the build folder):
#   1. an instrumented ehpt (-DEHPT_PGO=generate);
#   2. the training: it runs shipped scenarios (below), which writes its .gcda profiles into
#      BUILD_DIR/pgo-profile (emptied first: the profiles of two trainings add up);
#   3. the optimised build (-DEHPT_PGO=use) of TARGET, from scratch.
# usage: tools/pgo_build.sh [--target TARGET] [-j N] BUILD_DIR [CMAKE_ARG...]
#   --target TARGET  what step 3 builds (default: all, as the Debian packages need)
#   -j N             parallel build jobs (default: nproc)
#   CMAKE_ARG...     for both configures, e.g. -DEHPT_BUILD_TESTS=OFF -DEHPT_BUILD_BENCH=OFF
#                    (the build type defaults to Release; EHPT_PGO* are this script's)
# The last line printed is the optimised binary's path (BUILD_DIR/ehpt).
#   tools/pgo_build.sh build-pgo -DEHPT_BUILD_TESTS=OFF -DEHPT_BUILD_BENCH=OFF
set -euo pipefail
usage() {  # the lines above, to stdout for --help, else to stderr with status 2
  if [ "$1" -eq 0 ]; then sed -n '10,16p' "$0" | sed 's/^# \{0,1\}//'; else sed -n '10,16p' "$0" | sed 's/^# \{0,1\}//' >&2; fi
  exit "$1"
}
src="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
target=all jobs="$(nproc)"
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) usage 0 ;;
    --target) [ $# -ge 2 ] || usage 2; target="$2"; shift 2 ;;
    -j) { [ $# -ge 2 ] && [[ "$2" =~ ^[1-9][0-9]*$ ]]; } || usage 2; jobs="$2"; shift 2 ;;
    -j[1-9]*) jobs="${1#-j}"; shift ;;
    -*) echo "pgo_build: unknown option $1" >&2; usage 2 ;;
    *) break ;;
  esac
done
[ $# -ge 1 ] || usage 2
build="$(realpath -m "$1")"
shift
for a in "$@"; do
  case "$a" in -DEHPT_PGO*) echo "pgo_build: $a: EHPT_PGO and EHPT_PGO_DIR are this script's" >&2; exit 2 ;; esac
done
profile="$build/pgo-profile"
mkdir -p "$build"
log="$build/pgo_build.log"
: >"$log"
logged() {  # COMMAND...: its output into the log, the log's tail shown if it fails
  "$@" >>"$log" 2>&1 || { tail -40 "$log" >&2; echo "pgo_build: failed: $* (log: $log)" >&2; exit 1; }
}

# The training: the plant and ECU loop of each vehicle family (battery EV, power-split hybrid
# with its ECU's engine starts, the PM and the asynchronous machine drives, the series
# hybrid), batch runs without the time series (what `ehpt bench` times, and a sweep's runs),
# and one short run with it (the CSV's number formatting of a default `ehpt run`).
training=("ev_nedc --set output.timeseries=false"
          "psecu2_nedc --set output.timeseries=false"
          "evpm_sort1 --set output.timeseries=false"
          "evam_sort1 --set output.timeseries=false"
          "shev_oo_sort1 --set output.timeseries=false"
          "ev_sort1")
# Each run single-threaded, in this order, into the same folders, with a fixed environment and
# without address-space randomisation (setarch -R): GCC's value profiles record addresses
# (their alignment), which would otherwise differ from one training to the next.
norandom=()
if setarch "$(uname -m)" -R true 2>/dev/null; then
  norandom=(setarch "$(uname -m)" -R)
else
  echo "pgo_build: note: setarch -R refused here: the training runs with address-space randomisation" >&2
fi

echo "== 1/3 instrumented build (EHPT_PGO=generate): $build" >&2
logged cmake -S "$src" -B "$build" -DCMAKE_BUILD_TYPE=Release "$@" -DEHPT_PGO=generate -DEHPT_PGO_DIR="$profile"
logged cmake --build "$build" --target ehpt -j"$jobs"

echo "== 2/3 training into $profile" >&2
rm -rf "$profile" "$build/pgo-training"  # this script's own folders
mkdir -p "$build/pgo-training"
start=$SECONDS
for run in "${training[@]}"; do
  name="${run%% *}"
  # shellcheck disable=SC2086
  logged env -i PATH=/usr/bin:/bin LC_ALL=C "${norandom[@]}" \
    "$build/ehpt" run "$name" ${run#"$name"} --quiet --out "$build/pgo-training/$name"
done
echo "   ${#training[@]} runs in $((SECONDS - start)) s, $(find "$profile" -name '*.gcda' | wc -l) profiles" >&2

echo "== 3/3 optimised build (EHPT_PGO=use) of $target" >&2
logged cmake -S "$src" -B "$build" -DCMAKE_BUILD_TYPE=Release "$@" -DEHPT_PGO=use -DEHPT_PGO_DIR="$profile"
# from scratch: make would see no change in a source whose profile changed
logged cmake --build "$build" --clean-first --target "$target" -j"$jobs"
echo "$build/ehpt"
