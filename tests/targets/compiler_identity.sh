#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# The trajectory does not depend on the compiler or on -march=native (issue 11): ehpt built
# with clang++ and with g++ -march=native runs the same scenarios as the main build (g++,
# the project's flags), and every timeseries.csv is byte-identical. -ffp-contract=off (set
# in CMakeLists.txt for every build) is what makes this hold: without it clang fuses
# multiply-adds within an expression and gcc does with -march=native.
# usage: compiler_identity.sh SOURCE_DIR MAIN_EHPT WORK_DIR
set -euo pipefail
src="$1" main_ehpt="$2" work="$3"
mkdir -p "$work"

# clang from Debian, installed when this test needs it (as tools/setup.sh installs the rest)
if ! command -v clang++ >/dev/null; then
  "$src/tools/apt_install.sh" "compiler identity test" clang
fi

build() {  # name, cmake args...
  local name="$1"; shift
  cmake -S "$src" -B "$work/$name" -DCMAKE_BUILD_TYPE=Release -DEHPT_BUILD_TESTS=OFF -DEHPT_BUILD_BENCH=OFF "$@" \
    >"$work/$name.configure.log" 2>&1 || { cat "$work/$name.configure.log"; exit 1; }
  cmake --build "$work/$name" --target ehpt -j"$(nproc)" >"$work/$name.build.log" 2>&1 || {
    tail -40 "$work/$name.build.log"; exit 1; }
  echo "$work/$name/ehpt"
}

variants=("clang:$(build clang -DCMAKE_CXX_COMPILER=clang++)"
          "gcc-native:$(build gcc-native -DCMAKE_CXX_FLAGS=-march=native)")

fail=0
# the EV, the paper's hybrid (engine starts, ECU hysteresis, events), the machine-drive EVs
for sc in "ev_nedc --set solver.duration_s=400" "psecu2_nedc --set solver.duration_s=400" "evpm_sort1" "evam_sort1"; do
  name="${sc%% *}"
  rm -rf "$work/out-main-$name"
  # shellcheck disable=SC2086
  "$main_ehpt" run "$src/scenarios/$name.toml" ${sc#"$name"} --out "$work/out-main-$name" --quiet
  for v in "${variants[@]}"; do
    vname="${v%%:*}" bin="${v#*:}"
    rm -rf "$work/out-$vname-$name"
    # shellcheck disable=SC2086
    "$bin" run "$src/scenarios/$name.toml" ${sc#"$name"} --out "$work/out-$vname-$name" --quiet
    if cmp -s "$work/out-main-$name/timeseries.csv" "$work/out-$vname-$name/timeseries.csv"; then
      echo "identical  $name  main g++ == $vname"
    else
      echo "DIFFERENT  $name  main g++ != $vname"
      fail=1
    fi
  done
done
exit "$fail"
