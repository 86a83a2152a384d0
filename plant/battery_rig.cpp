// SPDX-License-Identifier: BSD-3-Clause
#include "plant/battery_rig.hpp"

#include <algorithm>
#include <cmath>

namespace ehpt::plant {

void validate(const BatteryRigParams& p, Problems& problems) {
  validate(p.battery, "battery", problems);
  if (p.profile.empty()) problems.add("profile", "[]", "must have at least one segment");
  for (std::size_t k = 0; k < p.profile.size(); ++k) {
    const BatterySegment& s = p.profile[k];
    const std::string at = "profile[" + std::to_string(k) + "]";
    if (!std::isfinite(s.value)) {
      problems.add(at + (s.kind == BatterySegment::Kind::kCurrent ? ".current_A" : ".power_W"), number_text(s.value),
                   "must be a finite number");
    }
    if (!(s.duration_s > 0.0) || !std::isfinite(s.duration_s)) {
      problems.add(at + ".duration_s", number_text(s.duration_s), "must be a finite number > 0");
    }
  }
}

const std::array<Signal<BatteryRig::Outputs>, 14> BatteryRig::kSignals = {{
    {"time_s", &Outputs::time_s, "simulation time"},
    {"profile_segment", &Outputs::profile_segment, "active profile segment, 0-based; -1 at rest after the profile"},
    {"current_ref_A", &Outputs::current_ref_A, "set current of the active current segment (0 otherwise)"},
    {"power_ref_W", &Outputs::power_ref_W, "set power of the active power segment (0 otherwise)"},
    {"battery_voltage_V", &Outputs::battery_voltage_V, "terminal voltage"},
    {"battery_current_A", &Outputs::battery_current_A, "terminal current, > 0 discharging"},
    {"battery_power_W", &Outputs::battery_power_W, "terminal power v i (batPowDel)"},
    {"battery_emf_V", &Outputs::battery_emf_V, "EMF E"},
    {"battery_vrc_V", &Outputs::battery_vrc_V, "voltage across the R1-C1 block"},
    {"soc", &Outputs::soc, "state of charge (batSOC)"},
    {"battery_out_J", &Outputs::battery_out_J, "integral of terminal power"},
    {"battery_loss_J", &Outputs::battery_loss_J, "integral of battery losses"},
    {"charge_out_As", &Outputs::charge_out_As, "integral of terminal current"},
    {"fault", &Outputs::fault, "fault bits: 1 SOC window, 2 cell current, 4 power infeasible, 8 non-finite"},
}};

BatteryRig::BatteryRig(const BatteryRigParams& params) : p_(params), battery_(params.battery) {
  ends_s_.reserve(p_.profile.size());
  double end_s = 0.0;
  for (const BatterySegment& s : p_.profile) {
    end_s += s.duration_s;
    ends_s_.push_back(end_s);
  }
}

BatteryRig::State BatteryRig::initial_state() const {
  State x = State::Zero();
  x[kEmf] = battery_.constants().emf_initial_V;
  return x;
}

// Run phase.
void BatteryRig::crossings(double t_s, const State&, const Modes& m, const Inputs&, double* z) const {
  if (m.segment == kRest) {
    z[0] = 1.0;
    return;
  }
  // a grid time t0 + n h that rounds a hair below an end time counts as that end, so the
  // switch happens on the step meant to end there, whatever the rounding of n h
  const double end_s = ends_s_[static_cast<std::size_t>(m.segment)];
  const double z_s = end_s - t_s;
  z[0] = std::abs(z_s) <= 1e-12 * std::max(1.0, end_s) ? 0.0 : z_s;
}

void BatteryRig::on_crossing(int, double, State&, Modes& m, const Inputs&) const {
  if (m.segment == kRest) return;
  m.segment = static_cast<std::size_t>(m.segment) + 1 < p_.profile.size() ? m.segment + 1 : kRest;
}

// Run phase: no allocation. Always inlined, so that each caller computes only what it uses.
[[gnu::always_inline]] inline BatteryRig::Eval BatteryRig::evaluate(const State& x, const Modes& m) const {
  Eval e{};
  e.segment = m.segment;
  if (e.segment < 0) {  // rest after the profile
    e.battery = battery_.at_current(x[kEmf], x[kVrc], 0.0);
    return e;
  }
  const BatterySegment& s = p_.profile[static_cast<std::size_t>(e.segment)];
  if (s.kind == BatterySegment::Kind::kCurrent) {
    e.current_ref_A = s.value;
    e.battery = battery_.at_current(x[kEmf], x[kVrc], s.value);
  } else {
    e.power_ref_W = s.value;
    e.battery = battery_.terminal(x[kEmf], x[kVrc], s.value);
  }
  return e;
}

void BatteryRig::derivatives(double, const State& x, const Modes& m, const Inputs&, State& dx) const {
  const Eval e = evaluate(x, m);
  dx[kEmf] = battery_.demf_dt(e.battery);
  dx[kVrc] = battery_.dvrc_dt(e.battery, x[kVrc]);
  dx[kBatteryOutJ] = e.battery.voltage_V * e.battery.current_A;
  dx[kBatteryLossJ] = e.battery.loss_W;
  dx[kChargeOutAs] = e.battery.current_A;
}

void BatteryRig::outputs(double t_s, const State& x, const Modes& m, const Inputs&, Outputs& y) const {
  const Eval e = evaluate(x, m);
  y.time_s = t_s;
  y.profile_segment = e.segment;
  y.current_ref_A = e.current_ref_A;
  y.power_ref_W = e.power_ref_W;
  y.battery_voltage_V = e.battery.voltage_V;
  y.battery_current_A = e.battery.current_A;
  y.battery_power_W = e.battery.voltage_V * e.battery.current_A;
  y.battery_emf_V = x[kEmf];
  y.battery_vrc_V = x[kVrc];
  y.soc = battery_.soc(x[kEmf]);
  y.battery_out_J = x[kBatteryOutJ];
  y.battery_loss_J = x[kBatteryLossJ];
  y.charge_out_As = x[kChargeOutAs];
  y.fault = battery_.faults(x[kEmf], e.battery) | (x.allFinite() ? 0u : kFaultNonFinite);
}

EnergyAudit BatteryRig::audit(const State& x0, const State& x) const {
  const double stored_out_J =
      battery_.stored_energy_J(x0[kEmf], x0[kVrc]) - battery_.stored_energy_J(x[kEmf], x[kVrc]);
  const double out_J = x[kBatteryOutJ] - x0[kBatteryOutJ];
  const double losses_J = x[kBatteryLossJ] - x0[kBatteryLossJ];
  EnergyAudit a;
  a.sources_J = stored_out_J;
  // a discharge followed by a charge can leave every net term small: the largest one is the scale
  a.scale_J = std::max({std::abs(stored_out_J), std::abs(out_J), std::abs(losses_J)});
  a.battery_out_J = out_J;
  a.battery_loss_J = losses_J;
  a.residual_J = stored_out_J - (out_J + losses_J);
  a.terms = {{"battery_stored_out_J", stored_out_J},
             {"battery_terminal_out_J", out_J},
             {"battery_losses_J", losses_J}};
  return a;
}

}  // namespace ehpt::plant
