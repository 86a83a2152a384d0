// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Test rigs for the map-based drives, MODELS.md §11.1 and §11.3.
// Paper: P15 §3, "TestMBOneFlange", Figs. 11-13.
//
// One flange (TestMBOneFlange): drive rotor J_d + load inertia J_l on one shaft,
//   (J_d + J_l) dw/dt = tau + tau_q(w),   tau_q = tau_nom (w / w_nom)^2   (tau_nom < 0: a load)
// Two flanges (TestTwoFlange): the drive's through-shaft carries, on flange B, the load
//   inertia and the quadratic load, and on flange A a constant torque tau_A:
//   (J_d + J_l) dw/dt = tau + tau_q(w) + tau_A
// tau = limiter(tau_ref(t), w) with tau_ref a trapezoid; the drive draws P_dc from an ideal
// DC source (§11.1: 100 V).
// Bus view (§0.5): genPowDel = (tau - J_d dw/dt) w is the power at the flange after the
// rotor inertia; for two flanges motPowDelA = -tau_A w and motPowDelB = (tau - J_d dw/dt) w - motPowDelA.
// State: 0 w (rad/s), 1 DC energy (J), 2 drive losses (J), 3 load work (J, > 0 when absorbed).

#include <array>
#include <span>

#include <Eigen/Core>

#include "plant/map_drive.hpp"
#include "plant/signals.hpp"

namespace ehpt::plant {

// Trapezoid source (§0.4): offset before start_s, linear rise in rising_s to offset + amplitude,
// hold width_s, linear fall in falling_s, back to offset; repeats every period_s.
struct Trapezoid {
  double offset = 0.0, amplitude = 0.0;
  double start_s = 0.0, rising_s = 0.0, width_s = 0.0, falling_s = 0.0, period_s = 1e6;
};
double trapezoid(const Trapezoid& tr, double t_s);
void validate(const Trapezoid& tr, const std::string& at, Problems& problems);

struct DriveRigParams {
  MapDriveParams drive;
  bool two_flange = false;
  double load_inertia_kgm2 = 0.5;
  double speed_initial_rad_s = 50.0;
  double load_torque_nominal_Nm = -50.0;   // quadratic load tau_nom (negative = load)
  double load_speed_nominal_rad_s = 400.0;
  double flange_a_torque_Nm = 0.0;         // two flanges only: constant torque on flange A
  Trapezoid request_Nm;
  double dc_voltage_V = 100.0;             // ideal source; reported only
};

void validate(const DriveRigParams& p, Problems& problems);

class DriveRig {
 public:
  static constexpr int kSpeed = 0, kDcJ = 1, kDriveLossJ = 2, kLoadJ = 3;
  static constexpr int kNumStates = 4;
  static constexpr int kNumCrossings = 0;
  using State = Eigen::Matrix<double, kNumStates, 1>;
  struct Modes {};
  struct Inputs {};
  struct Outputs {
    double time_s = 0, tau_ref_Nm = 0, tau_Nm = 0, tau_lim_Nm = 0, limit_state = 0, limiting = 0;
    double speed_rad_s = 0, pow_del_W = 0, pow_del_a_W = 0, pow_del_b_W = 0, power_mech_W = 0;
    double power_dc_W = 0, dc_current_A = 0, efficiency = 0, load_torque_Nm = 0, fault = 0;
  };

  static constexpr MetricSources<Outputs> kMetrics{};  // no vehicle: no speed, no engine

  explicit DriveRig(const DriveRigParams& params)
      : p_(params), drive_(params.drive), inv_inertia_(1.0 / total_inertia_kgm2()) {}
  std::span<const Signal<Outputs>> signals() const;

  State initial_state() const;
  Modes initial_modes(const State&) const { return {}; }

  // Run phase: pure functions.
  void derivatives(double t_s, const State& x, const Modes& m, const Inputs& u, State& dx) const;
  void crossings(double, const State&, const Modes&, const Inputs&, double*) const {}
  void on_crossing(int, double, State&, Modes&, const Inputs&) const {}
  void outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y) const;

  // Energy audit between x0 and x (end of run; allocates).
  EnergyAudit audit(const State& x0, const State& x) const;

 private:
  struct Eval {
    DriveOperatingPoint op;
    double tau_ref_Nm, load_Nm, accel_rad_s2;
  };
  Eval evaluate(double t_s, const State& x) const;
  double total_inertia_kgm2() const { return p_.drive.inertia_kgm2 + p_.load_inertia_kgm2; }

  DriveRigParams p_;
  MapDrive drive_;
  double inv_inertia_ = 0.0;  // 1 / (J_drive + J_load)
};

}  // namespace ehpt::plant
