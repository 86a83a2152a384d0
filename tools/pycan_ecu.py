#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""An example ECU for the ehpt plant on a CAN bus, with python-can (a starting point for HIL).

The bus contract is io/can/ehpt.dbc. Once per ECU period the plant sends its sensor frames and
then PlantStatus, the last frame of the sample; this ECU answers every PlantStatus with its
command frames, computed from the latest sensor frames. That is all the plant needs, in
lockstep (it waits for our answer) and in wall-clock mode (it uses our latest answer).

    tools/pycan_ecu.py --vehicle ev --interface socketcan --channel vcan0
    tools/pycan_ecu.py --vehicle psd --interface socketcand --host 127.0.0.1 --port 29536 --channel vcan0
"""

import argparse
import pathlib
import sys
import time

import can

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from ehpt_dbc import Dbc  # noqa: E402

_HERE = pathlib.Path(__file__).resolve().parent
# the source tree's (tools/ -> io/can/), else the installed package's (this file is then
# <prefix>/share/doc/ehpt/examples/pycan_ecu.py, the DBC <prefix>/share/ehpt/can/ehpt.dbc)
_DBC_CANDIDATES = [_HERE.parent / "io" / "can" / "ehpt.dbc"]
if len(_HERE.parents) > 2:
    _DBC_CANDIDATES.append(_HERE.parents[2] / "ehpt" / "can" / "ehpt.dbc")
DBC_PATH = next((p for p in _DBC_CANDIDATES if p.is_file()), _DBC_CANDIDATES[0])
SENSOR_FRAMES = {"ev": ["EvSensors1", "EvSensors2", "EvSensors3"],
                 "psd": [f"PsdSensors{i}" for i in range(1, 7)]}


def ev_strategy(s, torque_limit_Nm=None):
    """EV: pass the driver's request to the drive (what the built-in ecu::EvFollower does).
    The optional clamp is the simplest thing an ECU of your own might add."""
    tau = s["driverRequest_Nm"]
    if torque_limit_Nm is not None:
        tau = max(-torque_limit_Nm, min(torque_limit_Nm, tau))
    return {"EvCommand": {"driveTauRef_Nm": tau}}


class PsdDemoStrategy:
    """Power-split hybrid: a DEMONSTRATION strategy, deliberately simpler than the built-in
    MBecu2 (ecu/psd_ecu.hpp): no power filter, no SOC loop, no gen torque filter.
      - mot (on the ring, at the wheels) gives what the driver asks: 80 Nm per unit of request;
      - the engine runs when the traction power is high enough and is asked for that power
        (on/off with hysteresis, so that it does not toggle every period near the threshold);
      - gen (on the sun) holds the engine near a speed that suits that power, by a
        P controller; it has the same sign convention as MBecu2 (more gen torque: faster engine);
      - the battery covers the difference."""
    MOT_NM_PER_REQUEST = 80.0
    ICE_ON_ABOVE_W, ICE_OFF_BELOW_W = 7000.0, 5000.0
    ICE_SPEED_MIN_RAD_S = 125.0      # idle-ish floor; also the reference with the engine off
    RAD_S_PER_W = 0.01               # rough fit of data/maps/ecu_psd_power_to_ice_speed.csv
    GEN_GAIN_NM_S_RAD = 1.0
    GEN_TAU_MAX_NM = 80.0

    def __init__(self):
        self.ice_on = False

    def __call__(self, s):
        traction_W = s["motPowDelB_W"]  # power mot delivers through the final gear
        if traction_W > self.ICE_ON_ABOVE_W:
            self.ice_on = True
        elif traction_W < self.ICE_OFF_BELOW_W:
            self.ice_on = False
        ice_pow_W = traction_W if self.ice_on else 0.0
        w_ref = max(self.ICE_SPEED_MIN_RAD_S, self.RAD_S_PER_W * ice_pow_W)
        gen_tau = self.GEN_GAIN_NM_S_RAD * (w_ref - s["iceW_rad_s"])
        gen_tau = max(-self.GEN_TAU_MAX_NM, min(self.GEN_TAU_MAX_NM, gen_tau))
        return {"PsdCommand1": {"icePowRef_W": ice_pow_W, "iceTauRef_Nm": 0.0,  # 0: power-input engine
                                "iceON": int(self.ice_on)},
                "PsdCommand2": {"genTauRef_Nm": gen_tau,
                                "motTauRef_Nm": self.MOT_NM_PER_REQUEST * s["driverRequest"]}}


def new_stats():
    return {"answered": 0, "skipped": 0, "safe_state": 0, "counter_gaps": 0, "send_errors": 0,
            "last_step": None, "last_speed_m_s": None, "stop": "idle"}


def run(bus, dbc, vehicle, strategy, st, max_periods=0, idle_timeout_s=5.0):
    """Answers PlantStatus frames until max_periods answers (0: no limit) or idle_timeout_s
    without any frame; counts what happened in st (see new_stats)."""
    sensors, seen = {}, set()  # latest value of every sensor signal; frames seen at least once
    rx_counter, tx_counter = {}, {}
    last_rx = time.monotonic()
    while max_periods == 0 or st["answered"] < max_periods:
        msg = bus.recv(timeout=0.1)
        if msg is None:
            if time.monotonic() - last_rx > idle_timeout_s:
                return
            continue
        last_rx = time.monotonic()
        # No is_extended_id filter: python-can's socketcand client marks every frame extended.
        if msg.is_error_frame or msg.is_remote_frame:
            continue
        try:
            name, sig = dbc.decode(msg.arbitration_id, msg.data)
        except ValueError:
            continue  # not ours: other traffic on the bus
        # The plant's counters go +1 per frame of an id; a gap means frames were lost.
        if name in rx_counter and sig["counter"] != (rx_counter[name] + 1) % 16:
            st["counter_gaps"] += 1
        rx_counter[name] = sig["counter"]
        if name in SENSOR_FRAMES[vehicle]:
            sensors.update(sig)
            seen.add(name)
        elif name == "PlantStatus":
            st["last_step"] = sig["step"]
            st["safe_state"] += sig["ecuTimeout"]
            if len(seen) < len(SENSOR_FRAMES[vehicle]):
                st["skipped"] += 1  # started mid-sample: no complete sensor picture yet
                continue
            st["last_speed_m_s"] = sensors["speed_m_s"]
            for cmd_name, values in strategy(sensors).items():
                counter = tx_counter.get(cmd_name, 0)
                # echo the sample we answer: the plant drops commands for old samples
                values = dict(values, sampleStep=sig["step"] % 65536)
                can_id, data = dbc.encode(cmd_name, values, counter)
                try:
                    bus.send(can.Message(arbitration_id=can_id, data=data, is_extended_id=False))
                    tx_counter[cmd_name] = (counter + 1) % 16  # the plant rejects a repeated counter
                except can.CanError as e:
                    st["send_errors"] += 1
                    print(f"pycan_ecu: send {cmd_name} failed: {e}", file=sys.stderr)
            st["answered"] += 1
    st["stop"] = "max-periods"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--interface", default="socketcan", choices=["socketcan", "socketcand", "virtual"])
    ap.add_argument("--channel", default="vcan0")
    ap.add_argument("--host", default="127.0.0.1", help="socketcand only")
    ap.add_argument("--port", type=int, default=29536, help="socketcand only")
    ap.add_argument("--vehicle", default="ev", choices=["ev", "psd"])
    ap.add_argument("--max-periods", type=int, default=0, help="stop after N answered samples (0: no limit)")
    ap.add_argument("--idle-timeout", type=float, default=5.0, help="stop after this many seconds without frames")
    ap.add_argument("--torque-limit-Nm", type=float, default=None, help="EV: clamp driveTauRef to +-this")
    ap.add_argument("--dbc", default=str(DBC_PATH))
    args = ap.parse_args(argv)

    dbc = Dbc(args.dbc)
    strategy = (PsdDemoStrategy() if args.vehicle == "psd"
                else lambda s: ev_strategy(s, args.torque_limit_Nm))
    extra = {"host": args.host, "port": args.port} if args.interface == "socketcand" else {}
    bus = can.Bus(interface=args.interface, channel=args.channel, **extra)
    st, code = new_stats(), 0
    try:
        run(bus, dbc, args.vehicle, strategy, st, args.max_periods, args.idle_timeout)
    except KeyboardInterrupt:
        st["stop"], code = "Ctrl-C", 130  # still shut the bus down and print the summary
    finally:
        bus.shutdown()
    speed = "-" if st["last_speed_m_s"] is None else f"{st['last_speed_m_s']:.4f} m/s"
    print(f"pycan_ecu: {st['answered']} samples answered, last step {st['last_step']}, last speed {speed}"
          f" (stopped: {st['stop']}; skipped {st['skipped']}, safe-state samples {st['safe_state']},"
          f" counter gaps {st['counter_gaps']}, send errors {st['send_errors']})")
    return code


if __name__ == "__main__":
    sys.exit(main())
