// SPDX-License-Identifier: BSD-3-Clause
#include "plant/vehicle_body.hpp"

namespace ehpt::plant {

void validate(const VehicleBodyParams& p, const std::string& at, Problems& problems) {
  problems.require_positive(at + ".mass_kg", p.mass_kg);
  problems.require_positive(at + ".wheel_radius_m", p.wheel_radius_m);
  problems.require_positive(at + ".gear_ratio", p.gear_ratio);
  problems.require_non_negative(at + ".speed_initial_m_s", p.speed_initial_m_s);
}

}  // namespace ehpt::plant
