// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Battery-electric vehicle with a map-based one-flange drive: MBEV, MODELS.md §10.3
// (tutorial §4), built from PropDriver (§8), OneFlange (§1), Batt1 (§6), DragForce (§7) and
// the vehicle of §7.4. Paper: P15 §5.1 (same structure as EvPm_bat, map-based drive).
//
//   driver:   tau_req = clamp(k (v_ref(t) - v), -yMax, yMax)            (N m at the drive shaft)
//             the person at the wheel, part of the plant: a sensor (driverRequest_Nm) for the ECU
//   ECU:      tau_cmd, the command (msgs::EvCommand, the plant's Inputs), held over each ECU
//             period; the built-in ECU (ecu::EvFollower) sets tau_cmd = tau_req at each sample
//   drive:    w = v G / r;  tau = clamp(tau_cmd, -tau_lim(w), tau_lim(w));  P_dc from the map
//   brake:    the braking the drive cannot deliver: F_brake = (G / r) max(0, tau - tau_cmd),
//             opposing motion (MBEV's gain G*r is a source defect, §10.3; flag brake_library_gain).
//             brake.after_rotor_inertia: MBEV's signal, max(0, tau - J dw/dt - tau_req); with
//             dw/dt = (G/r) dv/dt this is an algebraic loop, linear on each branch, solved
//             exactly (unique while the gain times J (G/r) is below the effective mass)
//   battery:  supplies P_dc (constant-power load on the RC pack)
//   body:     (m + J (G/r)^2) dv/dt = tau G/r - F_roll - F_v(v) - m g sin(alpha) - F_brake
//             ds/dt = v,  dh/dt = v sin(alpha)
//   stuck:    dv/dt = 0 while |tau G/r - m g sin(alpha)| <= F_roll + F_brake   (locked, §7.2)
//
// State (one flat vector, offsets composed from the components' sizes): v (m/s); the
// VehicleBody's s (m), h (m), road-load work and brake dissipation (J); the battery's E and
// v_rc (V); the plant's energy integrals (J): battery terminal energy out, drive losses,
// battery losses. The integrals feed the energy audit:
//     stored-energy decrease = road work + drive losses + battery losses + brake
//                              + change of kinetic energy (vehicle + rotor) + m g (h - h0)
// Crossing 0 (one function per mode, always falling through zero):
//   kForward:  z = v                -> stop: v := 0, then stuck or restart per motion_at_rest
//   kBackward: z = -v               -> same
//   kStuck:    z = F_breakaway - |F_applied|  -> start in the direction of F_applied

#include <array>
#include <span>

#include <Eigen/Core>

#include "msgs/ev.hpp"
#include "plant/battery_rc.hpp"
#include "plant/ev_state.hpp"
#include "plant/map_drive.hpp"
#include "plant/prop_driver.hpp"
#include "plant/road_load.hpp"
#include "plant/signals.hpp"
#include "plant/vehicle_body.hpp"

namespace ehpt::plant {

struct BevParams {
  VehicleBodyParams body;
  RoadLoadParams road;
  MapDriveParams drive;
  BatteryRcParams battery;
  PropDriverParams driver;
  BrakeParams brake;
};

void validate(const BevParams& p, Problems& problems);

class BevPlant : public EvStateLayout {
 public:
  // the state: EvStateLayout (ev_state.hpp), [v | VehicleBody | BatteryRc | energy integrals]
  static constexpr int kNumCrossings = 1;
  using State = Eigen::Matrix<double, kNumStates, 1>;
  struct Modes {
    Motion motion = Motion::kStuck;
  };
  using Params = BevParams;
  using Inputs = msgs::EvCommand;  // held over each ECU period
  using Sensors = msgs::EvSensors;

  struct Outputs {
    double time_s = 0, speed_ref_m_s = 0, speed_m_s = 0, distance_m = 0, acceleration_m_s2 = 0;
    double driver_request_Nm = 0, drive_torque_ref_Nm = 0, drive_torque_Nm = 0, drive_torque_limit_Nm = 0;
    double drive_limit_state = 0;
    double drive_limiting = 0, drive_speed_rad_s = 0, drive_power_mech_W = 0, drive_power_dc_W = 0;
    double drive_efficiency = 0, brake_force_N = 0, road_force_N = 0, grade_rad = 0, altitude_m = 0;
    double battery_voltage_V = 0, battery_current_A = 0, battery_power_W = 0, battery_emf_V = 0, soc = 0;
    double locked = 0, fault = 0;
    double battery_out_J = 0, road_work_J = 0, drive_loss_J = 0, battery_loss_J = 0, brake_work_J = 0;
  };
  static const std::array<Signal<Outputs>, 31> kSignals;
  static constexpr MetricSources<Outputs> kMetrics{.speed_ref_m_s = &Outputs::speed_ref_m_s,
                                                   .speed_m_s = &Outputs::speed_m_s,
                                                   .locked = &Outputs::locked,
                                                   .distance_m = &Outputs::distance_m,
                                                   .soc = &Outputs::soc};

  explicit BevPlant(const BevParams& params);  // start-up: params already validated

  State initial_state() const;
  Modes initial_modes(const State& x0) const;

  // Run phase: pure functions, no allocation.
  // (defined below, inline: the integrators inline it into their stages)
  void derivatives(double t_s, const State& x, const Modes& m, const Inputs& u, State& dx) const;
  void crossings(double t_s, const State& x, const Modes& m, const Inputs& u, double* z) const;
  void on_crossing(int index, double t_s, State& x, Modes& m, const Inputs& u) const;
  void outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y) const;
  // The outputs and dx/dt from one evaluation: the runner hands dx/dt to the integrator as the
  // first stage of the next step (same t, x, modes, inputs), which saves one evaluation.
  void outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y, State& dx) const;
  // What the ECU reads at t_s (the stamp is the runner's).
  void sense(double t_s, const State& x, const Modes& m, const Inputs& u, Sensors& s) const;
  // The runner's observation at a grid point it does not record (solvers/plant.hpp), from one
  // evaluation: the outputs kMetrics names and fault (the other fields of y are left as they
  // were), dx/dt and the crossing functions z, each bit for bit what outputs(), derivatives()
  // and crossings() give at the same point.
  void observe(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y, State& dx, double* z) const;

  std::span<const Signal<Outputs>> signals() const { return kSignals; }
  // Energy audit between x0 and x (end of run; allocates).
  EnergyAudit audit(const State& x0, const State& x) const;

  const BevParams& params() const { return p_; }
  const BatteryRc& battery() const { return battery_; }

 private:
  struct Eval;  // everything one evaluation computes (the driver is not needed for it)
  Eval evaluate(const State& x, const Modes& m, const Inputs& u) const;
  void derivatives_from(const Eval& e, const State& x, State& dx) const;
  void outputs_from(const Eval& e, double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y) const;
  // At rest (v = 0): the force the road must hold, and the break-away threshold. A lean
  // version of evaluate() for the stuck-mode crossing, which runs twice per step.
  struct AtRest {
    double applied_N, breakaway_N;
  };
  AtRest at_rest(const State& x, const Inputs& u) const;

  BevParams p_;
  MapDrive drive_;
  BatteryRc battery_;
  VehicleBody body_;
  double g_over_r_ = 0.0;        // drive speed per vehicle speed (rad/m)
  double mass_eff_kg_ = 0.0;     // vehicle + rotor reflected
  double inv_mass_eff_kg_ = 0.0;
  double brake_inertia_kg_ = 0.0;  // after_rotor_inertia: brake_gain * J * G/r (0 otherwise)
};

struct BevPlant::Eval {
  DriveOperatingPoint drive;
  BatteryTerminal battery;
  double drive_speed_rad_s;
  double grade_rad;
  double rolling_N;      // Coulomb part (also the break-away force)
  double speed_force_N;  // aero / viscous part, odd in v
  double brake_N;        // magnitude
  double applied_N;      // drive force minus grade force: what the road must hold while stuck ("sa" of §7.2)
  double road_N;         // reaction of the road (rolling + speed part, or sa when stuck)
  double accel_m_s2;
};

// Run phase: no allocation. Always inlined, so that each caller computes only what it uses. In the
// header, with derivatives(), so that an integrator inlines every stage (solvers/integrators.hpp).
[[gnu::always_inline]] inline BevPlant::Eval BevPlant::evaluate(const State& x, const Modes& m, const Inputs& u) const {
  const double v = x[kSpeed];
  // the drive follows the ECU's command, a shaft torque; the limiter may cut it
  const double drive_speed_rad_s = v * g_over_r_;
  const DriveOperatingPoint op = drive_.operate(u.driveTauRef_Nm, drive_speed_rad_s);
  // forces at the wheel; the friction brake supplies the braking the drive could not
  const VehicleBody::Forces f = body_.forces(v, x[kDistance]);
  const double grade_rad = f.grade_rad, rolling_N = f.rolling_N, speed_force_N = f.speed_force_N;
  const double unmet_braking_Nm = op.torque_Nm - u.driveTauRef_Nm;
  double brake_N = body_.brake_N(unmet_braking_Nm);
  const double tractive_N = op.torque_Nm * g_over_r_;
  const double applied_N = tractive_N - f.grade_force_N;
  // stuck: the road reacts with the applied force, no acceleration; moving: road load and
  // brake oppose the motion (d = +1 forward, -1 backward)
  double road_N = applied_N, accel_m_s2 = 0.0;
  if (m.motion != Motion::kStuck) {
    const double d = m.motion == Motion::kForward ? 1.0 : -1.0;
    road_N = d * rolling_N + speed_force_N;
    accel_m_s2 = (applied_N - road_N - d * brake_N) * inv_mass_eff_kg_;
    if (brake_inertia_kg_ > 0.0) {
      // MBEV's brake signal: max(0, unmet - J (G/r) a). Without the brake, a0 above; if the
      // signal is positive there, the active branch m_eff a = F - d k (unmet - J (G/r) a) holds
      const double gain = body_.brake_gain_N_per_Nm();
      const double signal_N = gain * unmet_braking_Nm - brake_inertia_kg_ * ((applied_N - road_N) * inv_mass_eff_kg_);
      if (signal_N > 0.0) {
        accel_m_s2 = (applied_N - road_N - d * gain * unmet_braking_Nm) / (mass_eff_kg_ - d * brake_inertia_kg_);
        brake_N = gain * unmet_braking_Nm - brake_inertia_kg_ * accel_m_s2;
      } else {
        brake_N = 0.0;
        accel_m_s2 = (applied_N - road_N) * inv_mass_eff_kg_;
      }
    }
  }
  // the battery supplies the drive's DC power
  return Eval{.drive = op,
              .battery = battery_.terminal(x[kEmf], x[kVrc], op.power_dc_W),
              .drive_speed_rad_s = drive_speed_rad_s,
              .grade_rad = grade_rad,
              .rolling_N = rolling_N,
              .speed_force_N = speed_force_N,
              .brake_N = brake_N,
              .applied_N = applied_N,
              .road_N = road_N,
              .accel_m_s2 = accel_m_s2};
}

// Inlined into derivatives() (the RK4 stages) and outputs(): one evaluation, no copy of it.
[[gnu::always_inline]] inline void BevPlant::derivatives_from(const Eval& e, const State& x, State& dx) const {
  const double v = x[kSpeed];
  dx[kSpeed] = e.accel_m_s2;
  body_.derivatives(v, {e.grade_rad, e.rolling_N, e.speed_force_N, 0.0}, e.brake_N, dx.data() + kBodyAt);
  dx[kEmf] = battery_.demf_dt(e.battery);
  dx[kVrc] = battery_.dvrc_dt(e.battery, x[kVrc]);
  // energy integrals for the audit (all zero while stuck because v = 0)
  dx[kBatteryOutJ] = e.battery.voltage_V * e.battery.current_A;
  dx[kDriveLossJ] = e.drive.power_dc_W - e.drive.power_mech_W;
  dx[kBatteryLossJ] = e.battery.loss_W;
}

[[gnu::always_inline]] inline void BevPlant::derivatives(double, const State& x, const Modes& m, const Inputs& u, State& dx) const {
  derivatives_from(evaluate(x, m, u), x, dx);
}

}  // namespace ehpt::plant
