#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""Bus faults end to end: `ehpt test` with `ehpt ecu` as its own process over socketcand.

    /usr/bin/python3 tests/targets/bus_faults_e2e_test.py EHPT SOURCE_DIR

On psecu2 (NEDC, 12 s), each test file holds one bus fault from 10.0 s to 10.5 s (50 ECU
samples); the plant runs in lockstep on 127.0.0.1. Checked:
- the ECU's PsdCommand1 frames dropped: 50 frames lost, one timeout (counted under the bus
  fault, the session not degraded), about 0.5 s in the safe state (also as the test figures
  ecu_timeouts and safe_state_s); the run twice gives the same trajectory; without the fault
  (the negative control) no timeout and no safe state, and the same figures fail;
- the plant's PlantStatus dropped (the other direction): the faulted samples and the one after
  are not waited for, one timeout;
- a counter_freeze on PsdCommand1: the plant's counter rule refuses the repeats (bad_counter);
  a counter_jump: refused once where it jumps and once where it jumps back, no timeout;
- replay of the faulted session: bit-identical;
- without a bus (`ehpt test` alone, `ehpt run`), the built-in ECU on the in-process CAN bus:
  each faulted test gives the socketcand session's trajectory_hash, verdicts and bus figures;
  a --fault one-off is in inputs.log and the session replays bit for bit; a sweep of the test
  passes with the same trajectory;
- over LCM a test with a bus fault is skipped, with its reason (exit 0, JUnit <skipped>);
- refused before anything runs (exit 2, the file:line): a bus fault on a message the
  contract has not; with --realtime (the in-process bus is lockstep);
- the shipped example (examples/tests/command_frames_dropped.toml) passes, over socketcand and
  in-process.
Exit 0 if every check passed, 1 otherwise.
"""

import json
import os
import re
import subprocess
import sys
import tempfile

EHPT, SRC = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
PORT = 29650
failures = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what)
    if not ok:
        failures.append(what)


def test_file(folder, name, fault, expect=""):
    path = os.path.join(folder, name + ".toml")
    with open(path, "w") as f:
        f.write('scenario = "psecu2_nedc"\n[solver]\nduration_s = 12.0\n')
        if fault:
            f.write("[[fault]]\nat_s = 10.0\nuntil_s = 10.5\n" + fault + "\n")
        f.write('[[expect]]\nname = "soc_window"\nsignal = "soc"\nmin = 0.3\n' + expect)
    return path


def outcomes(summary):
    return {e["name"]: (e["passed"], e.get("value")) for e in summary["test"]["expectations"]}


# the link figures: one timeout and about 0.48 s of safe state under the fault, none without
LINK = ('[[expect]]\nname = "one_timeout"\nfigure = "ecu_timeouts"\nvalue = 1\ntol = 0\n'
        '[[expect]]\nname = "safe_state"\nfigure = "safe_state_s"\nmin = 0.4\nmax = 0.5\n')


def run_test(path, out, extra=None):
    args = [EHPT, "test", path, "--out", out]
    args += extra if extra is not None else ["--bus", f"socketcand:127.0.0.1:{PORT}", "--ecu-cmd", "ehpt", "ecu", "{test}",
                                             "--bus", "{bus}"]
    p = subprocess.run(args, capture_output=True, text=True, timeout=300)
    name = os.path.splitext(os.path.basename(path))[0]
    summary = None
    if os.path.exists(os.path.join(out, name, "summary.json")):
        with open(os.path.join(out, name, "summary.json")) as f:
            summary = json.load(f)
    return p.returncode, p.stdout + p.stderr, summary


with tempfile.TemporaryDirectory() as tmp:
    clean = test_file(tmp, "clean", "", LINK)
    drop = test_file(tmp, "drop_cmd", 'kind = "drop"\ntarget = "PsdCommand1"', LINK)
    status = test_file(tmp, "drop_status", 'kind = "drop"\ntarget = "PlantStatus"')
    freeze = test_file(tmp, "freeze", 'kind = "counter_freeze"\ntarget = "PsdCommand1"')
    delay = test_file(tmp, "delay", 'kind = "delay"\ntarget = "PsdCommand2"\ndelay_s = 0.02\n'
                               '[[fault]]\nat_s = 10.0\nuntil_s = 10.5\nkind = "duplicate"\ntarget = "PsdSensors1"')
    jump = test_file(tmp, "jump", 'kind = "counter_jump"\ntarget = "PsdCommand1"\njump = 5')

    rc, text, s = run_test(clean, os.path.join(tmp, "o_clean"))
    check(rc == 1 and s is not None, f"the clean test fails its link figures over socketcand ({rc})\n{text[-800:]}")
    if s:
        check(outcomes(s) == {"soc_window": (True, outcomes(s)["soc_window"][1]), "one_timeout": (False, 0),
                              "safe_state": (False, 0)}, f"no fault: 0 timeouts, 0 s safe state: {outcomes(s)}")
        b = s["bus"]
        check(b["timeouts"] == 0 and b["safe_state_time_s"] == 0.0 and "faults" not in b,
              f"negative control: no fault, no timeout, no safe state ({b['timeouts']}, {b['safe_state_time_s']})")

    rc, text, s = run_test(drop, os.path.join(tmp, "o_drop"))
    rc2, _, s2 = run_test(drop, os.path.join(tmp, "o_drop2"))
    check(rc == 0 and rc2 == 0 and s is not None and s2 is not None, f"PsdCommand1 dropped: the test runs ({rc}, {rc2})\n{text[-800:]}")
    if s and s2:
        b = s["bus"]
        check(b["faults"] == [{"kind": "drop", "message": "PsdCommand1", "direction": "ecu_to_plant", "frames": 50}],
              f"the fault lost the 50 frames of its span: {b['faults']}")
        check(b["timeouts"] == 1 and b["timeouts_under_bus_faults"] == 1, f"one timeout, under the fault: {b['timeouts']}")
        check(0.4 < b["safe_state_time_s"] < 0.5, f"safe state for the span less the timeout: {b['safe_state_time_s']} s")
        check(b["commands_lost_to_faults"] == 50 and b["samples_not_awaited"] == 0,
              f"50 commands lost, every sample awaited: {b['commands_lost_to_faults']}, {b['samples_not_awaited']}")
        check(s["status"] == "ok" and b["lockstep_waits_timed_out"] == 0,
              f"not degraded, no lockstep wait ran out: {s['status']}, {b['lockstep_waits_timed_out']}")
        check(all(p for p, _ in outcomes(s).values()), f"the link figures under the fault: {outcomes(s)}")
        check(s["heap_allocations_after_startup"] == 0, f"no allocation in the run: {s['heap_allocations_after_startup']}")
        check(s["trajectory_hash"] == s2["trajectory_hash"], f"twice, the same trajectory: {s['trajectory_hash']} {s2['trajectory_hash']}")
        with open(os.path.join(tmp, "o_drop", "drop_cmd", "timeseries.csv")) as f:
            header = f.readline().strip().split(",")
            rows = [line.strip().split(",") for line in f]
        col = header.index("faults_active")
        active = [r for r in rows if r[col] != "0"]
        check(len(active) > 0 and abs(float(active[0][0]) - 10.0) < 1e-9,
              f"faults_active from t = 10 s: {active[0][0] if active else None}")
        r = subprocess.run([EHPT, "replay", os.path.join(tmp, "o_drop", "drop_cmd"), "--out", os.path.join(tmp, "replay")],
                           capture_output=True, text=True, timeout=120)
        check(r.returncode == 0 and "bit-identical" in r.stderr + r.stdout, f"the faulted session replays bit for bit\n{r.stderr[-600:]}")
        with open(os.path.join(tmp, "replay", "summary.json")) as f:
            replayed = json.load(f)
        check(outcomes(replayed) == outcomes(s), f"the replay's verdict is the session's: {outcomes(replayed)}")

    # the same tests without a bus: the built-in ECU on the in-process bus gives the session
    # the socketcand one gave (drop_cmd above; the others below), bit for bit
    in_process = {}
    for path in (drop, status, freeze, delay, jump):
        name = os.path.splitext(os.path.basename(path))[0]
        in_process[name] = run_test(path, os.path.join(tmp, "m_" + name), [])
    rc_m, text_m, m = in_process["drop_cmd"]
    check(rc_m == 0 and m is not None and s is not None, f"drop_cmd in-process: the test runs ({rc_m})\n{text_m[-800:]}")
    if m and s:
        check(m["bus"]["transport"] == "in-process" and m["trajectory_hash"] == s["trajectory_hash"],
              f"in-process == socketcand: {m['bus']['transport']} {m['trajectory_hash']} {s['trajectory_hash']}")
        check(m["ecu_in_process"]["samples_answered"] == 1201 and m["heap_allocations_after_startup"] == 0,
              f"the in-process ECU answered every sample it got whole, no allocation: {m['ecu_in_process']}")

    def same_session(name, s):
        rc_m, text_m, m = in_process[name]
        if not (rc_m == 0 and m is not None and s is not None):
            check(False, f"{name} in-process: the test runs ({rc_m})\n{text_m[-800:]}")
            return
        keys = ("faults", "timeouts", "timeouts_under_bus_faults", "samples_not_awaited", "commands_lost_to_faults",
                "messages_received", "commands_applied", "safe_state_time_s")
        check(m["trajectory_hash"] == s["trajectory_hash"] and outcomes(m) == outcomes(s)
              and all(m["bus"][k] == s["bus"][k] for k in keys),
              f"{name}: in-process == socketcand (hash, verdicts, {', '.join(keys)}): "
              + str([(k, m["bus"][k], s["bus"][k]) for k in keys if m["bus"][k] != s["bus"][k]]))

    rc, text, s = run_test(status, os.path.join(tmp, "o_status"))
    same_session("drop_status", s)
    check(rc == 0 and s is not None, f"PlantStatus dropped: the test runs ({rc})\n{text[-800:]}")
    if s:
        b = s["bus"]
        check(b["faults"][0]["direction"] == "plant_to_ecu" and b["faults"][0]["frames"] == 50,
              f"50 PlantStatus frames lost on their way to the ECU: {b['faults']}")
        check(b["samples_not_awaited"] == 51 and b["timeouts"] == 1 and b["timeouts_under_bus_faults"] == 1,
              f"51 samples not awaited (the faulted and the next), one timeout: {b['samples_not_awaited']}, {b['timeouts']}")
        check(s["status"] == "ok", f"not degraded: {s['status']} {s.get('degraded')}")

    rc, text, s = run_test(freeze, os.path.join(tmp, "o_freeze"))
    same_session("freeze", s)
    check(rc == 0 and s is not None, f"counter_freeze: the test runs ({rc})\n{text[-800:]}")
    if s:
        b = s["bus"]
        check(b["messages_received"]["PsdCommand1"]["bad_counter"] > 0 and b["timeouts"] > 0,
              f"the frozen counter is refused: {b['messages_received']['PsdCommand1']}, {b['timeouts']} timeouts")

    rc, text, s = run_test(delay, os.path.join(tmp, "o_delay"))
    same_session("delay", s)
    check(rc == 0 and s is not None, f"delay and duplicate: the test runs ({rc})\n{text[-800:]}")
    if s:
        b = s["bus"]
        # each delayed PsdCommand2 comes two samples late, answering an old sample: refused as
        # stale; the duplicated sensor frame is refused by the ECU's counter rule, harmlessly
        check([f["frames"] for f in b["faults"]] == [50, 50] and b["messages_received"]["PsdCommand2"]["stale"] == 50,
              f"50 delayed and 50 doubled frames, the delayed ones stale: {b['faults']}, {b['messages_received']['PsdCommand2']}")
        check(b["commands_lost_to_faults"] == 50 and b["timeouts"] == 1 and s["heap_allocations_after_startup"] == 0,
              f"50 commands lost, one timeout, no allocation (the held frames in a ring): {b['commands_lost_to_faults']}, "
              f"{b['timeouts']}, {s['heap_allocations_after_startup']}")

    rc, text, s = run_test(jump, os.path.join(tmp, "o_jump"))
    same_session("jump", s)
    check(rc == 0 and s is not None, f"counter_jump: the test runs ({rc})\n{text[-800:]}")
    if s:
        b = s["bus"]
        # refused where the counter jumps forward (10.0 s) and back (10.5 s), heard again from
        # the next frame each time: no command lost to a timeout
        check(b["messages_received"]["PsdCommand1"]["bad_counter"] == 2 and b["timeouts"] == 0,
              f"a jumped counter is refused once each way: {b['messages_received']['PsdCommand1']}, {b['timeouts']} timeouts")

    example = os.path.join(SRC, "examples", "tests", "command_frames_dropped.toml")
    rc, text, _ = run_test(example, os.path.join(tmp, "o_example"))
    check(rc == 0 and "1 test: 1 passed" in text, f"the shipped bus-fault example passes ({rc})\n{text[-800:]}")
    rc, text, _ = run_test(example, os.path.join(tmp, "m_example"), [])
    check(rc == 0 and "1 test: 1 passed" in text, f"... and in-process ({rc})\n{text[-800:]}")

    # ehpt run with a --fault one-off: the in-process bus; inputs.log keeps the fault, so the
    # session replays bit for bit (without it the replay would differ, and say so)
    one_off = "kind=drop target=PsdCommand1 at_s=10.0 until_s=10.5"
    out = os.path.join(tmp, "o_run")
    r = subprocess.run([EHPT, "run", "psecu2_nedc", "--set", "solver.duration_s=12", "--fault", one_off, "--out", out],
                       capture_output=True, text=True, timeout=60)
    check(r.returncode == 0, f"ehpt run --fault on a frame runs ({r.returncode}): {r.stderr[-400:]}")
    if r.returncode == 0:
        with open(os.path.join(out, "inputs.log")) as f:
            head = [line.strip() for line in f if line.startswith("#")]
        check("# fault " + one_off in head and "# set solver.duration_s=12" in head, f"inputs.log's header: {head}")
        with open(os.path.join(out, "summary.json")) as f:
            run_s = json.load(f)
        check(run_s["bus"]["timeouts"] == 1 and run_s["bus"]["faults"][0]["frames"] == 50,
              f"ehpt run: 50 frames lost, one timeout: {run_s['bus']['faults']}, {run_s['bus']['timeouts']}")
        r = subprocess.run([EHPT, "replay", out, "--out", os.path.join(tmp, "o_run_replay")], capture_output=True,
                           text=True, timeout=120)
        check(r.returncode == 0 and "bit-identical" in r.stderr + r.stdout, f"... and replays bit for bit\n{r.stderr[-600:]}")

    # a sweep runs each test as `ehpt run`: the in-process bus, the socketcand session's trajectory
    camp = os.path.join(tmp, "camp.toml")
    with open(camp, "w") as f:
        f.write(f'scenarios = ["{drop}"]\n')
    r = subprocess.run([EHPT, "sweep", camp, "--out", os.path.join(tmp, "sweep")], capture_output=True, text=True, timeout=120)
    with open(os.path.join(tmp, "sweep", "results.jsonl")) as f:
        rows = [json.loads(line) for line in f if line.strip()]
    summ = rows[0]["summary"] if len(rows) == 1 else {}
    check(r.returncode == 0 and summ.get("test", {}).get("verdict") == "passed"
          and summ.get("trajectory_hash") == (in_process["drop_cmd"][2] or {}).get("trajectory_hash"),
          f"a sweep of the bus-fault test: passed, the same trajectory ({r.returncode}): {str(rows)[:400]} {r.stderr[-300:]}")

    # over LCM: skipped, with the reason, in the table and the JUnit file
    junit = os.path.join(tmp, "lcm.xml")
    rc, text, _ = run_test(drop, os.path.join(tmp, "o_lcm"),
                           ["--junit", junit, "--bus", "lcm:udpm://239.255.76.67:7667?ttl=0", "--ecu-cmd", "ehpt", "ecu",
                            "{test}", "--bus", "{bus}"])
    check(rc == 0 and re.search(r"drop_cmd +skipped +skipped: .*drop_cmd.toml:4: kind = \"drop\" acts on CAN frames, and "
                                r"LCM carries none", text) and "0 passed, 0 failed, 0 errors, 1 skipped" in text,
          f"ehpt test over LCM skips it, saying why ({rc}): {text[-400:]}")
    if os.path.exists(junit):
        with open(junit) as f:
            xml = f.read()
        check('skipped="1"' in xml and "<skipped message=" in xml and 'failures="0" errors="0"' in xml,
              f"JUnit: one skipped test: {xml[:600]}")
    else:
        check(False, "JUnit file written")
    r = subprocess.run([EHPT, "run", drop, "--realtime", "--out", os.path.join(tmp, "o_rt")], capture_output=True,
                       text=True, timeout=60)
    check(r.returncode != 0 and "in-process CAN bus in lockstep" in r.stderr and not os.path.exists(os.path.join(tmp, "o_rt")),
          f"--realtime with a bus fault is refused, no folder ({r.returncode}): {r.stderr[-300:]}")
    typo = test_file(tmp, "typo", 'kind = "drop"\ntarget = "PsdComand1"')
    rc, text, _ = run_test(typo, os.path.join(tmp, "o_typo"))
    check(rc == 2 and "typo.toml:4" in text and 'did you mean "PsdCommand1"' in text and "nothing was run" in text,
          f"a message the contract has not: exit 2, nothing run ({rc}): {text[-300:]}")

print("ok" if not failures else f"{len(failures)} check(s) failed")
sys.exit(1 if failures else 0)
