#!/bin/sh
# SPDX-License-Identifier: BSD-3-Clause
# Runs inside tools/vcan-vm.sh (a qemu guest with a real vcan0): ehpt plant on vcan0 in
# lockstep with (a) ehpt ecu and (b) the python-can example ECU (interface socketcan).
# usage: vcan_guest.sh EHPT OUT_DIR SOURCE_DIR DURATION_S
set -eu
ehpt=$1 out=$2 src=$3 duration=$4
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
