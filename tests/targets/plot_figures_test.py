#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""tools/plot.py's figures for every vehicle family, drawn from short real runs.

    /usr/bin/python3 tests/targets/plot_figures_test.py EHPT SOURCE_DIR

For one scenario per family (bev, ev_pm, ev_am, psd, both drive rigs, battery_rig,
pm_drive_test, am_drive_test: `ehpt run` with a small solver.duration_s) and a synthetic
sweep folder, checked:
- plot.py recognises the family, and the PNG files it writes are exactly the family's line
  of `plot.py --list-figures`;
- on the matplotlib figures themselves (plot.py imported as a module, draw_run and
  sweep_figures): no legend's box (display coordinates) is crossed by any plotted line
  segment or point of any axes of its figure, and every legend lies inside the figure;
- every axis label naming SOC reads "SOC [%]", its data lie in [0, 100] and are the CSV's
  soc (or the sweep's soc_end) times 100, not the fraction;
- every axis label's unit is SI as the column suffixes say (a fixed set: m/s, N m, rad/s,
  kW, V, A, g, %, 0/1, ...);
- a run with output.timeseries = false: one error line naming the folder (as --as says)
  and the key, exit 1, nothing written;
- docs/figures.md names, per family, exactly the figures of --list-figures, and every image
  it shows exists as a PNG.
Exit 0 if every check passed, 1 otherwise; each check is printed.
"""

import csv
import importlib.util
import json
import os
import re
import subprocess
import sys
import tempfile

import matplotlib.cbook
import matplotlib.collections
import matplotlib.lines
import numpy as np

EHPT, SRC = sys.argv[1], sys.argv[2]
PLOT_PY = os.path.join(SRC, "tools", "plot.py")
DOCS = os.path.join(SRC, "docs", "figures.md")
FAILURES = []
# family -> (scenario, solver.duration_s): short, but long enough for every figure's columns
RUNS = {
    "bev": [("ev_sort1", 30)],
    "ev_pm": [("evpm_sort1", 30)],
    "ev_am": [("evam_sort1", 30)],
    "psd": [("psecu2_nedc", 200)],  # the engine starts at ~145 s
    "drive_rig": [("one_flange_test", 50), ("two_flange_test", 50)],
    "battery_rig": [("battery_cc_discharge", 60)],
    "genset_rig": [("genset_test2", 5), ("genset_test_oo", 8)],
    "shev": [("shev_oo_sort1", 300)],  # the genset starts at 267.3 s
    "pm_drive_test": [("test_pm_drive", 0.5)],
    "am_drive_test": [("test_am_drive", 0.5)],
}
# the units an axis label may carry: SI as the columns' suffixes (kW: the W columns / 1000)
UNITS = {"s", "m/s", "N m", "rad/s", "kW", "V", "A", "g", "%", "0/1", "L/100 km", "Wh/km"}
UNITLESS = {"limiter state", "sample"}


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        FAILURES.append(what)
    return ok


def import_plot():
    spec = importlib.util.spec_from_file_location("ehpt_plot", PLOT_PY)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def listed_figures():
    """{family: [file, ...]} from `plot.py --list-figures`."""
    r = subprocess.run(["/usr/bin/python3", PLOT_PY, "--list-figures"], capture_output=True, text=True,
                       stdin=subprocess.DEVNULL, timeout=120)
    check(r.returncode == 0 and r.stderr == "", f"--list-figures exits 0 quietly (rc {r.returncode}, {r.stderr!r})")
    out = {}
    for line in r.stdout.splitlines():
        family, _, files = line.partition(":")
        out[family.strip()] = files.split()
    return out


def documented_figures(path):
    """{family: set of `x.png` named in its section}: a section is a '## ' heading naming
    the family in backticks, up to the next '## ' heading; images (![..](..)) are not names."""
    out, family = {}, None
    with open(path) as f:
        for line in f:
            if line.startswith("## "):
                names = re.findall(r"`([a-z_]+)`", line)
                family = names[-1] if names else None
                if family:
                    out.setdefault(family, set())
                continue
            if family:
                out[family].update(re.findall(r"`([A-Za-z0-9_<>.-]+\.png)`", line))
    return out


def drawn_path(line):
    """The line's vertices in display coordinates, as drawn (steps expanded)."""
    xy = np.asarray(line.get_xydata(), dtype=float)
    if len(xy) == 0:
        return xy
    style = line.get_drawstyle()
    if style in matplotlib.cbook.STEP_LOOKUP_MAP and style != "default":
        x, y = matplotlib.cbook.STEP_LOOKUP_MAP[style](xy[:, 0], xy[:, 1])
        xy = np.column_stack([x, y])
    return line.get_transform().transform(xy)


def segments_cross(p, box):
    """True if a segment between consecutive points of p (or a lone point) meets box
    (x0, y0, x1, y1).  Liang-Barsky clipping, vectorised; NaN breaks the line."""
    x0, y0, x1, y1 = box
    if len(p) == 1:
        p = np.vstack([p, p])
    a, b = p[:-1], p[1:]
    ok = np.all(np.isfinite(a), axis=1) & np.all(np.isfinite(b), axis=1)
    a, b = a[ok], b[ok]
    d = b - a
    t_in, t_out = np.zeros(len(a)), np.ones(len(a))
    hit = np.ones(len(a), dtype=bool)
    for step, room in ((-d[:, 0], a[:, 0] - x0), (d[:, 0], x1 - a[:, 0]),
                       (-d[:, 1], a[:, 1] - y0), (d[:, 1], y1 - a[:, 1])):
        hit &= ~((step == 0) & (room < 0))  # parallel to this edge and outside it
        with np.errstate(divide="ignore", invalid="ignore"):
            r = room / step
        t_in = np.where(step < 0, np.maximum(t_in, r), t_in)
        t_out = np.where(step > 0, np.minimum(t_out, r), t_out)
    return bool(np.any(hit & (t_in <= t_out)))


def intersect(box, clip):
    x0, y0 = max(box.x0, clip.x0), max(box.y0, clip.y0)
    x1, y1 = min(box.x1, clip.x1), min(box.y1, clip.y1)
    return (x0, y0, x1, y1) if x0 < x1 and y0 < y1 else None


def check_legends(where, fig):
    """No legend over any drawn data of its figure; every legend inside the figure."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    fbox = fig.bbox
    for leg in legends:
        box = leg.get_window_extent(renderer)
        inside = box.x0 >= fbox.x0 - 1 and box.y0 >= fbox.y0 - 1 and box.x1 <= fbox.x1 + 1 and box.y1 <= fbox.y1 + 1
        over = []
        for ax in fig.axes:
            for art in ax.get_children():
                if not art.get_visible():
                    continue
                clip = art.get_clip_box() if art.get_clip_on() and art.get_clip_box() is not None else fbox
                area = intersect(box, clip)
                if area is None:
                    continue
                if isinstance(art, matplotlib.lines.Line2D):
                    p = drawn_path(art)
                    if len(p) and segments_cross(p, area):
                        over.append(art.get_label())
                elif isinstance(art, matplotlib.collections.PathCollection):
                    pts = art.get_offset_transform().transform(art.get_offsets())
                    if any(area[0] <= x <= area[2] and area[1] <= y <= area[3] for x, y in pts):
                        over.append("scatter points")
        labels = [t.get_text() for t in leg.get_texts()]
        check(not over, f"{where}: legend {labels} covers no data (over: {over})")
        check(inside, f"{where}: legend {labels} lies inside the figure")
    return len(legends)


def axis_labels(fig):
    """(axes, 'x' or 'y', label) for every labelled axis."""
    for ax in fig.axes:
        for which, label in (("x", ax.get_xlabel()), ("y", ax.get_ylabel())):
            if label:
                yield ax, which, label


def check_units(where, fig):
    for _, _, label in axis_labels(fig):
        m = re.search(r"\[([^\]]*)\]$", label)
        check((m is not None and m.group(1) in UNITS) or label in UNITLESS,
              f"{where}: axis label {label!r} has an SI unit as the columns")


def check_soc(where, fig, soc_percent):
    """Every SOC axis: labelled 'SOC [%]', data in [0, 100] and = soc_percent (the truth)."""
    count = 0
    for ax, which, label in axis_labels(fig):
        if not re.search(r"soc", label, re.I):
            continue
        count += 1
        check("SOC [%]" in label, f"{where}: SOC axis label {label!r} reads 'SOC [%]'")
        i = 1 if which == "y" else 0
        data = [np.asarray(line.get_xydata(), float)[:, i] for line in ax.get_lines() if len(line.get_xydata())]
        data += [np.asarray(c.get_offsets(), float)[:, i] for c in ax.collections if len(c.get_offsets())]
        values = np.concatenate(data) if data else np.array([])
        values = values[np.isfinite(values)]
        check(len(values) > 0 and values.min() >= 0.0 and values.max() <= 100.0 and values.max() > 1.0,
              f"{where}: {label!r} data lie in [0, 100] % (got {values.min() if len(values) else None}"
              f" .. {values.max() if len(values) else None})")
        matches = any(len(d) == len(soc_percent) and np.allclose(d, soc_percent, equal_nan=True) for d in data)
        check(matches, f"{where}: {label!r} draws the run's SOC × 100")
    return count


def write_sweep(folder):
    """A small sweep folder as `ehpt sweep` writes it: two scenarios x soc_ref."""
    os.makedirs(folder)
    with open(os.path.join(folder, "sweep.json"), "w") as f:
        json.dump({"format": "ehpt sweep folder 1", "campaign": "/campaigns/tiny.toml"}, f)
    soc_end = []
    with open(os.path.join(folder, "results.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["run_id", "scenario", "ecu.soc_ref", "sweep_status", "exit_code", "message", "status",
                    "soc_start", "soc_end", "fuel_L_per_100km", "battery_Wh_per_km"])
        for i, (scenario, ref) in enumerate((s, r) for s in ("hyb", "ev") for r in ("0.6", "0.7")):
            end = (0.55 if scenario == "hyb" else 0.45) + 0.5 * (float(ref) - 0.6)
            soc_end.append(end)
            fuel = 4.0 + 10 * (float(ref) - 0.6) if scenario == "hyb" else 0.0
            w.writerow([f"{i:064x}", scenario, ref, "ok", "0", "", "ok", "0.6", end, fuel, 150.0 + 20 * i])
    return np.array(soc_end) * 100.0


def main():
    plot = import_plot()
    listed = listed_figures()
    families = set(plot.FAMILIES) | {"sweep"}
    check(set(listed) == families, f"--list-figures names every family (got {sorted(listed)})")
    with tempfile.TemporaryDirectory() as root:
        for family, runs in RUNS.items():
            for scenario, duration in runs:
                run = os.path.join(root, scenario)
                r = subprocess.run([EHPT, "run", os.path.join(SRC, "scenarios", scenario + ".toml"), "--quiet",
                                    "--set", f"solver.duration_s={duration}", "--out", run],
                                   capture_output=True, text=True, stdin=subprocess.DEVNULL, timeout=300)
                if not check(r.returncode == 0, f"{scenario}: ehpt run exits 0 ({r.stderr.strip()[-300:]!r})"):
                    continue
                out = os.path.join(root, scenario + "_figures")
                os.makedirs(out)
                r = subprocess.run(["/usr/bin/python3", PLOT_PY, run, "--out-dir", out, "--quiet"],
                                   capture_output=True, text=True, stdin=subprocess.DEVNULL, timeout=300)
                pngs = sorted(n for n in os.listdir(out) if n.endswith(".png"))
                check(r.returncode == 0 and pngs == sorted(listed.get(family, [])),
                      f"{scenario}: the PNGs written are the {family} line of --list-figures "
                      f"(wrote {pngs}, listed {listed.get(family)}, rc {r.returncode}, {r.stderr.strip()!r})")

                cols = plot.load_csv(os.path.join(run, "timeseries.csv"))
                got, figures = plot.draw_run(cols, scenario)
                check(got == family, f"{scenario}: recognised as {family} (got {got})")
                check([n for n, _ in figures] == listed.get(family),
                      f"{scenario}: draw_run gives the listed figures in order ({[n for n, _ in figures]})")
                socs = 0
                for name, fig in figures:
                    where = f"{scenario}/{name}"
                    check_legends(where, fig)
                    check_units(where, fig)
                    if "soc" in cols:
                        socs += check_soc(where, fig, cols["soc"] * 100.0)
                    plot.plt.close(fig)
                if "soc" in cols:
                    check(socs > 0, f"{scenario}: some figure shows the SOC ({socs} axes)")

        # a run without a timeseries: one error line naming the folder as --as says (ehpt
        # passes the user's folder there) and the key to change; nothing written
        bare, shown = os.path.join(root, "no_timeseries"), "/home/user/my run"
        r = subprocess.run([EHPT, "run", os.path.join(SRC, "scenarios", "ev_sort1.toml"), "--quiet", "--set",
                            "solver.duration_s=2", "--set", "output.timeseries=false", "--out", bare],
                           capture_output=True, text=True, stdin=subprocess.DEVNULL, timeout=300)
        before = sorted(os.listdir(bare)) if r.returncode == 0 else None
        r = subprocess.run(["/usr/bin/python3", PLOT_PY, bare, "--out-dir", bare, "--as", shown],
                           capture_output=True, text=True, stdin=subprocess.DEVNULL, timeout=300)
        lines = r.stderr.strip().splitlines()
        check(r.returncode == 1 and len(lines) == 1 and lines[0].startswith(f"plot.py: error: {shown}: ")
              and "output.timeseries = false" in lines[0] and "Traceback" not in r.stderr
              and sorted(os.listdir(bare)) == before,
              f"output.timeseries = false: exit 1, one line naming {shown!r} and the key, nothing written "
              f"(rc {r.returncode}, {r.stderr.strip()!r})")

        # a run with faults: every figure over time shades the span each fault acted (from
        # faults_active), named once in its legend, and the legend still covers no data; the
        # same run without faults shades nothing
        for faults in ([], ["kind=no_start at_s=10 until_s=30", "kind=offset target=batSOC offset=0.01 at_s=40"]):
            run = os.path.join(root, "faulted" if faults else "unfaulted")
            argv = [EHPT, "run", os.path.join(SRC, "scenarios", "psecu2_nedc.toml"), "--quiet", "--set",
                    "solver.duration_s=60", "--out", run]
            for f in faults:
                argv += ["--fault", f]
            r = subprocess.run(argv, capture_output=True, text=True, stdin=subprocess.DEVNULL, timeout=300)
            if not check(r.returncode == 0, f"faults {faults}: ehpt run exits 0 ({r.stderr.strip()[-300:]!r})"):
                continue
            cols = plot.load_csv(os.path.join(run, "timeseries.csv"))
            test = plot.load_summary(os.path.join(run, "summary.json")).get("test", {})
            _, figures = plot.draw_run(cols, "psecu2_nedc", test.get("faults", []))
            for name, fig in figures:
                # every panel (each of a psd figure's axes runs over time): its shaded spans
                spans = [{(round(np.asarray(p.get_xy())[:, 0].min(), 3), round(np.asarray(p.get_xy())[:, 0].max(), 3))
                          for p in ax.patches} for ax in fig.axes]
                first = fig.axes[0].get_legend_handles_labels()[1]
                if faults:
                    want = {(10.0, 30.0), (40.0, 60.0)}
                    check(all(s == want for s in spans) and
                          "fault fault1 (no_start)" in first and "fault fault2 (offset)" in first,
                          f"faulted/{name}: each of its {len(spans)} panels shades [10, 30] s and [40, 60] s, "
                          f"named in the legend ({spans}, {first})")
                    check_legends(f"faulted/{name}", fig)
                else:
                    check(not any(spans) and not any(l.startswith("fault ") for l in first),
                          f"unfaulted/{name}: nothing shaded ({spans})")
                plot.plt.close(fig)

        sweep = os.path.join(root, "sweep")
        truth = write_sweep(sweep)
        figures = plot.sweep_figures(sweep)
        check([n for n, _ in figures] == ["sweep_fuel_vs_soc_ecu_soc_ref.png"],
              f"sweep: one figure per swept key ({[n for n, _ in figures]})")
        for name, fig in figures:
            check(check_legends(f"sweep/{name}", fig) > 0, f"sweep/{name}: has its legend")
            check_units(f"sweep/{name}", fig)
            socs = 0
            for ax in fig.axes:  # one panel per scenario: compare each with its runs
                if "SOC" in ax.get_xlabel():
                    mine = truth[:2] if ax.get_title() == "hyb" else truth[2:]
                    socs += 1
                    offsets = np.concatenate([np.asarray(c.get_offsets())[:, 0] for c in ax.collections])
                    check("SOC [%]" in ax.get_xlabel() and np.allclose(np.sort(offsets), np.sort(mine)),
                          f"sweep/{name} {ax.get_title()}: x is final SOC [%] = soc_end × 100 "
                          f"({ax.get_xlabel()!r}: {offsets})")
            check(socs == 2, f"sweep/{name}: two SOC panels ({socs})")
        template = listed.get("sweep", [])
        check(any(re.fullmatch(re.escape(t).replace(re.escape("<key>"), "[A-Za-z0-9_-]+"), n)
                  for n, _ in figures for t in template), f"sweep: the file name matches {template}")

    documented = documented_figures(DOCS)
    for family in sorted(families):
        check(documented.get(family) == set(listed.get(family, [])),
              f"docs/figures.md names exactly the {family} figures (docs {sorted(documented.get(family, []))}, "
              f"listed {listed.get(family)})")
    check(set(documented) == families, f"docs/figures.md has a section per family and no other ({sorted(documented)})")
    with open(DOCS) as f:
        images = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", f.read())
    check(len(images) >= len(families), f"docs/figures.md shows an example image per family ({len(images)})")
    total = 0
    for img in images:
        path = os.path.join(os.path.dirname(DOCS), img)
        ok = os.path.isfile(path)
        if ok:
            with open(path, "rb") as f:
                ok = f.read(8) == b"\x89PNG\r\n\x1a\n"
            total += os.path.getsize(path)
        check(ok, f"docs/figures.md: {img} is a PNG")
    check(total < 1_500_000, f"docs/figures.md's images total {total} bytes < 1.5 MB")
    print("PASS" if not FAILURES else f"FAIL: {len(FAILURES)} check(s)")
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main())
