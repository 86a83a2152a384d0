// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Battery-electric vehicles with a physics-based machine drive: EvPm_bat (PMDrive, MODELS.md
// §10.1, P15 §5.1, Figs. 18-20) and EvAm_bat (AMDrive, §10.2). The same vehicle as the
// map-based EV (bev_plant.hpp): PropDriver, the driver-follower ECU (or an external one on a
// bus), the friction brake, DragForce with its locked state, Batt1. Only the drive differs:
//
//   driver:   tau_req = clamp(k (v_ref(t) - v), -yMax, yMax)            (N m at the drive shaft)
//   ECU:      tau_cmd (msgs::EvCommand), held over each ECU period
//   drive:    w = v G / r;  operating point of the machine for (tau_cmd, w, u_dc):
//             PM (pm_drive.hpp): MTPA / flux weakening / current limit -> Te, Id, Iq, P_dc
//             AM (am_drive.hpp): TorqueToDW -> slip -> equivalent circuit -> Te, I1, P_dc
//             u_dc = E - v_rc, the pack's voltage behind R0: the machine's voltage limit uses
//             it without closing the loop through the terminal voltage, which depends on
//             P_dc (with the recommended pack, 330-415 V, u_dc / sqrt 3 >= 190 V is above the
//             machine's own sqrt 2 U_max = 141 V, so the choice does not matter there)
//   brake:    F_brake = (G / r) max(0, Te - tau_cmd): the braking the drive could not deliver
//   battery:  supplies P_dc (constant-power load on the RC pack)
//   body:     (m + J (G/r)^2) dv/dt = Te G/r - F_roll - F_v(v) - m g sin(alpha) - F_brake
//   stuck:    dv/dt = 0 while |Te G/r - m g sin(alpha)| <= F_roll + F_brake   (locked, §7.2)
//
// State and energy audit: those of the map-based EV (ev_state.hpp).
// The drive's electrical state is algebraic (no states, §10.7 recommendation with the
// algebraic current limit), solved at each evaluation from the same inputs, so the plant's
// functions stay pure and a trajectory does not depend on which outputs were recorded
// (PmMachine remembers MTPA for the last command: a memo of a pure function, same bits).
//
// A Drive (PmMachine, AmMachine below the class) supplies: Params, Point (its operating
// point), Outputs (its own signals), operate(), torque/power accessors, faults, the torque
// limit reported to the ECU, and its own crossings with a Mode (none for AMDrive).

#include <array>
#include <cmath>
#include <limits>
#include <span>

#include <Eigen/Core>

#include "msgs/ev.hpp"
#include "plant/am_drive.hpp"
#include "plant/battery_rc.hpp"
#include "plant/ev_state.hpp"
#include "plant/pm_drive.hpp"
#include "plant/prop_driver.hpp"
#include "plant/road_load.hpp"
#include "plant/signals.hpp"
#include "plant/vehicle_body.hpp"

namespace ehpt::plant {

template <class Drive>
struct EvMachineParams {
  VehicleBodyParams body;
  RoadLoadParams road;
  typename Drive::Params drive;
  BatteryRcParams battery;
  PropDriverParams driver;
  BrakeParams brake;
};

// What every machine EV records; the drive's own signals follow (EvMachinePlant::Outputs).
struct EvMachineCommonOutputs {
  double time_s = 0, speed_ref_m_s = 0, speed_m_s = 0, distance_m = 0, acceleration_m_s2 = 0;
  double driver_request_Nm = 0, drive_torque_ref_Nm = 0, drive_torque_Nm = 0, drive_speed_rad_s = 0;
  double drive_power_mech_W = 0, drive_power_dc_W = 0, drive_loss_W = 0;
  double brake_force_N = 0, road_force_N = 0, altitude_m = 0;
  double battery_voltage_V = 0, battery_current_A = 0, battery_power_W = 0, battery_emf_V = 0, soc = 0;
  double locked = 0, fault = 0;
  double battery_out_J = 0, road_work_J = 0, drive_loss_J = 0, battery_loss_J = 0, brake_work_J = 0;
};

inline constexpr std::array<Signal<EvMachineCommonOutputs>, 27> kEvMachineCommonSignals = {{
    {"time_s", &EvMachineCommonOutputs::time_s, "simulation time"},
    {"speed_ref_m_s", &EvMachineCommonOutputs::speed_ref_m_s, "cycle (wanted) speed"},
    {"speed_m_s", &EvMachineCommonOutputs::speed_m_s, "vehicle speed"},
    {"distance_m", &EvMachineCommonOutputs::distance_m, "travelled distance"},
    {"acceleration_m_s2", &EvMachineCommonOutputs::acceleration_m_s2, "vehicle acceleration"},
    {"driver_request_Nm", &EvMachineCommonOutputs::driver_request_Nm, "driver torque request at the drive shaft"},
    {"drive_torque_ref_Nm", &EvMachineCommonOutputs::drive_torque_ref_Nm, "torque the ECU asks of the drive"},
    {"drive_torque_Nm", &EvMachineCommonOutputs::drive_torque_Nm, "electromagnetic torque of the machine"},
    {"drive_speed_rad_s", &EvMachineCommonOutputs::drive_speed_rad_s, "rotor speed"},
    {"drive_power_mech_W", &EvMachineCommonOutputs::drive_power_mech_W, "mechanical power torque x speed"},
    {"drive_power_dc_W", &EvMachineCommonOutputs::drive_power_dc_W, "DC power drawn by the drive"},
    {"drive_loss_W", &EvMachineCommonOutputs::drive_loss_W, "machine copper + inverter losses"},
    {"brake_force_N", &EvMachineCommonOutputs::brake_force_N, "friction-brake force magnitude"},
    {"road_force_N", &EvMachineCommonOutputs::road_force_N, "road load (rolling + aero), or the locked reaction"},
    {"altitude_m", &EvMachineCommonOutputs::altitude_m, "altitude gained since start"},
    {"battery_voltage_V", &EvMachineCommonOutputs::battery_voltage_V, "terminal voltage"},
    {"battery_current_A", &EvMachineCommonOutputs::battery_current_A, "terminal current, > 0 discharging"},
    {"battery_power_W", &EvMachineCommonOutputs::battery_power_W, "terminal power v i"},
    {"battery_emf_V", &EvMachineCommonOutputs::battery_emf_V, "EMF E"},
    {"soc", &EvMachineCommonOutputs::soc, "state of charge"},
    {"locked", &EvMachineCommonOutputs::locked, "1 while the vehicle is stuck at standstill (dragForce.locked)"},
    {"fault", &EvMachineCommonOutputs::fault,
     "fault bits: 1 SOC window, 2 cell current, 4 power infeasible, 8 non-finite, 16 drive solve"},
    {"battery_out_J", &EvMachineCommonOutputs::battery_out_J, "integral of terminal power"},
    {"road_work_J", &EvMachineCommonOutputs::road_work_J, "integral of road-load power"},
    {"drive_loss_J", &EvMachineCommonOutputs::drive_loss_J, "integral of drive losses"},
    {"battery_loss_J", &EvMachineCommonOutputs::battery_loss_J, "integral of battery losses"},
    {"brake_work_J", &EvMachineCommonOutputs::brake_work_J, "integral of brake dissipation"},
}};

// The common signals followed by the drive's, as signals of the combined Outputs (a member
// pointer of a base converts to one of the derived class).
template <class Outputs, class A, class B, std::size_t NA, std::size_t NB>
constexpr std::array<Signal<Outputs>, NA + NB> join_signals(const std::array<Signal<A>, NA>& a,
                                                            const std::array<Signal<B>, NB>& b) {
  std::array<Signal<Outputs>, NA + NB> out{};
  for (std::size_t i = 0; i < NA; ++i) out[i] = {a[i].name, a[i].member, a[i].meaning};
  for (std::size_t i = 0; i < NB; ++i) out[NA + i] = {b[i].name, b[i].member, b[i].meaning};
  return out;
}

template <class Drive>
void validate(const EvMachineParams<Drive>& p, Problems& problems) {
  validate(p.body, "vehicle", problems);
  validate(p.road, "road", problems);
  validate(p.drive, "drive", problems);
  validate(p.battery, "battery", problems);
  validate(p.driver, "driver", problems);
  if (p.brake.after_rotor_inertia) {
    problems.add("brake.after_rotor_inertia", "true", "is MBEV's brake signal; a machine drive's brake uses the applied torque");
  }
  Drive::validate_with_battery(p.drive, p.battery, problems);
}

template <class Drive>
class EvMachinePlant : public EvStateLayout {
 public:
  // the state: EvStateLayout (ev_state.hpp), [v | VehicleBody | BatteryRc | energy integrals]
  // crossing 0: stick/slip (as the map EV); then the drive's own (PMDrive: MTPA <-> flux
  // weakening, located so that no RK4 step straddles the kink)
  static constexpr int kNumCrossings = 1 + Drive::kNumCrossings;
  using State = Eigen::Matrix<double, kNumStates, 1>;
  using Params = EvMachineParams<Drive>;
  struct Modes {
    Motion motion = Motion::kStuck;
    typename Drive::Mode drive{};
  };
  using Inputs = msgs::EvCommand;
  using Sensors = msgs::EvSensors;
  struct Outputs : EvMachineCommonOutputs, Drive::Outputs {};

  static constexpr auto kSignals = join_signals<Outputs>(kEvMachineCommonSignals, Drive::kSignals);
  static constexpr MetricSources<Outputs> kMetrics{.speed_ref_m_s = &Outputs::speed_ref_m_s,
                                                   .speed_m_s = &Outputs::speed_m_s,
                                                   .locked = &Outputs::locked,
                                                   .distance_m = &Outputs::distance_m,
                                                   .soc = &Outputs::soc};

  explicit EvMachinePlant(const Params& params)  // start-up: params already validated
      : p_(params), drive_(params.drive), battery_(params.battery), body_(params.body, params.road, params.brake) {
    g_over_r_ = p_.body.gear_ratio / p_.body.wheel_radius_m;
    mass_eff_kg_ = p_.body.mass_kg + drive_.inertia_kgm2() * g_over_r_ * g_over_r_;
    inv_mass_eff_kg_ = 1.0 / mass_eff_kg_;
  }

  State initial_state() const {
    State x = State::Zero();
    x[kSpeed] = p_.body.speed_initial_m_s;
    x[kEmf] = battery_.constants().emf_initial_V;
    return x;
  }
  // the drive's mode starts at its default; if the first command says otherwise, its
  // crossing is negative at the first step's start and fires there
  Modes initial_modes(const State& x0) const { return Modes{x0[kSpeed] > 0.0 ? Motion::kForward : Motion::kStuck, {}}; }

  // Run phase: pure functions, no allocation.
  void derivatives(double, const State& x, const Modes& m, const Inputs& u, State& dx) const {
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
    const AtRest r = at_rest(x, u);
    m.motion = motion_at_rest(r.applied_N, r.breakaway_N);
  }
  void outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y) const {
    outputs_from(evaluate(x, m, u), t_s, x, m, u, y);
  }
  void outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y, State& dx) const {
    const Eval e = evaluate(x, m, u);
    outputs_from(e, t_s, x, m, u, y);
    derivatives_from(e, x, dx);
  }
  void sense(double t_s, const State& x, const Modes& m, const Inputs& u, Sensors& s) const {
    const Eval e = evaluate(x, m, u);
    s.driverRequest_Nm = drive(p_.driver, t_s, x[kSpeed]).request;
    s.speed_m_s = x[kSpeed];
    s.driveW_rad_s = e.drive_speed_rad_s;
    s.driveTauLim_Nm = drive_.torque_limit_Nm(e.drive_speed_rad_s);
    s.drivePowDel_W = e.power_mech_W;
    s.batSOC = battery_.soc(x[kEmf]);
    s.batPowDel_W = e.battery.voltage_V * e.battery.current_A;
    s.battery_voltage_V = e.battery.voltage_V;
    s.battery_current_A = e.battery.current_A;
    s.fault = faults(e, x);
    s.locked = m.motion == Motion::kStuck;
  }

  // The runner's observation at a grid point it does not record (solvers/plant.hpp), from one
  // evaluation: the outputs kMetrics names and fault (the other fields of y are left as they
  // were), dx/dt and the crossing functions z, each bit for bit what outputs(), derivatives()
  // and crossings() give at the same point.
  void observe(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y, State& dx, double* z) const {
    const Eval e = evaluate(x, m, u);
    ev_metric_outputs(p_.driver.cycle_m_s(t_s), x, battery_, m.motion, y);
    y.fault = faults(e, x);
    derivatives_from(e, x, dx);
    crossings(t_s, x, m, u, z);
  }

  std::span<const Signal<Outputs>> signals() const { return kSignals; }

  // Energy audit between x0 and x (end of run; allocates).
  EnergyAudit audit(const State& x0, const State& x) const {
    return ev_energy_audit(battery_, mass_eff_kg_, p_.body.mass_kg, x0.data(), x.data());
  }

  const Params& params() const { return p_; }
  const BatteryRc& battery() const { return battery_; }
  const Drive& machine() const { return drive_; }

 private:
  struct Eval {
    typename Drive::Point drive;
    double torque_Nm, power_mech_W, power_dc_W;
    BatteryTerminal battery;
    double drive_speed_rad_s, grade_rad, rolling_N, speed_force_N, brake_N, applied_N, road_N, accel_m_s2;
  };
  struct AtRest {
    double applied_N, breakaway_N;
  };

  [[gnu::always_inline]] Eval evaluate(const State& x, const Modes& m, const Inputs& u) const {
    const double v = x[kSpeed];
    const double drive_speed_rad_s = v * g_over_r_;
    const double u_dc_V = x[kEmf] - x[kVrc];
    Eval e;
    e.drive = drive_.operate(u.driveTauRef_Nm, drive_speed_rad_s, u_dc_V);
    e.torque_Nm = Drive::torque_Nm(e.drive);
    e.power_mech_W = e.torque_Nm * drive_speed_rad_s;
    e.power_dc_W = Drive::power_dc_W(e.drive);
    const VehicleBody::Forces f = body_.forces(v, x[kDistance]);
    e.grade_rad = f.grade_rad;
    e.rolling_N = f.rolling_N;
    e.speed_force_N = f.speed_force_N;
    e.brake_N = body_.brake_N(e.torque_Nm - u.driveTauRef_Nm);
    e.applied_N = e.torque_Nm * g_over_r_ - f.grade_force_N;
    e.road_N = e.applied_N;
    e.accel_m_s2 = 0.0;
    if (m.motion != Motion::kStuck) {
      const double d = m.motion == Motion::kForward ? 1.0 : -1.0;
      e.road_N = d * e.rolling_N + e.speed_force_N;
      e.accel_m_s2 = (e.applied_N - e.road_N - d * e.brake_N) * inv_mass_eff_kg_;
    }
    e.battery = battery_.terminal(x[kEmf], x[kVrc], e.power_dc_W);
    e.drive_speed_rad_s = drive_speed_rad_s;
    return e;
  }

  // At rest (v = 0): the force the road must hold and the break-away threshold.
  AtRest at_rest(const State& x, const Inputs& u) const {
    const auto op = drive_.operate(u.driveTauRef_Nm, 0.0, x[kEmf] - x[kVrc]);
    const double torque_Nm = Drive::torque_Nm(op);
    const double grade_rad = body_.road().grade_rad(x[kDistance]);
    return {torque_Nm * g_over_r_ - body_.road().grade_force_N(grade_rad),
            body_.road().rolling_N(grade_rad) + body_.brake_N(torque_Nm - u.driveTauRef_Nm)};
  }

  unsigned faults(const Eval& e, const State& x) const {
    return battery_.faults(x[kEmf], e.battery) | Drive::faults(e.drive) | (all_finite(x) ? 0u : kFaultNonFinite);
  }

  [[gnu::always_inline]] void derivatives_from(const Eval& e, const State& x, State& dx) const {
    dx[kSpeed] = e.accel_m_s2;
    body_.derivatives(x[kSpeed], {e.grade_rad, e.rolling_N, e.speed_force_N, 0.0}, e.brake_N, dx.data() + kBodyAt);
    dx[kEmf] = battery_.demf_dt(e.battery);
    dx[kVrc] = battery_.dvrc_dt(e.battery, x[kVrc]);
    dx[kBatteryOutJ] = e.battery.voltage_V * e.battery.current_A;
    dx[kDriveLossJ] = e.power_dc_W - e.power_mech_W;
    dx[kBatteryLossJ] = e.battery.loss_W;
  }

  void outputs_from(const Eval& e, double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y) const {
    const DriverOutput driver = drive(p_.driver, t_s, x[kSpeed]);
    y.time_s = t_s;
    y.speed_ref_m_s = driver.speed_ref_m_s;
    y.speed_m_s = x[kSpeed];
    y.distance_m = x[kDistance];
    y.acceleration_m_s2 = e.accel_m_s2;
    y.driver_request_Nm = driver.request;
    y.drive_torque_ref_Nm = u.driveTauRef_Nm;
    y.drive_torque_Nm = e.torque_Nm;
    y.drive_speed_rad_s = e.drive_speed_rad_s;
    y.drive_power_mech_W = e.power_mech_W;
    y.drive_power_dc_W = e.power_dc_W;
    y.drive_loss_W = e.power_dc_W - e.power_mech_W;
    y.brake_force_N = e.brake_N;
    y.road_force_N = e.road_N;
    y.altitude_m = x[kAltitude];
    y.battery_voltage_V = e.battery.voltage_V;
    y.battery_current_A = e.battery.current_A;
    y.battery_power_W = e.battery.voltage_V * e.battery.current_A;
    y.battery_emf_V = x[kEmf];
    y.soc = battery_.soc(x[kEmf]);
    y.locked = m.motion == Motion::kStuck ? 1.0 : 0.0;
    y.fault = faults(e, x);
    y.battery_out_J = x[kBatteryOutJ];
    y.road_work_J = x[kRoadJ];
    y.drive_loss_J = x[kDriveLossJ];
    y.battery_loss_J = x[kBatteryLossJ];
    y.brake_work_J = x[kBrakeJ];
    Drive::fill(e.drive, y);
  }

  Params p_;
  Drive drive_;
  BatteryRc battery_;
  VehicleBody body_;
  double g_over_r_ = 0.0;     // rotor speed per vehicle speed (rad/m)
  double mass_eff_kg_ = 0.0;  // vehicle + rotor reflected
  double inv_mass_eff_kg_ = 0.0;
};

// PMDrive as the EV's drive (pm_drive.hpp).
class PmMachine {
 public:
  using Params = PmDriveParams;
  using Point = PmOperatingPoint;
  struct Outputs {
    double id_A = 0, iq_A = 0, vd_V = 0, vq_V = 0, voltage_peak_V = 0, current_rms_A = 0;
    double weakening = 0, voltage_limited = 0, current_limited = 0, overload = 0;
  };
  static constexpr std::array<Signal<Outputs>, 10> kSignals = {{
      {"id_A", &Outputs::id_A, "d-axis current, peak (< 0: flux weakening or MTPA of an anisotropic rotor)"},
      {"iq_A", &Outputs::iq_A, "q-axis current, peak"},
      {"vd_V", &Outputs::vd_V, "d-axis voltage, peak phase"},
      {"vq_V", &Outputs::vq_V, "q-axis voltage, peak phase"},
      {"voltage_peak_V", &Outputs::voltage_peak_V, "space-phasor voltage |V|, peak phase"},
      {"current_rms_A", &Outputs::current_rms_A, "phase current, rms"},
      {"weakening", &Outputs::weakening, "1 in flux weakening (|V| held at the set voltage)"},
      {"voltage_limited", &Outputs::voltage_limited, "1 when the request is beyond reach at this speed"},
      {"current_limited", &Outputs::current_limited, "1 when the current limit cuts the torque"},
      {"overload", &Outputs::overload, "1 when holding the voltage alone needs more than the current limit"},
  }};

  explicit PmMachine(const Params& p)
      : p_(p),
        torque_max_Nm_(pm_torque_at_current_limit_Nm(p)),
        mtpa_at_limit_{pm_mtpa(p, torque_max_Nm_), pm_mtpa(p, -torque_max_Nm_)} {}
  // The operating point; MTPA for T* is solved once per command (see mtpa_of).
  Point operate(double torque_ref_Nm, double speed_rad_s, double u_dc_V) const {
    return pm_operating_point(p_, torque_ref_Nm, speed_rad_s, u_dc_V, mtpa_of(torque_ref_Nm));
  }

  // MTPA <-> flux weakening as a located event (the "switch as an event"; the
  // operating point itself is continuous there, MODELS.md §12, and picks its branch at every
  // evaluation, so the event only keeps RK4 steps off the kink and marks the time). The
  // switch is where the MTPA currents of the torque the drive gives reach the voltage: T*,
  // or MTPA at the current limit when T* needs more current.
  static constexpr int kNumCrossings = 1;
  struct Mode {
    bool weakening = false;
  };
  void crossings(const Mode& m, double torque_ref_Nm, double speed_rad_s, double u_dc_V, double* z) const {
    const PmCurrents& c = std::abs(torque_ref_Nm) > torque_max_Nm_ ? mtpa_at_limit_[torque_ref_Nm > 0.0 ? 0 : 1]
                                                                   : mtpa_of(torque_ref_Nm);
    const double excess_V2 = pm_voltage_excess_V2(p_, c, speed_rad_s, u_dc_V);
    z[0] = m.weakening ? excess_V2 : -excess_V2;
  }
  void on_crossing(int, Mode& m) const { m.weakening = !m.weakening; }

  double inertia_kgm2() const { return p_.inertia_kgm2; }
  // For the ECU (driveTauLim): the MTPA torque at the current limit; flux weakening lowers
  // what is reachable above base speed, which this bound does not follow.
  double torque_limit_Nm(double) const { return torque_max_Nm_; }
  static double torque_Nm(const Point& op) { return op.torque_Nm; }
  static double power_dc_W(const Point& op) { return op.p_dc_W; }
  static unsigned faults(const Point& op) { return op.converged ? 0u : kFaultDriveSolve; }
  static void fill(const Point& op, Outputs& y) {
    y.id_A = op.id_A;
    y.iq_A = op.iq_A;
    y.vd_V = op.vd_V;
    y.vq_V = op.vq_V;
    y.voltage_peak_V = std::sqrt(op.vd_V * op.vd_V + op.vq_V * op.vq_V);
    y.current_rms_A = std::sqrt(0.5 * (op.id_A * op.id_A + op.iq_A * op.iq_A));
    y.weakening = op.weakening ? 1.0 : 0.0;
    y.voltage_limited = op.voltage_limited ? 1.0 : 0.0;
    y.current_limited = op.current_limited ? 1.0 : 0.0;
    y.overload = op.overload ? 1.0 : 0.0;
  }
  // The machine's set voltage must be within what the pack gives at its lowest EMF.
  static void validate_with_battery(const Params& p, const BatteryRcParams& b, Problems& problems);

 private:
  // MTPA of T*, remembered for the last T* (the command is held over an ECU period, so all
  // RK4 stages and crossings of the period share one Newton solve). pm_mtpa is a pure
  // function of T*, so the memo returns exactly what a fresh solve would: a run does not
  // depend on the order of calls. Not for two threads at once (a plant belongs to one run).
  const PmCurrents& mtpa_of(double torque_ref_Nm) const {
    if (!(torque_ref_Nm == memo_torque_Nm_)) {  // NaN never matches: solved (and flagged) each time
      memo_ = pm_mtpa(p_, torque_ref_Nm);
      memo_torque_Nm_ = torque_ref_Nm;
    }
    return memo_;
  }

  Params p_;
  double torque_max_Nm_;
  PmCurrents mtpa_at_limit_[2];  // MTPA at the current limit, motoring and braking
  mutable PmCurrents memo_;
  mutable double memo_torque_Nm_ = std::numeric_limits<double>::quiet_NaN();
};

// AMDrive as the EV's drive (am_drive.hpp): TorqueToDW, slip limiter, current limit, QSAsma.
class AmMachine {
 public:
  using Params = AmDriveParams;
  using Point = AmOperatingPoint;
  struct Outputs {
    double slip_rad_s = 0, stator_frequency_rad_s = 0, emf_rms_V = 0, u1_rms_V = 0, i1_rms_A = 0, i2_rms_A = 0;
    double torque_at_max = 0, current_limited = 0, weakening = 0;
  };
  static constexpr std::array<Signal<Outputs>, 9> kSignals = {{
      {"slip_rad_s", &Outputs::slip_rad_s, "slip frequency dWe = w_e - pp w_m (electrical)"},
      {"stator_frequency_rad_s", &Outputs::stator_frequency_rad_s, "stator electrical angular frequency w_e"},
      {"emf_rms_V", &Outputs::emf_rms_V, "E behind R1 (U/f rule), rms phase"},
      {"u1_rms_V", &Outputs::u1_rms_V, "terminal voltage |U1|, rms phase"},
      {"i1_rms_A", &Outputs::i1_rms_A, "stator current |I1|, rms"},
      {"i2_rms_A", &Outputs::i2_rms_A, "rotor current |I2| (referred), rms"},
      {"torque_at_max", &Outputs::torque_at_max, "1 when the request is at or beyond the reachable torque"},
      {"current_limited", &Outputs::current_limited, "1 when the current limit reduces the slip"},
      {"weakening", &Outputs::weakening, "1 above base frequency (E held at U_base)"},
  }};

  explicit AmMachine(const Params& p) : p_(p) {}
  static constexpr int kNumCrossings = 0;  // continuous (§12): no event
  struct Mode {};
  // the U/f drive sets E from the frequency; the DC voltage only bounds it (validate)
  Point operate(double torque_ref_Nm, double speed_rad_s, double) const {
    return am_operating_point(p_, torque_ref_Nm, speed_rad_s);
  }
  double inertia_kgm2() const { return p_.inertia_kgm2; }
  double torque_limit_Nm(double speed_rad_s) const { return am_torque_limit_Nm(p_, speed_rad_s); }
  static double torque_Nm(const Point& op) { return op.torque_Nm; }
  static double power_dc_W(const Point& op) { return op.power_dc_W; }
  static unsigned faults(const Point&) { return 0u; }  // closed forms and bounded bracketed solves
  static void fill(const Point& op, Outputs& y) {
    y.slip_rad_s = op.slip_rad_s;
    y.stator_frequency_rad_s = op.w_e_rad_s;
    y.emf_rms_V = op.emf_rms_V;
    y.u1_rms_V = op.u1_rms_V;
    y.i1_rms_A = op.i1_rms_A;
    y.i2_rms_A = op.i2_rms_A;
    y.torque_at_max = op.torque_at_max ? 1.0 : 0.0;
    y.current_limited = op.current_limited ? 1.0 : 0.0;
    y.weakening = op.weakening ? 1.0 : 0.0;
  }
  // The U/f base voltage must be within what the pack gives at its lowest EMF.
  static void validate_with_battery(const Params& p, const BatteryRcParams& b, Problems& problems);

 private:
  Params p_;
};

using EvPmPlant = EvMachinePlant<PmMachine>;
using EvPmParams = EvMachineParams<PmMachine>;
using EvAmPlant = EvMachinePlant<AmMachine>;
using EvAmParams = EvMachineParams<AmMachine>;
extern template class EvMachinePlant<PmMachine>;
extern template class EvMachinePlant<AmMachine>;

}  // namespace ehpt::plant
