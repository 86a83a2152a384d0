// SPDX-License-Identifier: BSD-3-Clause
// Fuzz harness for io::can::parse_dbc: the input bytes are a DBC file's text.
// Any bytes must give an answer (a Dbc, with or without errors), never a crash, a hang or an
// exception; a Dbc without errors must keep the promises the run phase relies on (every signal
// inside its payload, 1..64 bits, a finite non-zero factor, ids unique and in range), and
// decoding and encoding every signal of it must not touch a byte outside the payload.
// Built with libFuzzer under clang (tools/fuzz.sh), else with standalone_main.cpp (ctest smoke).

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "fuzz_checks.hpp"
#include "io/can/dbc.hpp"

namespace {

void require(bool condition, const char* what) { ehpt::fuzz::require("dbc_fuzz", condition, what); }

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace can = ehpt::io::can;
  const can::Dbc dbc = can::parse_dbc(std::string_view(reinterpret_cast<const char*>(data), size), "input.dbc");
  std::vector<std::string> errors;
  for (const auto& e : dbc.errors) errors.push_back(can::to_string(dbc, e));
  ehpt::fuzz::report("dbc_fuzz", dbc.ok(), errors);

  require(dbc.errors.size() <= 101 && dbc.warnings.size() <= 100, "the problem lists are bounded");
  for (const auto& e : dbc.errors) require(!e.problem.empty() && e.line >= 0, "every problem says what and where");
  if (!dbc.ok()) return 0;
  std::set<std::pair<std::uint32_t, bool>> ids;
  for (const can::DbcMessage& m : dbc.messages) {
    require(ids.insert({m.id, m.extended}).second, "message ids are unique");
    require(m.extended ? m.id <= can::kMaxExtendedId : m.id <= 0x7FF, "ids fit their format");
    require(m.size_bytes >= 0 && m.size_bytes <= can::kMaxDbcPayloadBytes, "sizes are CAN's");
    // a payload with guard bytes after it: decoding and encoding must stay inside
    std::vector<std::uint8_t> frame(static_cast<std::size_t>(m.size_bytes) + 8, 0xA5);
    const std::span<std::uint8_t> payload(frame.data(), static_cast<std::size_t>(m.size_bytes));
    for (const can::DbcSignal& s : m.signals) {
      require(s.length >= 1 && s.length <= 64, "lengths are 1..64 bits");
      require(can::signal_fits(s, m.size_bytes), "every signal lies inside its payload");
      require(std::isfinite(s.factor) && s.factor != 0.0 && std::isfinite(s.offset), "scaling is finite");
      require(s.multiplex != can::Multiplex::kMultiplexed || m.multiplexor() != nullptr, "a multiplexed signal has its multiplexor");
      const double v = can::decode(s, payload);
      can::encode(s, v, payload);
      can::encode(s, 1e300, payload);
      can::encode(s, -1e300, payload);
      can::encode(s, NAN, payload);
      (void)can::is_present(m, s, payload);
    }
    for (std::size_t k = payload.size(); k < frame.size(); ++k) require(frame[k] == 0xA5, "nothing written past the payload");
  }
  return 0;
}
