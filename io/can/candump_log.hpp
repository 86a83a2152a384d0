// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// candump -L log lines, "(1700000000.123456) vcan0 123#1122334455667788": what can-utils'
// candump -L writes and canplayer reads, and what python-can's CanutilsLogReader reads. Pure.

#include <array>
#include <cstdint>
#include <string>
#include <string_view>

#include "io/can/frame.hpp"

namespace ehpt::io::can {

// The value of a hexadecimal digit, or -1.
constexpr int hex_digit_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// Appends one line (with '\n'). Allocates only if `out` lacks the capacity (reserve it).
void append_candump_line(std::string& out, double time_s, std::string_view interface_name, const Frame& f);
// The same line in two parts, for a writer that puts several frames under one time stamp:
// "(S.UUUUUU) IFACE", then " ID#DATA\n". The time in microseconds the head shows.
std::int64_t candump_time_us(double time_s);
void append_candump_head(std::string& out, double time_s, std::string_view interface_name);
void append_candump_body(std::string& out, const Frame& f);
// An error frame in the same format (as candump -L writes one): the id with CAN_ERR_FLAG
// (0x20000000) and the error class bits, 8 hex digits, then its 8 data bytes.
void append_candump_error_line(std::string& out, double time_s, std::string_view interface_name,
                               std::uint32_t can_id_with_flag, const std::array<std::uint8_t, 8>& data);

struct CandumpLine {
  double time_s = 0.0;
  std::string_view interface_name;  // a view into the parsed line
  Frame frame;
};
// Parses one line (without or with its '\n'); false and why if it is not a classic
// standard-id data frame line.
bool parse_candump_line(std::string_view line, CandumpLine& out, const char*& why);

}  // namespace ehpt::io::can
