// SPDX-License-Identifier: BSD-3-Clause
#include "plant/psd_plant.hpp"

#include <cmath>

namespace ehpt::plant {

void validate(const PsdParams& p, Problems& problems) {
  validate(p.body, "vehicle", problems);
  validate(p.road, "road", problems);
  validate(p.driver, "driver", problems);
  validate(p.battery, "battery", problems);
  validate(p.ice, "ice", problems);
  validate(p.gen, "gen", problems);
  validate(p.mot, "mot", problems);
  if (!(p.ring_sun_ratio > 1.0) || !std::isfinite(p.ring_sun_ratio)) {
    problems.add("planetary.ring_sun_ratio", number_text(p.ring_sun_ratio),
                 "must be > 1 (the ring has more teeth than the sun)");
  }
  if (p.brake.after_rotor_inertia) {
    problems.add("brake.after_rotor_inertia", "true", "only the map-based EV (kind = \"bev\") has this option");
  }
}

const std::array<Signal<PsdPlant::Outputs>, 35> PsdPlant::kSignals = {{
    {"time_s", &Outputs::time_s, "simulation time"},
    {"speed_ref_m_s", &Outputs::speed_ref_m_s, "cycle (wanted) speed"},
    {"speed_m_s", &Outputs::speed_m_s, "vehicle speed"},
    {"distance_m", &Outputs::distance_m, "travelled distance"},
    {"driverRequest", &Outputs::driverRequest, "driver request, per unit (bus)"},
    {"iceW_rad_s", &Outputs::iceW_rad_s, "engine speed (bus iceW)"},
    {"ice_torque_Nm", &Outputs::ice_torque_Nm, "engine torque (torque source, before its inertia)"},
    {"icePowDel_W", &Outputs::icePowDel_W, "power at the engine flange (bus icePowDel)"},
    {"icePowRef_W", &Outputs::icePowRef_W, "engine power request from the ECU (bus icePowRef)"},
    {"iceON", &Outputs::iceON, "engine on (bus iceON)"},
    {"fuel_rate_g_s", &Outputs::fuel_rate_g_s, "fuel mass flow"},
    {"fuel_g", &Outputs::fuel_g, "fuel used since start"},
    {"sfc_g_kWh", &Outputs::sfc_g_kWh, "specific consumption at the operating point"},
    {"genW_rad_s", &Outputs::genW_rad_s, "gen (sun) speed (bus genW)"},
    {"genTauRef_Nm", &Outputs::genTauRef_Nm, "gen torque request (bus genTauRef)"},
    {"gen_torque_Nm", &Outputs::gen_torque_Nm, "gen torque after its limiter"},
    {"genTauLim_Nm", &Outputs::genTauLim_Nm, "gen torque limit (bus genTauLim)"},
    {"genPowDel_W", &Outputs::genPowDel_W, "power gen delivers at its flange (bus genPowDel)"},
    {"gen_power_dc_W", &Outputs::gen_power_dc_W, "DC power drawn by gen (< 0 generating)"},
    {"motW_rad_s", &Outputs::motW_rad_s, "mot (ring) speed (bus motW)"},
    {"motTauRef_Nm", &Outputs::motTauRef_Nm, "mot torque request (bus motTauRef)"},
    {"mot_torque_Nm", &Outputs::mot_torque_Nm, "mot torque after its limiter"},
    {"motTauLim_Nm", &Outputs::motTauLim_Nm, "mot torque limit (bus motTauLim)"},
    {"motPowDelA_W", &Outputs::motPowDelA_W, "power mot delivers through flange A, ring side (bus)"},
    {"motPowDelB_W", &Outputs::motPowDelB_W, "power mot delivers through flange B, traction (bus)"},
    {"mot_power_dc_W", &Outputs::mot_power_dc_W, "DC power drawn by mot"},
    {"brake_force_N", &Outputs::brake_force_N, "friction-brake force magnitude"},
    {"road_force_N", &Outputs::road_force_N, "road load (rolling + aero), or the locked reaction"},
    {"grade_rad", &Outputs::grade_rad, "road angle, > 0 uphill"},
    {"battery_voltage_V", &Outputs::battery_voltage_V, "terminal voltage"},
    {"battery_current_A", &Outputs::battery_current_A, "terminal current, > 0 discharging"},
    {"battery_power_W", &Outputs::battery_power_W, "terminal power (bus batPowDel)"},
    {"soc", &Outputs::soc, "state of charge (bus batSOC)"},
    {"locked", &Outputs::locked, "1 while the vehicle is stuck at standstill"},
    {"fault", &Outputs::fault, "fault bits: 1 SOC window, 2 cell current, 4 power infeasible, 8 non-finite"},
}};

PsdPlant::PsdPlant(const PsdParams& params)
    : p_(params),
      ice_(params.ice),
      gen_(params.gen),
      mot_(params.mot),
      battery_(params.battery),
      body_(params.body, params.road, params.brake),
      rho_(params.ring_sun_ratio) {
  g_over_r_ = p_.body.gear_ratio / p_.body.wheel_radius_m;
  r_over_g_ = 1.0 / g_over_r_;
  const double j_i = p_.ice.inertia_kgm2, j_g = p_.gen.inertia_kgm2, j_m = p_.mot.inertia_kgm2;
  m11_ = j_i + j_g * (1.0 + rho_) * (1.0 + rho_);
  m12_ = -j_g * rho_ * (1.0 + rho_);
  m22_ = j_m + j_g * rho_ * rho_ + p_.body.mass_kg * r_over_g_ * r_over_g_;
  const double det = m11_ * m22_ - m12_ * m12_;
  i11_ = m22_ / det;
  i12_ = -m12_ / det;
  i22_ = m11_ / det;
  one_plus_rho_ = 1.0 + rho_;
  i11_one_plus_rho_ = i11_ * one_plus_rho_;
}

PsdPlant::State PsdPlant::initial_state() const {
  State x = State::Zero();
  x[kIceSpeed] = p_.ice.speed_initial_rad_s;
  x[kRingSpeed] = p_.body.speed_initial_m_s * g_over_r_;
  x[kEmf] = battery_.constants().emf_initial_V;
  return x;
}

PsdPlant::Modes PsdPlant::initial_modes(const State& x0) const {
  return Modes{x0[kRingSpeed] > 0.0 ? Motion::kForward : Motion::kStuck};
}

PsdPlant::Eval PsdPlant::evaluate(double t_s, const State& x, const Modes& m, const Inputs& u) const {
  return eval(t_s, x, m, u);
}

[[gnu::always_inline]] inline unsigned PsdPlant::faults(const Eval& e, const State& x) const {
  return battery_.faults(x[kEmf], e.battery) | (all_finite(x) ? 0u : kFaultNonFinite);
}

[[gnu::always_inline]] inline double PsdPlant::stuck_crossing(const Eval& e) {
  return VehicleBody::stuck_crossing(e.applied_N, e.rolling_N + e.brake_N);
}

void PsdPlant::crossings(double t_s, const State& x, const Modes& m, const Inputs& u, double* z) const {
  if (m.motion != Motion::kStuck) {
    z[0] = VehicleBody::moving_crossing(m.motion, x[kRingSpeed]);
  } else {
    z[0] = stuck_crossing(eval(t_s, x, m, u));
  }
}

void PsdPlant::on_crossing(int, double t_s, State& x, Modes& m, const Inputs& u) const {
  if (m.motion != Motion::kStuck) x[kRingSpeed] = 0.0;  // came to rest: exactly zero
  const Modes stuck{Motion::kStuck};
  const Eval e = eval(t_s, x, stuck, u);
  m.motion = motion_at_rest(e.applied_N, e.rolling_N + e.brake_N);
}

[[gnu::always_inline]] inline void PsdPlant::sense_from(const Eval& e, const State& x, const Modes& m,
                                                        Sensors& bus) const {
  const double w_c = x[kIceSpeed], w_r = x[kRingSpeed];
  const double sun_accel = one_plus_rho_ * e.ice_accel_rad_s2 - rho_ * e.ring_accel_rad_s2;
  bus.driverRequest = e.driver.request;
  bus.iceW_rad_s = w_c;
  bus.icePowDel_W = (e.ice_torque_Nm - p_.ice.inertia_kgm2 * e.ice_accel_rad_s2) * w_c;
  bus.genW_rad_s = e.sun_speed_rad_s;
  bus.genPowDel_W = (e.gen.torque_Nm - p_.gen.inertia_kgm2 * sun_accel) * e.sun_speed_rad_s;
  bus.genTauLim_Nm = e.gen.limit_Nm;
  bus.motW_rad_s = w_r;
  // flange B drives the final gear: traction power = (m dv/dt + resisting forces) v
  const double accel_m_s2 = e.ring_accel_rad_s2 * r_over_g_;
  const double v = e.speed_m_s;
  const double resist_N =
      VehicleBody::resisting_N(m.motion, {e.grade_rad, e.rolling_N, e.speed_force_N, e.grade_force_N}, e.brake_N);
  bus.motPowDelB_W = (p_.body.mass_kg * accel_m_s2 + resist_N) * v;
  const double pow_ab_W = (e.mot.torque_Nm - p_.mot.inertia_kgm2 * e.ring_accel_rad_s2) * w_r;
  bus.motPowDelAB_W = pow_ab_W;
  bus.motPowDelA_W = pow_ab_W - bus.motPowDelB_W;
  bus.motTauLim_Nm = e.mot.limit_Nm;
  bus.batSOC = battery_.soc(x[kEmf]);
  bus.batPowDel_W = e.battery.voltage_V * e.battery.current_A;
  bus.speed_m_s = e.speed_m_s;
  bus.battery_voltage_V = e.battery.voltage_V;
  bus.battery_current_A = e.battery.current_A;
  bus.fault = faults(e, x);
  bus.locked = m.motion == Motion::kStuck;
}

void PsdPlant::sense(double t_s, const State& x, const Modes& m, const Inputs& u, Sensors& s) const {
  sense_from(eval(t_s, x, m, u), x, m, s);
}

// The outputs, once for both sets (observation.hpp): the observed fields outside the
// `if constexpr`, the rest inside.
template <OutputSet kSet>
[[gnu::always_inline]] inline void PsdPlant::outputs_from(const Eval& e, double t_s, const State& x,
                                                          const Modes& m, const Inputs& u, Outputs& y) const {
  constexpr bool kAll = kSet == OutputSet::kAll;
  y.speed_ref_m_s = e.driver.speed_ref_m_s;
  y.speed_m_s = e.speed_m_s;
  y.distance_m = x[kDistance];
  y.iceON = ice_.running(u.iceON) ? 1.0 : 0.0;
  y.fuel_g = 1e3 * x[kFuelKg];
  y.soc = battery_.soc(x[kEmf]);
  y.locked = m.motion == Motion::kStuck ? 1.0 : 0.0;
  y.fault = faults(e, x);
  if constexpr (kAll) {
    Sensors bus;
    sense_from(e, x, m, bus);
    y.time_s = t_s;
    y.driverRequest = bus.driverRequest;
    y.iceW_rad_s = x[kIceSpeed];
    y.ice_torque_Nm = e.ice_torque_Nm;
    y.icePowDel_W = bus.icePowDel_W;
    y.icePowRef_W = u.icePowRef_W;
    y.fuel_rate_g_s = 1e3 * e.fuel_rate_kg_s;
    y.sfc_g_kWh = e.ice_torque_Nm > 0.0 ? ice_.sfc_g_kWh(e.ice_torque_Nm, x[kIceSpeed]) : 0.0;
    y.genW_rad_s = e.sun_speed_rad_s;
    y.genTauRef_Nm = u.genTauRef_Nm;
    y.gen_torque_Nm = e.gen.torque_Nm;
    y.genTauLim_Nm = e.gen.limit_Nm;
    y.genPowDel_W = bus.genPowDel_W;
    y.gen_power_dc_W = e.gen.power_dc_W;
    y.motW_rad_s = x[kRingSpeed];
    y.motTauRef_Nm = u.motTauRef_Nm;
    y.mot_torque_Nm = e.mot.torque_Nm;
    y.motTauLim_Nm = e.mot.limit_Nm;
    y.motPowDelA_W = bus.motPowDelA_W;
    y.motPowDelB_W = bus.motPowDelB_W;
    y.mot_power_dc_W = e.mot.power_dc_W;
    y.brake_force_N = e.brake_N;
    y.road_force_N = e.road_N;
    y.grade_rad = e.grade_rad;
    y.battery_voltage_V = e.battery.voltage_V;
    y.battery_current_A = e.battery.current_A;
    y.battery_power_W = bus.batPowDel_W;
  }
}

void PsdPlant::outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y) const {
  outputs_from<OutputSet::kAll>(eval(t_s, x, m, u), t_s, x, m, u, y);
}

void PsdPlant::outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y, State& dx) const {
  const Eval e = eval(t_s, x, m, u);
  outputs_from<OutputSet::kAll>(e, t_s, x, m, u, y);
  derivatives_from(e, x, dx);
}

// outputs_from(), derivatives_from() and crossings() from one evaluation (while stuck,
// crossings() would evaluate again: the same e).
template <OutputSet kSet>
void PsdPlant::observe(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y, State& dx,
                       double* z) const {
  static_assert(kObservationTested<PsdPlant>, "list the plant in ObservedPlants (plant/observation.hpp)");
  const Eval e = eval(t_s, x, m, u);
  outputs_from<kSet>(e, t_s, x, m, u, y);
  derivatives_from(e, x, dx);
  z[0] = m.motion != Motion::kStuck ? VehicleBody::moving_crossing(m.motion, x[kRingSpeed]) : stuck_crossing(e);
}
template void PsdPlant::observe<OutputSet::kObserved>(double, const State&, const Modes&, const Inputs&, Outputs&,
                                                      State&, double*) const;
template void PsdPlant::observe<OutputSet::kAll>(double, const State&, const Modes&, const Inputs&, Outputs&, State&,
                                                 double*) const;

double PsdPlant::kinetic_energy_J(const State& x) const {
  const double w_c = x[kIceSpeed], w_r = x[kRingSpeed];
  return 0.5 * (m11_ * w_c * w_c + 2.0 * m12_ * w_c * w_r + m22_ * w_r * w_r);
}

EnergyAudit PsdPlant::audit(const State& x0, const State& x) const {
  const auto delta = [&](int i) { return x[i] - x0[i]; };
  const double stored_out_J = battery_.stored_out_J(x0[kEmf], x0[kVrc], x[kEmf], x[kVrc]);
  const double fuel_J = p_.ice.fuel_lhv_J_kg * delta(kFuelKg);
  const double ice_work_J = delta(kIceWorkJ);
  const double kinetic_J = kinetic_energy_J(x) - kinetic_energy_J(x0);
  const double potential_J = p_.body.mass_kg * kGravity_m_s2 * delta(kAltitude);
  EnergyAudit a;
  a.sources_J = fuel_J + stored_out_J;
  a.scale_J = std::abs(ice_work_J) + std::abs(stored_out_J);
  a.battery_out_J = delta(kBatteryOutJ);
  a.battery_loss_J = delta(kBatteryLossJ);
  // engine losses = fuel energy - engine work, so the fuel term cancels and the residual
  // checks the mechanical and electrical integration
  a.residual_J = fuel_J + stored_out_J -
                 ((fuel_J - ice_work_J) + delta(kRoadJ) + delta(kGenLossJ) + delta(kMotLossJ) +
                  delta(kBatteryLossJ) + delta(kBrakeJ) + kinetic_J + potential_J);
  a.terms = {{"fuel_chemical_J", fuel_J},
             {"fuel_lhv_J_kg", p_.ice.fuel_lhv_J_kg},
             {"battery_stored_out_J", stored_out_J},
             {"battery_terminal_out_J", delta(kBatteryOutJ)},
             {"engine_work_J", ice_work_J},
             {"engine_losses_J", fuel_J - ice_work_J},
             {"road_load_work_J", delta(kRoadJ)},
             {"gen_losses_J", delta(kGenLossJ)},
             {"mot_losses_J", delta(kMotLossJ)},
             {"battery_losses_J", delta(kBatteryLossJ)},
             {"brake_dissipation_J", delta(kBrakeJ)},
             {"kinetic_energy_change_J", kinetic_J},
             {"potential_energy_change_J", potential_J}};
  if (battery_.removed_by_faults_J() != 0.0) a.terms.push_back({"battery_removed_by_faults_J", battery_.removed_by_faults_J()});
  return a;
}

}  // namespace ehpt::plant
