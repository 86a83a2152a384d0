// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Run metrics over every grid point of a run (run phase: no allocation), from the outputs a
// vehicle declares in Plant::kMetrics (plant/signals.hpp):
//   speed error e_n = 3.6 (v_ref - v) km/h at every grid point n = 0..N: rms and max;
//   locked time = h x the number of steps that end locked (n = 1..N);
//   engine on-time = h x the number of steps that start with the engine on (n = 0..N-1),
//   starts = off -> on switches, and one if it runs at t = 0.
// Times are counted in steps, never summed, so they are exact multiples of h.

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "plant/signals.hpp"

namespace ehpt::hil {

struct MetricTotals {
  bool has_speed = false;
  std::int64_t speed_samples = 0;
  double speed_error_sq_sum = 0.0;  // (km/h)^2
  double speed_error_max_kmh = 0.0;
  bool has_locked = false;
  double locked_time_s = 0.0;
  bool has_engine = false;
  double engine_on_time_s = 0.0;
  std::int64_t engine_starts = 0;

  double speed_error_rms_kmh() const {
    return speed_samples > 0 ? std::sqrt(speed_error_sq_sum / static_cast<double>(speed_samples)) : NAN;
  }
};

template <class Outputs>
class Metrics {
 public:
  Metrics(const plant::MetricSources<Outputs>& sources, double h_s) : src_(sources), h_s_(h_s) {
    totals_.has_speed = src_.speed_ref_m_s != nullptr && src_.speed_m_s != nullptr;
    totals_.has_locked = src_.locked != nullptr;
    totals_.has_engine = src_.engine_on != nullptr;
  }

  // Run phase: the outputs at grid point n (called once per n, in order).
  void observe(std::int64_t n, const Outputs& y) { observe_from(src_, n, y); }
  // The same with the sources known at compile time (the runner passes Plant::kMetrics, the
  // ones this was built with): the members are read directly, absent metrics cost nothing.
  template <plant::MetricSources<Outputs> Src>
  [[gnu::always_inline]] void observe(std::int64_t n, const Outputs& y) {
    observe_from(Src, n, y);
  }

  // The times from the step counts when they are read, not at every grid point.
  const MetricTotals& totals() const {
    totals_.locked_time_s = static_cast<double>(locked_steps_) * h_s_;
    totals_.engine_on_time_s = static_cast<double>(engine_on_steps_) * h_s_;
    return totals_;
  }

 private:
  [[gnu::always_inline]] void observe_from(const plant::MetricSources<Outputs>& src, std::int64_t n, const Outputs& y) {
    if (src.speed_ref_m_s != nullptr && src.speed_m_s != nullptr) {
      const double err_kmh = 3.6 * (y.*src.speed_ref_m_s - y.*src.speed_m_s);
      ++totals_.speed_samples;
      totals_.speed_error_sq_sum += err_kmh * err_kmh;
      totals_.speed_error_max_kmh = std::max(totals_.speed_error_max_kmh, std::abs(err_kmh));
    }
    if (src.locked != nullptr && n > 0 && y.*src.locked != 0.0) ++locked_steps_;
    if (src.engine_on != nullptr) {
      const bool on = y.*src.engine_on != 0.0;
      if (n > 0 && engine_was_on_) ++engine_on_steps_;  // on during the step that ended here
      if (on && (n == 0 || !engine_was_on_)) ++totals_.engine_starts;
      engine_was_on_ = on;
    }
  }

  plant::MetricSources<Outputs> src_;
  double h_s_;
  mutable MetricTotals totals_;
  std::int64_t locked_steps_ = 0, engine_on_steps_ = 0;
  bool engine_was_on_ = false;
};

}  // namespace ehpt::hil
