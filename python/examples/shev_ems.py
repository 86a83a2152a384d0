#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""The series hybrid's EMS in Python: PowerFilt, PowerFiltSoc and ShevEMS (MODELS.md §5.5), the
built-in ECU of ecu/shev_ems.cpp written again as an energy management of your own would be,
and run in process against the plant.

It does the same floating-point operations in the same order as the C++ (Python floats are
IEEE doubles; math.exp is the same libm exp), so its run equals the built-in one bit for bit
(tests/python/test_python_ecu.py checks it). Start from here to try a strategy of your own:

    /usr/bin/python3 python/examples/shev_ems.py [SCENARIO] [dotted.key=value ...]

(with the module on PYTHONPATH, e.g. PYTHONPATH=build/python).
"""

import ast
import math
import sys

import ehpt


class ShevEms:
    """One ECU period: the sensors sampled at its start -> the command for it.

    P_c = clamp(P_f + soc_gain_W * (soc_ref - SOC), 0, power_max_W), where P_f is the drive's DC
    power through a first-order filter (time constant power_filter_s, exact for the input held
    over the period); ShevEMS switches the genset on above on_W and off below off_W (and asks
    nothing of it while off), the other two keep it running."""

    def __init__(self, params):
        self.kind = params["kind"]
        self.a_power = 1.0 - math.exp(-params["period_s"] / params["power_filter_s"])
        self.p_f_W = params["power_filter_initial_W"]
        self.power_max_W = params["power_max_W"]
        self.soc_ref = params["soc_ref"]
        self.soc_gain_W = 0.0 if self.kind == "PowerFilt" else params["soc_gain_W"]
        self.on_W, self.off_W = params["on_W"], params["off_W"]
        self.on = False
        self.sequence = 0

    def update(self, s):
        p_c_W = min(max(self.p_f_W + self.soc_gain_W * (self.soc_ref - s.batSOC), 0.0), self.power_max_W)
        if self.kind == "ShevEMS":
            if not self.on and p_c_W > self.on_W:
                self.on = True
            if self.on and p_c_W < self.off_W:
                self.on = False
        else:
            self.on = True
        command = ehpt.ShevCommand(driveTauRef_Nm=s.driverRequest_Nm, gensetPowRef_W=p_c_W if self.on else 0.0,
                                   gensetON=self.on,
                                   stamp=ehpt.Stamp(time_s=s.stamp.time_s, step=s.stamp.step, sequence=self.sequence))
        self.sequence += 1
        self.p_f_W += self.a_power * (s.drivePowDc_W - self.p_f_W)  # the filter, after the command (its state at the sample)
        return command


def run_with_python_ems(scenario, overrides=None, ems_class=ShevEms):
    """The scenario with this EMS instead of the built-in one: at every ECU sample read the
    sensors, write the command, step one period. Returns the Simulation."""
    sim = ehpt.Simulation(scenario, set=overrides, external_ecu=True)
    period = sim.ecu_period_steps
    ems = ems_class(sim.ecu_parameters)
    while not sim.finished:
        sim.write_command(ems.update(sim.read_sensors()))
        sim.step(period)
    return sim


def main(argv):
    scenario = argv[1] if len(argv) > 1 else "shev_oo_sort1"
    overrides = {}
    for kv in argv[2:]:  # key=value: a Python literal (0.62, True, "x"), else the text
        key, _, value = kv.partition("=")
        try:
            overrides[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            overrides[key] = value
    mine = run_with_python_ems(scenario, overrides).timeseries()
    builtin = ehpt.run(scenario, set=overrides).timeseries
    same = all(mine[k].tobytes() == builtin[k].tobytes() for k in builtin)
    print(f"{scenario}: the Python EMS's run {'equals' if same else 'DIFFERS FROM'} the built-in EMS's, bit for bit")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
