// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// A trajectory's fingerprint: 64-bit FNV-1a over the bits of every recorded value, in order.
// Two runs with the same hash recorded the same rows bit for bit (as their timeseries.csv,
// written with round-trip digits, are then byte-identical); any pacer (as fast as possible,
// lockstep on a bus, real time, replay) must give the same one. Not cryptographic: it tells
// runs apart, it does not defend against forgery.

#include <bit>
#include <cstdint>
#include <cstdio>
#include <span>
#include <string>

namespace ehpt::hil {

class TrajectoryHash {
 public:
  void add(std::span<const double> values) {
    for (const double v : values) {
      auto bits = std::bit_cast<std::uint64_t>(v);
      for (int i = 0; i < 8; ++i, bits >>= 8) {
        h_ ^= bits & 0xFF;
        h_ *= 0x100000001b3ULL;
      }
    }
  }
  std::uint64_t value() const { return h_; }
  std::string hex() const {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h_));
    return buf;
  }

 private:
  std::uint64_t h_ = 0xcbf29ce484222325ULL;
};

}  // namespace ehpt::hil
