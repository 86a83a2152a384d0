#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""What makes the module feel native: ehpt.Error with the parts of each problem (file, line, key,
value, message), arguments of the wrong type named with the type wanted, Result.to_dataframe(),
and command messages that start in the machine's safe state (every reference 0, engine off)."""

import os
import pathlib
import sys
import unittest

import numpy as np

import ehpt
from ehpt_test_support import WorkDir

work = None


def setUpModule():
    global work
    work = WorkDir()


def tearDownModule():
    work.close()


class StructuredErrors(unittest.TestCase):
    def error(self, scenario, overrides=None, **kw):
        with self.assertRaises(ehpt.Error) as cm:
            ehpt.run(scenario, set=overrides, **kw)
        return cm.exception

    def test_a_value_in_a_file(self):
        # a scenario file of our own with a bad value on line 4
        with open("own.toml", "w") as f:
            f.write('vehicle_file = "{}"\ncycle = "{}"\n[solver]\nstep_s = 2.5\n'.format(
                os.path.join(os.path.dirname(ehpt_scenario_path()), "..", "vehicles", "mbev.toml"),
                os.path.join(os.path.dirname(ehpt_scenario_path()), "..", "data", "cycles", "cycle_nedc.csv")))
        e = self.error("own.toml")
        self.assertIsInstance(e, ValueError)
        self.assertEqual((e.file, e.line, e.key, e.value, e.message), ("own.toml", 4, "solver.step_s", "2.5", "must be in (0, 1] s"))
        self.assertEqual(e.where, "own.toml:4")
        self.assertEqual(len(e.problems), 1)
        self.assertEqual(str(e), "own.toml: 1 problem; nothing was run:\nown.toml:4: solver.step_s = 2.5: must be in (0, 1] s")

    def test_every_problem_of_the_overrides(self):
        e = self.error("psecu2_nedc", {"vehicle.ecu.soc_ref": 1.5, "vehicle.ecu.soc_reff": 0.6, "solver.duration_s": "100"})
        parts = sorted((p.where, p.file, p.line, p.key, p.value, p.message) for p in e.problems)
        self.assertEqual(parts, [
            ('--set solver.duration_s="100"', None, None, "solver.duration_s", "'100'", "must be a number"),
            ("--set vehicle.ecu.soc_ref=1.5", None, None, "vehicle.ecu.soc_ref", "1.5", "must be in [0, 1]"),
            ("--set vehicle.ecu.soc_reff=0.6", None, None, "vehicle.ecu.soc_reff", None,
             "unknown key; did you mean `vehicle.ecu.soc_ref`?"),
        ])
        self.assertIn("3 problems", str(e))
        self.assertEqual((e.key, e.where), (e.problems[0].key, e.problems[0].where))  # the first one's
        self.assertEqual([p.text for p in e.problems], str(e).splitlines()[1:])

    def test_a_value_with_colons_and_equals(self):
        # the value is found by its quotes, not by the first ": " after it
        e = self.error("ev_nedc", {"vehicle.battery.soc_initial": "a: b = c", "output.signals": ["time_s", "x: y"]})
        got = {p.key: (p.value, p.message) for p in e.problems}
        self.assertEqual(got["vehicle.battery.soc_initial"], ("'a: b = c'", "must be a number"))
        self.assertEqual(got["output.signals"][0], '"x: y"')
        self.assertTrue(got["output.signals"][1].startswith("unknown signal; available: time_s, "))

    def test_a_default_that_does_not_fit(self):
        # a one-point cycle: no length, so solver.duration_s's default (0) is the second problem
        e = self.error("ev_nedc", cycle=([0.0], [0.0]))
        p = e.problems[1]
        self.assertEqual(p.file, ehpt_scenario_path())  # "FILE (default)": the key was not given
        self.assertEqual(p.where, ehpt_scenario_path() + " (default)")
        self.assertIsNone(p.line)
        self.assertEqual((p.key, p.value), ("solver.duration_s", "0"))
        self.assertTrue(p.message.startswith("must be a finite number > 0 s"))

    def test_a_csv_cell(self):
        with open("c.csv", "w") as f:
            f.write("time_s,speed_kmh\n0,0\n1,3.6\n# a comment\n2,x\n")
        e = self.error("ev_nedc", {"cycle": os.path.abspath("c.csv")})
        self.assertEqual((e.file, e.line, e.key), (os.path.abspath("c.csv"), 5, None))
        self.assertIn('"x" is not a number', e.message)

    def test_no_such_scenario(self):
        e = self.error("no_such_scenario")
        self.assertEqual((e.key, e.value, e.file, e.line), ("scenario", "no_such_scenario", None, None))
        self.assertTrue(e.message.startswith("no such scenario"), e.message)

    def test_argument_problems(self):
        e = self.error("ev_nedc", {"solver.duration_s=5": 1})
        self.assertEqual((e.where, e.key, e.file), ("set", "'solver.duration_s=5'", None))
        with self.assertRaises(ehpt.Error) as cm:
            ehpt.Simulation("battery_cc_discharge", external_ecu=True)
        self.assertEqual((cm.exception.key, cm.exception.value), ("external_ecu", "True"))
        self.assertIn("no ECU", cm.exception.message)

    def test_problem_reads_as_its_text(self):
        e = self.error("psecu2_nedc", {"vehicle.ecu.soc_ref": 1.5})
        p = e.problems[0]
        self.assertIsInstance(p, ehpt.Problem)
        self.assertEqual(str(p), "--set vehicle.ecu.soc_ref=1.5: vehicle.ecu.soc_ref = 1.5: must be in [0, 1]")
        self.assertEqual(repr(p), "ehpt.Problem(" + repr(str(p)) + ")")


def ehpt_scenario_path():
    """Where ev_nedc.toml is (the module finds it as the CLI does)."""
    r = ehpt.run("ev_nedc", set={"solver.duration_s": 0.01})
    return r.summary["provenance"]["inputs"][0]["path"]


class ArgumentTypes(unittest.TestCase):
    def assert_type_error(self, call, *words):
        with self.assertRaises(TypeError) as cm:
            call()
        text = str(cm.exception)
        self.assertNotIn("incompatible function arguments", text)  # pybind11's raw message
        for w in words:
            self.assertIn(w, text)

    def test_run(self):
        self.assert_type_error(lambda: ehpt.run(3), "run(): scenario must be a str", "got int 3")
        self.assert_type_error(lambda: ehpt.run(b"ev_nedc"), "scenario must be a str", "got bytes")
        self.assert_type_error(lambda: ehpt.run("ev_nedc", set=[("a", 1)]), "set must be a dict", "got list")

    def test_simulation(self):
        self.assert_type_error(lambda: ehpt.Simulation("ev_nedc", external_ecu="yes"), "external_ecu must be a bool", "got str 'yes'")
        self.assert_type_error(lambda: ehpt.Simulation("ev_nedc", chunk_steps=10.0), "chunk_steps must be an int", "got float 10.0")
        self.assert_type_error(lambda: ehpt.Simulation("ev_nedc", chunk_steps=True), "chunk_steps must be an int")
        sim = ehpt.Simulation("ev_nedc", set={"solver.duration_s": 1}, external_ecu=True)
        self.assert_type_error(lambda: sim.step(2.5), "step(n): n must be an int", "got float 2.5")
        self.assert_type_error(lambda: sim.step("10"), "step(n): n must be an int")
        self.assert_type_error(lambda: sim.write_command(ehpt.PsdCommand()), "command must be an ehpt.EvCommand", "got PsdCommand")
        self.assertEqual(sim.step(np.int64(10)), 10)  # numpy ints are ints

    def test_a_path_is_a_scenario(self):
        path = pathlib.Path(ehpt_scenario_path())
        r = ehpt.run(path, set={"solver.duration_s": 1})
        self.assertEqual(r.summary["steps"], 1000)
        self.assertEqual(ehpt.Simulation(path, set={"solver.duration_s": 1}).name, "ev_nedc")

    def test_message_fields(self):
        c = ehpt.PsdCommand()
        for field, value, wanted in (("iceON", 1, "is not a bool"), ("iceON", "yes", "is not a bool"),
                                     ("motTauRef_Nm", "x", "is not a float"), ("motTauRef_Nm", True, "is not a float"),
                                     ("stamp", 3, "is not an ehpt.Stamp")):
            with self.assertRaises(TypeError, msg=field) as cm:
                setattr(c, field, value)
            self.assertEqual(str(cm.exception), f"PsdCommand.{field}: {value!r} is not {wanted[7:]}")
        s = ehpt.Stamp()
        for value in (-1, 2**32, 1.5):
            with self.assertRaises(TypeError):
                s.sequence = value
        s.sequence = 2**32 - 1
        c.motTauRef_Nm = 3  # an int is a float
        c.iceON = np.bool_(True)
        self.assertEqual((c.motTauRef_Nm, c.iceON, s.sequence), (3.0, True, 2**32 - 1))
        self.assertEqual(c, ehpt.PsdCommand(motTauRef_Nm=3.0, iceON=True))
        self.assertNotEqual(c, ehpt.PsdCommand(motTauRef_Nm=3.0))


class DataFrames(unittest.TestCase):
    def test_run_to_dataframe(self):
        import pandas as pd
        r = ehpt.run("psecu2_nedc", set={"solver.duration_s": 20.0, "output.signals": ["time_s", "soc", "speed_m_s"]})
        df = r.to_dataframe()
        self.assertIsInstance(df, pd.DataFrame)
        self.assertEqual(list(df.columns), ["soc", "speed_m_s"])  # time_s is the index
        self.assertEqual(df.index.name, "time_s")
        self.assertEqual(df.shape, (201, 2))
        np.testing.assert_array_equal(df.index.to_numpy(), r.timeseries["time_s"])
        for c in df.columns:
            self.assertEqual(df[c].dtype, np.float64)
            self.assertEqual(df[c].to_numpy().tobytes(), r.timeseries[c].tobytes())
        self.assertEqual(df.loc[10.0, "speed_m_s"], r.timeseries["speed_m_s"][100])

    def test_without_time_and_without_rows(self):
        r = ehpt.run("ev_nedc", set={"solver.duration_s": 1.0, "output.signals": ["soc"]})
        df = r.to_dataframe()
        self.assertEqual((list(df.columns), df.index.name, len(df)), (["soc"], None, len(r.timeseries["soc"])))
        r = ehpt.run("ev_nedc", set={"solver.duration_s": 1.0, "output.timeseries": False})
        df = r.to_dataframe()
        self.assertEqual(len(df), 0)
        self.assertEqual(list(df.columns), [c for c in r.columns if c != "time_s"])

    def test_simulation_to_dataframe(self):
        sim = ehpt.Simulation("ev_nedc", set={"solver.duration_s": 2.0})
        sim.step(1000)
        df = sim.to_dataframe()
        self.assertEqual(len(df), len(sim.timeseries()["time_s"]))
        self.assertEqual(df.index[-1], sim.timeseries()["time_s"][-1])

    def test_without_pandas(self):
        r = ehpt.run("ev_nedc", set={"solver.duration_s": 1.0})
        saved = sys.modules.get("pandas")
        sys.modules["pandas"] = None  # import pandas raises ImportError, as without python3-pandas
        try:
            with self.assertRaises(ImportError) as cm:
                r.to_dataframe()
        finally:
            if saved is None:
                del sys.modules["pandas"]
            else:
                sys.modules["pandas"] = saved
        self.assertIn("RunResult.to_dataframe() needs pandas", str(cm.exception))
        self.assertIn("apt-get install python3-pandas", str(cm.exception))


class SafeDefaults(unittest.TestCase):
    def test_psd_command(self):
        c = ehpt.PsdCommand()
        self.assertIs(c.iceON, False)
        self.assertEqual((c.icePowRef_W, c.iceTauRef_Nm, c.genTauRef_Nm, c.motTauRef_Nm), (0.0, 0.0, 0.0, 0.0))
        self.assertEqual((c.stamp.time_s, c.stamp.step, c.stamp.sequence), (0.0, 0, 0))
        self.assertEqual(ehpt.PsdCommand._fields, ("stamp", "icePowRef_W", "iceTauRef_Nm", "genTauRef_Nm", "motTauRef_Nm", "iceON"))
        # a field given leaves the others safe
        c = ehpt.PsdCommand(motTauRef_Nm=5.0)
        self.assertEqual((c.motTauRef_Nm, c.iceON, c.genTauRef_Nm), (5.0, False, 0.0))

    def test_ev_command(self):
        c = ehpt.EvCommand()
        self.assertEqual((c.driveTauRef_Nm, c.stamp.time_s, c.stamp.step, c.stamp.sequence), (0.0, 0.0, 0, 0))
        self.assertEqual(ehpt.EvCommand._fields, ("stamp", "driveTauRef_Nm"))

    def test_sensors_start_at_zero(self):
        for cls in (ehpt.PsdSensors, ehpt.EvSensors):
            s = cls()
            for f in cls._fields[1:]:
                self.assertEqual(getattr(s, f), 0, f"{cls.__name__}.{f}")

    def test_the_safe_command_keeps_the_engine_off(self):
        # a hybrid driven by PsdCommand() only: the plant sees the engine off at every step
        sim = ehpt.Simulation("psecu2_nedc", set={"solver.duration_s": 30}, external_ecu=True)
        while not sim.finished:
            sim.write_command(ehpt.PsdCommand())
            sim.step(sim.ecu_period_steps)
        ts = sim.timeseries()
        self.assertEqual(len(ts["iceON"]), 301)
        self.assertEqual(float(np.max(ts["iceON"])), 0.0)
        for reference in ("motTauRef_Nm", "genTauRef_Nm", "icePowRef_W"):
            self.assertEqual(float(np.max(np.abs(ts[reference]))), 0.0, reference)
        self.assertEqual(sim.stats()["fuel_g"], 0.0)


if __name__ == "__main__":
    unittest.main()
