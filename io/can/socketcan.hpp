// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// SocketCAN transport: one raw CAN socket (PF_CAN, SOCK_RAW, CAN_RAW) bound to one interface
// (can0 on a real bus, vcan0 in tests). Linux only.
//
// What the socket is set up to hear, and why:
// - Kernel receive filters for exactly the given 11-bit ids, as standard data frames: the
//   filter mask includes CAN_EFF_FLAG and CAN_RTR_FLAG, so an extended or remote frame with
//   the same number is dropped in the kernel, not in our loop.
// - Error frames (CAN_RAW_ERR_FILTER = all classes): counted in error_frames, never handed
//   out, never fatal. A bus-off or a missing ACK shows up in the stats instead of silence.
// - Own frames are not received (CAN_RAW_RECV_OWN_MSGS off), but local loopback stays on
//   (the default), so another socket on the same interface (candump, the ECU on vcan0) does
//   see what we send.
// - Non-blocking: a full TX queue (EAGAIN/ENOBUFS) is counted in send_dropped and the frame
//   is lost; the run never waits on the bus.
//
// Start-up: open_socketcan() may allocate and fails with one clear line. Run phase: send(),
// receive(), wait() use no heap, throw nothing and print nothing.

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "io/can/transport.hpp"

namespace ehpt::io::can {

// Opens a raw CAN socket on interface_name (e.g. "vcan0"). nullptr and one line in error if
// it cannot, e.g.
//   "socketcan:vcan9: no such CAN interface"
//   "socketcan: this kernel has no CAN support (socket(AF_CAN) failed: Address family not
//    supported by protocol)"
// The name must be 1..15 characters (IFNAMSIZ - 1) without '/'; every rx id must be <= 0x7FF,
// or an extended one (<= 0x1FFFFFFF) with kExtendedIdFlag set.
// An empty rx_ids receives no data frames (error frames are still counted).
// The frame of an error (linux/can/error.h): its id with CAN_ERR_FLAG and class bits, and its
// CAN_ERR_DLC data bytes. Pure: what send_error writes, and what bus.log records of it.
void error_frame_bits(ErrorFrame kind, std::uint32_t& can_id, std::array<std::uint8_t, 8>& data);

std::unique_ptr<Transport> open_socketcan(const std::string& interface_name,
                                          std::span<const std::uint32_t> rx_ids,
                                          std::string& error);

}  // namespace ehpt::io::can
