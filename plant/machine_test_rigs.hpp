// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// TestPMDrive and TestAMDrive: the quasi-static drives of MODELS.md §9 next to the
// time-domain machines of plant/detailed_machines.hpp, fed as P15 §2 describes, on one
// imposed speed and one torque request (vehicle kinds "pm_drive_test", "am_drive_test").
// Each rig evaluates the quasi-static operating point and integrates the detailed machine fed
// from it, so one run gives both sides of the paper's comparison; the product's implicit
// Euler integrates it at a step that resolves the electrical period (5-10 us). The drive's
// solve depends on t only, but derivatives() is a pure function of (t, x): it is solved again
// in each of the ~9 evaluations of an implicit-Euler step (6 or 8 for the Jacobian, 2-3 Newton).
//
// What the step does to the steady state (the tests' tolerances come from here): for sources
// turning at w_e, implicit Euler's periodic solution is the continuous circuit with each d/dt
// replaced by (1 - exp(-j w_e h)) / h = j w_e + w_e^2 h / 2 + O(h^2): a numerical resistance
// w_e^2 h L / 2 in series with each inductance L (4 mOhm for Lq at 317 rad/s, h = 5 us). It
// dissipates w_e^2 h W_mag per second that the energy states count as electrical input, so
// each audit below is open by the integral of w_e^2 h W_mag, first order in h (0.3 % for
// TestPMDrive at 5 us: above the runner's 0.1 % warning; 0.06 % for TestAMDrive).
//
// PM (SmaAllSpeeds-like, §11.6): w_m(t) and T*(t) are trapezoids (speed imposed, no
// mechanics). The quasi-static drive gives (Id, Iq, Vd, Vq) = pm_operating_point(T*, w_m,
// u_dc) (§9.1: MTPA, flux weakening, current limit). The detailed PMSM is current-fed
// (the MSL harness): i_ref,ab = R(th_e) [Id, Iq] through the 20 us filters, th_e integrated
// from w_e = pp w_m. Outputs: the drive's Id, Iq, |V| (peak) and V rms = |V| / sqrt 2,
// torque, flags; the detailed v_a, i_a, |v_ab| (the space-phasor voltage: the peak phase
// voltage), rotor-frame currents and torque; and the "full flux" voltage: the |V| the machine
// would need at the delivered torque with MTPA currents only (no flux weakening), which
// exceeds U_lim above base speed and is why flux weakening is needed.
// States: 0-1 filtered i_alpha, i_beta (A), 2 th_e (rad), 3 electrical energy in (J),
// 4 mechanical work out (J), 5 copper losses (J).
// Audit: E_el = W_mech + E_cu + (W_mag(end) - W_mag(start)), W_mag = 0.75 (Ld Id^2 + Lq Iq^2).
//
// AM (StartASMA / AsmaTqFollowing-like, §11.6, with the speed imposed): w_m(t) and T*(t)
// trapezoids. The quasi-stationary drive gives (w_e, U1) = am_operating_point(T*, w_m)
// (§9.2: TorqueToDW, U/f with E capped at U_base above base frequency, QSAsma). The detailed
// squirrel-cage machine is voltage-fed as P15 describes (U/f sine voltages):
//   v_alpha = sqrt 2 U1 cos th_s,  v_beta = sqrt 2 U1 sin th_s,  d th_s/dt = w_e
// from zero flux at t = 0 (the start-up transient is part of the picture: with the rotor
// turning at 100-200 rad/s the slowest electrical mode decays in 22 ms, well inside the rotor
// time constant Lr / R2 = 0.24 s; at standstill it would take 0.55 s). Outputs: the drive's U1, I1
// (rms), torque, slip, w_e, flags; the detailed v_a, i_a, |v_ab|, |i_s,ab| (peak) and torque.
// States: 0-1 psi_s (Wb), 2-3 psi_r (Wb), 4 th_s (rad), 5 electrical energy in (J),
// 6 mechanical work out (J), 7 copper losses (J).
// Audit: E_el = W_mech + E_cu + (W_mag(end) - W_mag(start)), W_mag = 0.75 (psi_s.i_s + psi_r.i_r).

#include <array>
#include <span>
#include <string>

#include <Eigen/Core>

#include "plant/am_drive.hpp"
#include "plant/detailed_machines.hpp"
#include "plant/drive_rigs.hpp"
#include "plant/pm_drive.hpp"
#include "plant/signals.hpp"

namespace ehpt::plant {

struct PmDriveTestParams {
  PmDriveParams machine;
  double u_dc_V = 300.0;             // ideal DC source (SmaAllSpeeds)
  double current_filter_s = 20e-6;   // the harness's current filters (§11.6)
  Trapezoid speed_rad_s;             // imposed rotor speed
  Trapezoid request_Nm;              // torque request T*
};

void validate(const PmDriveTestParams& p, Problems& problems);

class PmDriveTest {
 public:
  static constexpr int kIalpha = 0, kIbeta = 1, kTheta = 2, kElectricalJ = 3, kMechanicalJ = 4, kCopperJ = 5;
  static constexpr int kNumStates = 6;
  static constexpr int kNumCrossings = 0;
  using State = Eigen::Matrix<double, kNumStates, 1>;
  struct Modes {};
  struct Inputs {};
  struct Outputs {
    double time_s = 0, speed_rad_s = 0, torque_ref_Nm = 0;
    double qs_id_A = 0, qs_iq_A = 0, qs_v_peak_V = 0, qs_v_rms_V = 0, qs_i_rms_A = 0, qs_torque_Nm = 0;
    double weakening = 0, current_limited = 0, voltage_limited = 0, v_lim_peak_V = 0, full_flux_v_peak_V = 0;
    double det_v_a_V = 0, det_i_a_A = 0, det_v_peak_V = 0, det_id_A = 0, det_iq_A = 0, det_torque_Nm = 0;
    double det_power_W = 0, det_magnetic_energy_J = 0, fault = 0;
  };
  static const std::array<Signal<Outputs>, 24> kSignals;
  static constexpr MetricSources<Outputs> kMetrics{};  // no vehicle

  explicit PmDriveTest(const PmDriveTestParams& params);  // start-up: params validated
  std::span<const Signal<Outputs>> signals() const { return kSignals; }

  State initial_state() const { return State::Zero(); }
  Modes initial_modes(const State&) const { return {}; }

  // Run phase: pure functions, no allocation.
  void derivatives(double t_s, const State& x, const Modes& m, const Inputs& u, State& dx) const;
  void crossings(double, const State&, const Modes&, const Inputs&, double*) const {}
  void on_crossing(int, double, State&, Modes&, const Inputs&) const {}
  void outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y) const;

  // Energy audit between x0 and x (end of run; allocates).
  EnergyAudit audit(const State& x0, const State& x) const;

  const PmsmParams& pmsm() const { return pmsm_; }

 private:
  struct Eval {
    double speed_rad_s, torque_ref_Nm;
    PmOperatingPoint op;
    PmsmResponse machine;
  };
  Eval evaluate(double t_s, const State& x) const;

  PmDriveTestParams p_;
  PmsmParams pmsm_;
  PmDriveParams full_flux_;  // the machine without voltage or current limit: MTPA only
};

struct AmDriveTestParams {
  AmDriveParams machine;
  Trapezoid speed_rad_s;  // imposed rotor speed
  Trapezoid request_Nm;   // torque request T*
};

void validate(const AmDriveTestParams& p, Problems& problems);

class AmDriveTest {
 public:
  static constexpr int kPsiS = 0, kPsiR = 2, kTheta = 4, kElectricalJ = 5, kMechanicalJ = 6, kCopperJ = 7;
  static constexpr int kNumStates = 8;
  static constexpr int kNumCrossings = 0;
  using State = Eigen::Matrix<double, kNumStates, 1>;
  struct Modes {};
  struct Inputs {};
  struct Outputs {
    double time_s = 0, speed_rad_s = 0, torque_ref_Nm = 0;
    double qs_w_e_rad_s = 0, qs_slip_rad_s = 0, qs_u1_rms_V = 0, qs_i1_rms_A = 0, qs_torque_Nm = 0;
    double weakening = 0, current_limited = 0, torque_at_max = 0;
    double det_v_a_V = 0, det_i_a_A = 0, det_v_peak_V = 0, det_i_peak_A = 0, det_torque_Nm = 0;
    double det_power_W = 0, det_magnetic_energy_J = 0, fault = 0;
  };
  static const std::array<Signal<Outputs>, 19> kSignals;
  static constexpr MetricSources<Outputs> kMetrics{};  // no vehicle

  explicit AmDriveTest(const AmDriveTestParams& params);  // start-up: params validated
  std::span<const Signal<Outputs>> signals() const { return kSignals; }

  State initial_state() const { return State::Zero(); }
  Modes initial_modes(const State&) const { return {}; }

  // Run phase: pure functions, no allocation.
  void derivatives(double t_s, const State& x, const Modes& m, const Inputs& u, State& dx) const;
  void crossings(double, const State&, const Modes&, const Inputs&, double*) const {}
  void on_crossing(int, double, State&, Modes&, const Inputs&) const {}
  void outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y) const;

  // Energy audit between x0 and x (end of run; allocates).
  EnergyAudit audit(const State& x0, const State& x) const;

  const InductionMachineParams& induction_machine() const { return im_; }

 private:
  struct Eval {
    double speed_rad_s, torque_ref_Nm;
    AmOperatingPoint op;
    Vec2 v_V;
    InductionMachineResponse machine;
  };
  Eval evaluate(double t_s, const State& x) const;

  AmDriveTestParams p_;
  InductionMachineParams im_;
};

}  // namespace ehpt::plant
