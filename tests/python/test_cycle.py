#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""cycle=(t_s, v_m_s): a drive cycle given as two numpy arrays runs exactly as the same numbers
in a cycle file do (every column bit for bit, the trajectory hash), and is checked by the same
rules with the same messages: a bad value is named "<cycle arrays>:INDEX" where the file's is
"file:LINE" (LINE = INDEX + 2, after the header), and the rest of the message is the file's,
word for word. What makes the arrays numbers (a pair, 1-D, int or float) is checked first."""

import os
import subprocess
import unittest

import numpy as np

import ehpt
from ehpt_test_support import WorkDir, assert_same_bits, cli_path

work = None


def setUpModule():
    global work
    work = WorkDir()


def tearDownModule():
    work.close()


def number(x):
    """The shortest text that reads back as x, as ehpt writes numbers in messages ("1", "0.1")."""
    r = repr(float(x))
    return r[:-2] if r.endswith(".0") else r


def write_cycle(name, t, v):
    """The numbers as a cycle file (each reads back as the same double)."""
    path = os.path.join(work.path, name + ".csv")
    with open(path, "w") as f:
        f.write("time_s,speed_m_s\n")
        for a, b in zip(t, v):
            f.write(f"{number(a)},{number(b)}\n")
    return path


def file_problems(t, v, name="c"):
    """The CLI's messages for a cycle file of these numbers."""
    path = write_cycle(name, t, v)
    proc = subprocess.run([cli_path(), "run", "ev_nedc", "--set", f'cycle="{path}"', "--out", os.path.join(work.path, "o"),
                           "--quiet"], capture_output=True, text=True, timeout=120, cwd=work.path)
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    return path, [l for l in proc.stderr.splitlines() if l.startswith(path)]


# A short cycle of the kind a test bench makes: accelerate, cruise, brake, stand
T = np.array([0.0, 2.0, 2.0, 7.5, 12.25, 15.0, 20.0])
V = np.array([0.0, 0.0, 1.0, 8.0, 8.0, 0.5, 0.0])


class ArraysRunAsAFile(unittest.TestCase):
    def test_same_run_as_the_file(self):
        path = write_cycle("bench", T, V)
        from_file = ehpt.run("ev_nedc", set={"cycle": path})
        from_arrays = ehpt.run("ev_nedc", cycle=(T, V))
        self.assertEqual(from_arrays.exit_code, 0)
        self.assertEqual(from_arrays.summary["steps"], 20000)  # duration: the last time stamp
        assert_same_bits(self, from_arrays.timeseries, from_file.timeseries, "cycle arrays vs file")
        self.assertEqual(from_arrays.summary["trajectory_hash"], from_file.summary["trajectory_hash"])
        self.assertEqual(from_arrays.summary["distance_m"], from_file.summary["distance_m"])
        self.assertGreater(from_arrays.summary["distance_m"], 50.0)
        # the speed reference follows the arrays (every 0.1 s row; the ramp 2 -> 7.5 s: 1 + 7 (t-2)/5.5)
        ts = from_arrays.timeseries
        i = int(np.flatnonzero(ts["time_s"] == 5.0)[0])
        self.assertAlmostEqual(ts["speed_ref_m_s"][i], 1.0 + 7.0 * 3.0 / 5.5, places=12)
        # the provenance says where the cycle came from, and the numbers' hash
        self.assertEqual(from_arrays.summary["cycle_file"], "<cycle arrays>")
        inputs = {i["path"]: i for i in from_arrays.summary["provenance"]["inputs"]}
        self.assertEqual(inputs["<cycle arrays>"]["bytes"], 2 * 8 * len(T))
        other = ehpt.run("ev_nedc", cycle=(T, V * 0.5))
        others = {i["path"]: i for i in other.summary["provenance"]["inputs"]}
        self.assertNotEqual(others["<cycle arrays>"]["sha256"], inputs["<cycle arrays>"]["sha256"])
        self.assertNotEqual(other.summary["provenance"]["run_id"], from_arrays.summary["provenance"]["run_id"])

    def test_lists_ints_and_a_simulation(self):
        # plain lists of ints are numbers too; Simulation takes the same argument
        sim = ehpt.Simulation("ev_nedc", cycle=([0, 10, 20], [0, 5, 0]))
        self.assertEqual(sim.total_steps, 20000)
        sim.run()
        r = ehpt.run("ev_nedc", cycle=(np.array([0.0, 10.0, 20.0]), np.array([0.0, 5.0, 0.0])))
        assert_same_bits(self, sim.timeseries(), r.timeseries, "Simulation vs run")

    def test_periodic_and_duration(self):
        # cycle_periodic and solver.duration_s apply as to a file: twice round the bench cycle
        r = ehpt.run("ev_nedc", set={"cycle_periodic": True, "solver.duration_s": 40.0}, cycle=(T, V))
        ts = r.timeseries
        first, second = ts["speed_ref_m_s"][(ts["time_s"] < 20.0)], ts["speed_ref_m_s"][(ts["time_s"] >= 20.0) & (ts["time_s"] < 40.0)]
        self.assertEqual(len(first), 200)
        np.testing.assert_allclose(second, first, rtol=0, atol=1e-12)  # t mod 20 s: rounding only
        self.assertEqual(r.summary["steps"], 40000)

    def test_the_arrays_replace_the_scenario_cycle(self):
        r = ehpt.run("ev_nedc", cycle=(T, V))
        self.assertLess(r.summary["steps"], 1184000 / 10)  # not NEDC's 1184 s
        self.assertNotIn("cycle_nedc.csv", " ".join(i["path"] for i in r.summary["provenance"]["inputs"]))


class SameRulesAsAFile(unittest.TestCase):
    def check(self, t, v, *words):
        """The arrays' problems are the file's: same keys, values and messages."""
        path, want = file_problems(t, v)
        with self.assertRaises(ehpt.Error) as cm:
            ehpt.run("ev_nedc", cycle=(np.asarray(t, dtype=float), np.asarray(v, dtype=float)))
        e = cm.exception
        got = [p for p in e.problems if p.file == "<cycle arrays>"]
        self.assertEqual(len(got), len(want), (str(e), want))
        self.assertGreater(len(got), 0)
        for p, w in zip(got, want):
            where, _, rest = w[len(path):].partition(": ")
            self.assertEqual(p.text.split(": ", 1)[1], rest, "the message after the location")
            if where.startswith(":"):
                self.assertEqual(p.line + 2, int(where[1:]), "the index is the file's line - 2")
            else:
                self.assertIsNone(p.line)
        for word in words:
            self.assertIn(word, str(e))
        return e

    def test_time_must_not_decrease(self):
        e = self.check([0.0, 2.0, 1.0, 5.0], [0.0, 1.0, 2.0, 0.0], "axis must be non-decreasing (previous value 2)")
        self.assertEqual((e.file, e.line, e.key, e.column, e.value), ("<cycle arrays>", 2, "driver.cycle", "time_s", "1"))

    def test_repeated_times_are_a_step(self):
        ehpt.run("ev_nedc", cycle=([0.0, 1.0, 1.0, 2.0], [0.0, 0.0, 1.0, 1.0]))  # legal, as in a file

    def test_finite(self):
        e = self.check([0.0, 1.0, 2.0], [0.0, np.nan, 0.0], "must be a finite number")
        self.assertEqual((e.line, e.column, e.value), (1, "speed_m_s", "nan"))
        self.check([0.0, np.inf, 2.0], [0.0, 1.0, 0.0], "must be a finite number")

    def test_at_least_two_points(self):
        e = self.check([0.0], [0.0], "needs at least 2 rows")
        self.assertEqual((e.key, e.value), ("driver.cycle", "1 rows"))

    def test_speed_range(self):
        e = self.check([0.0, 1.0], [0.0, -1.0], "speed must be >= 0")
        self.assertEqual((e.line, e.column, e.value), (1, "speed_m_s", "-1"))
        self.check([0.0, 1.0], [0.0, 250.0], "below 200 m/s")

    def test_a_span(self):
        self.check([1.0, 1.0], [0.0, 0.0], "axis must span a non-zero range")

    def test_same_length(self):
        with self.assertRaises(ehpt.Error) as cm:
            ehpt.run("ev_nedc", cycle=(np.array([0.0, 1.0, 2.0]), np.array([0.0, 1.0])))
        e = cm.exception
        self.assertEqual((e.file, e.key, e.value), ("<cycle arrays>", "driver.cycle", "3 time stamps, 2 speeds"))
        self.assertEqual(e.message, "the two arrays must have the same length")
        self.assertEqual(len(e.problems), 1)  # no follow-on problem

    def test_not_numbers(self):
        cases = [
            ((np.zeros((2, 2)), np.zeros(2)), "t_s must be a 1-D array, not one of shape (2, 2)"),
            ((np.zeros(2), np.zeros((1, 2))), "v_m_s must be a 1-D array"),
            ((["0", "1"], [0.0, 1.0]), "t_s must hold numbers (int or float), not dtype <U1"),
            (([0.0, 1.0], [True, False]), "v_m_s must hold numbers (int or float), not dtype bool"),
            (([0.0, [1.0, 2.0]], [0.0, 1.0]), "t_s is not an array of numbers"),
            (([0.0, 1.0], [0.0, 1j]), "not dtype complex128"),
        ]
        for cycle, words in cases:
            with self.assertRaises(ehpt.Error, msg=words) as cm:
                ehpt.run("ev_nedc", cycle=cycle)
            self.assertIn(words, str(cm.exception))
            self.assertEqual(cm.exception.key, "cycle")
        for bad in ((np.zeros(2),), np.zeros((2, 2)), "x.csv", 5):
            with self.assertRaises(TypeError) as cm:
                ehpt.Simulation("ev_nedc", cycle=bad)
            self.assertIn("cycle must be a pair (t_s, v_m_s)", str(cm.exception))

    def test_a_rig_has_no_cycle(self):
        with self.assertRaises(ehpt.Error) as cm:
            ehpt.run("battery_cc_discharge", cycle=(T, V))
        self.assertIn("has no driver: remove the cycle", str(cm.exception))
        self.assertEqual(cm.exception.key, "cycle")


if __name__ == "__main__":
    unittest.main()
