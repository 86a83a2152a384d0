// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// A single-producer, single-consumer queue of recorded rows (fixed column count), preallocated
// at start-up: the real-time loop pushes each tick's rows without waiting, allocating or
// locking, and the writer thread pops them to format and write the CSV. A row that does not
// fit (the writer fell behind by the whole capacity) is dropped and counted, never waited for.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace ehpt::hil {

class RowQueue {
 public:
  // Start-up: room for capacity_rows rows of `columns` values.
  RowQueue(std::size_t columns, std::size_t capacity_rows)
      : columns_(std::max<std::size_t>(columns, 1)), capacity_(std::max<std::size_t>(capacity_rows, 1)),
        buf_(columns_ * capacity_) {}

  // Producer (run phase): rows row-major, a whole number of rows. Returns the rows dropped.
  std::size_t push(std::span<const double> rows) {
    const std::size_t n = rows.size() / columns_;
    const std::size_t head = head_.load(std::memory_order_relaxed);
    const std::size_t tail = tail_.load(std::memory_order_acquire);
    const std::size_t room = capacity_ - (head - tail);
    const std::size_t take = std::min(n, room);
    for (std::size_t r = 0; r < take; ++r) {
      double* dst = buf_.data() + ((head + r) % capacity_) * columns_;
      std::copy_n(rows.data() + r * columns_, columns_, dst);
    }
    head_.store(head + take, std::memory_order_release);
    dropped_.fetch_add(n - take, std::memory_order_relaxed);
    return n - take;
  }

  // Consumer: calls on_row(span of one row) for every row pushed so far, oldest first, then
  // frees their room. Returns the rows taken.
  template <class OnRow>
  std::size_t pop_all(OnRow&& on_row) {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    const std::size_t head = head_.load(std::memory_order_acquire);
    for (std::size_t i = tail; i != head; ++i) {
      on_row(std::span<const double>(buf_.data() + (i % capacity_) * columns_, columns_));
    }
    tail_.store(head, std::memory_order_release);
    return head - tail;
  }

  std::size_t columns() const { return columns_; }
  std::size_t capacity_rows() const { return capacity_; }
  std::int64_t dropped() const { return static_cast<std::int64_t>(dropped_.load(std::memory_order_relaxed)); }

 private:
  std::size_t columns_, capacity_;
  std::vector<double> buf_;
  // the producer's and the consumer's index on their own cache lines (no false sharing)
  alignas(64) std::atomic<std::size_t> head_{0};  // rows pushed (monotonic)
  alignas(64) std::atomic<std::size_t> tail_{0};  // rows popped (monotonic)
  alignas(64) std::atomic<std::size_t> dropped_{0};
};

}  // namespace ehpt::hil
