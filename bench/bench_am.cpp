// SPDX-License-Identifier: BSD-3-Clause
// AMDrive's operating point (plant/am_drive.hpp): the algebraic solve each step will pay.
#include <benchmark/benchmark.h>

#include "plant/am_drive.hpp"

namespace {

using namespace ehpt::plant;

// range(0): rotor speed in rad/s; range(1): torque request in N m. 50 / 60: below base, the
// closed form alone; 250 / 40: above base, regula falsi on the flux; 50 / 400: current limit
// (250 A); 250 / 1000: beyond reach above base (the torque peak's bisection, then the current).
void BM_AmOperatingPoint(benchmark::State& state) {
  const AmDriveParams p;
  const double w = static_cast<double>(state.range(0));
  const double t0 = static_cast<double>(state.range(1));
  double t = t0;
  for (auto _ : state) {
    const AmOperatingPoint op = am_operating_point(p, t, w);
    t = t > 1.2 * t0 ? t0 : t + 0.001 * t0;  // a slowly moving request, as in a drive cycle
    benchmark::DoNotOptimize(op);
  }
}
BENCHMARK(BM_AmOperatingPoint)->Args({50, 60})->Args({250, 40})->Args({50, 400})->Args({250, 1000});

// The ECU's torque limit sensor: both directions, each to its current limit.
void BM_AmTorqueLimit(benchmark::State& state) {
  const AmDriveParams p;
  double w = static_cast<double>(state.range(0));
  for (auto _ : state) {
    benchmark::DoNotOptimize(am_torque_limit_Nm(p, w));
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_AmTorqueLimit)->Arg(50)->Arg(250);

}  // namespace
