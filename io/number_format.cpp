// SPDX-License-Identifier: BSD-3-Clause
#include "io/number_format.hpp"

#include <algorithm>
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

namespace {
// "00" .. "99": two digits per division
constexpr char kPairs[] =
    "00010203040506070809101112131415161718192021222324252627282930313233343536373839"
    "40414243444546474849505152535455565758596061626364656667686970717273747576777879"
    "8081828384858687888990919293949596979899";
}  // namespace

char* put_uint(char* p, std::uint64_t v) {
  char digits[20];
  int n = 20;
  while (v >= 100) {
    const std::uint64_t pair = v % 100;
    v /= 100;
    digits[--n] = kPairs[2 * pair + 1];
    digits[--n] = kPairs[2 * pair];
  }
  if (v >= 10) {
    digits[--n] = kPairs[2 * v + 1];
    digits[--n] = kPairs[2 * v];
  } else {
    digits[--n] = static_cast<char>('0' + v);
  }
  return std::copy(digits + n, digits + 20, p);
}

char* put_int(char* p, std::int64_t v) {
  if (v < 0) {
    *p++ = '-';
    return put_uint(p, ~static_cast<std::uint64_t>(v) + 1);  // also INT64_MIN
  }
  return put_uint(p, static_cast<std::uint64_t>(v));
}

char* put_hex(char* p, std::uint32_t v, int min_digits) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  if (min_digits == 2 && v <= 0xFF) {  // a payload byte: the common case
    p[0] = kHex[v >> 4];
    p[1] = kHex[v & 0xF];
    return p + 2;
  }
  int n = 1;
  while (n < 8 && (v >> (4 * n)) != 0) ++n;
  n = std::max(n, std::min(min_digits, 8));
  for (int i = n - 1; i >= 0; --i) *p++ = kHex[(v >> (4 * i)) & 0xF];
  return p;
}

char* put_seconds_us(char* p, std::int64_t us) {
  if (us < 0) us = 0;
  p = put_uint(p, static_cast<std::uint64_t>(us / 1000000));
  *p++ = '.';
  auto frac = static_cast<std::uint32_t>(us % 1000000);
  for (int i = 4; i >= 0; i -= 2) {  // three pairs of digits, the last pair first
    const std::uint32_t pair = frac % 100;
    frac /= 100;
    p[i] = kPairs[2 * pair];
    p[i + 1] = kPairs[2 * pair + 1];
  }
  return p + 6;
}

char* put_number(char* p, double value) {
  if (std::isnan(value)) return std::copy_n("nan", 3, p);
  if (std::isinf(value)) return value > 0 ? std::copy_n("inf", 3, p) : std::copy_n("-inf", 4, p);
  return std::to_chars(p, p + 24, value).ptr;  // the shortest round trip of a double fits in 24
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
