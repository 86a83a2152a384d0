// SPDX-License-Identifier: BSD-3-Clause
// io/can/ls_bus: the FMI-LS-BUS CAN operations byte for byte as the specification lays them out
// (OP Code 4 bytes, Total Length 4 bytes, arguments; little-endian), and the terminal's rules:
// a malformed operation is counted and answered with a Format Error, a full Tx drops and counts.
#include <gtest/gtest.h>

#include <vector>

#include "io/can/ls_bus.hpp"

namespace ehpt::io::can::ls_bus {
namespace {

std::vector<std::uint8_t> bytes(std::initializer_list<int> v) {
  std::vector<std::uint8_t> out;
  for (const int b : v) out.push_back(static_cast<std::uint8_t>(b));
  return out;
}

TEST(LsBusCodec, CanTransmitIsOpCodeTotalLengthIdIdeRtrDataLengthData) {
  Frame f;
  f.id = 0x123;
  f.len = 3;
  f.data = {0xAA, 0xBB, 0xCC};
  std::vector<std::uint8_t> buf(64);
  ASSERT_EQ(put_transmit(buf, 0, f), 19u);
  buf.resize(19);
  EXPECT_EQ(buf, bytes({0x10, 0, 0, 0, 19, 0, 0, 0, 0x23, 0x01, 0, 0, 0, 0, 3, 0, 0xAA, 0xBB, 0xCC}));
  // an extended id: Ide TRUE
  f.id = 0x1ABCDEF0;
  f.extended = true;
  f.len = 0;
  std::vector<std::uint8_t> ext(64);
  ASSERT_EQ(put_transmit(ext, 0, f), 16u);
  ext.resize(16);
  EXPECT_EQ(ext, bytes({0x10, 0, 0, 0, 16, 0, 0, 0, 0xF0, 0xDE, 0xBC, 0x1A, 1, 0, 0, 0}));
}

TEST(LsBusCodec, BusErrorAndStatusLayouts) {
  std::vector<std::uint8_t> buf(64);
  ASSERT_EQ(put_bus_error(buf, 0, 0x10, kFormError, kPrimaryErrorFlag, false), 15u);
  ASSERT_EQ(put_status(buf, 15, kBusOff), 9u);
  buf.resize(24);
  EXPECT_EQ(buf, bytes({0x31, 0, 0, 0, 15, 0, 0, 0, 0x10, 0, 0, 0, 3, 1, 0,  //
                        0x41, 0, 0, 0, 9, 0, 0, 0, 3}));
}

TEST(LsBusCodec, AnOperationThatDoesNotFitIsNotWritten) {
  Frame f;
  f.len = 8;
  std::vector<std::uint8_t> buf(23);  // 24 needed
  EXPECT_EQ(put_transmit(buf, 0, f), 0u);
  EXPECT_EQ(put_transmit(buf, 30, f), 0u);  // used past the end: no room, no overflow
}

TEST(LsBusCodec, ParseReadsBackEveryFrameAndCountsTheRest) {
  std::vector<std::uint8_t> buf(256);
  std::size_t used = 0;
  Frame a, b;
  a.id = 0x100;
  a.len = 8;
  for (int i = 0; i < 8; ++i) a.data[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(i + 1);
  b.id = 0x7FF;
  b.len = 1;
  b.data[0] = 0x5A;
  used += put_transmit(buf, used, a);
  used += put_status(buf, used, kErrorPassive);
  used += put_transmit(buf, used, b);
  used += put_bus_error(buf, used, 0x100, kFormError, kPrimaryErrorFlag, true);
  std::vector<Frame> got;
  int malformed = 0;
  const RxCounts c = parse(
      std::span<const std::uint8_t>(buf.data(), used), [&](const Frame& f) { got.push_back(f); },
      [&](std::span<const std::uint8_t>) { ++malformed; });
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0], a);
  EXPECT_EQ(got[1], b);
  EXPECT_EQ(c.frames, 2);
  EXPECT_EQ(c.status, 1);
  EXPECT_EQ(c.last_status, kErrorPassive);
  EXPECT_EQ(c.bus_errors, 1);
  EXPECT_EQ(c.malformed, 0);
  EXPECT_EQ(malformed, 0);
}

TEST(LsBusCodec, MalformedOperationsAreCountedNeverRead) {
  const auto count = [](const std::vector<std::uint8_t>& in, std::int64_t& frames) {
    frames = 0;
    return parse(std::span<const std::uint8_t>(in), [&](const Frame&) { ++frames; }, [](std::span<const std::uint8_t>) {})
        .malformed;
  };
  std::int64_t frames = 0;
  // a length past the buffer's end
  EXPECT_EQ(count(bytes({0x10, 0, 0, 0, 40, 0, 0, 0, 1, 0, 0, 0}), frames), 1);
  // a length below the header's
  EXPECT_EQ(count(bytes({0x10, 0, 0, 0, 4, 0, 0, 0}), frames), 1);
  // a CAN Transmit whose Data Length disagrees with its Total Length
  EXPECT_EQ(count(bytes({0x10, 0, 0, 0, 17, 0, 0, 0, 1, 0, 0, 0, 0, 0, 2, 0, 9}), frames), 1);
  EXPECT_EQ(frames, 0);
  // an 11-bit frame with a 29-bit id
  EXPECT_EQ(count(bytes({0x10, 0, 0, 0, 16, 0, 0, 0, 0, 8, 0, 0, 0, 0, 0, 0}), frames), 1);
  // a Status of a value the standard does not have; an OP code it does not have
  EXPECT_EQ(count(bytes({0x41, 0, 0, 0, 9, 0, 0, 0, 7}), frames), 1);
  EXPECT_EQ(count(bytes({0x77, 0, 0, 0, 8, 0, 0, 0}), frames), 1);
}

// Valid operations of other nodes on a mixed bus (CAN FD and XL, a remote frame, nine data
// bytes) are counted as not classic CAN, not refused and not read; the walk goes on past them.
TEST(LsBusCodec, OtherNodesFdXlAndRemoteFramesAreLetBeNotRefused) {
  std::vector<std::uint8_t> in = bytes({0x11, 0, 0, 0, 17, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 1, 0});  // CAN FD
  const std::vector<std::uint8_t> remote = bytes({0x10, 0, 0, 0, 16, 0, 0, 0, 5, 0, 0, 0, 0, 1, 0, 0});
  in.insert(in.end(), remote.begin(), remote.end());
  std::vector<std::uint8_t> nine = bytes({0x10, 0, 0, 0, 25, 0, 0, 0, 1, 0, 0, 0, 0, 0, 9, 0});
  nine.resize(25, 0);
  in.insert(in.end(), nine.begin(), nine.end());
  std::vector<std::uint8_t> good(17);
  Frame g;
  g.id = 5;
  g.len = 1;
  put_transmit(good, 0, g);
  in.insert(in.end(), good.begin(), good.end());
  std::int64_t frames = 0, refused = 0;
  const RxCounts c = parse(std::span<const std::uint8_t>(in), [&](const Frame& f) { frames += f.id == 5 ? 1 : 100; },
                           [&](std::span<const std::uint8_t>) { ++refused; });
  EXPECT_EQ(c.not_classic, 3);
  EXPECT_EQ(c.malformed, 0);
  EXPECT_EQ(refused, 0);
  EXPECT_EQ(frames, 1);
}

TEST(LsBusCodec, TheTerminalQueuesRxAnswersMalformedWithAFormErrorAndCountsAFullTx) {
  LsBusTerminal t(64, 2);
  std::vector<std::uint8_t> rx(256);
  std::size_t used = 0;
  Frame f;
  f.id = 0x10;
  f.len = 2;
  for (int i = 0; i < 3; ++i) used += put_transmit(rx, used, f);  // three frames, room for two
  rx[used++] = 0x99;                                                // and a stray byte
  const RxCounts c = t.take_rx(std::span<const std::uint8_t>(rx.data(), used));
  EXPECT_EQ(c.frames, 3);
  EXPECT_EQ(c.malformed, 1);
  EXPECT_EQ(t.rx_dropped(), 1);
  EXPECT_EQ(t.counters().rx_malformed, 1);
  Frame out[4];
  EXPECT_EQ(t.receive(out), 2u);
  EXPECT_EQ(out[0], f);
  // the Format Error carries the byte it refuses
  EXPECT_EQ(std::vector<std::uint8_t>(t.tx().begin(), t.tx().end()), bytes({0x01, 0, 0, 0, 11, 0, 0, 0, 1, 0, 0x99}));
  t.clear_tx();
  // 64 bytes of Tx hold two 8-byte frames (24 each), not three
  f.len = 8;
  EXPECT_TRUE(t.send(f));
  EXPECT_TRUE(t.send(f));
  EXPECT_FALSE(t.send(f));
  EXPECT_EQ(t.counters().frames_out, 2);
  EXPECT_EQ(t.counters().send_dropped, 1);
  EXPECT_EQ(t.tx().size(), 48u);
  // error frames become Bus Error and Status operations
  t.clear_tx();
  EXPECT_TRUE(t.send_error(ErrorFrame::kBusOff));
  EXPECT_EQ(std::vector<std::uint8_t>(t.tx().begin(), t.tx().end()), bytes({0x41, 0, 0, 0, 9, 0, 0, 0, 3}));
  EXPECT_EQ(t.counters().error_frames_sent, 1);
}

}  // namespace
}  // namespace ehpt::io::can::ls_bus
