// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// What the battery-electric vehicles (EvPlant, ev_plant.hpp: the map-based EV and the
// machine-drive EVs) share beyond their components: one state layout,
//   [v | VehicleBody (s, h, road work, brake work) | BatteryRc (E, v_rc) |
//    battery terminal energy out, drive losses, battery losses]        (m/s, m, J, V)
// and one energy balance over it:
//   stored-energy decrease = road work + drive losses + battery losses + brake
//                            + change of kinetic energy (vehicle + rotor) + m g (h - h0)

#include <array>

#include "plant/battery_rc.hpp"
#include "plant/signals.hpp"
#include "plant/vehicle_body.hpp"

namespace ehpt::plant {

struct EvStateLayout {
  // offsets composed from the components' sizes
  static constexpr int kSpeed = 0;
  static constexpr int kBodyAt = kSpeed + 1;
  static constexpr int kBatteryAt = kBodyAt + VehicleBody::kNumStates;
  static constexpr int kIntegralsAt = kBatteryAt + BatteryRc::kNumStates;
  static constexpr int kNumStates = kIntegralsAt + 3;
  static constexpr int kDistance = kBodyAt + VehicleBody::kDistance, kAltitude = kBodyAt + VehicleBody::kAltitude;
  static constexpr int kRoadJ = kBodyAt + VehicleBody::kRoadJ, kBrakeJ = kBodyAt + VehicleBody::kBrakeJ;
  static constexpr int kEmf = kBatteryAt + BatteryRc::kEmf, kVrc = kBatteryAt + BatteryRc::kVrc;
  static constexpr int kBatteryOutJ = kIntegralsAt, kDriveLossJ = kIntegralsAt + 1, kBatteryLossJ = kIntegralsAt + 2;
  // States no derivative reads (the audit's integrals and the altitude; the distance is read:
  // a slope table is a function of it): implicit Euler skips their Jacobian columns.
  static constexpr std::array<int, 6> kAuditOnlyStates = {kAltitude, kRoadJ, kBrakeJ, kBatteryOutJ, kDriveLossJ,
                                                          kBatteryLossJ};
};

// The balance above between the states x0 and x (kNumStates values each; end of run, allocates).
// mass_eff_kg: vehicle + rotor reflected (kinetic energy); mass_kg: the vehicle (potential).
EnergyAudit ev_energy_audit(const BatteryRc& battery, double mass_eff_kg, double mass_kg, const double* x0,
                            const double* x);

}  // namespace ehpt::plant
