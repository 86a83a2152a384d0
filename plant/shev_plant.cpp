// SPDX-License-Identifier: BSD-3-Clause
#include "plant/shev_plant.hpp"

#include <algorithm>
#include <cmath>

namespace ehpt::plant {

void validate(const ShevParams& p, Problems& problems) {
  validate(p.body, "vehicle", problems);
  validate(p.road, "road", problems);
  validate(p.driver, "driver", problems);
  validate(p.battery, "battery", problems);
  validate(p.drive, "drive", problems);
  validate(p.genset, "genset", problems);
  if (p.brake.after_rotor_inertia) {
    problems.add("brake.after_rotor_inertia", "true", "only the map-based EV (kind = \"bev\") has this option");
  }
  if (p.genset.ice.input != IceInput::kTorque) {
    problems.add("genset.ice.input", "\"power\"",
                 "the genset's engine is IceT01, run by its GMS through the throttle: set input = \"torque\"");
  }
}

const std::array<Signal<ShevPlant::Outputs>, 37> ShevPlant::kSignals = {{
    {"time_s", &Outputs::time_s, "simulation time"},
    {"speed_ref_m_s", &Outputs::speed_ref_m_s, "cycle (wanted) speed"},
    {"speed_m_s", &Outputs::speed_m_s, "vehicle speed"},
    {"distance_m", &Outputs::distance_m, "travelled distance"},
    {"acceleration_m_s2", &Outputs::acceleration_m_s2, "vehicle acceleration"},
    {"driver_request_Nm", &Outputs::driver_request_Nm, "driver torque request at the drive shaft (driverRequest)"},
    {"drive_torque_ref_Nm", &Outputs::drive_torque_ref_Nm, "torque the ECU asks of the drive (driveTauRef)"},
    {"drive_torque_Nm", &Outputs::drive_torque_Nm, "torque the drive applies (after the limiter)"},
    {"drive_torque_limit_Nm", &Outputs::drive_torque_limit_Nm, "drive limiter bound yH (driveTauLim)"},
    {"drive_limit_state", &Outputs::drive_limit_state, "drive limiter state 0 torque, 1 power, 2 speed ramp, 3 over speed"},
    {"drive_speed_rad_s", &Outputs::drive_speed_rad_s, "drive shaft speed"},
    {"drive_power_mech_W", &Outputs::drive_power_mech_W, "drive mechanical power torque x speed"},
    {"drive_power_dc_W", &Outputs::drive_power_dc_W, "DC power the drive draws (drivePowDc, the EMS's input)"},
    {"genset_power_ref_W", &Outputs::genset_power_ref_W, "power the ECU asks of the genset (gensetPowRef)"},
    {"genset_on", &Outputs::genset_on, "1 while the genset runs (gensetON of an ON/OFF genset)"},
    {"genset_speed_rad_s", &Outputs::genset_speed_rad_s, "genset (engine) shaft speed"},
    {"genset_speed_ref_rad_s", &Outputs::genset_speed_ref_rad_s, "GMS optimal speed for the power request"},
    {"throttle", &Outputs::throttle, "GMS throttle, before the engine's clamp to [0, 1]"},
    {"ice_torque_Nm", &Outputs::ice_torque_Nm, "engine torque"},
    {"ice_torque_max_Nm", &Outputs::ice_torque_max_Nm, "engine maximum torque at its speed"},
    {"ice_power_W", &Outputs::ice_power_W, "engine power torque x speed"},
    {"gen_torque_request_Nm", &Outputs::gen_torque_request_Nm, "GMS generator torque request (< 0 generating)"},
    {"gen_torque_Nm", &Outputs::gen_torque_Nm, "generator torque after its limiter"},
    {"gen_limit_state", &Outputs::gen_limit_state, "generator limiter state 0 torque, 1 power, 2 speed ramp, 3 over speed"},
    {"gen_power_mech_W", &Outputs::gen_power_mech_W, "generator mechanical power (< 0 generating)"},
    {"genset_power_dc_W", &Outputs::genset_power_dc_W, "DC power the genset delivers to the bus (gensetPowDc)"},
    {"fuel_rate_g_s", &Outputs::fuel_rate_g_s, "fuel mass flow"},
    {"fuel_g", &Outputs::fuel_g, "fuel used since start"},
    {"brake_force_N", &Outputs::brake_force_N, "friction-brake force magnitude"},
    {"road_force_N", &Outputs::road_force_N, "road load (rolling + aero), or the locked reaction"},
    {"grade_rad", &Outputs::grade_rad, "road angle, > 0 uphill"},
    {"battery_voltage_V", &Outputs::battery_voltage_V, "terminal voltage"},
    {"battery_current_A", &Outputs::battery_current_A, "terminal current, > 0 discharging"},
    {"battery_power_W", &Outputs::battery_power_W, "terminal power (batPowDel)"},
    {"soc", &Outputs::soc, "state of charge (batSOC)"},
    {"locked", &Outputs::locked, "1 while the vehicle is stuck at standstill"},
    {"fault", &Outputs::fault, "fault bits: 1 SOC window, 2 cell current, 4 power infeasible, 8 non-finite"},
}};

ShevPlant::ShevPlant(const ShevParams& params)
    : p_(params),
      drive_(params.drive),
      genset_(params.genset),
      battery_(params.battery),
      body_(params.body, params.road, params.brake) {
  g_over_r_ = p_.body.gear_ratio / p_.body.wheel_radius_m;
  mass_eff_kg_ = p_.body.mass_kg + p_.drive.inertia_kgm2 * g_over_r_ * g_over_r_;
  inv_mass_eff_kg_ = 1.0 / mass_eff_kg_;
}

ShevPlant::State ShevPlant::initial_state() const {
  State x = State::Zero();
  x[kSpeed] = p_.body.speed_initial_m_s;
  x[kEmf] = battery_.constants().emf_initial_V;
  x[kGensetSpeed] = p_.genset.ice.speed_initial_rad_s;
  return x;
}

ShevPlant::Modes ShevPlant::initial_modes(const State& x0) const {
  return Modes{x0[kSpeed] > 0.0 ? Motion::kForward : Motion::kStuck};
}

ShevPlant::Eval ShevPlant::evaluate(const State& x, const Modes& m, const Inputs& u) const {
  Eval e;
  const double v = x[kSpeed];
  // the drive follows the ECU's command within its limits
  e.drive_speed_rad_s = v * g_over_r_;
  e.drive = drive_.operate(u.driveTauRef_Nm, e.drive_speed_rad_s);
  if (torque_gain_[0] != 1.0) [[unlikely]] {
    e.drive = drive_.derated(e.drive, u.driveTauRef_Nm, e.drive_speed_rad_s, torque_gain_[0]);
  }
  // the genset: its GMS from the power request, on while the ECU says so (ON/OFF genset only)
  e.on = !p_.genset.ice.on_off || u.gensetON;
  e.genset = genset_.operate(u.gensetPowRef_W, e.on, x[kGensetSpeed], torque_gain_[1]);
  // forces at the wheel; the friction brake supplies the braking the drive could not
  const VehicleBody::Forces f = body_.forces(v, x[kDistance]);
  e.grade_rad = f.grade_rad;
  e.rolling_N = f.rolling_N;
  e.speed_force_N = f.speed_force_N;
  e.grade_force_N = f.grade_force_N;
  e.brake_N = body_.brake_N(e.drive.torque_Nm - u.driveTauRef_Nm);
  e.applied_N = e.drive.torque_Nm * g_over_r_ - f.grade_force_N;
  e.road_N = e.applied_N;
  e.accel_m_s2 = 0.0;
  if (m.motion != Motion::kStuck) {
    const double d = m.motion == Motion::kForward ? 1.0 : -1.0;
    e.road_N = d * e.rolling_N + e.speed_force_N;
    e.accel_m_s2 = (e.applied_N - e.road_N - d * e.brake_N) * inv_mass_eff_kg_;
  }
  // the battery balances the DC bus: the drive draws, the genset delivers
  e.battery = battery_.terminal(x[kEmf], x[kVrc], e.drive.power_dc_W + e.genset.gen.power_dc_W);
  return e;
}

unsigned ShevPlant::faults(const Eval& e, const State& x) const {
  return battery_.faults(x[kEmf], e.battery) | (all_finite(x) ? 0u : kFaultNonFinite);
}

void ShevPlant::derivatives_from(const Eval& e, const State& x, State& dx) const {
  const double w = x[kGensetSpeed];
  dx[kSpeed] = e.accel_m_s2;
  body_.derivatives(x[kSpeed], {e.grade_rad, e.rolling_N, e.speed_force_N, e.grade_force_N}, e.brake_N,
                    dx.data() + kBodyAt);
  dx[kEmf] = battery_.demf_dt(e.battery);
  dx[kVrc] = battery_.dvrc_dt(e.battery, x[kVrc]);
  dx[kGensetSpeed] = e.genset.shaft_torque_Nm / genset_.inertia_kgm2();
  dx[kFuelKg] = e.genset.fuel_rate_kg_s;
  dx[kIceWorkJ] = e.genset.ice_torque_Nm * w;
  dx[kBatteryOutJ] = e.battery.voltage_V * e.battery.current_A;
  dx[kDriveLossJ] = e.drive.power_dc_W - e.drive.power_mech_W;
  dx[kGenLossJ] = e.genset.gen.power_dc_W - e.genset.gen.power_mech_W;
  dx[kBatteryLossJ] = e.battery.loss_W;
}

void ShevPlant::derivatives(double, const State& x, const Modes& m, const Inputs& u, State& dx) const {
  derivatives_from(evaluate(x, m, u), x, dx);
}

void ShevPlant::crossings(double, const State& x, const Modes& m, const Inputs& u, double* z) const {
  if (m.motion != Motion::kStuck) {
    z[0] = VehicleBody::moving_crossing(m.motion, x[kSpeed]);
  } else {
    const Eval e = evaluate(x, m, u);
    z[0] = VehicleBody::stuck_crossing(e.applied_N, e.rolling_N + e.brake_N);
  }
}

void ShevPlant::on_crossing(int, double, State& x, Modes& m, const Inputs& u) const {
  if (m.motion != Motion::kStuck) x[kSpeed] = 0.0;  // came to rest: exactly zero
  const Eval e = evaluate(x, Modes{Motion::kStuck}, u);
  m.motion = motion_at_rest(e.applied_N, e.rolling_N + e.brake_N);
}

void ShevPlant::sense(double t_s, const State& x, const Modes& m, const Inputs& u, Sensors& s) const {
  const Eval e = evaluate(x, m, u);
  s.driverRequest_Nm = drive(p_.driver, t_s, x[kSpeed]).request;
  s.speed_m_s = x[kSpeed];
  s.driveW_rad_s = e.drive_speed_rad_s;
  s.driveTauLim_Nm = e.drive.limit_Nm;
  s.drivePowDc_W = e.drive.power_dc_W;
  s.gensetW_rad_s = x[kGensetSpeed];
  s.gensetPowDc_W = -e.genset.gen.power_dc_W;
  s.batSOC = battery_.soc(x[kEmf]);
  s.batPowDel_W = e.battery.voltage_V * e.battery.current_A;
  s.battery_voltage_V = e.battery.voltage_V;
  s.battery_current_A = e.battery.current_A;
  s.fault = faults(e, x);
  s.locked = m.motion == Motion::kStuck;
}

void ShevPlant::outputs_from(const Eval& e, double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y) const {
  const double v = x[kSpeed], w = x[kGensetSpeed];
  const DriverOutput drv = drive(p_.driver, t_s, v);
  y.time_s = t_s;
  y.speed_ref_m_s = drv.speed_ref_m_s;
  y.speed_m_s = v;
  y.distance_m = x[kDistance];
  y.acceleration_m_s2 = e.accel_m_s2;
  y.driver_request_Nm = drv.request;
  y.drive_torque_ref_Nm = u.driveTauRef_Nm;
  y.drive_torque_Nm = e.drive.torque_Nm;
  y.drive_torque_limit_Nm = e.drive.limit_Nm;
  y.drive_limit_state = e.drive.limit_state;
  y.drive_speed_rad_s = e.drive_speed_rad_s;
  y.drive_power_mech_W = e.drive.power_mech_W;
  y.drive_power_dc_W = e.drive.power_dc_W;
  y.genset_power_ref_W = u.gensetPowRef_W;
  y.genset_on = e.on ? 1.0 : 0.0;
  y.genset_speed_rad_s = w;
  y.genset_speed_ref_rad_s = e.genset.speed_ref_rad_s;
  y.throttle = e.genset.throttle;
  y.ice_torque_Nm = e.genset.ice_torque_Nm;
  y.ice_torque_max_Nm = e.genset.ice_torque_max_Nm;
  y.ice_power_W = e.genset.ice_torque_Nm * w;
  y.gen_torque_request_Nm = e.genset.gen_request_Nm;
  y.gen_torque_Nm = e.genset.gen.torque_Nm;
  y.gen_limit_state = e.genset.gen.limit_state;
  y.gen_power_mech_W = e.genset.gen.power_mech_W;
  y.genset_power_dc_W = -e.genset.gen.power_dc_W;
  y.fuel_rate_g_s = 1e3 * e.genset.fuel_rate_kg_s;
  y.fuel_g = 1e3 * x[kFuelKg];
  y.brake_force_N = e.brake_N;
  y.road_force_N = e.road_N;
  y.grade_rad = e.grade_rad;
  y.battery_voltage_V = e.battery.voltage_V;
  y.battery_current_A = e.battery.current_A;
  y.battery_power_W = e.battery.voltage_V * e.battery.current_A;
  y.soc = battery_.soc(x[kEmf]);
  y.locked = m.motion == Motion::kStuck ? 1.0 : 0.0;
  y.fault = faults(e, x);
}

void ShevPlant::outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y) const {
  outputs_from(evaluate(x, m, u), t_s, x, m, u, y);
}

// one evaluation for both (the runner hands dx/dt to the next step as its first stage)
void ShevPlant::outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y, State& dx) const {
  const Eval e = evaluate(x, m, u);
  outputs_from(e, t_s, x, m, u, y);
  derivatives_from(e, x, dx);
}

double ShevPlant::kinetic_energy_J(const State& x) const {
  const double v = x[kSpeed], w = x[kGensetSpeed];
  return 0.5 * mass_eff_kg_ * v * v + 0.5 * genset_.inertia_kgm2() * w * w;
}

EnergyAudit ShevPlant::audit(const State& x0, const State& x) const {
  const auto delta = [&](int i) { return x[i] - x0[i]; };
  const double stored_out_J = battery_.stored_out_J(x0[kEmf], x0[kVrc], x[kEmf], x[kVrc]);
  const double fuel_J = p_.genset.ice.fuel_lhv_J_kg * delta(kFuelKg);
  const double ice_work_J = delta(kIceWorkJ);
  const double kinetic_J = kinetic_energy_J(x) - kinetic_energy_J(x0);
  const double potential_J = p_.body.mass_kg * kGravity_m_s2 * delta(kAltitude);
  EnergyAudit a;
  a.sources_J = fuel_J + stored_out_J;
  a.scale_J = std::abs(ice_work_J) + std::abs(stored_out_J);
  a.battery_out_J = delta(kBatteryOutJ);
  a.battery_loss_J = delta(kBatteryLossJ);
  // engine losses = fuel energy - engine work: the fuel term cancels, and the residual checks
  // the mechanical and electrical integration
  a.residual_J = fuel_J + stored_out_J -
                 ((fuel_J - ice_work_J) + delta(kRoadJ) + delta(kDriveLossJ) + delta(kGenLossJ) +
                  delta(kBatteryLossJ) + delta(kBrakeJ) + kinetic_J + potential_J);
  a.terms = {{"fuel_chemical_J", fuel_J},
             {"fuel_lhv_J_kg", p_.genset.ice.fuel_lhv_J_kg},
             {"battery_stored_out_J", stored_out_J},
             {"battery_terminal_out_J", delta(kBatteryOutJ)},
             {"engine_work_J", ice_work_J},
             {"engine_losses_J", fuel_J - ice_work_J},
             {"road_load_work_J", delta(kRoadJ)},
             {"drive_losses_J", delta(kDriveLossJ)},
             {"generator_losses_J", delta(kGenLossJ)},
             {"battery_losses_J", delta(kBatteryLossJ)},
             {"brake_dissipation_J", delta(kBrakeJ)},
             {"kinetic_energy_change_J", kinetic_J},
             {"potential_energy_change_J", potential_J}};
  if (battery_.removed_by_faults_J() != 0.0) {
    a.terms.push_back({"battery_removed_by_faults_J", battery_.removed_by_faults_J()});
  }
  return a;
}

}  // namespace ehpt::plant
