#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""End-to-end tests of `ehpt sweep` with the local executor, on the real binary.

Usage: /usr/bin/python3 tests/targets/sweep_e2e_test.py EHPT [GROUP ...]
GROUP: Failures, Resume, ChangedInput, BadInput, Plot (default: all). Exit 0 when every check
passes, 1 otherwise. The Slurm executor has its own test (sweep_slurm_test.py), which
compares its merged results with this executor's, using the helpers below.
"""
import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.dirname(os.path.dirname(HERE))
# summary fields that are wall times or depend on the machine's load: everything else must be
# bit-identical between two runs of the same inputs
MACHINE_FIELDS = {"wall_time_s", "run_wall_time_s", "realtime_factor", "ns_per_step", "peak_rss_MB"}

failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        failures.append(what)


def sweep(ehpt, *args, cwd=None, env=None, timeout=600):
    return subprocess.run([ehpt, "sweep", *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def results(folder):
    """results.csv as a list of dicts without the machine-dependent fields, and its header."""
    with open(os.path.join(folder, "results.csv"), newline="") as f:
        rows = list(csv.DictReader(f))
    header = list(rows[0].keys()) if rows else []
    return [{k: v for k, v in r.items() if k not in MACHINE_FIELDS} for r in rows], header


def runs_of_sweep(sweep_pid):
    """The pids of processes started by the sweep with this pid (their environment names it)."""
    mark = b"EHPT_SWEEP_PID=%d\0" % sweep_pid
    pids = []
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            with open("/proc/%s/environ" % name, "rb") as f:
                if mark in f.read() + b"\0":
                    pids.append(int(name))
        except OSError:
            pass  # ended meanwhile, or not ours to read
    return pids


def write_campaign(tmp, name="c.toml", extra="", duration_s=40):
    """A 16-run campaign of short runs: 2 vehicles x 4 x 2 grid values."""
    path = os.path.join(tmp, name)
    with open(path, "w") as f:
        f.write('description = "e2e: 16 short runs"\n'
                'scenarios = ["ev_nedc", "psecu2_nedc"]\n'
                '[set]\n"solver.duration_s" = %g\n' % duration_s +
                '[grid]\n"vehicle.battery.soc_initial" = [0.5, 0.55, 0.6, 0.65]\n'
                '"solver.step_s" = [0.001, 0.002]\n' + extra)
    return path


def tree(folder):
    """Every path under folder with its size and mtime (to show nothing was touched)."""
    out = {}
    for root, dirs, files in os.walk(folder):
        for n in dirs + files:
            p = os.path.join(root, n)
            st = os.lstat(p)
            out[os.path.relpath(p, folder)] = (st.st_size, st.st_mtime_ns)
    return out


def test_failures(ehpt, tmp):
    with open(os.path.join(tmp, "v.csv"), "w") as f:
        f.write("vehicle.battery.soc_initial,solver.method\n0.6,rk4\n1.5,rk4\n0.62,implicit-euler\n,rk4\n")
    camp = os.path.join(tmp, "var.toml")
    with open(camp, "w") as f:
        f.write('scenarios = ["ev_nedc"]\nvariants = "v.csv"\n[set]\n"solver.duration_s" = 30\n')
    out = os.path.join(tmp, "var")
    r = sweep(ehpt, camp, "--out", out, "-j", "2")
    check(r.returncode == 3, "a failed variant: exit 3 (got %d: %s)" % (r.returncode, r.stderr[-300:]))
    rows, header = results(out)
    check([x["sweep_status"] for x in rows] == ["ok", "failed", "ok", "ok"],
          "the invalid variant fails alone, the others run: %s" % [x["sweep_status"] for x in rows])
    ok_rows = [x for x in rows if x["sweep_status"] == "ok"]
    check(len(ok_rows) == 3 and all(x["provenance.run_id"] == x["run_id"] for x in ok_rows),
          "each run's summary.json records the sweep's content hash: provenance.run_id = run_id")
    bad = rows[1]
    check(bad["exit_code"] == "2" and "v.csv:3" in bad["message"] and "soc_initial" in bad["message"],
          "its exit code and message name the CSV line and key: %r" % bad["message"])
    check(rows[2]["solver"] == "implicit-euler" and rows[0]["solver"] == "rk4",
          "each variant's value reaches its run (solver column)")
    check(rows[3]["soc_start"] != rows[0]["soc_start"] and rows[3]["vehicle.battery.soc_initial"] == "",
          "an empty cell keeps the scenario's value")
    check(header[:6] == ["run_id", "scenario", "vehicle.battery.soc_initial", "solver.method", "sweep_status", "exit_code"],
          "results.csv: id, scenario, swept keys, then status: %s" % header[:6])
    check(len(header) == len(set(header)) and "solver" in header and "steps" in header,
          "results.csv: one column per name (the summary's own \"scenario\" is not repeated)")
    run_dir = os.path.join(out, "runs", rows[0]["run_id"])
    check(sorted(os.listdir(run_dir)) == ["ehpt-manifest.txt", "summary.json"],
          "summary only by default (output.timeseries=false): %s" % sorted(os.listdir(run_dir)))
    # the rows are still hashed: the same trajectory_hash with and without timeseries.csv
    hashes = []
    for i, extra in enumerate(([], ["--set", "output.timeseries=false"])):
        d = os.path.join(tmp, "plain%d" % i)
        subprocess.run([ehpt, "run", "ev_nedc", "--quiet", "--out", d, "--set", "solver.duration_s=20", *extra], check=True)
        with open(os.path.join(d, "summary.json")) as f:
            hashes.append(json.load(f)["trajectory_hash"])
    check(hashes[0] == hashes[1] and os.path.exists(os.path.join(tmp, "plain0", "timeseries.csv"))
          and not os.path.exists(os.path.join(tmp, "plain1", "timeseries.csv")),
          "output.timeseries=false: no timeseries.csv, the same trajectory_hash %s" % hashes)
    # a second sweep runs nothing; --retry-failed runs only the failed one
    r = sweep(ehpt, camp, "--out", out)
    check("0 to run" in r.stdout and r.returncode == 3, "again: nothing to run, still exit 3: %s" % r.stdout.strip())
    r = sweep(ehpt, camp, "--out", out, "--retry-failed")
    check("1 to run" in r.stdout, "--retry-failed runs the one failed run: %s" % r.stdout.strip())
    with open(os.path.join(out, "results.jsonl")) as f:
        lines = f.read().splitlines()
    docs = [json.loads(line) for line in lines]
    check(len(docs) == 4 and docs[0]["summary"]["soc_start"] is not None and docs[1]["summary"] is None
          and docs[1]["exit_code"] == 2 and docs[2]["overrides"] == {"vehicle.battery.soc_initial": 0.62,
                                                                      "solver.method": "implicit-euler"},
          "results.jsonl: one object per run, typed overrides, the summary or null")


def test_damaged_records(ehpt, tmp):
    """What is in DIR is checked, not trusted: a status without its run, a garbage status."""
    camp = write_campaign(tmp)
    out = os.path.join(tmp, "rec")
    r = sweep(ehpt, camp, "--out", out)
    rows, _ = results(out)
    shutil.rmtree(os.path.join(out, "runs", rows[0]["run_id"]))  # a run folder went missing
    with open(os.path.join(out, "status", rows[1]["run_id"] + ".txt"), "w") as f:
        f.write("exit 0.7\n")  # not an exit status
    r = sweep(ehpt, camp, "--out", out)
    check(r.returncode == 0 and "(14 done and 0 failed earlier), 2 to run" in r.stdout,
          "a status without its summary, and a damaged status, run again: %s" % r.stdout.strip())
    # a variant refused by a cross-field check (ecu.period_s is no whole multiple of this step)
    # fails alone, and a grid value refused the same way stops the campaign, naming its line
    with open(os.path.join(tmp, "st.csv"), "w") as f:
        f.write("solver.step_s\n0.001\n0.00051\n")
    st = os.path.join(tmp, "st.toml")
    with open(st, "w") as f:
        f.write('scenarios = ["psecu2_nedc"]\nvariants = "st.csv"\n[set]\n"solver.duration_s" = 5\n')
    r = sweep(ehpt, st, "--out", os.path.join(tmp, "st_out"))
    rows, _ = results(os.path.join(tmp, "st_out"))
    check(r.returncode == 3 and [x["sweep_status"] for x in rows] == ["ok", "failed"] and "ecu.period_s" in rows[1]["message"],
          "a variant refused by a cross-field check fails alone: %s" % [x["message"][:80] for x in rows])
    with open(st, "w") as f:
        f.write('scenarios = ["psecu2_nedc"]\n[grid]\n"solver.step_s" = [0.001, 0.00051]\n')
    r = sweep(ehpt, st, "--out", os.path.join(tmp, "st_out2"))
    check(r.returncode == 2 and "st.toml:3" in r.stderr and not os.path.exists(os.path.join(tmp, "st_out2")),
          "the same value in the grid: exit 2, the campaign's line named: %s" % r.stderr.strip()[:300])


def test_resume(ehpt, tmp):
    # runs of 200 s (tens of ms each), so that the kill lands mid-way even on a loaded machine
    camp = write_campaign(tmp, duration_s=200)
    clean = os.path.join(tmp, "clean")
    r = sweep(ehpt, camp, "--out", clean, "-j", "2")
    check(r.returncode == 0 and "16 runs: 16 ok" in r.stdout, "a clean 16-run sweep: %s" % r.stdout.strip())
    killed = os.path.join(tmp, "killed")
    # its own session, so that killing the group kills the sweep and the runs under way
    p = subprocess.Popen([ehpt, "sweep", camp, "--out", killed, "-j", "1"], stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL, start_new_session=True)
    status = os.path.join(killed, "status")

    def recorded():
        # the status files (<id>.txt), not a temporary one a kill left half written
        names = os.listdir(status) if os.path.isdir(status) else []
        return len([n for n in names if len(n) == 68 and n.endswith(".txt")])
    deadline = time.time() + 60
    while time.time() < deadline and recorded() < 4:
        time.sleep(0.005)
    os.killpg(p.pid, signal.SIGKILL)
    p.wait()
    done_before = recorded()
    check(4 <= done_before < 16, "killed midway with %d of 16 runs ended" % done_before)
    r = sweep(ehpt, camp, "--out", killed, "-j", "2")
    check(r.returncode == 0 and "%d to run" % (16 - done_before) in r.stdout,
          "the second sweep runs only the %d missing runs: %s" % (16 - done_before, r.stdout.strip()))
    a, ha = results(clean)
    b, hb = results(killed)
    check(ha == hb and a == b and len(a) == 16,
          "resumed results equal the clean run's (every field but wall times, bit for bit)")
    # SIGKILL to the sweep alone (an OOM kill): its runs end with it (they would otherwise hold
    # their folders' locks against the next sweep and be recorded as failed)
    alone = os.path.join(tmp, "alone")
    p = subprocess.Popen([ehpt, "sweep", camp, "--out", alone, "-j", "2"], stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL)
    status = os.path.join(alone, "status")
    deadline = time.time() + 60
    while time.time() < deadline and recorded() < 2:
        time.sleep(0.005)
    p.kill()
    p.wait()
    # its runs get SIGTERM from the kernel (PR_SET_PDEATHSIG) and end as interrupted runs within
    # milliseconds; until they have, their folders are rightly busy (not run, left pending)
    orphans = lambda: runs_of_sweep(p.pid)
    deadline = time.time() + 30
    while time.time() < deadline and orphans():
        time.sleep(0.01)
    check(not orphans(), "the runs of a SIGKILLed sweep end with it (still running: %s)" % orphans())
    r = sweep(ehpt, camp, "--out", alone, "-j", "2")
    check(r.returncode == 0 and "16 runs: 16 ok, 0 failed" in r.stdout,
          "after a SIGKILL of the sweep alone, the next sweep finishes every run: %s %s" % (r.stdout.strip(), r.stderr.strip()[-300:]))
    # and the status says what is done
    r = subprocess.run([ehpt, "sweep", "--status", killed], capture_output=True, text=True)
    check(r.returncode == 0 and "16 runs: 16 ok, 0 failed, 0 not done" in r.stdout, "--status: %s" % r.stdout.strip())


def test_changed_input(ehpt, tmp):
    # a scenario of our own whose cycle is a copy: one byte changed re-runs exactly its runs
    shutil.copy(os.path.join(SOURCE, "data/cycles/cycle_nedc.csv"), os.path.join(tmp, "cycle.csv"))
    with open(os.path.join(tmp, "mine.toml"), "w") as f:
        f.write('vehicle_file = "%s"\ncycle = "cycle.csv"\n' % os.path.join(SOURCE, "vehicles/mbev.toml"))
    camp = os.path.join(tmp, "changed.toml")
    with open(camp, "w") as f:
        f.write('scenarios = ["mine.toml", "psecu2_nedc"]\n[set]\n"solver.duration_s" = 20\n'
                '[grid]\n"vehicle.battery.soc_initial" = [0.5, 0.6, 0.7]\n')
    out = os.path.join(tmp, "changed")
    r = sweep(ehpt, camp, "--out", out)
    check(r.returncode == 0 and "6 to run" in r.stdout, "6 runs: %s" % r.stdout.strip())
    before, _ = results(out)
    with open(os.path.join(tmp, "cycle.csv"), "a") as f:
        f.write("# one more line\n")
    r = sweep(ehpt, camp, "--out", out)
    check(r.returncode == 0 and "6 runs (3 done and 0 failed earlier), 3 to run" in r.stdout,
          "one byte more in the cycle file: exactly its 3 runs again: %s" % r.stdout.strip())
    after, _ = results(out)
    check([x["run_id"] for x in before[3:]] == [x["run_id"] for x in after[3:]] and
          all(x["run_id"] != y["run_id"] for x, y in zip(before[:3], after[:3])),
          "new ids for the changed scenario's runs only")
    # the ids do not depend on where the files are: the same campaign from a copied folder
    copy = os.path.join(tmp, "copy")
    os.mkdir(copy)
    for n in ("mine.toml", "cycle.csv", "changed.toml"):
        shutil.copy(os.path.join(tmp, n), copy)
    r = sweep(ehpt, os.path.join(copy, "changed.toml"), "--out", os.path.join(copy, "out"))
    moved, _ = results(os.path.join(copy, "out"))
    check([x["run_id"] for x in moved] == [x["run_id"] for x in after],
          "the same files in another folder give the same run ids")


def test_bad_input(ehpt, tmp):
    camp = write_campaign(tmp, "bad_base.toml")
    # a folder that holds someone's files
    theirs = os.path.join(tmp, "project")
    os.mkdir(theirs)
    with open(os.path.join(theirs, "notes.txt"), "w") as f:
        f.write("mine\n")
    before = tree(theirs)
    r = sweep(ehpt, camp, "--out", theirs)
    check(r.returncode == 1 and "not an ehpt sweep folder" in r.stderr and tree(theirs) == before,
          "a folder of other files: exit 1, untouched: %s" % r.stderr.strip())
    # a folder that holds another campaign's sweep
    other = write_campaign(tmp, "other.toml")
    out = os.path.join(tmp, "other_out")
    r = sweep(ehpt, other, "--out", out)
    check(r.returncode == 0, "another campaign's sweep")
    before = tree(out)
    r = sweep(ehpt, camp, "--out", out)
    check(r.returncode == 1 and "another campaign" in r.stderr and tree(out) == before,
          "a folder of another campaign: exit 1, untouched: %s" % r.stderr.strip())
    # --executor slurm without sbatch: one line, nothing created
    env = dict(os.environ, PATH="/nonexistent")
    fresh = os.path.join(tmp, "never")
    r = sweep(ehpt, camp, "--out", fresh, "--executor", "slurm", env=env)
    check(r.returncode == 1 and "sbatch not found" in r.stderr and not os.path.exists(fresh)
          and len(r.stderr.strip().splitlines()) == 1, "no sbatch: one line, exit 1, no folder: %s" % r.stderr.strip())
    # campaign problems, each with file:line, before anything runs
    bad = os.path.join(tmp, "bad.toml")
    with open(bad, "w") as f:
        f.write('scenarios = ["ev_nedc", "no_such_scenario"]\ncolour = 3\n[grid]\n'
                '"vehicle.battery.soc_initial" = []\n"solver.step_s" = [0.001, "fast"]\n')
    r = sweep(ehpt, bad, "--out", fresh)
    for needle in ("bad.toml:1: scenarios: \"no_such_scenario\"", "bad.toml:2: colour: unknown key",
                   "bad.toml:4: grid.\"vehicle.battery.soc_initial\" = []: an empty grid",
                   "bad.toml:5: grid.\"solver.step_s\""):
        check(needle in r.stderr, "campaign problem reported: %s" % needle)
    check(r.returncode == 2 and not os.path.exists(fresh), "invalid campaign: exit 2, no folder")
    # a key no scenario has, and a value the model refuses, in the grid: before anything runs
    typo = os.path.join(tmp, "typo.toml")
    with open(typo, "w") as f:
        f.write('scenarios = ["ev_nedc"]\n[grid]\n"vehicle.battery.soc_initail" = [0.5]\n'
                '"vehicle.battery.soc_initial" = [0.5, 1.5]\n')
    r = sweep(ehpt, typo, "--out", fresh)
    check(r.returncode == 2 and "typo.toml:3 (vehicle.battery.soc_initail=0.5)" in r.stderr and "unknown key" in r.stderr
          and "typo.toml:4 (vehicle.battery.soc_initial=1.5)" in r.stderr and not os.path.exists(fresh),
          "an unknown key and a refused grid value, named at the campaign's line: %s" % r.stderr.strip()[:400])
    # the same with variants beside the grid: the grid's refused value still stops the campaign
    with open(os.path.join(tmp, "ok_variants.csv"), "w") as f:
        f.write("solver.method\nrk4\nimplicit-euler\n")
    mixed = os.path.join(tmp, "mixed.toml")
    with open(mixed, "w") as f:
        f.write('scenarios = ["ev_nedc"]\nvariants = "ok_variants.csv"\n[grid]\n'
                '"vehicle.battery.soc_initial" = [0.5, 1.5]\n')
    r = sweep(ehpt, mixed, "--out", fresh)
    check(r.returncode == 2 and "mixed.toml:4 (vehicle.battery.soc_initial=1.5)" in r.stderr and not os.path.exists(fresh),
          "a refused grid value beside valid variants: exit 2 before anything runs: %s" % r.stderr.strip()[:300])
    # a queue entry that is not a run id (it names a file under DIR/status): refused, no file
    q = os.path.join(out, "slurm")
    os.makedirs(q, exist_ok=True)
    with open(os.path.join(q, "queue.txt"), "w") as f:
        f.write("0 ../../victim\n")
    r = sweep(ehpt, other, "--out", out, "--shard", "0/1")
    check(r.returncode == 1 and "queue.txt:1" in r.stderr and not os.path.exists(os.path.join(tmp, "victim.txt")),
          "a hostile queue.txt: exit 1, nothing written outside: %s" % r.stderr.strip())
    # a symbolic link in place of DIR/status: refused, nothing written where it points
    victim = os.path.join(tmp, "victimdir")
    os.mkdir(victim)
    linked = os.path.join(tmp, "linked")
    sweep(ehpt, camp, "--out", linked)
    shutil.rmtree(os.path.join(linked, "status"))
    os.symlink(victim, os.path.join(linked, "status"))
    r = sweep(ehpt, camp, "--out", linked)
    check(r.returncode == 1 and "symbolic link" in r.stderr and os.listdir(victim) == [],
          "DIR/status a symbolic link: refused, its target untouched: %s" % r.stderr.strip())
    # a new DIR whose parent does not exist yet
    deep = os.path.join(tmp, "deep", "new", "dir")
    r = sweep(ehpt, camp, "--out", deep)
    check(r.returncode == 0 and os.path.isfile(os.path.join(deep, "results.csv")), "--out in folders that do not exist yet")
    r = sweep(ehpt, camp, "--out", fresh, "-j", "0")
    check(r.returncode == 1 and not os.path.exists(fresh), "-j 0: usage error, exit 1")


def test_plan(ehpt, tmp):
    camp = write_campaign(tmp, "plan.toml")
    before = tree(tmp)
    r = sweep(ehpt, camp, "--plan")
    check(r.returncode == 0 and "16 runs, every one valid; planned in " in r.stdout and "nothing was run" in r.stdout
          and tree(tmp) == before, "--plan: the count, exit 0, nothing written: %s" % (r.stdout + r.stderr).strip())
    # planned on several workers (398 runs, the first key outermost): the value refused in the
    # second half of the runs only (a later worker's block), reported once at the campaign's
    # line, exit 2, as the sweep itself reports it
    many = os.path.join(tmp, "many.toml")
    with open(many, "w") as f:
        f.write('scenarios = ["ev_nedc"]\n[grid]\n"vehicle.battery.soc_initial" = [0.5, 1.5]\n'
                '"solver.duration_s" = [%s]\n' % ", ".join(str(d) for d in range(1, 200)))
    before = tree(tmp)
    r = sweep(ehpt, many, "--plan")
    lines = [l for l in r.stderr.splitlines() if "many.toml:3 (vehicle.battery.soc_initial=1.5)" in l]
    check(r.returncode == 2 and len(lines) == 1 and "nothing was run" in r.stderr and tree(tmp) == before,
          "--plan over workers: the refused value once, exit 2: %s" % r.stderr.strip()[:300])
    fresh = os.path.join(tmp, "plan_out")
    r2 = sweep(ehpt, many, "--out", fresh)
    check(r2.returncode == 2 and r2.stderr == r.stderr and not os.path.exists(fresh),
          "... the same problems as the sweep gives, nothing created")
    r = sweep(ehpt, camp, "--plan", "--out", fresh)
    check(r.returncode == 1 and "--plan" in r.stderr and not os.path.exists(fresh), "--plan with --out: usage error, exit 1")
    # two scenario files of the same bytes are one run twice (one id): the campaign's problem,
    # said once, before anything runs
    src = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scenarios", "ev_nedc.toml")
    with open(src) as f:
        text = f.read()
    for d in ("a", "b"):
        os.makedirs(os.path.join(tmp, "twins", d), exist_ok=True)
        with open(os.path.join(tmp, "twins", d, "s.toml"), "w") as f:
            f.write(text.replace('"../', '"' + os.path.abspath(os.path.join(os.path.dirname(src), "..")) + "/"))
    twins = os.path.join(tmp, "twins", "c.toml")
    with open(twins, "w") as f:
        f.write('scenarios = ["a/s.toml", "b/s.toml"]\n[set]\n"solver.duration_s" = 5\n')
    for args in (["--plan"], ["--out", fresh]):
        r = sweep(ehpt, twins, *args)
        check(r.returncode == 2 and r.stderr.count("runs 0 and 1 are the same run") == 1 and not os.path.exists(fresh),
              "%s: two scenarios of the same bytes: exit 2, said once, nothing created: %s" % (args[0], r.stderr.strip()[:300]))


def test_plot(ehpt, tmp):
    camp = write_campaign(tmp, "plot.toml")
    out = os.path.join(tmp, "plot_out")
    r = sweep(ehpt, camp, "--out", out)
    check(r.returncode == 0, "a sweep to plot")
    for attempt in (1, 2):  # the second time, the figures of the first are replaced
        r = subprocess.run([ehpt, "plot", out], capture_output=True, text=True, timeout=300)
        figures = sorted(n for n in os.listdir(out) if n.endswith(".png"))
        check(r.returncode == 0 and "sweep_fuel_vs_soc_vehicle_battery_soc_initial.png" in figures,
              "ehpt plot on a sweep folder (%d): %s %s" % (attempt, figures, r.stderr.strip()[-300:]))


GROUPS = {"Plan": test_plan, "Failures": test_failures, "DamagedRecords": test_damaged_records, "Resume": test_resume, "ChangedInput": test_changed_input,
          "BadInput": test_bad_input, "Plot": test_plot}


def main(argv):
    ehpt = os.path.abspath(argv[1])
    groups = argv[2:] or list(GROUPS)
    for g in groups:
        with tempfile.TemporaryDirectory(prefix="ehpt-sweep-") as tmp:
            print("== %s" % g, flush=True)
            GROUPS[g](ehpt, tmp)
    print("%d failure(s)" % len(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
