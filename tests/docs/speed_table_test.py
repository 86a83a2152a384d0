#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""The one speed table equals its bench run: `ehpt bench --quick` into a temporary folder,
tools/speed_table.py on a copy of docs/speed.md, then every number in the table is compared
with the bench.json value its row names (values, not keys), the header with the bench's
commit, date and load average, and the rows with the figures a bench must give. A copy with
one number changed must be refused by the same check (the check can fail).

usage: speed_table_test.py EHPT_BINARY SOURCE_DIR WORK_DIR [BENCH_JSON]
       (BENCH_JSON: check against an existing bench run instead of running one)
"""
import json
import math
import os
import re
import shutil
import subprocess
import sys

BEGIN = "<!-- speed-table:begin -->"
END = "<!-- speed-table:end -->"


def at(doc, path):
    node = doc
    for part in path.split("."):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node


def table_of(page_text):
    inside = page_text.split(BEGIN, 1)[1].split(END, 1)[0]
    rows = []
    for line in inside.split("\n"):
        if not line.startswith("|") or line.startswith("|---") or line.startswith("| figure |"):
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        rows.append(cells)
    return inside, rows


def shown_equal(text, value):
    """text is value as the table shows it: the value rounded to the decimals of text (of its
    mantissa, for 1.2e-11)."""
    m = re.fullmatch(r"(-?\d+(?:\.(\d+))?)e([+-]\d+)", text)
    if m:
        scale = 10.0 ** int(m.group(3))
        decimals = len(m.group(2) or "")
        return abs(float(m.group(1)) * scale - value) <= 0.5 * 10 ** -decimals * scale * (1 + 1e-9)
    if not re.fullmatch(r"-?\d+(\.\d+)?", text):
        return False
    decimals = len(text.split(".")[1]) if "." in text else 0
    return abs(float(text) - value) <= 0.5 * 10 ** -decimals * (1 + 1e-9) + 1e-12


def check(page_text, bench):
    problems = []
    inside, rows = table_of(page_text)
    machine = bench["machine"]
    for what, want in (("commit", f"`{bench['commit']}`"), ("date", bench["date_utc"]),
                       ("load at the start", machine["load_average_start"]),
                       ("load at the end", machine["load_average_end"])):
        if want not in inside:
            problems.append(f"the header does not give the bench's {what} ({want})")
    paths = []
    for cells in rows:
        if len(cells) != 5:
            problems.append(f"a row without 5 cells: {cells}")
            continue
        figure, value, spread, _, source = cells
        path = source.strip("`")
        paths.append(path)
        want = at(bench, path)
        if not isinstance(want, (int, float)) or isinstance(want, bool):
            problems.append(f"{figure}: bench.json has no number at {path}")
            continue
        if not shown_equal(value, want):
            problems.append(f"{figure}: the table shows {value}, bench.json {path} = {want!r}")
        if spread:
            lo_hi = spread.split("..")
            parent = path.rsplit(".", 1)[0]
            lo, hi = at(bench, parent + ".min"), at(bench, parent + ".max")
            if len(lo_hi) != 2 or lo is None or hi is None or not shown_equal(lo_hi[0], lo) or \
                    not shown_equal(lo_hi[1], hi):
                problems.append(f"{figure}: range {spread}, bench.json {parent} min {lo!r} max {hi!r}")
    # the figures every bench must show: each vehicle x solver that ran, latency if it ran, CVODE
    required = []
    for vehicle, solvers in bench["speed"]["vehicles"].items():
        for solver, run in solvers.items():
            if isinstance(run, dict) and run.get("status") == "ok":
                required += [f"speed.vehicles.{vehicle}.{solver}.ns_per_step.median",
                             f"speed.vehicles.{vehicle}.{solver}.realtime_factor"]
    for source in ("cyclictest_us", "ehpt_us"):
        if at(bench, f"latency.{source}.status") == "ok":
            required += [f"latency.{source}.p50", f"latency.{source}.p99"]
    for scenario, run in bench["cvode"].get("scenarios", {}).items():
        if isinstance(run, dict) and run.get("status") == "ok":
            required += [f"cvode.scenarios.{scenario}.rk4_wall_s.median",
                         f"cvode.scenarios.{scenario}.cvode_wall_s.median"]
    if at(bench, "sweep_plan.status") == "ok":
        required += ["sweep_plan.wall_s", "sweep_plan.peak_rss_MB"]
    if len(required) < 10:
        problems.append(f"the bench gave only {len(required)} speed figures: it did not run its sections")
    for path in required:
        if path not in paths:
            problems.append(f"the table has no row for {path}")
    return problems, rows


def main(argv):
    if len(argv) not in (4, 5):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    binary, source, work = os.path.abspath(argv[1]), os.path.abspath(argv[2]), os.path.abspath(argv[3])
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    if len(argv) == 5:
        bench_json = argv[4]
    else:
        bench_dir = os.path.join(work, "bench")
        done = subprocess.run([binary, "bench", "--quick", "--quiet", "--out", bench_dir], timeout=600,
                              stdin=subprocess.DEVNULL)
        if done.returncode not in (0, 3):  # 3: a determinism problem, which ehpt_bench_quick reports
            print(f"error: ehpt bench --quick exit {done.returncode}", file=sys.stderr)
            return 1
        bench_json = os.path.join(bench_dir, "bench.json")
    page = os.path.join(work, "speed.md")
    shutil.copyfile(os.path.join(source, "docs", "speed.md"), page)
    done = subprocess.run([sys.executable, os.path.join(source, "tools", "speed_table.py"), bench_json, page],
                          timeout=60)
    if done.returncode != 0:
        print(f"error: tools/speed_table.py exit {done.returncode}", file=sys.stderr)
        return 1
    with open(bench_json, encoding="utf-8") as f:
        bench = json.load(f)
    with open(page, encoding="utf-8") as f:
        text = f.read()
    with open(os.path.join(source, "docs", "speed.md"), encoding="utf-8") as f:
        original = f.read()
    # outside the markers the page is unchanged
    outside = lambda t: t.split(BEGIN, 1)[0] + t.split(END, 1)[1]
    problems, rows = check(text, bench)
    if outside(text) != outside(original):
        problems.append("tools/speed_table.py changed the page outside the markers")
    print(text.split(BEGIN, 1)[1].split(END, 1)[0])
    # negative control: one value off by one unit of its last digit must be caught
    figure, value = rows[0][0], rows[0][1]
    step = 10 ** -(len(value.split(".")[1]) if "." in value else 0)
    bad_value = f"{float(value) + 2 * step:.{len(value.split('.')[1]) if '.' in value else 0}f}"
    bad = text.replace(f"| {figure} | {value} |", f"| {figure} | {bad_value} |", 1)
    if bad == text or not check(bad, bench)[0]:
        problems.append(f"the check did not catch a planted wrong value ({figure}: {value} -> {bad_value})")
    for p in problems:
        print(f"error: {p}", file=sys.stderr)
    if problems:
        return 1
    print(f"speed table ok: {len(rows)} rows equal {bench_json}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
