// SPDX-License-Identifier: BSD-3-Clause
#include "io/number_format.hpp"

#include <charconv>
#include <cmath>

namespace ehpt::io {

void append_number(std::string& out, double value) {
  if (std::isnan(value)) {
    out += "nan";
    return;
  }
  if (std::isinf(value)) {
    out += value > 0 ? "inf" : "-inf";
    return;
  }
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, value);
  out.append(buf, r.ptr);
}

std::string number_text(double value) {
  std::string s;
  append_number(s, value);
  return s;
}

bool parse_number(const std::string& text, double& value) {
  std::size_t b = 0, e = text.size();
  while (b < e && (text[b] == ' ' || text[b] == '\t')) ++b;
  while (e > b && (text[e - 1] == ' ' || text[e - 1] == '\t' || text[e - 1] == '\r')) --e;
  if (b == e) return false;
  const char* first = text.data() + b;
  if (*first == '+') ++first;
  const auto r = std::from_chars(first, text.data() + e, value);
  return r.ec == std::errc() && r.ptr == text.data() + e;
}

}  // namespace ehpt::io
