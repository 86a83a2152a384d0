#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# The main job: install what is missing, build, and run the paper's PSecu2 (power-split hybrid
# with MBecu2) on NEDC as two processes over the CAN contract: `ehpt plant` and `ehpt ecu`
# (MBecu2) in lockstep over socketcand on 127.0.0.1. Prints the plant's summary, runs the same
# scenario in one process with the ECU's signals through the same codec, and says whether the
# two timeseries are identical. Outputs and plots: out/psecu2_nedc/ (the bus run) and
# out/psecu2_nedc_in_process/. Extra arguments go to both runs (e.g. --set solver.duration_s=200).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$here/tools/setup.sh"
cd "$here"
ehpt=./build/ehpt
# a free port on the loopback interface (the kernel picks it)
port=${EHPT_PORT:-$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')}
bus="socketcand:127.0.0.1:$port"

echo "plant and MBecu2 in lockstep over $bus" >&2
"$ehpt" plant psecu2_nedc --bus "$bus" --lockstep --out out/psecu2_nedc "$@" &
plant=$!
ecu_rc=0
# wait until the plant listens (it loads the scenario first); the ECU connects once
for _ in $(seq 50); do
  if /usr/bin/python3 -c "import socket,sys; socket.create_connection(('127.0.0.1', $port), 0.1)" 2>/dev/null; then break; fi
  kill -0 "$plant" 2>/dev/null || break
  sleep 0.1
done
"$ehpt" ecu psecu2_nedc --bus "$bus" "$@" || ecu_rc=$?
plant_rc=0
wait "$plant" || plant_rc=$?
if [ "$plant_rc" -ne 0 ] || [ "$ecu_rc" -ne 0 ]; then
  echo "main: the bus run failed (plant exit $plant_rc, ecu exit $ecu_rc)" >&2
  exit 1
fi
"$ehpt" plot out/psecu2_nedc || echo "main: plotting failed (the run is kept)" >&2

echo "the same run in one process, the ECU's signals through the same codec:" >&2
"$ehpt" run psecu2_nedc --set vehicle.ecu.codec=can --out out/psecu2_nedc_in_process --quiet "$@"
if cmp -s out/psecu2_nedc/timeseries.csv out/psecu2_nedc_in_process/timeseries.csv; then
  echo "identical     the bus run's timeseries.csv equals the in-process run's, byte for byte"
else
  echo "DIFFERENT     the bus run's timeseries.csv differs from the in-process run's" >&2
  exit 1
fi
