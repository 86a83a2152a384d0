// SPDX-License-Identifier: BSD-3-Clause
// open_socketcan's start-up errors, on whatever kernel runs the tests: with no CAN in the
// kernel (this host, most CI runners) the message says so; with CAN, a missing interface is
// named. Frames on a real vcan0: tests/io/socketcan_probe.cpp under tools/vcan-vm.sh.

#include "io/can/socketcan.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <string>

namespace ehpt::io::can {
namespace {

const std::array<std::uint32_t, 1> kIds{0x100};

TEST(SocketCanOpen, MissingInterfaceOrNoCanKernelIsNamed) {
  std::string error;
  EXPECT_EQ(open_socketcan("vcan9", kIds, error), nullptr);
  if (error.rfind("socketcan: this kernel", 0) == 0) {
    EXPECT_EQ(error,
              "socketcan: this kernel has no CAN support "
              "(socket(AF_CAN) failed: Address family not supported by protocol)");
  } else {
    EXPECT_EQ(error, "socketcan:vcan9: no such CAN interface");
  }
}

// checked before any socket exists, so these hold on every kernel
TEST(SocketCanOpen, RejectsBadInterfaceNames) {
  std::string error;
  EXPECT_EQ(open_socketcan("", kIds, error), nullptr);
  EXPECT_EQ(error, "socketcan:: interface name must be 1..15 characters without '/'");
  EXPECT_EQ(open_socketcan("vcan0123456789ab", kIds, error), nullptr);  // 16 characters
  EXPECT_EQ(error, "socketcan:vcan0123456789ab: interface name must be 1..15 characters without '/'");
  EXPECT_EQ(open_socketcan("../vcan0", kIds, error), nullptr);
  EXPECT_EQ(error, "socketcan:../vcan0: interface name must be 1..15 characters without '/'");
}

TEST(SocketCanOpen, RejectsExtendedReceiveIds) {
  std::string error;
  const std::array<std::uint32_t, 2> ids{0x100, 0x800};
  EXPECT_EQ(open_socketcan("vcan0", ids, error), nullptr);
  EXPECT_EQ(error, "socketcan:vcan0: receive id 0x800 is not an 11-bit standard id (max 0x7FF)");
}

}  // namespace
}  // namespace ehpt::io::can
