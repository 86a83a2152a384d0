#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""summary.json's peak_rss_MB is the run's own memory (issue 26 item 3 and 5).

    /usr/bin/python3 tests/targets/peak_rss_test.py BUILD/ehpt

- Started from a parent that holds 300 MB, `ehpt run` reports its own high-water mark (VmHWM),
  not the parent's: getrusage's ru_maxrss keeps the peak of the image before exec, and said
  300+ MB here.
- Recording every step of PSecu2 (120 000 rows of every signal) stays within 16 MB: the row
  buffer is sized to a chunk of at most 4 MiB of rows (it was 50 000 rows whatever their
  width).
"""

import json
import pathlib
import subprocess
import sys
import tempfile
import unittest

EHPT = None


class PeakRss(unittest.TestCase):
    def run_ehpt(self, out, *sets):
        args = [EHPT, "run", "psecu2_nedc", "--quiet", "--out", str(out)]
        for s in sets:
            args += ["--set", s]
        r = subprocess.run(args, capture_output=True, text=True, timeout=300)
        self.assertEqual(r.returncode, 0, r.stderr)
        return json.loads((out / "summary.json").read_text())

    def test_a_big_parent_is_not_the_runs_memory(self):
        ballast = bytearray(300 * 1024 * 1024)
        for i in range(0, len(ballast), 4096):
            ballast[i] = 1  # resident, not just reserved
        with tempfile.TemporaryDirectory() as tmp:
            s = self.run_ehpt(pathlib.Path(tmp) / "small", "solver.duration_s=20")
        self.assertGreater(s["peak_rss_MB"], 1.0)
        self.assertLess(s["peak_rss_MB"], 50.0, "the parent's 300 MB counted as the run's")
        del ballast

    def test_recording_every_step_stays_within_16_MB(self):
        with tempfile.TemporaryDirectory() as tmp:
            out = pathlib.Path(tmp) / "every"
            s = self.run_ehpt(out, "solver.duration_s=120", "output.interval_s=0.001")
            with open(out / "timeseries.csv") as f:
                header = f.readline().split(",")
                rows = sum(1 for _ in f)
        self.assertEqual(rows, 120001)
        self.assertGreater(len(header), 30)
        print(f"\n     every step of PSecu2, {len(header)} columns, 120 001 rows: peak RSS {s['peak_rss_MB']:.1f} MB",
              file=sys.stderr)
        self.assertLess(s["peak_rss_MB"], 16.0)


if __name__ == "__main__":
    EHPT = sys.argv.pop(1)
    unittest.main()
