// SPDX-License-Identifier: BSD-3-Clause
#include "plant/road_load.hpp"

namespace ehpt::plant {

void validate(const RoadLoadParams& p, const std::string& at, Problems& problems) {
  if (p.form == RoadLoadForm::kCoefficients) {
    problems.require_non_negative(at + ".rolling_coefficient", p.rolling_coefficient);
    problems.require_positive(at + ".air_density_kg_m3", p.air_density_kg_m3);
    problems.require_non_negative(at + ".frontal_area_m2", p.frontal_area_m2);
    problems.require_non_negative(at + ".drag_coefficient", p.drag_coefficient);
  } else {
    problems.require_non_negative(at + ".f0_N", p.f0_N);
    problems.require_non_negative(at + ".f1_N_s_m", p.f1_N_s_m);
    problems.require_non_negative(at + ".f2_N_s2_m2", p.f2_N_s2_m2);
  }
  if (!p.slope_rad.empty()) {
    validate(p.slope_rad, at + ".slope", false, problems);
    const auto& angle = p.slope_rad.y();
    for (std::size_t i = 0; i < angle.size(); ++i) {
      if (!(angle[i] > -1.5 && angle[i] < 1.5)) {
        problems.add_cell(at + ".slope", i, 1, number_text(angle[i]), "angle must be in (-1.5, 1.5) rad");
        break;
      }
    }
  }
}

RoadLoad::RoadLoad(const RoadLoadParams& p, double mass_kg) : p_(p), mass_kg_(mass_kg) {
  if (p.form == RoadLoadForm::kCoefficients) {
    rolling_level_N_ = p.rolling_coefficient * mass_kg * kGravity_m_s2;
    f1_N_s_m_ = 0.0;
    f2_N_s2_m2_ = 0.5 * p.air_density_kg_m3 * p.frontal_area_m2 * p.drag_coefficient;
  } else {
    rolling_level_N_ = p.f0_N;
    f1_N_s_m_ = p.f1_N_s_m;
    f2_N_s2_m2_ = p.f2_N_s2_m2;
  }
  has_slope_ = !p.slope_rad.empty();
}

}  // namespace ehpt::plant
