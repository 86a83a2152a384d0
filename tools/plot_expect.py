#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""Draw one figure per failed expectation of an ehpt test run.

Usage: /usr/bin/python3 tools/plot_expect.py DIR [--out-dir OUT] [--quiet]

DIR holds timeseries.csv and summary.json of a run whose scenario has [[expect]] tables
(docs/testing.md). For every expectation of summary.json's "test" that did not hold and
bounds a signal, expect_<name>.png (the name with anything but letters, digits, - and _ as
_) shows the signal over time as recorded, its bound (min/max lines, or the band value ± tol
or other ± tol), the window it was judged over (shaded blue), the spans each fault acted
(shaded red, from the faults_active column), and where it failed (a red cross at the time
and value summary.json gives). Figures are written into OUT (default DIR). Exit 0 when every
figure was drawn (none when nothing failed), 1 on a problem (named on stderr).
"""
import csv
import json
import os
import re
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from plot import fault_spans as spans  # noqa: E402  (beside this file, installed with it)

LEGEND = dict(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize="small")


def load_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, data = rows[0], rows[1:]
    cols = {}
    for i, name in enumerate(header):
        cols[name] = np.array([float(r[i]) if r[i] else np.nan for r in data])
    return cols


def draw(cols, test, e):
    spec = e["spec"]
    sig = spec["signal"]
    t = cols["time_s"]
    fig, ax = plt.subplots(figsize=(10, 4.5))
    ax.plot(t, cols[sig], color="C0", lw=1.2, label=sig)
    if spec.get("other"):
        ref = cols[spec["other"]]
        ax.plot(t, ref, color="0.4", lw=0.8, ls="--", label=spec["other"])
        ax.fill_between(t, ref - spec["tol"], ref + spec["tol"], color="0.8", alpha=0.5,
                        label=f"{spec['other']} ± {spec['tol']:g}")
    elif spec.get("value") is not None:
        ax.axhspan(spec["value"] - spec["tol"], spec["value"] + spec["tol"], color="0.8", alpha=0.5,
                   label=f"{spec['value']:g} ± {spec['tol']:g}")
    for key, style in (("min", ":"), ("max", "--")):
        if spec.get(key) is not None:
            ax.axhline(spec[key], color="k", lw=1.0, ls=style, label=f"{key} {spec[key]:g}")
    w0, w1 = e.get("window_from_s"), e.get("window_to_s")
    if w0 is not None and w1 is not None:
        ax.axvspan(w0, w1, color="C0", alpha=0.07, label=f"window {spec['window']}")
    if "faults_active" in cols:
        for i, f in enumerate(test.get("faults", [])):
            for k, (a, b) in enumerate(spans(t, cols["faults_active"], i)):
                ax.axvspan(a, b, color="C3", alpha=0.12, label=f"fault {f['name']} ({f['kind']})" if k == 0 else None)
    if e.get("time_s") is not None and e.get("value") is not None:
        ax.plot([e["time_s"]], [e["value"]], "x", color="C3", ms=10, mew=2, label=f"failed at {e['time_s']:g} s")
    ax.set_xlabel("time [s]")
    ax.set_ylabel(sig)
    ax.set_title(f"{e['name']}: {spec['window']}", fontsize="medium")
    ax.grid(True, alpha=0.3)
    ax.legend(**LEGEND)
    fig.tight_layout()
    return fig


def main(argv):
    args = [a for a in argv if not a.startswith("--")]
    quiet = "--quiet" in argv
    out_dir = None
    if "--out-dir" in argv:
        i = argv.index("--out-dir")
        if i + 1 >= len(argv):
            print("--out-dir needs a folder", file=sys.stderr)
            return 1
        out_dir = argv[i + 1]
        args = [a for a in args if a != out_dir]
    if len(args) != 1:
        print(__doc__, file=sys.stderr)
        return 1
    src = args[0]
    out_dir = out_dir or src
    try:
        with open(os.path.join(src, "summary.json")) as f:
            test = json.load(f).get("test")
        if test is None:
            print(f"{src}/summary.json: not a test run (no \"test\")", file=sys.stderr)
            return 1
        failed = [e for e in test["expectations"] if not e["passed"] and e.get("spec", {}).get("signal")]
        if not failed:
            return 0
        cols = load_csv(os.path.join(src, "timeseries.csv"))
        for e in failed:
            missing = [c for c in ("time_s", e["spec"]["signal"], e["spec"].get("other")) if c and c not in cols]
            if missing:
                print(f"{src}/timeseries.csv: no column {missing[0]} for expectation {e['name']}", file=sys.stderr)
                return 1
            fig = draw(cols, test, e)
            name = "expect_" + re.sub(r"[^A-Za-z0-9_-]", "_", e["name"]) + ".png"
            fig.savefig(os.path.join(out_dir, name), dpi=100)
            plt.close(fig)
            if not quiet:
                print(f"figure        {os.path.join(out_dir, name)}")
    except (OSError, ValueError, KeyError) as err:
        print(f"{src}: {err}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
