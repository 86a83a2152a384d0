#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Instructions per step of a scenario, from callgrind (repeatable under load, unlike timings):
# the instructions of a run of D2 seconds minus those of a run of D1 seconds, over the steps in
# between, so start-up and the end of the run cancel.
#   tools/instructions_per_step.sh EHPT SCENARIO [D1 D2] [--set key=value ...]
#   tools/instructions_per_step.sh build/ehpt ev_nedc 50 150 --set output.timeseries=false
set -euo pipefail
if [ $# -lt 2 ]; then
  sed -n '3,7p' "$0" >&2
  exit 2
fi
ehpt="$1" scenario="$2"
shift 2
d1=50 d2=150
if [ $# -ge 2 ] && [[ "$1" =~ ^[0-9]+$ ]] && [[ "$2" =~ ^[0-9]+$ ]]; then
  d1="$1" d2="$2"
  shift 2
fi
command -v valgrind >/dev/null || { echo "instructions_per_step: needs valgrind (apt-get install valgrind)" >&2; exit 2; }
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
instructions() {  # the run's total instructions (callgrind's "Collected") and its steps
  valgrind --tool=callgrind --callgrind-out-file="$tmp/cg.out" "$ehpt" run "$scenario" --quiet --out "$tmp/run" \
    --set "solver.duration_s=$1" "${@:2}" >/dev/null 2>"$tmp/err" || { cat "$tmp/err" >&2; exit 1; }
  echo "$(sed -n 's/.*Collected : \([0-9]*\).*/\1/p' "$tmp/err") $(sed -n 's/^ *"steps": \([0-9]*\).*/\1/p' "$tmp/run/summary.json")"
}
read -r a steps_a < <(instructions "$d1" "$@")
read -r b steps_b < <(instructions "$d2" "$@")
awk -v a="$a" -v b="$b" -v na="$steps_a" -v nb="$steps_b" -v s="$scenario" \
  'BEGIN { printf "%s: %.1f instructions per step (%d steps minus %d)\n", s, (b - a) / (nb - na), nb, na }'
