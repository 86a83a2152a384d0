// SPDX-License-Identifier: BSD-3-Clause
// Bus bindings (hil/bus/bus_binding.hpp) and the CAN wire that runs on them
// (hil/bus/bus_wire_can.hpp): ehpt's contract as a binding sends exactly the codec's frames and
// takes commands exactly as the codec's filter does; every binding error names file:line; unit
// conversion, E2E, multiplexing, extended ids, cycle times and per-message timeouts.
#include <gtest/gtest.h>

#include <cmath>
#include <deque>
#include <random>
#include <string>
#include <vector>

#include "hil/bus/bus_binding.hpp"
#include "hil/bus/bus_wire_can.hpp"
#include "io/can/codec.hpp"
#include "io/can/e2e.hpp"
#include "io/json_value.hpp"
#include "test_plants.hpp"

namespace ehpt::hil {
namespace {

using io::can::Frame;

// A transport that keeps what the plant sends and hands it what the test queues.
class LoopBus final : public io::can::Transport {
 public:
  std::vector<Frame> sent;
  std::deque<Frame> inbox;
  bool send(const Frame& f) override {
    sent.push_back(f);
    ++counters_.frames_out;
    return true;
  }
  std::size_t receive(std::span<Frame> out) override {
    std::size_t n = 0;
    while (n < out.size() && !inbox.empty()) {
      out[n++] = inbox.front();
      inbox.pop_front();
    }
    counters_.frames_in += static_cast<std::int64_t>(n);
    return n;
  }
  bool wait(std::int64_t) override { return !inbox.empty(); }
  bool has_peer() const override { return true; }
  const io::can::TransportCounters& counters() const override { return counters_; }
  std::string describe() const override { return "loop"; }

 private:
  io::can::TransportCounters counters_;
};

constexpr double kStep = 0.001, kPeriod = 0.01;

Binding contract(const char* family) {
  std::vector<std::string> errors;
  std::optional<Binding> b = default_binding(family, kPeriod, errors);
  EXPECT_TRUE(b) << (errors.empty() ? "" : errors.front());
  return std::move(b.value());
}

// A wire's report, parsed: report(path) is the integer at a path of keys ("rejected", "stale").
struct Report {
  io::JsonValue root;
  template <class Wire>
  explicit Report(const Wire& wire) {
    io::JsonObject b;
    std::int64_t rejected = 0;
    wire.report(b, rejected);
    total = rejected;
    std::string error;
    EXPECT_TRUE(io::parse_json(b.str(), root, error)) << error;
  }
  std::int64_t operator()(std::initializer_list<std::string_view> path) const {
    const io::JsonValue* v = &root;
    for (std::string_view k : path) {
      v = v->find(k);
      if (v == nullptr) {
        ADD_FAILURE() << "no " << k;
        return -1;
      }
    }
    return std::stoll(v->text);
  }
  std::int64_t total = 0;
};

// ---------------------------------------------------------------------------------------------
// ehpt's own contract through the binding: the codec's frames, bit for bit.

TEST(DefaultBinding, EveryFamilyLoadsCleanAndListsTheContractsIdsInOrder) {
  for (const char* family : {"psd", "ev", "shev"}) {
    std::vector<std::string> errors;
    const auto b = parse_binding(builtin_binding_text(family), "b.toml", builtin_ehpt_dbc(), "ehpt.dbc", family, kPeriod,
                                 errors);
    ASSERT_TRUE(b) << family << ": " << (errors.empty() ? "" : errors.front());
    EXPECT_TRUE(b->warnings.empty()) << b->warnings.front();
    EXPECT_TRUE(b->echo);
  }
  const Binding psd = contract("psd");
  std::vector<std::uint32_t> sent;
  for (const auto& m : psd.send) sent.push_back(m.message->id);
  EXPECT_EQ(sent, std::vector<std::uint32_t>(io::can::kPsdSensorIds.begin(), io::can::kPsdSensorIds.end()));
  EXPECT_EQ(psd.receive_ids(), std::vector<std::uint32_t>(io::can::kPsdCommandIds.begin(), io::can::kPsdCommandIds.end()));
  const Binding shev = contract("shev");
  sent.clear();
  for (const auto& m : shev.send) sent.push_back(m.message->id);
  EXPECT_EQ(sent, (std::vector<std::uint32_t>{0x230, 0x231, 0x232, 0x233, 0x200}));
  EXPECT_EQ(shev.receive_ids(), std::vector<std::uint32_t>{0x130});
  // the files in the source tree are what is compiled in, and load by path as any binding does
  for (const char* family : {"psd", "ev", "shev"}) {
    std::vector<std::string> errors;
    EXPECT_TRUE(load_binding(test::source_path("io/can/ehpt-" + std::string(family) + ".binding.toml"), family, kPeriod,
                             errors))
        << family << ": " << (errors.empty() ? "" : errors.front());
  }
  EXPECT_TRUE(builtin_binding_text("hev").empty());
}

msgs::PsdSensors random_sensors(std::mt19937_64& rng, double spread) {
  std::uniform_real_distribution<double> u(-spread, spread);
  msgs::PsdSensors s;
  for (const auto& f : msgs::kPsdSensorFieldTable) {
    if (f.kind == msgs::FieldKind::kQuantity || f.kind == msgs::FieldKind::kFraction) f.set(s, u(rng));
  }
  s.fault = static_cast<unsigned>(rng() % 300);  // beyond 255 too: saturates
  s.locked = (rng() & 1) != 0;
  return s;
}

TEST(DefaultBinding, SensorFramesEqualTheCodecsBitForBitWithTheSameSaturationCount) {
  LoopBus bus;
  CanWire<msgs::PsdSensors> wire(bus, contract("psd"), kStep, false, 3 * kPeriod, "can0");
  io::can::TxCounters tx;
  std::mt19937_64 rng(7);
  for (int i = 0; i < 20000; ++i) {
    // ranges of every size: inside every signal's range, and far outside (saturation), and the
    // half steps where rounding rules differ
    const double spread = i % 3 == 0 ? 1.0 : i % 3 == 1 ? 600.0 : 3e5;
    msgs::PsdSensors s = random_sensors(rng, spread);
    if (i % 7 == 0) s.icePowDel_W = 0.25 * static_cast<double>(static_cast<int>(rng() % 2001) - 1000);  // x.25, x.75 W
    if (i % 11 == 0) s.batSOC = NAN;
    const std::int64_t step = static_cast<std::int64_t>(rng() % 5'000'000'000ULL);
    const bool timeout = (rng() & 1) != 0;
    std::array<Frame, io::can::kPsdSensorIds.size()> want;
    const int want_sat =
        io::can::encode(s, io::can::PlantStatus{static_cast<std::uint32_t>(step), s.fault, s.locked, timeout}, tx, want);
    bus.sent.clear();
    const int got_sat = wire.send_sample(s, step, timeout);
    ASSERT_EQ(bus.sent.size(), want.size());
    for (std::size_t k = 0; k < want.size(); ++k) {
      ASSERT_TRUE(bus.sent[k] == want[k]) << "sample " << i << ", frame " << k << " (id 0x" << std::hex << want[k].id << ")";
    }
    ASSERT_EQ(got_sat, want_sat) << "sample " << i;
  }
}

// Random and mangled command frames: the wire takes exactly the frames the codec's filter takes,
// rejects the others for the same reason, and assembles the same commands.
TEST(DefaultBinding, CommandsAreTakenAndRejectedExactlyAsTheCodecsFilterDoes) {
  LoopBus bus;
  CanWire<msgs::PsdSensors> wire(bus, contract("psd"), kStep, true, 3 * kPeriod, "can0");
  io::can::FrameFilter filter(io::can::kPsdCommandIds);
  io::can::TxCounters tx;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-600.0, 600.0);
  msgs::PsdCommand codec_cmd{};
  unsigned mask = 0;
  int completed = 0;
  for (int i = 0; i < 20000; ++i) {
    const std::uint32_t sample = static_cast<std::uint32_t>(i / 4);
    msgs::PsdCommand c;
    c.icePowRef_W = u(rng) * 100.0;
    c.iceTauRef_Nm = u(rng);
    c.genTauRef_Nm = u(rng);
    c.motTauRef_Nm = u(rng);
    c.iceON = (rng() & 1) != 0;
    c.stamp.step = sample - static_cast<std::uint32_t>(rng() % 3);  // now and then an old sample
    std::array<Frame, 2> frames;
    io::can::encode(c, tx, frames);
    Frame f = frames[rng() % 2];
    switch (rng() % 8) {  // mangle some
      case 0: f.len = 7; break;
      case 1: f.id = 0x7FF; break;
      case 2:  // the first signal (20 bits) at its largest raw value: beyond its range
        f.data[0] = 0xFF;
        f.data[1] = 0xFF;
        f.data[2] = static_cast<std::uint8_t>((f.data[2] & 0xF0) | 0x07);
        break;
      case 3: f.data[7] ^= 0x30; break;                   // the counter
      case 4: f.extended = true; break;
      default: break;
    }
    bus.inbox.push_back(f);
    msgs::PsdCommand got{};
    bool wire_done = false;
    const std::int64_t max_age = 1;
    wire.receive(sample, sample, max_age, [&](const msgs::PsdCommand& cmd) {
      got = cmd;
      wire_done = true;
    });
    const io::can::Freshness fresh{sample, static_cast<std::uint32_t>(max_age)};
    bool codec_done = false;
    if (filter.accept(f, &fresh) == io::can::Reject::kNone) {
      io::can::apply(f, codec_cmd);
      mask |= f.id == io::can::kPsdCommand1 ? 1u : 2u;
      if (mask == 3u) {
        mask = 0;
        codec_done = true;
      }
    }
    ASSERT_EQ(wire_done, codec_done) << "frame " << i;
    if (codec_done) {
      ++completed;
      ASSERT_EQ(got.icePowRef_W, codec_cmd.icePowRef_W);
      ASSERT_EQ(got.iceTauRef_Nm, codec_cmd.iceTauRef_Nm);
      ASSERT_EQ(got.genTauRef_Nm, codec_cmd.genTauRef_Nm);
      ASSERT_EQ(got.motTauRef_Nm, codec_cmd.motTauRef_Nm);
      ASSERT_EQ(got.iceON, codec_cmd.iceON);
    }
  }
  EXPECT_GT(completed, 300);
  const Report r(wire);
  const io::can::RxStats& st = filter.stats();
  EXPECT_EQ(r.total, st.unknown_id + st.wrong_length + st.bad_counter + st.out_of_range + st.stale);
  for (const auto& [key, n] : std::vector<std::pair<std::string, std::int64_t>>{{"unknown_id", st.unknown_id},
                                                                               {"wrong_length", st.wrong_length},
                                                                               {"bad_counter", st.bad_counter},
                                                                               {"out_of_range", st.out_of_range},
                                                                               {"stale", st.stale}}) {
    EXPECT_EQ(r({"rejected", key}), n) << key;
    EXPECT_GT(n, 0) << key;
  }
  EXPECT_EQ(r({"frames_lost"}), st.lost);
  EXPECT_EQ(r({"frames_accepted"}), st.accepted);
}

// A command of ehpt's contract is assembled only from frames that came after the sample's
// sensors: half a command of the last sample and half of this one are not a command.
TEST(DefaultBinding, ACommandIsAssembledOnlyFromFramesOfOneSample) {
  for (const bool lockstep : {false, true}) {
    LoopBus bus;
    CanWire<msgs::PsdSensors> wire(bus, contract("psd"), kStep, lockstep, 3 * kPeriod, "can0");
    io::can::TxCounters tx;
    const auto frames_for = [&](std::uint32_t step) {
      msgs::PsdCommand c;
      c.motTauRef_Nm = static_cast<double>(step);
      c.stamp.step = step;
      std::array<Frame, 2> f;
      io::can::encode(c, tx, f);
      return f;
    };
    int commands = 0;
    double mot = -1.0;
    const auto take = [&](std::int64_t n, std::int64_t sample) {
      wire.receive(n, sample, lockstep ? 0 : 30, [&](const msgs::PsdCommand& c) {
        ++commands;
        mot = c.motTauRef_Nm;
      });
    };
    wire.send_sample(msgs::PsdSensors{}, 0, false);
    bus.inbox.push_back(frames_for(0)[0]);  // PsdCommand1 of sample 0
    take(5, 0);
    wire.send_sample(msgs::PsdSensors{}, 10, false);
    bus.inbox.push_back(frames_for(10)[1]);  // PsdCommand2 of sample 10
    take(12, 10);
    EXPECT_EQ(commands, 0) << "lockstep " << lockstep;
    bus.inbox.push_back(frames_for(10)[0]);
    take(13, 10);
    EXPECT_EQ(commands, 1) << "lockstep " << lockstep;
    EXPECT_EQ(mot, 10.0);
  }
}

// ---------------------------------------------------------------------------------------------
// A user's DBC.

const char* kDbc = R"(VERSION ""
BU_: HIL VCU

BO_ 257 HIL_Out: 8 HIL
 SG_ Spd : 7|16@0+ (0.01,0) [0|300] "km/h" VCU
 SG_ Soc : 16|8@1+ (0.5,0) [0|100] "%" VCU
 SG_ Rpm : 24|16@1+ (0.25,0) [0|10000] "rpm" VCU
 SG_ Alive : 40|4@1+ (1,0) [0|15] "" VCU

BO_ 258 HIL_Extra: 8 HIL
 SG_ E : 0|8@1+ (1,0) [0|255] "" VCU

BO_ 2147484160 VCU_Cmd: 8 VCU
 SG_ Crc : 0|8@1+ (1,0) [0|255] "" HIL
 SG_ Cnt : 8|4@1+ (1,0) [0|15] "" HIL
 SG_ Trq : 23|16@0- (0.01,0) [-300|300] "Nm" HIL

BO_ 514 VCU_Mux: 8 VCU
 SG_ Mux M : 0|2@1+ (1,0) [0|3] "" HIL
 SG_ Pwr m0 : 8|16@1- (0.01,0) [-300|300] "kW" HIL
 SG_ Gen m1 : 8|16@1- (0.01,0) [-300|300] "Nm" HIL

BO_ 515 VCU_Fd: 12 VCU
 SG_ X : 0|8@1+ (1,0) [0|255] "" HIL

BO_ 259 HIL_Mux: 8 HIL
 SG_ Sel M : 0|2@1+ (1,0) [0|3] "" VCU
 SG_ A m0 : 8|8@1+ (1,0) [0|255] "" VCU

BA_DEF_ BO_ "GenMsgCycleTime" INT 0 10000;
BA_ "GenMsgCycleTime" BO_ 257 20;
BA_ "GenMsgCycleTime" BO_ 2147484160 10;
)";

const char* kBinding = R"(dbc = "x.dbc"
plant_node = "HIL"
[unbound]
iceON = true
iceTauRef_Nm = 0

[[send]]
message = "HIL_Out"
counter = "Alive"
signals = { Spd = "speed_m_s", Soc = "batSOC", Rpm = "iceW_rad_s" }

[[receive]]
message = "VCU_Cmd"
e2e = { profile = "P01", data_id = 0x1234, crc = "Crc", counter = "Cnt" }
signals = { Trq = "motTauRef_Nm" }

[[receive]]
message = "VCU_Mux"
timeout_ms = 50
signals = { Pwr = "icePowRef_W", Gen = "genTauRef_Nm" }
)";

std::optional<Binding> parse(const std::string& binding, std::vector<std::string>& errors, const char* dbc = kDbc) {
  return parse_binding(binding, "my.binding.toml", dbc, "x.dbc", "psd", kPeriod, errors);
}

Binding good() {
  std::vector<std::string> errors;
  auto b = parse(kBinding, errors);
  EXPECT_TRUE(b) << (errors.empty() ? "" : errors.front());
  return std::move(b.value());
}

TEST(UserBinding, UnitsConvertByName) {
  EXPECT_DOUBLE_EQ(*unit_to_si("km/h", "m/s"), 1.0 / 3.6);
  EXPECT_DOUBLE_EQ(*unit_to_si("RPM", "rad/s"), M_PI / 30.0);
  EXPECT_DOUBLE_EQ(*unit_to_si("kW", "W"), 1000.0);
  EXPECT_DOUBLE_EQ(*unit_to_si("%", ""), 0.01);
  EXPECT_DOUBLE_EQ(*unit_to_si("Nm", "Nm"), 1.0);
  EXPECT_FALSE(unit_to_si("km/h", "W"));
  EXPECT_FALSE(unit_to_si("%", "Nm"));
  EXPECT_FALSE(unit_to_si("furlong", "m/s"));
}

TEST(UserBinding, SensorsGoOutInTheirUnitsAtTheirCycleWithACounter) {
  LoopBus bus;
  CanWire<msgs::PsdSensors> wire(bus, good(), kStep, false, 3 * kPeriod, "can0");
  msgs::PsdSensors s;
  s.speed_m_s = 10.0;  // 36 km/h
  s.batSOC = 0.6;      // 60 %
  s.iceW_rad_s = 100.0 * M_PI / 30.0;  // 100 rpm
  const io::can::Dbc& dbc = wire.binding().dbc;
  const io::can::DbcMessage& out = *dbc.message("HIL_Out");
  for (int sample = 0; sample < 6; ++sample) wire.send_sample(s, sample * 10, false);  // ECU period 10 ms
  ASSERT_EQ(bus.sent.size(), 3u);  // GenMsgCycleTime 20 ms: every other sample
  for (std::size_t k = 0; k < bus.sent.size(); ++k) {
    const std::span<const std::uint8_t> d(bus.sent[k].data.data(), 8);
    EXPECT_DOUBLE_EQ(io::can::decode(*out.signal("Spd"), d), 36.0);
    EXPECT_DOUBLE_EQ(io::can::decode(*out.signal("Soc"), d), 60.0);
    EXPECT_DOUBLE_EQ(io::can::decode(*out.signal("Rpm"), d), 100.0);
    EXPECT_EQ(io::can::decode(*out.signal("Alive"), d), static_cast<double>(k));
  }
  EXPECT_FALSE(bus.sent[0].extended);
}

Frame cmd_frame(const Binding& b, double torque_Nm, std::uint8_t counter, bool good_crc = true) {
  const io::can::DbcMessage& m = *b.dbc.message("VCU_Cmd");
  Frame f;
  f.id = m.id;
  f.extended = true;
  f.len = 8;
  std::span<std::uint8_t> d(f.data.data(), 8);
  io::can::encode(*m.signal("Trq"), torque_Nm, d);
  io::can::e2e_protect(*b.receive[0].e2e, d, counter);
  if (!good_crc) f.data[0] ^= 0x01;
  return f;
}
Frame mux_frame(const Binding& b, int mux, double value) {
  const io::can::DbcMessage& m = *b.dbc.message("VCU_Mux");
  Frame f;
  f.id = m.id;
  f.len = 8;
  std::span<std::uint8_t> d(f.data.data(), 8);
  io::can::encode(*m.signal("Mux"), mux, d);
  io::can::encode(*m.signal(mux == 0 ? "Pwr" : "Gen"), value, d);
  return f;
}

// Wall clock without an echo: the latest value of each signal; a command once every field has
// come (both values of the multiplexor), then one per accepted frame; E2E failures are the
// frame's; a message older than its timeout is a timeout of that message.
TEST(UserBinding, LatestValuesE2eMultiplexingAndPerMessageTimeouts) {
  LoopBus bus;
  const Binding b = good();
  Binding copy = good();
  CanWire<msgs::PsdSensors> wire(bus, std::move(copy), kStep, false, 3 * kPeriod, "can0");
  std::vector<msgs::PsdCommand> cmds;
  const auto take = [&](std::int64_t n) { wire.receive(n, n, 1000, [&](const msgs::PsdCommand& c) { cmds.push_back(c); }); };
  bus.inbox.push_back(cmd_frame(b, 12.34, 0));
  bus.inbox.push_back(mux_frame(b, 0, 20.0));  // kW
  take(0);
  EXPECT_TRUE(cmds.empty()) << "genTauRef_Nm (mux 1) has not come yet";
  bus.inbox.push_back(mux_frame(b, 1, -7.5));
  take(1);
  ASSERT_EQ(cmds.size(), 1u);
  EXPECT_DOUBLE_EQ(cmds[0].motTauRef_Nm, 12.34);
  EXPECT_DOUBLE_EQ(cmds[0].icePowRef_W, 20000.0);
  EXPECT_DOUBLE_EQ(cmds[0].genTauRef_Nm, -7.5);
  EXPECT_TRUE(cmds[0].iceON);  // [unbound]
  // a forged torque (wrong CRC) is never applied; the genuine next one is
  bus.inbox.push_back(cmd_frame(b, 250.0, 1, false));
  bus.inbox.push_back(cmd_frame(b, 13.0, 1));
  take(2);
  ASSERT_EQ(cmds.size(), 2u);
  EXPECT_DOUBLE_EQ(cmds[1].motTauRef_Nm, 13.0);
  // the same counter again: repeated, a bad counter
  bus.inbox.push_back(cmd_frame(b, 14.0, 1));
  take(3);
  EXPECT_EQ(cmds.size(), 2u);
  // timeouts: VCU_Cmd 3 cycles (30 ms = 30 steps), VCU_Mux timeout_ms = 50
  EXPECT_FALSE(wire.message_timed_out(2 + 30));
  EXPECT_TRUE(wire.message_timed_out(2 + 31));
  EXPECT_FALSE(wire.message_timed_out(2 + 32));  // counted once
  EXPECT_FALSE(wire.message_timed_out(1 + 50));
  EXPECT_TRUE(wire.message_timed_out(1 + 51));
  const Report r(wire);
  EXPECT_EQ(r({"messages_received", "VCU_Cmd", "accepted"}), 2);
  EXPECT_EQ(r({"messages_received", "VCU_Cmd", "bad_crc"}), 1);  // the frame's, not the VCU's
  EXPECT_EQ(r({"messages_received", "VCU_Cmd", "bad_counter"}), 1);
  EXPECT_EQ(r({"messages_received", "VCU_Cmd", "timed_out"}), 1);
  EXPECT_EQ(r({"messages_received", "VCU_Mux", "accepted"}), 2);
  EXPECT_EQ(r({"messages_received", "VCU_Mux", "timed_out"}), 1);
  EXPECT_EQ(r({"rejected", "bad_crc"}), 1);
  EXPECT_EQ(r.total, 2);
  // after a resync (the safe state), a command needs every field again
  wire.resync();
  bus.inbox.push_back(cmd_frame(b, 15.0, 5));
  take(100);
  EXPECT_EQ(cmds.size(), 2u);
}

// Unbound signals of a sent message carry their GenSigStartValue (raw), clamped into what the
// codec's rule allows however large the DBC's number.
TEST(UserBinding, UnboundSignalsCarryTheirStartValues) {
  std::string dbc = kDbc;
  const std::string out = " SG_ Alive : 40|4@1+ (1,0) [0|15] \"\" VCU\n";
  dbc.replace(dbc.find(out), out.size(),
              out + " SG_ Mode : 48|8@1+ (1,0) [0|200] \"\" VCU\n SG_ Huge : 56|8@1- (1,0) [0|0] \"\" VCU\n");
  dbc += "BA_DEF_ SG_ \"GenSigStartValue\" FLOAT -1e300 1e300;\nBA_ \"GenSigStartValue\" SG_ 257 Mode 7;\n"
         "BA_ \"GenSigStartValue\" SG_ 257 Huge 1e300;\n";
  std::vector<std::string> errors;
  auto b = parse(kBinding, errors, dbc.c_str());
  ASSERT_TRUE(b) << (errors.empty() ? "" : errors.front());
  LoopBus bus;
  CanWire<msgs::PsdSensors> wire(bus, std::move(b.value()), kStep, false, 3 * kPeriod, "can0");
  wire.send_sample(msgs::PsdSensors{}, 0, false);
  ASSERT_EQ(bus.sent.size(), 1u);
  EXPECT_EQ(bus.sent[0].data[6], 7);     // Mode
  EXPECT_EQ(bus.sent[0].data[7], 0x7F);  // Huge: the largest an 8-bit signed signal holds
}

TEST(UserBinding, TheStandardFrameOfAnExtendedIdIsNotIt) {
  LoopBus bus;
  const Binding b = good();
  CanWire<msgs::PsdSensors> wire(bus, good(), kStep, false, 3 * kPeriod, "can0");
  Frame f = cmd_frame(b, 1.0, 0);
  f.extended = false;
  bus.inbox.push_back(f);
  wire.receive(0, 0, 10, [](const msgs::PsdCommand&) {});
  EXPECT_EQ(Report(wire)({"rejected", "unknown_id"}), 1);
  EXPECT_EQ(b.receive_ids()[0], 0x200u | io::can::kExtendedIdFlag);
}

// Every problem of a binding: its file and line, what is wrong, a suggestion where a name is close.
TEST(UserBinding, EachErrorNamesFileLineAndWhatToDo) {
  struct Case {
    std::string from, to;  // replace in kBinding
    std::string want;      // in the first error
  };
  const std::vector<Case> cases = {
      {"message = \"HIL_Out\"", "message = \"HIL_Ot\"", "my.binding.toml:8: [[send]]: no message `HIL_Ot` in x.dbc; did you mean `HIL_Out`?"},
      {"Soc = \"batSOC\"", "Sock = \"batSOC\"", "my.binding.toml:10: [[send]] HIL_Out: no signal `Sock` in HIL_Out (x.dbc:4); did you mean `Soc`?"},
      {"Soc = \"batSOC\"", "Soc = \"batSoc\"", "`batSoc` is not an output of the psd plant; did you mean `batSOC`?"},
      {"Soc = \"batSOC\"", "Soc = \"motTauRef_Nm\"", "`motTauRef_Nm` is not an output of the psd plant (it is an input: bind it in [[receive]])"},
      {"Spd = \"speed_m_s\"", "Spd = \"iceW_rad_s\"", "unit \"km/h\" does not convert to rad/s"},
      {"Rpm = \"iceW_rad_s\"", "Rpm = { field = \"iceW_rad_s\", unit = \"W\" }", "unit \"W\" does not convert to rad/s"},
      {"Gen = \"genTauRef_Nm\"", "Gen = \"motTauRef_Nm\"", "plant input `motTauRef_Nm` is bound twice"},
      {"iceTauRef_Nm = 0\n", "", "plant input `iceTauRef_Nm` is neither bound to a signal nor given a value in [unbound]"},
      {"iceON = true", "iceON = true\nmotTauRef_Nm = 1", "[unbound] `motTauRef_Nm` is bound to a signal"},
      {"message = \"VCU_Cmd\"", "message = \"HIL_Extra\"", "[[receive]] HIL_Extra: the DBC says HIL sends it (x.dbc:10): the plant cannot receive it"},
      {"message = \"HIL_Out\"", "message = \"VCU_Mux\"", "[[send]] VCU_Mux: the DBC says VCU sends it"},
      {"message = \"VCU_Mux\"", "message = \"VCU_Fd\"", "VCU_Fd: 12 bytes (CAN FD)"},
      {"plant_node = \"HIL\"", "plant_node = \"Hil\"", "my.binding.toml:2: plant_node `Hil` is not a node of x.dbc; did you mean `HIL`?"},
      {"crc = \"Crc\"", "crc = \"Trq\"", "e2e: crc Trq must be one whole byte"},
      {"profile = \"P01\"", "profile = \"P03\"", "profile \"P03\": must be \"P01\""},
      {"timeout_ms = 50", "timeout_ms = -5", "my.binding.toml:19: [[receive]] VCU_Mux: timeout_ms must be a number > 0"},
      {"counter = \"Alive\"", "counter = \"Spd\"", "`counter` Spd: must be an unsigned integer signal with factor 1"},
      {"counter = \"Alive\"", "countr = \"Alive\"", "unknown key `countr`; did you mean `counter`?"},
      {"[[receive]]\nmessage = \"VCU_Mux\"", "[[receive]]\nmessage = \"VCU_Cmd\"", "[[receive]] VCU_Cmd: bound twice"},
      {"dbc = \"x.dbc\"", "dbc = \"x.dbc\"\n[[bogus", "TOML syntax"},
      {"message = \"HIL_Out\"", "message = \"HIL_Mux\"", "my.binding.toml:8: [[send]] HIL_Mux: a multiplexed message can be received, not sent"},
      {"signals = { Trq = \"motTauRef_Nm\" }", "signals = { Crc = \"motTauRef_Nm\" }", "Crc: bound twice in this message (or also its counter, echo or E2E signal)"},
      {"signals = { Trq = \"motTauRef_Nm\" }", "signals = {}", "my.binding.toml:12: [[receive]] VCU_Cmd: binds no plant input"},
  };
  for (const Case& c : cases) {
    std::string text = kBinding;
    const std::size_t at = text.find(c.from);
    ASSERT_NE(at, std::string::npos) << c.from;
    text.replace(at, c.from.size(), c.to);
    std::vector<std::string> errors;
    EXPECT_FALSE(parse(text, errors)) << c.to;
    ASSERT_FALSE(errors.empty()) << c.to;
    std::string all;
    for (const auto& e : errors) all += e + "\n";
    EXPECT_NE(all.find(c.want), std::string::npos) << "want: " << c.want << "\ngot:\n" << all;
    EXPECT_EQ(all.rfind("my.binding.toml:", 0), 0u) << all;
  }
}

// E2E's CRC is a whole byte in either byte order: Intel from the byte's bit 0, Motorola from its bit 7.
TEST(UserBinding, AnE2eCrcByteInMotorolaOrderIsTheSameByte) {
  std::string dbc = kDbc;
  const std::string intel = " SG_ Crc : 0|8@1+ (1,0) [0|255] \"\" HIL";
  dbc.replace(dbc.find(intel), intel.size(), " SG_ Crc : 7|8@0+ (1,0) [0|255] \"\" HIL");
  std::vector<std::string> errors;
  const auto b = parse(kBinding, errors, dbc.c_str());
  ASSERT_TRUE(b) << (errors.empty() ? "" : errors.front());
  EXPECT_EQ(b->receive[0].e2e->crc_byte, 0);
  // Motorola from bit 0 would span two bytes: refused
  dbc.replace(dbc.find(" SG_ Crc : 7|8@0+"), 17, " SG_ Crc : 0|8@0+");
  errors.clear();
  EXPECT_FALSE(parse(kBinding, errors, dbc.c_str()));
  ASSERT_FALSE(errors.empty());
  EXPECT_NE(errors.front().find("e2e: crc Crc must be one whole byte"), std::string::npos) << errors.front();
}

TEST(UserBinding, ADbcWithErrorsIsRefusedWithItsLine) {
  std::vector<std::string> errors;
  EXPECT_FALSE(parse(kBinding, errors, "BO_ 1 A: 8 HIL\n SG_ S : 60|8@1+ (1,0) [0|0] \"\" VCU\n"));
  ASSERT_FALSE(errors.empty());
  EXPECT_EQ(errors.front().rfind("x.dbc:2:", 0), 0u) << errors.front();
}

TEST(UserBinding, AMissingOrUnreadableFileIsOneLine) {
  std::vector<std::string> errors;
  EXPECT_FALSE(load_binding("/nonexistent/b.toml", "psd", kPeriod, errors));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].rfind("/nonexistent/b.toml: ", 0), 0u) << errors[0];
  errors.clear();
  // the example's DBC is found beside its binding
  EXPECT_TRUE(load_binding(test::source_path("examples/own_dbc/vcu.binding.toml"), "psd", kPeriod, errors))
      << (errors.empty() ? "" : errors.front());
  EXPECT_FALSE(load_binding(test::source_path("examples/own_dbc/vcu.binding.toml"), "ev", kPeriod, errors));
}

}  // namespace
}  // namespace ehpt::hil
