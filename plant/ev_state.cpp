// SPDX-License-Identifier: BSD-3-Clause
#include "plant/ev_state.hpp"

#include <cmath>

namespace ehpt::plant {

EnergyAudit ev_energy_audit(const BatteryRc& battery, double mass_eff_kg, double mass_kg, const double* x0,
                            const double* x) {
  const double fault_removed_J = battery.removed_by_faults_J();
  using L = EvStateLayout;
  const auto delta = [&](int i) { return x[i] - x0[i]; };
  const double stored_out_J = battery.stored_out_J(x0[L::kEmf], x0[L::kVrc], x[L::kEmf], x[L::kVrc]);
  const double kinetic_J = 0.5 * mass_eff_kg * (x[L::kSpeed] * x[L::kSpeed] - x0[L::kSpeed] * x0[L::kSpeed]);
  const double potential_J = mass_kg * kGravity_m_s2 * delta(L::kAltitude);
  EnergyAudit a;
  a.sources_J = stored_out_J;
  a.scale_J = std::abs(stored_out_J);
  a.battery_out_J = delta(L::kBatteryOutJ);
  a.battery_loss_J = delta(L::kBatteryLossJ);
  a.residual_J = stored_out_J - (delta(L::kRoadJ) + delta(L::kDriveLossJ) + delta(L::kBatteryLossJ) +
                                 delta(L::kBrakeJ) + kinetic_J + potential_J);
  a.terms = {{"battery_stored_out_J", stored_out_J},      {"battery_terminal_out_J", delta(L::kBatteryOutJ)},
             {"road_load_work_J", delta(L::kRoadJ)},       {"drive_losses_J", delta(L::kDriveLossJ)},
             {"battery_losses_J", delta(L::kBatteryLossJ)}, {"brake_dissipation_J", delta(L::kBrakeJ)},
             {"kinetic_energy_change_J", kinetic_J},        {"potential_energy_change_J", potential_J}};
  if (fault_removed_J != 0.0) a.terms.push_back({"battery_removed_by_faults_J", fault_removed_J});
  return a;
}

}  // namespace ehpt::plant
