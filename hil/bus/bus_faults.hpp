// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Bus faults (docs/testing.md, "Bus faults"): what a scenario's drop, delay, duplicate,
// reorder, corrupt, counter_freeze, counter_jump, bad_crc, stop, period and bus_off faults do
// to the frames of the bound contract (hil/bus/bus_binding.hpp), in the direction each
// message travels: the plant's [[send]] messages as they leave it, its [[receive]] messages
// before its rules see them. The CAN wire (hil/bus/bus_wire_can.hpp) passes every frame
// through here with the fault mask of the step (FaultInjector::mask: when each fault acts).
//
// Resolved once at start-up (target = a message of the binding; parameters checked against
// it); the run phase allocates nothing: one seeded generator per probabilistic drop, one ring
// per direction for delayed frames, one slot per direction for a frame held back by reorder.
// Deterministic: what happens to a frame depends only on the step and the frames before it
// in its direction, never on the wall clock.
//
// Per frame, in this order: its content (counter_freeze, counter_jump - the sender's counter,
// the E2E CRC recomputed -, bad_crc, corrupt: as a wire would damage it), then its delivery:
// lost (drop, stop, bus_off, a period's skipped sample), held (delay: whole ECU periods),
// after the next frame (reorder), twice (duplicate). On a bus that carries CAN error frames
// (SocketCAN), error_frames puts one on it at each sample, and bus_off reports the controller
// going bus-off where it starts and restarting where it ends.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "hil/bus/bus_binding.hpp"
#include "hil/config/test_spec.hpp"
#include "io/can/frame.hpp"
#include "io/can/transport.hpp"
#include "io/json_writer.hpp"

namespace ehpt::hil {

class BusFaults {
 public:
  enum class Direction { kTx, kRx };  // from the plant, to the plant

  BusFaults() = default;

  // The scenario's bus faults on this binding; false and every problem (file:line, the
  // fault, what is wrong, what would do) in errors. step_s, ecu_ratio: the plant's grid
  // (delays and periods in whole ECU periods). error_frames: only on a transport that sends
  // error frames (error_frames_ok: SocketCAN).
  static bool resolve(const std::vector<FaultSpec>& faults, const Binding& binding, double step_s,
                      std::int64_t ecu_ratio, bool error_frames_ok, BusFaults& out, std::vector<std::string>& errors);

  bool empty() const { return faults_.empty(); }
  // the mask bits of the bus faults (FaultInjector::mask's bits)
  std::uint64_t bits() const { return bits_; }

  // Run phase. A direction's frames go through process() in the order they would be sent;
  // emit(frame) is called for each frame that goes on (0, 1 or 2 times, maybe later).
  // message: its index in binding.send (kTx) or binding.receive (kRx). step: the plant step
  // (a sample's), mask: the faults acting at it. True if no fault acted on the frame.
  template <class Emit>
  bool process(Direction d, std::size_t message, io::can::Frame f, std::int64_t step, std::uint64_t mask, Emit&& emit) {
    DirState& ds = dir_[static_cast<int>(d)];
    bool intact = true, lost = false, duplicate = false, reorder = false;
    std::int64_t delay_steps = 0;
    for (Fault& x : faults_) {
      if ((mask & x.bit) == 0 || x.direction != d || (x.message != message && !x.whole_bus)) {
        if ((mask & x.bit) == 0) x.period_start = -1;  // a period counts from when it starts acting
        continue;
      }
      bool acted = true;
      switch (x.effect) {
        case FaultEffect::kCounterFreeze:
        case FaultEffect::kCounterJump: acted = rewrite_counter(x, f); break;
        case FaultEffect::kBadCrc: f.data[static_cast<std::size_t>(x.crc_byte)] ^= 0xFF; break;
        case FaultEffect::kCorrupt: f.data[static_cast<std::size_t>(x.byte)] ^= static_cast<std::uint8_t>(x.mask); break;
        case FaultEffect::kDrop: acted = !lost && drops(x); lost = lost || acted; break;
        case FaultEffect::kStop:
        case FaultEffect::kBusOff: acted = !lost; lost = true; break;
        case FaultEffect::kPeriod: {
          if (x.period_start < 0) x.period_start = step;
          const bool due = ((step - x.period_start) / x.ecu_ratio) % x.period_samples == 0;
          acted = !lost && !due;
          lost = lost || !due;
          break;
        }
        case FaultEffect::kDelay: acted = !lost; delay_steps = x.delay_steps; break;
        case FaultEffect::kReorder: acted = !lost; reorder = true; break;
        case FaultEffect::kDuplicate: acted = !lost; duplicate = true; break;
        default: acted = false; break;
      }
      if (acted) {
        ++x.frames;
        if (x.effect != FaultEffect::kDuplicate) intact = false;
      }
    }
    if (lost) return false;
    if (delay_steps > 0) {
      if (!ds.ring.push(Held{f, step + delay_steps, duplicate})) ++ds.ring_overflow;
      return false;
    }
    if (reorder && !ds.holding) {  // it goes after the next frame of this direction
      ds.held = f;
      ds.held_twice = duplicate;
      ds.holding = true;
      return false;
    }
    deliver(ds, f, duplicate, emit);
    return intact;
  }

  // Once per sample, before its frames: the error frames the faults put on the bus, each
  // through send(io::can::ErrorFrame) (error_frames: one per sample while it acts; bus_off:
  // kBusOff where it starts, kRestarted where it ends, on a bus that carries them).
  template <class Send>
  void error_frames(std::uint64_t mask, Send&& send) {
    for (Fault& x : faults_) {
      if (x.direction != Direction::kTx) continue;
      const bool on = (mask & x.bit) != 0;
      if (x.effect == FaultEffect::kErrorFrames && on) {
        send(io::can::ErrorFrame::kBusError);
        ++x.frames;
      }
      if (x.effect == FaultEffect::kBusOff && x.error_edges && on != x.was_on) {
        send(on ? io::can::ErrorFrame::kBusOff : io::can::ErrorFrame::kRestarted);
      }
      x.was_on = on;
    }
  }

  // Before a direction's frames at step: the delayed frames now due, in the order they were
  // held; true if there was none (nothing from an earlier sample came in between).
  template <class Emit>
  bool release(Direction d, std::int64_t step, Emit&& emit) {
    DirState& ds = dir_[static_cast<int>(d)];
    bool none = true;
    while (!ds.ring.empty() && ds.ring.front().release_step <= step) {
      const Held h = ds.ring.pop();
      deliver(ds, h.frame, h.twice, emit);
      none = false;
    }
    return none;
  }
  // A frame held back by reorder whose next frame never came (its direction fell silent, the
  // fault ended): it goes now. True if there was none.
  template <class Emit>
  bool release_held(Direction d, std::uint64_t mask, Emit&& emit) {
    DirState& ds = dir_[static_cast<int>(d)];
    if (!ds.holding) return true;
    bool reordering = false;
    for (const Fault& x : faults_) reordering = reordering || (x.effect == FaultEffect::kReorder && x.direction == d && (mask & x.bit) != 0);
    if (reordering) return true;  // still acting: it waits for the next frame
    ds.holding = false;
    emit(ds.held);
    if (ds.held_twice) emit(ds.held);
    return false;
  }

  // summary.json's bus.faults: each fault's kind, message, direction and the frames it acted on.
  void report(io::JsonObject& bus) const;
  std::int64_t frames_acted() const {
    std::int64_t n = 0;
    for (const Fault& x : faults_) n += x.frames;
    return n;
  }
  // the frames the scenario's fault[index] acted on (both directions for bus_off)
  std::int64_t frames_of(std::size_t index) const {
    std::int64_t n = 0;
    for (const Fault& x : faults_) n += x.bit == (1ull << index) ? x.frames : 0;
    return n;
  }

 private:
  struct Fault {
    FaultEffect effect = FaultEffect::kDrop;
    std::uint64_t bit = 0;
    Direction direction = Direction::kTx;
    std::size_t message = 0;  // index in its direction's messages
    bool whole_bus = false;   // bus_off: every message, both directions (one Fault per direction); error_frames
    bool error_edges = false, was_on = false;  // bus_off on a bus with error frames: its edges reported
    std::string name;         // the message ("bus"), for the report
    std::string kind;
    // drop
    double probability = 1.0;
    std::uint64_t rng = 0;     // splitmix64 state
    std::string pattern;       // "" or 0/1 per frame
    std::size_t pattern_pos = 0;
    // corrupt, bad_crc
    int byte = 0, mask = 0xFF, crc_byte = 0;
    // counter faults: the rolling counter's signal and the E2E layout (either may be absent)
    const io::can::DbcSignal* counter = nullptr;
    const io::can::E2eConfig* e2e = nullptr;
    int jump = 0;
    std::int64_t frozen = -1, frozen_e2e = -1;  // counter_freeze: the first frame's counters
    // delay, period (steps; period in ECU samples)
    std::int64_t delay_steps = 0, period_samples = 1, ecu_ratio = 1, period_start = -1;
    std::int64_t frames = 0;  // frames it acted on
  };
  struct Held {
    io::can::Frame frame;
    std::int64_t release_step = 0;
    bool twice = false;
  };
  // A fixed ring of held frames (sized at start-up from the longest delay).
  struct Ring {
    std::vector<Held> slots;
    std::size_t head = 0, count = 0;
    bool empty() const { return count == 0; }
    const Held& front() const { return slots[head]; }
    bool push(const Held& h) {
      if (count == slots.size()) return false;
      slots[(head + count) % slots.size()] = h;
      ++count;
      return true;
    }
    Held pop() {
      const Held h = slots[head];
      head = (head + 1) % slots.size();
      --count;
      return h;
    }
  };
  struct DirState {
    Ring ring;
    std::int64_t ring_overflow = 0;  // frames a full ring lost (counted, reported)
    io::can::Frame held{};
    bool holding = false, held_twice = false;
  };

  template <class Emit>
  static void deliver(DirState& ds, const io::can::Frame& f, bool twice, Emit& emit) {
    emit(f);
    if (twice) emit(f);
    if (ds.holding) {  // the frame held back by reorder: after this one
      ds.holding = false;
      emit(ds.held);
      if (ds.held_twice) emit(ds.held);
    }
  }
  static bool drops(Fault& x);
  static bool rewrite_counter(Fault& x, io::can::Frame& f);

  std::vector<Fault> faults_;
  std::uint64_t bits_ = 0;
  std::array<DirState, 2> dir_{};
};

}  // namespace ehpt::hil
