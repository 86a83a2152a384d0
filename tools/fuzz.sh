#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Fuzzes a loader with libFuzzer (clang, ASan + UBSan) for a while.
# usage: tools/fuzz.sh [csv|scenario|dbc] [SECONDS]     (defaults: csv, 60 s)
# Installs clang when missing, builds into build-fuzz/ (never build/), fuzzes a writable copy of
# the corpus in build-fuzz/corpus/NAME (the seeds in tests/fuzz/corpus are only read) and writes
# crashes, hangs and leaks into build-fuzz/artifacts/. Extra libFuzzer flags: FUZZ_ARGS="...".
# Exit status: 0 when nothing was found, else libFuzzer's.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
name="${1:-csv}"
seconds="${2:-60}"
case "$name" in
  csv|scenario|dbc) ;;
  *) echo "usage: tools/fuzz.sh [csv|scenario|dbc] [SECONDS]" >&2; exit 2 ;;
esac
[[ "$seconds" =~ ^[0-9]+$ ]] || { echo "usage: tools/fuzz.sh [csv|scenario|dbc] [SECONDS]" >&2; exit 2; }

# clang's libFuzzer runtime is in libclang-rt-14-dev on Debian 12; the rest is what the build needs
packages=(cmake make clang libclang-rt-14-dev libeigen3-dev libgtest-dev libtomlplusplus-dev)
"$here/tools/apt_install.sh" "ehpt fuzz" "${packages[@]}"

build="$here/build-fuzz"
mkdir -p "$build"
# a build folder, never committed: git skips a folder whose own .gitignore ignores everything
[ -f "$build/.gitignore" ] || printf '*\n' >"$build/.gitignore"
# The libraries are instrumented too (fuzzer-no-link): without coverage of the loaders libFuzzer
# would be blind. _GLIBCXX_ASSERTIONS turns an out-of-range operator[] into a crash.
san_flags="-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer -D_GLIBCXX_ASSERTIONS"
CC=clang CXX=clang++ cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DEHPT_BUILD_TESTS=ON -DEHPT_BUILD_BENCH=OFF -DCMAKE_CXX_FLAGS="$san_flags" >/dev/null
cmake --build "$build" -j"$(nproc)" --target "${name}_fuzz"

corpus="$build/corpus/$name"
artifacts="$build/artifacts/$name"
mkdir -p "$corpus" "$artifacts"
cp -n "$here/tests/fuzz/corpus/$name/"* "$corpus/"
binary="$build/tests/fuzz/${name}_fuzz"

status=0
# -timeout: an input slower than 10 s is a hang (libFuzzer's default, 1200 s, hides them);
# -max_len: long lines and deep nesting need more than the 4 KiB default
# shellcheck disable=SC2086  # FUZZ_ARGS is a list of flags
(cd "$build" && "$binary" -max_total_time="$seconds" -timeout=10 -max_len=131072 -print_final_stats=1 \
  -artifact_prefix="$artifacts/" ${FUZZ_ARGS:-} "$corpus") || status=$?

found=$(find "$artifacts" -type f | wc -l)
echo
echo "ehpt fuzz: $name for $seconds s, exit status $status; corpus now $(find "$corpus" -type f | wc -l) inputs in $corpus"
echo "ehpt fuzz: $found finding(s) in $artifacts/ (crash-*: crash or exception, timeout-*: hang, oom-*: memory, leak-*)"
echo "ehpt fuzz: reproduce one with: $binary $artifacts/crash-<hash>"
echo "ehpt fuzz:   (add EHPT_FUZZ_VERBOSE=1 to see the loader's messages; -minimize_crash=1 -runs=10000 shrinks it)"
exit "$status"
