#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""MBecu2 (and MBecu1, MBecu1soc) in Python: the built-in power-split ECU of ecu/psd_ecu.cpp,
written again as an ECU of your own would be, and run in process against the plant.

It performs the same floating-point operations in the same order as the C++ (Python floats are
IEEE doubles; math.exp is the same libm exp), including the PowToW table lookup of
plant/table.hpp, so its run equals the built-in one bit for bit (tests/python/test_python_ecu.py
checks it). Start from here to test an ECU of your own in process:

    /usr/bin/python3 python/examples/mbecu2_ecu.py [SCENARIO] [dotted.key=value ...]

(with the module on PYTHONPATH, e.g. PYTHONPATH=build/python).
"""

import ast
import math
import sys
from types import SimpleNamespace

# the ehpt module is needed to run in process (run_with_python_ecu, main); the ECU itself
# (PsdEcu.decide) is plain Python, so that an ECU on a bus can use it without the module
# (examples/own_dbc/vcu_ecu.py)
try:
    import ehpt
except ImportError:  # pragma: no cover - only the bus examples import this file without it
    ehpt = None


class PowToW:
    """The ECU's power -> engine speed table: plant::Table1d with linear extrapolation.

    The lookup is plant::AxisIndex's, step for step (uniform axis: one multiplication; any other
    axis: a bucket grid and a short forward scan), because the segment it picks and the fraction
    it computes decide the last bits of the result."""

    def __init__(self, x, y):
        self.x, self.y = list(x), list(y)
        n = len(x)
        self.last = n - 2
        self.x0 = x[0]
        self.inv_dx = [1.0 / (x[i + 1] - x[i]) if x[i + 1] > x[i] else 0.0 for i in range(n - 1)]
        span = x[-1] - x[0]
        self.uniform = all(abs(x[i] - (self.x0 + span * float(i) / float(n - 1))) <= 1e-12 * span
                           for i in range(n))
        if self.uniform:
            self.buckets = float(n - 1)
            self.inv_width = self.buckets / span
            return
        buckets = min(16 * n, 1 << 18)
        self.buckets = float(buckets)
        self.inv_width = self.buckets / span
        self.bucket = []
        i = 0
        for k in range(buckets):
            lower = self.x0 + (float(k) - 0.5) / self.inv_width
            while i + 2 < n and x[i + 1] <= lower:
                i += 1
            self.bucket.append(i)

    def _locate(self, u):
        k = (u - self.x0) * self.inv_width
        if self.uniform:
            # C++: i = k > 0 ? int64(k) : 0, then the last segment if k >= buckets (tested first
            # here: int() of an infinite k would raise)
            i = self.last if k >= self.buckets else (int(k) if k > 0.0 else 0)
            return i, k - float(i)
        i = 0
        if k >= self.buckets:
            i = self.last
        elif k > 0.0:
            i = self.bucket[int(k)]
            while i < self.last and self.x[i + 1] <= u:
                i += 1
        return i, (u - self.x[i]) * self.inv_dx[i]

    def __call__(self, u):
        # inside the axis or beyond it, linear extrapolation is the same formula on the end segment
        i, t = self._locate(u)
        return self.y[i] + t * (self.y[i + 1] - self.y[i])


class PsdEcu:
    """ecu::PsdEcu: one update per ECU period, from the sensors sampled at its start."""

    def __init__(self, params):
        """params: Simulation.ecu_parameters (what the scenario loaded, overrides included)."""
        p = dict(params)
        self.kind = p["kind"]
        period_s = p["period_s"]
        self.max_torque_request_Nm = p["max_torque_request_Nm"]
        self.gen_loop_gain = p["gen_loop_gain_Nm_s_rad"]
        self.gen_torque_max_Nm = p["gen_torque_max_Nm"]
        self.ice_speed_min_rad_s = p["ice_speed_min_rad_s"]
        self.pow_to_w = PowToW(p["power_to_speed_W"], p["power_to_speed_rad_s"])
        self.soc_ref = p["soc_ref"]
        self.soc_loop_gain_W = 0.0 if self.kind == "MBecu1" else p["soc_loop_gain_W"]
        self.on_threshold_W = p["on_threshold_W"]
        self.off_threshold_W = p["off_threshold_W"]
        self.ice_off_speed_ref_rad_s = p["ice_off_speed_ref_rad_s"]
        # the filters, exact for an input held over the period: 1 - exp(-Ts / T)
        self.a_power = 1.0 - math.exp(-period_s / p["power_filter_s"])
        self.a_gen = 1.0 - math.exp(-period_s / p["gen_filter_s"])
        self.p_avg_W = 0.0
        self.tau_gf_Nm = 0.0
        self.ice_on = False
        self.sequence = 0

    def update(self, s):
        """PsdSensors -> PsdCommand, stamped with the sample it answers (as the runner stamps
        the built-in ECU's command)."""
        d = self.decide(s)
        out = ehpt.PsdCommand()
        out.motTauRef_Nm, out.iceON, out.icePowRef_W = d.motTauRef_Nm, d.iceON, d.icePowRef_W
        out.iceTauRef_Nm, out.genTauRef_Nm = d.iceTauRef_Nm, d.genTauRef_Nm
        out.stamp = ehpt.Stamp(time_s=s.stamp.time_s, step=s.stamp.step, sequence=self.sequence)
        self.sequence = (self.sequence + 1) & 0xFFFFFFFF
        return out

    def decide(self, s):
        """The sensors (driverRequest, batSOC, motPowDelB_W, iceW_rad_s as attributes) -> the
        command's five fields (ecu/psd_ecu.cpp PsdEcu::update, line by line)."""
        out = SimpleNamespace()
        out.motTauRef_Nm = self.max_torque_request_Nm * s.driverRequest
        p_add_W = self.p_avg_W + self.soc_loop_gain_W * (self.soc_ref - s.batSOC)
        if self.kind == "MBecu2":
            if not self.ice_on and p_add_W > self.on_threshold_W:
                self.ice_on = True
            if self.ice_on and p_add_W < self.off_threshold_W:
                self.ice_on = False
        else:
            self.ice_on = True
        out.iceON = self.ice_on
        out.icePowRef_W = p_add_W if self.ice_on else 0.0
        out.iceTauRef_Nm = 0.0
        if self.ice_on:
            w = self.pow_to_w(out.icePowRef_W)
            speed_ref_rad_s = w if self.ice_speed_min_rad_s < w else self.ice_speed_min_rad_s  # std::max(min, w)
        else:
            speed_ref_rad_s = self.ice_off_speed_ref_rad_s
        # std::clamp(v, lo, hi) in libstdc++: min(max(v, lo), hi)
        lo, hi = -self.gen_torque_max_Nm, self.gen_torque_max_Nm
        v = lo if self.tau_gf_Nm < lo else self.tau_gf_Nm
        out.genTauRef_Nm = hi if hi < v else v
        self.p_avg_W += self.a_power * (s.motPowDelB_W - self.p_avg_W)
        self.tau_gf_Nm += self.a_gen * (self.gen_loop_gain * (speed_ref_rad_s - s.iceW_rad_s) - self.tau_gf_Nm)
        return out


def run_with_python_ecu(scenario, overrides=None):
    """The scenario with this ECU instead of the built-in one: the lockstep loop (at every ECU
    sample read the sensors, write the command, step one period). Returns the Simulation."""
    sim = ehpt.Simulation(scenario, set=overrides, external_ecu=True)
    ecu = PsdEcu(sim.ecu_parameters)
    period = sim.ecu_period_steps
    while not sim.finished:
        sim.write_command(ecu.update(sim.read_sensors()))
        sim.step(period)
    return sim


def main(argv):
    scenario = argv[1] if len(argv) > 1 else "psecu2_nedc"
    overrides = {}
    for kv in argv[2:]:  # key=value: a Python literal (0.62, True, "x"), else the text
        key, _, value = kv.partition("=")
        try:
            overrides[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            overrides[key] = value
    mine = run_with_python_ecu(scenario, overrides).timeseries()
    builtin = ehpt.run(scenario, set=overrides).timeseries
    same = all(mine[k].tobytes() == builtin[k].tobytes() for k in builtin)
    print(f"{scenario}: the Python ECU's run {'equals' if same else 'DIFFERS FROM'} the built-in ECU's, bit for bit")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
