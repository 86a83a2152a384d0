// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Faults and expectations as a scenario or a test file states them ([[fault]], [[expect]],
// [test]; docs/testing.md): plain data, validated once at load (hil/config/test_reader.cpp),
// compiled for the step loop by hil/run/fault_injector.hpp and hil/run/expectations.hpp.

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace ehpt::hil {

// What a fault does to the value of its target (a field of the sensor message the plant sends
// to the ECU, or of the command it receives), or to a component of the plant (the battery, a
// machine: plant/health.hpp). `v` is the healthy value, `t` the time since the fault became
// active.
enum class FaultEffect {
  kStuck,         // holds the value it had when the fault became active
  kFixed,         // value
  kOffset,        // v + offset
  kGain,          // v * gain
  kNoise,         // v + N(0, sigma^2), from its own seeded generator
  kDrift,         // v + rate * t
  kDelay,         // the value delay_s earlier
  kQuantise,      // round(v / step) * step
  kIntermittent,  // value for the first duty * period_s of every period_s, healthy otherwise
  kSaturate,      // clamped to [-limit, limit]
  kLoss,          // 0 (a machine off; a flag reads false)
  kNoStart,       // the engine does not run: iceON false, its power and torque requests 0
  // plant faults (target "battery", or a machine: "drive"; "gen", "mot")
  kR0Gain,          // the pack's R0 x gain
  kCapacityFade,    // the pack's capacity x (1 - fraction)
  kInternalShort,   // a self-discharge current current_A inside the pack
  kStringLoss,      // `strings` of the pack's parallel strings open
  kDerate,          // the machine's torque bound x gain
  // bus faults: on the frames of a message of the bound contract (target: its name in the
  // DBC), in the direction it travels; hil/bus/bus_faults.hpp. (kDelay on a message too.)
  kDrop,           // each frame lost (all, with `probability`, or by `pattern`)
  kDuplicate,      // each frame twice
  kReorder,        // each frame after the next one in its direction
  kCorrupt,        // byte `byte` of each frame XOR `mask`
  kCounterFreeze,  // the rolling (or E2E) counter holds the value of its first frame
  kCounterJump,    // the rolling (or E2E) counter + jump
  kBadCrc,         // the E2E CRC inverted
  kStop,           // the sender stops: no frame of the message
  kPeriod,         // the message every period_s instead of every sample
  kBusOff,         // target "bus": nothing sent or received (SocketCAN: error frames at its edges)
  kErrorFrames,    // target "bus": a CAN error frame every sample (SocketCAN only)
};
inline bool is_plant_effect(FaultEffect e) { return e >= FaultEffect::kR0Gain && e <= FaultEffect::kDerate; }
inline bool is_bus_effect(FaultEffect e) { return e >= FaultEffect::kDrop; }
const char* fault_effect_name(FaultEffect e);

// Which message the target belongs to, the plant itself, or the frames on the bus (a message
// of the bound contract, or the whole bus).
enum class FaultSide { kSensor, kCommand, kPlant, kBus };

// A condition on a plant output, `soc_1 < 0.3` (when = ..., after = ...).
struct SignalCondition {
  std::string signal;  // as in `ehpt signals`
  enum class Op { kLess, kLessEqual, kGreater, kGreaterEqual } op = Op::kLess;
  double value = 0.0;
  std::string text;    // as written
};

inline constexpr double kForever = std::numeric_limits<double>::infinity();

struct FaultSpec {
  std::string name;      // `name`, default fault1, fault2, ... (events name it: after = "NAME.start")
  std::string where;     // "file:line" of its table
  FaultEffect effect = FaultEffect::kStuck;
  std::string target;    // a field of the sensor or command message
  FaultSide side = FaultSide::kSensor;  // settled by the vehicle's reader (check_test_targets)
  double at_s = 0.0;
  double until_s = kForever;
  bool has_when = false;  // active from the step after `when` first holds, until until_s
  SignalCondition when;
  // the effect's parameters (those it does not use are refused at load)
  double value = 0.0, offset = 0.0, gain = 1.0, sigma = 0.0, rate = 0.0, delay_s = 0.0, step = 0.0;
  double period_s = 0.0, duty = 0.5, limit = 0.0;
  double fraction = 0.0, current_A = 0.0;  // capacity_fade, internal_short
  int strings = 0;                         // string_loss
  int machine = -1;                        // derate: the index of its target in the plant's kMachines
  // bus faults (hil/bus/bus_faults.hpp)
  double probability = 1.0;  // drop: each frame's chance of being lost (seeded)
  std::string pattern;       // drop: "1" lost, "0" passed, one character per frame, repeated
  int byte = 0, mask = 0xFF; // corrupt: data[byte] ^= mask
  int jump = 4;              // counter_jump: added to the counter (mod its range)
  std::uint64_t seed = 0;  // noise, drop: default 1 + the fault's index, so every fault has its own stream
};

// How an expectation is judged over time.
enum class ExpectWindow {
  kAlways,      // the bound holds at every plant step in [from_s, to_s]
  kEventually,  // at one step at least in [from_s, to_s]
  kWithin,      // at one step at least in [event, event + within_s]; the event must happen
  kAtEnd,       // at the last step (a signal), or of the run's summary figure
};
const char* expect_window_name(ExpectWindow w);

struct ExpectSpec {
  std::string name;   // `name`, default expect1, ...
  std::string where;  // "file:line" of its table
  std::string signal; // a plant output (`ehpt signals`); empty for a figure
  std::string figure; // a summary figure (soc_end, fuel_g, ...; hil/run/expectations.hpp); empty for a signal
  // the bound: min <= x <= max; |x - (value or other's x)| <= tol; |dx/dt| <= rate_max
  bool has_min = false, has_max = false, has_near = false, has_rate = false;
  double min = 0.0, max = 0.0;
  double value = 0.0, tol = 0.0;
  std::string other;  // near another signal (instead of value)
  double rate_max = 0.0;
  ExpectWindow window = ExpectWindow::kAlways;
  double from_s = 0.0, to_s = kForever;
  // kWithin: the event is a fault's start or end ("NAME.start", "NAME.end") or a condition that
  // first holds ("soc_1 < 0.5")
  std::string after;
  int after_fault = -1;  // index into the faults, or -1 for a condition
  bool after_end = false;
  SignalCondition after_condition;
  double within_s = 0.0;
};

// [test]: what a test file says about itself.
struct TestSettings {
  bool is_test = false;      // the file has a [test] table (or faults or expectations)
  bool expect_fail = false;  // written to fail: it passes when an expectation fails
  std::string where;
};

}  // namespace ehpt::hil
