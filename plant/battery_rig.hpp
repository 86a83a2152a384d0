// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Battery test rig: the Batt1 pack of MODELS.md §6 (BatteryRc) on a profile of constant-current
// and constant-power segments, vehicle kind "battery_rig"; it lets a constant-current discharge
// be compared with its closed form. Sign convention: terminal current i and power P > 0
// discharge, < 0 charge. The active segment is the mode: segment k runs from the end of
// segment k-1 to t_k (cumulative end times), and a crossing z = t_k - t ends it, so the event
// stepper switches exactly at t_k (on a step boundary or inside a step) and no step mixes two
// segments. At t_k itself the new segment applies (right-continuous, like the cycle tables).
// After the last segment the pack rests (i = 0). Current segment: i = I,
// v_term = E - v_rc - R0 i; power segment: the constant-power node of §6.5,
// v_term = (v_int + sqrt(v_int^2 - 4 R0 P)) / 2, i = P / v_term. With i_m = i + k|i|:
//   C_batt dE/dt = -i_m,  C1 dv_rc/dt = i_m - v_rc / R1,
//   d(out)/dt = v_term i,  d(loss)/dt = R0 i^2 + v_rc^2/R1 + (E - v_rc) k|i|,  d(q)/dt = i.
// Closed form at constant current I from rest: E = E0 - i_m t / C_batt,
// v_rc = R1 i_m (1 - exp(-t / (R1 C1))). Audit: decrease of the stored energy
// 0.5 C_batt E^2 + 0.5 C1 v_rc^2 = terminal energy out + losses.
// State: 0 E (V), 1 v_rc (V), 2 terminal energy out (J), 3 battery losses (J), 4 charge out
// at the terminals (As). Mode: the segment index (kRest after the profile).

#include <array>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "plant/battery_rc.hpp"
#include "plant/problems.hpp"
#include "plant/signals.hpp"

namespace ehpt::plant {

struct BatterySegment {
  enum class Kind { kCurrent, kPower } kind = Kind::kCurrent;
  double value = 0.0;       // terminal current (A) or terminal power (W); > 0 discharge, < 0 charge
  double duration_s = 0.0;  // > 0
};

struct BatteryRigParams {
  BatteryRcParams battery;
  std::vector<BatterySegment> profile;  // run in order from t = 0; then rest at 0 A
};

void validate(const BatteryRigParams& p, Problems& problems);

class BatteryRig {
 public:
  static constexpr int kEmf = 0, kVrc = 1, kBatteryOutJ = 2, kBatteryLossJ = 3, kChargeOutAs = 4;
  static constexpr int kNumStates = 5;
  static constexpr int kNumCrossings = 1;
  using State = Eigen::Matrix<double, kNumStates, 1>;
  static constexpr int kRest = -1;
  struct Modes {
    int segment = kRest;  // index into the profile; kRest after it
  };
  struct Inputs {};
  struct Outputs {
    double time_s = 0, profile_segment = 0, current_ref_A = 0, power_ref_W = 0;
    double battery_voltage_V = 0, battery_current_A = 0, battery_power_W = 0, battery_emf_V = 0;
    double battery_vrc_V = 0, soc = 0, battery_out_J = 0, battery_loss_J = 0, charge_out_As = 0;
    double fault = 0;
  };
  static const std::array<Signal<Outputs>, 14> kSignals;
  static constexpr MetricSources<Outputs> kMetrics{.soc = &Outputs::soc};  // no vehicle: no speed, no engine

  explicit BatteryRig(const BatteryRigParams& params);  // start-up: params already validated
  std::span<const Signal<Outputs>> signals() const { return kSignals; }

  State initial_state() const;
  Modes initial_modes(const State&) const { return {p_.profile.empty() ? kRest : 0}; }

  // Run phase: pure functions, no allocation.
  void derivatives(double t_s, const State& x, const Modes& m, const Inputs& u, State& dx) const;
  // z = t_k - t while segment k runs (falls through zero at its end); 1 at rest.
  void crossings(double t_s, const State& x, const Modes& m, const Inputs& u, double* z) const;
  void on_crossing(int index, double t_s, State& x, Modes& m, const Inputs& u) const;
  void outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y) const;
  double profile_end_s() const { return ends_s_.empty() ? 0.0 : ends_s_.back(); }

  // Energy audit between x0 and x (end of run; allocates).
  EnergyAudit audit(const State& x0, const State& x) const;

  const BatteryRigParams& params() const { return p_; }
  const BatteryRc& battery() const { return battery_; }

 private:
  struct Eval {
    int segment;
    double current_ref_A, power_ref_W;
    BatteryTerminal battery;
  };
  Eval evaluate(const State& x, const Modes& m) const;

  BatteryRigParams p_;
  BatteryRc battery_;
  std::vector<double> ends_s_;  // cumulative end time of each segment, sized at start-up
};

}  // namespace ehpt::plant
