#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""LCM sessions recorded with lcm-logger, checked with lcm_log_check, and replayed with
lcm-logplayer: the record + replay workflow of the README, end to end.

    /usr/bin/python3 tests/targets/lcm_log_test.py EHPT LCM_LOG_CHECK LCM_ECU_EXAMPLE

LCM udpm is multicast: the test re-executes itself under `unshare -n` (a private network
namespace, lo up, 224.0.0.0/4 routed to lo, ?ttl=0), so no packet can leave the host. The
replay runs in a second, nested namespace of its own, so what its logger records can only
come from lcm-logplayer. Exit 0 if every check passed, 1 otherwise; each check is printed.
"""

import csv
import json
import os
import pathlib
import signal
import struct
import subprocess
import sys
import tempfile
import time

URL = "udpm://239.255.76.67:7667?ttl=0"
# lcm-logplayer reads the log in a thread of its own and, at speed 1 (bursts of ~5000 messages
# a second), lost messages in 2 of 6 replays here while the kernel counted no UDP drop; at 0.2
# none in 10 (measured)
REPLAY_SPEED = float(os.environ.get("EHPT_LCM_REPLAY_SPEED", "0.2"))
SCENARIO = "ev_nedc"
DURATION_S = 10
SAMPLES = DURATION_S * 100 + 1  # a 10 ms ECU period, t = 0 .. 10 s both included
# NEDC stands still for its first 11 s (the driver asks for 0 Nm): the example ECU's commands are
# compared again on a run that drives
DRIVING_S = 30
NETNS_ENV = "EHPT_LCM_LOG_TEST_NETNS"
FAILURES = []
STARTED = []  # every process started, ended at exit if still running (a failed step leaves no logger)


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        FAILURES.append(what)
    return ok


def in_new_netns(argv):
    """This script with argv, in a new network namespace whose lo carries multicast."""
    env = dict(os.environ, **{NETNS_ENV: "1"})
    setup = 'ip link set lo up && ip route add 224.0.0.0/4 dev lo && exec "$@"'
    return subprocess.run(["unshare", "-n", "sh", "-c", setup, "netns", sys.executable] + argv, env=env).returncode


def start(args, log_dir, name):
    """A process whose output goes to files (a full pipe must never stall a lockstep run)."""
    out = open(pathlib.Path(log_dir) / (name + ".out"), "w+")
    err = open(pathlib.Path(log_dir) / (name + ".err"), "w+")
    p = subprocess.Popen(args, stdout=out, stderr=err, text=True)
    p.files = (out, err)
    STARTED.append(p)
    return p


def finish(p, timeout_s=120):
    try:
        p.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        p.kill()
        p.wait()
    for f in p.files:
        f.seek(0)
    return p.returncode, p.files[0].read(), p.files[1].read()


def start_logger(log, log_dir, name):
    """lcm-logger on every channel (its default .*); given time to subscribe before traffic."""
    # ahead of the lockstep pair in the scheduler (root may raise it): a bystander that falls
    # behind loses messages inside liblcm
    nice = ["nice", "-n", "-10"] if os.geteuid() == 0 else []
    p = start(nice + ["lcm-logger", "--quiet", "--force", "--lcm-url=" + URL, str(log)], log_dir, name)
    time.sleep(0.5)
    if p.poll() is not None:
        raise AssertionError("lcm-logger ended at once: " + finish(p)[2])
    return p


def stop_logger(p):
    """SIGINT: lcm-logger writes out what it has and closes the log."""
    time.sleep(0.3)  # the last messages are in its socket buffer: let it take them
    p.send_signal(signal.SIGINT)
    return finish(p, 20)


def read_lcm_log(path):
    """An LCM event log -> [(channel, payload)] (the format of lcm/eventlog.c, big endian)."""
    data, events, i = pathlib.Path(path).read_bytes(), [], 0
    while i < len(data):
        sync, _num, _utime, clen, dlen = struct.unpack_from(">IqqII", data, i)
        assert sync == 0xEDA1DA01, "bad sync word at %d" % i
        i += 28
        events.append((data[i:i + clen].decode(), data[i + clen:i + clen + dlen]))
        i += clen + dlen
    return events


def write_lcm_log(path, events):
    with open(path, "wb") as f:
        for n, (channel, payload) in enumerate(events):
            c = channel.encode()
            f.write(struct.pack(">IqqII", 0xEDA1DA01, n, 1_000_000 + n, len(c), len(payload)) + c + payload)
    return path


def csv_rows(out):
    with open(out / "timeseries.csv", newline="") as f:
        return list(csv.DictReader(f))


def log_check(tool, log):
    r = subprocess.run([tool, str(log), "EHPT_"], capture_output=True, text=True, timeout=60)
    return r.returncode, r.stdout.strip(), r.stderr.strip()


def session(ehpt, tool, ecu_args, tmp, name, duration_s=DURATION_S, attempts=5, logged=True):
    """One lockstep session recorded by lcm-logger: the ECU first (LCM has no connections, an ECU
    that is late makes the plant re-send sample 0), then the plant. -> (plant dir, log, ECU stdout)
    lcm-logger is a bystander nothing waits for: on a busy host liblcm (1.3.1) dropped messages
    inside it (measured: 21 in a row, none counted by the kernel as UDP drops). A session whose
    plant took every command but whose log is short is therefore recorded again (said so).
    logged=False: a session that only compares timeseries, with no logger (and no log checks)."""
    n = duration_s * 100 + 1
    expected = "status %d command %d first_step 0 last_step %d" % (n, n, (n - 1) * 10)
    for attempt in range(1, attempts + 1):
        log, out = tmp / ("%s-%d.lcmlog" % (name, attempt)), tmp / ("%s-%d" % (name, attempt))
        logger = start_logger(log, tmp, "%s-%d-logger" % (name, attempt)) if logged else None
        t0 = time.monotonic()
        ecu = start(ecu_args, tmp, "%s-%d-ecu" % (name, attempt))
        time.sleep(0.3)
        plant = subprocess.run([ehpt, "plant", SCENARIO, "--bus", "lcm:" + URL, "--lockstep", "--quiet", "--out",
                                str(out), "--set", "solver.duration_s=%d" % duration_s],
                               capture_output=True, text=True, timeout=60)
        t_plant = time.monotonic() - t0
        ecu_rc, ecu_out, ecu_err = finish(ecu)
        t_ecu = time.monotonic() - t0
        bus = json.loads((out / "summary.json").read_text())["bus"] if (out / "summary.json").exists() else {}
        if not logged:
            break
        logger_rc, _, logger_err = stop_logger(logger)
        rc, line, err = log_check(tool, log)
        plant_clean = plant.returncode == 0 and bus.get("messages_out") == n and bus.get("commands_applied") == n
        if (rc != 0 or line != expected) and plant_clean and attempt < attempts:
            print("     %s: the plant took all %d commands but lcm-logger's log is short ('%s' %s): recorded "
                  "again" % (name, n, line, err))
            continue
        break
    print("     %s: plant done after %.2f s, ECU after %.2f s (its idle timeout included)" % (name, t_plant, t_ecu))
    check(plant.returncode == 0, "%s: ehpt plant exits 0 (%s)" % (name, plant.stderr.strip()[-300:]))
    check(ecu_rc == 0, "%s: the ECU exits 0 (%s)" % (name, (ecu_out + ecu_err).strip()[-300:]))
    if not logged:
        return out, None, ecu_out
    check(logger_rc == 0 and log.exists(), "%s: lcm-logger wrote %s (%s)" % (name, log.name, logger_err.strip()))
    check(rc == 0 and line == expected, "%s: lcm_log_check: '%s' (expected '%s') %s" % (name, line, expected, err))
    counts = line.split()
    got = (int(counts[1]), int(counts[3])) if len(counts) == 8 else None
    want = (bus.get("messages_out"), bus.get("commands_applied"))
    check(got == want, "%s: the log's status/command counts %s = the plant's summary.json bus "
          "messages_out/commands_applied %s" % (name, got, want))
    return out, log, ecu_out


def checker_rejects(tool, good_log, tmp):
    """lcm_log_check itself: each kind of broken log (made from a good one) is refused."""
    events = read_lcm_log(good_log)
    status = [i for i, (c, _) in enumerate(events) if c == "EHPT_PLANT_STATUS"]
    command = [i for i, (c, _) in enumerate(events) if c == "EHPT_ECU_COMMAND"]
    # a sample from 5000 on whose answer is logged right after it (the delivery may swap a few)
    k = next(k for k in range(500, SAMPLES) if command[k] == status[k] + 1)
    s500, c500 = status[k], command[k]

    def patched(i, field, value):  # a payload with an int64 field replaced (0: utime, 1: step, 2: session)
        channel, data = events[i]
        off = 8 + 8 * field  # after the type's 8-byte fingerprint
        return channel, data[:off] + struct.pack(">q", value) + data[off + 8:]

    def utime(i):
        return struct.unpack_from(">q", events[i][1], 8)[0]

    def session(i):
        return struct.unpack_from(">q", events[i][1], 24)[0]

    swapped = events[:s500] + [events[c500], events[s500]] + events[c500 + 1:]
    cases = {
        "a status sample missing": [e for i, e in enumerate(events) if i != status[500]],
        "a status sample twice (not sample 0)": events[:s500 + 1] + [events[s500]] + events[s500 + 1:],
        "a status payload one byte short": [(c, d[:-1] if i == status[7] else d) for i, (c, d) in enumerate(events)],
        "a command payload with a byte too many": [(c, d + b"\0" if i == command[7] else d)
                                                   for i, (c, d) in enumerate(events)],
        "a command answering the sample after the next": [patched(i, 1, 10 * k + 20) if i == c500 else e
                                                           for i, e in enumerate(events)],
        "a command logged and sent before its sample": events[:s500] + [patched(c500, 0, utime(s500) - 1),
                                                                        events[s500]] + events[c500 + 1:],
        "a last command without its sample": [e for i, e in enumerate(events) if i != status[-1]],
        "a command naming another plant session": [patched(i, 2, session(c500) ^ 1) if i == c500 else e
                                                   for i, e in enumerate(events)],
        "a status sample of another plant session": [patched(i, 2, session(s500) ^ 1) if i == s500 else e
                                                     for i, e in enumerate(events)],
        "samples naming no plant session": [patched(i, 2, 0) if c == "EHPT_PLANT_STATUS" else (c, d)
                                            for i, (c, d) in enumerate(events)],
    }
    rc, line, err = log_check(tool, write_lcm_log(tmp / "swapped.lcmlog", swapped))
    check(rc == 0 and line.startswith("status %d command %d " % (SAMPLES, SAMPLES)) and "logged just before" in err,
          "lcm_log_check takes a command logged just before its sample but sent after it (as the loopback "
          "delivers at times): '%s' %s" % (line, err))
    for what, broken in cases.items():
        path = tmp / "broken.lcmlog"
        write_lcm_log(path, broken)
        rc, line, err = log_check(tool, path)
        check(rc == 1 and err, "lcm_log_check refuses %s: exit %d, '%s'" % (what, rc, err))
    # and the log rewritten unchanged passes, with sample 0 re-sent as the plant does when no
    # ECU has answered yet
    write_lcm_log(tmp / "resent.lcmlog", [events[status[0]]] + events)
    rc, line, err = log_check(tool, tmp / "resent.lcmlog")
    check(rc == 0 and line.startswith("status %d command %d " % (SAMPLES + 1, SAMPLES)),
          "lcm_log_check takes a re-sent sample 0: '%s' %s" % (line, err))


def replay_main(log, replay_log):
    """In the second namespace: a fresh lcm-logger records what lcm-logplayer plays."""
    tmp = pathlib.Path(replay_log).parent
    logger = start_logger(replay_log, tmp, "replay-logger")
    t0 = time.monotonic()
    player = subprocess.run(["lcm-logplayer", "--speed=%g" % REPLAY_SPEED, "--lcm-url=" + URL, str(log)], capture_output=True, text=True,
                            timeout=120)
    print("     replay: lcm-logplayer --speed=%g took %.2f s" % (REPLAY_SPEED, time.monotonic() - t0))
    logger_rc, _, logger_err = stop_logger(logger)
    ok = player.returncode == 0 and logger_rc == 0
    if not ok:
        print("lcm-logplayer: %d %s; lcm-logger: %d %s" % (player.returncode, player.stderr, logger_rc, logger_err))
    return 0 if ok else 1


def test_main(ehpt, tool, example):
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="lcm_log_test-"))
    print("     in a private network namespace; files in %s" % tmp)
    sets = ["--set", "solver.duration_s=%d" % DURATION_S]

    # 1. ehpt plant + ehpt ecu, recorded
    ehpt_out, log, _ = session(ehpt, tool, [ehpt, "ecu", SCENARIO, "--bus", "lcm:" + URL, "--idle-timeout-s", "1"]
                               + sets, tmp, "ehpt_ecu")

    # 2. the same with the C++ example ECU: the same commands, so the same run, bit for bit
    ex_out, ex_log, ex_stdout = session(ehpt, tool, [example, "--url", URL, "--idle-timeout-s", "1"], tmp,
                                        "example_ecu")
    check(ex_stdout.startswith("lcm_ecu: %d samples answered, last step %d " % (SAMPLES, (SAMPLES - 1) * 10)),
          "example ECU's summary: '%s'" % ex_stdout.strip())
    same = (ehpt_out / "timeseries.csv").read_bytes() == (ex_out / "timeseries.csv").read_bytes()
    check(same, "timeseries.csv with the example ECU == with ehpt ecu (byte for byte)")
    ref = tmp / "run"
    r = subprocess.run([ehpt, "run", SCENARIO, "--quiet", "--out", str(ref)] + sets, capture_output=True, text=True,
                       timeout=120)
    check(r.returncode == 0 and (ref / "timeseries.csv").read_bytes() == (ex_out / "timeseries.csv").read_bytes(),
          "... == ehpt run's, with no bus (byte for byte)")
    # besides ehpt's channels, a log holds liblcm's own LCM_SELF_TEST (each udpm client's start-up probe)
    ours = [c for c, _ in read_lcm_log(ex_log) if c.startswith("EHPT_")]
    others = sorted({c for c, _ in read_lcm_log(ex_log)} - set(ours))
    check(len(ours) == 2 * SAMPLES and set(others) <= {"LCM_SELF_TEST"},
          "the example session's log: %d messages on EHPT_ channels (expected %d), other channels %s"
          % (len(ours), 2 * SAMPLES, others))

    # 2b. ... and on a run that drives: = ehpt run; with --torque-limit-Nm the reference is limited
    long_sets = ["--set", "solver.duration_s=%d" % DRIVING_S]
    ref = tmp / "run_driving"
    r = subprocess.run([ehpt, "run", SCENARIO, "--quiet", "--out", str(ref)] + long_sets, capture_output=True,
                       text=True, timeout=120)
    drive_out, _, _ = session(ehpt, tool, [example, "--url", URL, "--idle-timeout-s", "1"], tmp, "example_driving",
                              DRIVING_S, logged=False)
    check(r.returncode == 0 and (ref / "timeseries.csv").read_bytes() == (drive_out / "timeseries.csv").read_bytes(),
          "%d s (driving): timeseries.csv with the example ECU == ehpt run's (byte for byte)" % DRIVING_S)
    lim_out, _, _ = session(ehpt, tool, [example, "--url", URL, "--idle-timeout-s", "1", "--torque-limit-Nm", "50"],
                            tmp, "example_limited", DRIVING_S, logged=False)
    ask = [float(row["driver_request_Nm"]) for row in csv_rows(drive_out)]
    got = [float(row["drive_torque_ref_Nm"]) for row in csv_rows(lim_out)]
    check(max(map(abs, ask)) > 50 and max(map(abs, got)) <= 50 and max(map(abs, got)) > 49,
          "--torque-limit-Nm 50: the driver asks up to %.1f Nm, the reference reaches %.1f Nm"
          % (max(map(abs, ask)), max(map(abs, got))))

    # 2c. two plants on one URL and prefix, one example ECU that answers every sample it hears
    # naming its plant's session: each plant takes only its own commands (the other plant's are
    # counted as foreign), so each equals its own `ehpt run`; and each says the bus was shared
    # UDP multicast on a loaded host can lose a message (measured in CI: one lockstep wait of
    # ev_sort1 timed out, its sample then in the safe state): such a session is run again, said so
    for attempt in range(1, 4):
        two, results = {}, {}
        ecu = start([example, "--url", URL, "--idle-timeout-s", "2"], tmp, "two_plants_ecu_%d" % attempt)
        time.sleep(0.3)
        for scenario in ("ev_nedc", "ev_sort1"):
            two[scenario] = start([ehpt, "plant", scenario, "--bus", "lcm:" + URL, "--lockstep", "--quiet", "--out",
                                   str(tmp / ("two_%s_%d" % (scenario, attempt)))] + long_sets, tmp,
                                  "two_plants_%s_%d" % (scenario, attempt))
        for scenario, p in two.items():
            results[scenario] = finish(p)
        finish(ecu)
        lost = [sc for sc, (_, _, err) in results.items() if "lockstep wait" in err]
        if not lost or attempt == 3:
            break
        print("     two plants on one URL: a lockstep wait of %s timed out (a multicast message lost): run again"
              % ", ".join(lost))
    for scenario, (rc, _, err) in results.items():
        ref = tmp / ("two_ref_" + scenario)
        subprocess.run([ehpt, "run", scenario, "--quiet", "--out", str(ref)] + long_sets, capture_output=True,
                       timeout=120)
        out = tmp / ("two_%s_%d" % (scenario, attempt))
        bus = json.loads((out / "summary.json").read_text())["bus"] if (out / "summary.json").exists() else {}
        foreign = bus.get("rejected", {}).get("foreign", 0)
        check(rc == 4 and "commands named another plant session on this URL and prefix" in err,
              "two plants on one URL: %s ends degraded (exit 4) naming the shared bus: exit %d, '%s'"
              % (scenario, rc, err.strip()[-300:]))
        check(foreign > 0 and bus.get("commands_applied") == DRIVING_S * 100 + 1,
              "two plants on one URL: %s took its %d commands and ignored %d of the other plant's"
              % (scenario, bus.get("commands_applied", 0), foreign))
        check((ref / "timeseries.csv").read_bytes() == (out / "timeseries.csv").read_bytes(),
              "two plants on one URL: %s's timeseries == its own ehpt run's (byte for byte)" % scenario)

    # 3. the checker refuses what it must
    checker_rejects(tool, log, tmp)

    # 4. replay the first session's log in a second namespace, recorded afresh
    # (the recording lcm-logger is a bystander that can lose messages on a busy host, as in
    # session(): a replay whose log is short is replayed again, said so, at most 5 times)
    for attempt in range(1, 6):
        replay_log = tmp / ("replayed-%d.lcmlog" % attempt)
        rc = in_new_netns([os.path.abspath(__file__), "--replay", str(log), str(replay_log)])
        if rc != 0 or not replay_log.exists() or read_lcm_log(log) == read_lcm_log(replay_log) or attempt == 5:
            break
        print("     replay: the replayed log is short (%s): replayed again" % log_check(tool, replay_log)[1])
    check(rc == 0 and replay_log.exists(), "lcm-logplayer replayed the log in a second namespace, lcm-logger "
          "recorded it")
    if replay_log.exists():
        a, b = log_check(tool, log), log_check(tool, replay_log)
        check(b[0] == 0 and a[1] == b[1], "lcm_log_check on the replayed log: '%s' (the recorded one: '%s')"
              % (b[1], a[1]))
        check(read_lcm_log(log) == read_lcm_log(replay_log),
              "the replayed log holds the recorded events: channels and payloads, in order")
    return 1 if FAILURES else 0


def main():
    if os.environ.get(NETNS_ENV) != "1":
        if subprocess.run(["unshare", "-n", "true"], capture_output=True).returncode != 0:
            print("skipped: cannot create a network namespace (unshare -n needs root or user namespaces)")
            return 77  # ctest: skipped
        rc = in_new_netns([os.path.abspath(__file__)] + sys.argv[1:])
        print("lcm_log_test: " + ("passed" if rc == 0 else "FAILED"))
        return rc
    if sys.argv[1:2] == ["--replay"]:
        return replay_main(sys.argv[2], sys.argv[3])
    if len(sys.argv) != 4:
        print(__doc__)
        return 1
    try:
        rc = test_main(*[os.path.abspath(a) for a in sys.argv[1:]])
    except Exception as e:  # a broken step: report it as a failure, not a traceback only
        check(False, "%s: %s" % (type(e).__name__, e))
        rc = 1
    finally:
        for p in STARTED:
            if p.poll() is None:
                p.kill()
                p.wait()
    if FAILURES:
        print("%d check(s) failed" % len(FAILURES))
    return rc


if __name__ == "__main__":
    sys.exit(main())
