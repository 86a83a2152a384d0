#include "plant/map_drive.hpp"

#include <algorithm>
#include <cmath>

namespace ehpt::plant {

namespace {
constexpr double kEfficiencyFloor = 0.01;  // §1.4: avoid dividing by ~0 outside the map
}

void validate(const MapDriveParams& p, const std::string& at, Problems& problems) {
  problems.require_positive(at + ".torque_max_Nm", p.torque_max_Nm);
  problems.require_positive(at + ".power_max_W", p.power_max_W);
  problems.require_positive(at + ".speed_max_rad_s", p.speed_max_rad_s);
  problems.require_positive(at + ".inertia_kgm2", p.inertia_kgm2);
  problems.require_in(at + ".limit_ramp_fraction", p.limit_ramp_fraction, 0.0, 1.0, true, false);
  if (p.loss_model == DriveLossModel::kMap) {
    validate(p.efficiency_map, at + ".efficiency_map", problems);
    for (double eta : p.efficiency_map.values()) {
      if (!(eta > 0.0 && eta <= 1.0)) {
        problems.add(at + ".efficiency_map", number_text(eta), "efficiency must be in (0, 1]");
        break;
      }
    }
  }
  if (p.loss_model == DriveLossModel::kFormula) {
    problems.require_non_negative(at + ".loss_formula.a", p.loss_formula.a);
    problems.require_non_negative(at + ".loss_formula.b_t", p.loss_formula.b_t);
    problems.require_non_negative(at + ".loss_formula.b_w", p.loss_formula.b_w);
    problems.require_non_negative(at + ".loss_formula.b_p", p.loss_formula.b_p);
  }
}

MapDrive::MapDrive(const MapDriveParams& params) : p_(params) {
  base_speed_rad_s_ = p_.power_max_W / p_.torque_max_Nm;
  inv_torque_max_ = 1.0 / p_.torque_max_Nm;
  inv_speed_max_ = 1.0 / p_.speed_max_rad_s;
  inv_ramp_rad_s_ = 1.0 / (p_.limit_ramp_fraction * p_.speed_max_rad_s);
  power_over_speed_max_Nm_ = p_.power_max_W / p_.speed_max_rad_s;
}

TorqueLimit MapDrive::torque_limit(double speed_rad_s) const {
  const double w = std::abs(speed_rad_s);
  if (w > p_.speed_max_rad_s) {
    const double ramp = (w - p_.speed_max_rad_s) * inv_ramp_rad_s_;
    if (ramp < 1.0) return {power_over_speed_max_Nm_ * (1.0 - ramp), 2};
    return {0.0, 3};
  }
  if (w < base_speed_rad_s_) return {p_.torque_max_Nm, 0};
  return {p_.power_max_W / w, 1};
}

double MapDrive::efficiency(double torque_Nm, double speed_rad_s) const {
  switch (p_.loss_model) {
    case DriveLossModel::kIdeal:
      return 1.0;
    case DriveLossModel::kMap: {
      const double eta = p_.efficiency_map(std::abs(torque_Nm) * inv_torque_max_, std::abs(speed_rad_s) * inv_speed_max_);
      return std::max(eta, kEfficiencyFloor);
    }
    case DriveLossModel::kFormula: {
      const double tu = std::abs(torque_Nm) * inv_torque_max_;
      const double wu = std::abs(speed_rad_s) * inv_speed_max_;
      const double pu = tu * wu;
      const LossFormula& f = p_.loss_formula;
      const double loss_pu = f.a + f.b_t * tu * tu + f.b_w * wu * wu + f.b_p * pu * pu;
      // at zero torque or speed P_mech = 0 as well: report eta = 1 there (no power flows)
      if (pu == 0.0) return 1.0;
      return std::max(pu / (pu + loss_pu), kEfficiencyFloor);
    }
  }
  return 1.0;
}

DriveOperatingPoint MapDrive::operate(double torque_request_Nm, double speed_rad_s) const {
  const TorqueLimit lim = torque_limit(speed_rad_s);
  DriveOperatingPoint op;
  op.torque_Nm = std::clamp(torque_request_Nm, -lim.torque_Nm, lim.torque_Nm);
  op.limit_Nm = lim.torque_Nm;
  op.limit_state = lim.state;
  op.limiting = std::abs(op.torque_Nm - torque_request_Nm) > 1e-15;
  op.power_mech_W = op.torque_Nm * speed_rad_s;
  op.efficiency = efficiency(op.torque_Nm, speed_rad_s);
  // motoring: losses added; generating: losses subtracted (§1.4)
  op.power_dc_W = op.power_mech_W > 0.0 ? op.power_mech_W / op.efficiency : op.power_mech_W * op.efficiency;
  return op;
}

}  // namespace ehpt::plant
