// SPDX-License-Identifier: BSD-3-Clause
// PMDrive's operating point (plant/pm_drive.hpp): the algebraic solve each step will pay.
#include <benchmark/benchmark.h>

#include "plant/pm_drive.hpp"

namespace {

using namespace ehpt::plant;

// range(0): rotor speed in rad/s (20: MTPA, 160: flux weakening); warm-started like a run
void BM_PmOperatingPoint(benchmark::State& state) {
  PmDriveParams p;
  p.Ld_H = 2e-3;
  p.Lq_H = 4e-3;
  const double w = static_cast<double>(state.range(0));
  double t = 60.0, warm = 0.0;
  for (auto _ : state) {
    const PmOperatingPoint op = pm_operating_point(p, t, w, 300.0, warm);
    warm = op.iq_A;
    t = t > 80.0 ? 60.0 : t + 0.01;  // a slowly moving request, as in a drive cycle
    benchmark::DoNotOptimize(op);
  }
}
BENCHMARK(BM_PmOperatingPoint)->Arg(20)->Arg(160);

}  // namespace
