// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Named output signals of a plant. Each plant lists its Outputs fields with their column
// name (unit suffix included), so the runner can write any chosen subset without knowing
// the plant, and a bus codec can later map the same names.

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace ehpt::plant {

template <class Outputs>
struct Signal {
  std::string_view name;      // column header, SI unit as suffix: "speed_m_s"
  double Outputs::*member;
  std::string_view meaning;   // one line for the README and `ehpt run --help`
};

// The outputs a vehicle's run metrics are computed from (hil/run/metrics.hpp), declared by each
// plant (static constexpr kMetrics), never inferred from the names of its output fields. A
// null member: the vehicle has no such quantity (a rig has no speed, an EV no engine).
template <class Outputs>
struct MetricSources {
  double Outputs::*speed_ref_m_s = nullptr;  // the cycle's speed: speed error against it
  double Outputs::*speed_m_s = nullptr;
  double Outputs::*locked = nullptr;         // 1 while held at standstill: locked time
  double Outputs::*engine_on = nullptr;      // 1 while the engine runs: on-time, starts
  double Outputs::*distance_m = nullptr;     // travelled: Wh/km, L/100 km
  double Outputs::*soc = nullptr;            // battery state of charge: start and end
  double Outputs::*fuel_g = nullptr;         // fuel used so far
};

// Run-time faults (§6.4 asserts and numerical health). Plants report them in Outputs.
enum Fault : unsigned {
  kFaultNone = 0,
  kFaultSocWindow = 1u << 0,        // SOC left [soc_min, soc_max]
  kFaultCellCurrent = 1u << 1,      // |i| / np >= cell_current_max_A
  kFaultPowerInfeasible = 1u << 2,  // constant-power load beyond the pack's maximum power
  kFaultNonFinite = 1u << 3,        // NaN or Inf in the state
  kFaultDriveSolve = 1u << 4,       // a machine drive's algebraic solve did not converge (§9.1)
};

// Whether every value of a state vector (an Eigen vector) is finite, the kFaultNonFinite test
// at every grid point: x - x is 0 for a finite x and NaN for an infinite or NaN one, and a NaN
// makes the sum NaN. The same answer as Eigen's allFinite(), in Eigen's vectorised sum: a
// fraction of the instructions.
template <class Vector>
[[gnu::always_inline]] inline bool all_finite(const Vector& x) {
  const double s = (x - x).sum();
  return s == s;
}

// Energy audit over a run, built once at the end (may allocate). The plant states the
// balance; `sources_J` is what entered the system (battery stores, DC source, fuel) and
// `residual_J` = sources - (all sinks and stored changes). Terms are listed for summary.json.
struct EnergyAudit {
  double sources_J = 0.0;
  double residual_J = 0.0;
  // what the residual is relative to: the energy that actually flowed through the balance
  // (a term that appears on both sides, like fuel energy in a hybrid, is left out)
  double scale_J = 0.0;
  double battery_out_J = 0.0;   // net out of the battery terminals (0 without a battery)
  double battery_loss_J = 0.0;  // battery losses; out + losses = what left the EMF (SOC drop)
  std::vector<std::pair<std::string, double>> terms;
};

}  // namespace ehpt::plant
