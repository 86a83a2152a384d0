// SPDX-License-Identifier: BSD-3-Clause
#include "plant/genset_rig.hpp"

#include <cmath>

namespace ehpt::plant {

void validate(const GensetRigParams& p, Problems& problems) {
  validate(p.genset, "genset", problems);
  validate(p.request_W, "request", problems);
  if (!(p.off_at_s >= 0.0)) problems.add("off_at_s", number_text(p.off_at_s), "must be >= 0 s (leave it out: always on)");
  problems.require_positive("dc_voltage_V", p.dc_voltage_V);
}

using O = GensetRig::Outputs;
const std::array<Signal<O>, 22> GensetRig::kSignals = {{
    {"time_s", &O::time_s, "simulation time"},
    {"power_ref_W", &O::power_ref_W, "the genset's power request"},
    {"on", &O::on, "1 while the genset is on (GensetOO's ON input)"},
    {"iceW_rad_s", &O::speed_rad_s, "engine speed"},
    {"ice_speed_ref_rad_s", &O::speed_ref_rad_s, "the GMS's best engine speed for the request"},
    {"throttle", &O::throttle, "the GMS's throttle, before the engine's clamp to [0, 1]"},
    {"ice_torque_Nm", &O::ice_torque_Nm, "engine torque"},
    {"ice_torque_max_Nm", &O::ice_torque_max_Nm, "the engine's maximum torque at its speed"},
    {"ice_power_W", &O::ice_power_W, "engine power (torque x speed)"},
    {"genW_rad_s", &O::gen_speed_rad_s, "generator speed"},
    {"genTauRef_Nm", &O::gen_torque_request_Nm, "the GMS's generator torque request (< 0 generating)"},
    {"gen_torque_Nm", &O::gen_torque_Nm, "generator torque after its limiter"},
    {"genTauLim_Nm", &O::gen_torque_limit_Nm, "the generator's torque bound"},
    {"gen_limit_state", &O::gen_limit_state, "the generator's limiter: 0 torque, 1 power, 2 speed ramp, 3 over speed"},
    {"gen_limiting", &O::gen_limiting, "1 while the generator's limiter cuts the request"},
    {"gen_power_mech_W", &O::gen_power_mech_W, "generator mechanical power (< 0 generating)"},
    {"dc_power_W", &O::dc_power_W, "DC power delivered to the source (> 0 generating)"},
    {"dc_current_A", &O::dc_current_A, "DC current into the source"},
    {"gen_efficiency", &O::gen_efficiency, "generator efficiency from its map"},
    {"fuel_rate_g_s", &O::fuel_rate_g_s, "fuel mass flow"},
    {"fuel_g", &O::fuel_g, "fuel used since start"},
    {"fault", &O::fault, "fault bits (8 non-finite)"},
}};

GensetRig::State GensetRig::initial_state() const {
  State x = State::Zero();
  x[kSpeed] = p_.genset.ice.speed_initial_rad_s;
  return x;
}

// Run phase: no allocation. Always inlined, so that each caller computes only what it uses.
[[gnu::always_inline]] inline GensetRig::Eval GensetRig::evaluate(double t_s, const State& x) const {
  Eval e;
  e.power_ref_W = trapezoid(p_.request_W, t_s);
  e.on = t_s < p_.off_at_s;
  e.g = genset_.operate(e.power_ref_W, e.on, x[kSpeed]);
  return e;
}

void GensetRig::derivatives(double t_s, const State& x, const Modes&, const Inputs&, State& dx) const {
  const Eval e = evaluate(t_s, x);
  dx[kSpeed] = e.g.shaft_torque_Nm / genset_.inertia_kgm2();
  dx[kFuelKg] = e.g.fuel_rate_kg_s;
  dx[kIceJ] = e.g.ice_torque_Nm * x[kSpeed];
  dx[kDcOutJ] = -e.g.gen.power_dc_W;
  dx[kGenLossJ] = e.g.gen.power_dc_W - e.g.gen.power_mech_W;
}

void GensetRig::outputs(double t_s, const State& x, const Modes&, const Inputs&, Outputs& y) const {
  const Eval e = evaluate(t_s, x);
  const double w = x[kSpeed];
  y.time_s = t_s;
  y.power_ref_W = e.power_ref_W;
  y.on = e.on ? 1.0 : 0.0;
  y.speed_rad_s = w;
  y.speed_ref_rad_s = e.g.speed_ref_rad_s;
  y.throttle = e.g.throttle;
  y.ice_torque_Nm = e.g.ice_torque_Nm;
  y.ice_torque_max_Nm = e.g.ice_torque_max_Nm;
  y.ice_power_W = e.g.ice_torque_Nm * w;
  y.gen_speed_rad_s = w / p_.genset.gear_ratio;
  y.gen_torque_request_Nm = e.g.gen_request_Nm;
  y.gen_torque_Nm = e.g.gen.torque_Nm;
  y.gen_torque_limit_Nm = e.g.gen.limit_Nm;
  y.gen_limit_state = e.g.gen.limit_state;
  y.gen_limiting = e.g.gen.limiting ? 1.0 : 0.0;
  y.gen_power_mech_W = e.g.gen.power_mech_W;
  y.dc_power_W = -e.g.gen.power_dc_W;
  y.dc_current_A = y.dc_power_W / p_.dc_voltage_V;
  y.gen_efficiency = e.g.gen.efficiency;
  y.fuel_rate_g_s = e.g.fuel_rate_kg_s * 1e3;
  y.fuel_g = x[kFuelKg] * 1e3;
  y.fault = x.allFinite() ? kFaultNone : kFaultNonFinite;
}

EnergyAudit GensetRig::audit(const State& x0, const State& x) const {
  const double ice_J = x[kIceJ] - x0[kIceJ];
  const double dc_J = x[kDcOutJ] - x0[kDcOutJ];
  const double loss_J = x[kGenLossJ] - x0[kGenLossJ];
  const double kinetic_J = 0.5 * genset_.inertia_kgm2() * (x[kSpeed] * x[kSpeed] - x0[kSpeed] * x0[kSpeed]);
  EnergyAudit a;
  a.sources_J = ice_J;
  a.scale_J = std::abs(ice_J);
  a.residual_J = ice_J - (kinetic_J + dc_J + loss_J);
  a.terms = {{"engine_work_J", ice_J},
             {"kinetic_energy_change_J", kinetic_J},
             {"dc_energy_delivered_J", dc_J},
             {"generator_losses_J", loss_J}};
  return a;
}

}  // namespace ehpt::plant
