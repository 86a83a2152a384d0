// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Power-split hybrid (PSecu1/2/3 of the library, the paper's "PSecu2" example), MODELS.md
// §4 and §10.4. Paper: P15 §5.2, Figs. 21-23.
//
// Wiring (§4.2): ICE -- carrier; gen (one-flange drive) -- sun; ring -- mot (two-flange
// drive) flange A; mot flange B -- final gear G -- wheels (r) -- vehicle mass m -- DragForce.
// gen and mot share the battery's DC bus. The ECU (ecu/, or an external one on a bus) talks to
// the plant only through messages: the plant's Inputs are msgs::PsdCommand, sense() fills
// msgs::PsdSensors.
//
// Planetary gear (§4.1), rho = z_ring / z_sun, massless and lossless (Willis):
//   (1 + rho) w_c = w_s + rho w_r,    tau_r = rho tau_s,   tau_c = -(1 + rho) tau_s
// Two degrees of freedom, generalised speeds w_c (engine) and w_r (ring = mot), v = w_r r/G
// (§4.3, from the kinetic energy and virtual power):
//   M = | J_i + J_g (1+rho)^2      -J_g rho (1+rho)           |
//       | -J_g rho (1+rho)         J_m + J_g rho^2 + m (r/G)^2 |
//   Q = | tau_ice + (1+rho) tau_g                              |
//       | tau_m - rho tau_g - (r/G) (F_road + F_grade + F_brake) |
//   M [dw_c/dt, dw_r/dt]' = Q       (M is constant: its inverse is computed once)
// Vehicle stuck (DragForce locked, §7.2): w_r = 0, one degree of freedom,
//   (J_i + J_g (1+rho)^2) dw_c/dt = tau_ice + (1+rho) tau_g, and the road must hold
//   F_applied = (G/r)(tau_m - rho tau_g + J_g rho (1+rho) dw_c/dt) - F_grade.
// Engine (§3.4-3.6): power loop solved exactly with dw_c/dt = a0 + a1 tau_ice (or a torque
// request for a torque-input engine); OFF (ON/OFF engine and bus.iceON false) gives no
// torque and no fuel.
// Friction brake: the braking mot could not deliver, F = (G/r) max(0, tau_m - motTauRef).
//
// State (one flat vector, offsets composed from the components' sizes): w_c and w_r (rad/s);
// the VehicleBody's s (m), h (m), road-load work and brake dissipation (J); the battery's E
// and v_rc (V); fuel (kg); the plant's energy integrals (J): engine work, battery terminal
// energy out, gen losses, mot losses, battery losses.
// Energy audit: fuel chemical energy + battery stored-energy decrease = road work + engine
// losses (fuel energy - engine work) + gen, mot and battery losses + brake
// + change of kinetic energy (1/2 w' M w: vehicle and every rotating part) + m g dh.
// Crossing 0 as for the EV (plant/ev_plant.hpp), on w_r.

#include <array>
#include <span>

#include <Eigen/Core>

#include "plant/battery_rc.hpp"
#include "plant/map_drive.hpp"
#include "plant/map_ice.hpp"
#include "plant/prop_driver.hpp"
#include "msgs/psd.hpp"
#include "plant/observation.hpp"
#include "plant/road_load.hpp"
#include "plant/vehicle_body.hpp"
#include "plant/signals.hpp"

namespace ehpt::plant {

struct PsdParams {
  VehicleBodyParams body;      // gear_ratio = final gear G (mot speed / wheel speed)
  RoadLoadParams road;
  BrakeParams brake;
  PropDriverParams driver;     // request in per unit (k = 1 / (m/s), yMax = 1.8)
  BatteryRcParams battery;
  MapIceParams ice;            // input kPower (IceConnP) or kTorque; on_off: IceConnPOO
  MapDriveParams gen;          // one-flange drive on the sun
  MapDriveParams mot;          // two-flange drive on the ring
  double ring_sun_ratio = 78.0 / 30.0;
};

void validate(const PsdParams& p, Problems& problems);

class PsdPlant {
 public:
  // the state, composed: [w_c w_r | VehicleBody | BatteryRc | fuel | energy integrals]
  static constexpr int kIceSpeed = 0, kRingSpeed = 1;
  static constexpr int kBodyAt = 2;
  static constexpr int kBatteryAt = kBodyAt + VehicleBody::kNumStates;
  static constexpr int kFuelKg = kBatteryAt + BatteryRc::kNumStates;
  static constexpr int kIntegralsAt = kFuelKg + 1;
  static constexpr int kNumStates = kIntegralsAt + 5;
  static constexpr int kDistance = kBodyAt + VehicleBody::kDistance, kAltitude = kBodyAt + VehicleBody::kAltitude;
  static constexpr int kRoadJ = kBodyAt + VehicleBody::kRoadJ, kBrakeJ = kBodyAt + VehicleBody::kBrakeJ;
  static constexpr int kEmf = kBatteryAt + BatteryRc::kEmf, kVrc = kBatteryAt + BatteryRc::kVrc;
  static constexpr int kIceWorkJ = kIntegralsAt, kBatteryOutJ = kIntegralsAt + 1, kGenLossJ = kIntegralsAt + 2,
                       kMotLossJ = kIntegralsAt + 3, kBatteryLossJ = kIntegralsAt + 4;
  // States no derivative reads (fuel, the audit's integrals, the altitude): implicit Euler
  // skips their Jacobian columns (solvers/integrators.hpp)
  static constexpr std::array<int, 9> kAuditOnlyStates = {kAltitude,  kRoadJ,       kBrakeJ,   kFuelKg,      kIceWorkJ,
                                                          kBatteryOutJ, kGenLossJ, kMotLossJ, kBatteryLossJ};
  static constexpr int kNumCrossings = 1;
  using State = Eigen::Matrix<double, kNumStates, 1>;
  struct Modes {
    Motion motion = Motion::kStuck;
  };
  using Params = PsdParams;
  using Inputs = msgs::PsdCommand;  // held over each ECU period
  using Sensors = msgs::PsdSensors;

  struct Outputs {
    double time_s = 0, speed_ref_m_s = 0, speed_m_s = 0, distance_m = 0, driverRequest = 0;
    double iceW_rad_s = 0, ice_torque_Nm = 0, icePowDel_W = 0, icePowRef_W = 0, iceON = 0;
    double fuel_rate_g_s = 0, fuel_g = 0, sfc_g_kWh = 0;
    double genW_rad_s = 0, genTauRef_Nm = 0, gen_torque_Nm = 0, genTauLim_Nm = 0, genPowDel_W = 0,
           gen_power_dc_W = 0;
    double motW_rad_s = 0, motTauRef_Nm = 0, mot_torque_Nm = 0, motTauLim_Nm = 0, motPowDelA_W = 0,
           motPowDelB_W = 0, mot_power_dc_W = 0;
    double brake_force_N = 0, road_force_N = 0, grade_rad = 0;
    double battery_voltage_V = 0, battery_current_A = 0, battery_power_W = 0, soc = 0;
    double locked = 0, fault = 0;
  };
  static const std::array<Signal<Outputs>, 35> kSignals;
  static constexpr MetricSources<Outputs> kMetrics{.speed_ref_m_s = &Outputs::speed_ref_m_s,
                                                   .speed_m_s = &Outputs::speed_m_s,
                                                   .locked = &Outputs::locked,
                                                   .engine_on = &Outputs::iceON,
                                                   .distance_m = &Outputs::distance_m,
                                                   .soc = &Outputs::soc,
                                                   .fuel_g = &Outputs::fuel_g};
  std::span<const Signal<Outputs>> signals() const { return kSignals; }

  explicit PsdPlant(const PsdParams& params);  // start-up: params already validated

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
  // and crossings() give at the same point (one outputs_from for both, observation.hpp). The
  // runner hands dx and z to the next step (its first stage, and the crossings at its start:
  // two evaluations while stuck, one saved). With kSet = kAll every field of y, bit for bit
  // outputs(): what a test's expectations read at every step, with dx/dt and z as above.
  template <OutputSet kSet = OutputSet::kObserved>
  void observe(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y, State& dx, double* z) const;

  EnergyAudit audit(const State& x0, const State& x) const;
  // Plant faults, between steps only (the run's fault injector; this plant is that run's own):
  // the pack's constants and the machines' derating, in kMachines order.
  static constexpr std::array<const char*, 2> kMachines = {"gen", "mot"};
  void set_health(const PlantHealth& h, const State& x) {
    battery_.set_health(h.battery, x[kEmf], x[kVrc]);
    torque_gain_ = h.torque_gain;
  }
  const PsdParams& params() const { return p_; }
  // Willis: sun (gen) speed from carrier and ring speeds.
  double sun_speed_rad_s(const State& x) const {
    return (1.0 + rho_) * x[kIceSpeed] - rho_ * x[kRingSpeed];
  }

  struct Eval;
  // One evaluation (tests check the planetary balances on it); the plant's own functions use
  // eval(), the same code always inlined, so that each computes only what it uses (the stuck
  // crossing needs neither the driver, nor the fuel map, nor the battery).
  Eval evaluate(double t_s, const State& x, const Modes& m, const Inputs& u) const;

 private:
  Eval eval(double t_s, const State& x, const Modes& m, const Inputs& u) const;
  double kinetic_energy_J(const State& x) const;
  void sense_from(const Eval& e, const State& x, const Modes& m, Sensors& s) const;
  void derivatives_from(const Eval& e, const State& x, State& dx) const;
  template <OutputSet kSet>
  void outputs_from(const Eval& e, double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y) const;
  unsigned faults(const Eval& e, const State& x) const;
  // crossing 0 while stuck: the break-away threshold minus the force the road holds
  static double stuck_crossing(const Eval& e);

  PsdParams p_;
  MapIce ice_;
  MapDrive gen_, mot_;
  BatteryRc battery_;
  std::array<double, kMaxMachines> torque_gain_ = {1.0, 1.0};  // derating (plant faults): 1 healthy
  VehicleBody body_;
  double rho_ = 0.0;
  double g_over_r_ = 0.0, r_over_g_ = 0.0;
  double m11_ = 0, m12_ = 0, m22_ = 0;             // mass matrix (symmetric)
  double i11_ = 0, i12_ = 0, i22_ = 0;             // its inverse
  // products of parameters the evaluation used to form at every call (the same values)
  double one_plus_rho_ = 0.0, i11_one_plus_rho_ = 0.0;  // 1 + rho, i11 (1 + rho)
};

// Everything one evaluation computes (public so tests can check the planetary balances).
struct PsdPlant::Eval {
  DriverOutput driver;
  DriveOperatingPoint gen, mot;
  BatteryTerminal battery;
  double sun_speed_rad_s;
  double ice_torque_Nm, fuel_rate_kg_s;
  double ice_accel_rad_s2, ring_accel_rad_s2;
  double speed_m_s;
  double grade_rad, rolling_N, speed_force_N, grade_force_N, brake_N;
  double applied_N;  // stuck: force the road must hold (sa); moving: unused
  double road_N;     // reaction of the road: road load when moving, sa when stuck
};

// Run phase: no allocation. Always inlined: each caller computes only what it uses. In the
// header, with derivatives(), so that an integrator inlines every stage (solvers/integrators.hpp).
[[gnu::always_inline]] inline PsdPlant::Eval PsdPlant::eval(double t_s, const State& x, const Modes& m,
                                                            const Inputs& u) const {
  Eval e;
  const double w_c = x[kIceSpeed], w_r = x[kRingSpeed];
  e.speed_m_s = w_r * r_over_g_;
  e.sun_speed_rad_s = one_plus_rho_ * w_c - rho_ * w_r;
  e.driver = drive(p_.driver, t_s, e.speed_m_s);
  // electric machines follow the bus within their limits
  e.gen = gen_.operate(u.genTauRef_Nm, e.sun_speed_rad_s);
  e.mot = mot_.operate(u.motTauRef_Nm, w_r);
  if (torque_gain_[0] != 1.0 || torque_gain_[1] != 1.0) [[unlikely]] {  // derating (plant faults)
    e.gen = gen_.derated(e.gen, u.genTauRef_Nm, e.sun_speed_rad_s, torque_gain_[0]);
    e.mot = mot_.derated(e.mot, u.motTauRef_Nm, w_r, torque_gain_[1]);
  }
  const double tau_g = e.gen.torque_Nm, tau_m = e.mot.torque_Nm;
  // road, grade and the friction brake that supplies what mot could not brake
  const VehicleBody::Forces f = body_.forces(e.speed_m_s, x[kDistance]);
  e.grade_rad = f.grade_rad;
  e.rolling_N = f.rolling_N;
  e.speed_force_N = f.speed_force_N;
  e.grade_force_N = f.grade_force_N;
  e.brake_N = body_.brake_N(tau_m - u.motTauRef_Nm);
  // engine torque from the power loop, with dw_c/dt = a0 + a1 tau_ice
  double a0 = 0.0, a1 = 0.0, q2 = 0.0;
  if (m.motion == Motion::kStuck) {
    a1 = 1.0 / m11_;
    a0 = one_plus_rho_ * tau_g * a1;
  } else {
    const double resist_N =
        VehicleBody::resisting_N(m.motion, f, e.brake_N);
    q2 = tau_m - rho_ * tau_g - r_over_g_ * resist_N;
    a1 = i11_;
    a0 = i11_one_plus_rho_ * tau_g + i12_ * q2;
    e.road_N = m.motion == Motion::kForward ? e.rolling_N + e.speed_force_N : -e.rolling_N + e.speed_force_N;
  }
  e.ice_torque_Nm = ice_.torque_Nm(u.iceON, u.icePowRef_W, u.iceTauRef_Nm, w_c, a0, a1);
  e.fuel_rate_kg_s = ice_.fuel_rate_kg_s(u.iceON, e.ice_torque_Nm, w_c);
  e.ice_accel_rad_s2 = a0 + a1 * e.ice_torque_Nm;
  if (m.motion == Motion::kStuck) {
    // the ring is held: the road reacts with what the shafts push
    e.ring_accel_rad_s2 = 0.0;
    e.applied_N = g_over_r_ * (tau_m - rho_ * tau_g - m12_ * e.ice_accel_rad_s2) - e.grade_force_N;
    e.road_N = e.applied_N;
  } else {
    const double q1 = e.ice_torque_Nm + one_plus_rho_ * tau_g;
    e.ring_accel_rad_s2 = i12_ * q1 + i22_ * q2;
    e.applied_N = 0.0;
  }
  // gen and mot share the DC bus
  e.battery = battery_.terminal(x[kEmf], x[kVrc], e.gen.power_dc_W + e.mot.power_dc_W);
  return e;
}

// Inlined into derivatives() (the RK4 stages) and outputs(): one evaluation, no copy of it.
[[gnu::always_inline]] inline void PsdPlant::derivatives_from(const Eval& e, const State& x, State& dx) const {
  dx[kIceSpeed] = e.ice_accel_rad_s2;
  dx[kRingSpeed] = e.ring_accel_rad_s2;
  body_.derivatives(e.speed_m_s, {e.grade_rad, e.rolling_N, e.speed_force_N, e.grade_force_N}, e.brake_N,
                    dx.data() + kBodyAt);
  dx[kEmf] = battery_.demf_dt(e.battery);
  dx[kVrc] = battery_.dvrc_dt(e.battery, x[kVrc]);
  dx[kFuelKg] = e.fuel_rate_kg_s;
  dx[kIceWorkJ] = e.ice_torque_Nm * x[kIceSpeed];
  dx[kBatteryOutJ] = e.battery.voltage_V * e.battery.current_A;
  dx[kGenLossJ] = e.gen.power_dc_W - e.gen.power_mech_W;
  dx[kMotLossJ] = e.mot.power_dc_W - e.mot.power_mech_W;
  dx[kBatteryLossJ] = e.battery.loss_W;
}

[[gnu::always_inline]] inline void PsdPlant::derivatives(double t_s, const State& x, const Modes& m, const Inputs& u, State& dx) const {
  derivatives_from(eval(t_s, x, m, u), x, dx);
}

}  // namespace ehpt::plant
