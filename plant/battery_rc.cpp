// SPDX-License-Identifier: BSD-3-Clause
#include "plant/battery_rc.hpp"

#include <cmath>

namespace ehpt::plant {

namespace {
struct CellValues {
  double i_max_A, r0_Ohm, r1_Ohm, c1_F, i_eff_A;
};
// Cell defaults of §6.2 that depend on other cell data.
CellValues cell_values(const BatteryRcParams& p) {
  CellValues c{};
  c.i_max_A = p.cell_current_max_A.value_or(10.0 * p.cell_capacity_Ah);
  c.r0_Ohm = p.r0_cell_Ohm.value_or(0.05 * p.cell_emf_max_V / c.i_max_A);
  c.r1_Ohm = p.r1_cell_Ohm.value_or(c.r0_Ohm);
  c.c1_F = p.c1_cell_F.value_or(60.0 / c.r1_Ohm);
  c.i_eff_A = p.cell_current_efficiency_A.value_or(0.5 * c.i_max_A);
  return c;
}
}  // namespace

BatteryRcConstants derive(const BatteryRcParams& p) {
  const CellValues cell = cell_values(p);
  const double ns = p.cells_series, np = p.strings_parallel;
  BatteryRcConstants c;
  const double c_cell_F = p.cell_capacity_Ah * 3600.0 / (p.cell_emf_max_V - p.cell_emf_min_V);
  c.c_batt_F = c_cell_F * np / ns;
  c.emf_min_V = ns * p.cell_emf_min_V;
  c.emf_max_V = ns * p.cell_emf_max_V;
  c.r0_Ohm = cell.r0_Ohm * ns / np;
  c.r1_Ohm = cell.r1_Ohm * ns / np;
  c.c1_F = cell.c1_F * np / ns;
  c.current_max_A = cell.i_max_A * np;
  // §6.3 with cell values (identical to the library for np = 1, consistent for np > 1)
  const double e_sum = p.cell_emf_max_V + p.cell_emf_min_V;
  const double r_i = (cell.r0_Ohm + cell.r1_Ohm) * cell.i_eff_A;
  const double eta = p.efficiency;
  c.k_parasitic = ((1.0 - eta) * e_sum - 2.0 * (1.0 + eta) * r_i) / ((1.0 + eta) * e_sum - 2.0 * (1.0 - eta) * r_i);
  c.efficiency_max = (e_sum - 2.0 * r_i) / (e_sum + 2.0 * r_i);
  c.soc_min = p.soc_min;
  c.soc_max = p.soc_max;
  c.emf_initial_V = c.emf_min_V + p.soc_initial * (c.emf_max_V - c.emf_min_V);
  c.strings_parallel = p.strings_parallel;
  return c;
}

void validate(const BatteryRcParams& p, const std::string& at, Problems& problems) {
  const std::size_t before = problems.size();
  problems.require_positive(at + ".cell_capacity_Ah", p.cell_capacity_Ah);
  problems.require_positive(at + ".cell_emf_min_V", p.cell_emf_min_V);
  problems.require_positive(at + ".cell_emf_max_V", p.cell_emf_max_V);
  if (p.cell_emf_max_V <= p.cell_emf_min_V) {
    problems.add(at + ".cell_emf_max_V", number_text(p.cell_emf_max_V),
                 "must be > cell_emf_min_V = " + number_text(p.cell_emf_min_V));
  }
  problems.require_in(at + ".soc_min", p.soc_min, 0.0, 1.0);
  problems.require_in(at + ".soc_max", p.soc_max, 0.0, 1.0);
  if (!(p.soc_min < p.soc_max)) {
    problems.add(at + ".soc_max", number_text(p.soc_max), "must be > soc_min = " + number_text(p.soc_min));
  }
  problems.require_in(at + ".soc_initial", p.soc_initial, p.soc_min, p.soc_max);
  const auto opt_positive = [&](const char* key, const std::optional<double>& v) {
    if (v) problems.require_positive(at + "." + key, *v);
  };
  opt_positive("cell_current_max_A", p.cell_current_max_A);
  opt_positive("r0_cell_Ohm", p.r0_cell_Ohm);
  opt_positive("r1_cell_Ohm", p.r1_cell_Ohm);
  opt_positive("c1_cell_F", p.c1_cell_F);
  opt_positive("cell_current_efficiency_A", p.cell_current_efficiency_A);
  problems.require_in(at + ".efficiency", p.efficiency, 0.0, 1.0, true, false);
  if (p.cells_series < 1) problems.add(at + ".cells_series", std::to_string(p.cells_series), "must be >= 1");
  if (p.strings_parallel < 1) problems.add(at + ".strings_parallel", std::to_string(p.strings_parallel), "must be >= 1");
  if (problems.size() != before) return;  // derived checks need sane inputs
  const BatteryRcConstants c = derive(p);
  if (!(p.efficiency <= c.efficiency_max)) {
    problems.add(at + ".efficiency", number_text(p.efficiency),
                 "must be <= " + number_text(c.efficiency_max) +
                     ", the best the cell resistances allow at cell_current_efficiency_A");
  }
}

BatteryTerminal BatteryRc::at_current(double emf_V, double v_rc_V, double current_A) const {
  BatteryTerminal b;
  const double v_int = emf_V - v_rc_V;
  b.current_A = current_A;
  b.voltage_V = v_int - c_.r0_Ohm * current_A;
  b.parasitic_A = c_.k_parasitic * std::abs(current_A);
  b.main_A = current_A + b.parasitic_A + short_A_;
  b.loss_W = c_.r0_Ohm * current_A * current_A + v_rc_V * v_rc_V * inv_r1_Ohm_ + v_int * (b.parasitic_A + short_A_);
  return b;
}

}  // namespace ehpt::plant
