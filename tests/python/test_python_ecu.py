#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""The stepping interface: an ECU written in Python, in process, in lockstep with the plant.

python/examples/mbecu2_ecu.py mirrors ecu/psd_ecu.cpp operation for operation; driven through
ehpt.Simulation(external_ecu=True) (at each sample: read_sensors, write_command, step one
period) it must reproduce the built-in ECU's run (ehpt.run) bit for bit, for MBecu2 and the
other two power-split ECUs, and a Python EV follower the EV's. The comparison is sensitive: an
ECU that differs by one rounding does not pass it (test_a_different_ecu_differs)."""

import os
import sys
import unittest

import ehpt
from ehpt_test_support import WorkDir, assert_same_bits

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "python", "examples"))
import mbecu2_ecu  # noqa: E402
import shev_ems  # noqa: E402

work = None


def setUpModule():
    global work
    work = WorkDir()


def tearDownModule():
    work.close()


def follower_run(scenario, overrides=None):
    """The EV's built-in ECU (ecu/ev_follower.hpp) in Python."""
    sim = ehpt.Simulation(scenario, set=overrides, external_ecu=True)
    sequence = 0
    while not sim.finished:
        s = sim.read_sensors()
        sim.write_command(ehpt.EvCommand(driveTauRef_Nm=s.driverRequest_Nm,
                                         stamp=ehpt.Stamp(time_s=s.stamp.time_s, step=s.stamp.step, sequence=sequence)))
        sequence += 1
        sim.step(sim.ecu_period_steps)
    return sim


class PythonEcuReproducesBuiltIn(unittest.TestCase):
    def check(self, scenario, overrides=None):
        sim = mbecu2_ecu.run_with_python_ecu(scenario, overrides)
        builtin = ehpt.run(scenario, set=overrides)
        self.assertEqual(builtin.exit_code, 0)
        self.assertTrue(sim.finished)
        self.assertEqual(sim.step_index, sim.total_steps)
        assert_same_bits(self, sim.timeseries(), builtin.timeseries, scenario + " with the Python ECU")
        st = sim.stats()
        for k in ("distance_m", "soc_end", "fuel_g"):
            self.assertEqual(repr(st[k]), repr(builtin.summary[k]), k)
        return sim

    def test_mbecu2_psecu2_nedc(self):
        sim = self.check("psecu2_nedc")
        self.assertEqual(sim.ecu_parameters["kind"], "MBecu2")
        self.assertEqual(sim.ecu_period_steps, 10)

    def test_mbecu2_with_overrides(self):
        # the parameters reach the Python ECU through Simulation.ecu_parameters, overrides included
        sim = self.check("psecu2_nedc", {"vehicle.ecu.soc_ref": 0.62, "vehicle.ecu.period_s": 0.005})
        self.assertEqual(sim.ecu_parameters["soc_ref"], 0.62)
        self.assertEqual(sim.ecu_period_steps, 5)

    def test_mbecu1_and_mbecu1soc(self):
        self.check("psecu1_nedc", {"solver.duration_s": 400})
        self.check("psecu1soc_nedc", {"solver.duration_s": 400})

    def test_ev_follower(self):
        sim = follower_run("ev_nedc")
        assert_same_bits(self, sim.timeseries(), ehpt.run("ev_nedc").timeseries, "ev_nedc with the Python follower")

    def test_series_hybrid_ems(self):
        # ShevEMS through a genset start and stop (267.31 s, 373.25 s), and PowerFilt
        for scenario, kind in (("shev_oo_sort1", "ShevEMS"), ("shev_power_filt_sort1", "PowerFilt")):
            overrides = {"solver.duration_s": 400}
            sim = shev_ems.run_with_python_ems(scenario, overrides)
            self.assertEqual(sim.ecu_parameters["kind"], kind)
            builtin = ehpt.run(scenario, set=overrides)
            assert_same_bits(self, sim.timeseries(), builtin.timeseries, scenario + " with the Python EMS")
            self.assertEqual(repr(sim.stats()["fuel_g"]), repr(builtin.summary["fuel_g"]))
        self.assertGreater(builtin.summary["fuel_g"], 0.0)

        # the same EMS with a 1 W hysteresis instead of 30 kW: the comparison must see it
        class NoHysteresis(shev_ems.ShevEms):
            def __init__(self, params):
                super().__init__(params)
                self.off_W = self.on_W - 1.0

        overrides = {"solver.duration_s": 400}
        builtin = ehpt.run("shev_oo_sort1", set=overrides).timeseries
        sim = shev_ems.run_with_python_ems("shev_oo_sort1", overrides, NoHysteresis)
        with self.assertRaises(AssertionError):
            assert_same_bits(self, sim.timeseries(), builtin, "")

    def test_a_different_ecu_differs(self):
        # the same ECU with soc_ref two ulps off: the comparison must see it
        class Off(mbecu2_ecu.PsdEcu):
            def __init__(self, params):
                super().__init__(params)
                self.soc_ref = self.soc_ref + 2**-53 * 2

        sim = ehpt.Simulation("psecu2_nedc", set={"solver.duration_s": 300}, external_ecu=True)
        ecu = Off(sim.ecu_parameters)
        while not sim.finished:
            sim.write_command(ecu.update(sim.read_sensors()))
            sim.step(sim.ecu_period_steps)
        with self.assertRaises(AssertionError):
            assert_same_bits(self, sim.timeseries(), ehpt.run("psecu2_nedc", set={"solver.duration_s": 300}).timeseries, "")


class Stepping(unittest.TestCase):
    def test_steps_of_any_size_equal_the_run(self):
        # the built-in ECU, stepped in uneven pieces: the rows collected between calls are the run's
        sim = ehpt.Simulation("psecu2_nedc", set={"solver.duration_s": 200})
        sizes = [1, 7, 999, 50000, 12345]
        i = 0
        while not sim.finished:
            sim.step(sizes[i % len(sizes)])
            i += 1
        assert_same_bits(self, sim.timeseries(), ehpt.run("psecu2_nedc", set={"solver.duration_s": 200}).timeseries,
                         "stepped")
        self.assertEqual(sim.step(5), 0)  # finished: nothing more

    def test_run_to_the_end(self):
        sim = ehpt.Simulation("ev_nedc", set={"solver.duration_s": 100})
        sim.step(1234)
        self.assertEqual(sim.run(), 100000 - 1234)
        assert_same_bits(self, sim.timeseries(), ehpt.run("ev_nedc", set={"solver.duration_s": 100}).timeseries, "run")

    def test_external_ecu_stops_at_samples(self):
        sim = ehpt.Simulation("psecu2_nedc", set={"solver.duration_s": 10}, external_ecu=True)
        self.assertEqual((sim.step_index, sim.total_steps, sim.time_s), (0, 10000, 0.0))
        s = sim.read_sensors()
        self.assertIsInstance(s, ehpt.PsdSensors)
        self.assertEqual((s.stamp.step, s.stamp.time_s), (0, 0.0))
        self.assertEqual(sim.step(25), 10)  # to the next sample (period 10 steps)
        self.assertEqual(sim.time_s, 10 * sim.step_s)
        s = sim.read_sensors()
        self.assertEqual(s.stamp.step, 10)
        # outputs() there are still step 9's: the outputs at 10 are taken with the command
        self.assertEqual(sim.outputs()["time_s"], 9 * sim.step_s)
        sim.write_command(ehpt.PsdCommand())
        self.assertEqual(sim.step(3), 3)
        self.assertEqual(sim.outputs()["time_s"], 13 * sim.step_s)

    def test_outputs_and_signals(self):
        sim = ehpt.Simulation("ev_nedc", set={"solver.duration_s": 10})
        sim.step(5000)
        y = sim.outputs()
        self.assertEqual(list(y), sim.signals)
        self.assertAlmostEqual(y["time_s"], 5.0, places=12)
        self.assertEqual(sim.columns, sim.signals)  # no output.signals: every signal is recorded


if __name__ == "__main__":
    unittest.main()
