// SPDX-License-Identifier: BSD-3-Clause
// Bus faults (hil/bus/bus_faults.hpp): what each kind does to the frames of a bound message,
// frame by frame, with its exact effect; the load errors of a fault the binding cannot take.
#include "hil/bus/bus_faults.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "hil/bus/bus_binding.hpp"
#include "io/can/dbc.hpp"
#include "io/can/candump_log.hpp"
#include "io/can/e2e.hpp"
#include "io/can/socketcan.hpp"
#include "test_plants.hpp"

namespace ehpt::hil {
namespace {

using Dir = BusFaults::Direction;
constexpr double kStep = 0.001;
constexpr std::int64_t kRatio = 10;  // ECU period 10 ms

Binding psd_binding() {
  std::vector<std::string> errors;
  auto b = default_binding("psd", kStep * kRatio, errors);
  EXPECT_TRUE(b) << (errors.empty() ? "" : errors[0]);
  return std::move(*b);
}
Binding vcu_binding() {  // the example's own DBC: an E2E-protected command (P01)
  std::vector<std::string> errors;
  auto b = load_binding(test::source_path("examples/own_dbc/vcu.binding.toml"), "psd", kStep * kRatio, errors);
  EXPECT_TRUE(b) << (errors.empty() ? "" : errors[0]);
  return std::move(*b);
}

FaultSpec bus_fault(FaultEffect e, const std::string& target) {
  FaultSpec f;
  f.where = "t.toml:7";
  f.effect = e;
  f.target = target;
  f.side = FaultSide::kBus;
  f.at_s = 0.5;
  return f;
}

std::size_t index_of(const std::vector<BoundMessage>& list, const std::string& name) {
  for (std::size_t i = 0; i < list.size(); ++i) {
    if (list[i].message->name == name) return i;
  }
  ADD_FAILURE() << name;
  return 0;
}

// a frame of message m with its counter signal (if it has one) at `counter`, other bytes 0x5A
io::can::Frame frame_of(const BoundMessage& m, std::uint64_t counter = 0) {
  io::can::Frame f;
  f.id = m.message->id;
  f.extended = m.message->extended;
  f.len = static_cast<std::uint8_t>(m.message->size_bytes);
  f.data.fill(0x5A);
  for (const BoundSignal& b : m.signals) {
    if (b.role == BoundRole::kCounter) {
      io::can::insert_raw(*b.signal, counter, std::span<std::uint8_t>(f.data.data(), f.len));
    }
  }
  return f;
}
std::uint64_t counter_of(const BoundMessage& m, const io::can::Frame& f) {
  for (const BoundSignal& b : m.signals) {
    if (b.role == BoundRole::kCounter) {
      return io::can::extract_raw(*b.signal, std::span<const std::uint8_t>(f.data.data(), f.len));
    }
  }
  return 999;
}

BusFaults resolved(const std::vector<FaultSpec>& faults, const Binding& b) {
  BusFaults out;
  std::vector<std::string> errors;
  EXPECT_TRUE(BusFaults::resolve(faults, b, kStep, kRatio, false, out, errors)) << (errors.empty() ? "" : errors[0]);
  return out;
}

struct Sink {
  std::vector<io::can::Frame> frames;
  void operator()(const io::can::Frame& f) { frames.push_back(f); }
};

TEST(BusFaults, DropLosesEveryFrameOnlyWhileItActsAndOnlyItsMessage) {
  const Binding b = psd_binding();
  BusFaults bf = resolved({bus_fault(FaultEffect::kDrop, "PsdCommand1")}, b);
  const std::size_t c1 = index_of(b.receive, "PsdCommand1"), c2 = index_of(b.receive, "PsdCommand2");
  Sink out;
  EXPECT_FALSE(bf.process(Dir::kRx, c1, frame_of(b.receive[c1]), 0, 1, std::ref(out)));  // acting: lost
  EXPECT_TRUE(bf.process(Dir::kRx, c2, frame_of(b.receive[c2]), 0, 1, std::ref(out)));   // the other message
  EXPECT_TRUE(bf.process(Dir::kRx, c1, frame_of(b.receive[c1]), 10, 0, std::ref(out)));  // not acting
  EXPECT_TRUE(bf.process(Dir::kTx, c1, frame_of(b.send[c1]), 20, 1, std::ref(out)));     // the other direction
  ASSERT_EQ(out.frames.size(), 3u);
  EXPECT_EQ(out.frames[0].id, b.receive[c2].message->id);
  EXPECT_EQ(out.frames[1].id, b.receive[c1].message->id);
  EXPECT_EQ(bf.frames_of(0), 1);
  EXPECT_EQ(bf.bits(), 1u);
}

TEST(BusFaults, DropByPatternAndBySeededProbability) {
  const Binding b = psd_binding();
  FaultSpec p = bus_fault(FaultEffect::kDrop, "PlantStatus");
  p.pattern = "0110";
  BusFaults bf = resolved({p}, b);
  const std::size_t s = index_of(b.send, "PlantStatus");
  std::string seen;
  for (int i = 0; i < 9; ++i) {
    Sink out;
    bf.process(Dir::kTx, s, frame_of(b.send[s]), i * kRatio, 1, std::ref(out));
    seen += out.frames.empty() ? '1' : '0';
  }
  EXPECT_EQ(seen, "011001100");  // the pattern, repeated, one character per frame
  EXPECT_EQ(bf.frames_of(0), 4);

  // probability 0.3: about 30 % lost, the same frames for the same seed, others for another
  const auto lost = [&](std::uint64_t seed) {
    FaultSpec q = bus_fault(FaultEffect::kDrop, "PlantStatus");
    q.probability = 0.3;
    q.seed = seed;
    BusFaults x = resolved({q}, b);
    std::string which;
    for (int i = 0; i < 20000; ++i) {
      Sink out;
      x.process(Dir::kTx, s, frame_of(b.send[s]), i * kRatio, 1, std::ref(out));
      which += out.frames.empty() ? '1' : '0';
    }
    return which;
  };
  const std::string a = lost(7), again = lost(7), other = lost(8);
  EXPECT_EQ(a, again);
  EXPECT_NE(a, other);
  const double fraction = static_cast<double>(std::count(a.begin(), a.end(), '1')) / 20000.0;
  EXPECT_NEAR(fraction, 0.3, 0.015);  // 4.6 sigma of a binomial with n = 20000
}

TEST(BusFaults, DuplicateReorderAndDelayDeliverInTheirOrder) {
  const Binding b = psd_binding();
  const std::size_t s1 = index_of(b.send, "PsdSensors1"), s2 = index_of(b.send, "PsdSensors2");
  {
    BusFaults bf = resolved({bus_fault(FaultEffect::kDuplicate, "PsdSensors1")}, b);
    Sink out;
    EXPECT_TRUE(bf.process(Dir::kTx, s1, frame_of(b.send[s1], 3), 0, 1, std::ref(out)));  // whole: the frame twice
    ASSERT_EQ(out.frames.size(), 2u);
    EXPECT_EQ(counter_of(b.send[s1], out.frames[1]), 3u);
  }
  {
    BusFaults bf = resolved({bus_fault(FaultEffect::kReorder, "PsdSensors1")}, b);
    Sink out;
    EXPECT_FALSE(bf.process(Dir::kTx, s1, frame_of(b.send[s1], 3), 0, 1, std::ref(out)));  // held back
    EXPECT_TRUE(out.frames.empty());
    bf.process(Dir::kTx, s2, frame_of(b.send[s2], 9), 0, 1, std::ref(out));  // the next: then the held one
    ASSERT_EQ(out.frames.size(), 2u);
    EXPECT_EQ(out.frames[0].id, b.send[s2].message->id);
    EXPECT_EQ(out.frames[1].id, b.send[s1].message->id);
    // one held at the fault's end goes at the next sample, before anything else
    bf.process(Dir::kTx, s1, frame_of(b.send[s1], 4), 10, 1, std::ref(out));
    EXPECT_TRUE(bf.release_held(Dir::kTx, 1, std::ref(out)));  // still acting: it waits
    EXPECT_EQ(out.frames.size(), 2u);
    EXPECT_FALSE(bf.release_held(Dir::kTx, 0, std::ref(out)));
    ASSERT_EQ(out.frames.size(), 3u);
    EXPECT_EQ(counter_of(b.send[s1], out.frames[2]), 4u);
  }
  {
    FaultSpec d = bus_fault(FaultEffect::kDelay, "PsdSensors1");
    d.delay_s = 0.03;  // three ECU periods
    BusFaults bf = resolved({d}, b);
    Sink out;
    for (int k = 0; k < 2; ++k) {
      EXPECT_FALSE(bf.process(Dir::kTx, s1, frame_of(b.send[s1], static_cast<std::uint64_t>(k)), k * kRatio, 1,
                              std::ref(out)));
    }
    EXPECT_TRUE(bf.release(Dir::kTx, 29, std::ref(out)));  // not yet due
    EXPECT_TRUE(out.frames.empty());
    EXPECT_FALSE(bf.release(Dir::kTx, 30, std::ref(out)));  // the first, exactly 3 periods later
    ASSERT_EQ(out.frames.size(), 1u);
    EXPECT_EQ(counter_of(b.send[s1], out.frames[0]), 0u);
    bf.release(Dir::kTx, 45, std::ref(out));
    ASSERT_EQ(out.frames.size(), 2u);
    EXPECT_EQ(counter_of(b.send[s1], out.frames[1]), 1u);
  }
}

TEST(BusFaults, CorruptCountersAndPeriodChangeTheFramesExactly) {
  const Binding b = psd_binding();
  const std::size_t c1 = index_of(b.receive, "PsdCommand1");
  {
    FaultSpec c = bus_fault(FaultEffect::kCorrupt, "PsdCommand1");
    c.byte = 2;
    c.mask = 0x11;
    BusFaults bf = resolved({c}, b);
    Sink out;
    EXPECT_FALSE(bf.process(Dir::kRx, c1, frame_of(b.receive[c1]), 0, 1, std::ref(out)));
    ASSERT_EQ(out.frames.size(), 1u);
    EXPECT_EQ(out.frames[0].data[2], 0x5A ^ 0x11);
    EXPECT_EQ(out.frames[0].data[1], 0x5A);
  }
  {
    BusFaults bf = resolved({bus_fault(FaultEffect::kCounterFreeze, "PsdCommand1")}, b);
    Sink out;
    for (std::uint64_t k = 5; k < 9; ++k) bf.process(Dir::kRx, c1, frame_of(b.receive[c1], k), 0, 1, std::ref(out));
    bf.process(Dir::kRx, c1, frame_of(b.receive[c1], 9), 0, 0, std::ref(out));  // ended
    ASSERT_EQ(out.frames.size(), 5u);
    for (int i = 0; i < 4; ++i) EXPECT_EQ(counter_of(b.receive[c1], out.frames[static_cast<std::size_t>(i)]), 5u);
    EXPECT_EQ(counter_of(b.receive[c1], out.frames[4]), 9u);
  }
  {
    FaultSpec j = bus_fault(FaultEffect::kCounterJump, "PsdCommand1");
    j.jump = 6;
    BusFaults bf = resolved({j}, b);
    Sink out;
    bf.process(Dir::kRx, c1, frame_of(b.receive[c1], 12), 0, 1, std::ref(out));
    ASSERT_EQ(out.frames.size(), 1u);
    EXPECT_EQ(counter_of(b.receive[c1], out.frames[0]), 2u);  // 12 + 6 mod 16
  }
  {
    FaultSpec p = bus_fault(FaultEffect::kPeriod, "PsdCommand1");
    p.period_s = 0.03;  // every third sample, counted from the fault's start
    BusFaults bf = resolved({p}, b);
    std::string seen;
    for (int k = 4; k < 11; ++k) {
      Sink out;
      bf.process(Dir::kRx, c1, frame_of(b.receive[c1]), k * kRatio, 1, std::ref(out));
      seen += out.frames.empty() ? '.' : 'x';
    }
    EXPECT_EQ(seen, "x..x..x");
    EXPECT_EQ(bf.frames_of(0), 4);  // the frames it kept from the bus
  }
  {
    FaultSpec off = bus_fault(FaultEffect::kBusOff, "bus");
    BusFaults bf = resolved({bus_fault(FaultEffect::kStop, "PsdCommand2"), off}, b);
    Sink out;
    bf.process(Dir::kRx, c1, frame_of(b.receive[c1]), 0, 2, std::ref(out));  // bus_off: both ways, every message
    bf.process(Dir::kTx, 0, frame_of(b.send[0]), 0, 2, std::ref(out));
    bf.process(Dir::kRx, c1, frame_of(b.receive[c1]), 10, 1, std::ref(out));  // stop acts on PsdCommand2 only
    EXPECT_EQ(out.frames.size(), 1u);
    EXPECT_EQ(bf.frames_of(1), 2);
    EXPECT_EQ(bf.frames_of(0), 0);
  }
}

// With E2E: bad_crc spoils the CRC (the receiver says bad_crc); a counter fault keeps the CRC
// right (the receiver says the sequence is wrong, not the CRC).
TEST(BusFaults, E2eCrcAndCounterAsTheReceiverJudgesThem) {
  const Binding b = vcu_binding();
  const std::size_t t = index_of(b.receive, "VCU_TorqueCmd");
  const io::can::E2eConfig& e2e = *b.receive[t].e2e;
  const auto protected_frame = [&](int counter) {
    io::can::Frame f = frame_of(b.receive[t]);
    io::can::e2e_protect(e2e, std::span<std::uint8_t>(f.data.data(), f.len), static_cast<std::uint8_t>(counter));
    return f;
  };
  const auto judge = [&](io::can::E2eReceiver& rx, const io::can::Frame& f) {
    return io::can::e2e_check(e2e, std::span<const std::uint8_t>(f.data.data(), f.len), rx);
  };
  {
    BusFaults bf = resolved({bus_fault(FaultEffect::kBadCrc, "VCU_TorqueCmd")}, b);
    Sink out;
    bf.process(Dir::kRx, t, protected_frame(3), 0, 1, std::ref(out));
    io::can::E2eReceiver rx;
    ASSERT_EQ(out.frames.size(), 1u);
    EXPECT_EQ(judge(rx, out.frames[0]), io::can::E2eResult::kBadCrc);
    EXPECT_EQ(judge(rx, protected_frame(3)), io::can::E2eResult::kOk);  // the frame itself was good
  }
  {
    FaultSpec j = bus_fault(FaultEffect::kCounterJump, "VCU_TorqueCmd");
    j.jump = 5;
    BusFaults bf = resolved({j}, b);
    Sink out;
    io::can::E2eReceiver rx;
    EXPECT_EQ(judge(rx, protected_frame(2)), io::can::E2eResult::kOk);
    bf.process(Dir::kRx, t, protected_frame(3), 0, 1, std::ref(out));
    ASSERT_EQ(out.frames.size(), 1u);
    EXPECT_EQ(judge(rx, out.frames[0]), io::can::E2eResult::kWrongSequence);  // 2 -> 8: CRC right
  }
  {
    BusFaults bf = resolved({bus_fault(FaultEffect::kCounterFreeze, "VCU_TorqueCmd")}, b);
    Sink out;
    bf.process(Dir::kRx, t, protected_frame(3), 0, 1, std::ref(out));
    bf.process(Dir::kRx, t, protected_frame(4), 0, 1, std::ref(out));
    io::can::E2eReceiver rx;
    ASSERT_EQ(out.frames.size(), 2u);
    EXPECT_EQ(judge(rx, out.frames[0]), io::can::E2eResult::kOk);
    EXPECT_EQ(judge(rx, out.frames[1]), io::can::E2eResult::kRepeated);
  }
}

// On a bus that carries error frames (SocketCAN): error_frames one per sample while it acts,
// bus_off its controller's bus-off where it starts and the restart where it ends; elsewhere
// bus_off is silence alone. As candump -L records them.
TEST(BusFaults, ErrorFramesAndBusOffEdgesOnABusThatCarriesThem) {
  const Binding b = psd_binding();
  FaultSpec e = bus_fault(FaultEffect::kErrorFrames, "bus");
  FaultSpec off = bus_fault(FaultEffect::kBusOff, "bus");
  BusFaults bf;
  std::vector<std::string> errors;
  ASSERT_TRUE(BusFaults::resolve({e, off}, b, kStep, kRatio, true, bf, errors)) << (errors.empty() ? "" : errors[0]);
  std::vector<io::can::ErrorFrame> sent;
  const auto send = [&](io::can::ErrorFrame k) { sent.push_back(k); };
  for (std::uint64_t mask : {0u, 1u, 1u, 0u, 2u, 2u, 2u, 0u, 0u}) bf.error_frames(mask, send);
  using io::can::ErrorFrame;
  EXPECT_EQ(sent, (std::vector<ErrorFrame>{ErrorFrame::kBusError, ErrorFrame::kBusError, ErrorFrame::kBusOff,
                                           ErrorFrame::kRestarted}));
  EXPECT_EQ(bf.frames_of(0), 2);
  // without error frames on the bus: bus_off is silence, no edge reported
  BusFaults quiet;
  ASSERT_TRUE(BusFaults::resolve({off}, b, kStep, kRatio, false, quiet, errors));
  sent.clear();
  for (std::uint64_t mask : {1u, 1u, 0u}) quiet.error_frames(mask, send);
  EXPECT_TRUE(sent.empty());
  // the frames as linux/can/error.h has them, in candump -L's text
  std::string log;
  for (ErrorFrame k : {ErrorFrame::kBusError, ErrorFrame::kBusOff, ErrorFrame::kRestarted}) {
    std::uint32_t id = 0;
    std::array<std::uint8_t, 8> data{};
    io::can::error_frame_bits(k, id, data);
    io::can::append_candump_error_line(log, 1.5, "vcan0", id, data);
  }
  EXPECT_EQ(log,
            "(1.500000) vcan0 20000088#0000020000000000\n"
            "(1.500000) vcan0 20000040#0000000000000000\n"
            "(1.500000) vcan0 20000100#0000000000000000\n");
}

TEST(BusFaults, WhatTheBindingCannotTakeIsALoadErrorWithItsLine) {
  const Binding psd = psd_binding(), vcu = vcu_binding();
  const auto error_of = [&](const FaultSpec& f, const Binding& b) {
    BusFaults out;
    std::vector<std::string> errors;
    EXPECT_FALSE(BusFaults::resolve({f}, b, kStep, kRatio, false, out, errors));
    return errors.empty() ? std::string() : errors[0];
  };
  const auto has = [](const std::string& e, const std::string& what) {
    EXPECT_NE(e.find(what), std::string::npos) << e << "\n  (wanted: " << what << ")";
    EXPECT_EQ(e.rfind("t.toml:7: fault[0]", 0), 0u) << e;
  };
  has(error_of(bus_fault(FaultEffect::kDrop, "PsdComand1"), psd), "did you mean \"PsdCommand1\"");
  has(error_of(bus_fault(FaultEffect::kDrop, "EvCommand"), psd), "no message of that name");
  FaultSpec early = bus_fault(FaultEffect::kDrop, "PsdCommand1");
  early.at_s = 0.0099;  // inside sample 0's period
  has(error_of(early, psd), "at_s = 0.0099: a bus fault starts at the ECU's second sample (at_s >= 0.01 s) or later");
  early.at_s = 0.01;
  {
    BusFaults out;
    std::vector<std::string> errors;
    EXPECT_TRUE(BusFaults::resolve({early}, psd, kStep, kRatio, false, out, errors));
    early.at_s = 0.0;
    early.has_when = true;  // a trigger: it acts from the step after it holds, never at sample 0
    EXPECT_TRUE(BusFaults::resolve({early}, psd, kStep, kRatio, false, out, errors));
  }
  FaultSpec c = bus_fault(FaultEffect::kCorrupt, "PsdCommand1");
  c.byte = 8;
  has(error_of(c, psd), "byte = 8 is outside the frame");
  has(error_of(bus_fault(FaultEffect::kBadCrc, "PsdCommand1"), psd), "has no E2E protection");
  has(error_of(bus_fault(FaultEffect::kCounterFreeze, "VCU_EngineCmd"), vcu), "carries no counter");
  has(error_of(bus_fault(FaultEffect::kErrorFrames, "bus"), psd), "CAN error frames need a bus that carries them");
  // and what it can: a counter fault on an E2E message without a rolling counter
  BusFaults ok;
  std::vector<std::string> errors;
  EXPECT_TRUE(BusFaults::resolve({bus_fault(FaultEffect::kCounterJump, "VCU_TorqueCmd")}, vcu, kStep, kRatio, false, ok, errors));
  EXPECT_TRUE(errors.empty());
}

}  // namespace
}  // namespace ehpt::hil
