// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Expectations (docs/testing.md): a bound on a plant output judged over a window, at every
// plant step inside the runner (batch, bus and real time alike). Start-up compiles the
// scenario's ExpectSpecs against the plant's signals; the run phase allocates nothing. A
// summary figure (ExpectSpec::figure) is judged once the run is over (judge_figure).
//
// Windows in whole plant steps h: from = ceil(from_s / h), to = floor(to_s / h) (the run's last
// step if later), within: [event, event + floor(within_s / h)], every bound inclusive. A
// window the run did not reach (a run stopped by a plant fault) is a failure, never a pass.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "hil/config/test_spec.hpp"
#include "hil/run/fault_injector.hpp"
#include "plant/signals.hpp"

namespace ehpt::hil {

// How an expectation ended.
struct ExpectOutcome {
  enum class Why {
    kHeld,        // passed
    kOutOfBound,  // failed at `step` with `value` (always, at_end, a figure)
    kRate,        // |dx/dt| = value > rate_max at `step`
    kNeverHeld,   // eventually/within: never inside its window; `value` the closest, at `step`
    kNoEvent,     // within: its event did not happen
    kNotReached,  // the run ended (at `step`) before its window did
  };
  bool passed = false;
  Why why = Why::kNotReached;
  std::int64_t step = -1;
  double value = std::numeric_limits<double>::quiet_NaN();
  double reference = std::numeric_limits<double>::quiet_NaN();  // the other signal's value there
  std::int64_t event_step = -1;  // within: where its event was
};

// The last grid point of a window ending at t_s (inclusive; infinity: none).
inline std::int64_t last_step_at(double t_s, double h_s) {
  const double steps = std::floor(t_s / h_s + 1e-9);
  if (!(steps < 9e18)) return std::numeric_limits<std::int64_t>::max();  // (as first_step_at)
  return static_cast<std::int64_t>(steps);
}

// How far x lies outside the bound (0: inside). reference: value or the other signal's.
inline double bound_violation(const ExpectSpec& e, double x, double reference) {
  double v = 0.0;
  if (e.has_min) v = std::max(v, e.min - x);
  if (e.has_max) v = std::max(v, x - e.max);
  if (e.has_near) v = std::max(v, std::abs(x - reference) - e.tol);
  if (!(x == x)) v = std::numeric_limits<double>::infinity();  // NaN is outside every bound
  return v;
}

// How far inside the bound x lies (the smallest distance to any of its limits; infinity for
// none, e.g. a rate limit alone).
inline double bound_headroom(const ExpectSpec& e, double x, double reference) {
  double h = std::numeric_limits<double>::infinity();
  if (e.has_min) h = std::min(h, x - e.min);
  if (e.has_max) h = std::min(h, e.max - x);
  if (e.has_near) h = std::min(h, e.tol - std::abs(x - reference));
  return h;
}

// A figure at the end of the run.
ExpectOutcome judge_figure(const ExpectSpec& e, double value);
// One line for the table, JUnit and summary.json: what was expected and what happened.
std::string expect_message(const ExpectSpec& e, const ExpectOutcome& o, double step_s);

template <class Plant>
class ExpectationChecker {
 public:
  using Outputs = typename Plant::Outputs;

  ExpectationChecker(std::span<const ExpectSpec> specs, const Plant& plant, double step_s, std::int64_t total_steps)
      : h_s_(step_s), total_(total_steps) {
    const auto signals = plant.signals();
    const auto member = [&](const std::string& name) -> double Outputs::* {
      for (const auto& s : signals) {
        if (s.name == name) return s.member;
      }
      return nullptr;
    };
    for (const ExpectSpec& e : specs) {
      if (!e.figure.empty()) continue;  // judged after the run
      Item it;
      it.spec = &e;
      it.index = static_cast<std::size_t>(&e - specs.data());
      it.signal = member(e.signal);
      it.window = e.window;
      if (e.has_min) it.lo = e.min;
      if (e.has_max) it.hi = e.max;
      it.near = e.has_near;
      it.value = e.value;
      it.tol = e.tol;
      it.rate = e.has_rate;
      it.rate_max = e.rate_max;
      it.other = e.other.empty() ? nullptr : member(e.other);
      it.from = e.window == ExpectWindow::kAtEnd ? total_ : first_step_at(e.from_s, h_s_);
      it.to = e.window == ExpectWindow::kAtEnd ? total_ : std::min(total_, last_step_at(e.to_s, h_s_));
      // at most the run: event + width never overflows
      it.width = e.window == ExpectWindow::kWithin ? std::min(total_, last_step_at(e.within_s, h_s_)) : 0;
      if (e.window == ExpectWindow::kWithin) {
        it.from = it.to = std::numeric_limits<std::int64_t>::max();  // until the event
        if (e.after_fault < 0) it.condition = compile_condition<Outputs>(e.after_condition, signals);
      }
      if (it.signal != nullptr) items_.push_back(it);
    }
    outcomes_.resize(specs.size());
  }

  bool empty() const { return items_.empty(); }

  // Run phase: the outputs at grid point n (once per n, in order); faults: the run's, for the
  // events of `within` windows (nullptr: none).
  void observe(std::int64_t n, const Outputs& y, std::span<const FaultSpan> faults) {
    last_n_ = n;
    for (Item& it : items_) {
      if (it.decided) continue;  // a failed always-window, a window that held: nothing more to see
      ExpectOutcome& o = it.outcome;
      if (it.window == ExpectWindow::kWithin && o.event_step < 0) {
        const ExpectSpec& e = *it.spec;
        bool event = false;
        if (e.after_fault >= 0) {
          const FaultSpan& f = faults[static_cast<std::size_t>(e.after_fault)];
          event = (e.after_end ? f.end_step : f.first_step) == n;
        } else {
          event = it.condition.holds(y);
        }
        if (event) {
          o.event_step = n;
          it.from = n;
          it.to = std::min(total_, n + it.width);
        }
      }
      const double x = y.*it.signal;
      if (it.rate) {
        if (n > it.from && n <= it.to) {
          const double rate = std::abs(x - it.previous) / h_s_;
          if (!(rate <= it.rate_max)) {
            decide(it, false, ExpectOutcome::Why::kRate, n, rate);
            continue;
          }
        }
        it.previous = x;
      }
      if (n < it.from || n > it.to) continue;
      const double ref = it.other != nullptr ? y.*it.other : it.value;
      // lo, hi: min and max, or infinities; a NaN is outside every bound
      const bool inside = x >= it.lo && x <= it.hi && (!it.near || std::abs(x - ref) <= it.tol);
      if (it.window == ExpectWindow::kAlways) {
        if (!inside) {
          decide(it, false, ExpectOutcome::Why::kOutOfBound, n, x);
          o.reference = ref;
          continue;
        }
        // where a passing window came closest to its bound
        double room = std::min(x - it.lo, it.hi - x);
        if (it.near) room = std::min(room, it.tol - std::abs(x - ref));
        if (room < it.closest) {
          it.closest = room;
          o.step = n;
          o.value = x;
          o.reference = ref;
        }
      } else if (it.window == ExpectWindow::kAtEnd) {
        decide(it, inside, inside ? ExpectOutcome::Why::kHeld : ExpectOutcome::Why::kOutOfBound, n, x);
        o.reference = ref;
      } else if (inside) {  // eventually, within
        decide(it, true, ExpectOutcome::Why::kHeld, n, x);
      } else if (const double violation = bound_violation(*it.spec, x, ref); violation < it.closest) {
        it.closest = violation;
        o.step = n;
        o.value = x;
        o.reference = ref;
      }
    }
  }

  // Every outcome, in the specs' order, as if the run ended at its last observed grid point
  // (figures are left for judge_figure). Nothing of the checker changes: a caller may ask
  // mid-run (Simulation.verdict() in Python) and step on.
  std::span<const ExpectOutcome> finish() {
    for (const Item& it : items_) {
      ExpectOutcome o = it.outcome;
      if (!it.decided) {
        const ExpectWindow w = it.spec->window;
        if (w == ExpectWindow::kWithin && o.event_step < 0) {
          o.passed = false;
          o.why = ExpectOutcome::Why::kNoEvent;
        } else if (last_n_ < it.to) {
          o.passed = false;
          o.why = ExpectOutcome::Why::kNotReached;
          o.step = last_n_;
        } else if (w == ExpectWindow::kAlways) {
          o.passed = true;
          o.why = ExpectOutcome::Why::kHeld;
        } else {
          o.passed = false;
          o.why = ExpectOutcome::Why::kNeverHeld;
        }
      }
      outcomes_[it.index] = o;
    }
    return outcomes_;
  }

 private:
  struct Item {
    const ExpectSpec* spec = nullptr;
    std::size_t index = 0;
    double Outputs::*signal = nullptr;
    double Outputs::*other = nullptr;
    CompiledCondition<Outputs> condition;
    // the spec's bound and window, copied for the step loop
    ExpectWindow window = ExpectWindow::kAlways;
    double lo = -std::numeric_limits<double>::infinity(), hi = std::numeric_limits<double>::infinity();
    bool near = false, rate = false;
    double value = 0.0, tol = 0.0, rate_max = 0.0;
    std::int64_t from = 0, to = 0, width = 0;
    bool decided = false;
    double previous = 0.0;
    double closest = std::numeric_limits<double>::infinity();
    ExpectOutcome outcome;
  };
  static void decide(Item& it, bool passed, ExpectOutcome::Why why, std::int64_t n, double value) {
    it.decided = true;
    it.outcome.passed = passed;
    it.outcome.why = why;
    it.outcome.step = n;
    it.outcome.value = value;
  }

  double h_s_;
  std::int64_t total_;
  std::int64_t last_n_ = -1;
  std::vector<Item> items_;
  std::vector<ExpectOutcome> outcomes_;
};

}  // namespace ehpt::hil
