#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""A VCU that knows only its own DBC (examples/own_dbc) against the real `ehpt plant --bus-map`,
over python-can's socketcand client on 127.0.0.1.

    PYTHONPATH=BUILD/python /usr/bin/python3 tests/targets/own_dbc_test.py BUILD/ehpt [unittest args]

The reference is the same VCU object run in process against ehpt.Simulation, each sample's
frames made as the plant makes them: the plant's encoding rule and the binding's unit
conversions are written again here from docs/binding.md (not taken from the plant), and the
VCU decodes and encodes with its own code (canmatrix). Equal timeseries, bit for bit, show that
the binding carries exactly those values both ways, with the E2E check, the extended ids and the
multiplexed message in the path.
"""

import json
import math
import pathlib
import sys
import tempfile
import time
import tomllib
import unittest

SOURCE = pathlib.Path(__file__).resolve().parents[2]
OWN = SOURCE / "examples" / "own_dbc"
sys.path.insert(0, str(OWN))
sys.path.insert(0, str(SOURCE / "tests" / "targets"))
import vcu_ecu  # noqa: E402
from bus_e2e_test import free_port, start, wait_listening  # noqa: E402
import can  # noqa: E402
import ehpt  # noqa: E402  (the module, on PYTHONPATH)

EHPT = None  # set from argv
BINDING = OWN / "vcu.binding.toml"
SCENARIO = "psecu2_nedc"

# docs/binding.md: a value in the signal's unit times this is the field's SI value
TO_SI = {"km/h": 1.0 / 3.6, "%": 0.01, "kw": 1000.0, "rpm": math.pi / 30.0, "nm": 1.0, "": 1.0}


def llround(x):
    """C's llround: half away from zero, exactly (no x + 0.5 rounding)."""
    a = abs(x)
    r = math.floor(a)
    if a - r >= 0.5:
        r += 1
    return int(-r if x < 0 else r)


class PlantSide:
    """The plant's end of the binding, written from docs/binding.md: sensors -> frames, frames ->
    command."""

    def __init__(self, vcu):
        self.binding = tomllib.loads(BINDING.read_text())
        self.frames = vcu.frames

    def sensor_frames(self, s, step):
        out = []
        for m in self.binding["send"]:
            f = self.frames[m["message"]]
            raw = {}
            for sig in f.signals:
                field = m["signals"].get(sig.name)
                if field is None:
                    continue
                if field == "ecu_timeout":
                    raw[sig.name] = 0
                    continue
                v = float(getattr(s, field))
                to_si = TO_SI[sig.unit.lower()]
                if to_si != 1.0:
                    v = v / to_si
                lo, hi = float(sig.min), float(sig.max)
                v = lo if v < lo else hi if v > hi else v
                raw[sig.name] = llround((v - float(sig.offset)) / float(sig.factor))
            if "counter" in m:
                raw[m["counter"]] = step % 16
            out.append((f.arbitration_id.id, f.arbitration_id.extended, bytes(f.encode(raw))))
        return out

    def command(self, frames, into):
        for arbitration_id, ext, data in frames:
            f = self.frames_by_id(arbitration_id, ext)
            m = next(m for m in self.binding["receive"] if m["message"] == f.name)
            decoded = f.decode(data)
            for name, field in m["signals"].items():
                if name not in decoded:
                    continue  # a multiplexed signal of the other mux value
                sig = f.signal_by_name(name)
                v = float(decoded[name].raw_value) * float(sig.factor) + float(sig.offset)
                to_si = TO_SI[sig.unit.lower()]
                if to_si != 1.0:
                    v = v * to_si
                setattr(into, field, v != 0.0 if field == "iceON" else v)

    def frames_by_id(self, arbitration_id, ext):
        return next(f for f in self.frames.values()
                    if f.arbitration_id.id == arbitration_id and f.arbitration_id.extended == ext)


def reference_run(calibration):
    sim = ehpt.Simulation(SCENARIO, external_ecu=True)
    vcu = vcu_ecu.Vcu(calibration)
    plant = PlantSide(vcu)
    period = sim.ecu_period_steps
    while not sim.finished:
        s = sim.read_sensors()
        for frame in plant.sensor_frames(s, s.stamp.step):
            vcu.on_frame(*frame)
        c = ehpt.PsdCommand()
        plant.command(vcu.commands(), c)
        c.stamp = ehpt.Stamp(time_s=s.stamp.time_s, step=s.stamp.step, sequence=0)
        sim.write_command(c)
        sim.step(period)
    return sim.timeseries()


def csv_columns(path):
    lines = pathlib.Path(path).read_text().splitlines()
    header = lines[0].split(",")
    cols = {h: [] for h in header}
    for line in lines[1:]:
        for h, v in zip(header, line.split(",")):
            cols[h].append(float(v))
    return cols


class OwnDbc(unittest.TestCase):
    def setUp(self):
        self.tmp = pathlib.Path(tempfile.mkdtemp(prefix="ehpt-own-dbc-"))
        self.calibration = dict(ehpt.Simulation(SCENARIO, external_ecu=True).ecu_parameters)
        self.cal = self.tmp / "cal.json"
        self.cal.write_text(json.dumps(self.calibration))
        self.procs = []

    def tearDown(self):
        for p in self.procs:
            if p.poll() is None:
                p.kill()
                p.wait()

    def session(self, out, plant_extra, vcu_extra=(), sets=(), forger=None, scenario=SCENARIO):
        port = free_port()
        args = [EHPT, "plant", str(scenario), "--bus", "socketcand:127.0.0.1:%d" % port, "--bus-map", str(BINDING),
                "--out", str(out), "--quiet"] + list(plant_extra)
        for s in sets:
            args += ["--set", s]
        plant = start(args, self.tmp)
        self.procs.append(plant)
        wait_listening(port, plant)
        vcu = start([sys.executable, str(OWN / "vcu_ecu.py"), "--port", str(port), "--calibration", str(self.cal),
                     "--idle-timeout-s", "3"] + list(vcu_extra), self.tmp)
        self.procs.append(vcu)
        forged = forger(port) if forger else None
        rc = plant.wait(timeout=900)
        vcu.wait(timeout=60)
        self.plant_err = plant.err_file.name
        for p in (plant, vcu):
            p.out_file.close()
            p.err_file.close()
        summary = json.loads((out / "summary.json").read_text())
        return rc, summary, forged

    def test_lockstep_over_nedc_equals_the_same_vcu_in_process_bit_for_bit(self):
        out = self.tmp / "lockstep"
        rc, summary, _ = self.session(out, ["--lockstep"])
        self.assertEqual(rc, 0, pathlib.Path(self.plant_err).read_text())
        bus = summary["bus"]
        self.assertEqual(summary["status"], "ok")
        self.assertEqual(sum(bus["rejected"].values()), 0, bus["rejected"])
        self.assertEqual(bus["messages_received"]["VCU_TorqueCmd"]["bad_crc"], 0)
        self.assertEqual(bus["stale_samples"], 0)
        self.assertEqual(bus["timeouts"], 0)
        samples = summary["steps"] // 10 + 1  # every ECU sample of NEDC, t = 0 included
        self.assertEqual(bus["commands_applied"], samples)
        # three frames per command: the E2E-protected torques and the two multiplexed engine frames
        self.assertEqual(bus["messages_received"]["VCU_TorqueCmd"]["accepted"], samples)
        self.assertEqual(bus["messages_received"]["VCU_EngineCmd"]["accepted"], 2 * samples)
        ref = reference_run(self.calibration)
        got = csv_columns(out / "timeseries.csv")
        self.assertEqual(sorted(got), sorted(ref))
        for name, values in ref.items():
            self.assertEqual(len(got[name]), len(values), name)
            diff = [i for i, (a, b) in enumerate(zip(got[name], values)) if a != b]
            self.assertEqual(diff[:1], [], "%s differs first at row %s" % (name, diff[:1]))
        # the engine ran: the multiplexed engine request reached the plant
        self.assertGreater(max(got["iceON"]), 0.5)
        self.assertGreater(summary["fuel_g"], 10.0)

    def test_forged_torque_frames_are_never_applied_and_counted_as_bad_crc(self):
        """A client that sends VCU_TorqueCmd with 300 Nm and a CRC that does not match: not one
        is applied (the trajectory equals the session without it) and each is bad_crc, not
        blamed on the VCU."""
        sets = ["solver.duration_s=120"]
        clean = self.tmp / "clean"
        rc, clean_summary, _ = self.session(clean, ["--lockstep"], sets=sets)
        self.assertEqual(rc, 0)

        def forge(port):
            bus = can.Bus(interface="socketcand", host="127.0.0.1", port=port, channel="vcan0")
            vcu = vcu_ecu.Vcu(self.calibration)
            while True:  # the session has begun once the plant sends its samples
                msg = bus.recv(timeout=10)
                self.assertIsNotNone(msg, "the plant sent nothing")
                if vcu.on_frame(msg.arbitration_id, msg.is_extended_id, msg.data) == "HIL_Powertrain":
                    break
            f, data = vcu._encode("VCU_TorqueCmd", {"TrqCmd_Alive": 1, "MotTrqReq": 300.0, "GenTrqReq": 0.0})
            data[0] = (vcu_ecu.e2e_p01_crc(vcu_ecu.TORQUE_DATA_ID, data) + 1) & 0xFF  # wrong by one
            for _ in range(100):
                bus.send(can.Message(arbitration_id=f.arbitration_id.id, is_extended_id=False, data=bytes(data)))
                time.sleep(0.001)
            bus.shutdown()
            return 100

        forged = self.tmp / "forged"
        rc, summary, sent = self.session(forged, ["--lockstep"], sets=sets, forger=forge)
        self.assertEqual(rc, 0, pathlib.Path(self.plant_err).read_text())
        torque = summary["bus"]["messages_received"]["VCU_TorqueCmd"]
        self.assertEqual(torque["bad_crc"], sent)
        self.assertEqual(summary["bus"]["rejected"]["bad_crc"], sent)
        self.assertEqual(torque["bad_counter"], 0)  # the VCU's own frames were all good
        self.assertEqual(summary["trajectory_hash"], clean_summary["trajectory_hash"])
        self.assertEqual((forged / "timeseries.csv").read_bytes(), (clean / "timeseries.csv").read_bytes())

    def test_a_cyclic_vcu_drives_the_wall_clock_plant_without_echo(self):
        """--cyclic: the VCU sends every 10 ms on its own clock, the plant sends at the DBC's
        cycle times on its own; the plant takes the latest value of each signal. The stale figure
        depends on the machine's load: printed, not asserted to be 0 (docs/binding.md has it
        measured on a quiet machine)."""
        out = self.tmp / "cyclic"
        rc, summary, _ = self.session(out, [], vcu_extra=["--cyclic"], sets=["solver.duration_s=5"])
        bus = summary["bus"]
        self.assertIn(rc, (0, 4), pathlib.Path(self.plant_err).read_text())
        self.assertGreater(bus["commands_applied"], 300)  # ~3 frames per 10 ms for 5 s, each completes one
        self.assertEqual(bus["rejected"]["bad_crc"], 0)
        self.assertEqual(bus["rejected"]["stale"], 0)  # no echo: nothing can be stale by its step
        print("\ncyclic VCU, wall clock 5 s: %d commands, %d stale samples, %d timeouts"
              % (bus["commands_applied"], bus["stale_samples"], bus["timeouts"]), file=sys.stderr)

    def test_a_bus_fault_spoils_the_e2e_crc_and_the_plant_counts_each_frame_as_bad_crc(self):
        """bad_crc on the VCU's torque command for 1 s (wall clock, the cyclic VCU): every frame
        it spoiled is refused as bad_crc and nothing else is; the message times out into the
        safe state, counted under the bus fault (the session is not degraded by it)."""
        test = self.tmp / "bad_crc.toml"
        test.write_text('scenario = "psecu2_nedc"\n[solver]\nduration_s = 4.0\n'
                        '[[fault]]\nkind = "bad_crc"\ntarget = "VCU_TorqueCmd"\nat_s = 2.0\nuntil_s = 3.0\n')
        out = self.tmp / "bad_crc"
        rc, summary, _ = self.session(out, [], vcu_extra=["--cyclic"], scenario=test)
        bus = summary["bus"]
        self.assertIn(rc, (0, 4), pathlib.Path(self.plant_err).read_text())
        fault = bus["faults"][0]
        self.assertEqual((fault["kind"], fault["message"], fault["direction"]), ("bad_crc", "VCU_TorqueCmd", "ecu_to_plant"))
        self.assertGreater(fault["frames"], 50)  # ~100 at 10 ms (the VCU's own clock)
        self.assertEqual(bus["messages_received"]["VCU_TorqueCmd"]["bad_crc"], fault["frames"])
        self.assertEqual(bus["rejected"]["bad_crc"], fault["frames"])
        self.assertGreaterEqual(bus["timeouts"], 1)
        self.assertEqual(bus["timeouts_under_bus_faults"], bus["timeouts"])
        print("\nbad_crc 1 s: %d frames spoiled and refused, %d timeouts, %.3f s safe state"
              % (fault["frames"], bus["timeouts"], bus["safe_state_time_s"]), file=sys.stderr)


if __name__ == "__main__":
    EHPT = str(pathlib.Path(sys.argv.pop(1)).resolve())
    unittest.main()
