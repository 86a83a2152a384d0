// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The sections of `ehpt bench`, one file each; each fills its part of the Bench.

#include "targets/bench/state.hpp"

namespace ehpt::bench {

// (a) ns per step of each vehicle x solver at 1 ms in this process, (b) the real-time factor
// (targets/bench/section_speed.cpp).
void section_speed(Bench& b);
// (f) RK4 at 1 ms against the CVODE reference (targets/bench/section_cvode.cpp).
void section_cvode(Bench& b);
// (c) wake-up latency of 'ehpt run --realtime' next to cyclictest's (targets/bench/section_latency.cpp).
void section_latency(Bench& b);
// (g) planning a sweep of 10^5 runs (--quick: 10^4) with 'ehpt sweep --plan'
// (targets/bench/section_plan.cpp).
void section_plan(Bench& b);
// (d), (e) the sub-runs: heap allocations after start-up and the trajectory hash across
// pacers and transports (targets/bench/section_runs.cpp).
void section_runs(Bench& b);

// Reads DIR/name/summary.json written by this bench (not an earlier one); takes a sub-run's
// figures from it (section_runs.cpp; the real-time run of section (c) too).
bool read_summary(const std::string& dir, std::time_t since, Json& j, std::string& why);
void take_summary(Bench& b, SubRun& r, const Json& j);

// One whole run of sc in this process, timed (section_speed.cpp; section (f) too).
bool timed_run(const ehpt::hil::Scenario& sc, double& wall_s, ehpt::hil::RunFigures* figures, std::string& why);

}  // namespace ehpt::bench
