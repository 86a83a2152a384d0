// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// What plugs into the runner's one step loop (hil/run/runner.hpp) from outside: an ECU port
// (where the commands come from and the samples go) and a step pacer (when a step may start).
// The bus plant (CAN or LCM, lockstep or wall clock), a replayed session and the real-time
// loop's bus are ports; the wall clock is a pacer. None of them writes a loop of its own.
//
// Per grid point n the loop does, before the step from t_n:
//   (a) port.commands_due(n): the commands that act from step n on (frames received, a
//       recorded session's records);
//   (b) at an ECU sample step (every ecu_ratio steps from 0), after (a): port.sample(n,
//       sensors) with the sensors at t_n; the port sends them and may answer with the
//       command of this sample (lockstep waits for it, bounded);
//   (c) port.before_step(n): its last word before the step (a timeout's safe state);
//   then the step, then pacer.wait_for_step(n + 1).
// Each hook returns true when it wrote the command (what it does not set stays as it was).
// The outputs at a sample step are taken after (a)-(c); at the other steps before (a), right
// after the step that reached them: a command that arrives between samples acts on the
// integration from t_n, the row at t_n is the plant as it got there. The final grid point
// runs (a)-(c) when it is a sample step (its sample goes out, its command is logged).
// Run phase: the hooks neither allocate nor throw; a port's only I/O is its bounded,
// non-blocking socket calls (and lockstep's bounded wait for the command).

#include <cstdint>

namespace ehpt::hil {

template <class Sensors, class Command>
class EcuPort {
 public:
  virtual bool commands_due(std::int64_t n, Command& command) = 0;
  virtual bool sample(std::int64_t n, const Sensors& sensors, Command& command) = 0;
  virtual bool before_step(std::int64_t /*n*/, Command& /*command*/) { return false; }

 protected:
  ~EcuPort() = default;  // not owned through this interface
};

// When step n may start: called with n = 0 when it is attached, and after every step.
class StepPacer {
 public:
  virtual void wait_for_step(std::int64_t n) = 0;

 protected:
  ~StepPacer() = default;
};

}  // namespace ehpt::hil
