// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// `ehpt bench`: the timing and determinism benchmark suite in one command (targets/bench/).
// In one run on one machine it measures (a) ns per step of each vehicle x solver at 1 ms,
// (b) the real-time factor of each vehicle on its cycle, (c) the real-time loop's wake-up
// latency next to cyclictest's (same period, priority and CPU), (d) heap allocations after
// start-up of every kind of run, (e) the trajectory hash across pacers and (f) RK4 against
// the CVODE reference; prints a table and writes bench.json. Figures are reported, never
// asserted (the targets of the issue are printed next to them).

#include <string>
#include <vector>

namespace ehpt::cli {

// The usage text of `ehpt bench --help`.
extern const char* const kBenchHelp;

// `ehpt bench [options]` (args without the command word). Exit codes: 0 every section ran
// (what cannot run on this machine says why), 1 usage or output error (nothing run, or
// bench.json not written), 3 a run failed or trajectories that must be equal differ,
// 128 + N stopped by signal N (130 Ctrl-C; bench.json holds what was done).
int cmd_bench(const std::vector<std::string>& args);

}  // namespace ehpt::cli
