// SPDX-License-Identifier: BSD-3-Clause
#include "plant/ev_machine_plant.hpp"

#include <cmath>
#include <optional>

namespace ehpt::plant {

namespace {

// The pack's EMF at the bottom of its SOC window: the least the DC bus holds at no load.
// nullopt if the battery data are invalid (reported by the battery's own checks).
std::optional<double> lowest_dc_V(const BatteryRcParams& b) {
  if (!(b.cells_series >= 1 && std::isfinite(b.cell_emf_min_V) && std::isfinite(b.cell_emf_max_V) &&
        std::isfinite(b.soc_min))) {
    return std::nullopt;
  }
  return b.cells_series * (b.cell_emf_min_V + b.soc_min * (b.cell_emf_max_V - b.cell_emf_min_V));
}

// A sine-modulated inverter gives at most u_dc / sqrt 3 peak phase voltage.
void check_set_voltage(const char* field, double rms_V, const BatteryRcParams& b, Problems& problems) {
  const std::optional<double> u_dc_V = lowest_dc_V(b);
  if (!u_dc_V || !std::isfinite(rms_V)) return;
  const double peak_V = std::sqrt(2.0) * rms_V;
  if (peak_V > *u_dc_V / std::sqrt(3.0)) {
    problems.add(field, number_text(rms_V),
                 "the DC bus cannot supply it: its peak (" + number_text(peak_V) + " V) is above u_dc / sqrt 3 = " +
                     number_text(*u_dc_V / std::sqrt(3.0)) + " V at the pack's lowest EMF (" + number_text(*u_dc_V) +
                     " V at battery.soc_min)");
  }
}

}  // namespace

void PmMachine::validate_with_battery(const Params& p, const BatteryRcParams& b, Problems& problems) {
  check_set_voltage("drive.U_max_rms_V", p.U_max_rms_V, b, problems);
}

void AmMachine::validate_with_battery(const Params& p, const BatteryRcParams& b, Problems& problems) {
  check_set_voltage("drive.U_base_rms_V", p.U_base_rms_V, b, problems);
}

template class EvPlant<PmMachine>;
template class EvPlant<AmMachine>;

}  // namespace ehpt::plant
