// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The rows a run records: chosen columns of the outputs at every decimation-th grid point,
// plus row 0, the last step and a fault step, into a buffer sized at start-up for one chunk
// of steps. The caller drains it between chunks (rows(), clear()); a row that does not fit
// is counted as dropped, never written past the buffer.

#include <cstdint>
#include <span>
#include <vector>

#include "plant/signals.hpp"

namespace ehpt::hil {

template <class Outputs>
class Recorder {
 public:
  // Start-up: signals is the plant's list, columns the indices to record; bits (if given) a
  // last column, the faults acting (a test's faults_active).
  Recorder(std::span<const plant::Signal<Outputs>> signals, const std::vector<int>& columns,
           std::int64_t decimation, std::int64_t chunk_steps, const unsigned* bits = nullptr)
      : decimation_(decimation), bits_(bits) {
    for (int c : columns) members_.push_back(signals[static_cast<std::size_t>(c)].member);
    width_ = members_.size() + (bits_ != nullptr ? 1 : 0);
    rows_.resize(static_cast<std::size_t>((chunk_steps / decimation_ + 4) * static_cast<std::int64_t>(width_)));
  }

  // After a copy (a saved simulation state restored): the fault bits of the copy's owner.
  void rebind_bits(const unsigned* bits) { bits_ = bits; }

  // Run phase: whether grid point n is one that is written without being forced.
  bool due(std::int64_t n) const { return n % decimation_ == 0; }

  // Run phase: records y as the row of step n (once per n).
  void record(std::int64_t n, const Outputs& y) {
    if (last_recorded_ == n) return;
    if ((row_count_ + 1) * width_ > rows_.size()) {
      ++dropped_;
      return;
    }
    double* row = rows_.data() + row_count_ * width_;
    for (std::size_t c = 0; c < members_.size(); ++c) row[c] = y.*members_[c];
    if (bits_ != nullptr) row[members_.size()] = static_cast<double>(*bits_);
    ++row_count_;
    last_recorded_ = n;
  }

  // Rows since the last clear (row-major, columns as given).
  std::span<const double> rows() const { return {rows_.data(), row_count_ * width_}; }
  void clear() { row_count_ = 0; }
  std::int64_t dropped() const { return dropped_; }

 private:
  std::int64_t decimation_;
  const unsigned* bits_;
  std::vector<double Outputs::*> members_;
  std::size_t width_ = 0;
  std::vector<double> rows_;
  std::size_t row_count_ = 0;
  std::int64_t last_recorded_ = -1;
  std::int64_t dropped_ = 0;
};

}  // namespace ehpt::hil
