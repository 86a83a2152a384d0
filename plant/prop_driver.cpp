#include "plant/prop_driver.hpp"

namespace ehpt::plant {

void validate(const PropDriverParams& p, const std::string& at, Problems& problems) {
  validate(p.cycle_m_s, at + ".cycle", true, problems);
  for (double v : p.cycle_m_s.y()) {
    if (!(v >= 0.0 && v < 200.0)) {
      problems.add(at + ".cycle", number_text(v), "speeds must be in [0, 200) m/s");
      break;
    }
  }
  problems.require_positive(at + ".gain", p.gain);
  problems.require_positive(at + ".request_max", p.request_max);
  if (!(p.request_min <= 0.0)) problems.add(at + ".request_min", number_text(p.request_min), "must be <= 0");
}

}  // namespace ehpt::plant
