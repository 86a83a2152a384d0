// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// A latency histogram in whole microseconds, preallocated at start-up (record() neither
// allocates nor locks): timing figures of the bus pacers (round trips, period errors).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace ehpt::hil {

class MicrosecondHistogram {
 public:
  explicit MicrosecondHistogram(std::int64_t max_us = 100'000) : bins_(static_cast<std::size_t>(max_us) + 1, 0) {}

  // Run phase. Negative values count as 0; beyond max_us in the last bin (max_ns keeps the truth).
  void record(std::int64_t ns) {
    const std::int64_t us = std::clamp<std::int64_t>(ns / 1000, 0, static_cast<std::int64_t>(bins_.size()) - 1);
    ++bins_[static_cast<std::size_t>(us)];
    ++count_;
    max_ns_ = std::max(max_ns_, ns);
  }
  std::int64_t count() const { return count_; }
  double max_us() const { return static_cast<double>(max_ns_) / 1000.0; }
  // The smallest bin value with at least q of the samples at or below it (q in [0, 1]).
  double quantile_us(double q) const {
    if (count_ == 0) return 0.0;
    const auto need = static_cast<std::int64_t>(std::ceil(q * static_cast<double>(count_)));
    std::int64_t seen = 0;
    for (std::size_t i = 0; i < bins_.size(); ++i) {
      seen += bins_[i];
      if (seen >= std::max<std::int64_t>(need, 1)) return static_cast<double>(i);
    }
    return static_cast<double>(bins_.size() - 1);
  }

 private:
  std::vector<std::int64_t> bins_;
  std::int64_t count_ = 0;
  std::int64_t max_ns_ = 0;
};

}  // namespace ehpt::hil
