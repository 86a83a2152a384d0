#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""tools/plot.py on a sweep folder (`ehpt sweep`'s sweep.json + results.csv): the fuel vs
final SOC figures, one per swept key, drawn from a small synthetic campaign.

    /usr/bin/python3 tests/targets/plot_sweep_test.py [PLOT_PY]

PLOT_PY defaults to tools/plot.py of this source tree.  The campaign: a hybrid and an EV
(no fuel: battery Wh/km instead) x ecu.soc_ref (3 values) x ecu.on_W (2 values), one run
failed (with part of a summary) and one ok run without values.  Checked: the expected PNGs
and only those, valid and not trivially small; the two figures differ; the same campaign
with other results gives other pixels (a figure without its points would not), and so do
other battery Wh/km for the EV alone (drawn on y in place of its zero fuel); the failed
run's values are not drawn (same pixels without them); no swept key gives one figure; a
folder whose every run failed writes nothing and exits non-zero with one error line.
Exit 0 if every check passed, 1 otherwise; each check is printed.
"""

import csv
import json
import os
import pathlib
import subprocess
import sys
import tempfile

import matplotlib.image
import numpy as np

PLOT = sys.argv[1] if len(sys.argv) > 1 else str(pathlib.Path(__file__).resolve().parents[2] / "tools" / "plot.py")
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
FAILURES = []

SUMMARY = ["status", "scenario", "soc_start", "soc_end", "fuel_g", "fuel_L_per_100km",
           "battery_Wh_per_km", "energy_audit.fuel_chemical_J"]


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        FAILURES.append(what)
    return ok


def write_sweep(folder, keys, runs, campaign="/campaigns/synthetic_cal.toml"):
    """A sweep folder as `ehpt sweep` writes it; runs: (scenario, key values, status, summary)."""
    os.makedirs(folder)
    with open(os.path.join(folder, "sweep.json"), "w") as f:
        json.dump({"format": "ehpt sweep folder 1", "campaign": campaign}, f)
    with open(os.path.join(folder, "results.csv"), "w", newline="") as f:
        w = csv.writer(f)
        # the summary's own "scenario" repeats the column name, as in real results
        w.writerow(["run_id", "scenario"] + keys + ["sweep_status", "exit_code", "message"] + SUMMARY)
        for i, (scenario, values, status, summary) in enumerate(runs):
            w.writerow([f"{i:064x}", scenario] + values
                       + [status, "0" if status == "ok" else ("1" if status == "failed" else ""),
                          "run ended with status 1" if status == "failed" else ""]
                       + [summary.get(k, "") for k in SUMMARY])


def campaign_runs(shift=0.0, failed_values=True, ev_y=0.0):
    """The synthetic campaign; shift moves every result (same keys, other points), ev_y only the
    EV's battery Wh/km; failed_values=False empties the failed run's partial summary."""
    runs = []
    for scenario in ("hyb_nedc", "ev_nedc"):
        for soc_ref in ("0.6", "0.65", "0.7"):
            for on_w in ("6000", "10000"):
                d = float(soc_ref) - 0.6
                if scenario == "hyb_nedc":
                    summary = {"soc_end": 0.57 + 0.9 * d - 2 * shift + (0.004 if on_w == "6000" else 0.0),
                               "fuel_L_per_100km": 4.0 + 12.0 * d + 3 * shift + (0.2 if on_w == "6000" else 0.0),
                               "battery_Wh_per_km": 5.0 - 200.0 * d, "fuel_g": 400.0}
                else:  # an EV: fuel columns all zero
                    summary = {"soc_end": 0.5 - 0.2 * d - shift, "fuel_L_per_100km": 0, "fuel_g": 0,
                               "battery_Wh_per_km": 150.0 + 100.0 * d + 30 * shift
                               + (5.0 if on_w == "6000" else 0.0) + ev_y}
                summary.update(status="ok", scenario=scenario, soc_start=0.6 if scenario == "hyb_nedc" else 0.5,
                               **{"energy_audit.fuel_chemical_J": 1.0e7})
                runs.append((scenario, [soc_ref, on_w], "ok", summary))
    # hyb_nedc 0.65 x 10000 failed after writing part of its summary (wild values, not to be drawn)
    runs[3] = (runs[3][0], runs[3][1], "failed", dict(soc_end=0.9, fuel_L_per_100km=30.0) if failed_values else {})
    runs[8] = (runs[8][0], runs[8][1], "ok", dict(runs[8][3], soc_end=""))  # ok, but no final SOC
    return runs


def plot(src, out):
    os.makedirs(out, exist_ok=True)
    return subprocess.run([sys.executable, PLOT, src, "--out-dir", out], capture_output=True, text=True,
                          stdin=subprocess.DEVNULL, timeout=300)


def pngs(out):
    return sorted(n for n in os.listdir(out) if n.endswith(".png"))


def valid_png(path):
    with open(path, "rb") as f:
        head = f.read(8)
    return head == PNG_MAGIC and os.path.getsize(path) > 20000


def differ(a, b):
    """True if the two PNGs have different pixels (fraction of pixels that differ > 0.1 %)."""
    x, y = matplotlib.image.imread(a), matplotlib.image.imread(b)
    if x.shape != y.shape:
        return True
    return np.mean(np.any(np.abs(x - y) > 1e-3, axis=-1)) > 1e-3


def main():
    keys = ["ecu.soc_ref", "ecu.on_W"]
    expected = ["sweep_fuel_vs_soc_ecu_on_W.png", "sweep_fuel_vs_soc_ecu_soc_ref.png"]
    with tempfile.TemporaryDirectory() as src_root, tempfile.TemporaryDirectory() as out_root:
        a, b = os.path.join(src_root, "a"), os.path.join(src_root, "b")
        write_sweep(a, keys, campaign_runs())
        write_sweep(b, keys, campaign_runs(shift=0.02))
        out_a, out_b = os.path.join(out_root, "a"), os.path.join(out_root, "b")

        r = plot(a, out_a)
        check(r.returncode == 0, f"plot.py on the sweep folder exits 0 (got {r.returncode}; {r.stderr.strip()!r})")
        check(pngs(out_a) == expected, f"it writes {expected} (got {pngs(out_a)})")
        check(all(f"wrote {os.path.join(out_a, n)}" in r.stdout.splitlines() for n in expected),
              f"it names every figure it wrote (stdout {r.stdout.strip()!r})")
        check(not any(n.endswith(".png") for n in os.listdir(a)), "nothing is written into DIR with --out-dir")
        for n in pngs(out_a):
            check(valid_png(os.path.join(out_a, n)), f"{n} is a PNG of more than 20 kB")
        if pngs(out_a) == expected:
            check(differ(*(os.path.join(out_a, n) for n in expected)),
                  "the two keys' figures differ in their pixels")

        r = plot(b, out_b)
        check(r.returncode == 0 and pngs(out_b) == expected, "the shifted campaign draws the same figures")
        for n in expected:
            pa, pb = os.path.join(out_a, n), os.path.join(out_b, n)
            if os.path.exists(pa) and os.path.exists(pb):
                check(differ(pa, pb), f"{n}: other results give other pixels (the runs are drawn)")

        # the failed run's partial values are not drawn: the same pixels without them
        e, out_e = os.path.join(src_root, "e"), os.path.join(out_root, "e")
        write_sweep(e, keys, campaign_runs(failed_values=False))
        r = plot(e, out_e)
        check(r.returncode == 0 and pngs(out_e) == expected and pngs(out_a) == expected
              and not any(differ(os.path.join(out_a, n), os.path.join(out_e, n)) for n in expected),
              "a failed run's values are not drawn")

        # the EV's points sit at its battery Wh/km (its fuel is zero whatever the Wh/km)
        f, out_f = os.path.join(src_root, "f"), os.path.join(out_root, "f")
        write_sweep(f, keys, campaign_runs(ev_y=40.0))
        r = plot(f, out_f)
        check(r.returncode == 0 and pngs(out_f) == expected and pngs(out_a) == expected
              and all(differ(os.path.join(out_a, n), os.path.join(out_f, n)) for n in expected),
              "an EV is drawn at its battery Wh/km (other Wh/km, other pixels)")

        # one run per scenario, no swept key: one figure coloured by scenario
        c, out_c = os.path.join(src_root, "c"), os.path.join(out_root, "c")
        write_sweep(c, [], [(s, [], "ok", dict(v, scenario=s)) for s, _, st, v in campaign_runs()
                            if st == "ok" and v["soc_end"] != ""][::6])
        r = plot(c, out_c)
        check(r.returncode == 0 and pngs(out_c) == ["sweep_fuel_vs_soc.png"]
              and valid_png(os.path.join(out_c, "sweep_fuel_vs_soc.png")),
              f"no swept key: one sweep_fuel_vs_soc.png (exit {r.returncode}, {pngs(out_c)}, {r.stderr.strip()!r})")

        # every run failed (or pending): nothing written, one error line, exit non-zero
        d, out_d = os.path.join(src_root, "d"), os.path.join(out_root, "d")
        write_sweep(d, keys, [(s, v, "failed", dict(sm, status="failed")) for s, v, _, sm in campaign_runs()[:-1]]
                    + [("ev_nedc", ["0.7", "10000"], "pending", {})])
        r = plot(d, out_d)
        lines = r.stderr.strip().splitlines()
        check(r.returncode != 0, f"all runs failed: exit status non-zero (got {r.returncode})")
        check(pngs(out_d) == [] and os.listdir(out_d) == [], f"all runs failed: nothing written (got {os.listdir(out_d)})")
        check(len(lines) == 1 and lines[0].startswith("plot.py: error:") and "Traceback" not in r.stderr,
              f"all runs failed: one error line on stderr (got {r.stderr.strip()!r})")
    print("PASS" if not FAILURES else f"FAIL: {len(FAILURES)} check(s)")
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main())
