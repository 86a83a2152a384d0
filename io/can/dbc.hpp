// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// A DBC file (the CAN database format of Vector's tools, the one every ECU supplier ships) read
// into plain tables: nodes, messages, signals and the attributes a plant needs (cycle time,
// send type, start values, frame format). Reading is pure (parse_dbc takes the text) and
// checks everything the run phase relies on, so that decode and encode below need no checks:
// every signal lies inside its message's payload, lengths are 1..64 bits, factors are finite
// and non-zero, a multiplexed signal has its multiplexor. Every problem names the file, the
// line and the statement; nothing in a file can crash the reader (tests/fuzz/dbc_fuzz.cpp).
//
// Supported: BO_ (standard and extended ids, CAN FD payloads up to 64 bytes), SG_ (Intel @1 and
// Motorola @0, signed and unsigned, factor and offset in any number notation, min, max, unit,
// receivers), simple multiplexing (M and mN), SIG_VALTYPE_ (IEEE float and double), VAL_,
// BA_DEF_ / BA_DEF_DEF_ / BA_ (GenMsgCycleTime, GenMsgSendType, GenSigStartValue,
// VFrameFormat; other attributes are read and ignored), CM_, VERSION, NS_, BS_, BU_,
// VAL_TABLE_, BO_TX_BU_. Extended multiplexing (SG_MUL_VAL_, "m3M") is refused with its line;
// environment variables, signal types and groups are skipped with a warning.
//
// Bit numbering is the DBC's: byte k holds bits 8k (its least significant) .. 8k+7. An Intel
// signal's start bit is its least significant bit and it grows upwards; a Motorola signal's
// start bit is its most significant bit and it grows downwards within a byte, then on to bit 7
// of the next byte (Vector's "sawtooth" numbering, as python-can, cantools and canmatrix read it).

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "io/can/frame.hpp"

namespace ehpt::io::can {

inline constexpr int kMaxDbcPayloadBytes = 64;  // CAN FD

enum class ByteOrder { kIntel, kMotorola };  // @1 little-endian, @0 big-endian
enum class SignalValueType { kInteger, kFloat32, kFloat64 };  // SIG_VALTYPE_ 0, 1, 2
enum class Multiplex { kNone, kMultiplexor, kMultiplexed };  // "", "M", "mN"

struct DbcValueName {
  std::int64_t raw = 0;
  std::string name;
};

struct DbcSignal {
  std::string name;
  int line = 0;  // of its SG_ statement
  int start_bit = 0;
  int length = 0;  // bits, 1..64
  ByteOrder byte_order = ByteOrder::kIntel;
  bool is_signed = false;  // two's complement (integer signals)
  SignalValueType value_type = SignalValueType::kInteger;
  double factor = 1.0, offset = 0.0;  // physical = raw * factor + offset
  double min = 0.0, max = 0.0;        // physical range; [0|0] in a DBC means "not given"
  std::string unit;
  std::vector<std::string> receivers;
  Multiplex multiplex = Multiplex::kNone;
  std::uint64_t multiplex_value = 0;      // kMultiplexed: present while the multiplexor has this raw value
  std::optional<double> start_value_raw;  // GenSigStartValue, raw as Vector's tools store it
  std::vector<DbcValueName> value_names;  // VAL_
  std::string comment;                    // CM_ SG_

  bool has_range() const { return min < max; }
};

struct DbcMessage {
  std::string name;
  int line = 0;  // of its BO_ statement
  std::uint32_t id = 0;  // 11 or 29 bits, without the DBC's extended flag (bit 31 of the BO_ id)
  bool extended = false;
  bool fd = false;  // CAN FD: VFrameFormat StandardCAN_FD / ExtendedCAN_FD, or more than 8 bytes
  int size_bytes = 0;
  std::vector<std::string> senders;  // BO_'s node, then BO_TX_BU_'s others ("Vector__XXX": none)
  std::vector<DbcSignal> signals;
  std::optional<int> cycle_time_ms;  // GenMsgCycleTime (the message's or the default), > 0
  std::string send_type;             // GenMsgSendType as text ("Cyclic", ...), "" if not given
  std::string comment;               // CM_ BO_

  const DbcSignal* signal(std::string_view signal_name) const;
  const DbcSignal* multiplexor() const;  // nullptr if the message has none
};

struct DbcProblem {
  int line = 0;           // 0: the file as a whole
  std::string statement;  // the statement's first line as written (shortened), "" for the file
  std::string problem;
};

struct Dbc {
  std::string file;  // as given, for messages
  std::string version;
  std::vector<std::string> nodes;
  std::vector<DbcMessage> messages;
  std::vector<DbcProblem> errors;    // any: the file must not be used
  std::vector<DbcProblem> warnings;  // read, but worth a look (skipped statements, overlaps)

  bool ok() const { return errors.empty(); }
  const DbcMessage* message(std::string_view message_name) const;
  const DbcMessage* message(std::uint32_t id, bool extended) const;
};

// "file:line: problem (statement)", the form every ehpt message has.
std::string to_string(const Dbc& dbc, const DbcProblem& p);

// Start-up: parse a DBC's text; file is used in messages only.
Dbc parse_dbc(std::string_view text, const std::string& file);
// Start-up: read (a regular file, at most io::kMaxInputFileBytes) and parse.
Dbc load_dbc(const std::string& path);

// ---- run phase: pure, no allocation; the signal must come from a Dbc without errors ----

// The signal's raw bits (zero-extended) from a payload of at least its message's size.
std::uint64_t extract_raw(const DbcSignal& s, std::span<const std::uint8_t> payload);
// raw -> physical (sign extension, IEEE reinterpretation, factor and offset).
double raw_to_physical(const DbcSignal& s, std::uint64_t raw);
inline double decode(const DbcSignal& s, std::span<const std::uint8_t> payload) {
  return raw_to_physical(s, extract_raw(s, payload));
}
// Whether a signal is in this payload: always, unless it is multiplexed and the multiplexor
// holds another value.
bool is_present(const DbcMessage& m, const DbcSignal& s, std::span<const std::uint8_t> payload);

// physical -> raw: clamped to [min, max] when the DBC gives a range, rounded to the nearest
// step, saturated to what the bits hold. NaN gives the raw value of 0 (of the start value, if
// any): a caller that must not send NaN checks before.
std::uint64_t physical_to_raw(const DbcSignal& s, double physical);
// Writes the signal's bits into the payload, leaving every other bit as it was.
void insert_raw(const DbcSignal& s, std::uint64_t raw, std::span<std::uint8_t> payload);
inline void encode(const DbcSignal& s, double physical, std::span<std::uint8_t> payload) {
  insert_raw(s, physical_to_raw(s, physical), payload);
}

// ---- the codec's rule (io/can/codec.hpp), for an integer signal of any DBC: what the plant's
// bindings (hil/bus/bus_binding.hpp) send and check, so that ehpt's own contract as a binding
// gives the codec's frames bit for bit. Pure, no allocation. ----

// The low `length` bits set (1..64).
std::uint64_t raw_mask(int length);
// The raw bits as a number: sign-extended if the signal is signed.
std::int64_t raw_to_int(const DbcSignal& s, std::uint64_t raw);
struct RawRange {
  std::int64_t lo = 0, hi = 0;
};
// Start-up: the raw values the codec's rule allows: the DBC's [min, max] as raw values, each
// rounded half away from zero (as io/can/codec.cpp raw_min, raw_max), within what the bits hold
// (an unsigned 64-bit signal: up to 2^63 - 1); the bits' range if the DBC gives none.
RawRange codec_raw_range(const DbcSignal& s);
// physical -> raw bits: clamped to [min, max] (saturated), rounded half away from zero, within
// the range (saturated if the bits cannot hold it); NaN gives raw 0 clamped into the range
// (saturated). Float
// signals: physical_to_raw, saturated if not finite or outside [min, max].
std::uint64_t encode_codec_rule(const DbcSignal& s, const RawRange& range, double physical, bool& saturated);

// Start-up: whether the signal's bits all lie within payload_bytes (load checks it; exposed for tests).
bool signal_fits(const DbcSignal& s, int payload_bytes);

}  // namespace ehpt::io::can
