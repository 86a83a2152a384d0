#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""Independent re-simulation of the EHPT series-hybrid bus (SHEVpowerFilt, SHEV_OO).

Written from MODELS.md (sections 1, 3, 5.5, 6, 7, 8, 10.6; docs/MODELS.md), the vehicle files'
numbers and the CSV maps only, without reading ehpt's C++: the check behind
tests/data/ref/shev_*_sort1.csv (tests/data/ref/README.md). Fixed-step RK4 (h = 1 ms), the EMS
sampled every 10 steps with its inputs held, as ehpt's built-in ECU runs.

Usage:  /usr/bin/python3 tools/resim_shev.py pf|oo OUT_DIR [t_end]
        -> OUT_DIR/<run>_resim.csv (every 0.1 s) and OUT_DIR/<run>_events.txt
pf: SHEVpowerFilt (400 s), oo: SHEV_OO (2000 s), both on Sort1.
"""
import bisect
import csv
import math
import sys

import os

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
MAPS = os.path.join(ROOT, "data", "maps") + "/"
CYCLE = os.path.join(ROOT, "data", "cycles", "cycle_sort1.csv")


# ----------------------------------------------------------------------------- tables
def read_csv(path):
    with open(path) as f:
        r = csv.reader(f)
        hdr = next(r)
        rows = [[float(x) for x in row] for row in r if row]
    return hdr, rows


class Table1D:
    """Piecewise linear; extrapolation 'hold' (end values) or 'linear' (last two points)."""

    def __init__(self, xs, ys, extrap="hold"):
        self.x, self.y, self.ex = list(xs), list(ys), extrap

    def __call__(self, u):
        x, y = self.x, self.y
        n = len(x)
        if u <= x[0]:
            if self.ex == "hold":
                return y[0]
            i = 0
        elif u >= x[-1]:
            if self.ex == "hold":
                return y[-1]
            i = n - 2
        else:
            i = bisect.bisect_right(x, u) - 1
        return y[i] + (y[i + 1] - y[i]) * (u - x[i]) / (x[i + 1] - x[i])


class Table2D:
    """Bilinear, u1 = row axis, u2 = column axis; extrapolation linear from the last two grid
    lines ('linear') or edge values held ('hold')."""

    def __init__(self, rows, cols, z, extrap="linear"):
        self.r, self.c, self.z, self.ex = rows, cols, z, extrap

    @staticmethod
    def _seg(g, u, ex):
        n = len(g)
        if u <= g[0]:
            if ex == "hold":
                return 0, 0.0
            i = 0
        elif u >= g[-1]:
            if ex == "hold":
                return n - 2, 1.0
            i = n - 2
        else:
            i = bisect.bisect_right(g, u) - 1
        return i, (u - g[i]) / (g[i + 1] - g[i])

    def __call__(self, u1, u2):
        i, a = self._seg(self.r, u1, self.ex)
        j, b = self._seg(self.c, u2, self.ex)
        z = self.z
        z0 = z[i][j] + (z[i][j + 1] - z[i][j]) * b
        z1 = z[i + 1][j] + (z[i + 1][j + 1] - z[i + 1][j]) * b
        return z0 + (z1 - z0) * a


def long_to_2d(rows):
    r = sorted(set(row[0] for row in rows))
    c = sorted(set(row[1] for row in rows))
    z = [[None] * len(c) for _ in r]
    for a, b, v in rows:
        z[r.index(a)][c.index(b)] = v
    assert all(v is not None for line in z for v in line)
    return r, c, z


# ----------------------------------------------------------------------------- parameters
def params(run):
    p = dict(
        m=14000.0, r=0.473, G=10.0,
        fc=0.01, rho=1.226, S=6.5, Cx=0.65, g=9.80665,
        d_tmax=1000.0, d_pmax=150000.0, d_wmax=3000.0, d_J=0.25,
        ice_J=0.5, gen_J=0.25, w0=300.0, thr_gain=0.1,
        gen_tmax=500.0, gen_pmax=45000.0, gen_wmax=300.0,
        alpha=0.10,
        QCellNom=25.0 * 3600.0, ICellMax=500.0, R0Cell=0.35e-3, eff=0.9,
        ns=100, np=1, ECellMin=3.3, ECellMax=4.15, soc0=0.5,
        yMax=2000.0, ecu_dt=0.01, Pf0=20000.0,
    )
    if run == "pf":
        p.update(k_drv=500.0, iEff=100.0, T_f=500.0, gain=0.0, socRef=0.0, Pmax=100000.0,
                 onoff=False, gms_clamp=False, t_end=400.0)
    elif run == "oo":
        p.update(k_drv=200.0, iEff=200.0, T_f=300.0, gain=3e5, socRef=0.6, Pmax=200000.0,
                 onoff=True, on_W=60000.0, off_W=30000.0, gms_clamp=True, t_end=2000.0)
    else:
        raise SystemExit("run must be pf or oo")
    return p


def limiter_yH(w, tmax, pmax, wmax, alpha):
    """MODELS.md 1.3 (|w|), returns (yH, state)."""
    aw = abs(w)
    wb = pmax / tmax
    if aw < wb:
        yH, st = tmax, 0
    else:
        yH, st = pmax / aw, 1
    if aw > wmax:
        if aw < (1.0 + alpha) * wmax:
            yH, st = (pmax / wmax) * (1.0 - (aw - wmax) / (alpha * wmax)), 2
        else:
            yH, st = 0.0, 3
    return yH, st


# ----------------------------------------------------------------------------- model
def build(run, opti_extrap="hold", tmax_extrap="hold", sfc_extrap="linear", eff_extrap="linear"):
    p = params(run)
    # maps
    _, cyc = read_csv(CYCLE)
    cyc_t = [a for a, b in cyc]
    cyc_v = [b / 3.6 for a, b in cyc]
    period = cyc_t[-1] - cyc_t[0]
    vref_tab = Table1D(cyc_t, cyc_v, "hold")

    def vref(t):
        return vref_tab(math.fmod(t, period))

    _, tm = read_csv(MAPS + "map_shev_ice_max_torque.csv")
    tmax_ice = Table1D([a for a, b in tm], [b for a, b in tm], tmax_extrap)
    _, op = read_csv(MAPS + "map_shev_ice_opti_speed.csv")
    opti = Table1D([a for a, b in op], [b * 2.0 * math.pi / 60.0 for a, b in op], opti_extrap)
    _, sf = read_csv(MAPS + "map_shev_ice_sfc.csv")
    sfc = Table2D(*long_to_2d(sf), extrap=sfc_extrap)
    _, ef = read_csv(MAPS + "map_shev_genset_drive_eff.csv")
    effmap = Table2D(*long_to_2d(ef), extrap=eff_extrap)

    # derived constants
    Gr = p["G"] / p["r"]
    A = p["fc"] * p["m"] * p["g"]
    B = 0.5 * p["rho"] * p["S"] * p["Cx"]
    m_eff = p["m"] + p["d_J"] * Gr * Gr
    Jgs = p["ice_J"] + p["gen_J"]
    ns, npar = p["ns"], p["np"]
    C_cell = p["QCellNom"] / (p["ECellMax"] - p["ECellMin"])
    C_batt = C_cell * npar / ns
    Emin, Emax = ns * p["ECellMin"], ns * p["ECellMax"]
    R0 = p["R0Cell"] * ns / npar
    R1 = R0
    C1 = (60.0 / p["R0Cell"]) * npar / ns
    Rtot = R0 + R1
    eta, Ieff = p["eff"], p["iEff"]
    # cell-consistent k (identical to the pack formula for np = 1)
    Ec = p["ECellMax"] + p["ECellMin"]
    Rc = 2.0 * p["R0Cell"]
    kpar = ((1 - eta) * Ec - 2 * (1 + eta) * Rc * Ieff) / ((1 + eta) * Ec - 2 * (1 - eta) * Rc * Ieff)
    kpar_pack = ((1 - eta) * (Emax + Emin) - 2 * (1 + eta) * Rtot * Ieff) / (
        (1 + eta) * (Emax + Emin) - 2 * (1 - eta) * Rtot * Ieff)
    assert abs(kpar - kpar_pack) < 1e-12
    p.update(Gr=Gr, A=A, B=B, m_eff=m_eff, C_batt=C_batt, Emin=Emin, Emax=Emax, R0=R0, R1=R1, C1=C1,
             kpar=kpar)

    d_tmax, d_pmax, d_wmax, alpha = p["d_tmax"], p["d_pmax"], p["d_wmax"], p["alpha"]
    g_tmax, g_pmax, g_wmax = p["gen_tmax"], p["gen_pmax"], p["gen_wmax"]
    thr_gain, gms_clamp = p["thr_gain"], p["gms_clamp"]

    def drive(v, tau_cmd, locked):
        """returns tau_d, P_dc drive, F_brake, w_d, state"""
        if locked:
            w_d = 0.0
        else:
            w_d = v * Gr
        yH, st = limiter_yH(w_d, d_tmax, d_pmax, d_wmax, alpha)
        tau_d = min(max(tau_cmd, -yH), yH)
        Fb = Gr * max(0.0, tau_d - tau_cmd)
        return tau_d, tau_d * w_d, Fb, w_d, st

    def genset(w, Pref, on):
        """returns tau_ice, tau_gen, P_dc_gen (drawn, <0 generating), fuel rate g/s, P_ice"""
        if not on:
            return 0.0, 0.0, 0.0, 0.0, 0.0
        Pref = max(0.0, Pref)
        w_opt = opti(Pref)
        thr = thr_gain * (w_opt - w)
        thr = min(max(thr, -1.0), 1.0)
        tmx = tmax_ice(w)
        tau_ice = tmx * min(max(thr, 0.0), 1.0)
        tau_load = Pref / w
        if gms_clamp:
            tau_load = min(max(tau_load, -tmx), tmx)
        yH, st = limiter_yH(w, g_tmax, g_pmax, g_wmax, alpha)
        tau_gen = min(max(-tau_load, -yH), yH)
        Pm = tau_gen * w
        e = effmap(abs(tau_gen) / g_tmax, abs(w) / g_wmax)
        e = max(e, 0.01)
        Pdc = Pm * e if Pm <= 0.0 else Pm / e
        P_ice = tau_ice * w
        sf = max(sfc(tau_ice, w), 0.0)
        fr = sf * P_ice / 3.6e6
        return tau_ice, tau_gen, Pdc, fr, P_ice

    def battery(E, vRC, P):
        vint = E - vRC
        disc = vint * vint - 4.0 * R0 * P
        if disc < 0:
            raise RuntimeError("constant-power load beyond battery capability")
        vt = 0.5 * (vint + math.sqrt(disc))
        i = P / vt
        return i, vt

    def deriv(x, tau_cmd, Pref, on, locked):
        v, s, w, E, vRC, mf = x
        tau_d, Pd, Fb, w_d, _ = drive(v, tau_cmd, locked)
        if locked:
            dv = 0.0
            ds = 0.0
        else:
            dv = (tau_d * Gr - Fb - A - B * v * v) / m_eff   # mode Forward
            ds = v
        tau_ice, tau_gen, Pg, fr, _ = genset(w, Pref, on)
        dw = (tau_ice + tau_gen) / Jgs
        i, _ = battery(E, vRC, Pd + Pg)
        im = i + kpar * abs(i)
        dE = -im / C_batt
        dvRC = (im - vRC / R1) / C1
        return (dv, ds, dw, dE, dvRC, fr)

    def rk4(x, h, *u):
        k1 = deriv(x, *u)
        x2 = tuple(a + 0.5 * h * b for a, b in zip(x, k1))
        k2 = deriv(x2, *u)
        x3 = tuple(a + 0.5 * h * b for a, b in zip(x, k2))
        k3 = deriv(x3, *u)
        x4 = tuple(a + h * b for a, b in zip(x, k3))
        k4 = deriv(x4, *u)
        return tuple(a + h / 6.0 * (b1 + 2 * b2 + 2 * b3 + b4)
                     for a, b1, b2, b3, b4 in zip(x, k1, k2, k3, k4))

    def soc_of(E):
        return (E - Emin) / (Emax - Emin)

    def tau_req(t, v):
        return min(max(p["k_drv"] * (vref(t) - v), -p["yMax"]), p["yMax"])

    return p, dict(drive=drive, genset=genset, battery=battery, rk4=rk4, soc_of=soc_of,
                   tau_req=tau_req, vref=vref)


def simulate(run, t_end=None, h=1e-3, out_every=100, **kw):
    p, f = build(run, **kw)
    drive, genset, battery, rk4 = f["drive"], f["genset"], f["battery"], f["rk4"]
    soc_of, tau_req = f["soc_of"], f["tau_req"]
    if t_end is None:
        t_end = p["t_end"]
    nsteps = int(round(t_end / h))
    n_ecu = int(round(p["ecu_dt"] / h))
    a_f = 1.0 - math.exp(-p["ecu_dt"] / p["T_f"])
    A, Gr = p["A"], p["Gr"]

    E0 = p["Emin"] + p["soc0"] * (p["Emax"] - p["Emin"])
    x = (0.0, 0.0, p["w0"], E0, 0.0, 0.0)
    locked = True
    Pf = p["Pf0"]
    tau_cmd = 0.0
    on = not p["onoff"]   # pf: always on; oo: on(0) = false
    Pref = 0.0
    rows, events = [], []

    for n in range(nsteps + 1):
        t = n * h
        if n % n_ecu == 0:
            # ---- ECU sample (inputs at t_k, previous command still in force for drivePowDc)
            v = x[0]
            _, Pd_prev, _, _, _ = drive(v, tau_cmd, locked)
            soc = soc_of(x[3])
            Pc = min(max(Pf + p["gain"] * (p["socRef"] - soc), 0.0), p["Pmax"])
            if p["onoff"]:
                if not on and Pc > p["on_W"]:
                    on = True
                    events.append((t, "ON", Pc))
                elif on and Pc < p["off_W"]:
                    on = False
                    events.append((t, "OFF", Pc))
            Pref = Pc if on else 0.0
            Pf = Pf + a_f * (Pd_prev - Pf)
            tau_cmd = tau_req(t, 0.0 if locked else v)
            # ---- standstill: break-away test with the new command (sa = F_wheel - F_brake)
            if locked:
                tau_d, _, Fb, _, _ = drive(0.0, tau_cmd, True)
                sa = tau_d * Gr - Fb
                if sa > A:
                    locked = False
                    events.append((t, "unlock", sa))
                elif sa < -A:
                    raise RuntimeError("backward start at t=%g" % t)
        if n % out_every == 0:
            v, s, w, E, vRC, mf = x
            tau_d, Pd, Fb, w_d, _ = drive(v, tau_cmd, locked)
            tau_ice, tau_gen, Pg, fr, Pice = genset(w, Pref, on)
            i, vt = battery(E, vRC, Pd + Pg)
            rows.append((t, v, s, soc_of(E), w, Pice, -Pg, mf, Pd, Pref, int(on), int(locked),
                         tau_ice, tau_gen, vt, i, tau_cmd, tau_d))
        if n == nsteps:
            break
        u = (tau_cmd, Pref, on, locked)
        xn = rk4(x, h, *u)
        if not locked and xn[0] < 0.0:
            # v crosses 0 inside the step: locate by bisection, stop exactly, lock
            lo, hi = 0.0, h
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                if rk4(x, mid, *u)[0] > 0.0:
                    lo = mid
                else:
                    hi = mid
            ts = 0.5 * (lo + hi)
            xs = rk4(x, ts, *u)
            xs = (0.0,) + xs[1:]
            tau_d, _, Fb, _, _ = drive(0.0, tau_cmd, True)
            sa = tau_d * Gr - Fb
            if abs(sa) <= A:
                locked = True
                events.append((t + ts, "lock", sa))
                xn = rk4(xs, h - ts, tau_cmd, Pref, on, True)
            else:
                raise RuntimeError("restart at stop not handled, t=%g sa=%g" % (t + ts, sa))
        x = xn
    cols = ["time_s", "speed_m_s", "distance_m", "soc", "genset_speed_rad_s", "ice_power_W",
            "genset_power_dc_W", "fuel_g", "drive_power_dc_W", "genset_power_ref_W", "genset_on",
            "locked", "ice_torque_Nm", "gen_torque_Nm", "battery_voltage_V", "battery_current_A",
            "drive_torque_ref_Nm", "drive_torque_Nm"]
    return p, cols, rows, events


if __name__ == "__main__":
    if len(sys.argv) < 3 or sys.argv[1] not in ("pf", "oo"):
        sys.exit(__doc__)
    run, out_dir = sys.argv[1], sys.argv[2]
    t_end = float(sys.argv[3]) if len(sys.argv) > 3 else None
    p, cols, rows, events = simulate(run, t_end)
    with open(os.path.join(out_dir, "%s_resim.csv" % run), "w", newline="") as fo:
        w = csv.writer(fo)
        w.writerow(cols)
        for r in rows:
            w.writerow(["%.17g" % v for v in r])
    with open(os.path.join(out_dir, "%s_events.txt" % run), "w") as fo:
        for e in events:
            fo.write("%.6f %s %.10g\n" % e)
    print("done", run, "k =", p["kpar"], "C_batt =", p["C_batt"], "C1 =", p["C1"])
