#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""Draw PNG figures from an ehpt run folder.

Usage: /usr/bin/python3 tools/plot.py DIR [--out-dir OUT] [--as NAME] [--quiet]

Figures are written into OUT (default DIR); messages name them as if in NAME (default
OUT): ehpt draws into a private folder and moves the figures into place itself.
DIR must hold timeseries.csv (header of column names, then numeric rows) and
usually summary.json.  Vehicle runs (column speed_m_s etc.) give speed, torque,
power, soc and locked figures, and the machine's currents and voltage for the
machine-drive EVs (EvPm_bat, EvAm_bat); drive-rig runs (TestMBOneFlange/TestTwoFlange,
column tauElectrical_Nm etc.) give torque, power and efficiency figures; the
detailed-machine rigs (TestPMDrive/TestAMDrive, column det_v_a_V) give the phase
voltage against the quasi-static envelope, the torques, and a zoom on a few periods.
A figure whose columns are absent from the CSV is skipped silently.

A sweep folder (DIR/sweep.json, written by `ehpt sweep`) is drawn from DIR/results.csv
instead (one row per run: run_id, scenario, the swept keys, sweep_status, exit_code,
message, then the run's summary.json flattened): for each swept key K,
sweep_fuel_vs_soc_<K, dots as _>.png plots fuel [L/100 km] against final SOC, one panel per
scenario, each run coloured by its value of K (battery Wh/km instead of fuel for a scenario
that burns none, e.g. an EV); with no swept key, one sweep_fuel_vs_soc.png coloured by
scenario.  Runs that are not ok are not drawn (the title counts them); with none to draw,
nothing is written and the exit status is 1.
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
# Columns that only drive-rig runs write; anything else is treated as a vehicle run.
# columns only the drive rigs write (the hybrids share the bus names genTauRef_Nm etc.)
RIG_COLUMNS = {"tauElectrical_Nm", "limit_state", "limitingTorque", "power_mech_W", "power_dc_W",
               "efficiency", "load_torque_Nm"}


class PlotError(Exception):
    pass


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


class Plotter:
    def __init__(self, out_dir, cols, scenario, quiet, shown_dir=None):
        self.dir, self.c, self.scenario, self.quiet = out_dir, cols, scenario, quiet
        self.shown_dir = shown_dir or out_dir
        self.written = 0
        if "time_s" in cols:
            self.t, self.tlabel = cols["time_s"], "time [s]"
        else:
            n = len(next(iter(cols.values()), []))  # a sweep has no columns
            self.t, self.tlabel = np.arange(n, dtype=float), "sample"

    def has(self, *names):
        return all(n in self.c for n in names)

    def first(self, *names):
        """Name of the first of names present in the CSV, else None."""
        return next((n for n in names if n in self.c), None)

    def figure(self, nrows, title):
        """Figure with nrows stacked axes sharing the time axis."""
        fig, axes = plt.subplots(nrows, 1, figsize=(10, 6), dpi=100, sharex=True,
                                 squeeze=False,
                                 gridspec_kw={"height_ratios": [2] + [1] * (nrows - 1)})
        axes = list(axes[:, 0])
        fig.suptitle(f"{self.scenario}: {title}" if self.scenario else title)
        for ax in axes:
            ax.grid(True, alpha=0.4)
        axes[-1].set_xlabel(self.tlabel)
        return fig, axes

    def limit_state(self, ax, name):
        ax.step(self.t, self.c[name], where="post", color="tab:purple", label=name)
        ax.set_yticks(range(len(LIMIT_STATES)))
        ax.set_yticklabels(LIMIT_STATES)
        ax.set_ylim(-0.3, len(LIMIT_STATES) - 0.7)
        ax.set_ylabel("limiter state")

    def save(self, fig, name):
        """Write DIR/name via a temporary file so no half-written PNG appears."""
        for ax in fig.axes:
            if ax.get_legend_handles_labels()[0] and ax.get_legend() is None:
                ax.legend(loc="best", fontsize="small")
        fig.tight_layout()
        target = os.path.join(self.dir, name)
        fd, tmp = tempfile.mkstemp(prefix="." + name + ".", suffix=".tmp", dir=self.dir)
        try:
            with os.fdopen(fd, "wb") as f:
                fig.savefig(f, format="png")
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
        self.written += 1
        if not self.quiet:
            print(f"wrote {os.path.join(self.shown_dir, name)}")

    # ---------------------------------------------------------------- vehicle runs
    def vehicle(self):
        c, t = self.c, self.t
        # Wanted vs actual speed, plus the speed error when both are present.
        if self.first("speed_m_s", "speed_ref_m_s"):
            both = self.has("speed_m_s", "speed_ref_m_s")
            fig, axes = self.figure(2 if both else 1, "vehicle speed")
            if "speed_ref_m_s" in c:
                axes[0].plot(t, c["speed_ref_m_s"] * 3.6, "--", color="tab:gray", label="wanted")
            if "speed_m_s" in c:
                axes[0].plot(t, c["speed_m_s"] * 3.6, color="tab:blue", label="actual")
            axes[0].set_ylabel("speed [km/h]")
            if both:
                axes[1].plot(t, (c["speed_m_s"] - c["speed_ref_m_s"]) * 3.6, color="tab:red",
                             label="actual - wanted")
                axes[1].set_ylabel("speed error [km/h]")
            self.save(fig, "speed.png")

        # Requested vs delivered torque with the +/- limit, plus the limiter state.
        if self.first("driver_request_Nm", "drive_torque_Nm", "drive_torque_limit_Nm"):
            self.torque("driver_request_Nm", "drive_torque_Nm", "drive_torque_limit_Nm",
                        "drive_limit_state", "drive torque")

        # Mechanical vs electrical drive power (and battery terminal power).
        pw = [(n, lbl, ls) for n, lbl, ls in (("drive_power_mech_W", "drive mechanical", "-"),
                                              ("drive_power_dc_W", "drive electrical (DC)", "-"),
                                              ("battery_power_W", "battery terminal", "--"))
              if n in c]
        if pw:
            fig, axes = self.figure(1, "power")
            for n, lbl, ls in pw:  # dashed battery line: it often sits on the DC line
                axes[0].plot(t, c[n] / 1000.0, ls, label=lbl)
            axes[0].set_ylabel("power [kW]")
            self.save(fig, "power.png")

        # State of charge, plus battery voltage.
        if "soc" in c:
            volt = "battery_voltage_V" in c
            fig, axes = self.figure(2 if volt else 1, "battery state of charge")
            axes[0].plot(t, c["soc"] * 100.0, color="tab:green", label="SoC")
            axes[0].set_ylabel("SoC [%]")
            axes[0].ticklabel_format(axis="y", useOffset=False)
            if volt:
                axes[1].plot(t, c["battery_voltage_V"], color="tab:orange", label="terminal voltage")
                if "battery_emf_V" in c:
                    axes[1].plot(t, c["battery_emf_V"], "--", color="tab:gray", label="EMF")
                axes[1].set_ylabel("voltage [V]")
            self.save(fig, "soc.png")

        # Locked (standstill) flag with speed on a twin axis for context.
        if "locked" in c:
            fig, axes = self.figure(1, "vehicle locked at standstill")
            speed = "speed_m_s" in c
            axes[0].step(t, c["locked"], where="post", color="tab:red",
                         label=None if speed else "locked")
            axes[0].set_yticks([0, 1])
            axes[0].set_ylim(-0.1, 1.1)
            axes[0].set_ylabel("locked flag [0/1]")
            if speed:
                # one legend, on the twin axis (drawn on top), with a proxy for the flag
                ax2 = axes[0].twinx()
                ax2.plot([], [], color="tab:red", label="locked (left axis)")
                ax2.plot(t, c["speed_m_s"] * 3.6, color="tab:blue", alpha=0.6,
                         label="speed (right axis)")
                ax2.set_ylabel("speed [km/h]")
            self.save(fig, "locked.png")

    # ---------------------------------------------------------------- machine drives
    def machine(self):
        """EvPm_bat / EvAm_bat (P15 Fig. 19): the machine's electrical picture."""
        c, t = self.c, self.t
        if self.has("id_A", "iq_A"):  # PMDrive: dq currents, voltage and its set value
            volt = "voltage_peak_V" in c
            fig, axes = self.figure(2 if volt else 1, "PM machine: dq currents and voltage")
            axes[0].plot(t, c["id_A"], label="Id")
            axes[0].plot(t, c["iq_A"], label="Iq")
            axes[0].set_ylabel("current, peak [A]")
            if volt:
                axes[1].plot(t, c["voltage_peak_V"], color="tab:purple", label="|V| (peak phase)")
                if "weakening" in c:
                    w = np.where(c["weakening"] > 0.5, c["voltage_peak_V"], np.nan)
                    axes[1].plot(t, w, color="tab:red", lw=3, alpha=0.5, label="flux weakening")
                axes[1].set_ylabel("voltage [V]")
            self.save(fig, "machine.png")
        elif self.has("i1_rms_A", "slip_rad_s"):  # AMDrive: stator current, slip, voltage
            fig, axes = self.figure(3, "induction machine: current, slip and voltage")
            axes[0].plot(t, c["i1_rms_A"], label="stator current |I1| (rms)")
            axes[0].set_ylabel("current [A]")
            axes[1].plot(t, c["slip_rad_s"], color="tab:orange", label="slip frequency dWe")
            axes[1].set_ylabel("slip [rad/s]")
            if "u1_rms_V" in c:
                axes[2].plot(t, c["u1_rms_V"], color="tab:purple", label="terminal |U1| (rms)")
            if "emf_rms_V" in c:
                axes[2].plot(t, c["emf_rms_V"], "--", color="tab:gray", label="E (rms)")
            axes[2].set_ylabel("voltage [V]")
            self.save(fig, "machine.png")

    # ---------------------------------------------------------------- hybrid runs
    def hybrid(self):
        """Power-split hybrids (column iceW_rad_s), like the paper's Figs. 21 and 23."""
        c, t = self.c, self.t
        # hybrid.png: wanted vs actual speed; engine speed and ON flag; SOC
        panels = [n for n in ("speed_m_s", "iceW_rad_s", "soc") if n in c]
        if panels:
            fig, axes = self.figure(len(panels), "speed, engine and state of charge")
            for ax, n in zip(axes, panels):
                if n == "speed_m_s":
                    if "speed_ref_m_s" in c:
                        ax.plot(t, c["speed_ref_m_s"] * 3.6, "--", color="tab:gray", label="wanted")
                    ax.plot(t, c["speed_m_s"] * 3.6, color="tab:blue", label="actual")
                    ax.set_ylabel("speed [km/h]")
                elif n == "iceW_rad_s":
                    on = "iceON" in c
                    # with the ON flag: one legend, on the twin axis (drawn on top), with a
                    # proxy for the speed, so the two labels cannot overlap
                    ax.plot(t, c["iceW_rad_s"], color="tab:brown", label=None if on else "engine speed")
                    ax.set_ylabel("engine [rad/s]")
                    if on:
                        ax2 = ax.twinx()
                        ax2.plot([], [], color="tab:brown", label="engine speed (left axis)")
                        ax2.step(t, c["iceON"], where="post", color="tab:red", alpha=0.7,
                                 label="iceON (right axis)")
                        ax2.set_yticks([0, 1])
                        ax2.set_ylim(-0.1, 1.6)
                        ax2.set_ylabel("ON")
                        # headroom above both curves for the legend, in one row at the top
                        top = float(np.nanmax(c["iceW_rad_s"])) if len(t) else 1.0
                        ax.set_ylim(top=1.45 * top if top > 0 else 1.0)
                        ax2.legend(loc="upper left", ncol=2, fontsize="small")
                else:
                    ax.plot(t, c["soc"], color="tab:green", label="SOC")
                    ax.set_ylabel("SOC")
            self.save(fig, "hybrid.png")
        # hybrid_power.png: engine power vs traction power, battery; fuel used
        pw = [(n, lbl) for n, lbl in (("icePowDel_W", "engine (icePowDel)"), ("motPowDelB_W", "traction (motPowDelB)"),
                                      ("battery_power_W", "battery terminal")) if n in c]
        if pw:
            fuel = "fuel_g" in c
            fig, axes = self.figure(2 if fuel else 1, "powers and fuel")
            for n, lbl in pw:
                axes[0].plot(t, c[n] / 1000.0, label=lbl)
            axes[0].set_ylabel("power [kW]")
            if fuel:
                axes[1].plot(t, c["fuel_g"], color="tab:brown", label="fuel used")
                axes[1].set_ylabel("fuel [g]")
            self.save(fig, "hybrid_power.png")

    def torque(self, req, deliv, lim, state, title):
        """torque.png: request, delivered, dashed +/- limit; limiter state subplot."""
        c, t = self.c, self.t
        have_state = state is not None and state in c
        fig, axes = self.figure(2 if have_state else 1, title)
        if req in c:
            # wide pale line so the request stays visible when delivered == request
            axes[0].plot(t, c[req], color="tab:orange", lw=4, alpha=0.45, label=f"request ({req})")
        if deliv in c:
            axes[0].plot(t, c[deliv], color="tab:blue", label=f"delivered ({deliv})")
        if lim in c:
            axes[0].plot(t, c[lim], "--", color="tab:red", label=f"limit ± ({lim})")
            axes[0].plot(t, -c[lim], "--", color="tab:red")
        axes[0].set_ylabel("torque [N m]")
        if have_state:
            self.limit_state(axes[1], state)
        self.save(fig, "torque.png")

    # ---------------------------------------------------------------- drive-rig runs
    def rig(self):
        c, t = self.c, self.t
        req = self.first("genTauRef_Nm", "motTauRef_Nm")
        lim = self.first("genTauLim_Nm", "motTauLim_Nm")
        if req or lim or "tauElectrical_Nm" in c:
            self.torque(req, "tauElectrical_Nm", lim, "limit_state", "drive torque")

        # Mechanical vs electrical power, plus shaft speed.
        speed = self.first("genW_rad_s", "motW_rad_s")
        if self.first("power_mech_W", "power_dc_W"):
            fig, axes = self.figure(2 if speed else 1, "power")
            if "power_mech_W" in c:
                axes[0].plot(t, c["power_mech_W"] / 1000.0, label="mechanical")
            if "power_dc_W" in c:
                axes[0].plot(t, c["power_dc_W"] / 1000.0, "--", label="electrical (DC)")
            axes[0].set_ylabel("power [kW]")
            if speed:
                axes[1].plot(t, c[speed], color="tab:green", label=speed)
                axes[1].set_ylabel("shaft speed [rad/s]")
            self.save(fig, "power.png")

        # Efficiency, blanked where the shaft power is too small to mean anything.
        if "efficiency" in c:
            eff = c["efficiency"].copy()
            if "power_mech_W" in c:
                eff[~(np.abs(c["power_mech_W"]) > 1.0)] = np.nan
            fig, axes = self.figure(1, "drive efficiency")
            axes[0].plot(t, eff * 100.0, color="tab:blue", label="efficiency (|P_mech| > 1 W)")
            axes[0].set_ylabel("efficiency [%]")
            self.save(fig, "efficiency.png")


    # ---------------------------------------------------------------- detailed references
    def detailed(self):
        """TestPMDrive / TestAMDrive (column det_v_a_V): the time-domain machine's phase
        voltage against the quasi-static drive's peak (sqrt 2 x rms) envelope, and the two
        torques; then a few electrical periods up close."""
        c, t = self.c, self.t
        qs_rms = self.first("qs_v_rms_V", "qs_u1_rms_V")
        fig, axes = self.figure(2, "detailed machine vs quasi-static drive")
        axes[0].plot(t, c["det_v_a_V"], color="tab:blue", lw=0.3, label="detailed v_a")
        if qs_rms:
            env = np.sqrt(2.0) * c[qs_rms]
            axes[0].plot(t, env, color="tab:orange", label=f"quasi-static ±√2 × {qs_rms}")
            axes[0].plot(t, -env, color="tab:orange")
        if "v_lim_peak_V" in c:
            axes[0].plot(t, c["v_lim_peak_V"], "--", color="tab:red", label="U_lim (peak)")
        if "full_flux_v_peak_V" in c:
            axes[0].plot(t, c["full_flux_v_peak_V"], ":", color="tab:purple",
                         label="full flux: MTPA currents, no weakening (peak)")
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
        self.save(fig, "detailed.png")
        # three 40 ms windows, ending at 20 %, 60 % and 100 % of the run
        if len(t) < 2:
            return
        fig, axes = plt.subplots(1, 3, figsize=(12, 4), dpi=100, squeeze=False)
        fig.suptitle(f"{self.scenario}: a few electrical periods" if self.scenario else "a few electrical periods")
        for ax, frac in zip(axes[0], (0.2, 0.6, 1.0)):
            end = t[0] + frac * (t[-1] - t[0])
            m = (t > end - 0.04) & (t <= end)
            ax.plot(t[m], c["det_v_a_V"][m], ".-", color="tab:blue", ms=3, label="detailed v_a")
            if qs_rms:
                env = np.sqrt(2.0) * c[qs_rms][m]
                ax.plot(t[m], env, color="tab:orange", label="±√2 × QS rms")
                ax.plot(t[m], -env, color="tab:orange")
            if "det_i_a_A" in c:  # the induction rig: its phase current on a twin axis
                ax2 = ax.twinx()
                ax2.plot(t[m], c["det_i_a_A"][m], color="tab:green", lw=0.8, label="detailed i_a")
                if "qs_i1_rms_A" in c:
                    i1 = np.sqrt(2.0) * c["qs_i1_rms_A"][m]
                    ax2.plot(t[m], i1, "--", color="tab:green", label="±√2 × QS I1 rms")
                    ax2.plot(t[m], -i1, "--", color="tab:green")
                ax2.set_ylabel("current [A]")
                ax2.legend(loc="lower right", fontsize="x-small")
            ax.set_xlabel(self.tlabel)
            ax.set_ylabel("voltage [V]")
            ax.grid(True, alpha=0.4)
            ax.legend(loc="upper right", fontsize="x-small")
        self.save(fig, "detailed_zoom.png")


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


def sweep(src, p):
    """Fuel (or battery energy) against final SOC for every run of a sweep, per swept key."""
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
        fig = plt.figure(figsize=(4.2 * ncols + (0 if spare else 2.2), 3.4 * nrows + 1.0), dpi=100)
        grid = fig.add_gridspec(nrows, ncols + (0 if spare else 1),
                                width_ratios=[1] * ncols + ([] if spare else [0.5]))
        for i, (title, rs) in enumerate(panels):
            ax = fig.add_subplot(grid[i // ncols, i % ncols])
            x0s = {round(number(r.get("soc_start")), 4) for r in rs}
            for x0 in sorted(x for x in x0s if not math.isnan(x))[:8]:
                ax.axvline(x0, ls="--", lw=1, color="tab:gray")
            ax.scatter([number(r["soc_end"]) for r in rs],
                       [number(r[y_of[r["scenario"]]]) for r in rs],
                       c=[colour[r[colour_by]] for r in rs], s=45, edgecolors="black",
                       linewidths=0.5, zorder=3)
            ax.set_title(title, fontsize="medium")
            ax.set_xlabel("final SOC [-]")
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
        p.save(fig, name + ".png")


USAGE = "usage: /usr/bin/python3 tools/plot.py DIR [--out-dir OUT] [--as NAME] [--quiet]"


def main(argv):
    quiet, src, out_dir, shown = False, None, None, None
    it = iter(argv)
    for a in it:
        if a == "--quiet":
            quiet = True
        elif a in ("--out-dir", "--as"):
            value = next(it, None)
            if value is None:
                print(USAGE, file=sys.stderr)
                return 2
            if a == "--out-dir":
                out_dir = value
            else:
                shown = value
        elif a.startswith("-") or src is not None:
            print(USAGE, file=sys.stderr)
            return 2
        else:
            src = a
    if src is None:
        print(USAGE, file=sys.stderr)
        return 2
    out_dir = out_dir or src
    if os.path.isfile(os.path.join(src, "sweep.json")):  # `ehpt sweep`'s folder
        p = Plotter(out_dir, {}, "", quiet, shown)
        sweep(src, p)
        return 0
    cols = load_csv(os.path.join(src, "timeseries.csv"))
    scenario = load_summary(os.path.join(src, "summary.json")).get("scenario")
    p = Plotter(out_dir, cols, str(scenario) if scenario else "", quiet, shown)
    if "det_v_a_V" in cols:  # TestPMDrive / TestAMDrive
        p.detailed()
    elif RIG_COLUMNS & cols.keys():
        p.rig()
    else:
        p.vehicle()
        p.machine()
        if "iceW_rad_s" in cols:
            p.hybrid()
    if p.written == 0 and not quiet:
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
