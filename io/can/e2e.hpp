// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// End-to-end protection of a CAN frame in the style of AUTOSAR's E2E profiles 1 and 2: a CRC
// over the frame's other bytes and a data id known to both ends (so a frame of another
// message, or of another sender, fails), and a 4-bit alive counter (so a frame repeated,
// lost or replayed is seen). Pure functions and a small receiver state; no allocation.
//
// Profile 1 (P01): CRC-8 SAE J1850 (polynomial 0x1D) with register start 0x00 and no final
//   XOR, over the data id (low byte, then high byte, as the id mode says) and then every byte
//   of the frame but the CRC's; counter 0..14 (15 is invalid); the id modes of P01: both bytes,
//   alternating by counter parity, the low byte only, or "nibble" (the low byte in the CRC, the
//   high byte's low nibble sent in the frame).
// Profile 2 (P02): CRC-8H2F (polynomial 0x2F, start 0xFF, final XOR 0xFF) over every byte of
//   the frame but the CRC's and then DataIDList[counter]; counter 0..15.
// AUTOSAR fixes the CRC at byte 0 and the counter in the low nibble of byte 1 for its standard
// variants (1A, 2); a DBC's own layout may place them elsewhere, so both are configurable.

#include <array>
#include <cstdint>
#include <span>

namespace ehpt::io::can {

// The CRCs themselves, AUTOSAR's parameters (their check values over "123456789": 0x4B, 0xDF).
std::uint8_t crc8_sae_j1850(std::span<const std::uint8_t> data);  // init 0xFF, final XOR 0xFF
std::uint8_t crc8_h2f(std::span<const std::uint8_t> data);        // init 0xFF, final XOR 0xFF
// The raw register form both profiles chain through: one byte into a register.
std::uint8_t crc8_update(std::uint8_t crc, std::uint8_t byte, std::uint8_t polynomial);

enum class E2eProfile { kP01, kP02 };
enum class P01DataIdMode { kBoth, kAlternating, kLow, kNibble };

struct E2eConfig {
  E2eProfile profile = E2eProfile::kP01;
  int length_bytes = 8;      // the bytes the CRC covers: the frame's size
  int crc_byte = 0;          // where the CRC is
  int counter_bit = 8;       // the counter's nibble: a multiple of 4 (8: byte 1's low nibble)
  std::uint16_t data_id = 0;                    // P01
  P01DataIdMode id_mode = P01DataIdMode::kBoth;  // P01
  int data_id_nibble_bit = 12;                  // P01 kNibble: where the id's high nibble goes
  std::array<std::uint8_t, 16> data_id_list{};  // P02: one id per counter value
  int max_delta_counter = 1;                    // the receiver accepts counter jumps up to this
};

// Start-up: "" or what is wrong with the layout (a byte outside the frame, a nibble that is
// not one, the CRC's byte overlapping the counter's).
const char* e2e_config_problem(const E2eConfig& c);

// The counter's range: 15 for P01 (0..14), 16 for P02.
inline int e2e_counter_modulo(const E2eConfig& c) { return c.profile == E2eProfile::kP01 ? 15 : 16; }

// Run phase: the CRC the frame must carry (the CRC byte itself is skipped).
std::uint8_t e2e_crc(const E2eConfig& c, std::span<const std::uint8_t> frame, std::uint8_t counter);

// Run phase, the sender: writes the counter (and P01's id nibble), then the CRC.
void e2e_protect(const E2eConfig& c, std::span<std::uint8_t> frame, std::uint8_t counter);

enum class E2eResult {
  kOk,
  kBadCrc,       // the CRC does not match (a corrupted, forged or foreign frame)
  kBadDataId,    // P01 kNibble: the id nibble in the frame is not ours
  kBadCounter,   // a counter outside the profile's range
  kRepeated,     // the same counter as the last accepted frame
  kWrongSequence,  // a jump beyond max_delta_counter: frames lost
};
const char* e2e_result_name(E2eResult r);  // "ok", "bad_crc", ...

// The receiver's memory: the last counter accepted. A fresh state (or reset after a timeout)
// accepts any counter once.
struct E2eReceiver {
  bool synced = false;
  std::uint8_t last_counter = 0;
  void reset() { synced = false; }
};

// Run phase, the receiver: checks the frame; only kOk means "apply it". The counter of a frame
// that passed its CRC is remembered (also after kWrongSequence), so the next one in order is ok.
E2eResult e2e_check(const E2eConfig& c, std::span<const std::uint8_t> frame, E2eReceiver& rx);

}  // namespace ehpt::io::can
