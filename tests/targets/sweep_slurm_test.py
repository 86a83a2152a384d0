#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""`ehpt sweep --executor slurm` on a real one-node Slurm cluster (Debian's slurm-wlm and munge,
started by tools/slurm-cluster.sh in a temporary folder, private ports and munge socket).

Usage: /usr/bin/python3 tests/targets/sweep_slurm_test.py EHPT
Exit 0 pass, 1 fail, 77 skipped (the daemons cannot start on this machine: the reason is
printed). Every daemon the test started is stopped by its pid file, pass or fail.

Checks: a 16-run campaign with --shard-size 4 (4 array tasks) merges to the same results as
the local executor (every field but wall times, bit for bit); running it again submits
nothing; --no-wait then --status; an unknown partition is refused before anything is written
or submitted. Prints the overhead per array task (a figure, not asserted).
"""
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
import sweep_e2e_test as e2e  # noqa: E402  (the helpers: results(), write_campaign(), check())

CLUSTER = os.path.join(SOURCE, "tools", "slurm-cluster.sh")


def read_env(path):
    env = dict(os.environ)
    with open(path) as f:
        for line in f:
            line = line.strip()
            if line.startswith("export ") and "=" in line:
                k, v = line[len("export "):].split("=", 1)
                env[k] = v.strip("'\"")
    return env


def squeue_count(env):
    r = subprocess.run(["squeue", "-h", "-o", "%i"], env=env, capture_output=True, text=True, timeout=60)
    return len(r.stdout.split())


def run_checks(ehpt, tmp, env):
    check = e2e.check
    camp = e2e.write_campaign(tmp)
    local = os.path.join(tmp, "local")
    r = e2e.sweep(ehpt, camp, "--out", local, "-j", "2")
    check(r.returncode == 0, "the local executor's 16 runs")

    # an unknown partition: one line, exit 1, nothing written, nothing submitted
    never = os.path.join(tmp, "never")
    jobs_before = squeue_count(env)
    r = e2e.sweep(ehpt, camp, "--out", never, "--executor", "slurm", "--partition", "no_such_partition", env=env)
    check(r.returncode == 1 and "no such partition" in r.stderr and not os.path.exists(never)
          and len(r.stderr.strip().splitlines()) == 1 and squeue_count(env) == jobs_before,
          "unknown partition: exit 1, one line, no folder, no job: %s" % r.stderr.strip())

    slurm = os.path.join(tmp, "slurm")
    t0 = time.time()
    r = e2e.sweep(ehpt, camp, "--out", slurm, "--executor", "slurm", "--shard-size", "4", "--partition", "debug",
                  env=env, timeout=900)
    wall_slurm = time.time() - t0
    check(r.returncode == 0 and "16 runs in 4 array tasks" in r.stdout and "16 runs: 16 ok" in r.stdout,
          "16 runs as a job array of 4 tasks: %s %s" % (r.stdout.strip(), r.stderr.strip()[-400:]))
    tasks = sorted(n for n in os.listdir(os.path.join(slurm, "slurm")) if n.startswith("task-"))
    check(len(tasks) == 4, "4 array tasks ran (their output files): %s" % tasks)
    a, ha = e2e.results(local)
    b, hb = e2e.results(slurm)
    check(ha == hb and a == b and len(b) == 16,
          "Slurm's merged results equal the local executor's (every field but wall times)")
    # again: everything is done, nothing is submitted
    jobs_before = squeue_count(env)
    r = e2e.sweep(ehpt, camp, "--out", slurm, "--executor", "slurm", "--shard-size", "4", env=env)
    check(r.returncode == 0 and "0 to run" in r.stdout and "submitted" not in r.stdout and squeue_count(env) == jobs_before,
          "again: 0 to run, no job: %s" % r.stdout.strip())

    # --no-wait, then --status until the job has left the queue
    later = os.path.join(tmp, "later")
    r = e2e.sweep(ehpt, camp, "--out", later, "--executor", "slurm", "--shard-size", "8", "--no-wait",
                  "--max-parallel", "1", env=env)
    check(r.returncode == 0 and "2 array tasks" in r.stdout and "--status" in r.stdout,
          "--no-wait returns after submitting: %s" % r.stdout.strip())
    with open(os.path.join(later, "slurm", "job_id")) as f:
        job = f.read().strip()
    show = subprocess.run(["scontrol", "show", "job", job], env=env, capture_output=True, text=True, timeout=60)
    check("ArrayTaskThrottle=1" in show.stdout, "--max-parallel 1: the job array runs one task at a time (%s)" %
          [w for w in show.stdout.split() if w.startswith("ArrayTaskThrottle")])
    deadline = time.time() + 600
    status = None
    while time.time() < deadline:
        status = subprocess.run([ehpt, "sweep", "--status", later], env=env, capture_output=True, text=True, timeout=300)
        if "no longer queued" in status.stdout:
            break
        time.sleep(1)
    check(status is not None and status.returncode == 0 and "16 runs: 16 ok, 0 failed, 0 not done" in status.stdout,
          "--status after the job: every run ok, results merged: %s" % (status.stdout.strip() if status else None))
    c, hc = e2e.results(later)
    check(hc == ha and c == a, "the --no-wait sweep's merged results equal the local executor's")

    # the overhead per array task: 16 one-second runs as 16 tasks, against the same locally
    tiny = os.path.join(tmp, "tiny.toml")
    with open(tiny, "w") as f:
        f.write('scenarios = ["ev_nedc"]\n[set]\n"solver.duration_s" = 1\n'
                '[grid]\n"vehicle.battery.soc_initial" = [0.40, 0.42, 0.44, 0.46, 0.48, 0.50, 0.52, 0.54,'
                ' 0.56, 0.58, 0.60, 0.62, 0.64, 0.66, 0.68, 0.70]\n')
    t0 = time.time()
    e2e.sweep(ehpt, tiny, "--out", os.path.join(tmp, "tiny_local"), "-j", "1")
    wall_local = time.time() - t0
    t0 = time.time()
    r = e2e.sweep(ehpt, tiny, "--out", os.path.join(tmp, "tiny_slurm"), "--executor", "slurm", "--shard-size", "1",
                  env=env, timeout=900)
    wall_tasks = time.time() - t0
    check(r.returncode == 0, "16 one-second runs as 16 array tasks")
    print("figure: 16-run campaign: local -j2 vs Slurm 4 tasks: %.1f s (Slurm, incl. 2 s polls)" % wall_slurm)
    print("figure: Slurm overhead per array task: %.2f s (16 tasks of one tiny run: %.1f s; the same runs locally"
          " -j1: %.1f s)" % ((wall_tasks - wall_local) / 16, wall_tasks, wall_local))


def main(argv):
    ehpt = os.path.abspath(argv[1])
    with tempfile.TemporaryDirectory(prefix="ehpt-slurm-") as tmp:
        cluster = os.path.join(tmp, "cluster")
        os.mkdir(cluster)
        start = subprocess.run([CLUSTER, "start", cluster], capture_output=True, text=True, timeout=600)
        try:
            if start.returncode == 77:
                print("SKIP: the Slurm daemons cannot start here: " + start.stderr.strip())
                return 77
            if start.returncode != 0:
                print("FAIL: tools/slurm-cluster.sh start: exit %d: %s" % (start.returncode, start.stderr.strip()))
                return 1
            env = read_env(start.stdout.strip().splitlines()[-1])
            run_checks(ehpt, tmp, env)
        finally:
            stop = subprocess.run([CLUSTER, "stop", cluster], capture_output=True, text=True, timeout=120)
            e2e.check(stop.returncode == 0, "every daemon the test started is stopped: %s" % stop.stderr.strip())
    print("%d failure(s)" % len(e2e.failures))
    return 1 if e2e.failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
