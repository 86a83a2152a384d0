// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// How healthy a plant's components are: what a plant fault (docs/testing.md, [[fault]] with
// target = "battery" or a machine) changes while it acts. Set between steps only, by the run's
// fault injector (hil/run/fault_injector.hpp), on the plant that run owns; a healthy plant is
// PlantHealth{} and computes bit for bit what it computed before plant faults existed.

#include <array>

namespace ehpt::plant {

struct BatteryHealth {
  double r0_gain = 1.0;        // R0 x r0_gain (ageing, a loose connection)
  double capacity_gain = 1.0;  // C_batt x capacity_gain (capacity fade; the EMF does not jump)
  int strings_lost = 0;        // of strings_parallel: C_batt, C1, the current limit x (np - k)/np, R0, R1 x np/(np - k)
  double short_A = 0.0;        // an internal short: a self-discharge current in the main branch
};

// The machines a plant fault may name, in a plant's order (EV: "drive"; PSD: "gen", "mot").
inline constexpr int kMaxMachines = 2;

struct PlantHealth {
  BatteryHealth battery;
  std::array<double, kMaxMachines> torque_gain = {1.0, 1.0};  // derating: the torque bound x gain
};

}  // namespace ehpt::plant
