// SPDX-License-Identifier: BSD-3-Clause
// The run-phase text helpers (io/number_format.hpp) print what printf prints for the formats
// they replace in the bus logs, the socketcand protocol and inputs.log, and put_number reads
// back to the same double.
#include "io/number_format.hpp"

#include <gtest/gtest.h>

#include <cinttypes>
#include <cmath>
#include <cstring>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <random>
#include <string>

namespace ehpt::io {
namespace {

std::string text(const char* end, const char* begin) { return std::string(begin, end); }

TEST(NumberFormat, IntegersAndHexAsPrintfWritesThem) {
  std::mt19937_64 rng(26);
  char buf[64], want[64];
  const auto check = [&](std::uint64_t u) {
    std::snprintf(want, sizeof want, "%" PRIu64, u);
    ASSERT_EQ(text(put_uint(buf, u), buf), want);
    const auto i = static_cast<std::int64_t>(u);
    std::snprintf(want, sizeof want, "%" PRId64, i);
    ASSERT_EQ(text(put_int(buf, i), buf), want);
    const auto h = static_cast<std::uint32_t>(u);
    for (const int digits : {1, 2, 3, 8}) {
      std::snprintf(want, sizeof want, "%0*" PRIX32, digits, h);
      ASSERT_EQ(text(put_hex(buf, h, digits), buf), want) << digits;
      std::snprintf(want, sizeof want, "%0*" PRIX32, digits, h & 0xFF);
      ASSERT_EQ(text(put_hex(buf, h & 0xFF, digits), buf), want) << digits;
    }
  };
  for (std::uint64_t u : {std::uint64_t{0}, std::uint64_t{9}, std::uint64_t{10}, std::uint64_t{99}, std::uint64_t{100},
                          std::uint64_t{0x7FF}, std::uint64_t{0x1FFFFFFF}, std::uint64_t{4294967295u},
                          std::numeric_limits<std::uint64_t>::max(),
                          static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::min())}) {
    check(u);
  }
  for (int k = 0; k < 100000; ++k) check(rng() >> (rng() % 64));
}

TEST(NumberFormat, SecondsWithMicrosecondsAsTheLogsHadThem) {
  std::mt19937_64 rng(7);
  char buf[64], want[64];
  for (int k = 0; k < 100000; ++k) {
    const auto us = static_cast<std::int64_t>(rng() % 4'000'000'000'000'000);  // to the year 2096 and on
    std::snprintf(want, sizeof want, "%lld.%06lld", static_cast<long long>(us / 1000000), static_cast<long long>(us % 1000000));
    ASSERT_EQ(text(put_seconds_us(buf, us), buf), want);
  }
  EXPECT_EQ(text(put_seconds_us(buf, 0), buf), "0.000000");
  EXPECT_EQ(text(put_seconds_us(buf, 1000001), buf), "1.000001");
  EXPECT_EQ(text(put_seconds_us(buf, -5), buf), "0.000000");  // no negative times in a log
}

TEST(NumberFormat, PutNumberIsAppendNumberAndReadsBack) {
  std::mt19937_64 rng(11);
  char buf[32];
  for (int k = 0; k < 100000; ++k) {
    double v;
    const std::uint64_t bits = rng();
    std::memcpy(&v, &bits, sizeof v);
    std::string want;
    append_number(want, v);
    char* end = put_number(buf, v);
    ASSERT_LE(end - buf, 24);
    ASSERT_EQ(text(end, buf), want);
    if (std::isfinite(v)) {
      ASSERT_EQ(std::strtod(want.c_str(), nullptr), v);
    }
  }
  EXPECT_EQ(text(put_number(buf, -2.2250738585072014e-308), buf), "-2.2250738585072014e-308");  // the longest: 24
  EXPECT_EQ(text(put_number(buf, std::numeric_limits<double>::infinity()), buf), "inf");
  EXPECT_EQ(text(put_number(buf, -std::numeric_limits<double>::infinity()), buf), "-inf");
  EXPECT_EQ(text(put_number(buf, std::numeric_limits<double>::quiet_NaN()), buf), "nan");
  EXPECT_EQ(text(put_number(buf, 0.1), buf), "0.1");
}

}  // namespace
}  // namespace ehpt::io
