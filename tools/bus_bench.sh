#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Bus timing figures (a benchmark, not a test: the machine's load moves them):
#   lockstep SIL over socketcand on loopback: ECU periods per second, round trip p50/p99/max;
#   the wall-clock pacer's period error (lateness of each step's wake-up) at 1 ms and 10 ms.
# usage: tools/bus_bench.sh [BUILD_DIR]      (default build/; the outputs go to a temp folder)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
ehpt="${1:-$here/build}/ehpt"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT  # made above by mktemp: ours
port() { /usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
wait_port() {
  for _ in $(seq 100); do
    /usr/bin/python3 -c "import socket; socket.create_connection(('127.0.0.1', $1), 0.1)" 2>/dev/null && return 0
    sleep 0.05
  done
  return 1
}
# run NAME SCENARIO lockstep|wall SETTINGS... : plant + ehpt ecu over socketcand, prints the
# bus figures (SETTINGS: --set key=value, for both processes)
run() {
  local name=$1 scenario=$2 mode=$3
  shift 3
  local p pacing=()
  [ "$mode" = lockstep ] && pacing=(--lockstep)
  p=$(port)
  "$ehpt" plant "$scenario" --bus "socketcand:127.0.0.1:$p" --out "$work/$name" --quiet "${pacing[@]}" "$@" &
  local plant=$!
  wait_port "$p"
  "$ehpt" ecu "$scenario" --bus "socketcand:127.0.0.1:$p" --quiet "$@" || true
  wait "$plant"
  /usr/bin/python3 - "$work/$name/summary.json" "$name" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
b = s["bus"]
if b["pacing"] == "lockstep":
    t = b["round_trip_us"]
    print(f"{sys.argv[2]:34s} {t['count'] / s['run_wall_time_s']:8.0f} ECU periods/s, round trip "
          f"p50 {t['p50']:.0f} us, p99 {t['p99']:.0f} us, max {t['max']:.0f} us")
else:
    t = b["period_error_us"]
    print(f"{sys.argv[2]:34s} period error p50 {t['p50']:.0f} us, p99 {t['p99']:.0f} us, max {t['max']:.0f} us, "
          f"{b['missed_ticks']} missed ticks of {t['count']}, {b['stale_samples']} stale samples")
PY
}
# run_lcm NAME SCENARIO SETTINGS...: the same over LCM udpm, inside a private network namespace
run_lcm() {
  local name=$1 scenario=$2
  shift 2
  "$here/tests/targets/in_netns.sh" bash -c '"$1" plant "$2" --bus "$3" --lockstep --out "$4" --quiet "${@:6}" &
    "$1" ecu "$2" --bus "$3" --quiet --idle-timeout-s 2 "${@:6}"; wait' sh \
    "$ehpt" "$scenario" "lcm:udpm://239.255.76.67:7667?ttl=0" "$work/$name" x "$@"
  /usr/bin/python3 - "$work/$name/summary.json" "$name" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
t = s["bus"]["round_trip_us"]
print(f"{sys.argv[2]:34s} {t['count'] / s['run_wall_time_s']:8.0f} ECU periods/s, round trip "
      f"p50 {t['p50']:.0f} us, p99 {t['p99']:.0f} us, max {t['max']:.0f} us")
PY
}
run "lockstep psecu2 NEDC 200 s" psecu2_nedc lockstep --set solver.duration_s=200
run "lockstep EV NEDC 200 s" ev_nedc lockstep --set solver.duration_s=200
run_lcm "LCM udpm lockstep psecu2 200 s" psecu2_nedc --set solver.duration_s=200
run_lcm "LCM udpm lockstep EV 200 s" ev_nedc --set solver.duration_s=200
"$(dirname "$ehpt")/bench/ehpt_bench" --benchmark_filter=LcmMemq 2>/dev/null | grep -E "^BM_" || true
run "wall clock EV, 1 ms steps, 20 s" ev_nedc wall --set solver.duration_s=20
run "wall clock EV, 10 ms steps, 20 s" ev_nedc wall --set solver.duration_s=20 --set solver.step_s=0.01
