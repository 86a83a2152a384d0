// SPDX-License-Identifier: BSD-3-Clause
// ehpt's DBC reader (io/can/dbc.hpp): each feature on hand-written text with the value it must
// give, each refusal with its file:line, and encode/decode on known bit patterns. The same
// reader is compared with python3-canmatrix on random payloads in tests/io/dbc_crosscheck_test.py.
#include "io/can/dbc.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "test_plants.hpp"

namespace ehpt::io::can {
namespace {

const char* kHeader = "VERSION \"\"\n\nNS_ :\n\tCM_\n\tBA_\n\nBS_:\n\nBU_: Ecu Plant\n\n";  // lines 1..10

Dbc parse(const std::string& body) { return parse_dbc(std::string(kHeader) + body, "my.dbc"); }

std::string problems(const Dbc& d) {
  std::string s;
  for (const auto& e : d.errors) s += "\n  " + to_string(d, e);
  for (const auto& w : d.warnings) s += "\n  warning: " + to_string(d, w);
  return s.empty() ? " (none)" : s;
}

TEST(Dbc, ReadsMessagesSignalsAndTheirAttributes) {
  const Dbc d = parse(
      "BO_ 2566834709 Engine: 8 Ecu\n"                                             // 11
      " SG_ Torque : 7|16@0- (2.5E-002,-1e+1) [-800|800] \"Nm\" Plant,Ecu\n"      // 12
      " SG_ Mode : 16|3@1+ (1,0) [0|0] \"\" Plant\n"                              // 13
      "\n"
      "BO_ 1024 Status: 64 Plant\n"                                                // 15
      " SG_ Page M : 0|8@1+ (1,0) [0|255] \"\" Ecu\n"
      " SG_ Volts m1 : 8|32@1- (1,0) [0|0] \"V\" Ecu\n"
      "\n"
      "BO_TX_BU_ 1024 : Plant,Ecu;\n"
      "CM_ BO_ 1024 \"the plant's \\\"status\\\"\nover two lines\";\n"
      "CM_ SG_ 2566834709 Torque \"engine torque\";\n"
      "BA_DEF_ BO_ \"GenMsgCycleTime\" INT 0 65535;\n"
      "BA_DEF_ BO_ \"GenMsgSendType\" ENUM \"Cyclic\",\"Spontaneous\";\n"
      "BA_DEF_ SG_ \"GenSigStartValue\" FLOAT 0 1e6;\n"
      "BA_DEF_DEF_ \"GenMsgCycleTime\" 100;\n"
      "BA_DEF_DEF_ \"GenMsgSendType\" \"Cyclic\";\n"
      "BA_ \"GenMsgCycleTime\" BO_ 2566834709 20;\n"
      "BA_ \"GenMsgSendType\" BO_ 1024 1;\n"
      "BA_ \"GenSigStartValue\" SG_ 2566834709 Torque 400;\n"
      "VAL_ 2566834709 Mode 0 \"Off\" 1 \"On\" -1 \"Neg\" ;\n"
      "SIG_VALTYPE_ 1024 Volts : 1;\n");
  ASSERT_TRUE(d.ok()) << problems(d);
  EXPECT_TRUE(d.warnings.empty()) << problems(d);
  EXPECT_EQ(d.nodes, (std::vector<std::string>{"Ecu", "Plant"}));
  ASSERT_EQ(d.messages.size(), 2u);
  const DbcMessage& e = d.messages[0];
  EXPECT_EQ(e.name, "Engine");
  EXPECT_EQ(e.line, 11);
  EXPECT_EQ(e.id, 0x18FECA15u);
  EXPECT_TRUE(e.extended);
  EXPECT_FALSE(e.fd);
  EXPECT_EQ(e.size_bytes, 8);
  EXPECT_EQ(e.senders, (std::vector<std::string>{"Ecu"}));
  EXPECT_EQ(e.cycle_time_ms, 20);
  EXPECT_EQ(e.send_type, "Cyclic");  // the default
  ASSERT_EQ(e.signals.size(), 2u);
  const DbcSignal& t = e.signals[0];
  EXPECT_EQ(t.line, 12);
  EXPECT_EQ(t.start_bit, 7);
  EXPECT_EQ(t.length, 16);
  EXPECT_EQ(t.byte_order, ByteOrder::kMotorola);
  EXPECT_TRUE(t.is_signed);
  EXPECT_EQ(t.factor, 0.025);
  EXPECT_EQ(t.offset, -10.0);
  EXPECT_EQ(t.min, -800.0);
  EXPECT_EQ(t.max, 800.0);
  EXPECT_EQ(t.unit, "Nm");
  EXPECT_EQ(t.receivers, (std::vector<std::string>{"Plant", "Ecu"}));
  EXPECT_EQ(t.start_value_raw, 400.0);
  EXPECT_EQ(t.comment, "engine torque");
  const DbcSignal& mode = e.signals[1];
  EXPECT_FALSE(mode.has_range());
  ASSERT_EQ(mode.value_names.size(), 3u);
  EXPECT_EQ(mode.value_names[2].raw, -1);
  EXPECT_EQ(mode.value_names[2].name, "Neg");
  EXPECT_FALSE(mode.start_value_raw.has_value());  // BA_DEF_ without BA_DEF_DEF_: none

  const DbcMessage& s = d.messages[1];
  EXPECT_FALSE(s.extended);
  EXPECT_TRUE(s.fd);
  EXPECT_EQ(s.size_bytes, 64);
  EXPECT_EQ(s.senders, (std::vector<std::string>{"Plant", "Ecu"}));
  EXPECT_EQ(s.cycle_time_ms, 100);  // BA_DEF_DEF_
  EXPECT_EQ(s.send_type, "Spontaneous");  // the ENUM's index 1
  EXPECT_EQ(s.comment, "the plant's \"status\"\nover two lines");
  ASSERT_NE(s.multiplexor(), nullptr);
  EXPECT_EQ(s.multiplexor()->name, "Page");
  EXPECT_EQ(s.signals[1].multiplex, Multiplex::kMultiplexed);
  EXPECT_EQ(s.signals[1].multiplex_value, 1u);
  EXPECT_EQ(s.signals[1].value_type, SignalValueType::kFloat32);
  EXPECT_EQ(d.message("Status"), &s);
  EXPECT_EQ(d.message(0x18FECA15u, true), &e);
  EXPECT_EQ(d.message(0x18FECA15u, false), nullptr);
}

TEST(Dbc, VectorsOwnExtrasAreReadOrSkipped) {
  // VECTOR__INDEPENDENT_SIG_MSG holds signals of no frame; VAL_TABLE_, EV_, a BU_ comment
  const Dbc d = parse(
      "VAL_TABLE_ Onoff 1 \"On\" 0 \"Off\" ;\n"
      "BO_ 3221225472 VECTOR__INDEPENDENT_SIG_MSG: 0 Vector__XXX\n"
      " SG_ Orphan : 0|8@1+ (1,0) [0|0] \"\" Vector__XXX\n"
      "BO_ 100 A: 8 Ecu\n"
      " SG_ X : 0|8@1+ (1,0) [0|0] \"\" Vector__XXX\n"
      "EV_ Env: 0 [0|1] \"\" 0 1 DUMMY_NODE_VECTOR0 Vector__XXX;\n"
      "CM_ BU_ Ecu \"the ECU\";\n"
      "CM_ BO_ 3221225472 \"ignored\";\n"
      "CM_ \"the file\";\n");
  ASSERT_TRUE(d.ok()) << problems(d);
  ASSERT_EQ(d.messages.size(), 1u);
  EXPECT_EQ(d.messages[0].name, "A");
  ASSERT_EQ(d.warnings.size(), 1u) << problems(d);
  EXPECT_EQ(to_string(d, d.warnings[0]),
            "my.dbc:16: EV_ is not used by ehpt; skipped (EV_ Env: 0 [0|1] \"\" 0 1 DUMMY_NODE_VECTOR0 Vector__XXX;)");
}

// Each refusal: the line it names and what it says.
TEST(Dbc, EveryProblemNamesItsLine) {
  struct Case {
    std::string body;
    int line;
    std::string says;
  };
  const std::vector<Case> cases = {
      {"BO_ 2048 A: 8 Ecu\n", 11, "standard id 2048 (0x800) has more than 11 bits"},
      {"BO_ 4294967295 A: 8 Ecu\n", 11, "extended id 0x7FFFFFFF has more than 29 bits"},
      {"BO_ 1 A: 9 Ecu\n", 11, "size 9 bytes is no CAN frame length"},
      {"BO_ 1 A: 65 Ecu\n", 11, "the message size in bytes '65' must be a whole number in [0, 64]"},
      {"BO_ 1 A: 8 Ecu\n SG_ S : 60|8@1+ (1,0) [0|0] \"\" Ecu\n", 12, "does not fit in the 8 bytes of A"},
      {"BO_ 1 A: 2 Ecu\n SG_ S : 7|17@0+ (1,0) [0|0] \"\" Ecu\n", 12, "does not fit in the 2 bytes of A"},
      {"BO_ 1 A: 8 Ecu\n SG_ S : 0|0@1+ (1,0) [0|0] \"\" Ecu\n", 12, "the length in bits '0' must be a whole number in [1, 64]"},
      {"BO_ 1 A: 8 Ecu\n SG_ S : 0|65@1+ (1,0) [0|0] \"\" Ecu\n", 12, "'65' must be a whole number in [1, 64]"},
      {"BO_ 1 A: 8 Ecu\n SG_ S : 0|8@1+ (0,0) [0|0] \"\" Ecu\n", 12, "factor 0"},
      {"BO_ 1 A: 8 Ecu\n SG_ S : 0|8@1+ (1,0) [5|1] \"\" Ecu\n", 12, "minimum 5 is above the maximum 1"},
      {"BO_ 1 A: 8 Ecu\n SG_ S : 0|8@1+ (1e400,0) [0|0] \"\" Ecu\n", 12, "the factor '1e400' is not a finite number"},
      {"BO_ 1 A: 8 Ecu\n SG_ S : 0|8@1* (1,0) [0|0] \"\" Ecu\n", 12, "unexpected character '*'"},
      {"BO_ 1 A: 8 Ecu\n SG_ S : 0|8@1 (1,0) [0|0] \"\" Ecu\n", 12, "expected '+' (unsigned) or '-' (signed), found '('"},
      {" SG_ S : 0|8@1+ (1,0) [0|0] \"\" Ecu\n", 11, "SG_ before any BO_"},
      {"BO_ 1 A: 8 Ecu\n SG_ S : 0|8@1+ (1,0) [0|0] \"unit Ecu\n", 12, "a string that is never closed"},
      {"BO_ 1 A: 8 Ecu\nFOO_ 1 2;\n", 12, "unknown statement 'FOO_'"},
      {"BO_ 1 A: 8 Ecu\n SG_ S m1M : 0|8@1+ (1,0) [0|0] \"\" Ecu\n", 12, "extended multiplexing ('m1M') is not supported"},
      {"SG_MUL_VAL_ 1 S M 1-1;\n", 11, "extended multiplexing (SG_MUL_VAL_) is not supported"},
      {"BO_ 1 A: 8 Ecu\nBO_ 1 B: 8 Ecu\n", 12, "message id 1 (0x1) is defined twice"},
      {"BO_ 1 A: 8 Ecu\nBO_ 2 A: 8 Ecu\n", 12, "message name A is defined twice"},
      {"BO_ 1 A: 8 Ecu\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" Ecu\n SG_ S : 8|8@1+ (1,0) [0|0] \"\" Ecu\n", 13,
       "signal S is defined twice in A"},
      {"BO_ 1 A: 8 Ecu\n SG_ S m1 : 0|8@1+ (1,0) [0|0] \"\" Ecu\n", 12, "is multiplexed (m1) but A has no multiplexor"},
      {"BO_ 1 A: 8 Ecu\n SG_ M1 M : 0|8@1+ (1,0) [0|0] \"\" Ecu\n SG_ M2 M : 8|8@1+ (1,0) [0|0] \"\" Ecu\n", 11,
       "A has more than one multiplexor"},
      {"BO_ 1 A: 8 Ecu\n SG_ S : 0|16@1- (1,0) [0|0] \"\" Ecu\nSIG_VALTYPE_ 1 S : 1;\n", 13,
       "signal S is 16 bits long; an IEEE float has 32"},
      {"BO_ 1 A: 8 Ecu\nBA_DEF_ BO_ \"GenMsgCycleTime\" INT 0 65535;\nBA_ \"GenMsgCycleTime\" BO_ 1 2.5;\n", 13,
       "GenMsgCycleTime of A must be a whole number of ms"},
      {"BO_ 1 A: 8 Ecu\nBA_DEF_ BO_ \"GenMsgSendType\" ENUM \"Cyclic\";\nBA_ \"GenMsgSendType\" BO_ 1 3;\n", 13,
       "GenMsgSendType = 3 is no index of its ENUM (0..0)"},
      {"BO_ 1 A: 8 Ecu\nBA_DEF_ BO_ \"X\" WORD;\n", 12, "attribute type 'WORD'"},
      {"BO_ 1 A: 8 Ecu\nCM_ BO_ 1 \"text\"\nBO_ 2 B: 8 Ecu\n", 12, "expected ';' at the end of the statement"},
      {"BO_ 1 A: 8 Ecu\n SG_ M M : 0|8@1+ (1,0) [0|0] \"\" Ecu\n SG_ S m99999999999999999999 : 8|8@1+ (1,0) [0|0] \"\" Ecu\n",
       13, "multiplex value 'm99999999999999999999' is too large"},
      {"BO_ 1 A: 8 Ecu\n SG_ M M : 0|33@1+ (1,0) [0|0] \"\" Ecu\n", 12, "multiplexor M has more than 32 bits"},
      {"BO_ 1 A: 8 Ecu\nCM_ XX_ 1 \"t\";\n", 12, "CM_ of 'XX_': expected BU_, BO_, SG_ or EV_"},
      {"BO_ 1 A: 8 Ecu\nBA_ \"X\" XX_ 1 2;\n", 12, "BA_ of 'XX_': expected BU_, BO_, SG_ or EV_"},
      {"BO_ 1 A: 8 Ecu\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" Ecu\nBA_DEF_ SG_ \"GenSigStartValue\" STRING;\n"
       "BA_ \"GenSigStartValue\" SG_ 1 S \"abc\";\n", 14, "GenSigStartValue of S must be a number"},
      {"BO_ 1 A: 8 Ecu\nBA_DEF_ BO_ \"GenMsgCycleTime\" INT 0 65535;\nBA_ \"GenMsgCycleTime\" BO_ 1 -5;\n", 13,
       "GenMsgCycleTime of A must be a whole number of ms in [0, 3600000]"},
  };
  for (const Case& c : cases) {
    const Dbc d = parse(c.body);
    bool named = false;
    for (const auto& e : d.errors) {
      named = named || (e.line == c.line && e.problem.find(c.says) != std::string::npos);
    }
    EXPECT_TRUE(named) << "line " << c.line << ": \"" << c.says << "\"; found:" << problems(d) << "\nin:\n" << c.body;
  }
}

TEST(Dbc, AMessageWithAnErrorTakesItsSignalsWithItAndTheRestIsRead) {
  // BO_ without its sender: an error at 11; its SG_ line is not blamed on another message
  const Dbc d = parse(
      "BO_ 1 A: 8\n"
      " SG_ S : 0|8@1+ (1,0) [0|0] \"\" Ecu\n"
      "BO_ 2 B: 8 Ecu\n"
      " SG_ T : 0|8@1+ (1,0) [0|0] \"\" Ecu\n");
  ASSERT_EQ(d.errors.size(), 1u) << problems(d);
  EXPECT_EQ(to_string(d, d.errors[0]), "my.dbc:11: expected the sending node, found 'SG_' (BO_ 1 A: 8)");
  ASSERT_EQ(d.messages.size(), 1u);
  EXPECT_EQ(d.messages[0].name, "B");
  ASSERT_EQ(d.messages[0].signals.size(), 1u);
  EXPECT_EQ(d.messages[0].signals[0].name, "T");
}

TEST(Dbc, WarnsOfOverlapsAndReferencesToNothing) {
  const Dbc d = parse(
      "BO_ 1 A: 8 Ecu\n"
      " SG_ M M : 0|4@1+ (1,0) [0|0] \"\" Ecu\n"
      " SG_ P0 m0 : 8|8@1+ (1,0) [0|0] \"\" Ecu\n"
      " SG_ P1 m1 : 8|8@1+ (1,0) [0|0] \"\" Ecu\n"  // shares bits with P0, never at the same time
      " SG_ X : 3|4@1+ (1,0) [0|0] \"\" Ecu\n"      // shares bit 3 with M
      "CM_ SG_ 1 Nope \"?\";\n"
      "BA_DEF_ BO_ \"GenMsgCycleTime\" INT 0 65535;\n"
      "BA_ \"GenMsgCycleTime\" BO_ 7 10;\n");
  ASSERT_TRUE(d.ok()) << problems(d);
  ASSERT_EQ(d.warnings.size(), 3u) << problems(d);
  std::string all = problems(d);
  EXPECT_NE(all.find("my.dbc:15: signal X shares bit 3 with M in A"), std::string::npos) << all;
  EXPECT_NE(all.find("my.dbc:16: a comment of signal Nope, which message A does not have; ignored"), std::string::npos) << all;
  EXPECT_NE(all.find("my.dbc:18: BA_ of message 7, which no BO_ defines; ignored"), std::string::npos) << all;
}

// A message of very many signals (a generated or hostile file) is read in bounded time: the
// overlap check is skipped for it, with a warning that says so.
TEST(Dbc, AMessageOfThousandsOfSignalsIsReadWithoutTheOverlapCheck) {
  std::string body = "BO_ 1 A: 64 Ecu\n SG_ Page M : 480|32@1+ (1,0) [0|0] \"\" Ecu\n";
  for (int i = 0; i < 3000; ++i) {
    body += " SG_ s" + std::to_string(i) + " m" + std::to_string(i) + " : 0|64@1+ (1,0) [0|0] \"\" Ecu\n";
  }
  for (int i = 0; i < 3000; ++i) body += "VAL_ 1 s" + std::to_string(i) + " 0 \"zero\" ;\n";
  const Dbc d = parse(body);
  ASSERT_TRUE(d.ok()) << problems(d);
  ASSERT_EQ(d.messages[0].signals.size(), 3001u);
  EXPECT_EQ(d.messages[0].signals[2999].value_names.size(), 1u);
  ASSERT_EQ(d.warnings.size(), 1u) << problems(d);
  EXPECT_NE(d.warnings[0].problem.find("A has 3001 signals; overlaps are checked for 1024 at most"), std::string::npos);
}

TEST(Dbc, AFileIsReadFromDiskOrRefusedWithWhy) {
  const Dbc shipped = load_dbc(test::source_path("io/can/ehpt.dbc"));
  EXPECT_TRUE(shipped.ok()) << problems(shipped);
  EXPECT_EQ(shipped.messages.size(), 18u);  // EV 4, power-split 8, series hybrid 5, PlantStatus
  const Dbc missing = load_dbc("/nonexistent/x.dbc");
  ASSERT_EQ(missing.errors.size(), 1u);
  EXPECT_EQ(to_string(missing, missing.errors[0]), "/nonexistent/x.dbc: cannot read the DBC: no such file");
  const Dbc folder = load_dbc("/");
  ASSERT_EQ(folder.errors.size(), 1u);
  EXPECT_NE(folder.errors[0].problem.find("cannot read the DBC"), std::string::npos);
}

TEST(Dbc, ABinaryFileGivesABoundedListOfProblems) {
  std::string junk;
  std::mt19937 rng(7);
  for (int i = 0; i < 200000; ++i) junk += static_cast<char>(rng() % 256);
  const Dbc d = parse_dbc(junk, "junk.dbc");
  EXPECT_FALSE(d.ok());
  EXPECT_LE(d.errors.size(), 101u);
}

// ---- bits -----------------------------------------------------------------------------

DbcSignal sig(int start, int length, ByteOrder order, bool is_signed = false, double factor = 1, double offset = 0) {
  DbcSignal s;
  s.start_bit = start;
  s.length = length;
  s.byte_order = order;
  s.is_signed = is_signed;
  s.factor = factor;
  s.offset = offset;
  return s;
}

TEST(Dbc, BitsAreReadAsVectorNumbersThem) {
  const std::uint8_t data[8] = {0x12, 0x34, 0xAB, 0xC0, 0x00, 0x00, 0x00, 0x80};
  // Intel: start is the LSB, little-endian across bytes
  EXPECT_EQ(extract_raw(sig(0, 16, ByteOrder::kIntel), data), 0x3412u);
  EXPECT_EQ(extract_raw(sig(4, 8, ByteOrder::kIntel), data), 0x41u);
  // Motorola: start is the MSB, on to bit 7 of the next byte
  EXPECT_EQ(extract_raw(sig(7, 16, ByteOrder::kMotorola), data), 0x1234u);
  EXPECT_EQ(extract_raw(sig(23, 12, ByteOrder::kMotorola), data), 0xABCu);
  EXPECT_EQ(extract_raw(sig(3, 8, ByteOrder::kMotorola), data), 0x23u);  // 0x12's low nibble, 0x34's high
  EXPECT_EQ(extract_raw(sig(63, 1, ByteOrder::kMotorola), data), 1u);
  EXPECT_EQ(extract_raw(sig(7, 64, ByteOrder::kMotorola), data), 0x1234ABC000000080u);
  EXPECT_EQ(extract_raw(sig(0, 64, ByteOrder::kIntel), data), 0x80000000C0AB3412u);
  // sign and scaling
  EXPECT_EQ(raw_to_physical(sig(0, 8, ByteOrder::kIntel, true, 0.5, 1), 0xFF), 0.5);  // -1 x 0.5 + 1
  EXPECT_EQ(raw_to_physical(sig(0, 64, ByteOrder::kIntel, true), ~std::uint64_t{0}), -1.0);
  EXPECT_EQ(raw_to_physical(sig(0, 12, ByteOrder::kIntel, true), 0x800), -2048.0);
  EXPECT_EQ(raw_to_physical(sig(0, 12, ByteOrder::kIntel, false), 0x800), 2048.0);
  DbcSignal f = sig(0, 32, ByteOrder::kIntel, true, 2, -1);
  f.value_type = SignalValueType::kFloat32;
  EXPECT_EQ(raw_to_physical(f, 0x3FC00000u), 2.0);  // 1.5f x 2 - 1
  DbcSignal g = sig(0, 64, ByteOrder::kIntel);
  g.value_type = SignalValueType::kFloat64;
  EXPECT_EQ(raw_to_physical(g, 0x400921FB54442D18u), 3.141592653589793);
}

// The bits of a signal a bit at a time, as the DBC defines them: the yardstick of the codec's
// word-at-a-time extract_raw and insert_raw.
std::uint64_t reference_extract(const DbcSignal& s, const std::vector<std::uint8_t>& p) {
  std::uint64_t raw = 0;
  int pos = s.start_bit;
  for (int i = 0; i < s.length; ++i) {
    const std::uint64_t bit = (p[static_cast<std::size_t>(pos >> 3)] >> (pos & 7)) & 1u;
    if (s.byte_order == ByteOrder::kIntel) {
      raw |= bit << i;
      ++pos;
    } else {
      raw = (raw << 1) | bit;
      pos = (pos & 7) == 0 ? pos + 15 : pos - 1;
    }
  }
  return raw;
}

void reference_insert(const DbcSignal& s, std::uint64_t raw, std::vector<std::uint8_t>& p) {
  int pos = s.start_bit;
  for (int i = 0; i < s.length; ++i) {
    const int from = s.byte_order == ByteOrder::kIntel ? i : s.length - 1 - i;  // the raw bit put at pos
    std::uint8_t& byte = p[static_cast<std::size_t>(pos >> 3)];
    byte = static_cast<std::uint8_t>((byte & ~(1u << (pos & 7))) | (((raw >> from) & 1u) << (pos & 7)));
    pos = s.byte_order == ByteOrder::kIntel ? pos + 1 : (pos & 7) == 0 ? pos + 15 : pos - 1;
  }
}

TEST(Dbc, EveryPlaceOfEverySignalReadsAndWritesItsOwnBitsOnly) {
  // every start bit and length that fits a payload of 1 to 8 bytes, both byte orders, random
  // payloads and values: extract_raw gives the reference's bits, insert_raw changes those
  // bits alone (all others as they were) and reads back
  std::mt19937_64 rng(26);
  int checked = 0;
  for (std::size_t bytes = 1; bytes <= 8; ++bytes) {
    for (const ByteOrder order : {ByteOrder::kIntel, ByteOrder::kMotorola}) {
      for (int start = 0; start < static_cast<int>(8 * bytes); ++start) {
        for (int length = 1; length <= 64; ++length) {
          const DbcSignal s = sig(start, length, order);
          if (!signal_fits(s, static_cast<int>(bytes))) continue;
          std::vector<std::uint8_t> p(bytes);
          for (auto& b : p) b = static_cast<std::uint8_t>(rng());
          ASSERT_EQ(extract_raw(s, p), reference_extract(s, p)) << "start " << start << " length " << length;
          const std::uint64_t value = rng() & raw_mask(length);
          std::vector<std::uint8_t> want = p;
          reference_insert(s, value, want);
          insert_raw(s, value | ~raw_mask(length), p);  // bits above the length are dropped
          ASSERT_EQ(p, want) << "start " << start << " length " << length;
          ++checked;
        }
      }
    }
  }
  EXPECT_EQ(checked, 13344);  // each order: the sum over n = 1..8 of 8n (8n + 1) / 2 places
}

TEST(Dbc, SignalsFitOrNot) {
  EXPECT_TRUE(signal_fits(sig(56, 8, ByteOrder::kIntel), 8));
  EXPECT_FALSE(signal_fits(sig(57, 8, ByteOrder::kIntel), 8));
  EXPECT_TRUE(signal_fits(sig(7, 64, ByteOrder::kMotorola), 8));
  EXPECT_FALSE(signal_fits(sig(6, 64, ByteOrder::kMotorola), 8));
  EXPECT_TRUE(signal_fits(sig(56, 1, ByteOrder::kMotorola), 8));
  EXPECT_FALSE(signal_fits(sig(56, 2, ByteOrder::kMotorola), 8));  // would go on to byte 8
  EXPECT_TRUE(signal_fits(sig(63, 8, ByteOrder::kMotorola), 8));
  EXPECT_FALSE(signal_fits(sig(64, 1, ByteOrder::kIntel), 8));
  EXPECT_TRUE(signal_fits(sig(504, 8, ByteOrder::kIntel), 64));
}

TEST(Dbc, EncodeRoundsSaturatesAndLeavesOtherBitsAlone) {
  std::uint8_t data[8] = {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF};
  DbcSignal t = sig(7, 16, ByteOrder::kMotorola, true, 0.01, 0);
  encode(t, -1.234, data);
  EXPECT_EQ(data[0], 0xFF);  // -123 = 0xFF85
  EXPECT_EQ(data[1], 0x85);
  EXPECT_EQ(data[2], 0xFF);
  EXPECT_NEAR(decode(t, data), -1.23, 1e-12);
  encode(t, 1e9, data);  // no range in the DBC: the bits' range
  EXPECT_EQ(extract_raw(t, data), 0x7FFFu);
  encode(t, -1e9, data);
  EXPECT_EQ(extract_raw(t, data), 0x8000u);
  t.min = -100, t.max = 100;  // a range: clamped to it
  encode(t, 250.0, data);
  EXPECT_EQ(decode(t, data), 100.0);
  DbcSignal u = sig(16, 12, ByteOrder::kIntel, false, 0.5, -100);
  encode(u, -150.0, data);
  EXPECT_EQ(extract_raw(u, data), 0u);
  encode(u, 1e300, data);
  EXPECT_EQ(extract_raw(u, data), 0xFFFu);
  encode(u, 0.26, data);  // (0.26 + 100) / 0.5 = 200.52 -> 201
  EXPECT_EQ(extract_raw(u, data), 201u);
  EXPECT_EQ(data[3] & 0xF0, 0xF0);  // bits 28..31 untouched
  // NaN: the start value if there is one, else raw 0
  encode(u, std::numeric_limits<double>::quiet_NaN(), data);
  EXPECT_EQ(extract_raw(u, data), 0u);
  u.start_value_raw = 300;
  encode(u, std::numeric_limits<double>::quiet_NaN(), data);
  EXPECT_EQ(extract_raw(u, data), 300u);
  // rounding to a step never leaves the range: factor 0.5, max 10.3 gives 10, not 10.5
  DbcSignal half = sig(32, 8, ByteOrder::kIntel, false, 0.5, 0);
  half.min = 0, half.max = 10.3;
  encode(half, 10.3, data);
  EXPECT_EQ(decode(half, data), 10.0);
  half.min = 0.2;
  encode(half, 0.2, data);
  EXPECT_EQ(decode(half, data), 0.5);
  DbcSignal big = sig(0, 64, ByteOrder::kIntel);
  EXPECT_EQ(physical_to_raw(big, 1e30), ~std::uint64_t{0});
  EXPECT_EQ(physical_to_raw(big, -5), 0u);
  DbcSignal sbig = sig(0, 64, ByteOrder::kIntel, true);
  EXPECT_EQ(physical_to_raw(sbig, -1e30), std::uint64_t{1} << 63);
  EXPECT_EQ(physical_to_raw(sbig, 1e30), (std::uint64_t{1} << 63) - 1);
  EXPECT_EQ(physical_to_raw(sbig, -2), ~std::uint64_t{0} - 1);
}

bool shares_a_bit(const DbcSignal& a, const DbcSignal& b, int size_bytes) {
  std::vector<std::uint8_t> ma(static_cast<std::size_t>(size_bytes), 0), mb = ma;
  insert_raw(a, ~std::uint64_t{0}, ma);
  insert_raw(b, ~std::uint64_t{0}, mb);
  for (std::size_t i = 0; i < ma.size(); ++i) {
    if ((ma[i] & mb[i]) != 0) return true;
  }
  return false;
}

TEST(Dbc, EncodeThenDecodeGivesTheValueToItsResolution) {
  const Dbc d = load_dbc(test::source_path("tests/io/dbc/byte_orders.dbc"));
  ASSERT_TRUE(d.ok()) << problems(d);
  std::mt19937_64 rng(3);
  for (const DbcMessage& m : d.messages) {
    for (const DbcSignal& s : m.signals) {
      if (s.length > 52) continue;  // raw values beyond a double's mantissa
      const double lo = s.has_range() ? s.min : raw_to_physical(s, s.is_signed ? std::uint64_t{1} << (s.length - 1) : 0);
      const double hi = s.has_range() ? s.max
                                      : raw_to_physical(s, s.is_signed ? (std::uint64_t{1} << (s.length - 1)) - 1
                                                                       : (~std::uint64_t{0} >> (64 - s.length)));
      for (int k = 0; k < 200; ++k) {
        std::vector<std::uint8_t> data(static_cast<std::size_t>(m.size_bytes));
        for (auto& b : data) b = static_cast<std::uint8_t>(rng());
        const std::vector<std::uint8_t> before = data;
        const double v = lo + (hi - lo) * static_cast<double>(rng() % 10001) / 10000.0;
        encode(s, v, data);
        EXPECT_NEAR(decode(s, data), v, 0.5 * std::abs(s.factor) * (1 + 1e-9)) << m.name << "." << s.name << " = " << v;
        // every other signal that shares no bit with s keeps its value
        for (const DbcSignal& o : m.signals) {
          if (&o == &s || shares_a_bit(s, o, m.size_bytes)) continue;
          EXPECT_EQ(extract_raw(o, data), extract_raw(o, before)) << m.name << "." << o.name << " after " << s.name;
        }
      }
    }
  }
}

// The codec's rule for any DBC's integer signal (what bindings send): the raw range of every
// length and sign, the DBC's range within the bits, saturation counted where the bits cannot
// hold a value the DBC allows.
TEST(Dbc, TheCodecRuleRangesAndSaturation) {
  DbcSignal s;
  s.length = 64;
  s.is_signed = true;
  RawRange r = codec_raw_range(s);
  EXPECT_EQ(r.lo, std::numeric_limits<std::int64_t>::min());
  EXPECT_EQ(r.hi, std::numeric_limits<std::int64_t>::max());
  s.is_signed = false;
  r = codec_raw_range(s);
  EXPECT_EQ(r.lo, 0);
  EXPECT_EQ(r.hi, std::numeric_limits<std::int64_t>::max());
  s.length = 12;
  s.is_signed = true;
  r = codec_raw_range(s);
  EXPECT_EQ(r.lo, -2048);
  EXPECT_EQ(r.hi, 2047);
  EXPECT_EQ(raw_to_int(s, 0xFFF), -1);
  EXPECT_EQ(raw_to_int(s, 0x7FF), 2047);
  // a DBC range wider than the bits: the bits' range, and a value beyond them saturates
  s.length = 16;
  s.factor = 0.01;
  s.min = -400.0;
  s.max = 400.0;
  r = codec_raw_range(s);
  EXPECT_EQ(r.lo, -32768);
  EXPECT_EQ(r.hi, 32767);
  bool sat = false;
  EXPECT_EQ(encode_codec_rule(s, r, 350.0, sat), 32767u);
  EXPECT_TRUE(sat);
  sat = false;
  EXPECT_EQ(raw_to_int(s, encode_codec_rule(s, r, -12.345, sat)), -1235);  // half away from zero
  EXPECT_FALSE(sat);
  // a DBC range inside the bits: that range, raw values rounded as the codec does
  s.min = -2.5;
  s.max = 2.5;
  r = codec_raw_range(s);
  EXPECT_EQ(r.lo, -250);
  EXPECT_EQ(r.hi, 250);
  EXPECT_EQ(raw_to_int(s, encode_codec_rule(s, r, 9.0, sat)), 250);
  EXPECT_TRUE(sat);
  sat = false;
  EXPECT_EQ(raw_to_int(s, encode_codec_rule(s, r, NAN, sat)), 0);
  EXPECT_TRUE(sat);
}

TEST(Dbc, AMultiplexedSignalIsPresentOnlyWhenSelected) {
  const Dbc d = load_dbc(test::source_path("tests/io/dbc/multiplexed.dbc"));
  ASSERT_TRUE(d.ok()) << problems(d);
  const DbcMessage& m = *d.message("MuxCmd");
  const std::uint8_t page1[8] = {1, 0, 0, 0, 0, 0, 0, 0};
  EXPECT_TRUE(is_present(m, *m.signal("Always"), page1));
  EXPECT_TRUE(is_present(m, *m.signal("Page"), page1));
  EXPECT_TRUE(is_present(m, *m.signal("P1Speed"), page1));
  EXPECT_FALSE(is_present(m, *m.signal("P0Torque"), page1));
  EXPECT_FALSE(is_present(m, *m.signal("P7Motorola"), page1));
}

}  // namespace
}  // namespace ehpt::io::can
