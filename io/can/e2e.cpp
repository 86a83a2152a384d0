// SPDX-License-Identifier: BSD-3-Clause
#include "io/can/e2e.hpp"

namespace ehpt::io::can {

namespace {

constexpr std::uint8_t kPolySaeJ1850 = 0x1D, kPolyH2f = 0x2F;

std::uint8_t read_nibble(std::span<const std::uint8_t> frame, int bit) {
  const std::uint8_t byte = frame[static_cast<std::size_t>(bit / 8)];
  return bit % 8 == 0 ? byte & 0x0F : byte >> 4;
}

void write_nibble(std::span<std::uint8_t> frame, int bit, std::uint8_t value) {
  std::uint8_t& byte = frame[static_cast<std::size_t>(bit / 8)];
  byte = bit % 8 == 0 ? static_cast<std::uint8_t>((byte & 0xF0) | (value & 0x0F))
                      : static_cast<std::uint8_t>((byte & 0x0F) | (value << 4));
}

// the frame's bytes but the CRC's, into the register
std::uint8_t over_frame(std::uint8_t crc, const E2eConfig& c, std::span<const std::uint8_t> frame, std::uint8_t poly) {
  for (int i = 0; i < c.length_bytes; ++i) {
    if (i != c.crc_byte) crc = crc8_update(crc, frame[static_cast<std::size_t>(i)], poly);
  }
  return crc;
}

}  // namespace

std::uint8_t crc8_update(std::uint8_t crc, std::uint8_t byte, std::uint8_t polynomial) {
  crc ^= byte;
  for (int k = 0; k < 8; ++k) crc = static_cast<std::uint8_t>(crc & 0x80 ? (crc << 1) ^ polynomial : crc << 1);
  return crc;
}

std::uint8_t crc8_sae_j1850(std::span<const std::uint8_t> data) {
  std::uint8_t crc = 0xFF;
  for (const std::uint8_t b : data) crc = crc8_update(crc, b, kPolySaeJ1850);
  return crc ^ 0xFF;
}

std::uint8_t crc8_h2f(std::span<const std::uint8_t> data) {
  std::uint8_t crc = 0xFF;
  for (const std::uint8_t b : data) crc = crc8_update(crc, b, kPolyH2f);
  return crc ^ 0xFF;
}

const char* e2e_config_problem(const E2eConfig& c) {
  if (c.length_bytes < 2 || c.length_bytes > 64) return "the protected length must be 2..64 bytes";
  if (c.crc_byte < 0 || c.crc_byte >= c.length_bytes) return "the CRC's byte is outside the frame";
  if (c.counter_bit < 0 || c.counter_bit % 4 != 0 || c.counter_bit / 8 >= c.length_bytes) {
    return "the counter must be a nibble (a bit offset that is a multiple of 4) inside the frame";
  }
  if (c.counter_bit / 8 == c.crc_byte) return "the counter's nibble is in the CRC's byte";
  if (c.profile == E2eProfile::kP01 && c.id_mode == P01DataIdMode::kNibble) {
    if (c.data_id_nibble_bit < 0 || c.data_id_nibble_bit % 4 != 0 || c.data_id_nibble_bit / 8 >= c.length_bytes) {
      return "the data id's nibble must be a nibble inside the frame";
    }
    if (c.data_id_nibble_bit / 8 == c.crc_byte || c.data_id_nibble_bit == c.counter_bit) {
      return "the data id's nibble overlaps the CRC or the counter";
    }
    if (c.data_id > 0x0FFF) return "a nibble-mode data id has at most 12 bits";
  }
  if (c.max_delta_counter < 1 || c.max_delta_counter >= e2e_counter_modulo(c)) {
    return "max_delta_counter must be at least 1 and below the counter's range";
  }
  return "";
}

std::uint8_t e2e_crc(const E2eConfig& c, std::span<const std::uint8_t> frame, std::uint8_t counter) {
  if (c.profile == E2eProfile::kP02) {
    const std::uint8_t crc = over_frame(0xFF, c, frame, kPolyH2f);
    return crc8_update(crc, c.data_id_list[counter & 0x0F], kPolyH2f) ^ 0xFF;
  }
  const auto lo = static_cast<std::uint8_t>(c.data_id & 0xFF);
  const auto hi = static_cast<std::uint8_t>(c.data_id >> 8);
  std::uint8_t crc = 0x00;
  switch (c.id_mode) {
    case P01DataIdMode::kBoth:
      crc = crc8_update(crc8_update(crc, lo, kPolySaeJ1850), hi, kPolySaeJ1850);
      break;
    case P01DataIdMode::kAlternating:
      crc = crc8_update(crc, counter % 2 == 0 ? lo : hi, kPolySaeJ1850);
      break;
    case P01DataIdMode::kLow:
      crc = crc8_update(crc, lo, kPolySaeJ1850);
      break;
    case P01DataIdMode::kNibble:  // the high byte is sent (its low nibble); the CRC takes 0 for it
      crc = crc8_update(crc8_update(crc, lo, kPolySaeJ1850), 0x00, kPolySaeJ1850);
      break;
  }
  return over_frame(crc, c, frame, kPolySaeJ1850);
}

void e2e_protect(const E2eConfig& c, std::span<std::uint8_t> frame, std::uint8_t counter) {
  counter = static_cast<std::uint8_t>(counter % e2e_counter_modulo(c));
  write_nibble(frame, c.counter_bit, counter);
  if (c.profile == E2eProfile::kP01 && c.id_mode == P01DataIdMode::kNibble) {
    write_nibble(frame, c.data_id_nibble_bit, static_cast<std::uint8_t>((c.data_id >> 8) & 0x0F));
  }
  frame[static_cast<std::size_t>(c.crc_byte)] = e2e_crc(c, frame, counter);
}

const char* e2e_result_name(E2eResult r) {
  switch (r) {
    case E2eResult::kOk: return "ok";
    case E2eResult::kBadCrc: return "bad_crc";
    case E2eResult::kBadDataId: return "bad_data_id";
    case E2eResult::kBadCounter: return "bad_counter";
    case E2eResult::kRepeated: return "repeated";
    case E2eResult::kWrongSequence: return "wrong_sequence";
  }
  return "?";
}

E2eResult e2e_check(const E2eConfig& c, std::span<const std::uint8_t> frame, E2eReceiver& rx) {
  const std::uint8_t counter = read_nibble(frame, c.counter_bit);
  const int modulo = e2e_counter_modulo(c);
  if (counter >= modulo) return E2eResult::kBadCounter;
  if (c.profile == E2eProfile::kP01 && c.id_mode == P01DataIdMode::kNibble &&
      read_nibble(frame, c.data_id_nibble_bit) != ((c.data_id >> 8) & 0x0F)) {
    return E2eResult::kBadDataId;
  }
  if (frame[static_cast<std::size_t>(c.crc_byte)] != e2e_crc(c, frame, counter)) return E2eResult::kBadCrc;
  // a genuine frame: its counter against the last one
  const bool first = !rx.synced;
  const int delta = (counter - rx.last_counter + modulo) % modulo;
  rx.synced = true;
  rx.last_counter = counter;
  if (first) return E2eResult::kOk;
  if (delta == 0) return E2eResult::kRepeated;
  if (delta > c.max_delta_counter) return E2eResult::kWrongSequence;
  return E2eResult::kOk;
}

}  // namespace ehpt::io::can
