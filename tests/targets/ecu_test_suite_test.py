#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""`ehpt test` end to end, its JUnit file read by Debian's python3-junitparser.

    /usr/bin/python3 tests/targets/ecu_test_suite_test.py EHPT SOURCE_DIR

- the shipped suite (examples/tests/suite.toml, MBecu2) passes: exit 0, one testcase per
  test file it lists, no failure and no error, the test written to fail listed as xfail;
- a suite with a failing test exits 1: its testcase has a <failure> whose message names the
  expectation, the time and the value; the passing one none;
- a test that stops on a plant fault is an <error> (exit 3), with the fault in its message;
- a test file with a typo runs nothing (exit 2) and names file:line;
- the verdict in each run's summary.json agrees with the JUnit file.
Exit 0 if every check passed, 1 otherwise; each check is printed.
"""

import json
import os
import subprocess
import sys
import tempfile

import junitparser

EHPT, SRC = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
failures = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what)
    if not ok:
        failures.append(what)


def run(args):
    p = subprocess.run([EHPT] + args, capture_output=True, text=True, timeout=900)
    return p.returncode, p.stdout, p.stderr


def cases(path):
    xml = junitparser.JUnitXml.fromfile(path)
    out = {}
    for suite in xml:
        for case in suite:
            out[case.name] = case
    return xml, out


with tempfile.TemporaryDirectory() as tmp:
    # the shipped suite
    suite = os.path.join(SRC, "examples", "tests", "suite.toml")
    listed = [line for line in open(suite) if line.strip().startswith('"')]
    junit = os.path.join(tmp, "suite.xml")
    rc, out, err = run(["test", suite, "--out", os.path.join(tmp, "suite"), "--junit", junit, "-j", "2"])
    check(rc == 0, f"the shipped suite passes (exit {rc})\n{out}{err[-2000:]}")
    xml, by_name = cases(junit)
    check(len(by_name) == len(listed) and len(listed) >= 6, f"one testcase per listed test ({len(by_name)} of {len(listed)})")
    bad = [n for n, c in by_name.items() if c.result]
    check(not bad, f"no failure or error in the shipped suite: {bad}")
    check("xfail" in out, "the test written to fail is listed as xfail")
    xfail_dir = os.path.join(tmp, "suite", "soc_stuck_written_to_fail")
    check(os.path.exists(os.path.join(xfail_dir, "expect_soc_band.png")),
          "its failed expectation has its figure (expect_soc_band.png)")
    check(not any(f.startswith("expect_") for f in os.listdir(os.path.join(tmp, "suite", "soc_sensor_stuck"))),
          "a test whose expectations held has no expectation figure")
    # the same test cut short, before its expected failure: every expectation held, so the test
    # fails, and says why in the table and the JUnit message (summary.json's first_failure)
    short_junit = os.path.join(tmp, "short.xml")
    rc, out, err = run(["test", os.path.join(SRC, "examples", "tests", "soc_stuck_written_to_fail.toml"),
                        "--set", "solver.duration_s=300", "--out", os.path.join(tmp, "short"), "--junit", short_junit])
    _, short_cases = cases(short_junit)
    why = "written to fail (expect_fail = true), but every expectation held"
    msgs = [r.message for c in short_cases.values() for r in c.result]
    check(rc == 1 and why in out and any(why in (m or "") for m in msgs),
          f"written to fail but held: exit 1, the reason in the table and JUnit ({rc}: {out[-300:]} {msgs})")
    with open(os.path.join(xfail_dir, "ehpt-manifest.txt")) as f:
        check("expect_soc_band.png" in f.read(), "the figure is part of the committed run (its manifest lists it)")
    for name in by_name:
        with open(os.path.join(tmp, "suite", name, "summary.json")) as f:
            v = json.load(f)["test"]["verdict"]
        check(v == "passed", f"{name}: summary.json verdict {v} agrees with JUnit")

    # the names a fault's target takes
    rc, out, err = run(["signals", "psecu2_nedc", "--fault-targets"])
    names = [l.split()[0] for l in out.splitlines() if l.startswith("  ")]
    check(rc == 0 and "batSOC" in names and "motTauRef_Nm" in names and "iceON" in names and
          "fault" not in names and "locked" not in names, f"ehpt signals --fault-targets: the message fields ({names})")
    rc, out, err = run(["signals", "battery_cc_discharge", "--fault-targets"])
    check(rc == 2 and "no ECU messages" in err, f"... and a rig has none (exit {rc})")
    rc, out, err = run(["signals", "shev_oo_sort1", "--fault-targets"])
    names = [l.split()[0] for l in out.splitlines() if l.startswith("  ")]
    check(rc == 0 and "drivePowDc_W" in names and "gensetPowRef_W" in names and "gensetON" in names and
          "fault" not in names and "bus: none" not in out and "ShevCommand" in names and "ShevSensors4" in names,
          f"... the series hybrid's message fields and its frames ({names})")

    # a failing and a passing test
    base = os.path.join(SRC, "scenarios", "psecu2_nedc.toml")
    good = os.path.join(tmp, "good.toml")
    fail = os.path.join(tmp, "fail.toml")
    stop = os.path.join(tmp, "plantfault.toml")
    typo = os.path.join(tmp, "typo.toml")
    head = f'scenario = "{base}"\n[solver]\nduration_s = 60\n'
    open(good, "w").write(head + '[[expect]]\nname = "soc band"\nsignal = "soc"\nmin = 0.5\nmax = 0.7\n')
    open(fail, "w").write(head + '[[fault]]\nname = "no_engine"\nkind = "no_start"\n'
                          '[[expect]]\nname = "engine runs"\nsignal = "iceON"\nmin = 1\nwindow = "eventually"\n')
    # a SOC window that the run leaves: the plant's fault stops it
    open(stop, "w").write(head + '[vehicle.battery]\nsoc_min = 0.5999\n[[expect]]\nsignal = "soc"\nmin = 0\n')
    open(typo, "w").write(head + '[[fault]]\nkind = "stuk"\ntarget = "batSOC"\n[[expect]]\nsignal = "soc"\nmin = 0\n')
    junit2 = os.path.join(tmp, "two.xml")
    rc, out, err = run(["test", good, fail, "--out", os.path.join(tmp, "two"), "--junit", junit2])
    check(rc == 1, f"a suite with a failing test exits 1 (exit {rc})")
    _, two = cases(junit2)
    check(set(two) == {"good", "fail"}, f"both testcases named: {sorted(two)}")
    check(not two["good"].result, "the passing test has no failure")
    res = two["fail"].result
    check(len(res) == 1 and isinstance(res[0], junitparser.Failure), "the failing test has one <failure>")
    msg = res[0].message if res else ""
    check("engine runs" in msg and "never held" in msg and "closest iceON = 0" in msg and "t = " in msg,
          f"the failure names the expectation, its value and time: {msg}")
    check(os.path.exists(os.path.join(tmp, "two", "fail", "expect_engine_runs.png")), "the failed expectation's figure")
    rc, out, err = run(["test", stop, "--out", os.path.join(tmp, "stop"), "--junit", os.path.join(tmp, "stop.xml")])
    check(rc == 3, f"a test stopped by a plant fault exits 3 (exit {rc})")
    _, st = cases(os.path.join(tmp, "stop.xml"))
    r = st["plantfault"].result
    check(len(r) == 1 and isinstance(r[0], junitparser.Error) and "plant fault" in (r[0].message or ""),
          f"... and is a JUnit <error> naming the plant fault: {r[0].message if r else None}")
    # a campaign of test files: the verdict lands in results.csv
    camp = os.path.join(tmp, "camp.toml")
    open(camp, "w").write(f'scenarios = ["{good}", "{fail}"]\n[grid]\n"vehicle.ecu.soc_ref" = [0.6]\n')
    rc, out, err = run(["sweep", camp, "--out", os.path.join(tmp, "camp"), "-j", "2", "--quiet"])
    import csv
    with open(os.path.join(tmp, "camp", "results.csv")) as f:
        rows = {r["scenario"]: r for r in csv.DictReader(f)}
    check(rows["good"]["sweep_status"] == "ok" and rows["good"]["test.verdict"] == "passed",
          f"sweep: the passing test is ok, verdict passed ({rows['good']['sweep_status']}, {rows['good']['test.verdict']})")
    check(rows["fail"]["sweep_status"] == "failed" and rows["fail"]["exit_code"] == "5" and
          rows["fail"]["test.verdict"] == "failed" and rows["fail"]["message"].startswith("test failed: engine runs"),
          f"sweep: the failing test is failed, exit 5, its first failure the message ({rows['fail']['message'][:80]})")
    rc, out, err = run(["test", good, typo, "--out", os.path.join(tmp, "typo")])
    check(rc == 2 and "typo.toml:5" in err and 'did you mean "stuck"' in err, f"a typo: exit 2, file:line, a hint ({rc}: {err})")
    check(not os.path.exists(os.path.join(tmp, "typo", "good")), "... and nothing ran")
    # a command line that cannot run is bad input (2), never "a test failed" (1)
    for bad, what in [(["--bus", "lcm:udpm://239.255.76.67:99999?ttl=0", "--ecu-cmd", "true"], "a udpm port past 65279"),
                      (["--bus", "socketcand:127.0.0.1:0", "--ecu-cmd", "true"], "port 0"),
                      (["-j", "0"], "-j 0"), (["--frobnicate"], "an unknown option"),
                      (["--bus", "socketcand:127.0.0.1:29600"], "--bus without --ecu-cmd")]:
        rc, out, err = run(["test", good, "--out", os.path.join(tmp, "bad")] + bad)
        check(rc == 2 and not os.path.exists(os.path.join(tmp, "bad", "good")), f"{what}: exit 2, nothing ran ({rc}: {err[:120]})")

print("ok" if not failures else f"{len(failures)} check(s) failed")
sys.exit(1 if failures else 0)
