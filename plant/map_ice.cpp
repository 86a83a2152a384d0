#include "plant/map_ice.hpp"

namespace ehpt::plant {

void validate(const MapIceParams& p, const std::string& at, Problems& problems) {
  problems.require_positive(at + ".inertia_kgm2", p.inertia_kgm2);
  problems.require_finite(at + ".speed_initial_rad_s", p.speed_initial_rad_s);
  problems.require_non_negative(at + ".control_gain_Nm_W", p.control_gain_Nm_W);
  problems.require_positive(at + ".fuel_lhv_J_kg", p.fuel_lhv_J_kg);
  problems.require_positive(at + ".fuel_density_kg_m3", p.fuel_density_kg_m3);
  validate(p.torque_max_Nm, at + ".torque_max", false, problems);
  for (double t : p.torque_max_Nm.y()) {
    if (!(t >= 0.0)) {
      problems.add(at + ".torque_max", number_text(t), "maximum torque must be >= 0");
      break;
    }
  }
  validate(p.sfc_g_kWh, at + ".sfc_map", problems);
  for (double s : p.sfc_g_kWh.values()) {
    if (!(s > 0.0)) {
      problems.add(at + ".sfc_map", number_text(s), "specific consumption must be > 0 g/kWh");
      break;
    }
  }
}

}  // namespace ehpt::plant
