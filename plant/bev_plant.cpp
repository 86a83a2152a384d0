// SPDX-License-Identifier: BSD-3-Clause
#include "plant/bev_plant.hpp"

#include <algorithm>
#include <cmath>

namespace ehpt::plant {

void validate(const BevParams& p, Problems& problems) {
  validate(p.body, "vehicle", problems);
  validate(p.road, "road", problems);
  validate(p.drive, "drive", problems);
  validate(p.battery, "battery", problems);
  validate(p.driver, "driver", problems);
  if (p.brake.enabled && p.brake.after_rotor_inertia && p.body.mass_kg > 0.0 && p.body.wheel_radius_m > 0.0) {
    // the loop must have one solution: the brake's share of the inertia below the mass
    const double g_over_r = p.body.gear_ratio / p.body.wheel_radius_m;
    const double share_kg = brake_gain_N_per_Nm(p.brake, p.body) * p.drive.inertia_kgm2 * g_over_r;
    if (!(share_kg < p.body.mass_kg)) {
      problems.add("brake.after_rotor_inertia", "true",
                   "the brake gain times the reflected rotor inertia (" + number_text(share_kg) +
                       " kg) must be below vehicle.mass_kg");
    }
  }
}

const std::array<Signal<BevPlant::Outputs>, 31> BevPlant::kSignals = {{
    {"time_s", &Outputs::time_s, "simulation time"},
    {"speed_ref_m_s", &Outputs::speed_ref_m_s, "cycle (wanted) speed"},
    {"speed_m_s", &Outputs::speed_m_s, "vehicle speed"},
    {"distance_m", &Outputs::distance_m, "travelled distance"},
    {"acceleration_m_s2", &Outputs::acceleration_m_s2, "vehicle acceleration"},
    {"driver_request_Nm", &Outputs::driver_request_Nm, "driver torque request at the drive shaft (driverRequest)"},
    {"drive_torque_ref_Nm", &Outputs::drive_torque_ref_Nm, "torque the ECU asks of the drive (driveTauRef)"},
    {"drive_torque_Nm", &Outputs::drive_torque_Nm, "torque the drive applies (after the limiter)"},
    {"drive_torque_limit_Nm", &Outputs::drive_torque_limit_Nm, "limiter bound yH (genTauLim)"},
    {"drive_limit_state", &Outputs::drive_limit_state, "limiter state 0 torque, 1 power, 2 speed ramp, 3 over speed"},
    {"drive_limiting", &Outputs::drive_limiting, "1 when the limiter cuts the request"},
    {"drive_speed_rad_s", &Outputs::drive_speed_rad_s, "drive shaft speed"},
    {"drive_power_mech_W", &Outputs::drive_power_mech_W, "mechanical power torque x speed"},
    {"drive_power_dc_W", &Outputs::drive_power_dc_W, "DC power drawn by the drive"},
    {"drive_efficiency", &Outputs::drive_efficiency, "efficiency from the map"},
    {"brake_force_N", &Outputs::brake_force_N, "friction-brake force magnitude"},
    {"road_force_N", &Outputs::road_force_N, "road load (rolling + aero), or the locked reaction"},
    {"grade_rad", &Outputs::grade_rad, "road angle, > 0 uphill"},
    {"altitude_m", &Outputs::altitude_m, "altitude gained since start"},
    {"battery_voltage_V", &Outputs::battery_voltage_V, "terminal voltage"},
    {"battery_current_A", &Outputs::battery_current_A, "terminal current, > 0 discharging"},
    {"battery_power_W", &Outputs::battery_power_W, "terminal power v i (batPowDel)"},
    {"battery_emf_V", &Outputs::battery_emf_V, "EMF E"},
    {"soc", &Outputs::soc, "state of charge (batSOC)"},
    {"locked", &Outputs::locked, "1 while the vehicle is stuck at standstill (dragForce.locked)"},
    {"fault", &Outputs::fault, "fault bits: 1 SOC window, 2 cell current, 4 power infeasible, 8 non-finite"},
    {"battery_out_J", &Outputs::battery_out_J, "integral of terminal power"},
    {"road_work_J", &Outputs::road_work_J, "integral of road-load power"},
    {"drive_loss_J", &Outputs::drive_loss_J, "integral of drive losses"},
    {"battery_loss_J", &Outputs::battery_loss_J, "integral of battery losses"},
    {"brake_work_J", &Outputs::brake_work_J, "integral of brake dissipation"},
}};

BevPlant::BevPlant(const BevParams& params)
    : p_(params), drive_(params.drive), battery_(params.battery), body_(params.body, params.road, params.brake) {
  g_over_r_ = p_.body.gear_ratio / p_.body.wheel_radius_m;
  mass_eff_kg_ = p_.body.mass_kg + p_.drive.inertia_kgm2 * g_over_r_ * g_over_r_;
  inv_mass_eff_kg_ = 1.0 / mass_eff_kg_;
  if (p_.brake.after_rotor_inertia) {
    brake_inertia_kg_ = body_.brake_gain_N_per_Nm() * p_.drive.inertia_kgm2 * g_over_r_;
  }
}

BevPlant::State BevPlant::initial_state() const {
  State x = State::Zero();
  x[kSpeed] = p_.body.speed_initial_m_s;
  x[kEmf] = battery_.constants().emf_initial_V;
  return x;
}

BevPlant::Modes BevPlant::initial_modes(const State& x0) const {
  // §7.2: at t = 0 with v = 0 the vehicle is stuck and locked
  return Modes{x0[kSpeed] > 0.0 ? Motion::kForward : Motion::kStuck};
}

BevPlant::AtRest BevPlant::at_rest(const State& x, const Inputs& u) const {
  // same equations as evaluate() with v = 0: drive speed 0, so the limit is tau_max (state 0)
  const double request_Nm = u.driveTauRef_Nm;
  const double tau_max_Nm = drive_.params().torque_max_Nm;
  const double torque_Nm = std::clamp(request_Nm, -tau_max_Nm, tau_max_Nm);
  const double unmet_braking_Nm = torque_Nm - request_Nm;
  const double brake_N = body_.brake_N(unmet_braking_Nm);
  const double grade_rad = body_.road().grade_rad(x[kDistance]);
  return {torque_Nm * g_over_r_ - body_.road().grade_force_N(grade_rad), body_.road().rolling_N(grade_rad) + brake_N};
}

void BevPlant::crossings(double, const State& x, const Modes& m, const Inputs& u, double* z) const {
  if (m.motion != Motion::kStuck) {
    z[0] = VehicleBody::moving_crossing(m.motion, x[kSpeed]);
  } else {
    const AtRest r = at_rest(x, u);
    z[0] = VehicleBody::stuck_crossing(r.applied_N, r.breakaway_N);
  }
}

void BevPlant::on_crossing(int, double, State& x, Modes& m, const Inputs& u) const {
  if (m.motion != Motion::kStuck) x[kSpeed] = 0.0;  // came to rest: exactly zero
  // at rest (just stopped or stuck): stay, or start in the direction of the applied force;
  // a crossing that fired from the stuck mode starts by construction, a stop may stay stuck
  const AtRest r = at_rest(x, u);
  m.motion = motion_at_rest(r.applied_N, r.breakaway_N);
}

void BevPlant::sense(double t_s, const State& x, const Modes& m, const Inputs& u, Sensors& s) const {
  const Eval e = evaluate(x, m, u);
  s.driverRequest_Nm = drive(p_.driver, t_s, x[kSpeed]).request;
  s.speed_m_s = x[kSpeed];
  s.driveW_rad_s = e.drive_speed_rad_s;
  s.driveTauLim_Nm = e.drive.limit_Nm;
  s.drivePowDel_W = e.drive.power_mech_W;
  s.batSOC = battery_.soc(x[kEmf]);
  s.batPowDel_W = e.battery.voltage_V * e.battery.current_A;
  s.battery_voltage_V = e.battery.voltage_V;
  s.battery_current_A = e.battery.current_A;
  s.fault = battery_.faults(x[kEmf], e.battery) | (all_finite(x) ? 0u : kFaultNonFinite);
  s.locked = m.motion == Motion::kStuck;
}

[[gnu::always_inline]] inline void BevPlant::outputs_from(const Eval& e, double t_s, const State& x,
                                                          const Modes& m, const Inputs& u, Outputs& y) const {
  const DriverOutput driver = drive(p_.driver, t_s, x[kSpeed]);
  y.time_s = t_s;
  y.speed_ref_m_s = driver.speed_ref_m_s;
  y.speed_m_s = x[kSpeed];
  y.distance_m = x[kDistance];
  y.acceleration_m_s2 = e.accel_m_s2;
  y.driver_request_Nm = driver.request;
  y.drive_torque_ref_Nm = u.driveTauRef_Nm;
  y.drive_torque_Nm = e.drive.torque_Nm;
  y.drive_torque_limit_Nm = e.drive.limit_Nm;
  y.drive_limit_state = e.drive.limit_state;
  y.drive_limiting = e.drive.limiting ? 1.0 : 0.0;
  y.drive_speed_rad_s = e.drive_speed_rad_s;
  y.drive_power_mech_W = e.drive.power_mech_W;
  y.drive_power_dc_W = e.drive.power_dc_W;
  y.drive_efficiency = e.drive.efficiency;
  y.brake_force_N = e.brake_N;
  y.road_force_N = e.road_N;
  y.grade_rad = e.grade_rad;
  y.altitude_m = x[kAltitude];
  y.battery_voltage_V = e.battery.voltage_V;
  y.battery_current_A = e.battery.current_A;
  y.battery_power_W = e.battery.voltage_V * e.battery.current_A;
  y.battery_emf_V = x[kEmf];
  y.soc = battery_.soc(x[kEmf]);
  y.locked = m.motion == Motion::kStuck ? 1.0 : 0.0;
  y.fault = battery_.faults(x[kEmf], e.battery) | (all_finite(x) ? 0u : kFaultNonFinite);
  y.battery_out_J = x[kBatteryOutJ];
  y.road_work_J = x[kRoadJ];
  y.drive_loss_J = x[kDriveLossJ];
  y.battery_loss_J = x[kBatteryLossJ];
  y.brake_work_J = x[kBrakeJ];
}

void BevPlant::outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y) const {
  outputs_from(evaluate(x, m, u), t_s, x, m, u, y);
}

void BevPlant::outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y, State& dx) const {
  const Eval e = evaluate(x, m, u);
  outputs_from(e, t_s, x, m, u, y);
  derivatives_from(e, x, dx);
}

// The same expressions as outputs_from(), derivatives_from() and crossings(), from one evaluation.
void BevPlant::observe(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y, State& dx,
                       double* z) const {
  const Eval e = evaluate(x, m, u);
  ev_metric_outputs(p_.driver.cycle_m_s(t_s), x, battery_, m.motion, y);
  y.fault = battery_.faults(x[kEmf], e.battery) | (all_finite(x) ? 0u : kFaultNonFinite);
  derivatives_from(e, x, dx);
  crossings(t_s, x, m, u, z);
}

EnergyAudit BevPlant::audit(const State& x0, const State& x) const {
  return ev_energy_audit(battery_, mass_eff_kg_, p_.body.mass_kg, x0.data(), x.data());
}

}  // namespace ehpt::plant
