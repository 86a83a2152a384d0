// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Fixed-grid stepping with zero-crossing events (STYLE.md §6, MODELS.md §12).
//
// Crossing convention: each of the plant's kNumCrossings functions z_i(t, x, mode) is > 0
// while the current mode is valid; the event fires when z_i falls to <= 0 inside a step,
// i.e. on (t0, t1] (z0 > 0 and z1 <= 0). A z that starts a segment below zero, or at
// exactly zero and then goes negative (e.g. v = 0 right after a mode switch, then
// decreasing), fires at once, at the segment start: the mode is invalid from there on.
// A z that starts at zero and grows (a bounce) does not fire. A plant negates z for a
// "rising" condition.
// The plant provides, besides derivatives():
//   void crossings(double t_s, const State&, const Modes&, const Inputs&, double* z) const;
//   void on_crossing(int i, double t_s, State& x, Modes& m, const Inputs&) const;  // mode switch + reset
//
// One step from t_n = t0 + n h to t_{n+1}:
//   1. integrate the whole (remaining) step; evaluate z at its end;
//   2. if some z fell, locate the earliest crossing by bracketing in time (Illinois with a
//      bisection every third iteration, so the bracket at least halves every three
//      iterations), re-integrating from the segment start; stop when the bracket is
//      <= tolerance (1e-7 h, below the 1e-6 h asked for);
//   3. integrate to the crossed end of the bracket, call on_crossing (mode and reset), and
//      go back to 1 for the rest of the step.
// The grid stays t0 + n h whatever happens inside. At most kMaxEventsPerStep events are
// handled in one step; more are counted as chattering and the step is finished in the
// last mode. Blind spot: a z that dips below zero and comes back within one step is not seen.
// Time is t0 + n h, never accumulated.

#include <array>
#include <cstdint>

#include "solvers/integrators.hpp"
#include "solvers/plant.hpp"

namespace ehpt::solvers {

struct StepReport {
  int events = 0;           // crossings handled in this step
  bool chattering = false;  // event cap reached
  bool converged = true;    // every integrator call converged
  int iterations = 0;       // Newton iterations summed over the step
  double event_time_s = 0;  // time of the last event handled in this step (if events > 0)
};

template <class Plant, class Integrator>
  requires ::ehpt::solvers::Plant<Plant>
class EventStepper {
 public:
  using State = typename Plant::State;
  using Modes = typename Plant::Modes;
  using Inputs = typename Plant::Inputs;
  static constexpr int kNumZ = Plant::kNumCrossings;
  static constexpr int kMaxEventsPerStep = 8;
  static constexpr int kMaxLocateIterations = 100;

  EventStepper(const Plant& plant, Integrator& integrator, double t0_s, double h_s)
      : plant_(&plant), integ_(&integrator), t0_s_(t0_s), h_s_(h_s), tol_s_(1e-7 * h_s) {}
  // After a copy (a saved simulation state restored): the plant and integrator of the copy's owner.
  void rebind(const Plant& plant, Integrator& integrator) {
    plant_ = &plant;
    integ_ = &integrator;
  }

  double time_s(std::int64_t n) const { return t0_s_ + static_cast<double>(n) * h_s_; }
  double step_s() const { return h_s_; }

  // Run phase: x, m at t_n -> t_{n+1}. No allocation. dx_start: dx/dt at (t_n, x, m, u) if
  // the caller has it (the runner gets it with the outputs), else null; z_start likewise the
  // kNumZ crossing functions there (the runner gets them with its observation).
  // Inlined into its caller (the runner's loop): one call less per step.
  [[gnu::always_inline]] StepReport advance(std::int64_t n, State& x, Modes& m, const Inputs& u,
                                            const State* dx_start = nullptr, const double* z_start = nullptr) {
    StepReport r;
    const double t_end = time_s(n + 1);
    double ta = time_s(n);
    if constexpr (kNumZ == 0) {
      integrate(ta, t_end - ta, m, u, x, r, dx_start);
      return r;
    } else {
      const State* dx_a = dx_start;  // dx/dt at the segment start, until an event moves it
      const double* z_a = z_start;   // the same for the crossing functions
      for (;;) {
        // integrate the rest of the step in place, keeping its start for event location
        xa_ = x;
        integrate(ta, t_end - ta, m, u, x, r, dx_a);
        if (z_a != nullptr) {
          for (int i = 0; i < kNumZ; ++i) za_[i] = z_a[i];
        } else {
          plant_->crossings(ta, xa_, m, u, za_.data());
        }
        plant_->crossings(t_end, x, m, u, zb_.data());
        int fired = -1;
        double tau_s = t_end - ta;
        for (int i = 0; i < kNumZ; ++i) {
          if (za_[i] < 0.0 || (za_[i] == 0.0 && zb_[i] < 0.0)) {  // invalid from the start: fire now
            fired = i;
            tau_s = 0.0;
            break;
          }
          if (za_[i] > 0.0 && zb_[i] <= 0.0) {
            const double at_s = locate(i, ta, t_end - ta, m, u, r, dx_a);
            if (fired < 0 || at_s < tau_s) {
              fired = i;
              tau_s = at_s;
            }
          }
        }
        if (fired < 0) return r;
        if (r.events >= kMaxEventsPerStep) {
          r.chattering = true;  // finish the step in the last mode
          return r;
        }
        // integrate to the event, switch the mode, and carry on with the rest of the step
        x = xa_;
        if (tau_s > 0.0) integrate(ta, tau_s, m, u, x, r, dx_a);
        ta += tau_s;
        plant_->on_crossing(fired, ta, x, m, u);
        dx_a = nullptr;
        z_a = nullptr;
        ++r.events;
        r.event_time_s = ta;
        if (!(ta < t_end)) return r;
      }
    }
  }

 private:
  void integrate(double t_s, double h_s, const Modes& m, const Inputs& u, State& x, StepReport& r,
                 const State* dx_start) {
    const IntegratorStatus s = integ_->step(t_s, h_s, m, u, x, dx_start);
    r.converged = r.converged && s.converged;
    r.iterations += s.iterations;
  }

  // Earliest time (from ta) at which z_i <= 0; returns the crossed end of the bracket.
  double locate(int i, double ta, double span_s, const Modes& m, const Inputs& u, StepReport& r,
                const State* dx_a) {
    double lo = 0.0, hi = span_s;
    double z_lo = za_[i], z_hi = zb_[i];
    int side = 0;  // Illinois: which end was kept last time
    for (int it = 0; it < kMaxLocateIterations && hi - lo > tol_s_; ++it) {
      double mid = (it % 3 == 2) ? 0.5 * (lo + hi) : lo + (hi - lo) * z_lo / (z_lo - z_hi);
      if (!(mid > lo && mid < hi)) mid = 0.5 * (lo + hi);
      xm_ = xa_;
      integrate(ta, mid, m, u, xm_, r, dx_a);
      plant_->crossings(ta + mid, xm_, m, u, zm_.data());
      const double z = zm_[i];
      if (z <= 0.0) {
        hi = mid;
        z_hi = z;
        if (side == -1) z_lo *= 0.5;
        side = -1;
      } else {
        lo = mid;
        z_lo = z;
        if (side == 1) z_hi *= 0.5;
        side = 1;
      }
    }
    return hi;
  }

  const Plant* plant_;
  Integrator* integ_;
  double t0_s_, h_s_, tol_s_;
  State xa_, xm_;  // segment start; trial point while locating
  std::array<double, (kNumZ > 0 ? kNumZ : 1)> za_{}, zb_{}, zm_{};
};

}  // namespace ehpt::solvers
