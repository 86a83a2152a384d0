// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The CAN codec: pure functions from the messages (msgs/) to frames of the contract
// (io/can/contract.hpp, io/can/ehpt.dbc) and back. No I/O, no heap, no exceptions.
//   encode: physical value -> clamp to the signal's [min, max] (counted as saturated) ->
//           raw = round((value - offset) / factor) -> bits; NaN is sent as 0, also counted.
//   decode: a frame is checked (id, length, counter, every signal's range) before any of its
//           signals is used; a rejected frame changes nothing and says why.
// Quantisation rule: a value that crosses the bus is the one decode(encode(value)) gives,
// within half a resolution step (factor / 2) of what was sent. The in-process reference of a
// bus run (scenario key ecu.codec = "can") passes the ECU's inputs and outputs through exactly
// these functions, so the two runs are the same discrete-time system, bit for bit.

#include <array>
#include <cstdint>
#include <span>

#include "io/can/contract.hpp"
#include "io/can/frame.hpp"
#include "msgs/ev.hpp"
#include "msgs/psd.hpp"
#include "msgs/shev.hpp"

namespace ehpt::io::can {

// ---- signals (pure) ----
std::uint64_t payload(const Frame& f);           // data[0] is the least significant byte
void set_payload(Frame& f, std::uint64_t bits);  // len = 8
struct Raw {
  std::int64_t value = 0;
  bool saturated = false;  // the physical value was outside [min, max] or NaN
};
Raw to_raw(const SignalSpec& s, double physical);
double to_physical(const SignalSpec& s, std::int64_t raw);
void put_raw(std::uint64_t& bits, const SignalSpec& s, std::int64_t raw);
std::int64_t get_raw(std::uint64_t bits, const SignalSpec& s);  // sign-extended
bool raw_in_range(const SignalSpec& s, std::int64_t raw);       // within [min, max]

// ---- status ----
struct PlantStatus {
  std::uint32_t step = 0;   // plant step index of the sample (wraps at 2^32)
  unsigned fault = 0;       // plant::Fault bits
  bool locked = false;
  bool ecu_timeout = false; // the plant is in its safe state
};

// ---- rolling counters of the sender: +1 per frame of each id, mod 16 ----
class TxCounters {
 public:
  std::uint8_t take(std::uint32_t id);

 private:
  std::array<std::uint8_t, kMessageCount> next_{};
};

// ---- encode: frames in sending order; returns how many signals saturated ----
// A command's sampleStep is its stamp's step (the sample it answers), mod 2^16.
int encode(const msgs::PsdSensors& s, const PlantStatus& status, TxCounters& tx, std::span<Frame, kPsdSensorIds.size()> out);
int encode(const msgs::EvSensors& s, const PlantStatus& status, TxCounters& tx, std::span<Frame, kEvSensorIds.size()> out);
int encode(const msgs::ShevSensors& s, const PlantStatus& status, TxCounters& tx,
           std::span<Frame, kShevSensorIds.size()> out);
int encode(const msgs::PsdCommand& c, TxCounters& tx, std::span<Frame, kPsdCommandIds.size()> out);
int encode(const msgs::EvCommand& c, TxCounters& tx, std::span<Frame, kEvCommandIds.size()> out);
int encode(const msgs::ShevCommand& c, TxCounters& tx, std::span<Frame, kShevCommandIds.size()> out);

// ---- decode ----
enum class Reject : std::uint8_t { kNone, kUnknownId, kWrongLength, kBadCounter, kOutOfRange, kStale };
const char* reject_name(Reject r);  // "unknown_id", ...

// Stateless checks: the id is one this side accepts, the length is the contract's, every
// signal is within its range.
Reject check_frame(const Frame& f, std::span<const std::uint32_t> accepted_ids);
// The counter rule (like AUTOSAR E2E's MaxDeltaCounter): a frame is fresh if its counter moved
// on by 1..kMaxCounterJump since the last accepted frame of its id (the frames in between are
// counted as lost); a repeat (a frozen sender) or a larger jump is rejected. A rejected jump's
// counter becomes the last one (as E2E's receiver keeps the counter after a wrong sequence),
// so a sender that lost frames is heard again from its next frame in order instead of being
// shut out until its counter wraps. Without a last counter (start, or after the stream went
// stale) any counter is accepted.
inline constexpr int kMaxCounterJump = 3;
// >= 1: accepted, frames lost in between = result - 1; 0: rejected.
int counter_step(int last_counter, int counter);

// A command's freshness: how many plant steps before `sample_step` (the newest sample sent)
// the sample it answers is, from its sampleStep echo (mod 2^16). Pure.
std::uint32_t command_age_steps(const Frame& command, std::uint32_t sample_step);
// The freshness a receiver of commands asks for: a command older than max_age_steps is
// rejected as stale before its counter is looked at (so a replayed old frame cannot take the
// place of a fresh one).
struct Freshness {
  std::uint32_t sample_step = 0;    // the newest sample sent
  std::uint32_t max_age_steps = 0;  // lockstep: 0 (the command of this sample only)
};

// Applies the signals of an accepted frame to a message; fields of other frames are untouched.
void apply(const Frame& f, msgs::PsdSensors& s);  // PsdSensors1..6
void apply(const Frame& f, msgs::EvSensors& s);   // EvSensors1..3
void apply(const Frame& f, msgs::ShevSensors& s);  // ShevSensors1..4
void apply(const Frame& f, PlantStatus& status);  // PlantStatus
void apply(const Frame& f, msgs::PsdCommand& c);  // PsdCommand1..2
void apply(const Frame& f, msgs::EvCommand& c);   // EvCommand
void apply(const Frame& f, msgs::ShevCommand& c);  // ShevCommand

struct RxStats {
  std::int64_t accepted = 0;
  std::int64_t unknown_id = 0;    // not a frame this side accepts
  std::int64_t wrong_length = 0;
  std::int64_t bad_counter = 0;   // repeated or jumped too far
  std::int64_t out_of_range = 0;  // a signal outside its [min, max]
  std::int64_t stale = 0;         // a command for a sample older than the freshness allows
  std::int64_t lost = 0;          // frames missing between accepted counters
};

// One side's receive filter: the ids it accepts, their last counters, the counts.
class FrameFilter {
 public:
  explicit FrameFilter(std::span<const std::uint32_t> accepted_ids);
  // checks (with freshness: of commands), updates counters and stats
  Reject accept(const Frame& f, const Freshness* freshness = nullptr);
  void resync();                  // the stream went stale: the next counter of each id is taken as it is
  const RxStats& stats() const { return stats_; }

 private:
  std::array<std::uint32_t, kMessageCount> ids_{};
  std::array<int, kMessageCount> last_counter_{};  // -1: none
  std::size_t count_ = 0;
  RxStats stats_;
};

}  // namespace ehpt::io::can
