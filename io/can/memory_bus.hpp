// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// A CAN bus inside one process: two ends, each a Transport, each frame one end sends received
// by the other, in order, through a ring of fixed capacity (reserved at construction: no
// allocation after it; a frame that finds the ring full is counted in send_dropped). No
// thread, no clock: an end may have a pump, called before it receives or waits, that lets the
// other side run (hil/bus/in_process_bus.hpp serves the built-in ECU so, in the plant's thread).

#include <cstddef>
#include <string>
#include <vector>

#include "io/can/transport.hpp"

namespace ehpt::io::can {

class MemoryBus {
 public:
  // called by an end before it hands out frames or waits: the other side's turn
  using Pump = void (*)(void* context);

  explicit MemoryBus(std::size_t capacity_frames = 4096)
      : rings_{Ring(capacity_frames), Ring(capacity_frames)}, ends_{End(*this, 0), End(*this, 1)} {}
  MemoryBus(const MemoryBus&) = delete;
  MemoryBus& operator=(const MemoryBus&) = delete;

  Transport& end(int side) { return ends_[side & 1]; }
  void set_pump(int side, Pump pump, void* context) {
    ends_[side & 1].pump_ = pump;
    ends_[side & 1].context_ = context;
  }

 private:
  struct Ring {
    explicit Ring(std::size_t capacity) : frames(capacity == 0 ? 1 : capacity) {}
    std::vector<Frame> frames;
    std::size_t head = 0, count = 0;
    bool push(const Frame& f) {
      if (count == frames.size()) return false;
      frames[(head + count) % frames.size()] = f;
      ++count;
      return true;
    }
    bool pop(Frame& f) {
      if (count == 0) return false;
      f = frames[head];
      head = (head + 1) % frames.size();
      --count;
      return true;
    }
  };

  class End final : public Transport {
   public:
    End(MemoryBus& bus, int side) : bus_(&bus), side_(side) {}
    bool send(const Frame& frame) override {
      if (!bus_->rings_[1 - side_].push(frame)) {
        ++counters_.send_dropped;
        return false;
      }
      ++counters_.frames_out;
      return true;
    }
    std::size_t receive(std::span<Frame> out) override {
      pump();
      std::size_t k = 0;
      while (k < out.size() && bus_->rings_[side_].pop(out[k])) ++k;
      counters_.frames_in += static_cast<std::int64_t>(k);
      return k;
    }
    // nothing arrives while this thread waits: the other side runs in the pump, or not at all
    bool wait(std::int64_t) override {
      pump();
      return bus_->rings_[side_].count > 0;
    }
    bool has_peer() const override { return true; }
    const TransportCounters& counters() const override { return counters_; }
    std::string describe() const override { return "in-process"; }

   private:
    friend class MemoryBus;
    void pump() {
      if (pump_ != nullptr) pump_(context_);
    }
    MemoryBus* bus_;
    int side_;
    Pump pump_ = nullptr;
    void* context_ = nullptr;
    TransportCounters counters_;
  };

  Ring rings_[2];
  End ends_[2];
};

}  // namespace ehpt::io::can
