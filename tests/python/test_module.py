#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""ehpt.run equals `ehpt run`, bit for bit: the timeseries (every column, every row, read back
from timeseries.csv with float()) and every key of summary.json except the timing ones
(ehpt_test_support.TIMING_KEYS). Overrides given as Python values must reach the scenario as
the CLI's --set text does (provenance.overrides and run_id are compared too)."""

import unittest

import numpy as np

import ehpt
from ehpt_test_support import TIMING_KEYS, WorkDir, assert_same_bits, flat, run_cli

work = None


def setUpModule():
    global work
    work = WorkDir()


def tearDownModule():
    work.close()


class RunEqualsCli(unittest.TestCase):
    def compare(self, scenario, overrides, exit_code=0):
        rc, columns, series, summary = run_cli(scenario, overrides, work.path)
        r = ehpt.run(scenario, set=overrides)
        self.assertEqual(rc, exit_code, "the CLI's exit code")
        self.assertEqual(r.exit_code, rc, "the module's exit code")
        self.assertEqual(list(r.columns), columns)
        self.assertGreater(len(series["time_s"]), 100)
        assert_same_bits(self, r.timeseries, series, scenario)

        got, want = flat(r.summary), flat(summary)
        self.assertEqual(sorted(got), sorted(want), "summary keys")
        for k in TIMING_KEYS:  # left out below: they must at least be there
            self.assertIn(k, want)
        for k in want:
            if k in TIMING_KEYS:
                continue
            # repr: bit for bit, and None == None for a NaN written as null
            hint = " (the CLI and the module are from different builds: build both)" if k.startswith("provenance.") else ""
            self.assertEqual(repr(got[k]), repr(want[k]), f"summary {k}{hint}")
        return r

    def test_psecu2_nedc_with_soc_ref(self):
        r = self.compare("psecu2_nedc", {"vehicle.ecu.soc_ref": 0.62})
        self.assertEqual(r.summary["provenance"]["overrides"], ["vehicle.ecu.soc_ref=0.62"])
        self.assertEqual(r.warnings, [])

    def test_ev_nedc(self):
        # a float whose shortest text is long, and an int
        self.compare("ev_nedc", {"vehicle.battery.soc_initial": 0.1 + 0.7, "solver.duration_s": 600})

    def test_fault_returns_exit_code_3(self):
        # SOC leaves its window at once: the run stops, the outputs are kept, nothing is raised
        r = self.compare("ev_nedc", {"vehicle.battery.soc_min": 0.6999}, exit_code=3)
        self.assertEqual(r.summary["status"], "fault")

    def test_result_types(self):
        r = ehpt.run("psecu2_nedc", set={"solver.duration_s": 20.0, "output.signals": ["time_s", "soc", "speed_m_s"]})
        self.assertEqual(list(r.columns), ["time_s", "soc", "speed_m_s"])
        self.assertEqual(list(r.timeseries), ["time_s", "soc", "speed_m_s"])
        for a in r.timeseries.values():
            self.assertIsInstance(a, np.ndarray)
            self.assertEqual((a.dtype, a.ndim, a.shape[0]), (np.float64, 1, 201))
        self.assertIsInstance(r.summary, dict)
        self.assertEqual(r.summary["steps"], 20000)
        self.assertIn("scenario      psecu2_nedc", r.text)


if __name__ == "__main__":
    unittest.main()
