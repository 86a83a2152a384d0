#!/bin/sh
# SPDX-License-Identifier: BSD-3-Clause
# Runs inside tools/vcan-vm.sh (a qemu guest with a real vcan0): ehpt plant on vcan0 in
# lockstep with (a) ehpt ecu, (b) the python-can example ECU (interface socketcan) and, given
# a calibration, (c) the VCU that knows only its own DBC (examples/own_dbc: extended ids,
# Motorola, multiplexing, E2E) through its binding, on PSecu2; then (d) bus faults that put
# CAN error frames on vcan0 (error_frames, bus_off), heard by a raw-socket listener
# (tests/targets/vcan_error_listener.py), the plant in lockstep with ehpt ecu.
# usage: vcan_guest.sh EHPT OUT_DIR SOURCE_DIR DURATION_S [VCU_CALIBRATION_JSON]
set -eu
ehpt=$1 out=$2 src=$3 duration=$4 calibration=${5:-}
# the plant sends sample 0 again every second until an ECU answers, so the order of start
# does not matter (python-can takes seconds to import under qemu's emulation)
"$ehpt" ecu ev_nedc --bus socketcan:vcan0 --set solver.duration_s="$duration" --idle-timeout-s 5 \
  > "$out/ecu.txt" 2>&1 &
ecu=$!
"$ehpt" plant ev_nedc --bus socketcan:vcan0 --lockstep --out "$out/with_ehpt_ecu" \
  --set solver.duration_s="$duration" --quiet
wait $ecu
/usr/bin/python3 "$src/tools/pycan_ecu.py" --vehicle ev --interface socketcan --channel vcan0 \
  --idle-timeout 5 > "$out/pycan.txt" 2>&1 &
py=$!
"$ehpt" plant ev_nedc --bus socketcan:vcan0 --lockstep --out "$out/with_pycan_ecu" \
  --set solver.duration_s="$duration" --quiet
wait $py
if [ -n "$calibration" ]; then
  /usr/bin/python3 "$src/examples/own_dbc/vcu_ecu.py" --interface socketcan --channel vcan0 \
    --calibration "$calibration" --idle-timeout-s 10 > "$out/own_dbc.txt" 2>&1 &
  vcu=$!
  "$ehpt" plant psecu2_nedc --bus socketcan:vcan0 --bus-map "$src/examples/own_dbc/vcu.binding.toml" --lockstep \
    --out "$out/with_own_dbc_vcu" --set solver.duration_s="$duration" --quiet
  wait $vcu
fi
# (d) error frames: 1.00-1.05 s one per sample, bus-off 2.00-2.10 s (its start and restart)
cat > "$out/error_frames.toml" <<'TOML'
scenario = "ev_nedc"
[solver]
duration_s = 3.0
[[fault]]
kind = "error_frames"
at_s = 1.0
until_s = 1.05
[[fault]]
kind = "bus_off"
at_s = 2.0
until_s = 2.1
TOML
/usr/bin/python3 "$src/tests/targets/vcan_error_listener.py" vcan0 "$out/error_frames.txt" 5 120 &
listener=$!
# the plant sends its first error frame about a second in; the listener must be bound by then
for _ in $(seq 300); do [ -e "$out/error_frames.txt.ready" ] && break; sleep 0.1; done
"$ehpt" ecu ev_nedc --bus socketcan:vcan0 --set solver.duration_s=3 --idle-timeout-s 5 > "$out/ecu_errors.txt" 2>&1 &
ecu=$!
"$ehpt" plant "$out/error_frames.toml" --bus socketcan:vcan0 --lockstep --out "$out/with_error_frames" --quiet
wait $ecu
wait $listener
