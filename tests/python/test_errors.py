#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""Misuse raises a Python exception that says what is wrong, and never crashes the interpreter:
a scenario that does not load is a ValueError naming each bad key (and its value); a command of
the wrong vehicle family a TypeError; a step count out of range a ValueError."""

import threading
import unittest

import ehpt
from ehpt_test_support import WorkDir

work = None


def setUpModule():
    global work
    work = WorkDir()


def tearDownModule():
    work.close()


class LoadErrors(unittest.TestCase):
    def assert_value_error(self, scenario, overrides, *words):
        for call in (lambda: ehpt.run(scenario, set=overrides), lambda: ehpt.Simulation(scenario, set=overrides)):
            with self.assertRaises(ValueError) as cm:
                call()
            for w in words:
                self.assertIn(w, str(cm.exception))

    def test_unknown_key(self):
        self.assert_value_error("psecu2_nedc", {"vehicle.ecu.soc_reff": 0.6}, "vehicle.ecu.soc_reff", "unknown key")

    def test_bad_value(self):
        self.assert_value_error("psecu2_nedc", {"vehicle.ecu.soc_ref": 1.5}, "vehicle.ecu.soc_ref", "1.5", "[0, 1]")

    def test_value_of_the_wrong_type(self):
        # a str stays a str (the CLI would read --set solver.duration_s=100 as a number)
        self.assert_value_error("ev_nedc", {"solver.duration_s": "100"}, "solver.duration_s", "must be a number")

    def test_every_problem_is_listed(self):
        self.assert_value_error("psecu2_nedc", {"vehicle.ecu.soc_reff": 0.6, "solver.step_s": -1.0},
                                "vehicle.ecu.soc_reff", "solver.step_s", "2 problems")

    def test_unknown_scenario(self):
        self.assert_value_error("no_such_scenario", None, "no_such_scenario", "no such scenario")

    def test_keys_and_values_python_cannot_pass(self):
        with self.assertRaises(ValueError) as cm:
            ehpt.run("ev_nedc", set={"solver.duration_s=5 x": 1})
        self.assertIn("solver.duration_s=5 x", str(cm.exception))
        with self.assertRaises(TypeError) as cm:
            ehpt.run("ev_nedc", set={"solver.duration_s": object()})
        self.assertIn("solver.duration_s", str(cm.exception))
        with self.assertRaises(TypeError):
            ehpt.run("ev_nedc", set={1: 2})
        with self.assertRaises(TypeError):
            ehpt.run("ev_nedc", set=[("solver.duration_s", 1)])

    def test_bus_faults_need_frames(self):
        # a Simulation passes its commands directly: no frames for a bus fault to act on
        with self.assertRaises(ValueError) as cm:
            ehpt.Simulation("psecu2_nedc", faults=["kind=drop target=PsdCommand1 at_s=1"])
        self.assertIn("kind = \"drop\" on PsdCommand1 acts on CAN frames", str(cm.exception))
        self.assertIn("ehpt.run(...) takes bus faults", str(cm.exception))
        # ehpt.run takes them (the in-process bus), and refuses what the contract has not
        with self.assertRaises(ValueError) as cm:
            ehpt.run("psecu2_nedc", faults=["kind=drop target=PsdComand1 at_s=1"])
        self.assertIn('did you mean "PsdCommand1"', str(cm.exception))
        with self.assertRaises(ValueError) as cm:
            ehpt.run("psecu2_nedc", faults=["kind=drop target=PsdCommand1 at_s=0"])
        self.assertIn("a bus fault starts at the ECU's second sample", str(cm.exception))

    def test_external_ecu_needs_an_ecu(self):
        with self.assertRaises(ValueError) as cm:
            ehpt.Simulation("battery_cc_discharge", external_ecu=True)
        self.assertIn("no ECU", str(cm.exception))
        # the series hybrid's EMS can be replaced: read_sensors gives ShevSensors, and only a
        # ShevCommand is taken
        sim = ehpt.Simulation("shev_oo_sort1", set={"solver.duration_s": 1}, external_ecu=True)
        self.assertIsInstance(sim.read_sensors(), ehpt.ShevSensors)
        with self.assertRaises(TypeError) as cm:
            sim.write_command(ehpt.EvCommand(driveTauRef_Nm=1.0))
        self.assertIn("an ehpt.ShevCommand", str(cm.exception))
        with self.assertRaises(ehpt.Error):
            sim.write_command(ehpt.ShevCommand(gensetPowRef_W=float("nan")))
        r = ehpt.run("shev_oo_sort1", set={"solver.duration_s": 1})
        self.assertEqual(r.exit_code, 0)
        self.assertEqual(r.timeseries["genset_speed_rad_s"][0], 300.0)


class SteppingErrors(unittest.TestCase):
    def test_step_counts_out_of_range(self):
        sim = ehpt.Simulation("ev_nedc", set={"solver.duration_s": 10}, chunk_steps=1000)
        for n in (0, -1, 1001, 2**40, 2**70, -2**70):
            with self.assertRaises(ValueError, msg=str(n)) as cm:
                sim.step(n)
            self.assertIn("[1, 1000]", str(cm.exception))
        with self.assertRaises(TypeError):
            sim.step(2.5)
        self.assertEqual(sim.step_index, 0)  # nothing was stepped
        self.assertEqual(sim.step(1000), 1000)
        with self.assertRaises(ValueError):
            ehpt.Simulation("ev_nedc", chunk_steps=0)
        with self.assertRaisesRegex(ValueError, "chunk_steps must be in"):
            ehpt.Simulation("ev_nedc", chunk_steps=10**12)  # not a 10^12-row buffer

    def test_one_call_at_a_time(self):
        # run() releases the GIL: another thread's call meanwhile is refused, not a data race
        sim = ehpt.Simulation("psecu2_nedc")
        worker = threading.Thread(target=sim.run)
        refused = 0
        worker.start()
        while worker.is_alive():
            try:
                sim.step_index
            except RuntimeError as e:
                self.assertIn("in use by another thread", str(e))
                refused += 1
        worker.join()
        self.assertGreater(refused, 0)
        self.assertTrue(sim.finished)
        self.assertEqual(sim.stats()["steps_done"], sim.total_steps)

    def test_wrong_command_type(self):
        psd = ehpt.Simulation("psecu2_nedc", set={"solver.duration_s": 1}, external_ecu=True)
        ev = ehpt.Simulation("ev_nedc", set={"solver.duration_s": 1}, external_ecu=True)
        for sim, wrong, needed in ((psd, ehpt.EvCommand(), "PsdCommand"), (ev, ehpt.PsdCommand(), "EvCommand"),
                                   (psd, ehpt.PsdSensors(), "PsdCommand"), (ev, 1.0, "EvCommand")):
            with self.assertRaises(TypeError) as cm:
                sim.write_command(wrong)
            self.assertIn(needed, str(cm.exception))
        psd.write_command(ehpt.PsdCommand(iceON=False))  # the right one is taken
        ev.write_command(ehpt.EvCommand(driveTauRef_Nm=1.0))

    def test_a_non_finite_command_is_refused_and_not_applied(self):
        """+inf, -inf and NaN are never applied (as over LCM; CAN cannot carry them): ehpt.Error,
        and the command held is the one before."""
        for name, make in (("psecu2_nedc", lambda v: ehpt.PsdCommand(motTauRef_Nm=v)),
                           ("ev_nedc", lambda v: ehpt.EvCommand(driveTauRef_Nm=v))):
            sim = ehpt.Simulation(name, set={"solver.duration_s": 1}, external_ecu=True)
            sim.write_command(make(1.0))
            sim.step(sim.ecu_period_steps)
            before = sim.outputs()
            for bad in (float("inf"), float("-inf"), float("nan")):
                with self.assertRaises(ehpt.Error) as cm:
                    sim.write_command(make(bad))
                self.assertIn("not finite (NaN or inf); not applied", str(cm.exception))
            sim.step(sim.ecu_period_steps)
            after = sim.outputs()
            self.assertTrue(all(v == v for v in after.values()), after)  # no NaN got in
            reference = ehpt.Simulation(name, set={"solver.duration_s": 1}, external_ecu=True)
            reference.write_command(make(1.0))
            reference.step(reference.ecu_period_steps)
            reference.step(reference.ecu_period_steps)
            self.assertEqual(after, reference.outputs())  # as if the bad ones were never sent
            self.assertNotEqual(before, after)

    def test_a_rig_has_no_messages(self):
        sim = ehpt.Simulation("battery_cc_discharge")
        self.assertIsNone(sim.ecu_period_steps)
        with self.assertRaises(TypeError):
            sim.read_sensors()
        with self.assertRaises(TypeError):
            sim.write_command(ehpt.EvCommand())

    def test_message_fields(self):
        with self.assertRaises(TypeError) as cm:
            ehpt.PsdCommand(motTauRef=1.0)  # the field is motTauRef_Nm
        self.assertIn("motTauRef", str(cm.exception))
        c = ehpt.PsdCommand(motTauRef_Nm=2.0, stamp=ehpt.Stamp(step=7))
        c.stamp.sequence = 3  # a field of the stamp, in place
        self.assertEqual((c.motTauRef_Nm, c.iceON, c.stamp.step, c.stamp.sequence), (2.0, False, 7, 3))
        self.assertIn("motTauRef_Nm=2.0", repr(c))
        self.assertEqual(ehpt.EvSensors._fields[:2], ("stamp", "driverRequest_Nm"))
        with self.assertRaises(TypeError) as cm:
            ehpt.PsdCommand(motTauRef_Nm="x")  # a field of the wrong type is named, with its value
        self.assertIn("PsdCommand.motTauRef_Nm: 'x'", str(cm.exception))

    def test_a_nul_in_the_name_runs_nothing(self):
        # a C string would end at the NUL and run ev_nedc.toml
        for name in ("ev_nedc\0junk", "no_such\0zzz"):
            with self.assertRaises(ValueError) as cm:
                ehpt.run(name, set={"solver.duration_s": 1})
            self.assertIn(name.replace("\0", "\\0"), str(cm.exception))
            self.assertIn("NUL", str(cm.exception))

    def test_a_float_subclass_is_its_float(self):
        # numpy.float64's repr is "np.float64(...)" with numpy 2: the value, not the repr, is sent
        class F(float):
            def __repr__(self):
                return "F(%s)" % float.__repr__(self)

        r = ehpt.run("ev_nedc", set={"solver.duration_s": F(2.5)})
        self.assertEqual(r.summary["provenance"]["overrides"], ["solver.duration_s=2.5"])
        self.assertEqual(r.summary["steps"], 2500)


if __name__ == "__main__":
    unittest.main()
