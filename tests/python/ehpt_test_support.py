# SPDX-License-Identifier: BSD-3-Clause
"""Helpers of the Python module's tests (tests/python/test_*.py): the CLI run to compare with,
its CSV read back as doubles, and bit-for-bit comparisons that say where they differ.

The module comes from PYTHONPATH (ctest: the build folder), the CLI from $EHPT_BINARY (ctest:
$<TARGET_FILE:ehpt>). Each test file works in a temporary folder, so no test depends on the
folder it is started from (a ./scenarios there would be looked up first)."""

import csv
import json
import os
import shutil
import subprocess
import tempfile

import numpy as np

# summary.json keys that differ between any two runs, or between processes, and are left out of
# the comparison (and only these: the tests check that each is present on both sides):
#   wall_time_s, run_wall_time_s, realtime_factor, ns_per_step   the wall clock
#   peak_rss_MB                     the process's memory (Python and numpy are in the module's)
#   heap_allocations_after_startup  counted by the CLI's malloc hooks only (None in the module,
#                                   which must not replace malloc: hil/diag/alloc_guard.hpp)
TIMING_KEYS = ("wall_time_s", "run_wall_time_s", "realtime_factor", "ns_per_step", "peak_rss_MB",
               "heap_allocations_after_startup")


def cli_path():
    path = os.environ.get("EHPT_BINARY")
    if not path or not os.access(path, os.X_OK):
        raise RuntimeError("set EHPT_BINARY to the ehpt CLI (ctest does: $<TARGET_FILE:ehpt>)")
    return path


def toml_text(value):
    """What one writes after --set key= for a Python value (written here independently of the
    module's own conversion, which the comparison of the two runs then checks)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value)
    raise TypeError(value)


def read_timeseries(path):
    """timeseries.csv -> (columns, {name: float64 array}); float() reads each number back exactly."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    columns = rows[0]
    data = np.array([[float(v) for v in r] for r in rows[1:]], dtype=np.float64).reshape(-1, len(columns))
    return columns, {c: data[:, i].copy() for i, c in enumerate(columns)}


def run_cli(scenario, overrides, workdir):
    """`ehpt run SCENARIO --set k=v ... --out DIR --quiet` -> (exit code, columns, timeseries, summary)."""
    out = os.path.join(workdir, "cli_" + os.path.basename(scenario))
    shutil.rmtree(out, ignore_errors=True)
    args = [cli_path(), "run", scenario, "--out", out, "--quiet"]
    for k, v in (overrides or {}).items():
        args += ["--set", f"{k}={toml_text(v)}"]
    proc = subprocess.run(args, cwd=workdir, capture_output=True, text=True, timeout=600)
    if proc.returncode not in (0, 3):
        raise RuntimeError(f"{args} exited {proc.returncode}: {proc.stderr}")
    columns, series = read_timeseries(os.path.join(out, "timeseries.csv"))
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    return proc.returncode, columns, series, summary


def flat(d, prefix=""):
    """{"a": {"b": 1}} -> {"a.b": 1}"""
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(flat(v, prefix + k + "."))
        else:
            out[prefix + k] = v
    return out


def assert_same_bits(test, got, want, what):
    """Two {name: array} in the same column order, equal bit for bit (NaN, -0.0 included)."""
    test.assertEqual(list(got), list(want), f"{what}: columns")
    for name in want:
        a, b = np.asarray(got[name], dtype=np.float64), want[name]
        test.assertEqual(a.shape, b.shape, f"{what}: {name}: rows")
        if a.tobytes() != b.tobytes():
            diff = np.flatnonzero(a.view(np.int64) != b.view(np.int64))
            i = diff[0]
            test.fail(f"{what}: {name}: {len(diff)} rows differ, first row {i}: {a[i]!r} != {b[i]!r} "
                      f"(largest difference {np.nanmax(np.abs(a - b))!r})")


class WorkDir:
    """A temporary folder made the working directory for a test module."""

    def __init__(self):
        self.path = tempfile.mkdtemp(prefix="ehpt_pytest_")
        self.old = os.getcwd()
        os.chdir(self.path)

    def close(self):
        os.chdir(self.old)
        shutil.rmtree(self.path, ignore_errors=True)
