// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Genset test rig, MODELS.md §11.5 (EHPTlib TestGenset2, TestGensetOO): the genset of
// plant/genset.hpp on an ideal DC source (100 V), its power request a trapezoid; the OO variant
// is switched off at off_at_s. Vehicle kind "genset_rig".
//   (J_ice + J_gen / r^2) dw/dt = tau_ice + tau_gen / r
// DC power delivered to the source: P_out = -P_dc of the generator (> 0 when generating).
// Audit: engine work = change of the shaft's kinetic energy + DC energy delivered + generator
// losses, with the losses P_dc - P_mech (>= 0: the map takes them from the DC side).
// State: 0 w (rad/s, the engine's), 1 fuel (kg), 2 engine work (J), 3 DC energy delivered (J),
// 4 generator losses (J).

#include <array>
#include <limits>
#include <span>

#include <Eigen/Core>

#include "plant/drive_rigs.hpp"  // Trapezoid
#include "plant/genset.hpp"
#include "plant/signals.hpp"

namespace ehpt::plant {

struct GensetRigParams {
  GensetParams genset;
  Trapezoid request_W;  // the power request (W)
  double off_at_s = std::numeric_limits<double>::infinity();  // GensetOO: ON until then
  double dc_voltage_V = 100.0;                                 // ideal source; reported only
};

void validate(const GensetRigParams& p, Problems& problems);

class GensetRig {
 public:
  static constexpr int kSpeed = 0, kFuelKg = 1, kIceJ = 2, kDcOutJ = 3, kGenLossJ = 4;
  static constexpr int kNumStates = 5;
  static constexpr int kNumCrossings = 0;
  using State = Eigen::Matrix<double, kNumStates, 1>;
  struct Modes {};
  struct Inputs {};
  struct Outputs {
    double time_s = 0, power_ref_W = 0, on = 0, speed_rad_s = 0, speed_ref_rad_s = 0, throttle = 0;
    double ice_torque_Nm = 0, ice_torque_max_Nm = 0, ice_power_W = 0, gen_speed_rad_s = 0, gen_torque_request_Nm = 0;
    double gen_torque_Nm = 0, gen_torque_limit_Nm = 0, gen_limit_state = 0, gen_limiting = 0, gen_power_mech_W = 0;
    double dc_power_W = 0, dc_current_A = 0, gen_efficiency = 0, fuel_rate_g_s = 0, fuel_g = 0, fault = 0;
  };
  static const std::array<Signal<Outputs>, 22> kSignals;
  static constexpr MetricSources<Outputs> kMetrics{.engine_on = &Outputs::on, .fuel_g = &Outputs::fuel_g};

  explicit GensetRig(const GensetRigParams& params) : p_(params), genset_(params.genset) {}
  std::span<const Signal<Outputs>> signals() const { return kSignals; }

  State initial_state() const;
  Modes initial_modes(const State&) const { return {}; }

  // Run phase: pure functions, no allocation.
  void derivatives(double t_s, const State& x, const Modes& m, const Inputs& u, State& dx) const;
  void crossings(double, const State&, const Modes&, const Inputs&, double*) const {}
  void on_crossing(int, double, State&, Modes&, const Inputs&) const {}
  void outputs(double t_s, const State& x, const Modes& m, const Inputs& u, Outputs& y) const;

  // Energy audit between x0 and x (end of run; allocates).
  EnergyAudit audit(const State& x0, const State& x) const;

  const GensetRigParams& params() const { return p_; }

 private:
  struct Eval {
    double power_ref_W;
    bool on;
    GensetPoint g;
  };
  Eval evaluate(double t_s, const State& x) const;

  GensetRigParams p_;
  Genset genset_;
};

}  // namespace ehpt::plant
