// SPDX-License-Identifier: BSD-3-Clause
#include "plant/prop_driver.hpp"

namespace ehpt::plant {

void validate(const PropDriverParams& p, const std::string& at, Problems& problems) {
  validate(p.cycle_m_s, at + ".cycle", true, problems);
  const auto& v = p.cycle_m_s.y();
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (!(v[i] >= 0.0 && v[i] < 200.0)) {
      problems.add_cell(at + ".cycle", i, 1, number_text(v[i]), "speed must be >= 0 and below 200 m/s (720 km/h)");
      break;
    }
  }
  // gain 0 is a coasting car (no request): useful to check a plant against closed forms
  problems.require_non_negative(at + ".gain", p.gain);
  problems.require_positive(at + ".request_max", p.request_max);
  if (!(p.request_min <= 0.0)) problems.add(at + ".request_min", number_text(p.request_min), "must be <= 0");
}

}  // namespace ehpt::plant
