#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""A VCU of your own on the ehpt plant: it knows only its own CAN matrix, vcu.dbc.

Nothing here is ehpt's contract: the VCU reads and writes the messages of vcu.dbc (Motorola
signals, an extended id, a multiplexed message, km/h, rpm, kW and %), protects its torque
requests with AUTOSAR E2E profile 1 (CRC-8 SAE J1850 over its data id and the frame, a 4-bit
alive counter), and never echoes the plant's step. The plant is bound to it by
vcu.binding.toml (docs/binding.md):

    ehpt plant psecu2_nedc --bus socketcand:127.0.0.1:29536 --bus-map examples/own_dbc/vcu.binding.toml --lockstep
    /usr/bin/python3 examples/own_dbc/vcu_ecu.py --port 29536 --calibration cal.json

The strategy is MBecu2 (python/examples/mbecu2_ecu.py, the built-in ECU written again in
Python); its calibration comes from a JSON file (--calibration, e.g. written from
ehpt.Simulation(...).ecu_parameters) or, with the ehpt module importable, from --scenario.

Two ways to send, as real ECUs do:
  --answer (default): once a sample's last frame (HIL_Powertrain) has arrived, the three
      command frames for it: the plant can run in lockstep, deterministically;
  --cyclic: every 10 ms on the VCU's own clock, from the latest values heard (wall clock).

Libraries: python-can (the bus) and canmatrix (the DBC), both Debian packages.
"""

import argparse
import json
import logging
import math
import pathlib
import sys
import time
from types import SimpleNamespace

import can

logging.getLogger("canmatrix").setLevel(logging.ERROR)  # it warns at import about formats it lacks
# python-can 4.1's socketcand client logs a warning per connection attempt (thousands in its 10 s
# retry loop); a failure to connect is reported once, by main()
logging.getLogger("can.interfaces.socketcand").setLevel(logging.ERROR)
import canmatrix  # noqa: E402
import canmatrix.formats  # noqa: E402

HERE = pathlib.Path(__file__).resolve().parent
# the strategy: the source tree's python/examples, else one folder up (the installed examples)
for folder in (HERE.parents[1] / "python" / "examples", HERE.parent):
    if (folder / "mbecu2_ecu.py").is_file():
        sys.path.insert(0, str(folder))
        break
from mbecu2_ecu import PsdEcu  # noqa: E402

DBC_PATH = HERE / "vcu.dbc"
TORQUE_DATA_ID = 0x0201  # vcu.dbc's comment on VCU_TorqueCmd
CYCLE_S = 0.010


def e2e_p01_crc(data_id, payload, crc_byte=0):
    """AUTOSAR E2E profile 1, data id mode BOTH: CRC-8 SAE J1850 (polynomial 0x1D) over the data
    id's low byte, its high byte and every byte of the frame but the CRC's. The register starts
    at 0x00 and there is no final XOR: Crc_CalculateCRC8 chained from the start value 0xFF and
    the profile's own final XOR with 0xFF cancel."""
    crc = 0x00
    for b in [data_id & 0xFF, data_id >> 8] + [x for i, x in enumerate(payload) if i != crc_byte]:
        crc ^= b
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1D) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


class Vcu:
    """The VCU's logic without a bus: frames in (on_frame), frames out (commands)."""

    def __init__(self, calibration, dbc_path=DBC_PATH):
        self.db = canmatrix.formats.loadp_flat(str(dbc_path))
        self.ecu = PsdEcu(calibration)
        self.heard = {}      # signal name -> physical value, the latest of each
        self.alive = 0       # E2E P01 alive counter: 0..14
        self.frames = {f.name: f for f in self.db.frames}

    def frame_of(self, arbitration_id, is_extended):
        """The DBC's frame for an id. python-can 4.1's socketcand client marks every frame it
        receives as extended, so a standard id is looked up too."""
        for ext in (is_extended, not is_extended):
            f = self.db.frame_by_id(canmatrix.ArbitrationId(arbitration_id, extended=ext))
            if f is not None:
                return f
        return None

    def on_frame(self, arbitration_id, is_extended, data):
        """Takes in a received frame; returns its message's name (None: not in vcu.dbc)."""
        f = self.frame_of(arbitration_id, is_extended)
        if f is None or f.name not in ("HIL_Vehicle", "HIL_Powertrain"):
            return None
        for name, value in f.decode(bytes(data)).items():
            self.heard[name] = float(value.phys_value)
        return f.name

    def ready(self):
        return all(k in self.heard for k in ("DrvTrqReq", "BatSoc", "MotPwrB", "IceSpd"))

    def sensors(self):
        """What MBecu2 reads, in its units, from the signals heard (this VCU's own conversions)."""
        h = self.heard
        return SimpleNamespace(driverRequest=h["DrvTrqReq"], batSOC=h["BatSoc"] / 100.0,
                               motPowDelB_W=h["MotPwrB"] * 1000.0, iceW_rad_s=h["IceSpd"] * math.pi / 30.0)

    def _encode(self, frame_name, physical):
        """canmatrix packs raw values: round each physical value to its signal's step, within
        its [min, max]."""
        f = self.frames[frame_name]
        raw = {}
        for sig in f.signals:
            if sig.name not in physical:
                continue
            v = min(max(physical[sig.name], float(sig.min)), float(sig.max))
            raw[sig.name] = int(round((v - float(sig.offset)) / float(sig.factor)))
        return f, bytearray(f.encode(raw))

    def commands(self):
        """One period's command: [(arbitration_id, is_extended, data)], three frames."""
        d = self.ecu.decide(self.sensors())
        torque, t = self._encode("VCU_TorqueCmd", {"TrqCmd_Alive": self.alive, "MotTrqReq": d.motTauRef_Nm,
                                                   "GenTrqReq": d.genTauRef_Nm})
        t[0] = e2e_p01_crc(TORQUE_DATA_ID, t)
        self.alive = (self.alive + 1) % 15  # P01: 0..14
        engine, e0 = self._encode("VCU_EngineCmd", {"EngMux": 0, "IceOnReq": 1 if d.iceON else 0,
                                                    "IcePwrReq": d.icePowRef_W / 1000.0})
        _, e1 = self._encode("VCU_EngineCmd", {"EngMux": 1, "IceTrqReq": d.iceTauRef_Nm})
        return [(torque.arbitration_id.id, torque.arbitration_id.extended, bytes(t)),
                (engine.arbitration_id.id, engine.arbitration_id.extended, bytes(e0)),
                (engine.arbitration_id.id, engine.arbitration_id.extended, bytes(e1))]


def load_calibration(args):
    if args.calibration:
        return json.loads(pathlib.Path(args.calibration).read_text())
    import ehpt  # only to read the scenario's calibration
    return dict(ehpt.Simulation(args.scenario, external_ecu=True).ecu_parameters)


def open_bus(args):
    if args.interface == "socketcand":
        return can.Bus(interface="socketcand", host=args.host, port=args.port, channel=args.channel)
    return can.Bus(interface="socketcan", channel=args.channel)


def send_all(bus, frames):
    for arbitration_id, ext, data in frames:
        bus.send(can.Message(arbitration_id=arbitration_id, is_extended_id=ext, data=data))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--interface", choices=["socketcand", "socketcan"], default="socketcand")
    ap.add_argument("--host", default="127.0.0.1")
    ap.add_argument("--port", type=int, default=29536)
    ap.add_argument("--channel", default="vcan0")
    ap.add_argument("--calibration", help="MBecu2's parameters as JSON (ehpt.Simulation(...).ecu_parameters)")
    ap.add_argument("--scenario", default="psecu2_nedc", help="without --calibration: read it from this scenario")
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--answer", action="store_true", help="answer each sample (the default): lockstep works")
    mode.add_argument("--cyclic", action="store_true", help="send every 10 ms on our own clock (wall clock)")
    ap.add_argument("--idle-timeout-s", type=float, default=5.0, help="stop after this long without a frame")
    args = ap.parse_args(argv)
    try:
        vcu = Vcu(load_calibration(args))
    except (OSError, ValueError) as e:
        print(f"vcu: cannot read the calibration: {e}", file=sys.stderr)
        return 1
    except KeyError as e:
        print(f"vcu: the calibration has no {e} (write it from ehpt.Simulation(...).ecu_parameters)", file=sys.stderr)
        return 1
    try:
        bus = open_bus(args)
    except (OSError, TimeoutError, can.CanError) as e:
        where = f"{args.host}:{args.port}" if args.interface == "socketcand" else args.channel
        print(f"vcu: cannot open the bus ({args.interface} {where}): {e}", file=sys.stderr)
        return 1
    sent = 0
    last_heard = time.monotonic()
    next_send = time.monotonic()
    try:
        while True:
            now = time.monotonic()
            if now - last_heard > args.idle_timeout_s:
                break
            timeout = max(0.0, next_send - now) if args.cyclic else 0.1
            msg = bus.recv(timeout=timeout)
            if msg is not None:
                last_heard = time.monotonic()
                name = vcu.on_frame(msg.arbitration_id, msg.is_extended_id, msg.data)
                if not args.cyclic and name == "HIL_Powertrain" and vcu.ready():
                    send_all(bus, vcu.commands())
                    sent += 1
            if args.cyclic and time.monotonic() >= next_send:
                next_send += CYCLE_S
                if vcu.ready():
                    send_all(bus, vcu.commands())
                    sent += 1
    except (ConnectionError, OSError, can.CanError):
        pass  # the plant ended the session
    finally:
        try:
            bus.shutdown()
        except (ConnectionError, OSError, can.CanError):
            pass
    print(f"vcu: {sent} commands sent", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
