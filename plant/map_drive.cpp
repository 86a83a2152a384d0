// SPDX-License-Identifier: BSD-3-Clause
#include "plant/map_drive.hpp"

#include <algorithm>
#include <cmath>

namespace ehpt::plant {

void validate(const MapDriveParams& p, const std::string& at, Problems& problems) {
  problems.require_positive(at + ".torque_max_Nm", p.torque_max_Nm);
  problems.require_positive(at + ".power_max_W", p.power_max_W);
  problems.require_positive(at + ".speed_max_rad_s", p.speed_max_rad_s);
  problems.require_positive(at + ".inertia_kgm2", p.inertia_kgm2);
  problems.require_in(at + ".limit_ramp_fraction", p.limit_ramp_fraction, 0.0, 1.0, true, false);
  if (p.loss_model == DriveLossModel::kMap) {
    validate(p.efficiency_map, at + ".efficiency_map", problems);
    const auto& eta = p.efficiency_map.values();
    for (std::size_t k = 0; k < eta.size(); ++k) {
      if (!(eta[k] > 0.0 && eta[k] <= 1.0)) {
        problems.add_cell(at + ".efficiency_map", k, 2, number_text(eta[k]), "efficiency must be in (0, 1]");
        break;
      }
    }
  }
  if (p.loss_model == DriveLossModel::kConstant && !(p.efficiency > 0.0 && p.efficiency <= 1.0)) {
    problems.add(at + ".efficiency", number_text(p.efficiency), "must be in (0, 1]");
  }
  if (p.loss_model == DriveLossModel::kFormula) {
    problems.require_non_negative(at + ".loss_formula.a", p.loss_formula.a);
    problems.require_non_negative(at + ".loss_formula.b_t", p.loss_formula.b_t);
    problems.require_non_negative(at + ".loss_formula.b_w", p.loss_formula.b_w);
    problems.require_non_negative(at + ".loss_formula.b_p", p.loss_formula.b_p);
  }
}

void warn(const MapDriveParams& p, const std::string& at, Problems& warnings) {
  const double base_rad_s = p.power_max_W / p.torque_max_Nm;
  if (p.speed_max_rad_s < base_rad_s) {
    warnings.add(at + ".speed_max_rad_s", number_text(p.speed_max_rad_s),
                 "below power_max_W / torque_max_Nm = " + number_text(base_rad_s) +
                     " rad/s: the power-limited state 1 is never reached and the limit jumps from " +
                     number_text(p.torque_max_Nm) + " to " + number_text(p.power_max_W / p.speed_max_rad_s) +
                     " N m at speed_max (library behaviour, MODELS.md §1.3)");
  }
}

MapDrive::MapDrive(const MapDriveParams& params) : p_(params) {
  base_speed_rad_s_ = p_.power_max_W / p_.torque_max_Nm;
  inv_torque_max_ = 1.0 / p_.torque_max_Nm;
  inv_speed_max_ = 1.0 / p_.speed_max_rad_s;
  inv_ramp_rad_s_ = 1.0 / (p_.limit_ramp_fraction * p_.speed_max_rad_s);
  power_over_speed_max_Nm_ = p_.power_max_W / p_.speed_max_rad_s;
}

}  // namespace ehpt::plant
