// SPDX-License-Identifier: BSD-3-Clause
#include "io/can/codec.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>
#include <gtest/gtest.h>

#include "test_plants.hpp"

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "io/can/bus_spec.hpp"
#include "io/can/candump_log.hpp"
#include "io/can/contract.hpp"
#include "io/can/dbc.hpp"
#include "io/can/socketcand.hpp"

namespace ehpt::io::can {
namespace {

// ---------------------------------------------------------------------------------------------
// The DBC read by ehpt's own reader (io/can/dbc.hpp), its problems as lines.

Dbc parse_text(const std::string& text) { return parse_dbc(text, "ehpt.dbc"); }

std::vector<std::string> problems_of(const Dbc& dbc) {
  std::vector<std::string> lines;
  for (const auto& e : dbc.errors) lines.push_back(to_string(dbc, e));
  for (const auto& w : dbc.warnings) lines.push_back("warning: " + to_string(dbc, w));  // the contract has none
  return lines;
}

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string dbc_path() { return test::source_path("io/can/ehpt.dbc"); }

template <class T>
std::string str(const T& v) {
  std::ostringstream ss;
  ss.precision(17);
  ss << v;
  return ss.str();
}

// Every difference between a DBC and the C++ contract (contract.hpp), one line each.
std::vector<std::string> compare_with_contract(const Dbc& dbc, std::span<const MessageSpec> contract) {
  std::vector<std::string> diffs = problems_of(dbc);
  for (const DbcMessage& d : dbc.messages) {
    const MessageSpec* c = nullptr;
    for (const MessageSpec& m : contract) {
      if (m.name == d.name) c = &m;
    }
    if (c == nullptr) {
      diffs.push_back(d.name + ": message not in contract.hpp");
      continue;
    }
    const std::string at = d.name + ": ";
    if (d.id != c->id) diffs.push_back(at + "id " + str(d.id) + " in the DBC, " + str(c->id) + " in contract.hpp");
    if (d.size_bytes != c->dlc) {
      diffs.push_back(at + "dlc " + str(d.size_bytes) + " in the DBC, " + str(c->dlc) + " in contract.hpp");
    }
    const std::string sender = c->sender == Sender::kPlant ? "Plant" : "Ecu";
    const std::string senders = d.senders.size() == 1 ? d.senders[0] : str(d.senders.size()) + " senders";
    if (senders != sender) diffs.push_back(at + "sender " + senders + " in the DBC, " + sender + " in contract.hpp");
    if (d.extended) diffs.push_back(at + "an extended id in the DBC, standard in contract.hpp");
    const int cycle = d.cycle_time_ms.value_or(-1);
    if (cycle != c->cycle_time_ms) {
      diffs.push_back(at + "cycle time " + str(cycle) + " in the DBC, " + str(c->cycle_time_ms) + " in contract.hpp");
    }
    for (const DbcSignal& ds : d.signals) {
      const SignalSpec* cs = nullptr;
      for (const SignalSpec& s : c->signals) {
        if (s.name == ds.name) cs = &s;
      }
      const std::string sat = d.name + "." + ds.name + ": ";
      if (cs == nullptr) {
        diffs.push_back(sat + "signal not in contract.hpp");
        continue;
      }
      const auto differ = [&](const char* what, const auto& dv, const auto& cv) {
        if (!(dv == cv)) diffs.push_back(sat + what + " " + str(dv) + " in the DBC, " + str(cv) + " in contract.hpp");
      };
      differ("start bit", ds.start_bit, cs->start_bit);
      differ("length", ds.length, cs->length);
      differ("byte order", ds.byte_order == ByteOrder::kIntel ? '1' : '0', '1');  // the contract is Intel only
      differ("sign", ds.is_signed ? '-' : '+', cs->is_signed ? '-' : '+');
      differ("value type", ds.value_type == SignalValueType::kInteger ? "integer" : "IEEE", "integer");
      differ("multiplexing", ds.multiplex == Multiplex::kNone ? "none" : "M or mN", "none");
      differ("factor", ds.factor, cs->factor);
      differ("offset", ds.offset, cs->offset);
      differ("min", ds.min, cs->min);
      differ("max", ds.max, cs->max);
      differ("unit", ds.unit, std::string(cs->unit));
    }
    for (const SignalSpec& s : c->signals) {
      bool in_dbc = false;
      for (const DbcSignal& ds : d.signals) in_dbc = in_dbc || ds.name == s.name;
      if (!in_dbc) diffs.push_back(d.name + "." + std::string(s.name) + ": signal missing in the DBC");
    }
    for (std::size_t i = 0; i < d.signals.size(); ++i) {
      for (std::size_t j = i + 1; j < d.signals.size(); ++j) {
        if (d.signals[i].name == d.signals[j].name) diffs.push_back(at + "signal " + d.signals[i].name + " twice");
      }
    }
  }
  for (const MessageSpec& m : contract) {
    int in_dbc = 0;
    for (const DbcMessage& d : dbc.messages) in_dbc += d.name == m.name ? 1 : 0;
    if (in_dbc != 1) diffs.push_back(std::string(m.name) + ": " + str(in_dbc) + " times in the DBC, wanted once");
  }
  return diffs;
}

std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += "  " + x + "\n";
  return s;
}

// The layout rules of the contract, checked on any table of messages (one line per problem).
std::vector<std::string> layout_problems(std::span<const MessageSpec> messages) {
  std::vector<std::string> problems;
  for (std::size_t i = 0; i < messages.size(); ++i) {
    const MessageSpec& m = messages[i];
    const std::string at = std::string(m.name) + ": ";
    for (std::size_t j = i + 1; j < messages.size(); ++j) {
      if (messages[j].id == m.id) problems.push_back(at + "id shared with " + std::string(messages[j].name));
    }
    if (m.id > kMaxStandardId) problems.push_back(at + "not an 11-bit id");
    if (m.dlc != 8) problems.push_back(at + "dlc is not 8");
    int counters = 0;
    std::uint64_t used = 0;
    for (const SignalSpec& s : m.signals) {
      const std::string sat = at + std::string(s.name) + ": ";
      if (s.name == "counter") {
        ++counters;
        if (s.start_bit != 60 || s.length != 4 || s.is_signed) problems.push_back(sat + "counter not at 60|4 unsigned");
      }
      if (s.start_bit < 0 || s.length < 1 || s.start_bit + s.length > 64) {
        problems.push_back(sat + "does not fit in 64 bits");
        continue;
      }
      const std::uint64_t mask = (s.length == 64 ? ~0ULL : (1ULL << s.length) - 1) << s.start_bit;
      if ((used & mask) != 0) problems.push_back(sat + "overlaps another signal");
      used |= mask;
      // [min, max] in raw units, within what the bits can hold
      const double raw_lo = std::round((s.min - s.offset) / s.factor);
      const double raw_hi = std::round((s.max - s.offset) / s.factor);
      const double bits_lo = s.is_signed ? -std::ldexp(1.0, s.length - 1) : 0.0;
      const double bits_hi = s.is_signed ? std::ldexp(1.0, s.length - 1) - 1.0 : std::ldexp(1.0, s.length) - 1.0;
      if (!(s.factor > 0.0) || !(s.min <= s.max)) problems.push_back(sat + "factor <= 0 or min > max");
      if (raw_lo < bits_lo || raw_hi > bits_hi) {
        problems.push_back(sat + "[min, max] is raw [" + str(raw_lo) + ", " + str(raw_hi) + "], the bits hold [" +
                           str(bits_lo) + ", " + str(bits_hi) + "]");
      }
    }
    if (counters != 1) problems.push_back(at + "no counter (or more than one)");
  }
  return problems;
}

TEST(CanContract, DbcMatchesContractSignalBySignal) {
  const std::string text = read_text(dbc_path());
  ASSERT_FALSE(text.empty()) << dbc_path();
  const Dbc dbc = parse_text(text);
  EXPECT_TRUE(problems_of(dbc).empty()) << joined(problems_of(dbc));
  ASSERT_EQ(dbc.messages.size(), kMessageCount);
  const std::vector<std::string> diffs = compare_with_contract(dbc, kMessages);
  EXPECT_TRUE(diffs.empty()) << joined(diffs);
  // the reader really read the lines (values, not only names): a few spot checks
  EXPECT_EQ(dbc.messages[0].name, "PsdCommand1");
  EXPECT_EQ(dbc.messages[0].id, 272u);
  ASSERT_EQ(dbc.messages[0].signals.size(), 5u);
  EXPECT_EQ(dbc.messages[0].signals[1].name, "iceTauRef_Nm");
  EXPECT_EQ(dbc.messages[0].signals[1].start_bit, 20);
  EXPECT_EQ(dbc.messages[0].signals[1].factor, 0.001);
  EXPECT_EQ(dbc.messages[0].signals[1].min, -500.0);
  EXPECT_EQ(dbc.messages[0].signals[1].unit, "Nm");
  EXPECT_EQ(dbc.messages[0].cycle_time_ms, 10);
  EXPECT_EQ(dbc.messages[0].signals[3].name, "sampleStep");  // the echo of the sample answered
  EXPECT_EQ(dbc.messages[0].signals[3].start_bit, 44);
  EXPECT_EQ(dbc.messages[0].signals[3].length, 16);
  EXPECT_FALSE(dbc.messages[0].signals[3].is_signed);
  EXPECT_EQ(dbc.messages[0].signals[3].max, 65535.0);
  std::size_t signals = 0;
  for (const DbcMessage& m : dbc.messages) {
    signals += m.signals.size();
    EXPECT_EQ(m.cycle_time_ms, 10) << m.name;  // every message has its own BA_
    ASSERT_FALSE(m.signals.empty()) << m.name;
    EXPECT_EQ(m.signals.back().name, "counter") << m.name;
    EXPECT_EQ(m.signals.back().start_bit, 60) << m.name;
    EXPECT_EQ(m.signals.back().length, 4) << m.name;
  }
  EXPECT_EQ(signals, 51u + 20u);  // the series hybrid's: 15 in ShevSensors1..4, 5 in ShevCommand
  // the DBC itself obeys the layout rules too (it equals the tables, checked above)
  const std::vector<std::string> problems = layout_problems(kMessages);
  EXPECT_TRUE(problems.empty()) << joined(problems);
}

// The comparison above is only worth something if it sees a drift: one change of the DBC per
// attribute, each must be reported and named.
TEST(CanContract, ComparisonReportsEveryKindOfDrift) {
  const std::string text = read_text(dbc_path());
  ASSERT_FALSE(text.empty());
  struct Drift {
    std::string from, to, expect;
  };
  const Drift drifts[] = {
      {"BO_ 288 EvCommand: 8 Ecu", "BO_ 289 EvCommand: 8 Ecu", "EvCommand: id 289 in the DBC, 288"},
      {"PsdSensors6: 8 Plant", "PsdSensors6: 7 Plant", "PsdSensors6: dlc 7"},
      {"PlantStatus: 8 Plant", "PlantStatus: 8 Ecu", "PlantStatus: sender Ecu"},
      {"BA_ \"GenMsgCycleTime\" BO_ 546 10;", "BA_ \"GenMsgCycleTime\" BO_ 546 20;", "EvSensors3: cycle time 20"},
      {"iceTauRef_Nm : 20|20", "iceTauRef_Nm : 21|20", "PsdCommand1.iceTauRef_Nm: start bit 21"},
      {"iceW_rad_s : 0|20", "iceW_rad_s : 0|19", "PsdSensors2.iceW_rad_s: length 19"},
      {"genW_rad_s : 40|20@1-", "genW_rad_s : 40|20@0-", "PsdSensors2.genW_rad_s: byte order 0"},
      {"battery_voltage_V : 40|20@1+", "battery_voltage_V : 40|20@1-", "PsdSensors5.battery_voltage_V: sign -"},
      {"icePowRef_W : 0|20@1- (0.5,0)", "icePowRef_W : 0|20@1- (0.25,0)", "PsdCommand1.icePowRef_W: factor 0.25"},
      {"driveTauRef_Nm : 0|20@1- (0.1,0)", "driveTauRef_Nm : 0|20@1- (0.1,1)", "EvCommand.driveTauRef_Nm: offset 1"},
      {"driveTauRef_Nm : 0|20@1- (0.1,0)", "driveTauRef_Nm : 0|20@1- (0.01,0)", "EvCommand.driveTauRef_Nm: factor 0.01"},
      {"[-50000|50000] \"Nm\" Plant", "[-40000|50000] \"Nm\" Plant", "EvCommand.driveTauRef_Nm: min -40000"},
      {"[-50000|50000] \"Nm\" Ecu", "[-50000|5000] \"Nm\" Ecu", "EvSensors1.driverRequest_Nm: max 5000"},
      {"[0|4294967295]", "[0|4294967294]", "PlantStatus.step: max 4294967294"},
      {"motW_rad_s : 40|20@1- (0.01,0) [-5000|5000] \"rad/s\"", "motW_rad_s : 40|20@1- (0.01,0) [-5000|5000] \"rpm\"",
       "PsdSensors3.motW_rad_s: unit rpm"},
      {" SG_ iceON : 40|1@1+ (1,0) [0|1] \"\" Plant\n", "", "PsdCommand1.iceON: signal missing in the DBC"},
      {" SG_ battery_current_A : 0|20@1- (0.001,0) [-500|500] \"A\" Ecu\n",
       " SG_ battery_current_A : 0|20@1- (0.001,0) [-500|500] \"A\" Ecu\n SG_ spare : 20|8@1+ (1,0) [0|255] \"\" Ecu\n",
       "PsdSensors6.spare: signal not in contract.hpp"},
      {"BO_ 533 PsdSensors6:", "BO_ 533 PsdSensors7:", "PsdSensors6: 0 times in the DBC"},
      {" SG_ batSOC : 40|20@1+ (1e-06,0) [0|1] \"\" Ecu\n SG_ counter : 60|4@1+ (1,0) [0|15] \"\" Ecu\n\nBO_ 529",
       " SG_ batSOC : 40|20@1+ (1e-06,0) [0|1] \"\" Ecu\n SG_ counter : 56|4@1+ (1,0) [0|15] \"\" Ecu\n\nBO_ 529",
       "PsdSensors1.counter: start bit 56"},
      {"sampleStep : 44|16@1+ (1,0) [0|65535] \"\" Plant\n SG_ counter : 60|4@1+ (1,0) [0|15] \"\" Plant\n\nBO_ 512",
       "sampleStep : 44|15@1+ (1,0) [0|65535] \"\" Plant\n SG_ counter : 60|4@1+ (1,0) [0|15] \"\" Plant\n\nBO_ 512",
       "ShevCommand.sampleStep: length 15"},
      {" SG_ fault : 32|8@1+", " SG_ fault : 32|8@2+", "ehpt.dbc:40: the byte order (0 Motorola, 1 Intel) '2'"},
      {"gensetON : 40|1@1+", "gensetON : 41|1@1+", "ShevCommand.gensetON: start bit 41"},
      {"drivePowDc_W : 40|20@1- (0.5,0)", "drivePowDc_W : 40|20@1- (1,0)", "ShevSensors2.drivePowDc_W: factor 1"},
  };
  for (const Drift& d : drifts) {
    const std::size_t at = text.find(d.from);
    ASSERT_NE(at, std::string::npos) << d.from;
    ASSERT_EQ(text.find(d.from, at + 1), std::string::npos) << "not unique: " << d.from;
    std::string changed = text;
    changed.replace(at, d.from.size(), d.to);
    const std::vector<std::string> diffs = compare_with_contract(parse_text(changed), kMessages);
    bool named = false;
    for (const auto& line : diffs) named = named || line.find(d.expect) != std::string::npos;
    EXPECT_TRUE(named) << "drift '" << d.to << "' not reported as '" << d.expect << "'; reported:\n" << joined(diffs);
  }
}

TEST(CanContract, LayoutRulesCatchOverlapsWidthAndRange) {
  EXPECT_TRUE(layout_problems(kMessages).empty()) << joined(layout_problems(kMessages));
  // hand-made bad tables: each rule must speak
  static constexpr SignalSpec kOverlap[] = {{"a", 0, 20, true, 1, 0, -10, 10, ""},
                                            {"b", 19, 4, false, 1, 0, 0, 15, ""},
                                            detail::counter()};
  static constexpr SignalSpec kTooLong[] = {{"a", 50, 20, false, 1, 0, 0, 10, ""}, detail::counter()};
  static constexpr SignalSpec kRangeTooWide[] = {{"a", 0, 20, true, 0.5, 0, -262144.5, 10, ""}, detail::counter()};
  static constexpr SignalSpec kUnsignedNegative[] = {{"a", 0, 20, false, 1, 0, -1, 10, ""}, detail::counter()};
  static constexpr SignalSpec kNoCounter[] = {{"a", 0, 20, true, 1, 0, -10, 10, ""}};
  static constexpr SignalSpec kCounterMoved[] = {{"counter", 56, 4, false, 1, 0, 0, 15, ""}};
  const struct {
    MessageSpec m;
    const char* expect;
  } bad[] = {
      {{"Overlap", 0x100, 8, 10, Sender::kEcu, kOverlap}, "Overlap: b: overlaps"},
      {{"TooLong", 0x100, 8, 10, Sender::kEcu, kTooLong}, "TooLong: a: does not fit"},
      {{"Wide", 0x100, 8, 10, Sender::kEcu, kRangeTooWide}, "Wide: a: [min, max] is raw [-524289"},
      {{"Neg", 0x100, 8, 10, Sender::kEcu, kUnsignedNegative}, "Neg: a: [min, max] is raw [-1"},
      {{"NoCounter", 0x100, 8, 10, Sender::kEcu, kNoCounter}, "NoCounter: no counter"},
      {{"Moved", 0x100, 8, 10, Sender::kEcu, kCounterMoved}, "Moved: counter: counter not at 60|4"},
  };
  for (const auto& b : bad) {
    const MessageSpec one[] = {b.m};
    const std::vector<std::string> problems = layout_problems(one);
    ASSERT_EQ(problems.size(), 1u) << b.expect << "\n" << joined(problems);
    EXPECT_EQ(problems[0].rfind(b.expect, 0), 0u) << problems[0];
  }
  // at the edge: 20 signed bits hold raw -524288..524287, so that range is fine
  static constexpr SignalSpec kEdge[] = {{"a", 0, 20, true, 0.5, 0, -262144, 262143.5, ""}, detail::counter()};
  const MessageSpec edge[] = {{"Edge", 0x100, 8, 10, Sender::kEcu, kEdge}};
  EXPECT_TRUE(layout_problems(edge).empty()) << joined(layout_problems(edge));
}

// ---------------------------------------------------------------------------------------------
// The message fields and their signals, written out here (not taken from the codec).

template <class Msg>
struct TestField {
  std::uint32_t id;
  std::string_view signal;
  double Msg::*member;
};

const TestField<msgs::PsdSensors> kPsdSensorFields[] = {
    {kPsdSensors1, "driverRequest", &msgs::PsdSensors::driverRequest},
    {kPsdSensors1, "speed_m_s", &msgs::PsdSensors::speed_m_s},
    {kPsdSensors1, "batSOC", &msgs::PsdSensors::batSOC},
    {kPsdSensors2, "iceW_rad_s", &msgs::PsdSensors::iceW_rad_s},
    {kPsdSensors2, "icePowDel_W", &msgs::PsdSensors::icePowDel_W},
    {kPsdSensors2, "genW_rad_s", &msgs::PsdSensors::genW_rad_s},
    {kPsdSensors3, "genPowDel_W", &msgs::PsdSensors::genPowDel_W},
    {kPsdSensors3, "genTauLim_Nm", &msgs::PsdSensors::genTauLim_Nm},
    {kPsdSensors3, "motW_rad_s", &msgs::PsdSensors::motW_rad_s},
    {kPsdSensors4, "motPowDelA_W", &msgs::PsdSensors::motPowDelA_W},
    {kPsdSensors4, "motPowDelB_W", &msgs::PsdSensors::motPowDelB_W},
    {kPsdSensors4, "motPowDelAB_W", &msgs::PsdSensors::motPowDelAB_W},
    {kPsdSensors5, "motTauLim_Nm", &msgs::PsdSensors::motTauLim_Nm},
    {kPsdSensors5, "batPowDel_W", &msgs::PsdSensors::batPowDel_W},
    {kPsdSensors5, "battery_voltage_V", &msgs::PsdSensors::battery_voltage_V},
    {kPsdSensors6, "battery_current_A", &msgs::PsdSensors::battery_current_A},
};
const TestField<msgs::EvSensors> kEvSensorFields[] = {
    {kEvSensors1, "driverRequest_Nm", &msgs::EvSensors::driverRequest_Nm},
    {kEvSensors1, "speed_m_s", &msgs::EvSensors::speed_m_s},
    {kEvSensors1, "batSOC", &msgs::EvSensors::batSOC},
    {kEvSensors2, "driveW_rad_s", &msgs::EvSensors::driveW_rad_s},
    {kEvSensors2, "driveTauLim_Nm", &msgs::EvSensors::driveTauLim_Nm},
    {kEvSensors2, "drivePowDel_W", &msgs::EvSensors::drivePowDel_W},
    {kEvSensors3, "batPowDel_W", &msgs::EvSensors::batPowDel_W},
    {kEvSensors3, "battery_voltage_V", &msgs::EvSensors::battery_voltage_V},
    {kEvSensors3, "battery_current_A", &msgs::EvSensors::battery_current_A},
};
const TestField<msgs::PsdCommand> kPsdCommandFields[] = {
    {kPsdCommand1, "icePowRef_W", &msgs::PsdCommand::icePowRef_W},
    {kPsdCommand1, "iceTauRef_Nm", &msgs::PsdCommand::iceTauRef_Nm},
    {kPsdCommand2, "genTauRef_Nm", &msgs::PsdCommand::genTauRef_Nm},
    {kPsdCommand2, "motTauRef_Nm", &msgs::PsdCommand::motTauRef_Nm},
};
const TestField<msgs::EvCommand> kEvCommandFields[] = {
    {kEvCommand, "driveTauRef_Nm", &msgs::EvCommand::driveTauRef_Nm},
};
const TestField<msgs::ShevSensors> kShevSensorFields[] = {
    {kShevSensors1, "driverRequest_Nm", &msgs::ShevSensors::driverRequest_Nm},
    {kShevSensors1, "speed_m_s", &msgs::ShevSensors::speed_m_s},
    {kShevSensors1, "batSOC", &msgs::ShevSensors::batSOC},
    {kShevSensors2, "driveW_rad_s", &msgs::ShevSensors::driveW_rad_s},
    {kShevSensors2, "driveTauLim_Nm", &msgs::ShevSensors::driveTauLim_Nm},
    {kShevSensors2, "drivePowDc_W", &msgs::ShevSensors::drivePowDc_W},
    {kShevSensors3, "gensetW_rad_s", &msgs::ShevSensors::gensetW_rad_s},
    {kShevSensors3, "gensetPowDc_W", &msgs::ShevSensors::gensetPowDc_W},
    {kShevSensors3, "batPowDel_W", &msgs::ShevSensors::batPowDel_W},
    {kShevSensors4, "battery_voltage_V", &msgs::ShevSensors::battery_voltage_V},
    {kShevSensors4, "battery_current_A", &msgs::ShevSensors::battery_current_A},
};
const TestField<msgs::ShevCommand> kShevCommandFields[] = {
    {kShevCommand, "driveTauRef_Nm", &msgs::ShevCommand::driveTauRef_Nm},
    {kShevCommand, "gensetPowRef_W", &msgs::ShevCommand::gensetPowRef_W},
};

template <class Msg>
const SignalSpec& spec_of(const TestField<Msg>& f) {
  const SignalSpec* s = find_signal(f.id, f.signal);
  if (s == nullptr) {
    ADD_FAILURE() << "no signal " << f.signal;
    static constexpr SignalSpec kNone{};
    return kNone;
  }
  return *s;
}

// The largest error the bus may add to a value: half a resolution step (and round-off).
double tolerance(const SignalSpec& s, double v) { return 0.5 * s.factor + 1e-12 * std::max(1.0, std::abs(v)); }

// Every signal of the contract is a field above, a PlantStatus signal or a counter: the round
// trips below cover them all.
TEST(CanCodec, TestTablesCoverEverySignal) {
  int covered = 0;
  for (const MessageSpec& m : kMessages) {
    for (const SignalSpec& s : m.signals) {
      int uses = 0;
      for (const auto& f : kPsdSensorFields) uses += (f.id == m.id && f.signal == s.name) ? 1 : 0;
      for (const auto& f : kEvSensorFields) uses += (f.id == m.id && f.signal == s.name) ? 1 : 0;
      for (const auto& f : kPsdCommandFields) uses += (f.id == m.id && f.signal == s.name) ? 1 : 0;
      for (const auto& f : kEvCommandFields) uses += (f.id == m.id && f.signal == s.name) ? 1 : 0;
      for (const auto& f : kShevSensorFields) uses += (f.id == m.id && f.signal == s.name) ? 1 : 0;
      for (const auto& f : kShevCommandFields) uses += (f.id == m.id && f.signal == s.name) ? 1 : 0;
      uses += (m.id == kPsdCommand1 && s.name == "iceON") ? 1 : 0;
      uses += (m.id == kShevCommand && s.name == "gensetON") ? 1 : 0;
      const bool command = m.id == kPsdCommand1 || m.id == kPsdCommand2 || m.id == kEvCommand || m.id == kShevCommand;
      uses += (command && s.name == "sampleStep") ? 1 : 0;  // CanCodec.CommandsEchoTheirStampStep...
      uses += (m.id == kPlantStatus || s.name == "counter") ? 1 : 0;
      EXPECT_EQ(uses, 1) << m.name << "." << s.name;
      covered += uses;
    }
  }
  EXPECT_EQ(covered, 51 + 20);  // the series hybrid: 11 sensor fields, 4 counters; 3 command fields, echo, counter
}

// Decodes frames as the receiving side does: filter first, apply only what it accepts.
template <class Msg, std::size_t N>
void receive_all(std::span<const Frame, N> frames, std::span<const std::uint32_t> accepted, Msg& msg,
                 PlantStatus* status = nullptr) {
  FrameFilter filter(accepted);
  for (const Frame& f : frames) {
    const Reject r = filter.accept(f);
    EXPECT_EQ(r, Reject::kNone) << std::hex << f.id << " " << reject_name(r);
    if (r != Reject::kNone) continue;
    if (f.id == kPlantStatus) {
      if (status != nullptr) apply(f, *status);
    } else {
      apply(f, msg);
    }
  }
  EXPECT_EQ(filter.stats().accepted, static_cast<std::int64_t>(N));
}

enum class Pick { kMin, kMax, kZero, kRandom };

template <class Msg, std::size_t N>
Msg fill(const TestField<Msg> (&fields)[N], Pick pick, std::mt19937_64& rng) {
  Msg m{};
  for (const auto& f : fields) {
    const SignalSpec& s = spec_of(f);
    switch (pick) {
      case Pick::kMin: m.*f.member = s.min; break;
      case Pick::kMax: m.*f.member = s.max; break;
      case Pick::kZero: m.*f.member = 0.0; break;
      case Pick::kRandom: m.*f.member = std::uniform_real_distribution<double>(s.min, s.max)(rng); break;
    }
  }
  return m;
}

template <class Msg, std::size_t N>
void expect_fields_near(const TestField<Msg> (&fields)[N], const Msg& in, const Msg& out, const char* what) {
  for (const auto& f : fields) {
    const SignalSpec& s = spec_of(f);
    EXPECT_NEAR(out.*f.member, in.*f.member, tolerance(s, in.*f.member)) << what << " " << f.signal;
  }
}

constexpr Pick kPicks[] = {Pick::kMin, Pick::kMax, Pick::kZero, Pick::kRandom, Pick::kRandom,
                           Pick::kRandom, Pick::kRandom, Pick::kRandom, Pick::kRandom};

TEST(CanCodec, PsdSensorsRoundTripEveryFieldWithinHalfAStep) {
  std::mt19937_64 rng(20240611);
  for (Pick pick : kPicks) {
    const msgs::PsdSensors in = fill(kPsdSensorFields, pick, rng);
    TxCounters tx;
    std::array<Frame, kPsdSensorIds.size()> frames;
    EXPECT_EQ(encode(in, PlantStatus{}, tx, frames), 0);
    for (std::size_t i = 0; i < frames.size(); ++i) {
      EXPECT_EQ(frames[i].id, kPsdSensorIds[i]);
      EXPECT_EQ(frames[i].len, 8);
    }
    msgs::PsdSensors out{};
    receive_all<msgs::PsdSensors, kPsdSensorIds.size()>(frames, kPsdSensorIds, out);
    expect_fields_near(kPsdSensorFields, in, out, "PsdSensors");
  }
  // the ends and zero come back exactly (raw times factor is the same double)
  TxCounters tx;
  std::array<Frame, kPsdSensorIds.size()> frames;
  msgs::PsdSensors in{}, out{};
  in.speed_m_s = -100.0;
  in.batSOC = 1.0;
  in.icePowDel_W = 250000.0;
  in.battery_voltage_V = 1000.0;
  in.driverRequest = -5.0;
  encode(in, PlantStatus{}, tx, frames);
  receive_all<msgs::PsdSensors, kPsdSensorIds.size()>(frames, kPsdSensorIds, out);
  EXPECT_EQ(out.speed_m_s, -100.0);
  EXPECT_DOUBLE_EQ(out.batSOC, 1.0);
  EXPECT_EQ(out.icePowDel_W, 250000.0);
  EXPECT_DOUBLE_EQ(out.battery_voltage_V, 1000.0);
  EXPECT_DOUBLE_EQ(out.driverRequest, -5.0);
  EXPECT_EQ(out.genW_rad_s, 0.0);
}

TEST(CanCodec, EvSensorsRoundTripEveryFieldWithinHalfAStep) {
  std::mt19937_64 rng(7);
  for (Pick pick : kPicks) {
    const msgs::EvSensors in = fill(kEvSensorFields, pick, rng);
    TxCounters tx;
    std::array<Frame, kEvSensorIds.size()> frames;
    EXPECT_EQ(encode(in, PlantStatus{}, tx, frames), 0);
    for (std::size_t i = 0; i < frames.size(); ++i) EXPECT_EQ(frames[i].id, kEvSensorIds[i]);
    msgs::EvSensors out{};
    receive_all<msgs::EvSensors, kEvSensorIds.size()>(frames, kEvSensorIds, out);
    expect_fields_near(kEvSensorFields, in, out, "EvSensors");
  }
}

TEST(CanCodec, ShevSensorsRoundTripEveryFieldWithinHalfAStep) {
  std::mt19937_64 rng(25);
  for (Pick pick : kPicks) {
    const msgs::ShevSensors in = fill(kShevSensorFields, pick, rng);
    TxCounters tx;
    std::array<Frame, kShevSensorIds.size()> frames;
    PlantStatus status;
    status.step = 123456;
    status.fault = 2;
    status.locked = pick == Pick::kZero;
    EXPECT_EQ(encode(in, status, tx, frames), 0);
    const std::uint32_t ids[] = {0x230, 0x231, 0x232, 0x233, 0x200};  // ShevSensors1..4, PlantStatus last
    for (std::size_t i = 0; i < frames.size(); ++i) EXPECT_EQ(frames[i].id, ids[i]);
    msgs::ShevSensors out{};
    PlantStatus got;
    receive_all<msgs::ShevSensors, kShevSensorIds.size()>(frames, kShevSensorIds, out, &got);
    expect_fields_near(kShevSensorFields, in, out, "ShevSensors");
    EXPECT_EQ(got.step, 123456u);
    EXPECT_EQ(got.fault, 2u);
    EXPECT_EQ(got.locked, pick == Pick::kZero);
  }
  // a value known by hand: drivePowDc_W = 104 800.5 W is raw 209 601 at bit 40 of ShevSensors2
  TxCounters tx;
  std::array<Frame, kShevSensorIds.size()> frames;
  msgs::ShevSensors in{};
  in.drivePowDc_W = 104800.5;
  in.gensetPowDc_W = -1.0;  // raw -2: 20 bits of two's complement at bit 20 of ShevSensors3
  encode(in, PlantStatus{}, tx, frames);
  std::uint64_t bits2 = 0, bits3 = 0;
  for (std::size_t i = 0; i < 8; ++i) {
    bits2 |= static_cast<std::uint64_t>(frames[1].data[i]) << (8 * i);
    bits3 |= static_cast<std::uint64_t>(frames[2].data[i]) << (8 * i);
  }
  EXPECT_EQ((bits2 >> 40) & 0xFFFFF, 209601u);
  EXPECT_EQ((bits3 >> 20) & 0xFFFFF, 0xFFFFEu);
}

TEST(CanCodec, ShevCommandRoundTripsAndEchoesItsStepInOneFrame) {
  std::mt19937_64 rng(26);
  int n = 0;
  for (Pick pick : kPicks) {
    msgs::ShevCommand in = fill(kShevCommandFields, pick, rng);
    in.gensetON = (n++ % 2) == 0;
    in.stamp.step = static_cast<std::int64_t>(rng() >> 20);
    TxCounters tx;
    std::array<Frame, kShevCommandIds.size()> frames;
    EXPECT_EQ(encode(in, tx, frames), 0);
    EXPECT_EQ(frames[0].id, 0x130u);
    EXPECT_EQ((payload(frames[0]) >> 44) & 0xFFFF, static_cast<std::uint64_t>(in.stamp.step % 65536));
    EXPECT_EQ((payload(frames[0]) >> 40) & 1, in.gensetON ? 1u : 0u);
    msgs::ShevCommand out{};
    out.gensetON = !in.gensetON;
    receive_all<msgs::ShevCommand, 1>(frames, kShevCommandIds, out);
    expect_fields_near(kShevCommandFields, in, out, "ShevCommand");
    EXPECT_EQ(out.gensetON, in.gensetON);
  }
  // a torque beyond the signal's +-5000 N m is sent as the end and counted
  msgs::ShevCommand big{};
  big.driveTauRef_Nm = 6000.0;
  big.gensetPowRef_W = 300000.0;
  TxCounters tx;
  std::array<Frame, 1> frames;
  EXPECT_EQ(encode(big, tx, frames), 2);
  msgs::ShevCommand out{};
  receive_all<msgs::ShevCommand, 1>(frames, kShevCommandIds, out);
  EXPECT_EQ(out.driveTauRef_Nm, 5000.0);
  EXPECT_EQ(out.gensetPowRef_W, 250000.0);
}

// The payload of a frame and a command's sampleStep (bits 44..59), read here, not by the codec.
std::uint64_t payload_bits(const Frame& f) {
  std::uint64_t bits = 0;
  for (std::size_t i = 0; i < 8; ++i) bits |= static_cast<std::uint64_t>(f.data[i]) << (8 * i);
  return bits;
}
std::uint32_t sample_step_of(const Frame& f) { return static_cast<std::uint32_t>((payload_bits(f) >> 44) & 0xFFFF); }

TEST(CanCodec, CommandsRoundTripEveryFieldWithinHalfAStepAndFlagsExactly) {
  std::mt19937_64 rng(99);
  int n = 0;
  for (Pick pick : kPicks) {
    msgs::PsdCommand in = fill(kPsdCommandFields, pick, rng);
    in.iceON = (n++ % 2) == 0;
    in.stamp.step = static_cast<std::int64_t>(rng() >> 20);  // up to 2^44: the echo keeps 16 bits
    TxCounters tx;
    std::array<Frame, kPsdCommandIds.size()> frames;
    EXPECT_EQ(encode(in, tx, frames), 0);
    for (const Frame& f : frames) {
      EXPECT_EQ(sample_step_of(f), static_cast<std::uint32_t>(in.stamp.step % 65536)) << std::hex << f.id;
    }
    msgs::PsdCommand out{};
    out.iceON = !in.iceON;
    receive_all<msgs::PsdCommand, kPsdCommandIds.size()>(frames, kPsdCommandIds, out);
    expect_fields_near(kPsdCommandFields, in, out, "PsdCommand");
    EXPECT_EQ(out.iceON, in.iceON);

    msgs::EvCommand ev = fill(kEvCommandFields, pick, rng);
    ev.stamp.step = static_cast<std::int64_t>(rng() >> 20);
    std::array<Frame, 1> ev_frames;
    EXPECT_EQ(encode(ev, tx, ev_frames), 0);
    EXPECT_EQ(sample_step_of(ev_frames[0]), static_cast<std::uint32_t>(ev.stamp.step % 65536));
    msgs::EvCommand ev_out{};
    receive_all<msgs::EvCommand, 1>(ev_frames, kEvCommandIds, ev_out);
    expect_fields_near(kEvCommandFields, ev, ev_out, "EvCommand");
  }
}

// Every command frame carries stamp.step mod 2^16 at bits 44..59 (sampleStep), next to fields
// whose raw bits are all set and without touching them or the counter.
TEST(CanCodec, CommandsEchoTheirStampStepModulo65536) {
  const struct {
    std::int64_t step;
    std::uint32_t echo;
  } cases[] = {{0, 0u},           {1, 1u},        {65535, 65535u}, {65536, 0u}, {123456, 123456u & 0xFFFFu},
               {65537, 1u},       {0xABCD, 0xABCDu}, {0xFFFFFFFFLL, 0xFFFFu}, {0x123456789ALL, 0x789Au}};
  EXPECT_EQ(123456u & 0xFFFFu, 57920u);
  int n = 0;
  for (const auto& c : cases) {
    msgs::PsdCommand psd{};
    psd.stamp.step = c.step;
    psd.icePowRef_W = -0.5;     // raw -1: all 20 bits set
    psd.iceTauRef_Nm = -0.001;  // raw -1
    psd.genTauRef_Nm = -0.001;
    psd.motTauRef_Nm = -0.001;
    psd.iceON = true;
    msgs::EvCommand ev{};
    ev.stamp.step = c.step;
    ev.driveTauRef_Nm = -0.1;  // raw -1 (factor 0.1)
    TxCounters tx;
    for (int i = 0; i < n % 16; ++i) tx.take(kEvCommand);  // a counter other than 0 as well
    std::array<Frame, kPsdCommandIds.size()> frames;
    std::array<Frame, 1> ev_frames;
    ASSERT_EQ(encode(psd, tx, frames), 0);
    ASSERT_EQ(encode(ev, tx, ev_frames), 0);
    const Frame all[] = {frames[0], frames[1], ev_frames[0]};
    const std::uint64_t others[] = {
        0xFFFFFULL | (0xFFFFFULL << 20) | (1ULL << 40),  // icePowRef_W, iceTauRef_Nm, iceON
        0xFFFFFULL | (0xFFFFFULL << 20),                 // genTauRef_Nm, motTauRef_Nm
        0xFFFFFULL,                                      // driveTauRef_Nm
    };
    const std::uint64_t counters[] = {0, 0, static_cast<std::uint64_t>(n % 16)};
    for (std::size_t i = 0; i < 3; ++i) {
      const std::uint64_t want = others[i] | (static_cast<std::uint64_t>(c.echo) << 44) | (counters[i] << 60);
      EXPECT_EQ(payload_bits(all[i]), want) << std::hex << all[i].id << " step " << std::dec << c.step;
      EXPECT_EQ(sample_step_of(all[i]), c.echo) << c.step;
      EXPECT_EQ(check_frame(all[i], i < 2 ? std::span<const std::uint32_t>(kPsdCommandIds)
                                          : std::span<const std::uint32_t>(kEvCommandIds)),
                Reject::kNone);
      EXPECT_EQ(command_age_steps(all[i], c.echo), 0u) << c.step;
      EXPECT_EQ(command_age_steps(all[i], static_cast<std::uint32_t>(c.step)), 0u) << c.step;  // the full step
    }
    ++n;
  }
}

// Fields of other frames are left alone: each frame carries only its own fields.
TEST(CanCodec, ApplyChangesOnlyTheFieldsOfItsFrame) {
  std::mt19937_64 rng(3);
  const msgs::PsdSensors in = fill(kPsdSensorFields, Pick::kRandom, rng);
  TxCounters tx;
  std::array<Frame, kPsdSensorIds.size()> frames;
  encode(in, PlantStatus{}, tx, frames);
  for (const Frame& f : frames) {
    msgs::PsdSensors out{};
    for (const auto& fld : kPsdSensorFields) out.*fld.member = -12345.0;  // a sentinel no field is sent as
    apply(f, out);
    for (const auto& fld : kPsdSensorFields) {
      if (fld.id == f.id) {
        EXPECT_NEAR(out.*fld.member, in.*fld.member, tolerance(spec_of(fld), in.*fld.member)) << fld.signal;
      } else {
        EXPECT_EQ(out.*fld.member, -12345.0) << fld.signal << " changed by frame " << std::hex << f.id;
      }
    }
  }
}

TEST(CanCodec, PlantStatusRoundTripsExactly) {
  const std::uint32_t steps[] = {0u, 1u, 0x12345678u, 0x7FFFFFFFu, 0x80000000u, 0xFFFFFFFEu, 0xFFFFFFFFu};
  const unsigned faults[] = {0u, 1u, 2u, 4u, 8u, 15u, 0x80u, 255u};
  int n = 0;
  for (std::uint32_t step : steps) {
    for (unsigned fault : faults) {
      const PlantStatus in{step, fault, (n % 2) == 1, (n / 2) % 2 == 1};
      ++n;
      TxCounters tx;
      std::array<Frame, kEvSensorIds.size()> frames;
      EXPECT_EQ(encode(msgs::EvSensors{}, in, tx, frames), 0);
      ASSERT_EQ(frames.back().id, kPlantStatus);  // the last frame closes the sample
      PlantStatus out{~in.step, ~in.fault, !in.locked, !in.ecu_timeout};
      msgs::EvSensors sensors{};
      receive_all<msgs::EvSensors, kEvSensorIds.size()>(frames, kEvSensorIds, sensors, &out);
      EXPECT_EQ(out.step, in.step);
      EXPECT_EQ(out.fault, in.fault);
      EXPECT_EQ(out.locked, in.locked);
      EXPECT_EQ(out.ecu_timeout, in.ecu_timeout);
    }
  }
  EXPECT_EQ(n, 56);
  // the same through the PSD family's frames
  TxCounters tx;
  std::array<Frame, kPsdSensorIds.size()> frames;
  const PlantStatus in{4294967000u, 9u, true, true};
  EXPECT_EQ(encode(msgs::PsdSensors{}, in, tx, frames), 0);
  PlantStatus out{};
  msgs::PsdSensors sensors{};
  receive_all<msgs::PsdSensors, kPsdSensorIds.size()>(frames, kPsdSensorIds, sensors, &out);
  EXPECT_EQ(out.step, 4294967000u);
  EXPECT_EQ(out.fault, 9u);
  EXPECT_TRUE(out.locked);
  EXPECT_TRUE(out.ecu_timeout);
}

// ---------------------------------------------------------------------------------------------
// Saturation: out of range and non-finite values are sent as the range's ends (NaN as 0), and
// every such field is counted once.

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(CanCodec, SaturationSendsTheEndsAndCountsEveryField) {
  // value to send -> value expected back (as a function of the signal), per field pattern
  enum class Bad { kAbove, kBelow, kPlusInf, kMinusInf, kNaN, kInRange };
  const auto bad_value = [](Bad b, const SignalSpec& s) {
    switch (b) {
      case Bad::kAbove: return s.max + 0.1 * s.factor;  // less than half a step above: still saturated
      case Bad::kBelow: return s.min - 1e6;
      case Bad::kPlusInf: return kInf;
      case Bad::kMinusInf: return -kInf;
      case Bad::kNaN: return kNaN;
      case Bad::kInRange: return 0.25 * s.min + 0.5 * s.max;
    }
    return 0.0;
  };
  const auto expected = [&](Bad b, const SignalSpec& s) {
    switch (b) {
      case Bad::kAbove:
      case Bad::kPlusInf: return s.max;
      case Bad::kBelow:
      case Bad::kMinusInf: return s.min;
      case Bad::kNaN: return 0.0;
      case Bad::kInRange: return bad_value(b, s);
    }
    return 0.0;
  };
  const Bad patterns[] = {Bad::kAbove, Bad::kBelow, Bad::kPlusInf, Bad::kMinusInf, Bad::kNaN, Bad::kInRange};
  for (std::size_t shift = 0; shift < std::size(patterns); ++shift) {
    const auto bad_of = [&](std::size_t i) { return patterns[(i + shift) % std::size(patterns)]; };
    // PsdSensors (16 fields) and a fault beyond 8 bits
    {
      msgs::PsdSensors in{};
      int want = 0;
      for (std::size_t i = 0; i < std::size(kPsdSensorFields); ++i) {
        in.*kPsdSensorFields[i].member = bad_value(bad_of(i), spec_of(kPsdSensorFields[i]));
        want += bad_of(i) == Bad::kInRange ? 0 : 1;
      }
      const bool fault_too_big = shift % 2 == 1;
      const PlantStatus st{7u, fault_too_big ? 256u : 3u, false, false};
      TxCounters tx;
      std::array<Frame, kPsdSensorIds.size()> frames;
      EXPECT_EQ(encode(in, st, tx, frames), want + (fault_too_big ? 1 : 0)) << "shift " << shift;
      msgs::PsdSensors out{};
      PlantStatus st_out{};
      receive_all<msgs::PsdSensors, kPsdSensorIds.size()>(frames, kPsdSensorIds, out, &st_out);
      for (std::size_t i = 0; i < std::size(kPsdSensorFields); ++i) {
        const SignalSpec& s = spec_of(kPsdSensorFields[i]);
        const double e = expected(bad_of(i), s);
        EXPECT_NEAR(out.*kPsdSensorFields[i].member, e, tolerance(s, e)) << kPsdSensorFields[i].signal;
      }
      EXPECT_EQ(st_out.fault, fault_too_big ? 255u : 3u);
    }
    // EvSensors (9 fields)
    {
      msgs::EvSensors in{};
      int want = 0;
      for (std::size_t i = 0; i < std::size(kEvSensorFields); ++i) {
        in.*kEvSensorFields[i].member = bad_value(bad_of(i), spec_of(kEvSensorFields[i]));
        want += bad_of(i) == Bad::kInRange ? 0 : 1;
      }
      TxCounters tx;
      std::array<Frame, kEvSensorIds.size()> frames;
      EXPECT_EQ(encode(in, PlantStatus{}, tx, frames), want) << "shift " << shift;
      msgs::EvSensors out{};
      receive_all<msgs::EvSensors, kEvSensorIds.size()>(frames, kEvSensorIds, out);
      for (std::size_t i = 0; i < std::size(kEvSensorFields); ++i) {
        const SignalSpec& s = spec_of(kEvSensorFields[i]);
        const double e = expected(bad_of(i), s);
        EXPECT_NEAR(out.*kEvSensorFields[i].member, e, tolerance(s, e)) << kEvSensorFields[i].signal;
      }
    }
    // PsdCommand (4 fields) and EvCommand (1 field)
    {
      msgs::PsdCommand in{};
      int want = 0;
      for (std::size_t i = 0; i < std::size(kPsdCommandFields); ++i) {
        in.*kPsdCommandFields[i].member = bad_value(bad_of(i), spec_of(kPsdCommandFields[i]));
        want += bad_of(i) == Bad::kInRange ? 0 : 1;
      }
      TxCounters tx;
      std::array<Frame, kPsdCommandIds.size()> frames;
      EXPECT_EQ(encode(in, tx, frames), want) << "shift " << shift;
      msgs::PsdCommand out{};
      receive_all<msgs::PsdCommand, kPsdCommandIds.size()>(frames, kPsdCommandIds, out);
      for (std::size_t i = 0; i < std::size(kPsdCommandFields); ++i) {
        const SignalSpec& s = spec_of(kPsdCommandFields[i]);
        const double e = expected(bad_of(i), s);
        EXPECT_NEAR(out.*kPsdCommandFields[i].member, e, tolerance(s, e)) << kPsdCommandFields[i].signal;
      }
      msgs::EvCommand ev{};
      ev.driveTauRef_Nm = bad_value(bad_of(0), spec_of(kEvCommandFields[0]));
      std::array<Frame, 1> ev_frames;
      EXPECT_EQ(encode(ev, tx, ev_frames), bad_of(0) == Bad::kInRange ? 0 : 1);
      msgs::EvCommand ev_out{};
      receive_all<msgs::EvCommand, 1>(ev_frames, kEvCommandIds, ev_out);
      const SignalSpec& ev_spec = spec_of(kEvCommandFields[0]);
      const double ev_e = expected(bad_of(0), ev_spec);
      EXPECT_NEAR(ev_out.driveTauRef_Nm, ev_e, tolerance(ev_spec, ev_e));
    }
  }
}

TEST(CanCodec, TheRangeEndsThemselvesAreNotSaturated) {
  const SignalSpec& power = *find_signal(kPsdCommand1, "icePowRef_W");
  EXPECT_FALSE(to_raw(power, 250000.0).saturated);
  EXPECT_EQ(to_raw(power, 250000.0).value, 500000);
  EXPECT_FALSE(to_raw(power, -250000.0).saturated);
  EXPECT_EQ(to_raw(power, -250000.0).value, -500000);
  EXPECT_TRUE(to_raw(power, 250000.1).saturated);
  EXPECT_EQ(to_raw(power, 250000.1).value, 500000);
  EXPECT_TRUE(to_raw(power, kNaN).saturated);
  EXPECT_EQ(to_raw(power, kNaN).value, 0);
  EXPECT_EQ(to_raw(power, 0.74).value, 1);   // rounds to nearest
  EXPECT_EQ(to_raw(power, -0.76).value, -2);
  const SignalSpec& soc = *find_signal(kEvSensors1, "batSOC");
  EXPECT_FALSE(to_raw(soc, 0.0).saturated);
  EXPECT_TRUE(to_raw(soc, -1e-9).saturated);
  EXPECT_EQ(to_raw(soc, -1e-9).value, 0);
  EXPECT_EQ(to_raw(soc, 1.0).value, 1000000);

  // the EV's request torques (factor 0.1, +-50000 N m): US06's 11 800 N m is well inside
  for (const SignalSpec* s : {find_signal(kEvCommand, "driveTauRef_Nm"), find_signal(kEvSensors1, "driverRequest_Nm")}) {
    ASSERT_NE(s, nullptr);
    EXPECT_FALSE(to_raw(*s, 50000.0).saturated) << s->name;
    EXPECT_EQ(to_raw(*s, 50000.0).value, 500000) << s->name;
    EXPECT_FALSE(to_raw(*s, -50000.0).saturated) << s->name;
    EXPECT_EQ(to_raw(*s, -50000.0).value, -500000) << s->name;
    EXPECT_TRUE(to_raw(*s, 50000.01).saturated) << s->name;
    EXPECT_EQ(to_raw(*s, 50000.01).value, 500000) << s->name;
    EXPECT_TRUE(to_raw(*s, -50000.01).saturated) << s->name;
    EXPECT_EQ(to_raw(*s, -50000.01).value, -500000) << s->name;
    EXPECT_FALSE(to_raw(*s, -11800.0).saturated) << s->name;
    EXPECT_EQ(to_raw(*s, -11800.0).value, -118000) << s->name;
    EXPECT_EQ(to_raw(*s, 0.04).value, 0) << s->name;  // rounds to the nearest 0.1
    EXPECT_EQ(to_raw(*s, -0.06).value, -1) << s->name;
  }

  msgs::PsdCommand at_ends{};
  at_ends.icePowRef_W = 250000.0;
  at_ends.iceTauRef_Nm = -500.0;
  at_ends.genTauRef_Nm = 500.0;
  at_ends.motTauRef_Nm = -500.0;
  TxCounters tx;
  std::array<Frame, 2> frames;
  EXPECT_EQ(encode(at_ends, tx, frames), 0);
  // the EV command and sensor request at their ends: not counted, and back exactly
  for (double end : {-50000.0, 50000.0}) {
    msgs::EvCommand ev{};
    ev.driveTauRef_Nm = end;
    std::array<Frame, 1> ev_frames;
    EXPECT_EQ(encode(ev, tx, ev_frames), 0) << end;
    msgs::EvCommand ev_out{};
    receive_all<msgs::EvCommand, 1>(ev_frames, kEvCommandIds, ev_out);
    EXPECT_EQ(ev_out.driveTauRef_Nm, end);
    msgs::EvSensors sensors{};
    sensors.driverRequest_Nm = end;
    TxCounters sensor_tx;
    std::array<Frame, kEvSensorIds.size()> sensor_frames;
    EXPECT_EQ(encode(sensors, PlantStatus{}, sensor_tx, sensor_frames), 0) << end;
    msgs::EvSensors sensors_out{};
    receive_all<msgs::EvSensors, kEvSensorIds.size()>(sensor_frames, kEvSensorIds, sensors_out);
    EXPECT_EQ(sensors_out.driverRequest_Nm, end);
  }
}

// ---------------------------------------------------------------------------------------------
// Decode errors.

// A frame from raw payload bits (bit 0 = least significant bit of data[0]), packed here.
Frame frame_of(std::uint32_t id, std::uint64_t bits, std::uint8_t len = 8) {
  Frame f;
  f.id = id;
  f.len = len;
  for (std::size_t i = 0; i < 8; ++i) f.data[i] = static_cast<std::uint8_t>(bits >> (8 * i));
  return f;
}
std::uint64_t field_bits(std::int64_t raw, int start, int length) {
  return (static_cast<std::uint64_t>(raw) & ((1ULL << length) - 1)) << start;
}
Frame with_counter(Frame f, int counter) {
  f.data[7] = static_cast<std::uint8_t>((f.data[7] & 0x0F) | ((counter & 0x0F) << 4));
  return f;
}

TEST(CanDecode, CheckFrameNamesEachReason) {
  TxCounters tx;
  std::array<Frame, 2> cmd;
  msgs::PsdCommand c{};
  c.icePowRef_W = 1000.0;
  encode(c, tx, cmd);
  EXPECT_EQ(check_frame(cmd[0], kPsdCommandIds), Reject::kNone);
  EXPECT_EQ(check_frame(cmd[1], kPsdCommandIds), Reject::kNone);
  // unknown: not in the contract; in the contract but the other direction; the other family
  EXPECT_EQ(check_frame(frame_of(0x123, 0), kPsdCommandIds), Reject::kUnknownId);
  EXPECT_EQ(check_frame(frame_of(kPsdSensors1, 0), kPsdCommandIds), Reject::kUnknownId);
  EXPECT_EQ(check_frame(frame_of(kPlantStatus, 0), kPsdCommandIds), Reject::kUnknownId);
  EXPECT_EQ(check_frame(frame_of(kEvCommand, 0), kPsdCommandIds), Reject::kUnknownId);
  EXPECT_EQ(check_frame(cmd[0], kPsdSensorIds), Reject::kUnknownId);
  // wrong length
  Frame seven = cmd[0];
  seven.len = 7;
  Frame empty = cmd[0];
  empty.len = 0;
  EXPECT_EQ(check_frame(seven, kPsdCommandIds), Reject::kWrongLength);
  EXPECT_EQ(check_frame(empty, kPsdCommandIds), Reject::kWrongLength);
  // out of range: icePowRef_W (bits 0..19, signed, raw range -500000..500000)
  const std::int64_t raws[] = {524287, 500001, 500000, -500000, -500001, -524288, 0};
  const Reject want[] = {Reject::kOutOfRange, Reject::kOutOfRange, Reject::kNone, Reject::kNone,
                         Reject::kOutOfRange, Reject::kOutOfRange, Reject::kNone};
  for (std::size_t i = 0; i < std::size(raws); ++i) {
    EXPECT_EQ(check_frame(frame_of(kPsdCommand1, field_bits(raws[i], 0, 20)), kPsdCommandIds), want[i]) << raws[i];
    // the same raw in iceTauRef_Nm (bits 20..39), whose range is also -500000..500000 raw
    EXPECT_EQ(check_frame(frame_of(kPsdCommand1, field_bits(raws[i], 20, 20)), kPsdCommandIds), want[i]) << raws[i];
  }
  // by hand: FF FF 07 = raw 0x7FFFF = 524287 in icePowRef_W
  Frame hand = frame_of(kPsdCommand1, 0);
  hand.data = {0xFF, 0xFF, 0x07, 0, 0, 0, 0, 0};
  EXPECT_EQ(check_frame(hand, kPsdCommandIds), Reject::kOutOfRange);
  hand.data = {0x20, 0xA1, 0x07, 0, 0, 0, 0, 0};  // 0x7A120 = 500000: the maximum
  EXPECT_EQ(check_frame(hand, kPsdCommandIds), Reject::kNone);
  hand.data = {0xDF, 0x5E, 0x08, 0, 0, 0, 0, 0};  // 0x85EDF = -500001
  EXPECT_EQ(check_frame(hand, kPsdCommandIds), Reject::kOutOfRange);
  // unsigned: batSOC (bits 40..59, raw 0..1000000)
  EXPECT_EQ(check_frame(frame_of(kEvSensors1, field_bits(1000000, 40, 20)), kEvSensorIds), Reject::kNone);
  EXPECT_EQ(check_frame(frame_of(kEvSensors1, field_bits(1000001, 40, 20)), kEvSensorIds), Reject::kOutOfRange);
  EXPECT_EQ(check_frame(frame_of(kEvSensors1, field_bits(1048575, 40, 20)), kEvSensorIds), Reject::kOutOfRange);
  // the EV's request torques (bits 0..19, signed, raw range -500000..500000 at factor 0.1)
  for (std::size_t i = 0; i < std::size(raws); ++i) {
    EXPECT_EQ(check_frame(frame_of(kEvCommand, field_bits(raws[i], 0, 20)), kEvCommandIds), want[i]) << raws[i];
    EXPECT_EQ(check_frame(frame_of(kEvSensors1, field_bits(raws[i], 0, 20)), kEvSensorIds), want[i]) << raws[i];
  }
  // a full 32-bit step and 8-bit fault are always in range
  EXPECT_EQ(check_frame(frame_of(kPlantStatus, 0x0FFFFFFFFFFFFFFFULL), kEvSensorIds), Reject::kNone);
  EXPECT_STREQ(reject_name(Reject::kOutOfRange), "out_of_range");
  EXPECT_STREQ(reject_name(Reject::kBadCounter), "bad_counter");
  EXPECT_STREQ(reject_name(Reject::kUnknownId), "unknown_id");
  EXPECT_STREQ(reject_name(Reject::kWrongLength), "wrong_length");
  EXPECT_STREQ(reject_name(Reject::kStale), "stale");
  // every sampleStep is in range (16 unsigned bits, [0, 65535])
  EXPECT_EQ(check_frame(frame_of(kEvCommand, field_bits(0xFFFF, 44, 16)), kEvCommandIds), Reject::kNone);
  EXPECT_EQ(check_frame(frame_of(kPsdCommand2, field_bits(0xFFFF, 44, 16)), kPsdCommandIds), Reject::kNone);
}

TEST(CanDecode, CounterRuleAcceptsJumpsOfOneToThree) {
  for (int last = 0; last < 16; ++last) {
    for (int delta = 0; delta < 16; ++delta) {
      const int want = delta >= 1 && delta <= 3 ? delta : 0;
      EXPECT_EQ(counter_step(last, (last + delta) % 16), want) << last << " + " << delta;
    }
  }
  for (int c = 0; c < 16; ++c) EXPECT_EQ(counter_step(-1, c), 1);  // no last counter: any
}

// A sender that lost more frames than the rule allows (or whose counter a fault moved) is
// refused once and heard again from its next frame in order, as an E2E receiver does after a
// wrong sequence; a frozen sender stays refused.
TEST(CanDecode, FilterHearsASenderAgainAfterARefusedJump) {
  FrameFilter filter(kPsdCommandIds);
  TxCounters tx;
  std::array<Frame, 2> f;
  encode(msgs::PsdCommand{}, tx, f);
  EXPECT_EQ(filter.accept(with_counter(f[0], 1)), Reject::kNone);
  EXPECT_EQ(filter.accept(with_counter(f[0], 9)), Reject::kBadCounter);  // a jump of 8
  EXPECT_EQ(filter.accept(with_counter(f[0], 10)), Reject::kNone);       // the next in order
  EXPECT_EQ(filter.accept(with_counter(f[0], 10)), Reject::kBadCounter);  // a repeat
  EXPECT_EQ(filter.accept(with_counter(f[0], 10)), Reject::kBadCounter);  // still
  EXPECT_EQ(filter.accept(with_counter(f[0], 11)), Reject::kNone);
  EXPECT_EQ(filter.stats().lost, 0);
  EXPECT_EQ(filter.stats().bad_counter, 3);
}

TEST(CanDecode, FilterCountsEveryReasonAndRejectedFramesChangeNothing) {
  FrameFilter filter(kPsdCommandIds);
  msgs::PsdCommand cmd{};
  const auto feed = [&](const Frame& f) {
    const Reject r = filter.accept(f);
    if (r == Reject::kNone) apply(f, cmd);
    return r;
  };
  TxCounters tx;
  std::array<Frame, 2> good;
  msgs::PsdCommand first{};
  first.icePowRef_W = 1000.0;
  first.iceTauRef_Nm = 12.5;
  first.genTauRef_Nm = -3.0;
  first.motTauRef_Nm = 40.0;
  first.iceON = false;
  encode(first, tx, good);
  cmd.iceON = true;
  EXPECT_EQ(feed(with_counter(good[0], 5)), Reject::kNone);  // the first: any counter
  EXPECT_EQ(feed(with_counter(good[1], 11)), Reject::kNone);  // its own counter per id
  EXPECT_EQ(cmd.icePowRef_W, 1000.0);
  EXPECT_FALSE(cmd.iceON);
  EXPECT_EQ(cmd.genTauRef_Nm, -3.0);

  // frames that must be rejected, each with other values, none of which may arrive
  msgs::PsdCommand other{};
  other.icePowRef_W = -2000.0;
  other.iceTauRef_Nm = -99.0;
  other.genTauRef_Nm = 77.0;
  other.motTauRef_Nm = -1.0;
  other.iceON = true;
  std::array<Frame, 2> bad;
  encode(other, tx, bad);
  const msgs::PsdCommand before = cmd;
  EXPECT_EQ(feed(frame_of(0x7FF, 0)), Reject::kUnknownId);
  EXPECT_EQ(feed(with_counter(frame_of(kPsdSensors1, 0), 6)), Reject::kUnknownId);
  EXPECT_EQ(feed(with_counter(frame_of(kEvCommand, 0), 6)), Reject::kUnknownId);
  Frame seven = with_counter(bad[0], 6);
  seven.len = 7;
  Frame empty = with_counter(bad[0], 6);
  empty.len = 0;
  EXPECT_EQ(feed(seven), Reject::kWrongLength);
  EXPECT_EQ(feed(empty), Reject::kWrongLength);
  EXPECT_EQ(feed(with_counter(bad[0], 5)), Reject::kBadCounter);  // a repeat: a frozen sender
  // a larger jump is rejected and its counter kept (the next in order would be heard): each
  // jump from the last rejected one, 5 + 4 + 5 + ... + 15 = 7 (mod 16) at the end
  int last = 5;
  for (int jump = 4; jump <= 15; ++jump) {
    last = (last + jump) % 16;
    EXPECT_EQ(feed(with_counter(bad[0], last)), Reject::kBadCounter) << jump;
  }
  ASSERT_EQ(last, 7);
  Frame beyond = frame_of(kPsdCommand1, field_bits(524287, 0, 20) | field_bits(6, 60, 4));
  EXPECT_EQ(feed(beyond), Reject::kOutOfRange);
  Frame below = frame_of(kPsdCommand1, field_bits(-500001, 20, 20) | field_bits(6, 60, 4));
  EXPECT_EQ(feed(below), Reject::kOutOfRange);
  EXPECT_EQ(cmd.icePowRef_W, before.icePowRef_W);
  EXPECT_EQ(cmd.iceTauRef_Nm, before.iceTauRef_Nm);
  EXPECT_EQ(cmd.genTauRef_Nm, before.genTauRef_Nm);
  EXPECT_EQ(cmd.motTauRef_Nm, before.motTauRef_Nm);
  EXPECT_EQ(cmd.iceON, before.iceON);
  RxStats s = filter.stats();
  EXPECT_EQ(s.accepted, 2);
  EXPECT_EQ(s.unknown_id, 3);
  EXPECT_EQ(s.wrong_length, 2);
  EXPECT_EQ(s.bad_counter, 13);
  EXPECT_EQ(s.out_of_range, 2);
  EXPECT_EQ(s.lost, 0);

  // jumps of 1, 2, 3 are accepted (1 and 2 frames lost), across the wrap 15 -> 0
  EXPECT_EQ(feed(with_counter(bad[0], 8)), Reject::kNone);   // 7 (the last jump, kept) -> 8
  EXPECT_EQ(cmd.icePowRef_W, -2000.0);
  EXPECT_TRUE(cmd.iceON);
  EXPECT_EQ(feed(with_counter(good[0], 10)), Reject::kNone);  // 8 -> 10: one lost
  EXPECT_EQ(cmd.icePowRef_W, 1000.0);
  EXPECT_EQ(feed(with_counter(bad[0], 13)), Reject::kNone);  // 10 -> 13: two lost
  EXPECT_EQ(feed(with_counter(bad[0], 0)), Reject::kNone);   // 13 -> 0: three steps, two lost
  EXPECT_EQ(feed(with_counter(bad[0], 3)), Reject::kNone);   // 0 -> 3: two lost
  EXPECT_EQ(feed(with_counter(bad[1], 12)), Reject::kNone);  // the other id: 11 -> 12
  EXPECT_EQ(cmd.genTauRef_Nm, 77.0);
  s = filter.stats();
  EXPECT_EQ(s.accepted, 8);
  EXPECT_EQ(s.lost, 7);
  EXPECT_EQ(s.bad_counter, 13);

  // after resync any counter is taken as it is: a repeat and a jump of 8, nothing counted lost
  filter.resync();
  EXPECT_EQ(feed(with_counter(good[0], 1)), Reject::kNone);
  EXPECT_EQ(feed(with_counter(good[1], 4)), Reject::kNone);
  EXPECT_EQ(feed(with_counter(good[0], 1)), Reject::kBadCounter);  // and the rule is back
  EXPECT_EQ(feed(with_counter(good[0], 2)), Reject::kNone);
  s = filter.stats();
  EXPECT_EQ(s.accepted, 11);
  EXPECT_EQ(s.lost, 7);
  EXPECT_EQ(s.bad_counter, 14);
  EXPECT_EQ(s.unknown_id, 3);
  EXPECT_EQ(s.wrong_length, 2);
  EXPECT_EQ(s.out_of_range, 2);
}

// ---------------------------------------------------------------------------------------------
// Freshness: a command echoes the step of the sample it answers (sampleStep, mod 2^16).

// A command frame built by hand: its sampleStep echo and counter, nothing else.
Frame command_with_echo(std::uint32_t id, std::uint32_t echo, int counter) {
  return frame_of(id, field_bits(echo, 44, 16) | field_bits(counter, 60, 4));
}

TEST(CanFreshness, CommandAgeIsTheSampleMinusTheEchoModulo65536) {
  const struct {
    std::uint32_t sample, echo, age;
  } cases[] = {
      {0, 0, 0},          {7, 7, 0},         {8, 7, 1},           {7, 8, 65535},  // one ahead: as old as can be
      {3, 65534, 5},      {0, 65535, 1},     {65535, 0, 65535},   {65535, 65535, 0},
      {65536, 0, 0},      {65536 + 10, 10, 0}, {65536 + 10, 9, 1}, {123456, 57920, 0},  // the full step
      {0xFFFFFFFFu, 0xFFFF, 0}, {0xFFFFFFFFu, 0xFFF0, 15}, {2, 0xFFFF, 3}, {1000, 0, 1000},
  };
  for (const auto& c : cases) {
    for (std::uint32_t id : {kPsdCommand1, kPsdCommand2, kEvCommand}) {
      for (int counter : {0, 9, 15}) {
        EXPECT_EQ(command_age_steps(command_with_echo(id, c.echo, counter), c.sample), c.age)
            << std::hex << id << std::dec << " sample " << c.sample << " echo " << c.echo;
      }
    }
  }
  // the other fields do not move it: a full encoded command
  msgs::EvCommand ev{};
  ev.stamp.step = 65534;
  ev.driveTauRef_Nm = -50000.0;  // the minimum: raw -500000
  TxCounters tx;
  std::array<Frame, 1> f;
  encode(ev, tx, f);
  EXPECT_EQ(command_age_steps(f[0], 65536 + 3), 5u);
  EXPECT_EQ(command_age_steps(f[0], 65534), 0u);
  // by hand: sampleStep 0xFFFE = bytes 5..7 E0 FF 0F (counter 0)
  Frame hand = frame_of(kEvCommand, 0);
  hand.data = {0, 0, 0, 0, 0, 0xE0, 0xFF, 0x0F};
  EXPECT_EQ(command_age_steps(hand, 3), 5u);
}

TEST(CanFreshness, FilterRejectsStaleCommandsBeforeTheirCounter) {
  FrameFilter filter(kEvCommandIds);
  Freshness fresh{100, 0};  // lockstep: only the command for sample 100
  EXPECT_EQ(filter.accept(command_with_echo(kEvCommand, 100, 4), &fresh), Reject::kNone);  // age 0, max 0
  // age 1 with max 0: stale, counted, and the counter state stays at 4
  fresh.sample_step = 101;
  EXPECT_EQ(filter.accept(command_with_echo(kEvCommand, 100, 5), &fresh), Reject::kStale);
  EXPECT_EQ(filter.stats().stale, 1);
  EXPECT_EQ(filter.stats().accepted, 1);
  EXPECT_EQ(filter.stats().bad_counter, 0);
  EXPECT_EQ(filter.stats().lost, 0);
  // the fresh frame with the same counter 5 (c + 1) is accepted, nothing lost
  EXPECT_EQ(filter.accept(command_with_echo(kEvCommand, 101, 5), &fresh), Reject::kNone);
  EXPECT_EQ(filter.stats().lost, 0);
  EXPECT_EQ(filter.stats().accepted, 2);
  // a stale replay whose counter would be a repeat is stale, not a bad counter
  EXPECT_EQ(filter.accept(command_with_echo(kEvCommand, 90, 5), &fresh), Reject::kStale);
  // a command for a sample not sent yet (age 65535) is stale too
  EXPECT_EQ(filter.accept(command_with_echo(kEvCommand, 102, 6), &fresh), Reject::kStale);
  EXPECT_EQ(filter.stats().stale, 3);
  EXPECT_EQ(filter.stats().bad_counter, 0);

  // age <= max_age_steps is accepted, age max + 1 is not; across the 2^16 wrap
  fresh = Freshness{65536 + 2, 3};
  EXPECT_EQ(filter.accept(command_with_echo(kEvCommand, 65535, 6), &fresh), Reject::kNone);  // age 3
  EXPECT_EQ(filter.accept(command_with_echo(kEvCommand, 65534, 7), &fresh), Reject::kStale);  // age 4
  EXPECT_EQ(filter.accept(command_with_echo(kEvCommand, 0, 7), &fresh), Reject::kNone);       // age 2
  EXPECT_EQ(filter.accept(command_with_echo(kEvCommand, 1, 8), &fresh), Reject::kNone);       // age 1
  EXPECT_EQ(filter.accept(command_with_echo(kEvCommand, 2, 9), &fresh), Reject::kNone);       // age 0
  RxStats s = filter.stats();
  EXPECT_EQ(s.accepted, 6);
  EXPECT_EQ(s.stale, 4);
  EXPECT_EQ(s.lost, 0);
  EXPECT_EQ(s.bad_counter, 0);
  // without a Freshness the echo is not looked at
  EXPECT_EQ(filter.accept(command_with_echo(kEvCommand, 40000, 10)), Reject::kNone);
  // the other checks come first: a stale frame of a wrong length is wrong_length
  Frame short_stale = command_with_echo(kEvCommand, 0, 11);
  short_stale.len = 7;
  EXPECT_EQ(filter.accept(short_stale, &fresh), Reject::kWrongLength);
  s = filter.stats();
  EXPECT_EQ(s.accepted, 7);
  EXPECT_EQ(s.stale, 4);
  EXPECT_EQ(s.wrong_length, 1);

  // both PSD command frames, each with its own counter; encoded by the codec
  FrameFilter psd(kPsdCommandIds);
  TxCounters tx;
  std::array<Frame, 2> frames;
  msgs::PsdCommand c{};
  for (std::int64_t step = 65530; step < 65545; ++step) {
    c.stamp.step = step;
    encode(c, tx, frames);
    const Freshness now{static_cast<std::uint32_t>(step), 0};
    const Freshness next{static_cast<std::uint32_t>(step + 1), 0};
    EXPECT_EQ(psd.accept(frames[0], &next), Reject::kStale) << step;  // a sample late
    EXPECT_EQ(psd.accept(frames[0], &now), Reject::kNone) << step;
    EXPECT_EQ(psd.accept(frames[1], &next), Reject::kStale) << step;
    EXPECT_EQ(psd.accept(frames[1], &now), Reject::kNone) << step;
  }
  EXPECT_EQ(psd.stats().accepted, 30);
  EXPECT_EQ(psd.stats().stale, 30);
  EXPECT_EQ(psd.stats().lost, 0);
  EXPECT_EQ(psd.stats().bad_counter, 0);
}

// Sensor frames and PlantStatus have no sampleStep: never stale, whatever their bits 44..59.
TEST(CanFreshness, FramesWithoutSampleStepAreNeverStale) {
  const Freshness strict{12345, 0};
  std::mt19937_64 rng(5);
  FrameFilter psd(kPsdSensorIds), ev(kEvSensorIds);
  TxCounters tx;
  for (int i = 0; i < 20; ++i) {
    const msgs::PsdSensors ps = fill(kPsdSensorFields, Pick::kRandom, rng);
    const msgs::EvSensors es = fill(kEvSensorFields, Pick::kRandom, rng);
    const PlantStatus st{static_cast<std::uint32_t>(rng()), 0xA5u, true, true};  // step, fault at 44..59: no
    std::array<Frame, kPsdSensorIds.size()> pf;
    std::array<Frame, kEvSensorIds.size()> ef;
    encode(ps, st, tx, pf);
    encode(es, st, tx, ef);
    for (const Frame& f : pf) EXPECT_EQ(psd.accept(f, &strict), Reject::kNone) << std::hex << f.id;
    for (const Frame& f : ef) EXPECT_EQ(ev.accept(f, &strict), Reject::kNone) << std::hex << f.id;
  }
  // a sensor frame whose bits 44..59 would be an old echo (batSOC raw 0x12340 at 40..59: 0x1234)
  FrameFilter one(kEvSensorIds);
  const Frame soc = frame_of(kEvSensors1, field_bits(0x12340, 40, 20));
  EXPECT_EQ(check_frame(soc, kEvSensorIds), Reject::kNone);
  EXPECT_EQ(one.accept(soc, &strict), Reject::kNone);
  EXPECT_EQ(psd.stats().stale + ev.stats().stale + one.stats().stale, 0);
  EXPECT_EQ(psd.stats().accepted, 140);
  EXPECT_EQ(ev.stats().accepted, 80);
}

TEST(CanDecode, TxCountersCountPerIdModuloSixteen) {
  TxCounters tx;
  std::array<Frame, 1> ev;
  for (int i = 0; i < 20; ++i) {
    encode(msgs::EvCommand{}, tx, ev);
    EXPECT_EQ(ev[0].data[7] >> 4, i % 16) << i;
  }
  std::array<Frame, 2> psd;
  encode(msgs::PsdCommand{}, tx, psd);  // other ids start at 0
  EXPECT_EQ(psd[0].data[7] >> 4, 0);
  EXPECT_EQ(psd[1].data[7] >> 4, 0);
  // a receiver accepts the whole stream, wrap included, losing nothing
  FrameFilter filter(kEvCommandIds);
  TxCounters tx2;
  for (int i = 0; i < 40; ++i) {
    encode(msgs::EvCommand{}, tx2, ev);
    EXPECT_EQ(filter.accept(ev[0]), Reject::kNone) << i;
  }
  EXPECT_EQ(filter.stats().lost, 0);
}

// ---------------------------------------------------------------------------------------------
// Golden frames: tests/data/can/golden_frames.log (how it was made and four frames computed
// by hand: tests/data/can/README.md).

struct GoldenSet {
  msgs::PsdSensors psd;
  PlantStatus psd_status;
  msgs::EvSensors ev;
  PlantStatus ev_status;
  msgs::PsdCommand psd_cmd;
  msgs::EvCommand ev_cmd;
};

GoldenSet golden_values() {
  GoldenSet g;
  g.psd.driverRequest = 0.75;
  g.psd.speed_m_s = 22.2222;
  g.psd.batSOC = 0.6;
  g.psd.iceW_rad_s = 209.44;
  g.psd.icePowDel_W = 45000.5;
  g.psd.genW_rad_s = -1234.56;
  g.psd.genPowDel_W = -20000.0;
  g.psd.genTauLim_Nm = 75.5;
  g.psd.motW_rad_s = 2345.67;
  g.psd.motPowDelA_W = 10000.0;
  g.psd.motPowDelB_W = 30000.5;
  g.psd.motPowDelAB_W = 40000.5;
  g.psd.motTauLim_Nm = 163.123;
  g.psd.batPowDel_W = -15000.5;
  g.psd.battery_voltage_V = 201.6;
  g.psd.battery_current_A = -74.4;
  g.psd_status = {305419896u /* 0x12345678 */, 5u, true, false};
  g.ev.driverRequest_Nm = -11800.0;  // US06's largest request, beyond the old +-5000 N m
  g.ev.speed_m_s = 10.0;
  g.ev.batSOC = 0.55;
  g.ev.driveW_rad_s = 314.16;
  g.ev.driveTauLim_Nm = 2500.0;
  g.ev.drivePowDel_W = -50000.0;
  g.ev.batPowDel_W = -52000.5;
  g.ev.battery_voltage_V = 350.0;
  g.ev.battery_current_A = -148.572;
  g.ev_status = {4294967295u, 8u, false, true};
  g.psd_cmd.icePowRef_W = 30000.5;
  g.psd_cmd.iceTauRef_Nm = -120.25;
  g.psd_cmd.genTauRef_Nm = -45.678;
  g.psd_cmd.motTauRef_Nm = 210.001;
  g.psd_cmd.iceON = true;
  g.psd_cmd.stamp.step = 305419896;  // answers the PSD sample (0x12345678): sampleStep 0x5678
  g.ev_cmd.driveTauRef_Nm = 12.3;  // raw 123 = 0x7B
  g.ev_cmd.stamp.step = 175053;  // 0x2ABCD: sampleStep 0xABCD (mod 2^16)
  return g;
}

constexpr double kGoldenT0_s = 1700000000.0;

// All 14 frames in one sequence with one TxCounters (so the second PlantStatus has counter 1).
std::vector<Frame> golden_frames(const GoldenSet& g) {
  TxCounters tx;
  std::array<Frame, kPsdSensorIds.size()> psd;
  std::array<Frame, kEvSensorIds.size()> ev;
  std::array<Frame, kPsdCommandIds.size()> psd_cmd;
  std::array<Frame, kEvCommandIds.size()> ev_cmd;
  EXPECT_EQ(encode(g.psd, g.psd_status, tx, psd), 0);
  EXPECT_EQ(encode(g.ev, g.ev_status, tx, ev), 0);
  EXPECT_EQ(encode(g.psd_cmd, tx, psd_cmd), 0);
  EXPECT_EQ(encode(g.ev_cmd, tx, ev_cmd), 0);
  std::vector<Frame> all(psd.begin(), psd.end());
  all.insert(all.end(), ev.begin(), ev.end());
  all.insert(all.end(), psd_cmd.begin(), psd_cmd.end());
  all.insert(all.end(), ev_cmd.begin(), ev_cmd.end());
  return all;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) lines.push_back(line);
  return lines;
}

TEST(CanGolden, FramesMatchTheGoldenLog) {
  const std::vector<Frame> frames = golden_frames(golden_values());
  ASSERT_EQ(frames.size(), 14u);
  std::string log;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    append_candump_line(log, kGoldenT0_s + 0.001 * static_cast<double>(i), "vcan0", frames[i]);
  }
  const std::string path = std::string(EHPT_TEST_DATA_DIR) + "/can/golden_frames.log";
  const std::string golden = read_text(path);
  const std::vector<std::string> want = lines_of(golden), got = lines_of(log);
  EXPECT_EQ(got.size(), want.size()) << path;
  for (std::size_t i = 0; i < std::min(got.size(), want.size()); ++i) {
    EXPECT_EQ(got[i], want[i]) << path << ":" << i + 1;
  }
  if (log != golden) {
    const auto actual = test::scratch_root() / "golden_frames.actual.log";
    std::ofstream(actual) << log;
    ADD_FAILURE() << "differs from " << path << "; this run's output:\n" << log;
  }
  // the frames computed by hand in tests/data/can/README.md, independent of the file
  ASSERT_EQ(got.size(), 14u);
  EXPECT_EQ(got[7], "(1700000000.007000) vcan0 220#10330E350C706408");   // EvSensors1
  EXPECT_EQ(got[10], "(1700000000.010000) vcan0 200#FFFFFFFF08020010");  // PlantStatus, counter 1
  EXPECT_EQ(got[11], "(1700000000.011000) vcan0 110#61EA60A4E2816705");  // PsdCommand1, sampleStep 0x5678
  EXPECT_EQ(got[13], "(1700000000.013000) vcan0 120#7B00000000D0BC0A");  // EvCommand, sampleStep 0xABCD
}

TEST(CanGolden, GoldenLinesParseAndDecodeToTheOriginalValues) {
  const GoldenSet g = golden_values();
  const std::string path = std::string(EHPT_TEST_DATA_DIR) + "/can/golden_frames.log";
  const std::vector<std::string> lines = lines_of(read_text(path));
  ASSERT_EQ(lines.size(), 14u) << path;
  std::vector<Frame> frames;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    CandumpLine c;
    const char* why = nullptr;
    ASSERT_TRUE(parse_candump_line(lines[i], c, why)) << lines[i] << ": " << (why ? why : "");
    EXPECT_EQ(c.interface_name, "vcan0");
    EXPECT_NEAR(c.time_s, kGoldenT0_s + 0.001 * static_cast<double>(i), 1e-6);
    EXPECT_EQ(c.frame.len, 8);
    frames.push_back(c.frame);
  }
  const std::vector<Frame> encoded = golden_frames(g);
  for (std::size_t i = 0; i < frames.size(); ++i) EXPECT_TRUE(frames[i] == encoded[i]) << lines[i];

  msgs::PsdSensors psd{};
  PlantStatus psd_status{};
  receive_all<msgs::PsdSensors, 7>(std::span<const Frame, 7>(frames.data(), 7), kPsdSensorIds, psd, &psd_status);
  expect_fields_near(kPsdSensorFields, g.psd, psd, "golden PsdSensors");
  EXPECT_EQ(psd_status.step, 305419896u);
  EXPECT_EQ(psd_status.fault, 5u);
  EXPECT_TRUE(psd_status.locked);
  EXPECT_FALSE(psd_status.ecu_timeout);

  msgs::EvSensors ev{};
  PlantStatus ev_status{};
  receive_all<msgs::EvSensors, 4>(std::span<const Frame, 4>(frames.data() + 7, 4), kEvSensorIds, ev, &ev_status);
  expect_fields_near(kEvSensorFields, g.ev, ev, "golden EvSensors");
  EXPECT_EQ(ev_status.step, 4294967295u);
  EXPECT_EQ(ev_status.fault, 8u);
  EXPECT_FALSE(ev_status.locked);
  EXPECT_TRUE(ev_status.ecu_timeout);

  msgs::PsdCommand psd_cmd{};
  psd_cmd.iceON = false;
  receive_all<msgs::PsdCommand, 2>(std::span<const Frame, 2>(frames.data() + 11, 2), kPsdCommandIds, psd_cmd);
  expect_fields_near(kPsdCommandFields, g.psd_cmd, psd_cmd, "golden PsdCommand");
  EXPECT_TRUE(psd_cmd.iceON);

  msgs::EvCommand ev_cmd{};
  receive_all<msgs::EvCommand, 1>(std::span<const Frame, 1>(frames.data() + 13, 1), kEvCommandIds, ev_cmd);
  EXPECT_NEAR(ev_cmd.driveTauRef_Nm, 12.3, 1e-9);
  // the sampleStep echoes: each command is fresh for its own sample only
  for (std::size_t i : {std::size_t{11}, std::size_t{12}}) {
    EXPECT_EQ(sample_step_of(frames[i]), 0x5678u) << lines[i];
    EXPECT_EQ(command_age_steps(frames[i], 305419896u), 0u) << lines[i];
    EXPECT_EQ(command_age_steps(frames[i], 305419897u), 1u) << lines[i];
  }
  EXPECT_EQ(sample_step_of(frames[13]), 0xABCDu);
  EXPECT_EQ(command_age_steps(frames[13], 175053u), 0u);
  // the hand-computed values: exact raws
  EXPECT_NEAR(ev.driverRequest_Nm, -11800.0, 1e-9);
  EXPECT_NEAR(ev.batSOC, 0.55, 1e-12);
  EXPECT_NEAR(psd_cmd.iceTauRef_Nm, -120.25, 1e-9);
  EXPECT_NEAR(psd_cmd.icePowRef_W, 30000.5, 1e-9);
}

// ---------------------------------------------------------------------------------------------
// candump -L lines.

TEST(CandumpLine, ValidLinesRoundTrip) {
  const std::string lines[] = {"(1700000000.123456) vcan0 123#1122334455667788", "(0.000001) can0 7FF#",
                               "(1700000000.000000) vcan0 000#00", "(12.500000) a_long_name 210#DEADBEEF"};
  for (const std::string& line : lines) {
    const std::string with_newline = line + "\n";  // outlives c.interface_name, a view into it
    CandumpLine c;
    const char* why = nullptr;
    ASSERT_TRUE(parse_candump_line(with_newline, c, why)) << line << ": " << (why ? why : "");
    std::string out;
    append_candump_line(out, c.time_s, c.interface_name, c.frame);
    EXPECT_EQ(out, with_newline);
  }
  CandumpLine c;
  const char* why = nullptr;
  ASSERT_TRUE(parse_candump_line("(1700000000.123456) vcan0 1a2#0aFf\r\n", c, why));
  EXPECT_NEAR(c.time_s, 1700000000.123456, 1e-6);
  EXPECT_EQ(c.interface_name, "vcan0");
  EXPECT_EQ(c.frame.id, 0x1A2u);
  EXPECT_EQ(c.frame.len, 2);
  EXPECT_EQ(c.frame.data[0], 0x0A);
  EXPECT_EQ(c.frame.data[1], 0xFF);
  EXPECT_EQ(c.frame.data[2], 0x00);
  ASSERT_TRUE(parse_candump_line("(1.5) vcan0 123#1122334455667788", c, why));
  EXPECT_EQ(c.frame.len, 8);
  EXPECT_EQ(c.frame.data[7], 0x88);
  EXPECT_EQ(c.frame.data[3], 0x44);
  EXPECT_DOUBLE_EQ(c.time_s, 1.5);
  // the time is written in whole microseconds
  std::string out;
  append_candump_line(out, 1.0000004, "vcan0", c.frame);
  EXPECT_EQ(out, "(1.000000) vcan0 123#1122334455667788\n");
}

TEST(CandumpLine, MalformedLinesAreRejectedWithAReason) {
  const std::string bad[] = {
      "1700000000.000000) vcan0 123#11",        // no '('
      "(1700000000.000000 vcan0 123#11",        // no ')'
      "(1700000000.000000) vcan0 123#1G",       // bad hex in the data
      "(1700000000.000000) vcan0 1G3#11",       // bad hex in the id
      "(1700000000.000000) vcan0 123#112",      // odd number of data digits
      "(1700000000.000000) vcan0 123#112233445566778899",  // 9 bytes
      "(1700000000.000000) vcan0 1234#11",      // a 4-digit id (neither form)
      "(1700000000.000000) vcan0 800#11",       // above 0x7FF
      "(1700000000.000000) vcan0 123",          // no '#'
      "(17000x0000.000000) vcan0 123#11",       // not a time stamp
      "(1700000000.000000)vcan0 123#11",        // no space after ')'
      "(1700000000.000000) vcan0",              // no frame
      "",
  };
  for (const std::string& line : bad) {
    CandumpLine c;
    const char* why = nullptr;
    EXPECT_FALSE(parse_candump_line(line, c, why)) << line;
    EXPECT_NE(why, nullptr) << line;
    if (why != nullptr) {
      EXPECT_GT(std::string(why).size(), 5u) << line;
    }
  }
  // an id of 4..7 or 9 digits is neither form
  CandumpLine c;
  const char* why = nullptr;
  ASSERT_FALSE(parse_candump_line("(1700000000.000000) vcan0 0000123#11", c, why));
  ASSERT_NE(why, nullptr);
  EXPECT_NE(std::string(why).find("8-digit"), std::string::npos) << why;
  // 8 digits are an extended id, kept as one; written back the same
  ASSERT_TRUE(parse_candump_line("(1700000000.000000) vcan0 18FF0123#1122", c, why)) << why;
  EXPECT_TRUE(c.frame.extended);
  EXPECT_EQ(c.frame.id, 0x18FF0123u);
  std::string back;
  append_candump_line(back, 1700000000.0, "vcan0", c.frame);
  EXPECT_EQ(back, "(1700000000.000000) vcan0 18FF0123#1122\n");
  ASSERT_TRUE(parse_candump_line("(1700000000.000000) vcan0 00000123#11", c, why)) << why;
  EXPECT_TRUE(c.frame.extended);
  EXPECT_EQ(c.frame.id, 0x123u);
  // an extended frame is never one of the contract's, whatever its id
  Frame ext;
  ext.id = kPsdCommand1;
  ext.len = 8;
  ext.extended = true;
  EXPECT_EQ(check_frame(ext, kPsdCommandIds), Reject::kUnknownId);
}

// ---------------------------------------------------------------------------------------------
// socketcand messages.

TEST(Socketcand, SendAsPythonCanWritesIt) {
  Frame f;
  ASSERT_EQ(parse_socketcand("< send 120 8 78 ec f 0 0 0 0 0 >", f), SocketcandMessage::kSend);
  EXPECT_EQ(f.id, 0x120u);
  EXPECT_EQ(f.len, 8);
  const std::array<std::uint8_t, 8> want = {0x78, 0xEC, 0x0F, 0, 0, 0, 0, 0};
  EXPECT_EQ(f.data, want);
  ASSERT_EQ(parse_socketcand("< send 7FF 2 AA 55 >", f), SocketcandMessage::kSend);
  EXPECT_EQ(f.id, 0x7FFu);
  EXPECT_EQ(f.len, 2);
  EXPECT_EQ(f.data[0], 0xAA);
  EXPECT_EQ(f.data[1], 0x55);
  ASSERT_EQ(parse_socketcand("< send 1 0 >", f), SocketcandMessage::kSend);
  EXPECT_EQ(f.id, 1u);
  EXPECT_EQ(f.len, 0);
  EXPECT_FALSE(f.extended);
}

// Extended ids: 8 digits (socketcand's rule), or any id above 0x7FF (python-can 4.1 writes
// "{id:X}" without leading zeros); the plant writes them back with 8 digits.
TEST(Socketcand, ExtendedIds) {
  Frame f;
  ASSERT_EQ(parse_socketcand("< send 18FF50E5 2 1 2 >", f), SocketcandMessage::kSend);
  EXPECT_TRUE(f.extended);
  EXPECT_EQ(f.id, 0x18FF50E5u);
  ASSERT_EQ(parse_socketcand("< send 800 1 0 >", f), SocketcandMessage::kSend);
  EXPECT_TRUE(f.extended);
  EXPECT_EQ(f.id, 0x800u);
  ASSERT_EQ(parse_socketcand("< send 00000123 1 0 >", f), SocketcandMessage::kSend);
  EXPECT_TRUE(f.extended);
  EXPECT_EQ(f.id, 0x123u);
  ASSERT_EQ(parse_socketcand("< send 123 1 0 >", f), SocketcandMessage::kSend);
  EXPECT_FALSE(f.extended);
  ASSERT_EQ(parse_socketcand("< frame 1ABCDEF0 1.0 11 >", f), SocketcandMessage::kFrame);
  EXPECT_TRUE(f.extended);
  EXPECT_EQ(f.id, 0x1ABCDEF0u);
}

TEST(Socketcand, FramesParse) {
  Frame f;
  ASSERT_EQ(parse_socketcand("< frame 123 1700000000.000000 11223344 >", f), SocketcandMessage::kFrame);
  EXPECT_EQ(f.id, 0x123u);
  EXPECT_EQ(f.len, 4);
  const std::array<std::uint8_t, 8> want = {0x11, 0x22, 0x33, 0x44, 0, 0, 0, 0};
  EXPECT_EQ(f.data, want);
  f.len = 5;
  ASSERT_EQ(parse_socketcand("< frame 123 1.0 >", f), SocketcandMessage::kFrame);
  EXPECT_EQ(f.id, 0x123u);
  EXPECT_EQ(f.len, 0);
  ASSERT_EQ(parse_socketcand("< frame 220 1.5 10330E350C706408 >", f), SocketcandMessage::kFrame);
  EXPECT_EQ(f.len, 8);
  EXPECT_EQ(f.data[0], 0x10);
  EXPECT_EQ(f.data[7], 0x08);
}

TEST(Socketcand, MalformedMessagesAndOtherKinds) {
  const char* malformed[] = {
      "< send 123456789 1 00 >",            // 9-digit id
      "< send 20000000 1 00 >",             // above 0x1FFFFFFF
      "< send 123 9 0 0 0 0 0 0 0 0 0 >",   // 9 bytes
      "< send 123 3 01 02 >",               // fewer bytes than the length
      "< send 123 1 01 02 >",               // more bytes than the length
      "< send 123 1 zz >",                  // not hex
      "< send 123 1 100 >",                 // a byte of three digits
      "< send 123 1 01",                    // no '>'
      "< frame 3FFFFFFF 1.0 00 >",          // id above 0x1FFFFFFF
      "< frame 123 1.0 112 >",              // odd number of digits
      "< frame 123 1.0 112233445566778899 >",  // 9 bytes
      "< frame 123 1.0 11ZZ >",             // not hex
      "< frame 123 1.0 11 22 >",            // data not contiguous
      "< frame 123 >",                      // no time
      "< open >",                           // no channel
      "send 123 1 01 >",                    // no '<'
  };
  for (const char* m : malformed) {
    Frame f;
    f.id = 0x55;
    EXPECT_EQ(parse_socketcand(m, f), SocketcandMessage::kMalformed) << m;
    EXPECT_EQ(f.id, 0x55u) << m << ": a malformed message changed the frame";
  }
  Frame f;
  EXPECT_EQ(parse_socketcand("< hi >", f), SocketcandMessage::kHi);
  EXPECT_EQ(parse_socketcand("< ok >", f), SocketcandMessage::kOk);
  EXPECT_EQ(parse_socketcand("< rawmode >", f), SocketcandMessage::kRawmode);
  EXPECT_EQ(parse_socketcand("< open vcan0 >", f), SocketcandMessage::kOpen);
  EXPECT_EQ(parse_socketcand("< open can_1.a-b >", f), SocketcandMessage::kOpen);
  EXPECT_EQ(parse_socketcand("< open can/0 >", f), SocketcandMessage::kBadChannel);
  EXPECT_EQ(parse_socketcand("< open abcdefghijklmnop >", f), SocketcandMessage::kBadChannel);  // 16 characters
  EXPECT_EQ(parse_socketcand("< open a b >", f), SocketcandMessage::kMalformed);
  EXPECT_EQ(parse_socketcand("< echo >", f), SocketcandMessage::kEcho);
  EXPECT_EQ(parse_socketcand("< echo x >", f), SocketcandMessage::kMalformed);
  EXPECT_EQ(parse_socketcand("< error could not open bus >", f), SocketcandMessage::kError);
  EXPECT_EQ(parse_socketcand("< bcmode x >", f), SocketcandMessage::kOther);
  EXPECT_EQ(parse_socketcand("< bcmode >", f), SocketcandMessage::kOther);
}

// ---------------------------------------------------------------------------------------------
// --bus.

TEST(BusSpec, AcceptsBothTransports) {
  BusSpec b;
  std::string error;
  ASSERT_TRUE(parse_bus_spec("socketcan:vcan0", b, error)) << error;
  EXPECT_EQ(b.kind, BusSpec::Kind::kSocketCan);
  EXPECT_EQ(b.interface_name, "vcan0");
  ASSERT_TRUE(parse_bus_spec("socketcan:abcdefghijklmno", b, error)) << error;  // 15 characters: the limit
  EXPECT_EQ(b.interface_name, "abcdefghijklmno");
  ASSERT_TRUE(parse_bus_spec("socketcand:127.0.0.1:29536", b, error)) << error;
  EXPECT_EQ(b.kind, BusSpec::Kind::kSocketcand);
  EXPECT_EQ(b.host, "127.0.0.1");
  EXPECT_EQ(b.port, 29536);
  ASSERT_TRUE(parse_bus_spec("socketcand:localhost:1", b, error)) << error;
  EXPECT_EQ(b.host, "localhost");
  EXPECT_EQ(b.port, 1);
  ASSERT_TRUE(parse_bus_spec("socketcand:localhost:65535", b, error)) << error;
  EXPECT_EQ(b.port, 65535);
  // IPv6 in brackets, as in a URL
  ASSERT_TRUE(parse_bus_spec("socketcand:[::1]:29536", b, error)) << error;
  EXPECT_EQ(b.host, "::1");
  EXPECT_EQ(b.port, 29536);
}

// A plant on [::1] and an ECU that connects there: the bus works over IPv6 loopback.
TEST(BusSpec, AnIpv6LoopbackPlantTakesAClient) {
  // a free port on ::1: bound to 0 by the kernel, then released
  int port = 0;
  {
    const int fd = ::socket(AF_INET6, SOCK_STREAM, 0);
    if (fd < 0) GTEST_SKIP() << "no IPv6 sockets here";
    sockaddr_in6 a{};
    a.sin6_family = AF_INET6;
    a.sin6_addr = in6addr_loopback;
    socklen_t len = sizeof a;
    const bool bound = ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
                       ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0;
    ::close(fd);
    if (!bound) GTEST_SKIP() << "no IPv6 loopback here";
    port = ntohs(a.sin6_port);
  }
  BusSpec spec;
  std::string error;
  ASSERT_TRUE(parse_bus_spec("socketcand:[::1]:" + std::to_string(port), spec, error)) << error;
  auto server = open_socketcand_server(spec.host, spec.port, error);
  if (!server && error.find("Address family") != std::string::npos) GTEST_SKIP() << "no IPv6 here: " << error;
  ASSERT_TRUE(server) << error;
  std::unique_ptr<Transport> ecu;
  std::thread client([&] { ecu = open_socketcand_client(spec.host, spec.port, "can0", 5.0, error); });
  Frame none[4];
  for (int i = 0; i < 400 && !server->has_peer(); ++i) {
    server->wait(10'000'000);
    server->receive(none);
  }
  client.join();
  EXPECT_TRUE(ecu) << error;
  EXPECT_TRUE(server->has_peer());
}

TEST(BusSpec, RejectsBadSpecsNamingTheValue) {
  const std::string bad[] = {
      "socketcan:",
      "socketcan:abcdefghijklmnop",  // 16 characters
      "socketcan:vcan/0",
      "socketcan:vcan 0",
      "socketcand:host",
      "socketcand:host:",
      "socketcand::29536",
      "socketcand:host:0",
      "socketcand:host:65536",
      "socketcand:host:99999999999",
      "socketcand:host:abc",
      "socketcand:host:-1",
      "socketcand:::1:29536",  // IPv6 without its brackets
      "socketcand:[]:29536",
      "lcm:x",
      "",
  };
  for (const std::string& text : bad) {
    BusSpec b;
    b.interface_name = "untouched";
    std::string error;
    EXPECT_FALSE(parse_bus_spec(text, b, error)) << text;
    EXPECT_NE(error.find("--bus " + text + ":"), std::string::npos) << text << " -> " << error;
    EXPECT_EQ(b.interface_name, "untouched") << text;
  }
  std::string error;
  BusSpec b;
  EXPECT_FALSE(parse_bus_spec("lcm:x", b, error));
  EXPECT_NE(error.find("unknown transport"), std::string::npos) << error;
  EXPECT_FALSE(parse_bus_spec("socketcand:host:65536", b, error));
  EXPECT_NE(error.find("1 to 65535"), std::string::npos) << error;
  EXPECT_FALSE(parse_bus_spec("socketcand:::1:29536", b, error));
  EXPECT_NE(error.find("an IPv6 address is written in brackets: socketcand:[::1]:PORT"), std::string::npos) << error;
}

}  // namespace
}  // namespace ehpt::io::can
