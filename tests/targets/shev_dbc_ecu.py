#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""A series-hybrid (SHEV) ECU written from the public bus contract only.

It knows io/can/ehpt.dbc (read with canmatrix), the protocol in its comments and
MODELS.md 5.5 (ShevEMS). Per sample the plant sends ShevSensors1..4 and then
PlantStatus; on PlantStatus this ECU computes

  driveTauRef_Nm = driverRequest_Nm
  P_c            = clamp(P_f + soc_gain_W * (soc_ref - batSOC), 0, power_max_W)
  on             = hysteresis(P_c; off_W, on_W), starting off
  gensetPowRef_W = P_c if on else 0,  gensetON = on

where P_f is the first-order filter (time constant power_filter_s, P_f(0) =
power_filter_initial_W) of drivePowDc_W, discretised exactly for a zero-order
hold over one period: P_f[k+1] = a P_f[k] + (1 - a) u[k], a = exp(-period/T).
The command at sample k uses P_f[k], the filter's value at the sample time.

It answers with ShevCommand echoing PlantStatus.step mod 65536 in sampleStep,
with its own 4-bit rolling counter.

Run with Debian's python (python3-can 4.1, python3-canmatrix):
  /usr/bin/python3 tests/targets/shev_dbc_ecu.py --host 127.0.0.1 --port 29536
"""

import argparse
import math
import os
import sys
import time

import logging

import can
import canmatrix.formats

# python-can 4.1's socketcand client logs a warning for every TCP read that ends
# inside a frame ("Got incomplete message"): normal on a stream, not worth a line each
logging.getLogger("can.interfaces.socketcand").setLevel(logging.ERROR)

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_DBC = os.path.normpath(os.path.join(HERE, "..", "..", "io", "can", "ehpt.dbc"))

SENSOR_FRAMES = ("ShevSensors1", "ShevSensors2", "ShevSensors3", "ShevSensors4")
STATUS_FRAME = "PlantStatus"
COMMAND_FRAME = "ShevCommand"


class ShevEMS:
    """MODELS.md 5.5, sampled every `period` seconds."""

    def __init__(self, period, power_filter_s, power_filter_initial_W, power_max_W,
                 soc_ref, soc_gain_W, on_W, off_W):
        self.a = math.exp(-period / power_filter_s)
        self.p_f = power_filter_initial_W
        self.power_max_W = power_max_W
        self.soc_ref = soc_ref
        self.soc_gain_W = soc_gain_W
        self.on_W = on_W
        self.off_W = off_W
        self.on = False

    def step(self, drive_pow_dc_W, soc):
        p_c = self.p_f + self.soc_gain_W * (self.soc_ref - soc)
        p_c = min(max(p_c, 0.0), self.power_max_W)
        if p_c > self.on_W:
            self.on = True
        elif p_c < self.off_W:
            self.on = False
        # advance the filter to the next sample (input held over the period)
        self.p_f = self.a * self.p_f + (1.0 - self.a) * drive_pow_dc_W
        return (p_c if self.on else 0.0), self.on


class Codec:
    """Encode/decode with canmatrix. canmatrix 0.9.5's Frame.encode packs RAW values
    (and Signal.phys2raw truncates towards zero), so the physical value is scaled here
    with the DBC's factor and offset, rounded to the nearest step and saturated to the
    signal's [min, max] (the contract's quantisation rule); the bits are canmatrix's."""

    def __init__(self, path):
        self.db = canmatrix.formats.loadp_flat(path)
        self.frames = {}
        for name in SENSOR_FRAMES + (STATUS_FRAME, COMMAND_FRAME):
            frame = self.db.frame_by_name(name)
            if frame is None:
                raise SystemExit(f"{path}: no frame {name}")
            self.frames[name] = frame
        self.by_id = {self.frames[n].arbitration_id.id: n for n in self.frames}

    def frame_id(self, name):
        return self.frames[name].arbitration_id.id

    def decode(self, name, data):
        decoded = self.frames[name].decode(bytes(data))
        return {k: float(v.phys_value) for k, v in decoded.items()}

    def encode(self, name, values):
        frame = self.frames[name]
        raw = {}
        for sig in frame.signals:
            if sig.name not in values:
                continue
            x = float(values[sig.name])
            if math.isnan(x):
                x = 0.0
            lo, hi = float(sig.min), float(sig.max)
            x = min(max(x, lo), hi)
            r = int(round((x - float(sig.offset)) / float(sig.factor)))
            rmin = int(round((lo - float(sig.offset)) / float(sig.factor)))
            rmax = int(round((hi - float(sig.offset)) / float(sig.factor)))
            raw[sig.name] = min(max(r, rmin), rmax)
        return bytes(frame.encode(raw))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--host", default="127.0.0.1")
    ap.add_argument("--port", type=int, default=29536)
    ap.add_argument("--channel", default="can0")
    ap.add_argument("--idle-timeout", type=float, default=5.0,
                    help="exit 0 after this many seconds without a frame")
    ap.add_argument("--dbc", default=DEFAULT_DBC)
    ap.add_argument("--period-s", type=float, default=0.01)
    ap.add_argument("--power-filter-s", type=float, default=300.0)
    ap.add_argument("--power-filter-initial-W", type=float, default=20000.0)
    ap.add_argument("--power-max-W", type=float, default=200000.0)
    ap.add_argument("--soc-ref", type=float, default=0.6)
    ap.add_argument("--soc-gain-W", type=float, default=300000.0)
    ap.add_argument("--on-W", type=float, default=60000.0)
    ap.add_argument("--off-W", type=float, default=30000.0)
    args = ap.parse_args(argv)

    codec = Codec(args.dbc)
    ems = ShevEMS(args.period_s, args.power_filter_s, args.power_filter_initial_W,
                  args.power_max_W, args.soc_ref, args.soc_gain_W, args.on_W, args.off_W)
    sensor_ids = {codec.frame_id(n): n for n in SENSOR_FRAMES}
    status_id = codec.frame_id(STATUS_FRAME)
    command_id = codec.frame_id(COMMAND_FRAME)

    bus = can.Bus(interface="socketcand", host=args.host, port=args.port,
                  channel=args.channel)
    sensors = {}          # frame name -> decoded signals of the current sample
    counter = 0           # ShevCommand's rolling counter
    answered = 0
    incomplete = 0
    switches = 0
    last_step = None
    rx_counter = {}       # frame id -> last rolling counter received
    counter_gaps = 0
    before = (ems.p_f, ems.on, switches)
    last_frame = time.monotonic()
    try:
        while True:
            msg = bus.recv(0.1)
            now = time.monotonic()
            if msg is None:
                if now - last_frame >= args.idle_timeout:
                    break
                continue
            last_frame = now
            # python-can 4.1's socketcand client marks every received frame as an
            # extended-id frame (it never sets is_extended_id), so the flag is not
            # checked: the contract's ids are all 11-bit
            if msg.is_error_frame or msg.is_remote_frame:
                continue
            fid = msg.arbitration_id
            name = sensor_ids.get(fid, STATUS_FRAME if fid == status_id else None)
            if name is None or len(msg.data) != 8:
                continue
            values = codec.decode(name, msg.data)
            # the sender's rolling counter: +1 per frame of that id, mod 16
            rx = int(values["counter"])
            if fid in rx_counter and rx != (rx_counter[fid] + 1) % 16:
                counter_gaps += 1
            rx_counter[fid] = rx
            if name != STATUS_FRAME:
                sensors[name] = values
                continue
            status = values
            if not all(n in sensors for n in SENSOR_FRAMES):
                incomplete += 1   # no sensors yet: nothing to compute from
                continue
            s1, s2 = sensors["ShevSensors1"], sensors["ShevSensors2"]
            step = int(status["step"])
            if step == last_step:
                # the same sample again (the plant repeats sample 0 until it hears
                # an ECU): answer it again from the state it was computed from
                ems.p_f, ems.on, switches = before
                answered -= 1
            before = (ems.p_f, ems.on, switches)
            last_step = step
            was_on = ems.on
            pow_ref, on = ems.step(s2["drivePowDc_W"], s1["batSOC"])
            switches += on != was_on
            data = codec.encode(COMMAND_FRAME, {
                "driveTauRef_Nm": s1["driverRequest_Nm"],
                "gensetPowRef_W": pow_ref,
                "gensetON": 1 if on else 0,
                "sampleStep": step % 65536,
                "counter": counter,
            })
            bus.send(can.Message(arbitration_id=command_id, is_extended_id=False,
                                 data=data, dlc=8))
            counter = (counter + 1) % 16
            answered += 1
    except KeyboardInterrupt:
        pass
    except can.CanError as exc:
        print(f"shev_dbc_ecu: bus error: {exc}", file=sys.stderr)
        print(f"{answered} samples answered")
        bus.shutdown()
        return 1
    bus.shutdown()
    print(f"{answered} samples answered ({switches} genset switches, "
          f"{incomplete} samples without sensors, {counter_gaps} counter gaps)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
