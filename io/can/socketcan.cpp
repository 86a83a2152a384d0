// SPDX-License-Identifier: BSD-3-Clause
#include "io/can/socketcan.hpp"

#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <vector>

namespace ehpt::io::can {
namespace {

class SocketCanTransport final : public Transport {
 public:
  SocketCanTransport(int fd, const std::string& interface_name)
      : fd_(fd), description_("socketcan:" + interface_name) {}
  ~SocketCanTransport() override { ::close(fd_); }
  SocketCanTransport(const SocketCanTransport&) = delete;
  SocketCanTransport& operator=(const SocketCanTransport&) = delete;

  // Run phase: no allocation.
  bool send(const Frame& frame) override {
    // the contract has 11-bit ids and classic lengths only; anything else cannot go out
    if (frame.id > (frame.extended ? kMaxExtendedId : kMaxStandardId) || frame.len > CAN_MAX_DLEN) {
      ++counters_.send_dropped;
      return false;
    }
    struct can_frame out {};
    out.can_id = frame.extended ? (frame.id | CAN_EFF_FLAG) : frame.id;
    out.len = frame.len;
    std::memcpy(out.data, frame.data.data(), frame.len);
    if (!write_frame(out)) return false;
    ++counters_.frames_out;
    return true;
  }

  // Run phase: no allocation.
  std::size_t receive(std::span<Frame> out) override {
    std::size_t count = 0;
    while (count < out.size()) {
      struct can_frame in {};
      const ssize_t got = ::read(fd_, &in, sizeof in);
      if (got < 0) {
        if (errno == EINTR) continue;
        break;  // EAGAIN: nothing more now; ENETDOWN and the like: nothing to hand out either
      }
      // CAN FD frames are off (no CAN_RAW_FD_FRAMES), so a short read is a broken frame
      if (got != static_cast<ssize_t>(sizeof in)) {
        ++counters_.rx_malformed;
        continue;
      }
      if ((in.can_id & CAN_ERR_FLAG) != 0) {
        ++counters_.error_frames;
        continue;
      }
      // the filters already drop these; counted in case someone widens them
      if ((in.can_id & CAN_RTR_FLAG) != 0 || in.len > CAN_MAX_DLEN) {
        ++counters_.rx_malformed;
        continue;
      }
      Frame& frame = out[count++];
      frame.extended = (in.can_id & CAN_EFF_FLAG) != 0;
      frame.id = in.can_id & (frame.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
      frame.len = in.len;
      frame.data.fill(0);  // bytes beyond len are zero (frame.hpp)
      std::memcpy(frame.data.data(), in.data, in.len);
      ++counters_.frames_in;
    }
    return count;
  }

  // Run phase: no allocation. ppoll keeps nanoseconds, where poll would round to ms.
  bool wait(std::int64_t timeout_ns) override {
    const std::int64_t clamped_ns = timeout_ns > 0 ? timeout_ns : 0;
    struct timespec timeout {};
    timeout.tv_sec = static_cast<time_t>(clamped_ns / 1'000'000'000);
    timeout.tv_nsec = static_cast<long>(clamped_ns % 1'000'000'000);
    struct pollfd pfd {};
    pfd.fd = fd_;
    pfd.events = POLLIN;
    const int ready = ::ppoll(&pfd, 1, &timeout, nullptr);
    // EINTR: there may be something; receive() finds out at no cost
    return ready > 0 || (ready < 0 && errno == EINTR);
  }

  bool has_peer() const override { return true; }
  bool sends_error_frames() const override { return true; }
  // Run phase: no allocation. The frame linux/can/error.h describes (CAN_ERR_FLAG in the id,
  // CAN_ERR_DLC bytes): every socket with an error filter on the interface receives it; on
  // vcan that is the ECU under test, as a controller would report the bus's errors to it.
  bool send_error(ErrorFrame kind) override {
    struct can_frame out {};
    out.len = CAN_ERR_DLC;
    std::array<std::uint8_t, 8> data{};
    std::uint32_t id = 0;
    error_frame_bits(kind, id, data);
    out.can_id = id;
    std::memcpy(out.data, data.data(), data.size());
    if (!write_frame(out)) return false;
    ++counters_.error_frames_sent;
    return true;
  }
  const TransportCounters& counters() const override { return counters_; }
  std::string describe() const override { return description_; }

 private:
  // One frame to the socket (EINTR retried). EAGAIN/ENOBUFS (queue full) and ENETDOWN alike:
  // the frame is lost (send_dropped), the run goes on.
  bool write_frame(const struct can_frame& out) {
    ssize_t written = -1;
    do {
      written = ::write(fd_, &out, sizeof out);
    } while (written < 0 && errno == EINTR);
    if (written == static_cast<ssize_t>(sizeof out)) return true;
    ++counters_.send_dropped;
    return false;
  }

  int fd_;
  std::string description_;
  TransportCounters counters_;
};

std::string errno_text(int error_number) { return std::strerror(error_number); }

}  // namespace

void error_frame_bits(ErrorFrame kind, std::uint32_t& can_id, std::array<std::uint8_t, 8>& data) {
  static_assert(CAN_ERR_DLC == 8);
  data.fill(0);
  switch (kind) {
    case ErrorFrame::kBusError:
      can_id = CAN_ERR_FLAG | CAN_ERR_PROT | CAN_ERR_BUSERROR;
      data[2] = CAN_ERR_PROT_FORM;
      return;
    case ErrorFrame::kBusOff: can_id = CAN_ERR_FLAG | CAN_ERR_BUSOFF; return;
    case ErrorFrame::kRestarted: can_id = CAN_ERR_FLAG | CAN_ERR_RESTARTED; return;
  }
  can_id = CAN_ERR_FLAG;
}

std::unique_ptr<Transport> open_socketcan(const std::string& interface_name,
                                          std::span<const std::uint32_t> rx_ids,
                                          std::string& error) {
  const std::string at = "socketcan:" + interface_name;
  // a name the kernel would truncate or that looks like a path is a configuration mistake
  if (interface_name.empty() || interface_name.size() >= IFNAMSIZ ||
      interface_name.find('/') != std::string::npos) {
    error = at + ": interface name must be 1.." + std::to_string(IFNAMSIZ - 1) +
            " characters without '/'";
    return nullptr;
  }
  // filters: the exact id and frame format (an extended one carries kExtendedIdFlag, which is
  // the kernel's CAN_EFF_FLAG); RTR must be clear (data frames only)
  static_assert(kExtendedIdFlag == CAN_EFF_FLAG);
  std::vector<struct can_filter> filters;
  filters.reserve(rx_ids.size());
  for (const std::uint32_t id : rx_ids) {
    if ((id & kExtendedIdFlag) != 0 && (id & ~kExtendedIdFlag) <= kMaxExtendedId) {
      filters.push_back({id, CAN_EFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG});
      continue;
    }
    if (id > kMaxStandardId) {
      char hex[16];
      std::snprintf(hex, sizeof hex, "0x%X", id);
      error = at + ": receive id " + hex + " is not an 11-bit standard id (max 0x7FF)";
      return nullptr;
    }
    filters.push_back({id, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG});
  }

  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    const int e = errno;
    if (e == EAFNOSUPPORT || e == EPROTONOSUPPORT) {
      error = "socketcan: this kernel has no CAN support (socket(AF_CAN) failed: " +
              errno_text(e) + ")";
    } else {
      error = at + ": socket(AF_CAN) failed: " + errno_text(e);
    }
    return nullptr;
  }
  // from here on the fd is ours to close on every failure
  auto fail = [&](const std::string& message) {
    ::close(fd);
    error = at + ": " + message;
    return nullptr;
  };

  const unsigned int index = ::if_nametoindex(interface_name.c_str());
  if (index == 0) return fail("no such CAN interface");

  // an empty filter list (optlen 0) means: no data frames at all
  const int off = 0;
  const can_err_mask_t all_errors = CAN_ERR_MASK;
  const auto filters_size = static_cast<socklen_t>(filters.size() * sizeof(struct can_filter));
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters.empty() ? nullptr : filters.data(),
                   filters_size) != 0) {
    return fail("setsockopt(CAN_RAW_FILTER) failed: " + errno_text(errno));
  }
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &all_errors, sizeof all_errors) != 0) {
    return fail("setsockopt(CAN_RAW_ERR_FILTER) failed: " + errno_text(errno));
  }
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, &off, sizeof off) != 0) {
    return fail("setsockopt(CAN_RAW_RECV_OWN_MSGS) failed: " + errno_text(errno));
  }

  struct sockaddr_can address {};
  address.can_family = AF_CAN;
  address.can_ifindex = static_cast<int>(index);
  if (::bind(fd, reinterpret_cast<struct sockaddr*>(&address), sizeof address) != 0) {
    const int e = errno;
    // can_raw answers ENODEV for an interface that exists but is not CAN (lo, eth0)
    if (e == ENODEV) return fail("not a CAN interface");
    return fail("bind failed: " + errno_text(e));
  }
  // a down interface drops every send (ENETDOWN): say so now rather than count it later
  struct ifreq request {};
  std::memcpy(request.ifr_name, interface_name.c_str(), interface_name.size());
  if (::ioctl(fd, SIOCGIFFLAGS, &request) == 0 && (request.ifr_flags & IFF_UP) == 0) {
    return fail("interface is down (ip link set up dev " + interface_name + ")");
  }
  return std::make_unique<SocketCanTransport>(fd, interface_name);
}

}  // namespace ehpt::io::can
