// SPDX-License-Identifier: BSD-3-Clause
#include "io/can/candump_log.hpp"

#include "io/number_format.hpp"

#include <cmath>
#include <cstdio>

namespace ehpt::io::can {

namespace {

// "(seconds.micros) interface": seconds and microseconds as integers, the same text for the
// same time on every machine
void append_head(std::string& out, double time_s, std::string_view interface_name) {
  char head[32];
  char* p = head;
  *p++ = '(';
  p = io::put_seconds_us(p, candump_time_us(time_s));
  *p++ = ')';
  *p++ = ' ';
  out.append(head, p);
  out.append(interface_name);
}

// " ID#" (the id in hex, digits digits at least), then the bytes in hex, then a newline
void append_body(std::string& out, std::uint32_t id, int digits, const std::uint8_t* data, int len) {
  char body[32];
  char* p = body;
  *p++ = ' ';
  p = io::put_hex(p, id, digits);
  *p++ = '#';
  for (int i = 0; i < len && i < 8; ++i) p = io::put_hex(p, data[i], 2);
  *p++ = '\n';
  out.append(body, p);
}

}  // namespace

std::int64_t candump_time_us(double time_s) {
  const double t = std::isfinite(time_s) && time_s >= 0.0 && time_s < 9e12 ? time_s : 0.0;  // 9e12 s: us fit
  return static_cast<std::int64_t>(std::llround(t * 1e6));
}

void append_candump_head(std::string& out, double time_s, std::string_view interface_name) {
  append_head(out, time_s, interface_name);
}

void append_candump_body(std::string& out, const Frame& f) {
  if (f.extended) {
    append_body(out, f.id & kMaxExtendedId, 8, f.data.data(), f.len);
  } else {
    append_body(out, f.id & kMaxStandardId, 3, f.data.data(), f.len);
  }
}

void append_candump_line(std::string& out, double time_s, std::string_view interface_name, const Frame& f) {
  append_head(out, time_s, interface_name);
  append_candump_body(out, f);
}

void append_candump_error_line(std::string& out, double time_s, std::string_view interface_name,
                               std::uint32_t can_id_with_flag, const std::array<std::uint8_t, 8>& data) {
  append_head(out, time_s, interface_name);
  append_body(out, can_id_with_flag, 8, data.data(), 8);
}

bool parse_candump_line(std::string_view line, CandumpLine& out, const char*& why) {
  while (!line.empty() && (line.back() == '\n' || line.back() == '\r')) line.remove_suffix(1);
  if (line.size() < 3 || line.front() != '(') {
    why = "does not start with '(' and a time stamp";
    return false;
  }
  const std::size_t close = line.find(')');
  if (close == std::string_view::npos) {
    why = "no ')' after the time stamp";
    return false;
  }
  // seconds.microseconds, digits only
  double t = 0.0, scale = 0.0;
  for (std::size_t i = 1; i < close; ++i) {
    const char c = line[i];
    if (c == '.' && scale == 0.0) {
      scale = 0.1;
    } else if (c >= '0' && c <= '9') {
      if (scale == 0.0) {
        t = t * 10.0 + (c - '0');
      } else {
        t += (c - '0') * scale;
        scale /= 10.0;
      }
    } else {
      why = "the time stamp is not SECONDS.MICROSECONDS";
      return false;
    }
  }
  std::string_view rest = line.substr(close + 1);
  if (rest.empty() || rest.front() != ' ') {
    why = "no interface name after the time stamp";
    return false;
  }
  rest.remove_prefix(1);
  const std::size_t space = rest.find(' ');
  if (space == 0 || space == std::string_view::npos) {
    why = "no interface name after the time stamp";
    return false;
  }
  out.interface_name = rest.substr(0, space);
  std::string_view frame = rest.substr(space + 1);
  const std::size_t hash = frame.find('#');
  // candump's rule: up to 3 hex digits are a standard id, 8 an extended one
  if (hash == std::string_view::npos || hash == 0 || (hash > 3 && hash != 8)) {
    why = "the frame is not ID#DATA with a 3-digit (standard) or 8-digit (extended) id";
    return false;
  }
  std::uint32_t id = 0;
  for (std::size_t i = 0; i < hash; ++i) {
    const int v = hex_digit_value(frame[i]);
    if (v < 0) {
      why = "the id is not hexadecimal";
      return false;
    }
    id = id * 16 + static_cast<std::uint32_t>(v);
  }
  const std::string_view data = frame.substr(hash + 1);
  if (data.size() % 2 != 0 || data.size() > 16) {
    why = "the data is not 0..8 bytes of two hex digits";
    return false;
  }
  Frame f;
  f.id = id;
  f.extended = hash == 8;
  f.len = static_cast<std::uint8_t>(data.size() / 2);
  for (std::size_t i = 0; i < f.len; ++i) {
    const int hi = hex_digit_value(data[2 * i]), lo = hex_digit_value(data[2 * i + 1]);
    if (hi < 0 || lo < 0) {
      why = "the data is not hexadecimal";
      return false;
    }
    f.data[i] = static_cast<std::uint8_t>(hi * 16 + lo);
  }
  if (f.id > (f.extended ? kMaxExtendedId : kMaxStandardId)) {
    why = f.extended ? "the id is above 0x1FFFFFFF" : "the id is above 0x7FF";
    return false;
  }
  out.time_s = t;
  out.frame = f;
  return true;
}

}  // namespace ehpt::io::can
