// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The battery-electric vehicle, one template over its drive: MBEV with the map-based drive
// (MODELS.md §10.3, tutorial §4; Drive = MapMachine, bev_plant.hpp), EvPm_bat with PMDrive
// (§10.1, P15 §5.1, Figs. 18-20) and EvAm_bat with AMDrive (§10.2) (Drive = PmMachine,
// AmMachine, ev_machine_plant.hpp). Built from PropDriver (§8), Batt1 (§6), DragForce (§7)
// and the vehicle of §7.4; only the drive differs:
//
//   driver:   tau_req = clamp(k (v_ref(t) - v), -yMax, yMax)            (N m at the drive shaft)
//             the person at the wheel, part of the plant: a sensor (driverRequest_Nm) for the ECU
//   ECU:      tau_cmd, the command (msgs::EvCommand, the plant's Inputs), held over each ECU
//             period; the built-in ECU (ecu::EvFollower) sets tau_cmd = tau_req at each sample
//   drive:    w = v G / r;  the drive's operating point for (tau_cmd, w, u_dc): tau, P_dc
//             map (map_drive.hpp): tau = clamp(tau_cmd, -tau_lim(w), tau_lim(w)), P_dc from the map
//             PM (pm_drive.hpp): MTPA / flux weakening / current limit -> Te, Id, Iq, P_dc
//             AM (am_drive.hpp): TorqueToDW -> slip -> equivalent circuit -> Te, I1, P_dc
//             u_dc = E - v_rc, the pack's voltage behind R0: a machine's voltage limit uses
//             it without closing the loop through the terminal voltage, which depends on
//             P_dc (with the recommended pack, 330-415 V, u_dc / sqrt 3 >= 190 V is above the
//             machine's own sqrt 2 U_max = 141 V, so the choice does not matter there)
//   brake:    the braking the drive cannot deliver: F_brake = (G / r) max(0, tau - tau_cmd),
//             opposing motion (MBEV's gain G*r is a source defect, §10.3; flag brake_library_gain).
//             brake.after_rotor_inertia (map drive only, Drive::kMbevBrakeSignal): MBEV's
//             signal, max(0, tau - J dw/dt - tau_req); with dw/dt = (G/r) dv/dt this is an
//             algebraic loop, linear on each branch, solved exactly (unique while the gain
//             times J (G/r) is below the effective mass)
//   battery:  supplies P_dc (constant-power load on the RC pack)
//   body:     (m + J (G/r)^2) dv/dt = tau G/r - F_roll - F_v(v) - m g sin(alpha) - F_brake
//             ds/dt = v,  dh/dt = v sin(alpha)
//   stuck:    dv/dt = 0 while |tau G/r - m g sin(alpha)| <= F_roll + F_brake   (locked, §7.2)
//   faults:   set_health (plant/health.hpp) between steps: the pack's constants, and derating:
//             the drive's torque bound x gain (tau_cmd clamped to it before the drive, the
//             bound the ECU reads in driveTauLim; the friction brake takes the braking it cuts)
//
// State and energy audit: EvStateLayout and ev_energy_audit (ev_state.hpp).
// Crossing 0 (one function per mode, always falling through zero), then the drive's own
// (PMDrive: MTPA <-> flux weakening, located so that no RK4 step straddles the kink):
//   kForward:  z = v                -> stop: v := 0, then stuck or restart per motion_at_rest
//   kBackward: z = -v               -> same
//   kStuck:    z = F_breakaway - |F_applied|  -> start in the direction of F_applied
// A drive's electrical state is algebraic (no states, §10.7 recommendation with the algebraic
// current limit), solved at each evaluation from the same inputs, so the plant's functions
// stay pure and a trajectory does not depend on which outputs were recorded (PmMachine
// remembers MTPA for the last command: a memo of a pure function, same bits).
//
// A Drive supplies (MapMachine, PmMachine, AmMachine):
//   Params, Point (its operating point), Outputs (its own fields), Mode and kNumCrossings
//   (with crossings() and on_crossing() when > 0), kMbevBrakeSignal (brake.after_rotor_inertia
//   allowed), Drive(const Params&), inertia_kgm2();
//   operate(tau_cmd, w, u_dc) -> Point; torque_at_rest_Nm(tau_cmd, u_dc) = the torque of
//   operate(tau_cmd, 0, u_dc), lean (the stuck crossing runs twice per step);
//   torque_Nm(Point), power_dc_W(Point), faults(Point), fill(Point, Outputs&);
//   torque_limit_Nm(Point, w): the bound reported to the ECU (driveTauLim);
//   ev_signals<Outputs>(): the vehicle's signals in column order;
//   validate_with_battery(drive, battery, problems).

#include <algorithm>
#include <array>
#include <span>

#include <Eigen/Core>

#include "msgs/ev.hpp"
#include "plant/battery_rc.hpp"
#include "plant/ev_state.hpp"
#include "plant/observation.hpp"
#include "plant/problems.hpp"
#include "plant/prop_driver.hpp"
#include "plant/road_load.hpp"
#include "plant/signals.hpp"
#include "plant/vehicle_body.hpp"

namespace ehpt::plant {

template <class Drive>
struct EvParams {
  VehicleBodyParams body;
  RoadLoadParams road;
  typename Drive::Params drive;
  BatteryRcParams battery;
  PropDriverParams driver;
  BrakeParams brake;
};

// What every EV computes; the drive's own fields follow (EvPlant::Outputs). A drive's signal
// list (Drive::ev_signals) names the ones its vehicle records, in its column order.
struct EvOutputs {
  double time_s = 0, speed_ref_m_s = 0, speed_m_s = 0, distance_m = 0, acceleration_m_s2 = 0;
  double driver_request_Nm = 0, drive_torque_ref_Nm = 0, drive_torque_Nm = 0, drive_speed_rad_s = 0;
  double drive_power_mech_W = 0, drive_power_dc_W = 0, drive_loss_W = 0;
  double brake_force_N = 0, road_force_N = 0, grade_rad = 0, altitude_m = 0;
  double battery_voltage_V = 0, battery_current_A = 0, battery_power_W = 0, battery_emf_V = 0, soc = 0;
  double locked = 0, fault = 0;
  double battery_out_J = 0, road_work_J = 0, drive_loss_J = 0, battery_loss_J = 0, brake_work_J = 0;
};

template <class Drive>
void validate(const EvParams<Drive>& p, Problems& problems) {
  validate(p.body, "vehicle", problems);
  validate(p.road, "road", problems);
  validate(p.drive, "drive", problems);
  validate(p.battery, "battery", problems);
  validate(p.driver, "driver", problems);
  if constexpr (Drive::kMbevBrakeSignal) {
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
  } else if (p.brake.after_rotor_inertia) {
    problems.add("brake.after_rotor_inertia", "true",
                 "is MBEV's brake signal; a machine drive's brake uses the applied torque");
  }
  Drive::validate_with_battery(p.drive, p.battery, problems);
}

template <class Drive>
class EvPlant : public EvStateLayout {
 public:
  // the state: EvStateLayout (ev_state.hpp), [v | VehicleBody | BatteryRc | energy integrals]
  static constexpr int kNumCrossings = 1 + Drive::kNumCrossings;
  using State = Eigen::Matrix<double, kNumStates, 1>;
  using Params = EvParams<Drive>;
  struct Modes {
    Motion motion = Motion::kStuck;
    typename Drive::Mode drive{};
  };
  using Inputs = msgs::EvCommand;  // held over each ECU period
  using Sensors = msgs::EvSensors;
  struct Outputs : EvOutputs, Drive::Outputs {};

  static constexpr auto kSignals = Drive::template ev_signals<Outputs>();
  static constexpr MetricSources<Outputs> kMetrics{.speed_ref_m_s = &Outputs::speed_ref_m_s,
                                                   .speed_m_s = &Outputs::speed_m_s,
                                                   .locked = &Outputs::locked,
                                                   .distance_m = &Outputs::distance_m,
                                                   .soc = &Outputs::soc};

  explicit EvPlant(const Params& params)  // start-up: params already validated
      : p_(params), drive_(params.drive), battery_(params.battery), body_(params.body, params.road, params.brake) {
    g_over_r_ = p_.body.gear_ratio / p_.body.wheel_radius_m;
    mass_eff_kg_ = p_.body.mass_kg + drive_.inertia_kgm2() * g_over_r_ * g_over_r_;
    inv_mass_eff_kg_ = 1.0 / mass_eff_kg_;
    if constexpr (Drive::kMbevBrakeSignal) {
      if (p_.brake.after_rotor_inertia) {
        brake_inertia_kg_ = body_.brake_gain_N_per_Nm() * drive_.inertia_kgm2() * g_over_r_;
      }
    }
  }

  State initial_state() const {
    State x = State::Zero();
    x[kSpeed] = p_.body.speed_initial_m_s;
    x[kEmf] = battery_.constants().emf_initial_V;
    return x;
  }
  // §7.2: at t = 0 with v = 0 the vehicle is stuck and locked. The drive's mode starts at its
  // default; if the first command says otherwise, its crossing is negative at the first
  // step's start and fires there.
  Modes initial_modes(const State& x0) const { return Modes{x0[kSpeed] > 0.0 ? Motion::kForward : Motion::kStuck, {}}; }

  // Run phase: pure functions, no allocation; inline, so that the integrators inline every stage.
  [[gnu::always_inline]] void derivatives(double, const State& x, const Modes& m, const Inputs& u, State& dx) const {
    derivatives_from(evaluate(x, m, u), x, dx);
  }
  void crossings(double, const State& x, const Modes& m, const Inputs& u, double* z) const {
    if (m.motion != Motion::kStuck) {
      z[0] = VehicleBody::moving_crossing(m.motion, x[kSpeed]);
    } else {
      const AtRest r = at_rest(x, u);
      z[0] = VehicleBody::stuck_crossing(r.applied_N, r.breakaway_N);
    }
    if constexpr (Drive::kNumCrossings > 0) {
      drive_.crossings(m.drive, u.driveTauRef_Nm, x[kSpeed] * g_over_r_, x[kEmf] - x[kVrc], z + 1);
    }
  }
  void on_crossing(int index, double, State& x, Modes& m, const Inputs& u) const {
    if (index > 0) {
      if constexpr (Drive::kNumCrossings > 0) drive_.on_crossing(index - 1, m.drive);
      return;
    }
    if (m.motion != Motion::kStuck) x[kSpeed] = 0.0;  // came to rest: exactly zero
    // at rest (just stopped or stuck): stay, or start in the direction of the applied force;
    // a crossing that fired from the stuck mode starts by construction, a stop may stay stuck
    const AtRest r = at_rest(x, u);
    m.motion = motion_at_rest(r.applied_N, r.breakaway_N);
  }
  void outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y) const {
    outputs_from<OutputSet::kAll>(evaluate(x, m, u), t_s, x, m, u, y);
  }
  // The outputs and dx/dt from one evaluation: the runner hands dx/dt to the integrator as the
  // first stage of the next step (same t, x, modes, inputs), which saves one evaluation.
  void outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y, State& dx) const {
    const Eval e = evaluate(x, m, u);
    outputs_from<OutputSet::kAll>(e, t_s, x, m, u, y);
    derivatives_from(e, x, dx);
  }
  // What the ECU reads at t_s (the stamp is the runner's).
  void sense(double t_s, const State& x, const Modes& m, const Inputs& u, Sensors& s) const {
    const Eval e = evaluate(x, m, u);
    s.driverRequest_Nm = drive(p_.driver, t_s, x[kSpeed]).request;
    s.speed_m_s = x[kSpeed];
    s.driveW_rad_s = e.drive_speed_rad_s;
    s.driveTauLim_Nm = torque_gain_ * drive_.torque_limit_Nm(e.drive, e.drive_speed_rad_s);
    s.drivePowDel_W = e.power_mech_W;
    s.batSOC = battery_.soc(x[kEmf]);
    s.batPowDel_W = e.battery.voltage_V * e.battery.current_A;
    s.battery_voltage_V = e.battery.voltage_V;
    s.battery_current_A = e.battery.current_A;
    s.fault = faults(e, x);
    s.locked = m.motion == Motion::kStuck;
  }
  // The runner's observation at a grid point it does not record (solvers/plant.hpp), from one
  // evaluation: the outputs of OutputSet::kObserved (observation.hpp; the other fields of y are
  // left as they were), dx/dt and the crossing functions z. With kSet = kAll every field of y,
  // bit for bit outputs(): what a test's expectations read at every step.
  template <OutputSet kSet = OutputSet::kObserved>
  void observe(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y, State& dx, double* z) const {
    static_assert(kObservationTested<EvPlant>, "list the plant in ObservedPlants (plant/observation.hpp)");
    const Eval e = evaluate(x, m, u);
    outputs_from<kSet>(e, t_s, x, m, u, y);
    derivatives_from(e, x, dx);
    crossings(t_s, x, m, u, z);
  }

  std::span<const Signal<Outputs>> signals() const { return kSignals; }

  // Energy audit between x0 and x (end of run; allocates).
  EnergyAudit audit(const State& x0, const State& x) const {
    return ev_energy_audit(battery_, mass_eff_kg_, p_.body.mass_kg, x0.data(), x.data());
  }

  // Plant faults, between steps only (the run's fault injector; this plant is that run's own).
  static constexpr std::array<const char*, 1> kMachines = {"drive"};
  void set_health(const PlantHealth& h, const State& x) {
    battery_.set_health(h.battery, x[kEmf], x[kVrc]);
    torque_gain_ = h.torque_gain[0];
  }

  const Params& params() const { return p_; }
  const BatteryRc& battery() const { return battery_; }
  const Drive& machine() const { return drive_; }

 private:
  struct Eval {  // everything one evaluation computes (the driver is not needed for it)
    typename Drive::Point drive;
    double torque_Nm, power_mech_W, power_dc_W;
    BatteryTerminal battery;
    double drive_speed_rad_s, grade_rad;
    double rolling_N;      // Coulomb part (also the break-away force)
    double speed_force_N;  // aero / viscous part, odd in v
    double brake_N;        // magnitude
    double applied_N;      // drive force minus grade force: what the road must hold while stuck ("sa" of §7.2)
    double road_N;         // reaction of the road (rolling + speed part, or sa when stuck)
    double accel_m_s2;
  };
  // At rest (v = 0): the force the road must hold, and the break-away threshold.
  struct AtRest {
    double applied_N, breakaway_N;
  };

  // Always inlined, so that each caller computes only what it uses.
  [[gnu::always_inline]] Eval evaluate(const State& x, const Modes& m, const Inputs& u) const {
    const double v = x[kSpeed];
    // the drive follows the ECU's command, a shaft torque; its limits may cut it
    const double drive_speed_rad_s = v * g_over_r_;
    const double u_dc_V = x[kEmf] - x[kVrc];
    Eval e;
    e.drive = drive_.operate(u.driveTauRef_Nm, drive_speed_rad_s, u_dc_V);
    if (torque_gain_ != 1.0) [[unlikely]] {
      e.drive = derated(u.driveTauRef_Nm, e.drive, drive_speed_rad_s, u_dc_V);
    }
    e.torque_Nm = Drive::torque_Nm(e.drive);
    e.power_mech_W = e.torque_Nm * drive_speed_rad_s;
    e.power_dc_W = Drive::power_dc_W(e.drive);
    // forces at the wheel; the friction brake supplies the braking the drive could not
    const VehicleBody::Forces f = body_.forces(v, x[kDistance]);
    e.grade_rad = f.grade_rad;
    e.rolling_N = f.rolling_N;
    e.speed_force_N = f.speed_force_N;
    const double unmet_braking_Nm = e.torque_Nm - u.driveTauRef_Nm;
    e.brake_N = body_.brake_N(unmet_braking_Nm);
    e.applied_N = e.torque_Nm * g_over_r_ - f.grade_force_N;
    // stuck: the road reacts with the applied force, no acceleration; moving: road load and
    // brake oppose the motion (d = +1 forward, -1 backward)
    e.road_N = e.applied_N;
    e.accel_m_s2 = 0.0;
    if (m.motion != Motion::kStuck) {
      const double d = m.motion == Motion::kForward ? 1.0 : -1.0;
      e.road_N = d * e.rolling_N + e.speed_force_N;
      e.accel_m_s2 = (e.applied_N - e.road_N - d * e.brake_N) * inv_mass_eff_kg_;
      if constexpr (Drive::kMbevBrakeSignal) {
        if (brake_inertia_kg_ > 0.0) {
          // MBEV's brake signal: max(0, unmet - J (G/r) a). Without the brake, a0 above; if the
          // signal is positive there, the active branch m_eff a = F - d k (unmet - J (G/r) a) holds
          const double gain = body_.brake_gain_N_per_Nm();
          const double signal_N =
              gain * unmet_braking_Nm - brake_inertia_kg_ * ((e.applied_N - e.road_N) * inv_mass_eff_kg_);
          if (signal_N > 0.0) {
            e.accel_m_s2 = (e.applied_N - e.road_N - d * gain * unmet_braking_Nm) / (mass_eff_kg_ - d * brake_inertia_kg_);
            e.brake_N = gain * unmet_braking_Nm - brake_inertia_kg_ * e.accel_m_s2;
          } else {
            e.brake_N = 0.0;
            e.accel_m_s2 = (e.applied_N - e.road_N) * inv_mass_eff_kg_;
          }
        }
      }
    }
    // the battery supplies the drive's DC power
    e.battery = battery_.terminal(x[kEmf], x[kVrc], e.power_dc_W);
    e.drive_speed_rad_s = drive_speed_rad_s;
    return e;
  }

  // The same equations as evaluate() with v = 0, for the stuck crossing (twice per step).
  AtRest at_rest(const State& x, const Inputs& u) const {
    const double u_dc_V = x[kEmf] - x[kVrc];
    double torque_Nm = drive_.torque_at_rest_Nm(u.driveTauRef_Nm, u_dc_V);
    if (torque_gain_ != 1.0) [[unlikely]] {
      torque_Nm = Drive::torque_Nm(derated(u.driveTauRef_Nm, drive_.operate(u.driveTauRef_Nm, 0.0, u_dc_V), 0.0, u_dc_V));
    }
    const double grade_rad = body_.road().grade_rad(x[kDistance]);
    return {torque_Nm * g_over_r_ - body_.road().grade_force_N(grade_rad),
            body_.road().rolling_N(grade_rad) + body_.brake_N(torque_Nm - u.driveTauRef_Nm)};
  }

  // A derated drive: the command clamped to gain x the drive's own bound at this point.
  typename Drive::Point derated(double tau_cmd_Nm, const typename Drive::Point& healthy, double w_rad_s,
                                double u_dc_V) const {
    const double bound_Nm = torque_gain_ * drive_.torque_limit_Nm(healthy, w_rad_s);
    const double tau_Nm = std::clamp(tau_cmd_Nm, -bound_Nm, bound_Nm);
    return tau_Nm == tau_cmd_Nm ? healthy : drive_.operate(tau_Nm, w_rad_s, u_dc_V);
  }

  [[gnu::always_inline]] unsigned faults(const Eval& e, const State& x) const {
    return battery_.faults(x[kEmf], e.battery) | Drive::faults(e.drive) | (all_finite(x) ? 0u : kFaultNonFinite);
  }

  // Inlined into derivatives() (the RK4 stages) and outputs(): one evaluation, no copy of it.
  [[gnu::always_inline]] void derivatives_from(const Eval& e, const State& x, State& dx) const {
    dx[kSpeed] = e.accel_m_s2;
    body_.derivatives(x[kSpeed], {e.grade_rad, e.rolling_N, e.speed_force_N, 0.0}, e.brake_N, dx.data() + kBodyAt);
    dx[kEmf] = battery_.demf_dt(e.battery);
    dx[kVrc] = battery_.dvrc_dt(e.battery, x[kVrc]);
    // energy integrals for the audit (all zero while stuck because v = 0)
    dx[kBatteryOutJ] = e.battery.voltage_V * e.battery.current_A;
    dx[kDriveLossJ] = e.power_dc_W - e.power_mech_W;
    dx[kBatteryLossJ] = e.battery.loss_W;
  }

  // The outputs, once for both sets (observation.hpp): the observed fields outside the
  // `if constexpr`, the rest inside.
  template <OutputSet kSet>
  [[gnu::always_inline]] void outputs_from(const Eval& e, double t_s, const State& x, const Modes& m, const Inputs& u,
                                           Outputs& y) const {
    constexpr bool kAll = kSet == OutputSet::kAll;
    const double speed_ref_m_s = p_.driver.cycle_m_s(t_s);
    y.speed_ref_m_s = speed_ref_m_s;
    y.speed_m_s = x[kSpeed];
    y.distance_m = x[kDistance];
    y.soc = battery_.soc(x[kEmf]);
    y.locked = m.motion == Motion::kStuck ? 1.0 : 0.0;
    y.fault = faults(e, x);
    if constexpr (kAll) {
      y.time_s = t_s;
      y.acceleration_m_s2 = e.accel_m_s2;
      y.driver_request_Nm = drive_at(p_.driver, speed_ref_m_s, x[kSpeed]).request;
      y.drive_torque_ref_Nm = u.driveTauRef_Nm;
      y.drive_torque_Nm = e.torque_Nm;
      y.drive_speed_rad_s = e.drive_speed_rad_s;
      y.drive_power_mech_W = e.power_mech_W;
      y.drive_power_dc_W = e.power_dc_W;
      y.drive_loss_W = e.power_dc_W - e.power_mech_W;
      y.brake_force_N = e.brake_N;
      y.road_force_N = e.road_N;
      y.grade_rad = e.grade_rad;
      y.altitude_m = x[kAltitude];
      y.battery_voltage_V = e.battery.voltage_V;
      y.battery_current_A = e.battery.current_A;
      y.battery_power_W = e.battery.voltage_V * e.battery.current_A;
      y.battery_emf_V = x[kEmf];
      y.battery_out_J = x[kBatteryOutJ];
      y.road_work_J = x[kRoadJ];
      y.drive_loss_J = x[kDriveLossJ];
      y.battery_loss_J = x[kBatteryLossJ];
      y.brake_work_J = x[kBrakeJ];
      Drive::fill(e.drive, y);
    }
  }

  Params p_;
  Drive drive_;
  BatteryRc battery_;
  VehicleBody body_;
  double g_over_r_ = 0.0;          // drive speed per vehicle speed (rad/m)
  double mass_eff_kg_ = 0.0;       // vehicle + rotor reflected
  double inv_mass_eff_kg_ = 0.0;
  double brake_inertia_kg_ = 0.0;  // after_rotor_inertia: brake_gain * J * G/r (0 otherwise)
  double torque_gain_ = 1.0;       // derating (plant faults): 1 healthy
};

}  // namespace ehpt::plant
