// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Pacers: when the runner may take the next step. Every pacer gives the same trajectory; they
// differ only in waiting. The timing logic is a pure function (tick_after) so that it is
// tested against a fake clock (ros2_control's style); the waiting is the pacer's.
//   none (the runner without a StepPacer, hil/run/port.hpp): never waits (batch runs);
//   WallClock<Clock>: step n is due at start + n period; waits until then (the bus plant's
//   StepPacer). Overrun policy: when a step ends after later ticks have passed, those ticks
//   are skipped and counted, never caught up in a burst;
//   TickPacer<Clock>: the real-time loop's ticks on absolute deadlines (SCHED_FIFO);
//   lockstep is no pacer: the bus port's sample waits for that sample's command.

#include <time.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <thread>

#include "hil/run/latency_histogram.hpp"

namespace ehpt::hil {

// When the tick that follows `now` is, and how many ticks were missed on the way.
struct NextTick {
  std::int64_t tick = 0;    // index of the next tick to wait for
  std::int64_t missed = 0;  // ticks that passed while the last step ran (skipped)
};

// Pure: the tick to wait for after tick `done` finished at `now_ns`, on a grid start_ns +
// k period_ns. A finished step whose next tick is already past skips to the first tick after
// now (the missed ones are counted), so late steps never run back to back.
inline NextTick tick_after(std::int64_t done, std::int64_t now_ns, std::int64_t start_ns, std::int64_t period_ns) {
  const std::int64_t next = done + 1;
  if (now_ns <= start_ns + next * period_ns) return {next, 0};
  const std::int64_t first_future = (now_ns - start_ns) / period_ns + 1;
  return {first_future, first_future - next};
}

// Clock: now_ns() and sleep_until_ns(t) (the real one below; a fake one in the tests).
template <class Clock>
class WallClock {
 public:
  WallClock(Clock& clock, std::int64_t period_ns) : clock_(clock), period_ns_(period_ns) {}

  // Run phase: waits until step n is due. Step numbers are ticks until one is missed; after
  // that the grid stays the same and skipped ticks are counted.
  void wait_for_step(std::int64_t n) {
    if (n == 0) {
      start_ns_ = clock_.now_ns();
      tick_ = 0;
      return;
    }
    const NextTick next = tick_after(tick_, clock_.now_ns(), start_ns_, period_ns_);
    missed_ += next.missed;
    tick_ = next.tick;
    clock_.sleep_until_ns(start_ns_ + tick_ * period_ns_);
  }
  std::int64_t missed_ticks() const { return missed_; }
  // when the step last waited for was due (its lateness = now - this)
  std::int64_t last_deadline_ns() const { return start_ns_ + tick_ * period_ns_; }

 private:
  Clock& clock_;
  std::int64_t period_ns_;
  std::int64_t start_ns_ = 0, tick_ = 0, missed_ = 0;
};

struct SteadyClock {
  std::int64_t now_ns() const {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
  }
  void sleep_until_ns(std::int64_t t_ns) const {
    std::this_thread::sleep_until(std::chrono::steady_clock::time_point(std::chrono::nanoseconds(t_ns)));
  }
};

// The real-time loop's clock: CLOCK_MONOTONIC, and absolute deadlines with clock_nanosleep
// (TIMER_ABSTIME: a late wake-up is not carried into the next period, unlike a relative
// sleep). sleep_until_ns returns early only when a signal interrupts it.
struct MonotonicClock {
  std::int64_t now_ns() const {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
  }
  void sleep_until_ns(std::int64_t t_ns) const {
    const timespec ts{static_cast<time_t>(t_ns / 1'000'000'000), static_cast<long>(t_ns % 1'000'000'000)};
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
  }
};

// Per-tick timing of the real-time loop, in preallocated histograms: wake-up latency (how
// late the loop woke after its deadline), compute (the plant's steps) and IO (bus exchange,
// rows handed to the writer), with the overrun counters.
struct TickTiming {
  std::int64_t ticks = 0;         // ticks the loop ran
  std::int64_t overruns = 0;      // ticks whose work ended after the next tick's deadline
  std::int64_t missed_ticks = 0;  // ticks skipped because of them (never caught up)
  LatencyHistogram wakeup, compute, io;
};

// The real-time pacer: tick k is due at start + k period (absolute deadlines on one grid).
// Overrun policy: when a tick's work ends after later deadlines have passed, those ticks are
// skipped and counted, and the loop waits for the first deadline still ahead: it never runs
// ticks back to back to catch up (the plant then lags the wall clock by the skipped ticks).
// Clock: now_ns(), sleep_until_ns(t) (MonotonicClock; a fake one in the tests).
template <class Clock>
class TickPacer {
 public:
  TickPacer(Clock& clock, std::int64_t period_ns, TickTiming& timing)
      : clock_(clock), period_ns_(period_ns), timing_(timing) {}

  // Tick 0 is now: the loop's first work starts at once.
  void start() {
    start_ns_ = clock_.now_ns();
    tick_ = 0;
    timing_.ticks = 1;
    timing_.wakeup.record(0);
  }

  // Run phase: sleeps until the next tick's deadline (skipping those already past, counted)
  // and records how late it woke. False if stop was raised while it slept (no tick then).
  bool wait_next_tick(const std::atomic<int>* stop = nullptr) {
    const NextTick next = tick_after(tick_, clock_.now_ns(), start_ns_, period_ns_);
    if (next.missed > 0) {
      ++timing_.overruns;
      timing_.missed_ticks += next.missed;
    }
    tick_ = next.tick;
    const std::int64_t deadline = start_ns_ + tick_ * period_ns_;
    for (;;) {
      clock_.sleep_until_ns(deadline);
      const std::int64_t now = clock_.now_ns();
      if (now >= deadline) {
        timing_.wakeup.record(now - deadline);
        ++timing_.ticks;
        return true;
      }
      if (stop != nullptr && stop->load(std::memory_order_relaxed) != 0) return false;  // a signal woke us
    }
  }

  std::int64_t tick() const { return tick_; }
  std::int64_t deadline_ns() const { return start_ns_ + tick_ * period_ns_; }
  std::int64_t period_ns() const { return period_ns_; }

 private:
  Clock& clock_;
  std::int64_t period_ns_;
  TickTiming& timing_;
  std::int64_t start_ns_ = 0, tick_ = 0;
};

}  // namespace ehpt::hil
