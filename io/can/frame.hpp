// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// A classic CAN frame as it travels between the plant and its ECU (io/can: no plant types).

#include <array>
#include <cstdint>

namespace ehpt::io::can {

// ehpt's own contract (io/can/ehpt.dbc) uses 11-bit ids; a user's DBC (hil/bus/bus_binding.hpp)
// may use 29-bit ones.
inline constexpr std::uint32_t kMaxStandardId = 0x7FF;
inline constexpr std::uint32_t kMaxExtendedId = 0x1FFFFFFF;
// In a list of ids (a receive filter), an extended id carries this flag, as the kernel's can_id does.
inline constexpr std::uint32_t kExtendedIdFlag = 0x80000000;

struct Frame {
  std::uint32_t id = 0;               // 11-bit identifier, or 29-bit if extended
  std::uint8_t len = 0;               // data length, 0..8
  bool extended = false;              // a 29-bit id (CAN 2.0B)
  std::array<std::uint8_t, 8> data{}; // bytes beyond len are zero
};

inline bool operator==(const Frame& a, const Frame& b) {
  if (a.id != b.id || a.len != b.len || a.extended != b.extended) return false;
  for (int i = 0; i < a.len && i < 8; ++i) {
    if (a.data[static_cast<std::size_t>(i)] != b.data[static_cast<std::size_t>(i)]) return false;
  }
  return true;
}

}  // namespace ehpt::io::can
