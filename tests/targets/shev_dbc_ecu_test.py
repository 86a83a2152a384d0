#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""The series hybrid's bus contract, seen from outside: `tests/targets/shev_dbc_ecu.py`, a
ShevEMS written from io/can/ehpt.dbc and MODELS.md 5.5 only (python-can + canmatrix), runs
the real `ehpt plant shev_oo_sort1` in lockstep over socketcand, and its run is compared
with the built-in ShevEMS through the same CAN quantisation (`ehpt run ... --set
vehicle.ecu.codec=can`).

    /usr/bin/python3 tests/targets/shev_dbc_ecu_test.py BUILD/ehpt [unittest args]

Both runs log every ECU period (output.interval_s = 0.01: the scenario's own 0.1 s would
make a switching time only as exact as 0.1 s). Set SHEV_DBC_ECU_KEEP=1 to keep the
runs' directories.
"""

import csv
import json
import os
import pathlib
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import unittest

HERE = pathlib.Path(__file__).resolve().parent
CLIENT = HERE / "shev_dbc_ecu.py"
PYTHON = "/usr/bin/python3"  # Debian's python3-can and python3-canmatrix
SCENARIO = "shev_oo_sort1"
DURATION_S = 400.0
PERIOD_S = 0.01
SAMPLES = 40001  # t = 0, 0.01, ..., 400
COMMON = ["--quiet", "--set", f"solver.duration_s={DURATION_S:g}",
          "--set", f"output.interval_s={PERIOD_S:g}"]

EHPT = None  # from argv


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start(cmd, log_dir, name):
    """A process whose output goes to files, never to pipes (a full pipe would stall a
    lockstep run)."""
    out = open(log_dir / f"{name}.out", "w")
    err = open(log_dir / f"{name}.err", "w")
    p = subprocess.Popen([str(c) for c in cmd], stdout=out, stderr=err,
                         stdin=subprocess.DEVNULL)
    p.logs = (out, err)
    p.name = name
    return p


def finish(p, timeout_s):
    """Exit code of p (killed if it outlives timeout_s), its stdout and stderr."""
    try:
        rc = p.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        p.kill()
        p.wait()
        rc = f"killed after {timeout_s} s"
    texts = []
    for f in p.logs:
        f.close()
        texts.append(pathlib.Path(f.name).read_text(errors="replace"))
    return rc, texts[0], texts[1]


def wait_listening(port, proc, timeout_s=30.0):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            return False
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.2):
                return True
        except OSError:
            time.sleep(0.05)
    return False


def read_timeseries(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    cols = {k: [float(r[k]) for r in rows] for k in rows[0]}
    return cols


def switches(ts):
    """(time, new state) at each change of genset_on."""
    on = ts["genset_on"]
    return [(ts["time_s"][i], on[i]) for i in range(1, len(on)) if on[i] != on[i - 1]]


def switches_agree(a, b, tol_s):
    if len(a) != len(b):
        return False
    return all(sa == sb and abs(ta - tb) <= tol_s for (ta, sa), (tb, sb) in zip(a, b))


class Run:
    def __init__(self, out, rc, stdout, stderr, client=None):
        self.out, self.rc, self.stdout, self.stderr, self.client = out, rc, stdout, stderr, client
        summary = out / "summary.json"
        self.summary = json.loads(summary.read_text()) if summary.exists() else None
        ts = out / "timeseries.csv"
        self.ts = read_timeseries(ts) if ts.exists() else None

    def describe(self):
        text = f"{self.out}: exit {self.rc}\nstdout:\n{self.stdout[-3000:]}\nstderr:\n{self.stderr[-3000:]}"
        if self.client:
            rc, out, err = self.client
            text += f"\nclient exit {rc}\nstdout:\n{out[-2000:]}\nstderr:\n{err[-2000:]}"
        return text


def reference_run(tmp):
    out = tmp / "ref"
    cmd = [EHPT, "run", SCENARIO, "--out", out, "--set", "vehicle.ecu.codec=can"] + COMMON
    p = start(cmd, tmp, "ref")
    rc, stdout, stderr = finish(p, 300)
    return Run(out, rc, stdout, stderr)


def bus_run(tmp, name, client_args=()):
    out = tmp / name
    port = free_port()
    plant = start([EHPT, "plant", SCENARIO, "--bus", f"socketcand:127.0.0.1:{port}",
                   "--lockstep", "--out", out] + COMMON, tmp, f"{name}.plant")
    if not wait_listening(port, plant):
        rc, stdout, stderr = finish(plant, 10)
        raise AssertionError(f"the plant never listened on {port}: exit {rc}\n{stdout}\n{stderr}")
    client = start([PYTHON, CLIENT, "--host", "127.0.0.1", "--port", port, "--channel", "can0",
                    "--idle-timeout", "3"] + list(client_args), tmp, f"{name}.ecu")
    client_result = finish(client, 600)
    rc, stdout, stderr = finish(plant, 120)
    return Run(out, rc, stdout, stderr, client_result)


class ShevDbcEcuTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = pathlib.Path(tempfile.mkdtemp(prefix="shev_dbc_ecu-"))
        t0 = time.monotonic()
        cls.ref = reference_run(cls.tmp)
        cls.bus = bus_run(cls.tmp, "bus")
        cls.bus_wall_s = time.monotonic() - t0

    @classmethod
    def tearDownClass(cls):
        if os.environ.get("SHEV_DBC_ECU_KEEP"):
            print(f"\nruns kept in {cls.tmp}", file=sys.stderr)
        else:
            shutil.rmtree(cls.tmp, ignore_errors=True)

    def check_clean_session(self, run):
        self.assertEqual(run.rc, 0, run.describe())
        self.assertEqual(run.client[0], 0, run.describe())
        self.assertIn(f"{SAMPLES} samples answered", run.client[1], run.describe())
        self.assertIn(" 0 counter gaps", run.client[1], run.describe())  # no frame lost
        s = run.summary
        self.assertIsNotNone(s, run.describe())
        bus = s["bus"]
        self.assertEqual(s["status"], "ok", s.get("degraded"))
        self.assertEqual(bus["pacing"], "lockstep")
        self.assertEqual(bus["commands_applied"], SAMPLES, bus)
        self.assertEqual(bus["frames_in"], SAMPLES, bus)
        self.assertEqual(bus["frames_accepted"], SAMPLES, bus)
        self.assertEqual(bus["timeouts"], 0, bus)
        self.assertEqual(bus["stale_samples"], 0, bus)
        self.assertEqual(bus["safe_state_time_s"], 0, bus)
        self.assertEqual(bus["lockstep_waits_timed_out"], 0, bus)
        self.assertEqual(bus["frames_lost"], 0, bus)
        self.assertEqual(bus["saturated_signals"], 0, bus)
        self.assertEqual(sum(bus["rejected"].values()), 0, bus["rejected"])
        command = bus["messages_received"]["ShevCommand"]
        self.assertEqual(command["accepted"], SAMPLES, command)
        self.assertEqual(sum(v for k, v in command.items() if k != "accepted"), 0, command)

    def test_every_sample_got_a_command(self):
        self.check_clean_session(self.bus)

    def test_matches_the_builtin_ems_through_the_can_codec(self):
        ref, bus = self.ref, self.bus
        self.assertEqual(ref.rc, 0, ref.describe())
        self.assertEqual(ref.summary["status"], "ok")
        self.assertEqual(ref.summary["ecu_codec_saturated_signals"], 0)
        self.assertIsNotNone(bus.ts, bus.describe())
        self.assertEqual(len(ref.ts["time_s"]), SAMPLES)
        self.assertEqual(ref.ts["time_s"], bus.ts["time_s"])

        sw_ref, sw_bus = switches(ref.ts), switches(bus.ts)
        self.assertTrue(sw_ref, "the reference never switches the genset: nothing compared")
        self.assertTrue(switches_agree(sw_bus, sw_ref, PERIOD_S + 1e-9),
                        f"genset switches: bus {sw_bus}, reference {sw_ref}")

        soc_ref, soc_bus = ref.ts["soc"][-1], bus.ts["soc"][-1]
        fuel_ref, fuel_bus = ref.ts["fuel_g"][-1], bus.ts["fuel_g"][-1]
        dv = max(abs(a - b) for a, b in zip(bus.ts["speed_m_s"], ref.ts["speed_m_s"]))
        print(f"\n  switches bus {sw_bus}\n  switches ref {sw_ref}\n"
              f"  final SOC bus {soc_bus!r} ref {soc_ref!r} (diff {soc_bus - soc_ref:.3g})\n"
              f"  fuel bus {fuel_bus!r} g ref {fuel_ref!r} g "
              f"(diff {100 * (fuel_bus - fuel_ref) / fuel_ref:.3g} %)\n"
              f"  max |speed diff| {dv:.3g} m/s\n"
              f"  bus session {self.bus.summary['bus']['samples_per_s']:.0f} samples/s, "
              f"round trip p50 {self.bus.summary['bus']['round_trip_us']['p50']} us",
              file=sys.stderr)
        self.assertLessEqual(abs(soc_bus - soc_ref), 1e-4)
        self.assertLessEqual(abs(fuel_bus - fuel_ref), 0.005 * fuel_ref)
        self.assertLessEqual(dv, 0.01)

    def test_changed_hysteresis_does_not_match(self):
        """The comparison can fail: switching on at 40 kW instead of 60 kW is seen."""
        neg = bus_run(self.tmp, "neg", ["--on-W", "40000"])
        self.check_clean_session(neg)  # a clean session: only the strategy differs
        sw_ref, sw_neg = switches(self.ref.ts), switches(neg.ts)
        print(f"\n  --on-W 40000: switches {sw_neg} (reference {sw_ref}), final SOC "
              f"{neg.ts['soc'][-1]!r}, fuel {neg.ts['fuel_g'][-1]!r} g", file=sys.stderr)
        self.assertFalse(switches_agree(sw_neg, sw_ref, PERIOD_S + 1e-9),
                         f"on at 40 kW switches as on at 60 kW: {sw_neg}")


if __name__ == "__main__":
    if len(sys.argv) < 2 or sys.argv[1].startswith("-"):
        sys.exit(f"usage: {sys.argv[0]} BUILD/ehpt [unittest args]")
    EHPT = str(pathlib.Path(sys.argv.pop(1)).resolve())
    if not os.access(EHPT, os.X_OK):
        sys.exit(f"{EHPT}: not an executable")
    unittest.main(verbosity=2)
