#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""End-to-end tests of the CAN bus targets: the real `ehpt plant` and `ehpt ecu` binaries and
python-can's socketcand client, over TCP on 127.0.0.1 (no CAN in the kernel needed).

    /usr/bin/python3 tests/targets/bus_e2e_test.py BUILD/ehpt [unittest args]

Each test states what it shows; timeseries are compared byte for byte where the issue asks
for bit-identical runs.
"""

import json
import os
import pathlib
import random
import signal
import socket
import subprocess
import sys
import tempfile
import time
import unittest

SOURCE = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(SOURCE / "tools"))
from ehpt_dbc import Dbc  # noqa: E402

EHPT = None  # set from argv
DBC = Dbc(SOURCE / "io" / "can" / "ehpt.dbc")
COMMAND_IDS = {0x110, 0x111, 0x120, 0x130}


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def run(args, **kw):
    return subprocess.run([EHPT] + args, capture_output=True, text=True, timeout=kw.pop("timeout", 300), **kw)


def start(args, log_dir=None):
    """A process whose output goes to files (a full pipe must never stall a lockstep run)."""
    log_dir = pathlib.Path(log_dir or tempfile.gettempdir())
    out = tempfile.NamedTemporaryFile("w+", dir=log_dir, prefix="out-", delete=False)
    err = tempfile.NamedTemporaryFile("w+", dir=log_dir, prefix="err-", delete=False)
    p = subprocess.Popen(args if args[0].startswith("/") else [EHPT] + args, stdout=out, stderr=err, text=True)
    p.out_file, p.err_file = out, err
    return p


def output(p):
    p.out_file.seek(0)
    p.err_file.seek(0)
    return p.out_file.read(), p.err_file.read()


def wait_listening(port, proc, timeout_s=20.0):
    """Until the plant's socketcand endpoint accepts connections (then the probe leaves)."""
    deadline = time.time() + timeout_s
    while time.time() < deadline:
        if proc.poll() is not None:
            raise AssertionError("the plant ended early: " + output(proc)[1])
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.2):
                return
        except OSError:
            time.sleep(0.05)
    raise AssertionError("the plant does not listen on %d" % port)


def read_log(path):
    """bus.log (candump -L) -> [(time_s, id, bytes)]"""
    frames = []
    for line in pathlib.Path(path).read_text().splitlines():
        stamp, _iface, frame = line.split(" ")
        can_id, data = frame.split("#")
        frames.append((float(stamp.strip("()")), int(can_id, 16), bytes.fromhex(data)))
    return frames


def csv_rows(path):
    lines = pathlib.Path(path).read_text().splitlines()
    header = lines[0].split(",")
    return [dict(zip(header, map(float, line.split(",")))) for line in lines[1:]]


class BusTest(unittest.TestCase):
    def setUp(self):
        self.tmp = pathlib.Path(tempfile.mkdtemp(prefix="ehpt-bus-"))
        self.procs = []

    def tearDown(self):
        for p in self.procs:
            if p.poll() is None:
                p.kill()
                p.wait()

    def plant(self, scenario, port, out, *extra):
        p = start(["plant", scenario, "--bus", "socketcand:127.0.0.1:%d" % port, "--out", str(out), "--quiet"]
                  + list(extra), self.tmp)
        self.procs.append(p)
        wait_listening(port, p)
        return p

    def ecu(self, scenario, port, *extra):
        p = start(["ecu", scenario, "--bus", "socketcand:127.0.0.1:%d" % port] + list(extra), self.tmp)
        self.procs.append(p)
        return p

    def reference(self, scenario, sets, name):
        """The in-process run whose ECU signals pass through the same codec."""
        out = self.tmp / name
        args = ["run", scenario, "--out", str(out), "--quiet", "--set", "vehicle.ecu.codec=can"]
        for s in sets:
            args += ["--set", s]
        r = run(args)
        self.assertEqual(r.returncode, 0, r.stderr)
        return out

    def finish(self, proc, timeout_s=300):
        proc.wait(timeout=timeout_s)
        out, err = output(proc)
        proc.out_file.close()
        proc.err_file.close()
        return proc.returncode, out, err


class Lockstep(BusTest):
    def test_psecu2_with_ehpt_ecu_is_bit_identical_and_its_log_decodes(self):
        """The paper's PSecu2, 200 s of NEDC, plant and MBecu2 as two processes in lockstep over
        socketcand == the in-process run through the codec, byte for byte; bus.log holds every
        sample and decodes to the plant's signals."""
        sets = ["solver.duration_s=200"]
        ref = self.reference("psecu2_nedc", sets, "ref")
        port = free_port()
        plant = self.plant("psecu2_nedc", port, self.tmp / "bus", "--lockstep", "--set", sets[0])
        ecu = self.ecu("psecu2_nedc", port, "--set", sets[0])
        rc, _, err = self.finish(plant)
        self.assertEqual(rc, 0, err)
        self.assertEqual(self.finish(ecu)[0], 0)
        self.assertEqual((ref / "timeseries.csv").read_bytes(), (self.tmp / "bus" / "timeseries.csv").read_bytes())
        bus = json.loads((self.tmp / "bus" / "summary.json").read_text())["bus"]
        self.assertEqual(bus["pacing"], "lockstep")
        self.assertEqual(bus["commands_applied"], 20001)  # samples at 0, 10 ms, ..., 200 s
        self.assertEqual(bus["timeouts"], 0)
        self.assertEqual(bus["stale_samples"], 0)
        self.assertEqual(bus["saturated_signals"], 0)
        self.assertEqual(sum(bus["rejected"].values()), 0)

        frames = read_log(self.tmp / "bus" / "bus.log")
        # python-can reads the log as it is (its candump -L reader)
        import can  # noqa: E402 (Debian's python3-can)
        logged = list(can.CanutilsLogReader(str(self.tmp / "bus" / "bus.log")))
        self.assertEqual(len(logged), len(frames))
        self.assertEqual(len(frames), 20001 * 7 + 20001 * 2)  # 6 sensor frames + status, 2 commands
        self.assertEqual([(m.arbitration_id, bytes(m.data)) for m in logged[:50]], [(i, d) for _, i, d in frames[:50]])
        steps = [DBC.decode(i, d)[1]["step"] for _, i, d in frames if i == 0x200]
        self.assertEqual(steps, list(range(0, 200001, 10)))
        # each sample's frames, then its command: the decoded values are the plant's signals
        rows = {round(r["time_s"] * 1000): r for r in csv_rows(self.tmp / "bus" / "timeseries.csv")}
        checked = 0
        sensors, step = {}, None
        for _, i, d in frames:
            name, sig = DBC.decode(i, d)
            if name.startswith("PsdSensors"):
                sensors.update(sig)
            elif name == "PlantStatus":
                step = sig["step"]
            elif name == "PsdCommand2" and step in rows and step % 100 == 0:
                row = rows[step]
                self.assertAlmostEqual(sig["genTauRef_Nm"], row["genTauRef_Nm"], delta=1e-9)
                self.assertAlmostEqual(sensors["speed_m_s"], row["speed_m_s"], delta=0.0002 / 2 + 1e-12)
                self.assertAlmostEqual(sensors["iceW_rad_s"], row["iceW_rad_s"], delta=0.01 / 2 + 1e-9)
                checked += 1
        self.assertGreater(checked, 1900)

    def test_series_hybrid_with_ehpt_ecu_is_bit_identical_and_replays(self):
        """SHEV_OO, 400 s of Sort1: the plant and its EMS (ShevEMS) as two processes in lockstep
        over socketcand == the in-process run through the codec, byte for byte, through the
        genset's start at 267.31 s and stop at 373.25 s; bus.log decodes (ShevSensors1..4,
        PlantStatus, ShevCommand) to the plant's signals, gensetON switches on the frames where
        the run switches; the session replays from its inputs.log bit for bit."""
        sets = ["solver.duration_s=400"]
        ref = self.reference("shev_oo_sort1", sets, "ref")
        port = free_port()
        session = self.tmp / "bus"
        plant = self.plant("shev_oo_sort1", port, session, "--lockstep", "--set", sets[0])
        ecu = self.ecu("shev_oo_sort1", port, "--set", sets[0])
        rc, _, err = self.finish(plant)
        self.assertEqual(rc, 0, err)
        rc, out, err = self.finish(ecu)
        self.assertEqual(rc, 0, err)
        self.assertIn("40001 samples answered", out + err)
        self.assertEqual((ref / "timeseries.csv").read_bytes(), (session / "timeseries.csv").read_bytes())
        summary = json.loads((session / "summary.json").read_text())
        self.assertEqual(summary["status"], "ok")
        bus = summary["bus"]
        self.assertEqual(bus["commands_applied"], 40001)
        self.assertEqual(bus["timeouts"], 0)
        self.assertEqual(bus["saturated_signals"], 0)
        self.assertEqual(sum(bus["rejected"].values()), 0)
        self.assertGreater(summary["fuel_g"], 10.0)  # the genset ran

        frames = read_log(session / "bus.log")
        self.assertEqual(len(frames), 40001 * 6)  # 4 sensor frames + status, 1 command
        self.assertEqual({i for _, i, _ in frames}, {0x230, 0x231, 0x232, 0x233, 0x200, 0x130})
        rows = {round(r["time_s"] * 1000): r for r in csv_rows(session / "timeseries.csv")}
        on_steps, last_on, sensors, step, checked = [], False, {}, None, 0
        for _, i, d in frames:
            name, sig = DBC.decode(i, d)
            if name.startswith("ShevSensors"):
                sensors.update(sig)
            elif name == "PlantStatus":
                step = sig["step"]
            elif name == "ShevCommand":
                self.assertEqual(sig["sampleStep"], step % 65536)
                if sig["gensetON"] != last_on:
                    on_steps.append(step)
                    last_on = sig["gensetON"]
                if step % 1000 == 0:
                    row = rows[step]
                    self.assertAlmostEqual(sensors["speed_m_s"], row["speed_m_s"], delta=0.0002 / 2 + 1e-12)
                    self.assertAlmostEqual(sensors["batSOC"], row["soc"], delta=1e-6 / 2 + 1e-12)
                    self.assertAlmostEqual(sig["driveTauRef_Nm"], sensors["driverRequest_Nm"], delta=1e-9)
                    checked += 1
        self.assertEqual(checked, 401)
        self.assertEqual(len(on_steps), 2, on_steps)  # one start, one stop
        self.assertLess(abs(on_steps[0] - 267310), 20, on_steps)
        self.assertLess(abs(on_steps[1] - 373250), 20, on_steps)

        replay = self.tmp / "replay"
        r = run(["replay", str(session), "--out", str(replay), "--quiet"])
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual((replay / "timeseries.csv").read_bytes(), (session / "timeseries.csv").read_bytes())
        self.assertEqual(json.loads((replay / "summary.json").read_text())["replay"]["commands_applied"], 40001)
        self.assertIn("\n# family shev\n", (session / "inputs.log").read_text())

    def test_the_asc_log_reads_back_in_python_can_as_the_candump_log(self):
        """--bus-log-format asc: bus.asc beside bus.log, read by python-can's ASCReader: the same
        frames in the same order, ids, flags and data unchanged, each frame's direction as the
        plant saw it (the ECU's commands Rx, the plant's sensors Tx), times within 1 ms."""
        import can
        port = free_port()
        out = self.tmp / "asc"
        plant = self.plant("psecu2_nedc", port, out, "--lockstep", "--bus-log-format", "asc", "--set", "solver.duration_s=2")
        ecu = self.ecu("psecu2_nedc", port, "--set", "solver.duration_s=2")
        rc, _, err = self.finish(plant, 60)
        self.assertEqual(rc, 0, err)
        self.assertEqual(self.finish(ecu, 30)[0], 0)
        candump = list(can.CanutilsLogReader(str(out / "bus.log")))
        asc = list(can.ASCReader(str(out / "bus.asc"), relative_timestamp=False))  # the header's date + each line's time
        self.assertGreater(len(candump), 1000)
        self.assertEqual(len(asc), len(candump))
        commands = {0x110, 0x111}
        for a, c in zip(asc, candump):
            self.assertEqual(a.arbitration_id, c.arbitration_id)
            self.assertFalse(a.is_extended_id)
            self.assertFalse(a.is_error_frame or a.is_remote_frame)
            self.assertEqual(bytes(a.data), bytes(c.data))
            self.assertEqual(a.is_rx, c.arbitration_id in commands, hex(c.arbitration_id))
            self.assertLess(abs(a.timestamp - c.timestamp), 1.0e-3 + 1e-6)
        self.assertTrue((out / "bus.asc").read_text().endswith("End TriggerBlock\n"))
        # over LCM there are no CAN frames to log
        r = run(["plant", "ev_nedc", "--bus", "lcm:udpm://239.255.76.67:7667?ttl=0", "--bus-log-format", "asc"])
        self.assertEqual(r.returncode, 1)
        self.assertIn("an ASC log is of CAN frames", r.stderr)

    def test_machine_drive_evs_over_socketcand_are_bit_identical(self):
        """EvPm_bat and EvAm_bat take their torque reference through the EV's command frame:
        plant and follower as two processes in lockstep over socketcand, Sort1 (150 s) ==
        the in-process run through the codec, byte for byte."""
        for scenario in ("evpm_sort1", "evam_sort1"):
            ref = self.reference(scenario, [], scenario + "_ref")
            port = free_port()
            plant = self.plant(scenario, port, self.tmp / scenario, "--lockstep")
            ecu = self.ecu(scenario, port)
            rc, _, err = self.finish(plant)
            self.assertEqual(rc, 0, err)
            self.assertEqual(self.finish(ecu)[0], 0)
            self.assertEqual((ref / "timeseries.csv").read_bytes(),
                             (self.tmp / scenario / "timeseries.csv").read_bytes(), scenario)
            summary = json.loads((self.tmp / scenario / "summary.json").read_text())
            self.assertEqual(summary["bus"]["commands_applied"], 15001, scenario)
            self.assertEqual(summary["bus"]["timeouts"], 0, scenario)
            self.assertAlmostEqual(summary["distance_m"], 518.5, delta=1.0)

    def test_python_can_ev_ecu_over_socketcand(self):
        """python-can's socketcand interface drives the EV through the DBC signals: the car
        follows 60 s of NEDC, and the run equals the in-process follower through the codec."""
        sets = ["solver.duration_s=60"]
        ref = self.reference("ev_nedc", sets, "ref")
        port = free_port()
        plant = self.plant("ev_nedc", port, self.tmp / "py", "--lockstep", "--set", sets[0])
        ecu = start(["/usr/bin/python3", str(SOURCE / "tools" / "pycan_ecu.py"), "--vehicle", "ev",
                     "--interface", "socketcand", "--host", "127.0.0.1", "--port", str(port),
                     "--channel", "can0", "--idle-timeout", "5"], self.tmp)
        self.procs.append(ecu)
        rc, _, err = self.finish(plant)
        self.assertEqual(rc, 0, err)
        _, out, err = self.finish(ecu, 60)
        self.assertIn("6001 samples answered", out + err)
        self.assertNotIn("Bad data", err)  # python-can's warning of a frame split badly
        summary = json.loads((self.tmp / "py" / "summary.json").read_text())
        self.assertLess(summary["speed_error_rms_kmh"], 1.0)
        self.assertGreater(summary["distance_m"], 80.0)
        self.assertEqual((ref / "timeseries.csv").read_bytes(), (self.tmp / "py" / "timeseries.csv").read_bytes())


    def test_a_replay_streams_its_log_in_memory_that_does_not_grow_with_it(self):
        """A recorded lockstep session (EV, 200 s) replayed from its own inputs.log and from a
        copy whose every command is written 1000 times (550 MB; the replay applies each copy at
        the same step, so the trajectory is the same): both bit-identical to the session, and
        the peak resident memory of the big replay within 16 MiB of the small one's (it was a
        multiple of the log: 3.5 GB for 500 MiB)."""
        sets = ["solver.duration_s=200"]
        port = free_port()
        session = self.tmp / "session"
        plant = self.plant("ev_nedc", port, session, "--lockstep", "--set", sets[0])
        ecu = self.ecu("ev_nedc", port, "--set", sets[0])
        rc, _, err = self.finish(plant)
        self.assertEqual(rc, 0, err)
        self.assertEqual(self.finish(ecu)[0], 0)
        big = self.tmp / "big"  # a session folder of the test's own: the copy with the inflated log
        big.mkdir()
        (big / "summary.json").write_bytes((session / "summary.json").read_bytes())
        lines = (session / "inputs.log").read_text().splitlines(True)
        commands = [line for line in lines if not line.startswith("#")]
        self.assertEqual(len(commands), 20001)
        # each command repeated enough times for a log of more than 500 MB, whatever the
        # length of its lines (each number is its shortest round-trip text)
        repeat = 520 * 10**6 // sum(len(c) for c in commands) + 1
        try:
            with open(big / "inputs.log", "w") as f:
                for line in lines:
                    f.write(line if line.startswith("#") else line * repeat)
            self.assertGreater((big / "inputs.log").stat().st_size, 500 * 10**6)

            def replay(src, name):
                with open(self.tmp / (name + ".err"), "w+") as err:
                    p = subprocess.Popen([EHPT, "replay", str(src), "--out", str(self.tmp / name)],
                                         stdout=subprocess.DEVNULL, stderr=err, text=True)
                    _, status, usage = os.wait4(p.pid, 0)
                    p.returncode = os.waitstatus_to_exitcode(status)
                    err.seek(0)
                    return p.returncode, err.read(), usage.ru_maxrss  # KiB

            rc_small, err_small, rss_small = replay(session, "replay_small")
            rc_big, err_big, rss_big = replay(big, "replay_big")
        finally:
            (big / "inputs.log").unlink(missing_ok=True)  # 550 MB of the test's own
        self.assertEqual(rc_small, 0, err_small)
        self.assertEqual(rc_big, 0, err_big)
        for name, n in (("replay_small", 20001), ("replay_big", 20001 * repeat)):
            summary = json.loads((self.tmp / name / "summary.json").read_text())
            r = summary["replay"]
            self.assertEqual((r["commands_recorded"], r["commands_applied"]), (n, n), name)
            # the log read in the loop: no allocation there, the end of the log's digest check too
            self.assertEqual(summary["heap_allocations_after_startup"], 0, name)
            self.assertEqual((self.tmp / name / "timeseries.csv").read_bytes(),
                             (session / "timeseries.csv").read_bytes(), name)
        print("\n     replay peak RSS: %.1f MiB for a 0.55 MB log, %.1f MiB for a 550 MB log"
              % (rss_small / 1024, rss_big / 1024), file=sys.stderr)
        self.assertLess(rss_big - rss_small, 16 * 1024, (rss_small, rss_big))

class Safety(BusTest):
    def test_a_session_without_its_ecu_is_degraded_not_ok(self):
        """No ECU ever connects: lockstep over the whole of NEDC (118 001 samples) must neither
        wait once per sample (at 0.05 s a wait, 98 min) nor end "ok": status degraded with its
        reasons, exit 4; --allow-degraded exits 0 and the status stays degraded."""
        for allow in (False, True):
            port = free_port()
            out_dir = self.tmp / ("alone_allowed" if allow else "alone")
            extra = ["--lockstep", "--ecu-wait-s", "0.5", "--lockstep-wait-s", "0.05"]
            plant = self.plant("ev_nedc", port, out_dir, *(extra + (["--allow-degraded"] if allow else [])))
            rc, _, err = self.finish(plant, 120)
            self.assertEqual(rc, 0 if allow else 4, err)
            summary = json.loads((out_dir / "summary.json").read_text())
            self.assertEqual(summary["status"], "degraded")
            self.assertEqual(summary["steps"], 1184000)  # it ran to the end, in the safe state
            reasons = summary["degraded"]
            self.assertTrue(reasons[0].startswith("no ECU: not one command in the whole session"), reasons)
            self.assertTrue(any(r.startswith("10 lockstep waits for the ECU timed out; the plant stopped waiting")
                                for r in reasons), reasons)
            self.assertEqual(summary["bus"]["commands_applied"], 0)
            self.assertEqual(summary["bus"]["lockstep_waits_timed_out"], 10)
        # an ECU that answers every sample: not degraded, exit 0 (the negative case)
        port = free_port()
        plant = self.plant("ev_sort1", port, self.tmp / "with_ecu", "--lockstep", "--set", "solver.duration_s=3")
        ecu = self.ecu("ev_sort1", port, "--set", "solver.duration_s=3")
        rc, _, err = self.finish(plant, 60)
        self.assertEqual(rc, 0, err)
        self.assertEqual(self.finish(ecu, 30)[0], 0)
        summary = json.loads((self.tmp / "with_ecu" / "summary.json").read_text())
        self.assertEqual(summary["status"], "ok")
        self.assertNotIn("degraded", summary)

    def test_ecu_silence_gives_the_safe_state_and_a_restart_ends_it(self):
        """Wall clock: kill the ECU mid-run -> safe state within the timeout (30 ms), ecuTimeout
        in PlantStatus, torque reference zero; a new ECU process brings the plant back. Sort1
        accelerates to 20 km/h in the first 5 s: the driver asks for torque all along."""
        port = free_port()
        plant = self.plant("ev_sort1", port, self.tmp / "wall", "--set", "solver.duration_s=8")
        ecu = self.ecu("ev_sort1", port, "--set", "solver.duration_s=8")
        time.sleep(2.5)
        ecu.send_signal(signal.SIGKILL)
        ecu.wait()
        time.sleep(2.0)
        ecu2 = self.ecu("ev_sort1", port, "--set", "solver.duration_s=8")
        rc, out, err = self.finish(plant, 60)
        # a session that lost its ECU is degraded, whatever came after: exit 4, said so
        self.assertEqual(rc, 4, err)
        self.assertEqual(self.finish(ecu2, 30)[0], 0)
        summary = json.loads((self.tmp / "wall" / "summary.json").read_text())
        self.assertEqual(summary["status"], "degraded")
        # the timeout, and the frames sent while no ECU was connected
        self.assertRegex(summary["degraded"][0], r"^the ECU's commands timed out 1 time: [0-9.]+ s in the safe state$")
        self.assertRegex(summary["degraded"][1], r"^[0-9]+ frames the plant could not send \(no ECU connected")
        self.assertEqual(len(summary["degraded"]), 2, summary["degraded"])
        self.assertIn("error: the session is degraded (exit 4", err)
        bus = summary["bus"]
        self.assertEqual(bus["pacing"], "wall_clock")
        self.assertEqual(bus["timeouts"], 1)
        self.assertEqual(bus["peers_connected"], 2)
        self.assertGreaterEqual(bus["peers_lost"], 1)
        self.assertGreater(bus["safe_state_time_s"], 1.0)
        self.assertLess(bus["safe_state_time_s"], 4.0)
        self.assertGreater(bus["longest_command_gap_s"], 1.0)
        self.assertGreater(bus["commands_applied"], 300)

        frames = read_log(self.tmp / "wall" / "bus.log")
        status = [(t, DBC.decode(i, d)[1]) for t, i, d in frames if i == 0x200]
        commands = [t for t, i, _ in frames if i == 0x120]
        flagged = [t for t, s in status if s["ecuTimeout"]]
        self.assertTrue(flagged)
        # the last command before the silence, and the first flagged sample after it
        last_before = max(t for t in commands if t < flagged[0])
        self.assertLess(flagged[0] - last_before, 0.03 + 0.15)  # timeout + scheduling slack
        # fresh commands clear the flag again
        self.assertFalse(status[-1][1]["ecuTimeout"])
        # while safe, the plant's drive torque reference is zero (timeseries, decimated)
        safe_rows = [r for r in csv_rows(self.tmp / "wall" / "timeseries.csv")
                     if flagged[0] - frames[0][0] + 0.2 < r["time_s"] < flagged[-1] - frames[0][0] - 0.2]
        self.assertTrue(safe_rows)
        self.assertTrue(all(r["drive_torque_ref_Nm"] == 0.0 for r in safe_rows))
        self.assertTrue(all(r["driver_request_Nm"] > 1.0 for r in safe_rows))  # while it was asked for

    def test_hostile_frames_are_counted_and_change_nothing(self):
        """A third client floods the bus with foreign ids, wrong lengths, replayed counters,
        out-of-range values and broken text: each is counted by reason, and the lockstep run
        stays bit-identical to its reference."""
        sets = ["solver.duration_s=30"]
        ref = self.reference("psecu2_nedc", sets, "ref")
        port = free_port()
        plant = self.plant("psecu2_nedc", port, self.tmp / "hostile", "--lockstep", "--set", sets[0])
        ecu = self.ecu("psecu2_nedc", port, "--set", sets[0])
        hostile = socket.create_connection(("127.0.0.1", port))
        hostile.settimeout(5)
        self.assertEqual(hostile.recv(64), b"< hi >")
        hostile.sendall(b"< open can0 >")
        self.assertEqual(hostile.recv(64), b"< ok >")
        hostile.sendall(b"< rawmode >")
        self.assertEqual(hostile.recv(64), b"< ok >")
        hostile.setblocking(False)
        rng = random.Random(8)
        contract = {0x110, 0x111, 0x120, 0x200} | set(range(0x210, 0x216)) | set(range(0x220, 0x223))
        sent = {"foreign": 0, "length": 0, "replay": 0, "range": 0, "text": 0}
        buf = b""
        deadline = time.time() + 60
        while plant.poll() is None and time.time() < deadline:
            try:
                buf += hostile.recv(65536)
            except BlockingIOError:
                pass
            except OSError:
                break
            msgs = []
            for _ in range(20):
                kind = rng.choice(list(sent))
                if kind == "foreign":
                    cid = rng.choice([x for x in range(0x800) if x not in contract][:1500] + [0x7FF])
                    n = rng.randint(0, 8)
                    msgs.append("< send %X %X %s >" % (cid, n, " ".join("%X" % rng.randrange(256) for _ in range(n))))
                elif kind == "length":
                    n = rng.choice([0, 1, 7])
                    msgs.append("< send 110 %X %s >" % (n, " ".join("0" for _ in range(n))))
                elif kind == "replay":
                    # the latest command frame this client heard, again: a repeated counter
                    at = buf.rfind(b"< frame 111 ")
                    end = buf.find(b">", at) if at >= 0 else -1
                    if end < 0:  # none heard yet, or its end not received yet
                        continue
                    fields = buf[at:end].split()
                    data = bytes.fromhex(fields[4].decode())
                    msgs.append("< send 111 8 %s >" % " ".join("%X" % b for b in data))
                elif kind == "range":
                    # raw 524287 (beyond the +500 Nm max) in genTauRef, counter random
                    raw = 524287 | (rng.randrange(16) << 60)
                    msgs.append("< send 111 8 %s >" % " ".join("%X" % b for b in raw.to_bytes(8, "little")))
                else:
                    msgs.append(rng.choice(["< send 12345 8 0 0 0 0 0 0 0 0 >", "< send 110 9 0 >", "junk",
                                            "< send 1G0 1 0 >", "<" + "x" * 20000]))
                sent[kind] += 1
            buf = buf[-4096:]
            try:
                hostile.send(" ".join(msgs).encode() + b" ")
            except (BlockingIOError, OSError):
                pass
            time.sleep(0.002)
        hostile.close()
        print("hostile messages sent:", sent, file=sys.stderr)
        rc, _, err = self.finish(plant, 120)
        self.assertEqual(rc, 0, err)
        ecu_rc, ecu_out, _ = self.finish(ecu, 30)
        print(ecu_out, file=sys.stderr)
        bus = json.loads((self.tmp / "hostile" / "summary.json").read_text())["bus"]
        self.assertEqual((ref / "timeseries.csv").read_bytes(), (self.tmp / "hostile" / "timeseries.csv").read_bytes(),
                         json.dumps(bus))
        rejected = bus["rejected"]
        self.assertGreater(sent["replay"], 10)
        for reason in ("unknown_id", "wrong_length", "out_of_range", "malformed"):
            self.assertGreater(rejected[reason], 0, reason)
        # a replayed command is for an old sample by the time it arrives (stale); one that
        # came in time would repeat a counter (bad_counter): either way it is refused (the
        # trajectory above is the proof that none was applied). Not every one sent arrives:
        # a client holds at most its share of the plant's ring, the rest of a flood waits in
        # its socket and is dropped at the end
        self.assertGreater(rejected["stale"] + rejected["bad_counter"], 0)
        self.assertEqual(bus["timeouts"], 0)
        # every frame in lands in exactly one counter (frames before t = 0: before_start)
        self.assertEqual(bus["frames_in"], bus["frames_accepted"] + sum(v for k, v in rejected.items() if k != "malformed"),
                         bus)


LCM_URL = "lcm:udpm://239.255.76.67:7667?ttl=0"


class Lcm(BusTest):
    """Run inside tests/targets/in_netns.sh: a private network namespace, loopback multicast,
    ttl=0 (no packet leaves it)."""

    def setUp(self):
        super().setUp()
        if not os.environ.get("EHPT_IN_NETNS"):
            self.skipTest("needs tests/targets/in_netns.sh (a private network namespace)")

    def lcm_run(self, scenario, name, sets, *plant_args, ecu_args=()):
        plant = start(["plant", scenario, "--bus", LCM_URL, "--out", str(self.tmp / name), "--quiet"]
                      + list(plant_args) + [a for s in sets for a in ("--set", s)], self.tmp)
        ecu = start(["ecu", scenario, "--bus", LCM_URL, "--idle-timeout-s", "2"] + list(ecu_args)
                    + [a for s in sets for a in ("--set", s)], self.tmp)
        self.procs += [plant, ecu]
        return plant, ecu

    def plain_reference(self, scenario, sets, name):
        """LCM carries doubles: its reference is the plain in-process run (no codec)."""
        out = self.tmp / name
        r = run(["run", scenario, "--out", str(out), "--quiet"] + [a for s in sets for a in ("--set", s)])
        self.assertEqual(r.returncode, 0, r.stderr)
        return out

    def test_lockstep_over_udpm_is_bit_identical_to_the_plain_run(self):
        """ehpt plant and ehpt ecu as two processes over LCM udpm, lockstep: the EV (60 s), the
        paper's PSecu2 (200 s of NEDC) and EvPm_bat (Sort1) equal the in-process runs byte for byte. (The CAN
        run of the same scenario equals its own reference, the one through the CAN codec: CAN
        quantises, LCM does not; the two differ by the quantisation, checked small here.)"""
        for scenario, seconds in (("ev_nedc", 60), ("psecu2_nedc", 200), ("evpm_sort1", 150), ("shev_oo_sort1", 300)):
            sets = ["solver.duration_s=%d" % seconds]
            ref = self.plain_reference(scenario, sets, scenario + "_ref")
            plant, ecu = self.lcm_run(scenario, scenario, sets, "--lockstep")
            rc, _, err = self.finish(plant)
            self.assertEqual(rc, 0, err)
            self.assertEqual(self.finish(ecu, 30)[0], 0)
            self.assertEqual((ref / "timeseries.csv").read_bytes(), (self.tmp / scenario / "timeseries.csv").read_bytes(),
                             scenario)
            bus = json.loads((self.tmp / scenario / "summary.json").read_text())["bus"]
            samples = seconds * 100 + 1
            self.assertEqual(bus["transport"], LCM_URL)
            self.assertEqual(bus["commands_applied"], samples)
            # sample 0 goes out again each second until an ECU answers (the ECU may start later)
            self.assertIn(bus["messages_out"] - samples, (0, 1, 2))
            self.assertEqual(bus["messages_in"], samples)
            self.assertEqual(sum(bus["rejected"].values()), 0)
            self.assertEqual(bus["timeouts"], 0)
            # against the run through the CAN codec: close, not equal
            can_ref = self.reference(scenario, sets, scenario + "_can_ref")
            a = json.loads((can_ref / "summary.json").read_text())
            b = json.loads((self.tmp / scenario / "summary.json").read_text())
            self.assertNotEqual((can_ref / "timeseries.csv").read_bytes(), (ref / "timeseries.csv").read_bytes())
            self.assertAlmostEqual(a["distance_m"], b["distance_m"], delta=1e-3 * b["distance_m"])

    def test_ecu_silence_and_recovery_over_lcm(self):
        """Wall clock over LCM: ehpt ecu killed while the car accelerates (Sort1), restarted:
        one timeout, the torque reference zero meanwhile, ecuTimeout ends after the restart."""
        sets = ["solver.duration_s=8"]
        plant, ecu = self.lcm_run("ev_sort1", "wall", sets)
        time.sleep(2.5)
        ecu.send_signal(signal.SIGKILL)
        ecu.wait()
        time.sleep(2.0)
        ecu2 = start(["ecu", "ev_sort1", "--bus", LCM_URL, "--idle-timeout-s", "2", "--set", sets[0]], self.tmp)
        self.procs.append(ecu2)
        rc, _, err = self.finish(plant, 60)
        self.assertEqual(rc, 4, err)  # degraded: the ECU was lost for a while
        self.assertIn("the ECU's commands timed out 1 time", err)
        self.assertEqual(self.finish(ecu2, 30)[0], 0)
        bus = json.loads((self.tmp / "wall" / "summary.json").read_text())["bus"]
        self.assertEqual(bus["pacing"], "wall_clock")
        self.assertEqual(bus["timeouts"], 1)
        self.assertGreater(bus["safe_state_time_s"], 1.0)
        self.assertLess(bus["safe_state_time_s"], 4.0)
        rows = csv_rows(self.tmp / "wall" / "timeseries.csv")
        # the silence in the timeseries (its place in simulated time depends on when the first
        # ECU answered): one block of rows with the torque reference at zero while the driver
        # asks for torque, 1 to 4 s long; before and after it the follower passes the request on
        # (one sample late or so: wall clock)
        safe = [i for i, r in enumerate(rows) if r["drive_torque_ref_Nm"] == 0.0 and r["driver_request_Nm"] > 1.0]
        self.assertTrue(safe)
        first, last = safe[0], safe[-1]
        self.assertEqual(safe, list(range(first, last + 1)))
        self.assertGreater(rows[last]["time_s"] - rows[first]["time_s"], 1.0)
        self.assertLess(rows[last]["time_s"] - rows[first]["time_s"], 4.0)
        followed = [r for r in rows[:first - 1] + rows[last + 2:] if r["time_s"] > 0.5]
        self.assertTrue(followed)
        self.assertTrue(all(abs(r["drive_torque_ref_Nm"] - r["driver_request_Nm"]) < 0.1 * abs(r["driver_request_Nm"]) + 1
                            for r in followed),
                        [(r["time_s"], r["drive_torque_ref_Nm"], r["driver_request_Nm"]) for r in followed][:5])

    def test_no_multicast_route_is_one_line_and_no_folder(self):
        """In a namespace whose loopback has no multicast route (a fresh machine's usual
        failure), both commands say so in one line, exit 2, and make no folder."""
        out = self.tmp / "never"
        for cmd in (["plant", "ev_nedc", "--bus", LCM_URL, "--out", str(out)], ["ecu", "ev_nedc", "--bus", LCM_URL]):
            r = subprocess.run(["unshare", "-n", "sh", "-c", 'ip link set lo up && exec "$@"', "sh", EHPT] + cmd,
                               capture_output=True, text=True, timeout=60)
            self.assertEqual(r.returncode, 2, r.stderr)
            self.assertEqual(r.stderr.strip().splitlines(),
                             ["error: %s: cannot open (usually no multicast route: 'ip route add 224.0.0.0/4 dev lo' "
                              "for loopback, in a private network namespace: unshare -n; see the README)" % LCM_URL])
        self.no_folder_at(out)

    def no_folder_at(self, out):
        self.assertFalse(out.exists())
        self.assertFalse(list(out.parent.glob(out.name + ".partial-*")))


class Vcan(BusTest):
    def own_dbc_calibration(self):
        """MBecu2's calibration for examples/own_dbc/vcu_ecu.py, from this build's Python module."""
        cal = self.tmp / "vcu_calibration.json"
        r = subprocess.run(["/usr/bin/python3", "-c", "import sys, json; sys.path.insert(0, sys.argv[1]); import ehpt; "
                            "json.dump(dict(ehpt.Simulation('psecu2_nedc', external_ecu=True).ecu_parameters), "
                            "open(sys.argv[2], 'w'))", str(pathlib.Path(EHPT).parent / "python"), str(cal)],
                           capture_output=True, text=True, timeout=60)
        self.assertEqual(r.returncode, 0, r.stderr)
        return cal

    def own_dbc_on_socketcand(self, cal, duration, out):
        """The same VCU and binding over socketcand on the host: the reference of the vcan run."""
        port = free_port()
        plant = self.plant("psecu2_nedc", port, out, "--lockstep", "--bus-map",
                           str(SOURCE / "examples" / "own_dbc" / "vcu.binding.toml"), "--set", "solver.duration_s=" + duration)
        vcu = start(["/usr/bin/python3", str(SOURCE / "examples" / "own_dbc" / "vcu_ecu.py"), "--port", str(port),
                     "--calibration", str(cal), "--idle-timeout-s", "3"], self.tmp)
        self.procs.append(vcu)
        rc, _, err = self.finish(plant)
        self.assertEqual(rc, 0, err)
        self.finish(vcu, 60)

    def test_plant_on_a_real_vcan0_with_ehpt_ecu_and_python_can(self):
        """Inside tools/vcan-vm.sh (a qemu guest with vcan0): ehpt plant on SocketCAN in lockstep
        with ehpt ecu, then with the python-can example (interface socketcan). Both runs equal
        the in-process follower through the codec, byte for byte, and their bus.log decodes.
        Then the VCU of its own DBC (two extended ids, Motorola, a multiplexed message, E2E)
        through its binding on PSecu2: equal, byte for byte, to the same session over socketcand
        (which own_dbc_ecu shows equal to the VCU run in process), every 29-bit frame taken."""
        duration = "10"
        ref = self.reference("ev_nedc", ["solver.duration_s=" + duration], "ref")
        cal = self.own_dbc_calibration()
        out = self.tmp / "vm"
        out.mkdir()
        r = subprocess.run([str(SOURCE / "tools" / "vcan-vm.sh"), "--timeout", "900", "--out", str(out), "--",
                            "/bin/sh", str(SOURCE / "tests" / "targets" / "vcan_guest.sh"), EHPT, str(out),
                            str(SOURCE), duration, str(cal)], capture_output=True, text=True, timeout=1000)
        if r.returncode == 77:
            print("skipped: " + r.stderr.strip(), file=sys.stderr)
            os._exit(77)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        for run_dir in ("with_ehpt_ecu", "with_pycan_ecu"):
            self.assertEqual((ref / "timeseries.csv").read_bytes(), (out / run_dir / "timeseries.csv").read_bytes(),
                             run_dir)
            bus = json.loads((out / run_dir / "summary.json").read_text())["bus"]
            self.assertEqual(bus["transport"], "socketcan:vcan0")
            self.assertEqual(bus["commands_applied"], 1001)
            self.assertEqual(bus["timeouts"], 0)
            frames = read_log(out / run_dir / "bus.log")
            steps = [DBC.decode(i, d)[1]["step"] for _, i, d in frames if i == 0x200]
            self.assertEqual(sorted(set(steps)), list(range(0, 10001, 10)))  # sample 0 may be sent again
            torques = [DBC.decode(i, d)[1]["driveTauRef_Nm"] for _, i, d in frames if i == 0x120]
            requests = [DBC.decode(i, d)[1]["driverRequest_Nm"] for _, i, d in frames if i == 0x220]
            self.assertEqual(torques[-1000:], requests[-1000:])  # the follower passes the request on
        self.assertIn("1001 samples answered", (out / "pycan.txt").read_text())
        # the own-DBC VCU on vcan0 == over socketcand
        host = self.tmp / "own_dbc_socketcand"
        self.own_dbc_on_socketcand(cal, duration, host)
        vm_run = out / "with_own_dbc_vcu"
        self.assertEqual((host / "timeseries.csv").read_bytes(), (vm_run / "timeseries.csv").read_bytes(),
                         (out / "own_dbc.txt").read_text()[-2000:])
        summary = json.loads((vm_run / "summary.json").read_text())
        bus = summary["bus"]
        self.assertEqual(summary["status"], "ok")
        self.assertEqual(bus["transport"], "socketcan:vcan0")
        samples = int(duration) * 100 + 1
        self.assertEqual(bus["commands_applied"], samples)
        self.assertEqual(sum(bus["rejected"].values()), 0, bus["rejected"])
        # the VCU's E2E-protected torque frames and its multiplexed engine frames (a 29-bit id), each taken
        self.assertEqual(bus["messages_received"]["VCU_TorqueCmd"]["accepted"], samples)
        self.assertEqual(bus["messages_received"]["VCU_TorqueCmd"]["bad_crc"], 0)
        self.assertEqual(bus["messages_received"]["VCU_EngineCmd"]["accepted"], 2 * samples)
        # bus.log: the 29-bit frames as candump writes them (8 hex digits): the plant's HIL_Powertrain
        # and the VCU's two engine frames per sample
        ext = [line for line in (vm_run / "bus.log").read_text().splitlines() if line.split()[2].find("#") == 8]
        self.assertGreaterEqual(len(ext), 3 * samples, "extended-id frames in bus.log")
        # bus faults that put error frames on vcan0 (linux/can/error.h): 5 protocol errors (one
        # per sample of 1.00-1.05 s), a bus-off at 2.0 s and its restart at 2.1 s, as a listener
        # on the interface hears them and as bus.log has them; the plant does not hear its own
        errors = (out / "error_frames.txt").read_text().splitlines()
        self.assertEqual(errors, ["20000088 0000020000000000"] * 5 + ["20000040 0000000000000000",
                                                                      "20000100 0000000000000000"])
        err_run = out / "with_error_frames"
        summary = json.loads((err_run / "summary.json").read_text())
        bus = summary["bus"]
        self.assertEqual([(f["kind"], f["frames"]) for f in bus["faults"]], [("error_frames", 5), ("bus_off", 40)])  # 10 samples x EvSensors1..3, PlantStatus
        self.assertEqual(bus["error_frames"], 0)  # received: none (its own are not looped back to it)
        self.assertEqual(summary["status"], "ok", summary.get("degraded"))
        logged = [line.split()[2] for line in (err_run / "bus.log").read_text().splitlines() if line.split()[2].startswith("2000")]
        self.assertEqual(logged, ["20000088#0000020000000000"] * 5 + ["20000040#0000000000000000",
                                                                      "20000100#0000000000000000"])


class BadInput(BusTest):
    def no_folder(self, out):
        self.assertFalse(out.exists())
        self.assertFalse(list(out.parent.glob(out.name + ".partial-*")))

    def test_each_bad_bus_is_one_clear_line_and_no_output_folder(self):
        out = self.tmp / "never"
        # a kernel without CAN, or an interface that does not exist
        r = run(["plant", "ev_nedc", "--bus", "socketcan:vcan9", "--out", str(out)])
        self.assertEqual(r.returncode, 2)
        self.assertRegex(r.stderr, r"^error: socketcan(:vcan9)?: (this kernel has no CAN support|no such CAN interface)")
        self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
        self.no_folder(out)
        # nothing listens there
        port = free_port()
        r = run(["ecu", "ev_nedc", "--bus", "socketcand:127.0.0.1:%d" % port])
        self.assertEqual(r.returncode, 2)
        self.assertIn("socketcand:127.0.0.1:%d: cannot connect: Connection refused" % port, r.stderr)
        # port in use
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            s.listen()
            r = run(["plant", "ev_nedc", "--bus", "socketcand:127.0.0.1:%d" % s.getsockname()[1], "--out", str(out)])
        self.assertEqual(r.returncode, 2)
        self.assertIn("cannot listen: port in use", r.stderr)
        self.no_folder(out)
        # a vehicle without an ECU (a rig), both commands
        r = run(["ecu", "battery_cc_discharge", "--bus", "socketcand:127.0.0.1:%d" % port])
        self.assertEqual(r.returncode, 2)
        self.assertIn("has no built-in ECU", r.stderr)
        r = run(["plant", "battery_cc_discharge", "--bus", "socketcand:127.0.0.1:%d" % port, "--out", str(out)])
        self.assertEqual(r.returncode, 2)
        self.assertIn("has no bus messages", r.stderr)
        self.no_folder(out)
        # the series hybrid's plant with another family's binding
        r = run(["plant", "shev_oo_sort1", "--bus", "socketcand:127.0.0.1:%d" % port, "--out", str(out),
                 "--bus-map", str(SOURCE / "io" / "can" / "ehpt-ev.binding.toml")])
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn("ehpt-ev.binding.toml:16: [[send]] EvSensors2: drivePowDel_W: `drivePowDel_W` is not an output "
                      "of the shev plant; did you mean `drivePowDc_W`?", r.stderr)
        self.assertIn("plant input `gensetPowRef_W` is neither bound to a signal nor given a value", r.stderr)
        self.no_folder(out)
        # not a bus
        r = run(["plant", "ev_nedc", "--bus", "isotp:vcan0", "--out", str(out)])
        self.assertEqual(r.returncode, 1)
        self.assertIn("unknown transport", r.stderr)
        # malformed LCM URLs (no socket is opened for these)
        r = run(["plant", "ev_nedc", "--bus", "lcm:udpm://x", "--out", str(out)])
        self.assertEqual(r.returncode, 1)
        self.assertIn("--bus lcm:udpm://x: a udpm URL is udpm://MULTICAST_ADDRESS:PORT?ttl=0", r.stderr)
        r = run(["ecu", "ev_nedc", "--bus", "lcm:tcpq://127.0.0.1"])
        self.assertEqual(r.returncode, 1)
        self.assertIn("unknown LCM provider", r.stderr)
        # memq is a queue inside one process: between two it can never work
        for cmd in (["plant", "ev_nedc", "--bus", "lcm:memq://", "--out", str(out)], ["ecu", "ev_nedc", "--bus", "lcm:memq://"]):
            r = run(cmd)
            self.assertEqual(r.returncode, 1, r.stderr)
            self.assertIn("--bus lcm:memq://: lcm:memq:// is in-process only, so an ECU in another process can never", r.stderr)
            self.no_folder(out)
        r = run(["plant", "ev_nedc", "--bus", "lcm:udpm://239.255.76.67:7667?ttl=x", "--out", str(out)])
        self.assertEqual(r.returncode, 1)
        self.assertIn("ttl must be a whole number 0..255", r.stderr)
        # ttl > 0 warns (the scenario is not there, so no socket is ever opened: nothing is sent)
        r = run(["plant", "no_such_scenario", "--bus", "lcm:udpm://239.255.76.67:7667?ttl=1", "--out", str(out)])
        self.assertEqual(r.returncode, 2)
        self.assertIn("warning: --bus lcm:udpm://239.255.76.67:7667?ttl=1: ttl=1 lets the multicast leave this host "
                      "(1 router hop)", r.stderr)
        r = run(["plant", "no_such_scenario", "--bus", "lcm:udpm://239.255.76.67:7667?ttl=0", "--out", str(out)])
        self.assertNotIn("warning", r.stderr)
        r = run(["plant", "ev_nedc", "--bus", "socketcand:127.0.0.1:70000", "--out", str(out)])
        self.assertEqual(r.returncode, 1)
        self.assertIn("the port must be a number from 1 to 65535", r.stderr)
        self.no_folder(out)


if __name__ == "__main__":
    EHPT = os.path.abspath(sys.argv.pop(1))
    unittest.main()
