// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Text a real-time loop produces (bus.log, inputs.log) and another thread writes: two buffers
// reserved at start-up. The loop appends to the active one; when it holds `threshold` bytes
// and the other one is free, the two swap and the full one is handed to the writer (an
// atomic flag, no lock, no wait). If the writer has not finished with the previous one, the
// loop keeps appending up to the reserve and then drops and counts (never allocates, never
// blocks). Without a writer thread (the plain loops), take_all() on the loop's own thread
// writes everything in order.
//
// Threads: append() and take_all() on the producer thread only; take_handed() on one
// consumer thread only. take_all() only when no consumer runs (before it starts, after it
// stopped).

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace ehpt::io {

class HandoffBuffer {
 public:
  explicit HandoffBuffer(std::size_t threshold = 1 << 20) : threshold_(threshold) {
    for (auto& b : buf_) b.reserve(2 * threshold_);
  }

  // Producer. False if the text was dropped (both buffers full).
  bool append(std::string_view text) {
    std::string& a = buf_[active_];
    if (a.size() + text.size() > a.capacity()) {
      if (!try_hand_over() || buf_[active_].size() + text.size() > buf_[active_].capacity()) {
        dropped_bytes_ += static_cast<std::int64_t>(text.size());
        return false;
      }
    }
    buf_[active_].append(text);
    if (buf_[active_].size() >= threshold_) try_hand_over();
    return true;
  }
  bool wants_writer() const { return handed_.load(std::memory_order_acquire); }

  // Consumer: the handed-over buffer, if any, to write(text); then it is free again.
  template <class Write>
  void take_handed(Write&& write) {
    if (!handed_.load(std::memory_order_acquire)) return;
    std::string& b = buf_[1 - active_seen()];
    write(std::string_view(b));
    b.clear();
    handed_.store(false, std::memory_order_release);
  }

  // Producer, with no consumer running: everything, oldest first.
  template <class Write>
  void take_all(Write&& write) {
    if (handed_.load(std::memory_order_acquire)) {
      std::string& b = buf_[1 - active_];
      write(std::string_view(b));
      b.clear();
      handed_.store(false, std::memory_order_release);
    }
    std::string& a = buf_[active_];
    if (!a.empty()) write(std::string_view(a));
    a.clear();
  }

  std::int64_t dropped_bytes() const { return dropped_bytes_; }

 private:
  // the active index as the consumer must read it: published with the hand-over
  int active_seen() const { return active_published_.load(std::memory_order_acquire); }
  // Producer: swap if the other buffer is free.
  bool try_hand_over() {
    if (handed_.load(std::memory_order_acquire)) return false;
    active_ = 1 - active_;
    active_published_.store(active_, std::memory_order_relaxed);
    handed_.store(true, std::memory_order_release);
    return true;
  }

  std::size_t threshold_;
  std::string buf_[2];
  int active_ = 0;                           // producer's
  std::atomic<int> active_published_{0};     // for the consumer
  std::atomic<bool> handed_{false};          // buf_[1 - active] is the writer's
  std::int64_t dropped_bytes_ = 0;
};

}  // namespace ehpt::io
