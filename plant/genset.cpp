// SPDX-License-Identifier: BSD-3-Clause
#include "plant/genset.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace ehpt::plant {

void validate(const GensetParams& p, const std::string& at, Problems& problems) {
  validate(p.ice, at + ".ice", problems);
  validate(p.generator, at + ".generator", problems);
  problems.require_positive(at + ".gear_ratio", p.gear_ratio);
  problems.require_positive(at + ".throttle_per_rad_s", p.throttle_per_rad_s);
  validate(p.opti_speed_rpm, at + ".opti_speed", false, problems);
  const auto& rpm = p.opti_speed_rpm.y();
  for (std::size_t i = 0; i < rpm.size(); ++i) {
    if (!(rpm[i] > 0.0)) {
      problems.add_cell(at + ".opti_speed", i, 1, number_text(rpm[i]), "the best speed must be > 0 rpm");
      break;
    }
  }
}

Genset::Genset(const GensetParams& params)
    : p_(params),
      ice_(params.ice),
      gen_(params.generator),
      inertia_kgm2_(params.ice.inertia_kgm2 + params.generator.inertia_kgm2 / (params.gear_ratio * params.gear_ratio)) {}

GensetPoint Genset::operate(double power_request_W, bool on, double speed_rad_s, double gen_torque_gain) const {
  GensetPoint g;
  const double w = speed_rad_s, r = p_.gear_ratio;
  const double power_ref_W = power_request_W > 0.0 ? power_request_W : 0.0;  // the input limiter
  g.speed_ref_rad_s = p_.opti_speed_rpm(power_ref_W) * (2.0 * std::numbers::pi / 60.0);
  g.throttle = std::clamp(p_.throttle_per_rad_s * (g.speed_ref_rad_s - w), -1.0, 1.0);
  g.ice_torque_max_Nm = ice_.torque_max_Nm(w);
  if (!on) {  // GensetOO switched off: no fuel, no torque from either machine
    g.gen = gen_.operate(0.0, w / r);
    return g;
  }
  g.ice_torque_Nm = g.ice_torque_max_Nm * std::clamp(g.throttle, 0.0, 1.0);
  // the load the GMS asks of the generator, within what the engine can give at this speed (a
  // shaft at rest asks nothing: P / w has no value there)
  double load_Nm = w != 0.0 ? power_ref_W / w : 0.0;
  if (p_.gms_limits_torque) load_Nm = std::clamp(load_Nm, -g.ice_torque_max_Nm, g.ice_torque_max_Nm);
  g.gen_request_Nm = -r * load_Nm;
  g.gen = gen_.operate(g.gen_request_Nm, w / r);
  if (gen_torque_gain != 1.0) [[unlikely]] g.gen = gen_.derated(g.gen, g.gen_request_Nm, w / r, gen_torque_gain);
  g.fuel_rate_kg_s = ice_.fuel_rate_kg_s(g.ice_torque_Nm, w);
  g.shaft_torque_Nm = g.ice_torque_Nm + g.gen.torque_Nm / r;
  return g;
}

}  // namespace ehpt::plant
