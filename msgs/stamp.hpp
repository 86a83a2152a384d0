// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The messages the plant and its ECU exchange (a leaf library: plant/, ecu/ and io/ include
// it, it includes nothing of ehpt). Per vehicle family one sensor message (plant -> ECU) and
// one command message (ECU -> plant), SI units in the field names, fixed size, no heap, so
// that a codec (CAN, LCM) maps them field by field and a recorded session replays them.
//
// Every message carries a Stamp: the simulation time and step of the sample it belongs to
// (for a command: of the sensor sample it was computed from) and a sequence number that the
// sender increases by one per message.

#include <cstdint>

namespace ehpt::msgs {

struct Stamp {
  double time_s = 0.0;         // simulation time of the sample
  std::int64_t step = 0;       // plant step index of the sample
  std::uint32_t sequence = 0;  // per sender, +1 per message (wraps)
};

}  // namespace ehpt::msgs
