#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""Draw PNG figures from an ehpt run folder.

Usage: /usr/bin/python3 tools/plot.py DIR [--out-dir OUT] [--as NAME] [--quiet] [--dpi N]
       /usr/bin/python3 tools/plot.py --list-figures

Figures are written into OUT (default DIR); messages name them as if in NAME (default
OUT): ehpt draws into a private folder and moves the figures into place itself.
DIR must hold timeseries.csv (header of column names, then numeric rows) and usually
summary.json.  The columns tell the vehicle family (one per vehicle kind: bev, ev_pm, ev_am,
psd, shev, drive_rig, battery_rig, genset_rig, pm_drive_test, am_drive_test); FAMILIES below names each
family's figures and the function that draws each.  A figure whose columns are absent from
the CSV (a run with a chosen output.signals) is skipped silently.  --list-figures prints one
line per family: the family, a colon, its figure files (docs/figures.md describes them).

A sweep folder (DIR/sweep.json, written by `ehpt sweep`) is drawn from DIR/results.csv
instead (one row per run: run_id, scenario, the swept keys, sweep_status, exit_code,
message, then the run's summary.json flattened): for each swept key K,
sweep_fuel_vs_soc_<K, dots as _>.png plots fuel [L/100 km] against final SOC, one panel per
scenario, each run coloured by its value of K (battery Wh/km instead of fuel for a scenario
that burns none, e.g. an EV); with no swept key, one sweep_fuel_vs_soc.png coloured by
scenario.  Runs that are not ok are not drawn (the title counts them); with none to draw,
nothing is written and the exit status is 1.

Conventions, the same in every figure: SI units as the column suffixes say (speed in m/s,
torque in N m, angular speed in rad/s; power in kW, the W column / 1000); SOC and efficiency
in % (axis label "SOC [%]"); every legend outside its axes, to the right, so it never hides
a curve; a run with faults shades the spans each acted (faults_active, names from
summary.json's test.faults) on every panel over time.  As a module: draw_run(cols, scenario) and sweep_figures(src) return the finished
matplotlib figures without writing them (the tests inspect those).
"""
import csv
import json
import math
import os
import re
import sys
import tempfile

import matplotlib
matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt
import numpy as np

LIMIT_STATES = ["torque", "power", "speed ramp", "over speed"]
# columns only the drive rigs write (the hybrids share the bus names genTauRef_Nm etc.)
RIG_COLUMNS = {"tauElectrical_Nm", "limit_state", "limitingTorque", "power_mech_W", "power_dc_W",
               "efficiency", "load_torque_Nm"}
# every legend sits just right of its axes, top-aligned: never over a curve
LEGEND = dict(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize="small")
DEFAULT_DPI = 100


class PlotError(Exception):
    pass


# -------------------------------------------------------------------- reading a run folder
def load_csv(path):
    """Return {column name: float array}; unparsable fields become NaN."""
    if not os.path.exists(path):
        raise PlotError(f"{path}: file not found")
    if not os.path.isfile(path):
        raise PlotError(f"{path}: not a regular file")
    try:
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise PlotError(f"{path}: cannot read as CSV ({e})")
    rows = [r for r in rows if r and any(x.strip() for x in r)]
    if not rows:
        raise PlotError(f"{path}: file is empty")
    header = [h.strip() for h in rows[0]]
    data, skipped = [], 0
    for r in rows[1:]:
        if len(r) != len(header):  # e.g. a truncated last line
            skipped += 1
            continue
        try:
            data.append([float(x) for x in r])
        except ValueError:
            vals = []
            for x in r:
                try:
                    vals.append(float(x))
                except ValueError:
                    vals.append(float("nan"))
            data.append(vals)
    if skipped:
        print(f"plot.py: warning: {path}: skipped {skipped} row(s) with wrong field count",
              file=sys.stderr)
    if not data:
        raise PlotError(f"{path}: no data rows")
    arr = np.array(data, dtype=float)
    arr[np.isinf(arr)] = np.nan  # inf would wreck the axis autoscaling
    return {name: arr[:, i] for i, name in enumerate(header) if name}


def load_summary(path):
    """Return the summary dict, or {} if it is missing or unreadable."""
    try:
        with open(path) as f:
            s = json.load(f)
        return s if isinstance(s, dict) else {}
    except (OSError, ValueError):
        return {}


def fault_spans(t, bits, bit):
    """[(t0, t1)] where bit is set in the faults_active column (a test's fault i: bit i)."""
    on = (np.nan_to_num(bits).astype(np.int64) & (1 << bit)) != 0
    out, start = [], None
    for k in range(len(t)):
        if on[k] and start is None:
            start = t[k]
        if not on[k] and start is not None:
            out.append((start, t[k]))
            start = None
    if start is not None:
        out.append((start, t[-1]))
    return out


FAULT_COLORS = ["tab:red", "tab:purple", "tab:brown", "tab:pink", "tab:olive", "tab:cyan"]


class Run:
    """One run's columns, its time axis and the title prefix; makes the stacked figures.
    faults: summary.json's test.faults ([{"name", "kind", ...}], bit i of faults_active is
    fault i): each figure over time shades the spans they acted."""

    def __init__(self, cols, scenario="", faults=None):
        self.c, self.scenario, self.faults = cols, scenario, list(faults or [])
        self.time_axes = {}  # id(figure) -> its axes over time (those figure() made)
        if "time_s" in cols:
            self.t, self.tlabel = cols["time_s"], "time [s]"
        else:
            n = len(next(iter(cols.values()), []))
            self.t, self.tlabel = np.arange(n, dtype=float), "sample"

    def has(self, *names):
        return all(n in self.c for n in names)

    def first(self, *names):
        """Name of the first of names present in the CSV, else None."""
        return next((n for n in names if n in self.c), None)

    def title(self, text):
        return f"{self.scenario}: {text}" if self.scenario else text

    def figure(self, nrows, title, ratios=None, height=6.0):
        """Figure with nrows stacked axes sharing the time axis; the first is the tallest."""
        ratios = ratios or [2] + [1] * (nrows - 1)
        fig, axes = plt.subplots(nrows, 1, figsize=(11, height), dpi=DEFAULT_DPI, sharex=True,
                                 squeeze=False, gridspec_kw={"height_ratios": ratios})
        axes = list(axes[:, 0])
        fig.suptitle(self.title(title))
        for ax in axes:
            ax.grid(True, alpha=0.4)
        axes[-1].set_xlabel(self.tlabel)
        self.time_axes[id(fig)] = axes
        return fig, axes

    def shade_faults(self, fig):
        """The spans each active fault acted, shaded on every panel of a figure over time and
        named once in its first panel's legend (nothing when no fault acted)."""
        axes = self.time_axes.get(id(fig), [])
        bits = self.c.get("faults_active")
        if not axes or bits is None or not np.any(np.nan_to_num(bits)):
            return
        count = max(len(self.faults), int(np.nan_to_num(bits).max()).bit_length())
        for ax in axes:
            xlim = ax.get_xlim()  # a span must not widen the axis
            for i in range(count):
                f = self.faults[i] if i < len(self.faults) else {}
                label = f"fault {f.get('name', i + 1)} ({f.get('kind', 'active')})"
                for k, (a, b) in enumerate(fault_spans(self.t, bits, i)):
                    ax.axvspan(a, b, color=FAULT_COLORS[i % len(FAULT_COLORS)], alpha=0.12, lw=0,
                               label=label if k == 0 and ax is axes[0] else None)
            ax.set_xlim(xlim)

    # panels more than one figure draws
    def torque_panel(self, ax, req, deliv, lim, ylabel="torque [N m]"):
        """Request (wide, pale: visible under an equal delivered torque), delivered, ±limit."""
        c, t = self.c, self.t
        if req in c:
            ax.plot(t, c[req], color="tab:orange", lw=4, alpha=0.45, label=f"request ({req})")
        if deliv in c:
            ax.plot(t, c[deliv], color="tab:blue", label=f"delivered ({deliv})")
        if lim in c:
            ax.plot(t, c[lim], "--", color="tab:red", label=f"limit ± ({lim})")
            ax.plot(t, -c[lim], "--", color="tab:red")
        ax.set_ylabel(ylabel)

    def limit_state_panel(self, ax, name):
        ax.step(self.t, self.c[name], where="post", color="tab:purple", label=name)
        ax.set_yticks(range(len(LIMIT_STATES)))
        ax.set_yticklabels(LIMIT_STATES)
        ax.set_ylim(-0.3, len(LIMIT_STATES) - 0.7)
        ax.set_ylabel("limiter state")

    def speed_panel(self, ax):
        c, t = self.c, self.t
        if "speed_ref_m_s" in c:
            ax.plot(t, c["speed_ref_m_s"], "--", color="tab:gray", label="wanted (speed_ref_m_s)")
        if "speed_m_s" in c:
            ax.plot(t, c["speed_m_s"], color="tab:blue", label="actual (speed_m_s)")
        ax.set_ylabel("speed [m/s]")

    def soc_panel(self, ax):
        ax.plot(self.t, self.c["soc"] * 100.0, color="tab:green", label="SOC (soc × 100)")
        ax.set_ylabel("SOC [%]")
        ax.ticklabel_format(axis="y", useOffset=False)

    def flag_panel(self, ax, name, ylabel, color):
        ax.step(self.t, self.c[name], where="post", color=color, label=name)
        ax.set_yticks([0, 1])
        ax.set_ylim(-0.15, 1.15)
        ax.set_ylabel(ylabel)


# -------------------------------------------------------------------- every vehicle
def speed_figure(r):
    """Wanted vs actual speed, and the error when both are present."""
    if not r.first("speed_m_s", "speed_ref_m_s"):
        return None
    both = r.has("speed_m_s", "speed_ref_m_s")
    fig, axes = r.figure(2 if both else 1, "vehicle speed")
    r.speed_panel(axes[0])
    if both:
        axes[1].plot(r.t, r.c["speed_m_s"] - r.c["speed_ref_m_s"], color="tab:red",
                     label="actual − wanted")
        axes[1].set_ylabel("speed error [m/s]")
    return fig


def soc_figure(r):
    """State of charge, and the terminal voltage against the EMF."""
    if "soc" not in r.c:
        return None
    volt = "battery_voltage_V" in r.c
    fig, axes = r.figure(2 if volt else 1, "battery state of charge")
    r.soc_panel(axes[0])
    if volt:
        axes[1].plot(r.t, r.c["battery_voltage_V"], color="tab:orange", label="terminal voltage")
        if "battery_emf_V" in r.c:
            axes[1].plot(r.t, r.c["battery_emf_V"], "--", color="tab:gray", label="EMF")
        axes[1].set_ylabel("voltage [V]")
    return fig


def locked_figure(r):
    """The locked (stuck at standstill) flag under the speed it belongs to."""
    if "locked" not in r.c:
        return None
    speed = r.first("speed_m_s", "speed_ref_m_s") is not None
    fig, axes = r.figure(2 if speed else 1, "vehicle locked at standstill",
                         [2, 1] if speed else [1])
    if speed:
        r.speed_panel(axes[0])
    r.flag_panel(axes[-1], "locked", "locked [0/1]", "tab:red")
    return fig


# -------------------------------------------------------------------- EVs (bev, ev_pm, ev_am)
def drive_torque_figure(r):
    """Requested vs delivered torque with the ± limit, and the limiter state."""
    if not r.first("driver_request_Nm", "drive_torque_Nm", "drive_torque_limit_Nm"):
        return None
    state = "drive_limit_state" in r.c
    fig, axes = r.figure(2 if state else 1, "drive torque")
    r.torque_panel(axes[0], "driver_request_Nm", "drive_torque_Nm", "drive_torque_limit_Nm")
    if state:
        r.limit_state_panel(axes[1], "drive_limit_state")
    return fig


def drive_power_figure(r):
    """Mechanical vs electrical drive power, and the battery's terminal power."""
    lines = [(n, lbl, ls) for n, lbl, ls in (("drive_power_mech_W", "drive mechanical", "-"),
                                             ("drive_power_dc_W", "drive electrical (DC)", "-"),
                                             ("battery_power_W", "battery terminal", "--"))
             if n in r.c]
    if not lines:
        return None
    fig, axes = r.figure(1, "power")
    for n, lbl, ls in lines:  # dashed battery line: it often sits on the DC line
        axes[0].plot(r.t, r.c[n] / 1000.0, ls, label=lbl)
    axes[0].set_ylabel("power [kW]")
    return fig


def pm_machine_figure(r):
    """EvPm_bat (PMDrive): dq currents, the voltage and where the flux is weakened."""
    if not r.has("id_A", "iq_A"):
        return None
    c, t = r.c, r.t
    volt = "voltage_peak_V" in c
    fig, axes = r.figure(2 if volt else 1, "PM machine: dq currents and voltage")
    axes[0].plot(t, c["id_A"], label="Id")
    axes[0].plot(t, c["iq_A"], label="Iq")
    axes[0].set_ylabel("current, peak [A]")
    if volt:
        axes[1].plot(t, c["voltage_peak_V"], color="tab:purple", label="|V| (peak phase)")
        if "weakening" in c:
            w = np.where(c["weakening"] > 0.5, c["voltage_peak_V"], np.nan)
            axes[1].plot(t, w, color="tab:red", lw=3, alpha=0.5, label="flux weakening")
        axes[1].set_ylabel("voltage [V]")
    return fig


def am_machine_figure(r):
    """EvAm_bat (AMDrive): stator current, slip frequency and voltage."""
    if not r.has("i1_rms_A", "slip_rad_s"):
        return None
    c, t = r.c, r.t
    fig, axes = r.figure(3, "induction machine: current, slip and voltage")
    axes[0].plot(t, c["i1_rms_A"], label="stator current |I1| (rms)")
    axes[0].set_ylabel("current [A]")
    axes[1].plot(t, c["slip_rad_s"], color="tab:orange", label="slip frequency dWe")
    axes[1].set_ylabel("slip [rad/s]")
    if "u1_rms_V" in c:
        axes[2].plot(t, c["u1_rms_V"], color="tab:purple", label="terminal |U1| (rms)")
    if "emf_rms_V" in c:
        axes[2].plot(t, c["emf_rms_V"], "--", color="tab:gray", label="E (rms)")
    axes[2].set_ylabel("voltage [V]")
    return fig


# -------------------------------------------------------------------- power-split hybrids (psd)
def hybrid_torque_figure(r):
    """Engine torque; gen and mot each with request, delivered torque and ± limit."""
    panels = [p for p in (("ice_torque_Nm",), ("genTauRef_Nm", "gen_torque_Nm", "genTauLim_Nm"),
                          ("motTauRef_Nm", "mot_torque_Nm", "motTauLim_Nm"))
              if r.first(*p)]
    if not panels:
        return None
    fig, axes = r.figure(len(panels), "engine, generator and motor torques", [1] * len(panels))
    for ax, p in zip(axes, panels):
        if p[0] == "ice_torque_Nm":
            ax.plot(r.t, r.c["ice_torque_Nm"], color="tab:brown", label="engine (ice_torque_Nm)")
            ax.set_ylabel("engine [N m]")
        else:
            r.torque_panel(ax, *p, ylabel=f"{p[1][:3]} [N m]")
    return fig


def hybrid_machine_power_figure(r):
    """gen and mot, one panel each: mechanical power τ·ω (> 0 driving) against the DC power
    each draws; the battery's terminal power (the sum of the two DC powers) below."""
    panels = []
    for m in ("gen", "mot"):
        lines = []
        if r.has(f"{m}_torque_Nm", f"{m}W_rad_s"):
            lines.append((r.c[f"{m}_torque_Nm"] * r.c[f"{m}W_rad_s"], "mechanical (τ·ω)", "-"))
        if f"{m}_power_dc_W" in r.c:
            lines.append((r.c[f"{m}_power_dc_W"], f"electrical (DC, {m}_power_dc_W)", "--"))
        if lines:
            panels.append((f"{m} power [kW]", lines))
    if "battery_power_W" in r.c:
        panels.append(("battery [kW]", [(r.c["battery_power_W"], "terminal (battery_power_W)", "-")]))
    if not panels:
        return None
    fig, axes = r.figure(len(panels), "machine power: mechanical vs electrical", [1] * len(panels),
                         height=1.0 + 2.0 * len(panels))
    for ax, (ylabel, lines) in zip(axes, panels):
        for y, lbl, ls in lines:
            ax.plot(r.t, y / 1000.0, ls, label=lbl)
        ax.set_ylabel(ylabel)
    return fig


def hybrid_figure(r):
    """Wanted vs actual speed; engine speed; engine ON flag; SOC (the paper's Figs. 21/23)."""
    panels = [n for n in ("speed_m_s", "iceW_rad_s", "iceON", "soc") if n in r.c]
    if not panels:
        return None
    ratios = {"speed_m_s": 2, "iceW_rad_s": 1, "iceON": 0.7, "soc": 1}
    fig, axes = r.figure(len(panels), "speed, engine and state of charge", [ratios[n] for n in panels],
                         height=1.0 + 1.3 * sum(ratios[n] for n in panels))
    for ax, n in zip(axes, panels):
        if n == "speed_m_s":
            r.speed_panel(ax)
        elif n == "iceW_rad_s":
            ax.plot(r.t, r.c["iceW_rad_s"], color="tab:brown", label="engine speed")
            ax.set_ylabel("engine [rad/s]")
        elif n == "iceON":
            r.flag_panel(ax, "iceON", "iceON [0/1]", "tab:red")
        else:
            r.soc_panel(ax)
    return fig


def hybrid_power_figure(r):
    """Engine power vs traction power and the battery's; fuel used."""
    lines = [(n, lbl) for n, lbl in (("icePowDel_W", "engine (icePowDel)"),
                                     ("motPowDelB_W", "traction (motPowDelB)"),
                                     ("battery_power_W", "battery terminal")) if n in r.c]
    if not lines:
        return None
    fuel = "fuel_g" in r.c
    fig, axes = r.figure(2 if fuel else 1, "powers and fuel")
    for n, lbl in lines:
        axes[0].plot(r.t, r.c[n] / 1000.0, label=lbl)
    axes[0].set_ylabel("power [kW]")
    if fuel:
        axes[1].plot(r.t, r.c["fuel_g"], color="tab:brown", label="fuel used")
        axes[1].set_ylabel("fuel [g]")
    return fig


# -------------------------------------------------------------------- drive rigs
def rig_torque_figure(r):
    req = r.first("genTauRef_Nm", "motTauRef_Nm")
    lim = r.first("genTauLim_Nm", "motTauLim_Nm")
    if not (req or lim or "tauElectrical_Nm" in r.c):
        return None
    state = "limit_state" in r.c
    fig, axes = r.figure(2 if state else 1, "drive torque")
    r.torque_panel(axes[0], req, "tauElectrical_Nm", lim)
    if state:
        r.limit_state_panel(axes[1], "limit_state")
    return fig


def rig_power_figure(r):
    """Mechanical vs electrical power, and the shaft speed."""
    if not r.first("power_mech_W", "power_dc_W"):
        return None
    speed = r.first("genW_rad_s", "motW_rad_s")
    fig, axes = r.figure(2 if speed else 1, "power")
    if "power_mech_W" in r.c:
        axes[0].plot(r.t, r.c["power_mech_W"] / 1000.0, label="mechanical")
    if "power_dc_W" in r.c:
        axes[0].plot(r.t, r.c["power_dc_W"] / 1000.0, "--", label="electrical (DC)")
    axes[0].set_ylabel("power [kW]")
    if speed:
        axes[1].plot(r.t, r.c[speed], color="tab:green", label=speed)
        axes[1].set_ylabel("shaft speed [rad/s]")
    return fig


def rig_efficiency_figure(r):
    """Efficiency, blanked where the shaft power is too small to mean anything."""
    if "efficiency" not in r.c:
        return None
    eff = r.c["efficiency"].copy()
    if "power_mech_W" in r.c:
        eff[~(np.abs(r.c["power_mech_W"]) > 1.0)] = np.nan
    fig, axes = r.figure(1, "drive efficiency")
    axes[0].plot(r.t, eff * 100.0, color="tab:blue", label="efficiency (|P_mech| > 1 W)")
    axes[0].set_ylabel("efficiency [%]")
    return fig


# -------------------------------------------------------------------- battery rig
def battery_power_figure(r):
    """Terminal power and current (> 0 discharging)."""
    panels = [n for n in ("battery_power_W", "battery_current_A") if n in r.c]
    if not panels:
        return None
    fig, axes = r.figure(len(panels), "battery terminal power and current", [1] * len(panels))
    for ax, n in zip(axes, panels):
        if n == "battery_power_W":
            ax.plot(r.t, r.c[n] / 1000.0, color="tab:blue", label="terminal power")
            ax.set_ylabel("power [kW]")
        else:
            ax.plot(r.t, r.c[n], color="tab:orange", label="terminal current")
            ax.set_ylabel("current [A]")
    return fig


# -------------------------------------------------------------------- genset rig
def genset_power_figure(r):
    """The request against what the engine gives, what the generator takes and what reaches
    the DC side; below, when the generator's limiter cuts and whether the genset is on."""
    if "dc_power_W" not in r.c or "power_ref_W" not in r.c:
        return None
    c = r.c
    fig, axes = r.figure(2, "genset power", [3, 1])
    axes[0].plot(r.t, c["power_ref_W"] / 1000.0, color="black", lw=1.0, label="request")
    if "ice_power_W" in c:
        axes[0].plot(r.t, c["ice_power_W"] / 1000.0, color="tab:red", label="engine")
    if "gen_power_mech_W" in c:
        axes[0].plot(r.t, -c["gen_power_mech_W"] / 1000.0, "--", color="tab:orange", label="generator (mechanical)")
    axes[0].plot(r.t, c["dc_power_W"] / 1000.0, color="tab:blue", label="DC delivered")
    axes[0].set_ylabel("power [kW]")
    if "gen_limiting" in c:
        axes[1].step(r.t, c["gen_limiting"], where="post", color="tab:purple", label="generator limited")
    if "on" in c:
        axes[1].step(r.t, c["on"] * 0.5, where="post", color="tab:green", label="on (0.5)")
    axes[1].set_ylim(-0.1, 1.1)
    axes[1].set_ylabel("flags [0/1]")
    return fig


def genset_speed_figure(r):
    """The engine's speed against the GMS's best speed for the request; below, the engine's
    torque against its maximum and the generator's (negative: generating)."""
    if "iceW_rad_s" not in r.c or "ice_speed_ref_rad_s" not in r.c:
        return None
    c = r.c
    fig, axes = r.figure(2, "genset speed and torques")
    axes[0].plot(r.t, c["ice_speed_ref_rad_s"], "--", color="black", lw=1.0, label="GMS best speed")
    axes[0].plot(r.t, c["iceW_rad_s"], color="tab:red", label="engine speed")
    axes[0].set_ylabel("speed [rad/s]")
    if "ice_torque_Nm" in c:
        axes[1].plot(r.t, c["ice_torque_Nm"], color="tab:red", label="engine torque")
    if "ice_torque_max_Nm" in c:
        axes[1].plot(r.t, c["ice_torque_max_Nm"], ":", color="tab:red", label="engine maximum")
    if "gen_torque_Nm" in c:
        axes[1].plot(r.t, c["gen_torque_Nm"], color="tab:orange", label="generator torque")
    axes[1].set_ylabel("torque [N m]")
    return fig


# -------------------------------------------------------------------- series hybrid
def shev_power_figure(r):
    """The DC bus of the series hybrid: what the drive draws, what the genset delivers and
    what the battery gives (the difference), with the EMS's request; below, the genset on."""
    if "drive_power_dc_W" not in r.c or "genset_power_dc_W" not in r.c:
        return None
    c = r.c
    fig, axes = r.figure(2, "DC powers of drive and genset", [3, 1])
    axes[0].plot(r.t, c["drive_power_dc_W"] / 1000.0, color="tab:blue", lw=0.8, label="drive (drawn)")
    if "battery_power_W" in c:
        axes[0].plot(r.t, c["battery_power_W"] / 1000.0, color="tab:gray", lw=0.6, label="battery (given)")
    if "genset_power_ref_W" in c:
        axes[0].plot(r.t, c["genset_power_ref_W"] / 1000.0, "--", color="black", lw=1.0, label="EMS request")
    axes[0].plot(r.t, c["genset_power_dc_W"] / 1000.0, color="tab:red", lw=1.4, label="genset (delivered)")
    axes[0].set_ylabel("power [kW]")
    if "genset_on" in c:
        r.flag_panel(axes[1], "genset_on", "genset on [0/1]", "tab:green")
    return fig


def shev_genset_figure(r):
    """The genset: the engine's speed against the GMS's best speed for the request, and the
    engine's power against the generator's mechanical power and the DC power it delivers."""
    if "genset_speed_rad_s" not in r.c:
        return None
    c = r.c
    fig, axes = r.figure(2, "genset speed and power")
    if "genset_speed_ref_rad_s" in c:
        axes[0].plot(r.t, c["genset_speed_ref_rad_s"], "--", color="black", lw=1.0, label="GMS best speed")
    axes[0].plot(r.t, c["genset_speed_rad_s"], color="tab:red", label="engine speed")
    axes[0].set_ylabel("speed [rad/s]")
    if "ice_power_W" in c:
        axes[1].plot(r.t, c["ice_power_W"] / 1000.0, color="tab:red", label="engine")
    if "gen_power_mech_W" in c:
        axes[1].plot(r.t, -c["gen_power_mech_W"] / 1000.0, "--", color="tab:orange", label="generator (mechanical)")
    if "genset_power_dc_W" in c:
        axes[1].plot(r.t, c["genset_power_dc_W"] / 1000.0, color="tab:blue", lw=0.8, label="DC delivered")
    axes[1].set_ylabel("power [kW]")
    return fig


# -------------------------------------------------------------------- machine test rigs
def detailed_figure(r):
    """TestPMDrive / TestAMDrive: the time-domain machine's phase voltage against the
    quasi-static drive's peak (√2 × rms) envelope, and the two torques."""
    if "det_v_a_V" not in r.c:
        return None
    c, t = r.c, r.t
    qs_rms = r.first("qs_v_rms_V", "qs_u1_rms_V")
    fig, axes = r.figure(2, "detailed machine vs quasi-static drive")
    axes[0].plot(t, c["det_v_a_V"], color="tab:blue", lw=0.3, label="detailed v_a")
    if qs_rms:
        env = np.sqrt(2.0) * c[qs_rms]
        axes[0].plot(t, env, color="tab:orange", label=f"quasi-static ±√2 × {qs_rms}")
        axes[0].plot(t, -env, color="tab:orange")
    if "v_lim_peak_V" in c:
        axes[0].plot(t, c["v_lim_peak_V"], "--", color="tab:red", label="U_lim (peak)")
    if "full_flux_v_peak_V" in c:
        axes[0].plot(t, c["full_flux_v_peak_V"], ":", color="tab:purple",
                     label="full flux: MTPA currents,\nno weakening (peak)")
    axes[0].set_ylabel("phase voltage [V]")
    if "torque_ref_Nm" in c:
        axes[1].plot(t, c["torque_ref_Nm"], "--", color="tab:gray", label="request")
    if "qs_torque_Nm" in c:
        axes[1].plot(t, c["qs_torque_Nm"], color="tab:orange", lw=3, alpha=0.6, label="quasi-static")
    if "det_torque_Nm" in c:
        axes[1].plot(t, c["det_torque_Nm"], color="tab:blue", lw=0.8, label="detailed")
    axes[1].set_ylabel("torque [N m]")
    # the induction machine's start from zero flux swings far beyond the drive's range:
    # keep the drive's range in view (the swing is clipped)
    qs = [c[n] for n in ("qs_torque_Nm", "torque_ref_Nm") if n in c]
    if qs:
        lo, hi = min(0.0, float(np.nanmin(qs))), max(0.0, float(np.nanmax(qs)))
        axes[1].set_ylim(lo - 0.2 * (hi - lo + 1.0), hi + 0.2 * (hi - lo + 1.0))
    return fig


def detailed_zoom_figure(r):
    """Three 40 ms windows, ending at 20 %, 60 % and 100 % of the run: the phase voltage and,
    for the induction rig, the phase current below it; one legend per row, at its right."""
    if "det_v_a_V" not in r.c or len(r.t) < 2:
        return None
    c, t = r.c, r.t
    qs_rms = r.first("qs_v_rms_V", "qs_u1_rms_V")
    current = "det_i_a_A" in c
    nrows = 2 if current else 1
    fig, axes = plt.subplots(nrows, 3, figsize=(13, 3.4 * nrows + 0.6), dpi=DEFAULT_DPI,
                             squeeze=False, sharex="col")
    fig.suptitle(r.title("a few electrical periods"))
    for col, frac in enumerate((0.2, 0.6, 1.0)):
        end = t[0] + frac * (t[-1] - t[0])
        m = (t > end - 0.04) & (t <= end)
        labelled = col == 2  # the legend names the lines once, right of the last column

        def lbl(text):
            return text if labelled else None

        ax = axes[0][col]
        ax.plot(t[m], c["det_v_a_V"][m], ".-", color="tab:blue", ms=3, label=lbl("detailed v_a"))
        if qs_rms:
            env = np.sqrt(2.0) * c[qs_rms][m]
            ax.plot(t[m], env, color="tab:orange", label=lbl("±√2 × QS rms"))
            ax.plot(t[m], -env, color="tab:orange")
        ax.set_ylabel("voltage [V]")
        if current:
            ax = axes[1][col]
            ax.plot(t[m], c["det_i_a_A"][m], color="tab:green", lw=0.8, label=lbl("detailed i_a"))
            if "qs_i1_rms_A" in c:
                i1 = np.sqrt(2.0) * c["qs_i1_rms_A"][m]
                ax.plot(t[m], i1, "--", color="tab:green", label=lbl("±√2 × QS I1 rms"))
                ax.plot(t[m], -i1, "--", color="tab:green")
            ax.set_ylabel("current [A]")
        axes[-1][col].set_xlabel(r.tlabel)
        for row in axes:
            row[col].grid(True, alpha=0.4)
    return fig


# -------------------------------------------------------------------- the families
EV_FIGURES = [("speed.png", speed_figure), ("torque.png", drive_torque_figure),
              ("power.png", drive_power_figure), ("soc.png", soc_figure),
              ("locked.png", locked_figure)]
DETAILED_FIGURES = [("detailed.png", detailed_figure), ("detailed_zoom.png", detailed_zoom_figure)]
# family (one per vehicle kind) -> its figures in drawing order: (file name, function)
FAMILIES = {
    "bev": EV_FIGURES,
    "ev_pm": EV_FIGURES + [("machine.png", pm_machine_figure)],
    "ev_am": EV_FIGURES + [("machine.png", am_machine_figure)],
    "psd": [("speed.png", speed_figure), ("torque.png", hybrid_torque_figure),
            ("power.png", hybrid_machine_power_figure), ("soc.png", soc_figure),
            ("locked.png", locked_figure), ("hybrid.png", hybrid_figure),
            ("hybrid_power.png", hybrid_power_figure)],
    "drive_rig": [("torque.png", rig_torque_figure), ("power.png", rig_power_figure),
                  ("efficiency.png", rig_efficiency_figure)],
    "battery_rig": [("power.png", battery_power_figure), ("soc.png", soc_figure)],
    "genset_rig": [("power.png", genset_power_figure), ("speed.png", genset_speed_figure)],
    "shev": [("speed.png", speed_figure), ("power.png", shev_power_figure), ("genset.png", shev_genset_figure),
             ("soc.png", soc_figure), ("locked.png", locked_figure)],
    "pm_drive_test": DETAILED_FIGURES,
    "am_drive_test": DETAILED_FIGURES,
}
# a sweep folder's figures: one per swept key (<key> with dots as _), or one without a key
SWEEP_FIGURES = ["sweep_fuel_vs_soc.png", "sweep_fuel_vs_soc_<key>.png"]


def family_of(cols):
    """The vehicle family whose columns these are, or None."""
    if "det_v_a_V" in cols:
        return "am_drive_test" if "qs_u1_rms_V" in cols or "det_i_a_A" in cols else "pm_drive_test"
    if RIG_COLUMNS & cols.keys():
        return "drive_rig"
    if "dc_power_W" in cols and "ice_speed_ref_rad_s" in cols:
        return "genset_rig"
    if {"genset_speed_rad_s", "genset_power_dc_W", "genset_on", "genset_power_ref_W"} & cols.keys():
        return "shev"
    if "iceW_rad_s" in cols:
        return "psd"
    if "id_A" in cols:
        return "ev_pm"
    if "i1_rms_A" in cols:
        return "ev_am"
    if "speed_m_s" in cols or "speed_ref_m_s" in cols:
        return "bev"
    if "soc" in cols or "battery_power_W" in cols:
        return "battery_rig"
    return None


def finish(fig):
    """Every labelled axes gets its legend outside, right of it; then the layout."""
    for ax in fig.axes:
        if ax.get_legend_handles_labels()[0] and ax.get_legend() is None:
            ax.legend(**LEGEND)
    fig.tight_layout()
    return fig


def draw_run(cols, scenario="", faults=None):
    """(family, [(file name, finished figure)]) for a run's columns (faults: summary.json's
    test.faults, for the shaded spans); nothing is written."""
    family = family_of(cols)
    r = Run(cols, scenario, faults)
    figures = []
    for name, draw in FAMILIES.get(family, []):
        fig = draw(r)
        if fig is not None:
            r.shade_faults(fig)
            figures.append((name, finish(fig)))
    return family, figures


def list_figures():
    """The --list-figures text: 'family: file file ...', one line per family."""
    lines = [f"{family}: {' '.join(name for name, _ in figures)}" for family, figures in FAMILIES.items()]
    return "\n".join(lines + [f"sweep: {' '.join(SWEEP_FIGURES)}"]) + "\n"


# -------------------------------------------------------------------- sweep folders
def number(text):
    """float(text), or NaN for an empty, unparsable or infinite field."""
    try:
        v = float(text)
    except (TypeError, ValueError):
        return math.nan
    return v if math.isfinite(v) else math.nan


def load_results(path):
    """(swept keys, runs) of a sweep's results.csv; a run is {column: text}.  A column name
    met twice (the summary's own "scenario") keeps its first value."""
    if not os.path.isfile(path):
        raise PlotError(f"{path}: file not found")
    try:
        with open(path, newline="") as f:
            rows = [r for r in csv.reader(f) if any(x.strip() for x in r)]
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise PlotError(f"{path}: cannot read as CSV ({e})")
    if not rows:
        raise PlotError(f"{path}: file is empty")
    header = [h.strip() for h in rows[0]]
    if "scenario" not in header or "sweep_status" not in header[header.index("scenario"):]:
        raise PlotError(f"{path}: no scenario ... sweep_status header: not a sweep's results")
    keys = header[header.index("scenario") + 1:header.index("sweep_status")]
    runs = [r for r in rows[1:] if len(r) == len(header)]
    if len(runs) < len(rows) - 1:  # e.g. a truncated last line
        print(f"plot.py: warning: {path}: skipped {len(rows) - 1 - len(runs)} row(s) with wrong "
              "field count", file=sys.stderr)
    return keys, [dict(reversed(list(zip(header, (x.strip() for x in r))))) for r in runs]


def sweep_figures(src):
    """[(file name, finished figure)]: fuel (or battery energy) against final SOC for every
    run of a sweep, one figure per swept key."""
    keys, runs = load_results(os.path.join(src, "results.csv"))
    campaign = load_summary(os.path.join(src, "sweep.json")).get("campaign")
    campaign = os.path.splitext(os.path.basename(str(campaign)))[0] if campaign else \
        os.path.basename(os.path.abspath(src))
    ok = [r for r in runs if r["sweep_status"] == "ok"]
    scenarios = list(dict.fromkeys(r["scenario"] for r in ok))  # the campaign's order
    burns = {s: any(number(r.get("fuel_L_per_100km")) > 0 for r in ok if r["scenario"] == s)
             for s in scenarios}  # else an EV: battery energy instead of fuel
    y_of = {s: "fuel_L_per_100km" if burns[s] else "battery_Wh_per_km" for s in scenarios}
    drawn = [r for r in ok if not math.isnan(number(r.get("soc_end")))
             and not math.isnan(number(r.get(y_of[r["scenario"]])))]
    counts, drawn_ids = {}, {id(r) for r in drawn}
    for r in runs:
        if id(r) not in drawn_ids:
            st = r["sweep_status"] if r["sweep_status"] != "ok" else "ok without values"
            counts[st] = counts.get(st, 0) + 1
    # "failed" and "pending" first, then anything else a newer ehpt may write
    order = sorted(counts, key=lambda st: (st not in ("failed", "pending"), st))
    not_drawn = ", ".join(f"{counts[st]} {st or 'no status'}" for st in order)
    if not drawn:
        raise PlotError(f"{src}/results.csv: no successful run to plot ({len(runs)} runs"
                        + (f": {not_drawn})" if not_drawn else ")"))
    ylabels = {"fuel_L_per_100km": "fuel [L/100 km]", "battery_Wh_per_km": "battery [Wh/km]"}

    figures = []
    for key in keys or [None]:
        colour_by = key or "scenario"
        if key:  # one panel per scenario
            panels = [(s, [r for r in drawn if r["scenario"] == s]) for s in scenarios]
        else:  # one run per scenario: the fuel burners together, the EVs together
            panels = [(t, [r for r in drawn if burns[r["scenario"]] == b])
                      for t, b in (("with fuel", True), ("battery only", False))]
        panels = [(t, rs) for t, rs in panels if rs]
        values = sorted({r[colour_by] for r in drawn},
                        key=lambda v: (math.isnan(number(v)), number(v), v))
        numeric = not any(math.isnan(number(v)) for v in values)
        if numeric and len(values) > 8:  # a colour scale and a colorbar
            norm = matplotlib.colors.Normalize(number(values[0]), number(values[-1]))
            colour = {v: plt.cm.viridis(norm(number(v))) for v in values}
        elif numeric:  # an ordered key: a sequential map, short of viridis's pale yellow
            colour = {v: plt.cm.viridis(x) for v, x in zip(values, np.linspace(0, 0.85, len(values)))}
        else:
            cmap = plt.cm.tab10 if len(values) <= 10 else plt.cm.tab20
            colour = {v: cmap(i % cmap.N) for i, v in enumerate(values)}

        ncols = min(len(panels), 3)
        nrows = -(-len(panels) // ncols)
        spare = len(panels) < nrows * ncols  # an empty slot for the legend, else a column
        fig = plt.figure(figsize=(4.2 * ncols + (0 if spare else 2.2), 3.4 * nrows + 1.0), dpi=DEFAULT_DPI)
        grid = fig.add_gridspec(nrows, ncols + (0 if spare else 1),
                                width_ratios=[1] * ncols + ([] if spare else [0.5]))
        for i, (title, rs) in enumerate(panels):
            ax = fig.add_subplot(grid[i // ncols, i % ncols])
            x0s = {round(100.0 * number(r.get("soc_start")), 2) for r in rs}
            for x0 in sorted(x for x in x0s if not math.isnan(x))[:8]:
                ax.axvline(x0, ls="--", lw=1, color="tab:gray")
            ax.scatter([100.0 * number(r["soc_end"]) for r in rs],
                       [number(r[y_of[r["scenario"]]]) for r in rs],
                       c=[colour[r[colour_by]] for r in rs], s=45, edgecolors="black",
                       linewidths=0.5, zorder=3)
            ax.set_title(title, fontsize="medium")
            ax.set_xlabel("final SOC [%]")
            ax.set_ylabel(ylabels[y_of[rs[0]["scenario"]]])
            ax.ticklabel_format(useOffset=False)
            ax.grid(True, alpha=0.4)
        side = fig.add_subplot(grid[-1, -1] if spare else grid[:, ncols])  # shared legend
        side.axis("off")
        start = [matplotlib.lines.Line2D([], [], ls="--", lw=1, color="tab:gray",
                                         label="initial SOC")]
        if numeric and len(values) > 8:
            cax = side.inset_axes([0.05, 0.3, 0.12, 0.65])
            fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=plt.cm.viridis), cax=cax,
                         label=colour_by)
            side.legend(handles=start, loc="lower left", fontsize="small")
        else:
            side.legend(handles=[matplotlib.lines.Line2D(
                [], [], ls="", marker="o", markeredgecolor="black", markeredgewidth=0.5,
                color=colour[v], label=v) for v in values] + start,
                title=colour_by, loc="center left", fontsize="small", title_fontsize="small")
        fig.suptitle(f"{campaign}: consumption vs final SOC, coloured by {colour_by}\n"
                     f"{len(drawn)} runs drawn" + (f"; not drawn: {not_drawn}" if not_drawn else ""))
        name = "sweep_fuel_vs_soc" + (("_" + re.sub(r"[^A-Za-z0-9_-]", "_", key)) if key else "")
        fig.tight_layout()
        figures.append((name + ".png", fig))
    return figures


# -------------------------------------------------------------------- writing
def save(fig, out_dir, name, dpi=DEFAULT_DPI):
    """Write out_dir/name via a temporary file so no half-written PNG appears."""
    target = os.path.join(out_dir, name)
    fd, tmp = tempfile.mkstemp(prefix="." + name + ".", suffix=".tmp", dir=out_dir)
    try:
        with os.fdopen(fd, "wb") as f:
            fig.savefig(f, format="png", dpi=dpi)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; use the usual mode
        os.replace(tmp, target)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
    finally:
        plt.close(fig)


USAGE = ("usage: /usr/bin/python3 tools/plot.py DIR [--out-dir OUT] [--as NAME] [--quiet] [--dpi N]\n"
         "       /usr/bin/python3 tools/plot.py --list-figures")


def main(argv):
    quiet, src, out_dir, shown, dpi = False, None, None, None, DEFAULT_DPI
    it = iter(argv)
    for a in it:
        if a == "--quiet":
            quiet = True
        elif a == "--list-figures":
            sys.stdout.write(list_figures())
            return 0
        elif a in ("--out-dir", "--as", "--dpi"):
            value = next(it, None)
            if value is None:
                print(USAGE, file=sys.stderr)
                return 2
            if a == "--out-dir":
                out_dir = value
            elif a == "--as":
                shown = value
            else:
                try:
                    dpi = int(value)
                except ValueError:
                    dpi = 0
                if not 10 <= dpi <= 600:
                    print(f"plot.py: error: --dpi {value}: not a whole number from 10 to 600", file=sys.stderr)
                    return 2
        elif a.startswith("-") or src is not None:
            print(USAGE, file=sys.stderr)
            return 2
        else:
            src = a
    if src is None:
        print(USAGE, file=sys.stderr)
        return 2
    out_dir = out_dir or src
    # ehpt passes --as the run folder as the user named it (src may be its temporary folder)
    shown_src = shown or src
    shown = shown or out_dir
    if os.path.isfile(os.path.join(src, "sweep.json")):  # `ehpt sweep`'s folder
        figures = sweep_figures(src)
    else:
        csv_path = os.path.join(src, "timeseries.csv")
        if not os.path.exists(csv_path) and os.path.isfile(os.path.join(src, "summary.json")):
            raise PlotError(f"{shown_src}: the run wrote no timeseries.csv (output.timeseries = false in "
                            "its scenario or --set): nothing to draw; run it again with output.timeseries = true")
        cols = load_csv(csv_path)
        summary = load_summary(os.path.join(src, "summary.json"))
        scenario = summary.get("scenario")
        test = summary.get("test") if isinstance(summary.get("test"), dict) else {}
        faults = [f for f in test.get("faults", []) if isinstance(f, dict)]
        figures = draw_run(cols, str(scenario) if scenario else "", faults)[1]
    for name, fig in figures:
        save(fig, out_dir, name, dpi)
        if not quiet:
            print(f"wrote {os.path.join(shown, name)}")
    if not figures and not quiet:
        print(f"plot.py: note: no plottable columns in {src}/timeseries.csv", file=sys.stderr)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except PlotError as e:
        print(f"plot.py: error: {e}", file=sys.stderr)
        sys.exit(1)
    except KeyboardInterrupt:
        sys.exit(130)
    except Exception as e:  # bad input must never end in a traceback
        print(f"plot.py: error: {type(e).__name__}: {e}", file=sys.stderr)
        sys.exit(1)
