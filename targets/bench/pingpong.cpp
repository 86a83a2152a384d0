// SPDX-License-Identifier: BSD-3-Clause
#include "targets/bench/pingpong.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <vector>

namespace ehpt::bench {

namespace {

using Clock = std::chrono::steady_clock;

// a blocked read gives up after this (a child that died, a lost datagram): the bench goes on
constexpr int kReadTimeoutS = 2;

void set_read_timeout(int fd, int s) {
  timeval tv{s, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
}
void set_nodelay(int fd) {
  int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
}
std::string os_error(const char* what) { return std::string(what) + ": " + std::strerror(errno); }

// n bytes, in as many writes as the kernel needs (one, for these sizes)
bool write_all(int fd, const char* p, std::size_t n) {
  while (n > 0) {
    const ssize_t k = ::send(fd, p, n, MSG_NOSIGNAL);
    if (k < 0 && errno == EINTR) continue;
    if (k <= 0) return false;
    p += k;
    n -= static_cast<std::size_t>(k);
  }
  return true;
}
// TCP: exactly n bytes (a stream may split them); UDP: one datagram of n bytes
bool read_all(int fd, char* p, std::size_t n, bool stream) {
  if (!stream) {
    ssize_t k;
    do {
      k = ::recv(fd, p, n, 0);
    } while (k < 0 && errno == EINTR);
    return k == static_cast<ssize_t>(n);
  }
  while (n > 0) {
    const ssize_t k = ::recv(fd, p, n, 0);
    if (k < 0 && errno == EINTR) continue;
    if (k <= 0) return false;
    p += k;
    n -= static_cast<std::size_t>(k);
  }
  return true;
}

sockaddr_in loopback(std::uint16_t port) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  return a;
}
// a socket bound to 127.0.0.1 on a port the kernel picks; -1 on failure
int bound_socket(int type, std::uint16_t& port, std::string& error) {
  const int fd = ::socket(AF_INET, type | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    error = os_error("socket");
    return -1;
  }
  sockaddr_in a = loopback(0);
  socklen_t len = sizeof a;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0) {
    error = os_error("bind 127.0.0.1");
    ::close(fd);
    return -1;
  }
  port = ntohs(a.sin_port);
  return fd;
}

// The echoing side: reads out_bytes, answers back_bytes, until its peer is gone (or killed).
[[noreturn]] void echo_child(int fd, bool stream, std::size_t out_bytes, std::size_t back_bytes) {
  if (stream) {
    const int conn = ::accept(fd, nullptr, nullptr);  // the listening socket has a read timeout
    if (conn < 0) _exit(1);
    set_nodelay(conn);
    fd = conn;
  }
  set_read_timeout(fd, kReadTimeoutS);  // a parent that went away without killing us
  std::vector<char> in(out_bytes), back(back_bytes, 'b');
  while (read_all(fd, in.data(), out_bytes, stream) && write_all(fd, back.data(), back_bytes)) {
  }
  _exit(0);
}

void end_child(pid_t pid) {
  ::kill(pid, SIGKILL);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
}

}  // namespace

PingPong ping_pong(PingPongKind kind, std::size_t out_bytes, std::size_t back_bytes, double seconds) {
  PingPong r;
  if (out_bytes == 0 || back_bytes == 0 || out_bytes > 65000 || back_bytes > 65000 || !(seconds > 0.0 && seconds <= 60.0)) {
    r.error = "message sizes must be 1..65000 bytes and the window 0..60 s";
    return r;
  }
  const bool stream = kind == PingPongKind::kTcp;
  std::uint16_t child_port = 0, own_port = 0;
  // TCP: the child's listening socket; UDP: the child's socket and ours, each bound to loopback
  const int child_fd = bound_socket(stream ? SOCK_STREAM : SOCK_DGRAM, child_port, r.error);
  if (child_fd < 0) return r;
  int fd = -1;
  if (stream) {
    if (::listen(child_fd, 1) != 0) {
      r.error = os_error("listen");
      ::close(child_fd);
      return r;
    }
    set_read_timeout(child_fd, kReadTimeoutS);  // bounds the child's accept
    fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  } else {
    fd = bound_socket(SOCK_DGRAM, own_port, r.error);
    const sockaddr_in ours = loopback(own_port);
    if (fd >= 0 && ::connect(child_fd, reinterpret_cast<const sockaddr*>(&ours), sizeof ours) != 0) {
      r.error = os_error("connect (UDP)");
      ::close(fd);
      fd = -1;
    }
  }
  if (fd < 0) {
    if (r.error.empty()) r.error = os_error("socket");
    ::close(child_fd);
    return r;
  }
  const pid_t pid = ::fork();
  if (pid < 0) {
    r.error = os_error("fork");
    ::close(fd);
    ::close(child_fd);
    return r;
  }
  if (pid == 0) {
    ::close(fd);
    echo_child(child_fd, stream, out_bytes, back_bytes);
  }
  ::close(child_fd);
  const sockaddr_in theirs = loopback(child_port);
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&theirs), sizeof theirs) != 0) {
    r.error = os_error("connect");
  } else {
    if (stream) set_nodelay(fd);
    set_read_timeout(fd, kReadTimeoutS);
    std::vector<char> out(out_bytes, 'a'), back(back_bytes);
    const auto start = Clock::now() + std::chrono::milliseconds(200);  // warm-up: caches, the scheduler
    const auto end = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
    Clock::time_point measured_from{};
    for (;;) {
      if (!write_all(fd, out.data(), out_bytes) || !read_all(fd, back.data(), back_bytes, stream)) {
        r.error = errno == EAGAIN || errno == EWOULDBLOCK ? "no answer within " + std::to_string(kReadTimeoutS) + " s"
                                                          : os_error("round trip");
        break;
      }
      const auto now = Clock::now();
      if (now < start) continue;
      if (measured_from == Clock::time_point{}) {  // the window opens at the end of a round trip
        measured_from = now;
        continue;
      }
      ++r.round_trips;  // each counted one ended inside (measured_from, now]
      if (now >= end) {
        r.seconds = std::chrono::duration<double>(now - measured_from).count();
        break;
      }
    }
  }
  ::close(fd);
  end_child(pid);
  if (!r.error.empty()) r.round_trips = 0;
  return r;
}

}  // namespace ehpt::bench
