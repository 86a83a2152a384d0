// SPDX-License-Identifier: BSD-3-Clause
// SocketCAN transport against a real vcan0 (run by tools/vcan-vm.sh on kernels without CAN):
//   socketcan_probe [INTERFACE]      exit 0: all checks pass, 1: a check failed,
//                                    77: this kernel has no CAN (nothing was checked)
// Two transports on the same interface: `sender` transmits, `receiver` listens to 0x100 and
// 0x101 only. What is checked:
// - every frame arrives once, in order, with its bytes (a counter in bytes 0..3);
// - a listed id as an extended or remote frame, and an unlisted id, are dropped by the filters;
// - an error frame (written by a third, plain socket) is counted, not handed out, not fatal;
// - own frames are not received (the sender also listens to 0x100), while loopback lets the
//   other socket hear them;
// - wait() times out with nothing pending and wakes with something pending;
// - open errors on this kernel: missing interface, non-CAN interface.
// Frames go in batches smaller than the receive buffer, so the count does not depend on
// net.core.rmem_default (the VM raises it anyway).

#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

#include "io/can/socketcan.hpp"

namespace {

using ehpt::io::can::Frame;
using ehpt::io::can::Transport;

int failures = 0;

void check(bool ok, const std::string& what) {
  std::printf("%s %s\n", ok ? "ok  " : "FAIL", what.c_str());
  if (!ok) ++failures;
}

// Waits up to ~1 s in total for `want` frames; returns how many arrived.
std::size_t receive_some(Transport& t, std::span<Frame> out, std::size_t want) {
  std::size_t got = 0;
  for (int round = 0; round < 100 && got < want; ++round) {
    t.wait(10'000'000);
    got += t.receive(out.subspan(got));
  }
  return got;
}

// Writes one raw can_frame through a plain socket (for frames send() refuses to make).
bool write_raw(const std::string& interface_name, canid_t can_id, std::uint8_t len) {
  const int fd = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
  if (fd < 0) return false;
  struct sockaddr_can address {};
  address.can_family = AF_CAN;
  address.can_ifindex = static_cast<int>(::if_nametoindex(interface_name.c_str()));
  struct can_frame frame {};
  frame.can_id = can_id;
  frame.len = len;
  const bool ok = ::bind(fd, reinterpret_cast<struct sockaddr*>(&address), sizeof address) == 0 &&
                  ::write(fd, &frame, sizeof frame) == static_cast<ssize_t>(sizeof frame);
  ::close(fd);
  return ok;
}

Frame counter_frame(std::uint32_t id, std::uint32_t n) {
  Frame f;
  f.id = id;
  f.len = static_cast<std::uint8_t>(4 + n % 5);  // 4..8 bytes, to see len travel too
  for (int b = 0; b < 4; ++b) f.data[static_cast<std::size_t>(b)] = static_cast<std::uint8_t>(n >> (8 * b));
  for (int b = 4; b < f.len; ++b) f.data[static_cast<std::size_t>(b)] = static_cast<std::uint8_t>(0xA0 + b);
  return f;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string iface = argc > 1 ? argv[1] : "vcan0";
  std::string error;

  const std::array<std::uint32_t, 2> rx_ids{0x100, 0x101};
  auto receiver = ehpt::io::can::open_socketcan(iface, rx_ids, error);
  if (!receiver && error.rfind("socketcan: this kernel has no CAN support", 0) == 0) {
    std::printf("skip: %s\n", error.c_str());
    return 77;
  }
  check(receiver != nullptr, "open receiver on " + iface + (receiver ? "" : ": " + error));
  const std::array<std::uint32_t, 1> sender_ids{0x100};
  auto sender = ehpt::io::can::open_socketcan(iface, sender_ids, error);
  check(sender != nullptr, "open sender on " + iface + (sender ? "" : ": " + error));
  if (!receiver || !sender) return 1;
  check(receiver->describe() == "socketcan:" + iface, "describe() is socketcan:" + iface);
  check(receiver->has_peer(), "has_peer()");

  // open errors with the kernel's CAN present
  error.clear();
  bool opened = ehpt::io::can::open_socketcan("vcan9", rx_ids, error) != nullptr;
  check(!opened && error == "socketcan:vcan9: no such CAN interface", "missing interface: \"" + error + "\"");
  error.clear();
  opened = ehpt::io::can::open_socketcan("lo", rx_ids, error) != nullptr;
  check(!opened && error == "socketcan:lo: not a CAN interface", "non-CAN interface: \"" + error + "\"");

  // nothing pending: wait() returns false after its timeout
  check(!receiver->wait(20'000'000), "wait() times out when idle");

  // N counter frames on 0x100, with filtered-out frames interleaved, in batches of 50
  constexpr std::uint32_t kFrames = 1000;
  constexpr std::uint32_t kBatch = 50;
  std::array<Frame, 2 * kBatch> in{};
  std::uint32_t next_expected = 0;
  std::int64_t out_of_order = 0;
  std::int64_t unexpected = 0;
  for (std::uint32_t first = 0; first < kFrames; first += kBatch) {
    for (std::uint32_t n = first; n < first + kBatch; ++n) {
      sender->send(counter_frame(0x100, n));
      if (n % 10 == 0) {
        Frame other = counter_frame(0x200, n);  // unlisted id
        sender->send(other);
      }
    }
    const std::size_t got = receive_some(*receiver, in, kBatch);
    for (std::size_t i = 0; i < got; ++i) {
      if (in[i].id != 0x100) { ++unexpected; continue; }
      if (!(in[i] == counter_frame(0x100, next_expected))) ++out_of_order;
      ++next_expected;
    }
  }
  const auto& rc = receiver->counters();
  const auto& sc = sender->counters();
  check(next_expected == kFrames, "received " + std::to_string(next_expected) + " of " +
                                      std::to_string(kFrames) + " frames on 0x100");
  check(out_of_order == 0, "in order with their bytes (" + std::to_string(out_of_order) + " wrong)");
  check(unexpected == 0, "unlisted id 0x200 filtered out (" + std::to_string(unexpected) + " got through)");
  check(sc.frames_out == kFrames + kFrames / 10 && sc.send_dropped == 0,
        "sender: frames_out " + std::to_string(sc.frames_out) + ", send_dropped " + std::to_string(sc.send_dropped));
  check(rc.frames_in == kFrames, "receiver: frames_in " + std::to_string(rc.frames_in));

  // the sender listens to 0x100 too, but must not hear itself
  check(sender->receive(in) == 0 && sender->counters().frames_in == 0, "own frames not received");

  // a listed id as extended and as remote frame, then an error frame, then one good frame
  check(write_raw(iface, 0x100 | CAN_EFF_FLAG, 8), "wrote extended 0x100");
  check(write_raw(iface, 0x101 | CAN_RTR_FLAG, 0), "wrote remote 0x101");
  check(write_raw(iface, CAN_ERR_FLAG | CAN_ERR_BUSOFF, CAN_ERR_DLC), "wrote error frame (bus-off)");
  Frame last;
  last.id = 0x101;
  last.len = 0;
  check(sender->send(last), "send 0x101 with len 0");
  check(receiver->wait(1'000'000'000), "wait() wakes when a frame is pending");
  const std::size_t got = receive_some(*receiver, in, 1);
  check(got == 1 && in[0].id == 0x101 && in[0].len == 0,
        "only the standard data frame is handed out (got " + std::to_string(got) + ")");
  check(receiver->counters().error_frames == 1,
        "error frame counted: " + std::to_string(receiver->counters().error_frames));
  check(receiver->counters().rx_malformed == 0, "extended/remote dropped by the kernel filters");

  // send() refuses what the contract cannot carry, without writing
  Frame bad;
  bad.id = 0x800;
  check(!sender->send(bad) && sender->counters().send_dropped == 1, "send() refuses id 0x800");

  std::printf("%s: %d failure(s)\n", failures == 0 ? "PASS" : "FAIL", failures);
  return failures == 0 ? 0 : 1;
}
