#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""Self-test of tools/ehpt_dbc.py and tools/pycan_ecu.py, without a plant and without vcan:
DBC round trips and golden frames, the two strategies, and the ECU end to end on python-can's
in-process `virtual` bus against a tiny fake plant. Exit status 0: all passed.

    /usr/bin/python3 tests/targets/pycan_ecu_selftest.py
"""

import contextlib
import io
import math
import os
import pathlib
import random
import signal
import socket
import subprocess
import sys
import threading
import time
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools"))

import can  # noqa: E402
import ehpt_dbc  # noqa: E402
import pycan_ecu  # noqa: E402

DBC = ehpt_dbc.Dbc(ROOT / "io" / "can" / "ehpt.dbc")


def tolerance(s):
    return s.factor / 2 * (1 + 1e-9) + 1e-12 * max(abs(s.minimum), abs(s.maximum))


class DbcTest(unittest.TestCase):
    def test_contract_shape(self):
        self.assertEqual(sorted(DBC.by_id), [272, 273, 288, 304, 512, 528, 529, 530, 531, 532, 533, 544, 545, 546,
                                             560, 561, 562, 563])
        for m in DBC.by_id.values():
            self.assertEqual(m.length, 8, m.name)
            counter = [s for s in m.signals if s.name == "counter"]
            self.assertEqual([(s.start, s.length, s.signed) for s in counter], [(60, 4, False)], m.name)
            # every command echoes the step of the sample it answers; plant frames do not
            echo = [(s.start, s.length, s.signed, s.factor, s.minimum, s.maximum) for s in m.signals
                    if s.name == "sampleStep"]
            want = [(44, 16, False, 1.0, 0.0, 65535.0)] if m.sender == "Ecu" else []
            self.assertEqual(echo, want, m.name)
        self.assertEqual(sorted(m.name for m in DBC.by_id.values() if m.sender == "Ecu"),
                         ["EvCommand", "PsdCommand1", "PsdCommand2", "ShevCommand"])

    def test_round_trip_every_signal(self):
        rng = random.Random(1)
        for m in DBC.by_id.values():
            sigs = [s for s in m.signals if s.name != "counter"]
            for target in sigs:
                for value in (target.minimum, target.maximum, 0.0, rng.uniform(target.minimum, target.maximum)):
                    # the others random, so that a signal leaking into its neighbour shows
                    values = {s.name: rng.uniform(s.minimum, s.maximum) for s in sigs}
                    values[target.name] = value
                    counter = rng.randrange(16)
                    can_id, data = DBC.encode(m.name, values, counter)
                    self.assertEqual((can_id, len(data)), (m.id, 8))
                    name, out = DBC.decode(can_id, bytes(data))
                    self.assertEqual(name, m.name)
                    self.assertEqual(out["counter"], counter)
                    for s in sigs:
                        self.assertLessEqual(abs(out[s.name] - values[s.name]), tolerance(s),
                                             f"{m.name}.{s.name} = {values[s.name]!r} came back {out[s.name]!r}")

    def test_golden_frames(self):
        # Written out by hand from the DBC, so that an encoder and decoder wrong in the same way fail.
        # EvCommand: driveTauRef_Nm factor 0.1, -11800 -> raw -118000 -> 2^20 - 118000 = 0xE3310 at bits 0..19
        # -> bytes 10 33 0E; sampleStep 0x1234 at bits 44..59 -> byte 5 0x40, byte 6 0x23, byte 7 0x01 | counter 3 << 4.
        # The second is line 14 of tests/data/can/golden_frames.log (the C++ codec's): 12.3 -> raw 123 = 0x7B,
        # 0xABCD -> D0 BC 0A. EvSensors1 is line 8 of that file: driverRequest_Nm -11800 (0xE3310), speed_m_s 10
        # (raw 50000 = 0x0C350 at bits 20..39), batSOC 0.55 (raw 550000 = 0x86470 at bits 40..59).
        # The last two are the ends of the EV's request range, +-50000 Nm: raw +-500000 = 0x7A120 / 0x85EE0.
        cases = [("EvCommand", {"driveTauRef_Nm": -11800.0, "sampleStep": 0x1234}, 3, 288, "10330e0000402331"),
                 ("EvCommand", {"driveTauRef_Nm": 12.3, "sampleStep": 0xABCD}, 0, 288, "7b00000000d0bc0a"),
                 ("EvSensors1", {"driverRequest_Nm": -11800.0, "speed_m_s": 10.0, "batSOC": 0.55}, 0,
                  544, "10330e350c706408"),
                 ("EvCommand", {"driveTauRef_Nm": 50000.0, "sampleStep": 0}, 0, 288, "20a1070000000000"),
                 ("EvSensors1", {"driverRequest_Nm": -50000.0, "speed_m_s": 0.0, "batSOC": 0.0}, 0,
                  544, "e05e080000000000"),
                 ("PsdCommand1", {"icePowRef_W": 30000.5, "iceTauRef_Nm": -120.25, "iceON": 1, "sampleStep": 0x5678},
                  0, 272, "61ea60a4e2816705"),
                 ("PlantStatus", {"step": 0x01020304, "fault": 0x55, "locked": 1, "ecuTimeout": 1}, 10,
                  512, "04030201550300a0"),
                 ("PsdSensors1", {"driverRequest": 1.0, "speed_m_s": -0.0002, "batSOC": 0.5}, 0,
                  528, "a086f1ffff20a107")]
        for name, values, counter, can_id, hexdata in cases:
            self.assertEqual(DBC.encode(name, values, counter), (can_id, bytes.fromhex(hexdata)), name)
            got_name, got = DBC.decode(can_id, bytes.fromhex(hexdata))
            self.assertEqual(got_name, name)
            for k, v in values.items():
                self.assertAlmostEqual(got[k], v, places=9, msg=f"{name}.{k}")
        self.assertEqual(DBC.decode(512, bytes.fromhex("ffffffff00000000"))[1]["step"], 4294967295)

    def test_clamping_at_encode(self):
        for m in DBC.by_id.values():
            for s in m.signals:
                if s.name == "counter":
                    continue
                base = {x.name: 0.0 for x in m.signals if x.name != "counter"}
                span = s.maximum - s.minimum
                for value, expect in ((s.maximum + 10 * span, s.maximum), (s.minimum - 10 * span, s.minimum),
                                      (math.inf, s.maximum), (-math.inf, s.minimum)):
                    out = DBC.decode(*DBC.encode(m.name, {**base, s.name: value}, 0))[1]
                    self.assertLessEqual(abs(out[s.name] - expect), tolerance(s), f"{m.name}.{s.name} {value}")
                with self.assertRaises(ValueError):
                    DBC.encode(m.name, {**base, s.name: math.nan}, 0)

    def test_errors(self):
        cases = [(lambda: DBC.decode(0x7FF, bytes(8)), "unknown CAN id"),
                 (lambda: DBC.decode(288, bytes(7)), "7 data bytes"),
                 (lambda: DBC.decode(288, bytes(9)), "9 data bytes"),
                 (lambda: DBC.encode("NoSuchMessage", {}, 0), "unknown message"),
                 (lambda: DBC.encode("EvCommand", {}, 0), "missing ['driveTauRef_Nm', 'sampleStep']"),
                 (lambda: DBC.encode("EvCommand", {"driveTauRef_Nm": 1}, 0), "missing ['sampleStep']"),
                 (lambda: DBC.encode("EvCommand", {"driveTauRef_Nm": 1, "sampleStep": 0, "x": 2}, 0),
                  "unknown signals ['x']"),
                 (lambda: DBC.encode("EvCommand", {"driveTauRef_Nm": 1, "sampleStep": 0}, 16), "counter 16")]
        for call, text in cases:
            with self.assertRaises(ValueError) as ctx:
                call()
            self.assertIn(text, str(ctx.exception))


class StrategyTest(unittest.TestCase):
    def test_ev_passes_the_request_through(self):
        for req in (0.0, 123.45, -800.0, 4999.99, -11800.0, 50000.0):
            self.assertEqual(pycan_ecu.ev_strategy({"driverRequest_Nm": req}), {"EvCommand": {"driveTauRef_Nm": req}})
        self.assertEqual(pycan_ecu.ev_strategy({"driverRequest_Nm": 500.0}, 300.0)["EvCommand"]["driveTauRef_Nm"], 300.0)
        self.assertEqual(pycan_ecu.ev_strategy({"driverRequest_Nm": -500.0}, 300.0)["EvCommand"]["driveTauRef_Nm"], -300.0)
        self.assertEqual(pycan_ecu.ev_strategy({"driverRequest_Nm": 100.0}, 300.0)["EvCommand"]["driveTauRef_Nm"], 100.0)

    def test_psd_demo(self):
        ecu = pycan_ecu.PsdDemoStrategy()

        def step(traction_W, iceW, request=0.5):
            cmd = ecu({"driverRequest": request, "motPowDelB_W": traction_W, "iceW_rad_s": iceW})
            for name, values in cmd.items():
                # every command signal exists in the DBC; the echo is the ECU loop's, not the strategy's
                self.assertNotIn("sampleStep", values)
                DBC.encode(name, {**values, "sampleStep": 0}, 0)
            return {**cmd["PsdCommand1"], **cmd["PsdCommand2"]}

        c = step(3000.0, 0.0)  # low power: engine off, gen holds 125 rad/s, mot follows the driver
        self.assertEqual((c["iceON"], c["icePowRef_W"], c["iceTauRef_Nm"], c["motTauRef_Nm"]), (0, 0.0, 0.0, 40.0))
        self.assertEqual(c["genTauRef_Nm"], 80.0)  # 125 rad/s error, clamped
        c = step(20000.0, 150.0, request=-1.0)
        self.assertEqual((c["iceON"], c["icePowRef_W"], c["motTauRef_Nm"]), (1, 20000.0, -80.0))
        self.assertAlmostEqual(c["genTauRef_Nm"], 50.0)  # w_ref 200 rad/s
        self.assertEqual(step(20000.0, 400.0)["genTauRef_Nm"], -80.0)
        self.assertEqual(step(6000.0, 125.0)["iceON"], 1)  # hysteresis: stays on between 5 and 7 kW
        c = step(4000.0, 125.0)
        self.assertEqual((c["iceON"], c["icePowRef_W"], c["genTauRef_Nm"]), (0, 0.0, 0.0))
        self.assertEqual(step(6000.0, 125.0)["iceON"], 0)  # ... and stays off


class FakePlant:
    """Sends one sample (sensor frames, then PlantStatus) and waits for the command frames."""

    def __init__(self, channel, vehicle):
        self.bus = can.Bus(interface="virtual", channel=channel)
        self.vehicle, self.counters = vehicle, {}

    def send(self, name, values):
        c = self.counters.get(name, 0)
        can_id, data = DBC.encode(name, values, c)
        self.counters[name] = (c + 1) % 16
        self.bus.send(can.Message(arbitration_id=can_id, data=data, is_extended_id=False))

    def sample(self, step, sensors, want, timeout_s=1.0):
        """-> {command name: signals}. Every command must echo this sample's step mod 65536."""
        self.bus.send(can.Message(arbitration_id=0x100, data=bytes(8), is_extended_id=False))  # foreign traffic
        self.bus.send(can.Message(arbitration_id=288, data=bytes(3), is_extended_id=False))  # malformed
        for name in pycan_ecu.SENSOR_FRAMES[self.vehicle]:
            msg = DBC.by_name[name]
            self.send(name, {s.name: sensors[s.name] for s in msg.signals if s.name != "counter"})
        self.send("PlantStatus", {"step": step, "fault": 0, "locked": 0, "ecuTimeout": 0})
        got, end = {}, time.monotonic() + timeout_s
        while len(got) < len(want) and time.monotonic() < end:
            msg = self.bus.recv(timeout=0.05)
            if msg is not None:
                name, sig = DBC.decode(msg.arbitration_id, msg.data)
                self.assertIn_(name, want)
                if sig["sampleStep"] != step % 65536:
                    raise AssertionError(f"{name} answers sample {sig['sampleStep']}, "
                                         f"not {step % 65536} (step {step} mod 65536)")
                got[name] = sig
        return got

    @staticmethod
    def assertIn_(name, want):
        if name not in want:
            raise AssertionError(f"unexpected frame {name} from the ECU")


def quantized(message_names, values):
    """What the ECU sees after the bus: the values through encode and decode."""
    out = {}
    for name in message_names:
        msg = DBC.by_name[name]
        out.update(DBC.decode(*DBC.encode(name, {s.name: values[s.name] for s in msg.signals
                                                  if s.name != "counter"}, 0))[1])
    return out


class EndToEndTest(unittest.TestCase):
    def run_ecu(self, vehicle, periods, make_sensors, commands, extra_args=(), first_step=0):
        channel = f"pycan_selftest_{os.getpid()}_{vehicle}"
        plant = FakePlant(channel, vehicle)
        args = ["--interface", "virtual", "--channel", channel, "--vehicle", vehicle,
                "--max-periods", str(periods), "--idle-timeout", "3", *extra_args]
        result, stdout = {}, io.StringIO()

        def ecu():
            with contextlib.redirect_stdout(stdout):
                result["code"] = pycan_ecu.main(args)

        thread = threading.Thread(target=ecu, daemon=True)
        thread.start()
        answers, step, rng = [], first_step, random.Random(2)
        deadline = time.monotonic() + 10
        while len(answers) < periods and time.monotonic() < deadline:
            sensors = make_sensors(rng)
            got = plant.sample(step, sensors, commands, timeout_s=0.3 if not answers else 2.0)
            if got:  # the first samples may go out before the ECU's bus exists
                self.assertEqual(sorted(got), sorted(commands))
                for name in commands:  # checked in FakePlant.sample too; here so that it cannot be lost
                    self.assertEqual(got[name]["sampleStep"], step % 65536, f"{name} at step {step}")
                answers.append((sensors, got))
                step += 1
        thread.join(10)
        plant.bus.shutdown()
        self.assertFalse(thread.is_alive(), "the ECU did not stop after --max-periods")
        self.assertEqual(result.get("code"), 0)
        self.assertEqual(len(answers), periods)
        self.assertIn(f"{periods} samples answered, last step {step - 1}", stdout.getvalue())
        for name in commands:  # the counter of each command id goes +1 per frame, mod 16
            counters = [got[name]["counter"] for _, got in answers]
            for a, b in zip(counters, counters[1:]):
                self.assertEqual(b, (a + 1) % 16, f"{name} counters {counters}")
        return answers

    def test_ev(self):
        def sensors(rng):
            # up to the US06 request (11 800 Nm), beyond the old +-5000 Nm range
            return {"driverRequest_Nm": rng.uniform(-12000, 12000), "speed_m_s": rng.uniform(0, 40),
                    "batSOC": 0.6, "driveW_rad_s": 100.0, "driveTauLim_Nm": 2500.0, "drivePowDel_W": 1e4,
                    "batPowDel_W": 1e4, "battery_voltage_V": 350.0, "battery_current_A": 30.0}
        # steps 65526..65545: the echo wraps from 65535 to 0 half way
        answers = self.run_ecu("ev", 20, sensors, ["EvCommand"], first_step=65526)
        self.assertEqual([got["EvCommand"]["sampleStep"] for _, got in answers],
                         list(range(65526, 65536)) + list(range(0, 10)))
        for sens, got in answers:
            self.assertAlmostEqual(got["EvCommand"]["driveTauRef_Nm"], sens["driverRequest_Nm"], delta=0.051)
        # the last steps before PlantStatus.step itself wraps (2^32 - 1)
        for sens, got in self.run_ecu("ev", 5, sensors, ["EvCommand"], ["--torque-limit-Nm", "1000"],
                                      first_step=2**32 - 5):
            self.assertIn(got["EvCommand"]["sampleStep"], range(65531, 65536))
            want = max(-1000, min(1000, sens["driverRequest_Nm"]))
            self.assertAlmostEqual(got["EvCommand"]["driveTauRef_Nm"], want, delta=0.051)

    def test_psd(self):
        names = pycan_ecu.SENSOR_FRAMES["psd"]
        signals = [s for n in names for s in DBC.by_name[n].signals if s.name != "counter"]

        def sensors(rng):
            return {s.name: rng.uniform(s.minimum, s.maximum) * 0.1 for s in signals}
        answers = self.run_ecu("psd", 20, sensors, ["PsdCommand1", "PsdCommand2"], first_step=3 * 65536 + 12345)
        reference = pycan_ecu.PsdDemoStrategy()  # the same strategy fed what the ECU saw
        for sens, got in answers:
            want = reference(quantized(names, sens))
            for name, values in want.items():
                for k, v in values.items():
                    s = next(x for x in DBC.by_name[name].signals if x.name == k)
                    self.assertLessEqual(abs(got[name][k] - v), tolerance(s), f"{name}.{k}")

    def test_socketcand(self):
        # A minimal socketcand server in front of python-can 4.1's client (`< hi >`, `< ok >` as
        # separate reads, frames in, `< send ID LEN B0 B1 .. >` out with unpadded hex bytes).
        # Its frames arrive marked extended: the ECU must not drop them for that.
        srv = socket.create_server(("127.0.0.1", 0))
        proc = subprocess.Popen([sys.executable, str(ROOT / "tools" / "pycan_ecu.py"), "--interface", "socketcand",
                                 "--host", "127.0.0.1", "--port", str(srv.getsockname()[1]), "--channel", "vcan0",
                                 "--max-periods", "20"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.addCleanup(proc.kill)  # no-op once it has exited
        srv.settimeout(10)
        conn, _ = srv.accept()
        conn.settimeout(5)
        for hello, reply in ((b"< hi >", b"< open vcan0 >"), (b"< ok >", b"< rawmode >")):
            conn.sendall(hello)
            self.assertEqual(conn.recv(100), reply)
        conn.sendall(b"< ok >")
        sensors = {"driveW_rad_s": 1, "driveTauLim_Nm": 1, "drivePowDel_W": 1, "batSOC": 0.6,
                   "batPowDel_W": 1, "battery_voltage_V": 1, "battery_current_A": 1, "speed_m_s": 2.5}
        buf, counters = b"", []
        for k in range(20):
            sensors["driverRequest_Nm"] = 10.0 * k - 50
            frames = [DBC.encode(n, {s.name: sensors[s.name] for s in DBC.by_name[n].signals if s.name != "counter"},
                                 k % 16) for n in ("EvSensors1", "EvSensors2", "EvSensors3")]
            frames.append(DBC.encode("PlantStatus", {"step": 65526 + k, "fault": 0, "locked": 0, "ecuTimeout": 0},
                                     k % 16))
            conn.sendall(b"".join(f" < frame {i:X} {time.time():.6f} {d.hex().upper()} >".encode() for i, d in frames))
            while b">" not in buf:
                buf += conn.recv(1000)
            line, buf = buf.split(b">", 1)
            word, can_id, length, *data = line.decode().strip("< ").split()
            self.assertEqual((word, int(can_id, 16), int(length, 16)), ("send", 288, 8))
            sig = DBC.decode(288, bytes(int(b, 16) for b in data))[1]
            self.assertAlmostEqual(sig["driveTauRef_Nm"], 10.0 * k - 50, delta=0.051)
            self.assertEqual(sig["sampleStep"], (65526 + k) % 65536)
            counters.append(sig["counter"])
        out, err = proc.communicate(timeout=10)
        conn.close()
        srv.close()
        self.assertEqual(proc.returncode, 0, err)
        self.assertEqual(counters, [k % 16 for k in range(20)])
        self.assertIn("20 samples answered, last step 65545, last speed 2.5000 m/s", out)

    def test_ctrl_c(self):
        proc = subprocess.Popen([sys.executable, str(ROOT / "tools" / "pycan_ecu.py"), "--interface", "virtual",
                                 "--channel", "ctrl_c", "--idle-timeout", "60"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.addCleanup(proc.kill)
        time.sleep(1.5)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=10)
        self.assertEqual(proc.returncode, 130, err)
        self.assertIn("stopped: Ctrl-C", out)
        self.assertNotIn("Traceback", err)


if __name__ == "__main__":
    unittest.main(verbosity=1)
