// SPDX-License-Identifier: BSD-3-Clause
// The time-domain references (plant/machine_test_rigs.hpp) against the quasi-static drives
// they check: what resolving the electrical period costs, per step and per simulated second.
// cpu_s_per_sim_s: CPU seconds per simulated second (the rig at its scenario's step, 5 us;
// the quasi-static operating point as a vehicle pays it: 4 calls per RK4 step at 1 ms).
#include <benchmark/benchmark.h>

#include "plant/machine_test_rigs.hpp"
#include "solvers/integrators.hpp"

namespace {

using namespace ehpt;
using plant::Trapezoid;

constexpr double kStep_s = 5e-6;            // test_pm_drive.toml, test_am_drive.toml
constexpr double kQsCallsPerSimSecond = 4000.0;  // RK4 at 1 ms: 4 derivative calls per step

Trapezoid constant(double level) { return Trapezoid{level, 0.0, 0.0, 1.0, 0.0, 1.0, 1e6}; }

// seconds per iteration / per_iteration_s: with kIsIterationInvariantRate | kInvert the counter
// is elapsed / (iterations * value)
benchmark::Counter per_simulated_second(double sim_s_per_iteration) {
  return benchmark::Counter(sim_s_per_iteration, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

plant::PmDriveTestParams pm_rig(double speed_rad_s, double torque_Nm) {
  plant::PmDriveTestParams p;
  p.machine.Ld_H = 2e-3;
  p.machine.Lq_H = 4e-3;
  p.speed_rad_s = constant(speed_rad_s);
  p.request_Nm = constant(torque_Nm);
  return p;
}

plant::AmDriveTestParams am_rig(double speed_rad_s, double torque_Nm) {
  plant::AmDriveTestParams p;
  p.speed_rad_s = constant(speed_rad_s);
  p.request_Nm = constant(torque_Nm);
  return p;
}

// One implicit-Euler step of a rig (the drive's solve in each of its ~9 derivative calls).
template <class Rig, class Params>
void step_rig(benchmark::State& state, const Params& params) {
  const Rig rig(params);
  solvers::ImplicitEuler<Rig> ie(rig);
  typename Rig::State x = rig.initial_state();
  std::int64_t n = 0;
  for (auto _ : state) {
    ie.step(static_cast<double>(n) * kStep_s, kStep_s, {}, {}, x);
    ++n;
    benchmark::DoNotOptimize(x);
  }
  state.counters["cpu_s_per_sim_s"] = per_simulated_second(kStep_s);
}

// args: rotor speed (rad/s), torque request (N m): MTPA, weakening, current limit with T* out
// of reach, no load at top speed
void BM_DetailedPmStep(benchmark::State& state) {
  step_rig<plant::PmDriveTest>(state, pm_rig(static_cast<double>(state.range(0)), static_cast<double>(state.range(1))));
}
BENCHMARK(BM_DetailedPmStep)->Args({80, 150})->Args({160, 60})->Args({240, 150})->Args({317, 0});

// below and above base frequency
void BM_DetailedAmStep(benchmark::State& state) {
  step_rig<plant::AmDriveTest>(state, am_rig(static_cast<double>(state.range(0)), static_cast<double>(state.range(1))));
}
BENCHMARK(BM_DetailedAmStep)->Args({100, 50})->Args({100, 200})->Args({200, 50})->Args({200, 200});

// The machine equations alone (no drive solve), per call.
void BM_DetailedPmsmEquations(benchmark::State& state) {
  const plant::PmsmParams p{2, 0.5055, 2e-3, 4e-3, 0.03, 20e-6};
  double th = 0.0;
  for (auto _ : state) {
    th += 1e-3;
    const plant::PmsmResponse r = plant::pmsm_current_fed(p, th, 400.0, plant::Vec2(30.0, 80.0), plant::Vec2(31.0, 79.0));
    benchmark::DoNotOptimize(r);
  }
}
BENCHMARK(BM_DetailedPmsmEquations);

void BM_DetailedInductionEquations(benchmark::State& state) {
  const plant::InductionMachineParams p;
  double v = 0.0;
  for (auto _ : state) {
    v += 1e-3;
    const plant::InductionMachineResponse r = plant::induction_voltage_fed(
        p, 400.0, plant::Vec2(0.3, -0.1), plant::Vec2(0.28, -0.15), plant::Vec2(100.0 + v, 50.0));
    benchmark::DoNotOptimize(r);
  }
}
BENCHMARK(BM_DetailedInductionEquations);

// The quasi-static operating points at the same points, priced per simulated second as a vehicle
// pays them (the rig's own QS part is inside BM_Detailed*Step).
void BM_QsPmOperatingPoint(benchmark::State& state) {
  const plant::PmDriveParams p = pm_rig(0, 0).machine;
  const double w = static_cast<double>(state.range(0)), t = static_cast<double>(state.range(1));
  double tiny = 0.0;
  for (auto _ : state) {
    tiny += 1e-12;
    const plant::PmOperatingPoint op = plant::pm_operating_point(p, t + tiny, w, 300.0);
    benchmark::DoNotOptimize(op);
  }
  state.counters["cpu_s_per_sim_s"] = per_simulated_second(1.0 / kQsCallsPerSimSecond);
}
BENCHMARK(BM_QsPmOperatingPoint)->Args({80, 150})->Args({160, 60})->Args({240, 150})->Args({317, 0});

void BM_QsAmOperatingPoint(benchmark::State& state) {
  const plant::AmDriveParams p;
  const double w = static_cast<double>(state.range(0)), t = static_cast<double>(state.range(1));
  double tiny = 0.0;
  for (auto _ : state) {
    tiny += 1e-12;
    const plant::AmOperatingPoint op = plant::am_operating_point(p, t + tiny, w);
    benchmark::DoNotOptimize(op);
  }
  state.counters["cpu_s_per_sim_s"] = per_simulated_second(1.0 / kQsCallsPerSimSecond);
}
BENCHMARK(BM_QsAmOperatingPoint)->Args({100, 50})->Args({100, 200})->Args({200, 50})->Args({200, 200});

}  // namespace
