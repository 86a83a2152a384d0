// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// A histogram of durations in nanoseconds with a fixed relative resolution (log-linear bins,
// as HdrHistogram lays them out): values below 128 ns are exact, above that each power of two
// is split into 64 bins, so a quantile is within 1/64 (1.6 %) of the true sample. The bins
// are one fixed array (30 KB, any int64 value): record() neither allocates nor locks, in the
// run phase of the real-time loop (wake-up latency of 20 us and compute of 300 ns alike) and
// of the bus plant (lockstep round trips, wall-clock period errors). The one histogram type
// of ehpt (a fixed 1 us grid up to 100 ms took 800 KB and lost what was beyond it).

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>

namespace ehpt::hil {

class LatencyHistogram {
 public:
  static constexpr int kSubBits = 6;                    // 64 bins per power of two
  static constexpr std::int64_t kExact = 2 << kSubBits;  // 0 .. 127 ns: one bin each
  static constexpr int kBins = static_cast<int>(kExact) + (63 - kSubBits - 1) * (1 << kSubBits);

  // Run phase. Negative values (a clock that went back) count as 0.
  void record(std::int64_t ns) {
    ns = std::max<std::int64_t>(ns, 0);
    ++bins_[static_cast<std::size_t>(bin_of(ns))];
    ++count_;
    max_ns_ = std::max(max_ns_, ns);
    sum_ns_ += static_cast<double>(ns);
  }

  std::int64_t count() const { return count_; }
  std::int64_t max_ns() const { return max_ns_; }
  double mean_ns() const { return count_ > 0 ? sum_ns_ / static_cast<double>(count_) : 0.0; }

  // The q-quantile (q in [0, 1]): the upper edge of the bin holding the ceil(q N)-th smallest
  // sample, never above the largest sample seen. 0 when empty.
  std::int64_t quantile_ns(double q) const {
    if (count_ == 0) return 0;
    const auto need = std::max<std::int64_t>(1, static_cast<std::int64_t>(std::ceil(q * static_cast<double>(count_))));
    std::int64_t seen = 0;
    for (int i = 0; i < kBins; ++i) {
      seen += bins_[static_cast<std::size_t>(i)];
      if (seen >= need) return std::min(upper_edge(i), max_ns_);
    }
    return max_ns_;
  }

  // Where a value goes, and the largest value of a bin (exposed for the tests).
  static int bin_of(std::int64_t ns) {
    if (ns < kExact) return static_cast<int>(ns);
    const int msb = 63 - std::countl_zero(static_cast<std::uint64_t>(ns));  // >= kSubBits + 1
    const int shift = msb - kSubBits;
    const auto sub = static_cast<int>(ns >> shift) - (1 << kSubBits);  // 0 .. 63
    return static_cast<int>(kExact) + (msb - kSubBits - 1) * (1 << kSubBits) + sub;
  }
  static std::int64_t upper_edge(int bin) {
    if (bin < kExact) return bin;
    const int k = bin - static_cast<int>(kExact);
    const int msb = k / (1 << kSubBits) + kSubBits + 1;
    const int shift = msb - kSubBits;
    const std::int64_t sub = (k % (1 << kSubBits)) + (1 << kSubBits);
    return ((sub + 1) << shift) - 1;
  }

 private:
  std::array<std::int64_t, kBins> bins_{};
  std::int64_t count_ = 0, max_ns_ = 0;
  double sum_ns_ = 0.0;
};

}  // namespace ehpt::hil
