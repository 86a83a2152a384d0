// SPDX-License-Identifier: BSD-3-Clause
#include "plant/map_ice.hpp"

namespace ehpt::plant {

void validate(const MapIceParams& p, const std::string& at, Problems& problems) {
  problems.require_positive(at + ".inertia_kgm2", p.inertia_kgm2);
  problems.require_finite(at + ".speed_initial_rad_s", p.speed_initial_rad_s);
  problems.require_non_negative(at + ".control_gain_Nm_W", p.control_gain_Nm_W);
  problems.require_positive(at + ".fuel_lhv_J_kg", p.fuel_lhv_J_kg);
  problems.require_positive(at + ".fuel_density_kg_m3", p.fuel_density_kg_m3);
  validate(p.torque_max_Nm, at + ".torque_max", false, problems);
  const auto& tau = p.torque_max_Nm.y();
  for (std::size_t i = 0; i < tau.size(); ++i) {
    if (!(tau[i] >= 0.0)) {
      problems.add_cell(at + ".torque_max", i, 1, number_text(tau[i]), "maximum torque must be >= 0");
      break;
    }
  }
  validate(p.sfc_g_kWh, at + ".sfc_map", problems);
  const auto& sfc = p.sfc_g_kWh.values();
  for (std::size_t k = 0; k < sfc.size(); ++k) {
    if (!(sfc[k] > 0.0)) {
      problems.add_cell(at + ".sfc_map", k, 2, number_text(sfc[k]), "specific consumption must be > 0 g/kWh");
      break;
    }
  }
}

}  // namespace ehpt::plant
