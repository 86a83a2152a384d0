// SPDX-License-Identifier: BSD-3-Clause
// E2E protection in the style of AUTOSAR profiles 1 and 2 (io/can/e2e.hpp): the CRCs' check
// values, the CRC each profile puts in a frame (against a bit-by-bit reference written here from
// the profiles' description), every single-bit corruption caught, a foreign data id refused,
// and the counter's rules.
#include "io/can/e2e.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace ehpt::io::can {
namespace {

// Bit by bit, most significant first, over a list of bytes: the textbook CRC register.
std::uint8_t reference_crc(const std::vector<std::uint8_t>& bytes, std::uint8_t poly, std::uint8_t init, std::uint8_t xorout) {
  unsigned reg = init;
  for (const std::uint8_t b : bytes) {
    for (int bit = 7; bit >= 0; --bit) {
      const unsigned in = (b >> bit) & 1u;
      const unsigned top = (reg >> 7) & 1u;
      reg = (reg << 1) & 0xFFu;
      if (top ^ in) reg ^= poly;
    }
  }
  return static_cast<std::uint8_t>(reg ^ xorout);
}

const std::uint8_t kCheck[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};

TEST(E2e, TheCrcsHaveTheirCheckValues) {
  EXPECT_EQ(crc8_sae_j1850(kCheck), 0x4B);
  EXPECT_EQ(crc8_h2f(kCheck), 0xDF);
  const std::vector<std::uint8_t> v(std::begin(kCheck), std::end(kCheck));
  EXPECT_EQ(reference_crc(v, 0x1D, 0xFF, 0xFF), 0x4B);  // the reference agrees with the catalogue too
  EXPECT_EQ(reference_crc(v, 0x2F, 0xFF, 0xFF), 0xDF);
  EXPECT_EQ(crc8_sae_j1850({}), 0x00);
}

E2eConfig p01(P01DataIdMode mode = P01DataIdMode::kBoth) {
  E2eConfig c;
  c.profile = E2eProfile::kP01;
  c.data_id = 0x0123;
  c.id_mode = mode;
  return c;
}

E2eConfig p02() {
  E2eConfig c;
  c.profile = E2eProfile::kP02;
  for (int i = 0; i < 16; ++i) c.data_id_list[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(0x10 + 3 * i);
  return c;
}

TEST(E2e, Profile1PutsTheCrcOverTheDataIdAndTheOtherBytes) {
  std::array<std::uint8_t, 8> f{0, 0, 0x11, 0x22, 0x33, 0x44, 0x55, 0x66};
  const E2eConfig c = p01();
  e2e_protect(c, f, 5);
  EXPECT_EQ(f[1] & 0x0F, 5);  // the counter in byte 1's low nibble
  EXPECT_EQ(f[0], reference_crc({0x23, 0x01, f[1], 0x11, 0x22, 0x33, 0x44, 0x55, 0x66}, 0x1D, 0x00, 0x00));
  // the other id modes: one byte of the id, by parity or always the low one; the nibble mode
  // sends the high byte's low nibble in byte 1's high nibble and takes 0 for it in the CRC
  E2eConfig alt = p01(P01DataIdMode::kAlternating);
  e2e_protect(alt, f, 3);
  EXPECT_EQ(f[0], reference_crc({0x01, f[1], 0x11, 0x22, 0x33, 0x44, 0x55, 0x66}, 0x1D, 0x00, 0x00));
  e2e_protect(alt, f, 4);
  EXPECT_EQ(f[0], reference_crc({0x23, f[1], 0x11, 0x22, 0x33, 0x44, 0x55, 0x66}, 0x1D, 0x00, 0x00));
  e2e_protect(p01(P01DataIdMode::kLow), f, 3);
  EXPECT_EQ(f[0], reference_crc({0x23, f[1], 0x11, 0x22, 0x33, 0x44, 0x55, 0x66}, 0x1D, 0x00, 0x00));
  e2e_protect(p01(P01DataIdMode::kNibble), f, 7);
  EXPECT_EQ(f[1], 0x17);
  EXPECT_EQ(f[0], reference_crc({0x23, 0x00, 0x17, 0x11, 0x22, 0x33, 0x44, 0x55, 0x66}, 0x1D, 0x00, 0x00));
}

TEST(E2e, Profile2PutsTheCrcOverTheOtherBytesAndTheCountersDataId) {
  std::array<std::uint8_t, 8> f{0, 0xA0, 1, 2, 3, 4, 5, 6};
  const E2eConfig c = p02();
  e2e_protect(c, f, 9);
  EXPECT_EQ(f[1], 0xA9);
  EXPECT_EQ(f[0], reference_crc({0xA9, 1, 2, 3, 4, 5, 6, c.data_id_list[9]}, 0x2F, 0xFF, 0xFF));
}

TEST(E2e, ACrcAndCounterElsewhereInTheFrameAreTheirsToo) {
  // a DBC that puts the CRC last and the counter in byte 6's high nibble
  E2eConfig c = p01();
  c.crc_byte = 7;
  c.counter_bit = 52;
  ASSERT_STREQ(e2e_config_problem(c), "");
  std::array<std::uint8_t, 8> f{1, 2, 3, 4, 5, 6, 0x07, 0};
  e2e_protect(c, f, 2);
  EXPECT_EQ(f[6], 0x27);
  EXPECT_EQ(f[7], reference_crc({0x23, 0x01, 1, 2, 3, 4, 5, 6, 0x27}, 0x1D, 0x00, 0x00));
  E2eReceiver rx;
  EXPECT_EQ(e2e_check(c, f, rx), E2eResult::kOk);
}

TEST(E2e, EverySingleBitCorruptionAndAForeignIdAreRefused) {
  for (const E2eConfig& c : {p01(), p01(P01DataIdMode::kNibble), p02()}) {
    std::array<std::uint8_t, 8> good{0, 0, 9, 8, 7, 6, 5, 4};
    e2e_protect(c, good, 3);
    E2eReceiver rx;
    ASSERT_EQ(e2e_check(c, good, rx), E2eResult::kOk);
    for (int bit = 0; bit < 64; ++bit) {
      std::array<std::uint8_t, 8> bad = good;
      bad[static_cast<std::size_t>(bit / 8)] ^= static_cast<std::uint8_t>(1u << (bit % 8));
      E2eReceiver fresh;
      EXPECT_NE(e2e_check(c, bad, fresh), E2eResult::kOk) << "bit " << bit;
      EXPECT_FALSE(fresh.synced) << "a refused frame must not set the counter; bit " << bit;
    }
    E2eConfig other = c;
    other.data_id = 0x0124;
    other.data_id_list[3] ^= 0x01;
    E2eReceiver fresh;
    EXPECT_EQ(e2e_check(other, good, fresh), E2eResult::kBadCrc);
  }
  // nibble mode: a frame of another id's high nibble says so
  std::array<std::uint8_t, 8> f{};
  e2e_protect(p01(P01DataIdMode::kNibble), f, 1);
  E2eConfig other = p01(P01DataIdMode::kNibble);
  other.data_id = 0x0223;
  E2eReceiver rx;
  EXPECT_EQ(e2e_check(other, f, rx), E2eResult::kBadDataId);
  EXPECT_STREQ(e2e_result_name(E2eResult::kBadCrc), "bad_crc");
  EXPECT_STREQ(e2e_result_name(E2eResult::kBadCounter), "bad_counter");
}

TEST(E2e, TheCounterMustMoveOnByAtMostItsDelta) {
  for (const E2eConfig& base : {p01(), p02()}) {
    const int modulo = e2e_counter_modulo(base);
    EXPECT_EQ(modulo, base.profile == E2eProfile::kP01 ? 15 : 16);
    E2eConfig c = base;
    c.max_delta_counter = 2;
    E2eReceiver rx;
    std::array<std::uint8_t, 8> f{};
    const auto send = [&](int counter) {
      e2e_protect(c, f, static_cast<std::uint8_t>(counter));
      return e2e_check(c, f, rx);
    };
    EXPECT_EQ(send(7), E2eResult::kOk);  // the first frame sets the counter
    EXPECT_EQ(send(8), E2eResult::kOk);
    EXPECT_EQ(send(8), E2eResult::kRepeated);
    EXPECT_EQ(send(10), E2eResult::kOk);  // one lost: within max_delta_counter = 2
    EXPECT_EQ(send(13), E2eResult::kWrongSequence);
    EXPECT_EQ(send(14), E2eResult::kOk);  // back in order after the jump
    EXPECT_EQ(send(modulo), E2eResult::kOk);  // protect wraps: modulo is counter 0
    EXPECT_EQ(f[1] & 0x0F, 0);
    rx.reset();  // after a timeout: any counter once
    EXPECT_EQ(send(5), E2eResult::kOk);
  }
  // P01's counter 15 is not a counter
  E2eConfig c = p01();
  std::array<std::uint8_t, 8> f{};
  e2e_protect(c, f, 1);
  f[1] = static_cast<std::uint8_t>((f[1] & 0xF0) | 0x0F);
  f[0] = e2e_crc(c, f, 15);
  E2eReceiver rx;
  EXPECT_EQ(e2e_check(c, f, rx), E2eResult::kBadCounter);
}

TEST(E2e, ALayoutThatCannotWorkIsRefusedAtStartUp) {
  EXPECT_STREQ(e2e_config_problem(p01()), "");
  EXPECT_STREQ(e2e_config_problem(p02()), "");
  struct Case {
    E2eConfig c;
    std::string says;
  };
  std::vector<Case> cases;
  E2eConfig c = p01();
  c.crc_byte = 8;
  cases.push_back({c, "the CRC's byte is outside the frame"});
  c = p01();
  c.counter_bit = 10;
  cases.push_back({c, "the counter must be a nibble"});
  c = p01();
  c.counter_bit = 4;
  cases.push_back({c, "the counter's nibble is in the CRC's byte"});
  c = p01(P01DataIdMode::kNibble);
  c.data_id = 0x1234;
  cases.push_back({c, "a nibble-mode data id has at most 12 bits"});
  c = p01(P01DataIdMode::kNibble);
  c.data_id_nibble_bit = 8;
  cases.push_back({c, "the data id's nibble overlaps the CRC or the counter"});
  c = p01();
  c.max_delta_counter = 15;
  cases.push_back({c, "max_delta_counter"});
  c = p01();
  c.length_bytes = 1;
  cases.push_back({c, "the protected length must be 2..64 bytes"});
  for (const Case& k : cases) EXPECT_NE(std::string(e2e_config_problem(k.c)).find(k.says), std::string::npos) << k.says;
}

}  // namespace
}  // namespace ehpt::io::can
