#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""Writes the one speed table of the documentation from an `ehpt bench` run.

usage: tools/speed_table.py BENCH_JSON [PAGE]     (PAGE default: docs/speed.md next to this tool)

Reads BENCH_JSON (written by `ehpt bench`), builds a Markdown table of every speed figure it
holds (ns per step, real-time factors, implicit Euler / RK4, wake-up latency next to
cyclictest's, overruns, peak RSS of the real-time run, the lockstep exchange's rate and round
trip with ehpt ecu and a python-can ECU, the python-can ECU's command frames on the wall
clock, the own-DBC VCU's stale samples on the wall clock and in real time, RK4 and CVODE wall times,
sweep planning's time and memory) with the
commit, date, machine and load average the bench recorded, and writes it into PAGE between
the lines `<!-- speed-table:begin -->` and `<!-- speed-table:end -->` (everything else in
PAGE is kept as it is). Every row names the bench.json value it shows, so a reader (and the
test speed_table) can check it. Exit codes: 0 written, 2 bad input (named), nothing written.
"""
import json
import math
import os
import sys

BEGIN = "<!-- speed-table:begin -->"
END = "<!-- speed-table:end -->"
FORMAT = "ehpt bench, version 1"


class BadInput(Exception):
    pass


def at(doc, path):
    node = doc
    for part in path.split("."):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node


def number(value, decimals):
    """The value as shown in the table: fixed decimals, whole numbers without a point; "e2":
    scientific with two decimals (errors of 1e-11)."""
    if isinstance(decimals, str):
        return f"{value:.{int(decimals[1:])}e}"
    if decimals == 0:
        return str(int(round(value)))
    return f"{value:.{decimals}f}"


def rtol_text(rtol):
    """1e-08 -> 1e-8"""
    if not isinstance(rtol, (int, float)):
        return "?"
    mantissa, _, exponent = f"{rtol:g}".partition("e")
    return mantissa + ("e" + str(int(exponent)) if exponent else "")


def rows_of(bench):
    """(figure, value text, range text, target text, bench.json path) for every speed figure."""
    rows = []

    def add(figure, path, decimals, target="", with_range=False):
        value = at(bench, path)
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
            return
        spread = ""
        if with_range:
            parent = path.rsplit(".", 1)[0]
            lo, hi = at(bench, parent + ".min"), at(bench, parent + ".max")
            if isinstance(lo, (int, float)) and isinstance(hi, (int, float)):
                spread = f"{number(lo, decimals)}..{number(hi, decimals)}"
        rows.append((figure, number(value, decimals), spread, target, path))

    speed = bench.get("speed", {})
    reps = speed.get("repetitions")
    add("the latency floor of an RK4 step: the battery's four dependent stage chains, ns", "speed.floor_ns_per_step", 1)
    for vehicle, solvers in speed.get("vehicles", {}).items():
        for solver, run in solvers.items():
            if not isinstance(run, dict) or run.get("status") != "ok":
                continue
            base = f"speed.vehicles.{vehicle}.{solver}"
            target = run.get("target_ns_per_step")
            add(f"`{vehicle}` {solver}: ns per step (median of {reps} whole runs)", base + ".ns_per_step.median", 1,
                f"<= {number(target, 0)}" if isinstance(target, (int, float)) else "", with_range=True)
            add(f"`{vehicle}` {solver}: times real time", base + ".realtime_factor", 0)
            floor_target = run.get("target_floor_ratio")
            add(f"`{vehicle}` {solver}: ns per step / the latency floor", base + ".floor_ratio", 2,
                f"<= {floor_target:g}" if isinstance(floor_target, (int, float)) else "")
        ratio_target = solvers.get("target_implicit_euler_over_rk4")
        add(f"`{vehicle}`: implicit Euler / RK4, ns per step", f"speed.vehicles.{vehicle}.implicit_euler_over_rk4", 2,
            f"<= {ratio_target:g}" if isinstance(ratio_target, (int, float)) else "")

    target = speed.get("target_test_overhead_percent")
    add("an ECU test (a fault, four expectations at every step) over a plain `psecu2_nedc` rk4 step, %",
        "speed.test_overhead_percent", 1, f"<= {number(target, 0)}" if isinstance(target, (int, float)) else "")

    lat = bench.get("latency", {})
    if lat.get("status") == "ok" or at(bench, "latency.ehpt_us.status") == "ok":
        for source, label in (("cyclictest_us", "cyclictest"), ("ehpt_us", "`ehpt run ev_sort1 --realtime`")):
            if at(bench, f"latency.{source}.status") != "ok":
                continue
            for key, name in (("p50", "p50"), ("p99", "p99"), ("p99_9", "p99.9"), ("max", "max")):
                add(f"{label}: wake-up latency {name}, us", f"latency.{source}.{key}", 1)
        target = lat.get("target_p99_ratio")
        add("p99 wake-up latency, ehpt / cyclictest", "latency.p99_ratio", 2,
            f"<= {target:g}" if isinstance(target, (int, float)) else "")
        add(f"real-time run: ticks that overran ({lat.get('seconds')} s)", "latency.overruns", 0,
            f"{lat.get('target_overruns_over_60_s')} over 60 s")
        add("real-time run: ticks missed (skipped)", "latency.missed_ticks", 0)
        target = lat.get("target_peak_rss_MB")
        add("real-time run: peak RSS, MB", "latency.peak_rss_MB", 1,
            f"<= {target:g}" if isinstance(target, (int, float)) else "")

    runs = bench.get("runs", {})
    for kind, label in (("tcp", "TCP"), ("udp", "UDP")):
        if at(bench, f"exchange_floors.{kind}.status") == "ok":
            add(f"the exchange's floor: a {label} ping-pong of two processes on 127.0.0.1, round trips per second",
                f"exchange_floors.{kind}.round_trips_per_s", 0)
    for name, label in (("lockstep_socketcand", "lockstep over socketcand, `ehpt ecu` (ev_sort1)"),
                        ("lockstep_socketcand_psecu2", "lockstep over socketcand, `ehpt ecu` (psecu2_nedc)"),
                        ("lockstep_lcm", "lockstep over LCM udpm, `ehpt ecu` (ev_sort1)"),
                        ("lockstep_lcm_psecu2", "lockstep over LCM udpm, `ehpt ecu` (psecu2_nedc)"),
                        ("lockstep_pycan", "lockstep over socketcand, `tools/pycan_ecu.py` (python-can 4.1, psecu2_nedc)")):
        if at(runs, name + ".status") != "ok":
            continue
        add(f"{label}: periods per second", f"runs.{name}.samples_per_s", 0,
            ">= 2000" if name == "lockstep_pycan" else "")
        target = at(runs, name + ".target_floor_ratio")
        if at(runs, name + ".floor_ratio") is not None:
            add(f"{label}: periods per second / the floor's round trips", f"runs.{name}.floor_ratio", 2,
                f">= {target:g}" if isinstance(target, (int, float)) else "")
        add(f"{label}: round trip p50, us", f"runs.{name}.round_trip_p50_us", 0)
        add(f"{label}: round trip p99, us", f"runs.{name}.round_trip_p99_us", 0)
    if at(runs, "wallclock_pycan.status") == "ok":
        label = "wall clock over socketcand, `tools/pycan_ecu.py` (psecu2_nedc)"
        add(f"{label}: a sample's two command frames apart, p99, us (as read at 1 ms steps)",
            "runs.wallclock_pycan.command_frames_spread_p99_us", 0, "<= 1000")
        add(f"{label}: the same, max, us", "runs.wallclock_pycan.command_frames_spread_max_us", 0)
        add(f"{label}: stale samples", "runs.wallclock_pycan.stale_samples", 0, "0 on a quiet machine")
    for name, label in (("wallclock_own_dbc", "wall clock"), ("realtime_own_dbc", "real time (SCHED_FIFO)")):
        if at(runs, name + ".status") == "ok":
            add(f"`examples/own_dbc/vcu_ecu.py` (own DBC, E2E, no echo), {label}: stale samples",
                f"runs.{name}.stale_samples", 0, "0 on a quiet machine")
            add(f"`examples/own_dbc/vcu_ecu.py`, {label}: timeouts", f"runs.{name}.timeouts", 0, "0")

    cv = bench.get("cvode", {})
    for scenario, run in cv.get("scenarios", {}).items():
        if not isinstance(run, dict) or run.get("status") != "ok":
            continue
        base = f"cvode.scenarios.{scenario}"
        add(f"`{scenario}` ({number(run.get('duration_s', 0), 0)} s): RK4 at 1 ms, wall s (median)",
            base + ".rk4_wall_s.median", 3, with_range=True)
        add(f"`{scenario}`: CVODE (BDF, rtol {rtol_text(cv.get('rtol'))}), wall s (median)", base + ".cvode_wall_s.median", 3,
            with_range=True)
        add(f"`{scenario}`: final SOC error of RK4 at 1 ms (against RK4 at {cv.get('fine_step_s', 0) * 1e3:g} ms)",
            base + ".soc_error_rk4", "e1")
        add(f"`{scenario}`: final SOC error of CVODE (the same yardstick)", base + ".soc_error_cvode", "e1")
        target = cv.get("target_wall_ratio")
        add(f"`{scenario}`: CVODE / RK4 wall time", base + ".wall_ratio", 1,
            f">= {target:g}" if isinstance(target, (int, float)) else "")

    plan = bench.get("sweep_plan", {})
    if plan.get("status") == "ok":
        runs, target_runs = plan.get("runs"), plan.get("target_runs")
        full = runs == target_runs  # the targets are for target_runs runs
        add(f"`ehpt sweep --plan`, {runs} psecu2_nedc runs on {number(plan.get('cpus', 0), 0)} CPUs: wall s",
            "sweep_plan.wall_s", 2, f"<= {number(plan.get('target_wall_s', 0), 0)}" if full else "")
        add(f"`ehpt sweep --plan`, {runs} runs: peak memory, MB", "sweep_plan.peak_rss_MB", 1,
            f"<= {number(plan.get('target_peak_rss_MB', 0), 0)}" if full else "")
    return rows


def table(bench, source):
    machine = bench.get("machine", {})
    dirty = " (with uncommitted changes)" if bench.get("uncommitted_changes") else ""
    lines = [
        f"Generated by `tools/speed_table.py` from `{source}`, written by `{bench.get('command')}` "
        f"({bench.get('mode')} run, status {bench.get('status')}).",
        "",
        f"* commit `{bench.get('commit')}`{dirty}, {bench.get('date_utc')}",
        f"* machine: {machine.get('nproc')} CPUs ({machine.get('cpu_model')}), {machine.get('kernel')}",
        f"* load average (1, 5, 15 min): {machine.get('load_average_start')} at the start, "
        f"{machine.get('load_average_end')} at the end",
    ]
    lat = bench.get("latency", {})
    if isinstance(lat.get("period_s"), (int, float)):
        lines.append(f"* wake-up latency: period {lat['period_s'] * 1e3:g} ms, {lat.get('seconds')} s each, "
                     f"SCHED_FIFO priority {lat.get('priority')}, CPU {lat.get('cpu')}, cyclictest first, then ehpt")
    lines += [
        "",
        "| figure | value | min..max | target | bench.json |",
        "|---|---|---|---|---|",
    ]
    rows = rows_of(bench)
    if not rows:
        raise BadInput("it holds no speed figure (every section failed or was not run)")
    for figure, value, spread, target, path in rows:
        lines.append(f"| {figure} | {value} | {spread} | {target} | `{path}` |")
    return "\n".join(lines) + "\n"


def main(argv):
    if len(argv) not in (2, 3) or argv[1] in ("-h", "--help"):
        print(__doc__.strip(), file=sys.stderr if len(argv) not in (2, 3) else sys.stdout)
        return 0 if len(argv) == 2 else 2
    bench_path = argv[1]
    page = argv[2] if len(argv) == 3 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "docs",
                                                       "speed.md")
    try:
        try:
            with open(bench_path, encoding="utf-8") as f:
                bench = json.load(f)
        except (OSError, ValueError) as e:
            raise BadInput(f"cannot read it: {e}")
        if not isinstance(bench, dict) or bench.get("format") != FORMAT:
            raise BadInput(f'not an ehpt bench report (no "format": "{FORMAT}")')
        text = table(bench, os.path.basename(bench_path))
    except BadInput as e:
        print(f"error: {bench_path}: {e}", file=sys.stderr)
        return 2
    try:
        with open(page, encoding="utf-8") as f:
            lines = f.read().split("\n")
    except OSError as e:
        print(f"error: {page}: {e}", file=sys.stderr)
        return 2
    begins = [i for i, line in enumerate(lines) if line.strip() == BEGIN]
    ends = [i for i, line in enumerate(lines) if line.strip() == END]
    if len(begins) != 1 or len(ends) != 1 or ends[0] < begins[0]:
        print(f"error: {page}: needs exactly one '{BEGIN}' line and, after it, one '{END}' line", file=sys.stderr)
        return 2
    out = lines[:begins[0] + 1] + [""] + text.rstrip("\n").split("\n") + [""] + lines[ends[0]:]
    tmp = page + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write("\n".join(out))
    os.replace(tmp, page)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
