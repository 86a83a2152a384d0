// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// A variable-step reference for the fixed-step runs: the same plant equations, the same
// built-in ECU and the same events, integrated by SUNDIALS CVODE (BDF, dense Newton, rtol
// 1e-8 by default) with its root finding for the plant's crossings. It answers "how far is
// RK4 at 1 ms from the converged trajectory, and how much faster is it" (final SOC, fuel,
// distance; wall time). Start-up and off-line only: it allocates, and it is not a runner (no
// recorder, no pacer, no bus). Its own library (ehpt_reference) so that the core does not
// depend on SUNDIALS.
//
// The discrete-time semantics are the runner's (hil/run/runner.hpp), reproduced exactly:
//   - the ECU samples at t_n = n h for n a multiple of solver.ecu_ratio: plant.sense(t_n, ...)
//     with the state, modes and inputs there, then update(sensors, command) with the command
//     starting as a copy of the inputs; the command applies latency_steps later (0: at once)
//     and holds until the next one applies. CVODE lands exactly on every such time (stop
//     time) and restarts there (CVodeReInit: the inputs jump);
//   - a crossing z_i > 0 while its mode holds fires when it falls to <= 0: CVODE's root finding
//     locates it (direction: decreasing), then plant.on_crossing (mode, reset) and a restart;
//     a z that is < 0 at a segment start (after an input jump or a mode switch), or is 0
//     there and then falls, fires at once, at that time, as in solvers/event_stepper.hpp;
//   - at most EventStepper::kMaxEventsPerStep events per grid step [n h, (n+1) h); more are
//     counted as chattering and the rest of that grid step runs in the last mode;
//   - figures from plant.outputs() through Plant::kMetrics at t = 0 (after the first ECU
//     sample) and at the end, as SimulationOf::figures(): fuel is end - start.
// Measured (tests/hil/cvode_reference_test.cpp): at rtol 1e-8 the reference's own final-SOC
// error is ~2e-6 (the tolerance is relative to the pack EMF, hundreds of V, while SOC lives in
// its last volt); at rtol 1e-12 it meets RK4 at 1 ms within 1e-9 in SOC. Its cost is set by
// the restart at every ECU sample (one difference-quotient Jacobian each, then ~3 BDF steps
// per 10 ms period).

#include <cstdint>
#include <string>

#include "hil/config/config.hpp"
#include "hil/run/simulation.hpp"

namespace ehpt::hil {

struct ReferenceOptions {
  double rtol = 1e-8;
  // atol of state i = rtol * atol_scale * (state i's scale, cvode_reference.cpp): the error is
  // controlled relative to max(|x_i|, scale), the magnitude below which a state's value does
  // not matter. 1 unless a study varies it.
  double atol_scale = 1.0;
  long max_steps_per_segment = 100000;  // CVODE steps between two restarts before it gives up
  int max_order = 5;                    // BDF order (CVODE's default, 5)
};

struct ReferenceResult {
  RunFigures figures;  // as Simulation::figures(): nullopt where the vehicle has none
  double end_time_s = 0.0;  // = solver.steps * step_s unless a fault stopped the run
  double wall_s = 0.0;      // CVODE set-up, integration and clean-up (steady_clock); not the loading
  // CVODE's work, summed over every restart
  std::int64_t cvode_steps = 0;
  std::int64_t rhs_evaluations = 0;     // plant.derivatives calls (the difference-quotient Jacobians included)
  std::int64_t jacobian_evaluations = 0;
  std::int64_t error_test_failures = 0;
  std::int64_t nonlinear_failures = 0;  // Newton convergence failures
  std::int64_t restarts = 0;            // CVodeReInit: ECU samples, applied commands and events
  // events, comparable with RunStats::events: roots + immediate_events
  std::int64_t events = 0;
  std::int64_t roots = 0;               // crossings located by CVODE's root finding
  std::int64_t immediate_events = 0;    // fired at a segment start (z < 0 there, or 0 and falling)
  std::int64_t late_events = 0;         // z found < 0 where CVODE reported no root (fired late; expect 0)
  std::int64_t chattering_steps = 0;    // grid steps that reached the event cap
  // first fault (plant::Fault bits) in the outputs, checked at t = 0 and at every ECU sample (or
  // applied command); it stops the run, as the runner's default policy does
  unsigned fault = 0;
  double fault_time_s = 0.0;
};

// Runs the scenario's vehicle with its built-in ECU under CVODE. Supports the vehicles with a
// built-in ECU: bev, psd, ev_pm, ev_am. False with a one-line reason in why for another kind
// (the rigs) or when CVODE fails (its message).
bool run_cvode_reference(const Scenario& sc, const ReferenceOptions& opt, ReferenceResult& out, std::string& why);

}  // namespace ehpt::hil
