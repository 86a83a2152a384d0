// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// A classic CAN frame as it travels between the plant and its ECU (io/can: no plant types).

#include <array>
#include <cstdint>

namespace ehpt::io::can {

// 11-bit standard ids only (the contract, io/can/ehpt.dbc, uses no extended ids).
inline constexpr std::uint32_t kMaxStandardId = 0x7FF;

struct Frame {
  std::uint32_t id = 0;               // 11-bit identifier
  std::uint8_t len = 0;               // data length, 0..8
  std::array<std::uint8_t, 8> data{}; // bytes beyond len are zero
};

inline bool operator==(const Frame& a, const Frame& b) {
  if (a.id != b.id || a.len != b.len) return false;
  for (int i = 0; i < a.len && i < 8; ++i) {
    if (a.data[static_cast<std::size_t>(i)] != b.data[static_cast<std::size_t>(i)]) return false;
  }
  return true;
}

}  // namespace ehpt::io::can
